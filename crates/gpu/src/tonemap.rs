//! Display passes shared by both methods: tonemapping of the linear HDR image into an
//! sRGB target (with a fixed exposure, or one computed from the frame's own image:
//! [`AutoExposure`]), and the lights-per-tile heat map blended over it (of the opaque light grid,
//! of the blended geometry's own, or of the VPLs'). Neither reads a view: the tonemap has its own
//! parameters, the heat map a light grid. Bind groups are made
//! once per target set, never per frame. Depends on wgpu and the rest of this crate's
//! utilities.

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use bytemuck::{Pod, Zeroable};

use crate::bindings::{create_layout, Binding, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::timer::GpuTimer;
use crate::util::{buffer_init, buffer_zeroed, compute_pipeline_at, keyed_module, pipeline_layout, shader_module};
use crate::variants::{ShaderKey, TonemapKey};

/// Format of the HDR lighting target.
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the display image (PNG output, swapchain-like).
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    fs: &str,
    layout: &wgpu::PipelineLayout,
    blend: Option<wgpu::BlendState>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format: LDR_FORMAT, blend, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

fn fullscreen_pass(
    encoder: &mut wgpu::CommandEncoder,
    timer: &GpuTimer,
    label: &str,
    target: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
    pipeline: &wgpu::RenderPipeline,
    group: &wgpu::BindGroup,
) {
    let t = timer.begin(label, encoder);
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: t.render_writes(),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
    timer.end(encoder, t);
}

/// The heat map's palette, the CPU twin of `palette` in `shaders/heatmap.wgsl` (tests
/// compare the two): blue -> cyan -> green -> yellow -> red for `t` in [0, 1], linear RGB.
pub fn heatmap_palette(t: f32) -> [f32; 3] {
    let x = t.clamp(0.0, 1.0) * 4.0;
    let sat = |v: f32| v.clamp(0.0, 1.0);
    let g = if x > 2.0 { sat(4.0 - x) } else { sat(x) };
    [sat(x - 2.0), g, sat(2.0 - x)]
}

/// Where a tile with `count` lights falls on the palette, as the shader computes it:
/// `log2(count) / log2(max(capacity, 2))`.
pub fn heatmap_t(count: u32, capacity: u32) -> f32 {
    (count.max(1) as f32).log2() / (capacity.max(2) as f32).log2()
}

/// Colour of tiles whose list overflowed.
pub const HEATMAP_OVERFLOW: [f32; 3] = [1.0, 0.0, 1.0];
/// Opacity of the heat map over the image, for counted and overflowing tiles.
pub const HEATMAP_ALPHA: (f32, f32) = (0.6, 0.75);

/// The tonemap pass's own parameters.
///
/// Keep in sync with `shaders/tonemap.wgsl` (`Tonemap`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TonemapUniforms {
    /// Exposure multiplier before tonemapping.
    pub exposure: f32,
    /// Padding to 16 bytes.
    pub _pad0: f32,
    /// Padding.
    pub _pad1: f32,
    /// Padding.
    pub _pad2: f32,
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(TonemapUniforms, "Tonemap", "tonemap.wgsl", [exposure, _pad0, _pad1, _pad2])]
}

/// The bindings of [`TonemapPass`] (`shaders/tonemap.wgsl`): group 0, the HDR image (0)
/// and the parameters (1), with `AUTO_EXPOSURE` the computed exposure (2).
pub const TONEMAP_BINDINGS: PassBindings = PassBindings {
    entry: "tonemap.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, wgpu::ShaderStages::FRAGMENT, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::uniform(1, wgpu::ShaderStages::FRAGMENT),
            Binding::storage(2, wgpu::ShaderStages::FRAGMENT).when(crate::bindings::Cond::Defined("AUTO_EXPOSURE")),
        ],
    )],
};

/// The bindings of [`AutoExposure`] (`shaders/exposure.wgsl`): the HDR image (0), the
/// per-workgroup sums (1) and the exposure (2).
pub const EXPOSURE_BINDINGS: PassBindings = PassBindings {
    entry: "exposure.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::storage_rw(1, wgpu::ShaderStages::COMPUTE),
            Binding::storage_rw(2, wgpu::ShaderStages::COMPUTE),
        ],
    )],
};

/// Automatic exposure (`shaders/exposure.wgsl`; CPU twin
/// `tiledlight_cull::exposure::auto_exposure`): two compute dispatches before the tonemap,
/// a workgroup per 16 x 16 pixels summing log2 luminance, then one workgroup turning the
/// sums into the exposure the tonemap reads. Exists only when the exposure is automatic.
pub struct AutoExposure {
    reduce: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    groups: (u32, u32),
    /// The exposure (one f32) the tonemap reads; COPY_SRC for [`TonemapPass::read_exposure`].
    exposure: wgpu::Buffer,
}

impl AutoExposure {
    fn new(device: &wgpu::Device, hdr: &wgpu::TextureView, size: (u32, u32)) -> Result<Self, GpuError> {
        use tiledlight_cull::exposure::{AUTO_EXPOSURE_KEY, MAX_EXPOSURE, MIN_LUMINANCE};
        let groups = (size.0.div_ceil(16), size.1.div_ceil(16));
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let partials = buffer_zeroed(device, "exposure.partials", u64::from(groups.0 * groups.1) * 8, usage);
        let exposure = buffer_zeroed(device, "exposure.value", 4, usage);
        let layout = create_layout(device, "exposure.layout", EXPOSURE_BINDINGS.group(0), &[]);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("exposure.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) },
                wgpu::BindGroupEntry { binding: 1, resource: partials.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: exposure.as_entire_binding() },
            ],
        });
        let module = shader_module(device, EXPOSURE_BINDINGS.entry, &[])?;
        let constants = [
            ("KEY", f64::from(AUTO_EXPOSURE_KEY)),
            ("MIN_LUMINANCE", f64::from(MIN_LUMINANCE)),
            ("MAX_EXPOSURE", f64::from(MAX_EXPOSURE)),
        ];
        let pipeline =
            |label: &str, entry: &str| compute_pipeline_at(device, (label, entry), &[&layout], &module, &constants);
        Ok(Self {
            reduce: pipeline("exposure.reduce", "reduce"),
            finish: pipeline("exposure.finish", "finish"),
            group,
            groups,
            exposure,
        })
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer) {
        let t = timer.begin("exposure", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("exposure"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_bind_group(0, &self.group, &[]);
            pass.set_pipeline(&self.reduce);
            pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
            pass.set_pipeline(&self.finish);
            pass.dispatch_workgroups(1, 1, 1);
        }
        timer.end(encoder, t);
    }
}

/// The bindings of [`HeatmapPass`] (`shaders/heatmap.wgsl`): group 0, the light grid (0).
pub const HEATMAP_BINDINGS: PassBindings = PassBindings {
    entry: "heatmap.wgsl",
    source: file!(),
    groups: &[PassGroup::new(0, &[Binding::storage(0, wgpu::ShaderStages::FRAGMENT)])],
};

/// Tonemapping: HDR texture -> sRGB display target, with its exposure in its own uniform
/// (changing it rebuilds nothing: [`TonemapPass::set_exposure`]).
pub struct TonemapPass {
    pipeline: wgpu::RenderPipeline,
    params: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// The automatic exposure, when the exposure is not fixed.
    auto: Option<AutoExposure>,
}

impl TonemapPass {
    /// Builds the pipeline and the bind group reading `hdr` (`size` pixels), with the fixed
    /// `exposure`, or with `auto` the exposure computed from each frame's image (`exposure`
    /// is then only checked and kept).
    pub fn new(
        device: &wgpu::Device,
        hdr: &wgpu::TextureView,
        size: (u32, u32),
        (exposure, auto): (f32, bool),
    ) -> Result<Self, GpuError> {
        check_exposure(exposure)?;
        let auto = auto.then(|| AutoExposure::new(device, hdr, size)).transpose()?;
        let key = TonemapKey { auto_exposure: auto.is_some() };
        let layout = create_layout(device, "tonemap.layout", TONEMAP_BINDINGS.group(0), &key.defines());
        let u = TonemapUniforms { exposure, ..Default::default() };
        let params = buffer_init(
            device,
            "tonemap.params",
            bytemuck::bytes_of(&u),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) },
                wgpu::BindGroupEntry { binding: 1, resource: params.as_entire_binding() },
            ]
            .into_iter()
            .chain(auto.as_ref().map(|a| wgpu::BindGroupEntry { binding: 2, resource: a.exposure.as_entire_binding() }))
            .collect::<Vec<_>>(),
        });
        let module = keyed_module(device, &key)?;
        let pl = pipeline_layout(device, "tonemap.pipeline_layout", &[&layout]);
        Ok(Self {
            pipeline: fullscreen_pipeline(device, "tonemap", &module, "fs_tonemap", &pl, None),
            params,
            bind_group,
            auto,
        })
    }

    /// Whether the exposure is computed from each frame's image.
    pub fn is_auto(&self) -> bool {
        self.auto.is_some()
    }

    /// The exposure the last finished frame used when it is automatic (a read-back that
    /// waits for the GPU: for reports and tests, not per frame); None when fixed.
    pub fn read_exposure(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<f32>, GpuError> {
        let Some(a) = &self.auto else { return Ok(None) };
        let v: Vec<f32> = crate::readback::read_buffer_range(device, queue, &a.exposure, 0, 4)?;
        Ok(v.first().copied())
    }

    /// Sets the exposure of the next frames (a positive finite number).
    pub fn set_exposure(&self, queue: &wgpu::Queue, exposure: f32) -> Result<(), GpuError> {
        check_exposure(exposure)?;
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&TonemapUniforms { exposure, ..Default::default() }));
        Ok(())
    }

    /// Writes the tonemapped image to `target` (after computing the exposure, when it is
    /// automatic).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, target: &wgpu::TextureView) {
        if let Some(a) = &self.auto {
            a.record(encoder, timer);
        }
        fullscreen_pass(
            encoder,
            timer,
            "tonemap",
            target,
            wgpu::LoadOp::Clear(wgpu::Color::BLACK),
            &self.pipeline,
            &self.bind_group,
        );
    }
}

fn check_exposure(exposure: f32) -> Result<(), GpuError> {
    if exposure.is_finite() && exposure > 0.0 {
        Ok(())
    } else {
        Err(GpuError::Config(format!("exposure {exposure} must be a positive finite number")))
    }
}

/// Which light grid the heat map shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum HeatmapOf {
    /// The opaque geometry's grid (the method's culling; the default).
    #[default]
    Opaque,
    /// The alpha-blended geometry's own grid (`blended.light_grid`): tiles without blended
    /// samples have an empty list, so they keep the image.
    Blended,
    /// The virtual point lights' own grid (tiledlight-vpl, `--vpl`): VPLs per tile; tiles
    /// no VPL reaches keep the image.
    Vpl,
}

impl HeatmapOf {
    /// Every grid, in the order the command line and the viewer offer them.
    pub const ALL: [HeatmapOf; 3] = [HeatmapOf::Opaque, HeatmapOf::Blended, HeatmapOf::Vpl];

    /// "opaque", "blended" or "vpl", as the command line and the viewer name it.
    pub fn name(self) -> &'static str {
        match self {
            HeatmapOf::Opaque => "opaque",
            HeatmapOf::Blended => "blended",
            HeatmapOf::Vpl => "vpl",
        }
    }

    fn index(self) -> u8 {
        match self {
            HeatmapOf::Opaque => 0,
            HeatmapOf::Blended => 1,
            HeatmapOf::Vpl => 2,
        }
    }
}

/// Heat map of lights per tile, blended over the display target. It reads only a light
/// grid (whose header says the tiling), so it can be switched on and off, and between the
/// opaque, the blended and the VPL grid, between frames without rebuilding anything
/// ([`HeatmapPass::set_enabled`], [`HeatmapPass::set_of`]). The blended grid's bind group
/// exists only when the frame has blended geometry, the VPL grid's only with VPLs; every
/// grid shares the pipeline (the same layout and shader).
pub struct HeatmapPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    blended_group: Option<wgpu::BindGroup>,
    vpl_group: Option<wgpu::BindGroup>,
    enabled: AtomicBool,
    /// The grid shown ([`HeatmapOf::index`]; only ever one whose group exists).
    shown: AtomicU8,
}

/// The light grids a heat map can show: the opaque geometry's, and the blended geometry's
/// and the VPLs' when the frame has them (`LightGrid::grid`, which never changes size).
#[derive(Clone, Copy)]
pub struct HeatmapGrids<'a> {
    /// The opaque geometry's grid.
    pub opaque: &'a wgpu::Buffer,
    /// The blended geometry's own grid.
    pub blended: Option<&'a wgpu::Buffer>,
    /// The VPLs' own grid.
    pub vpl: Option<&'a wgpu::Buffer>,
}

impl HeatmapPass {
    /// Builds the pipeline and the bind groups reading the light grids' lists. Drawn when
    /// `enabled`, showing the opaque grid.
    pub fn new(device: &wgpu::Device, grids: HeatmapGrids<'_>, enabled: bool) -> Result<Self, GpuError> {
        let layout = create_layout(device, "heatmap.layout", HEATMAP_BINDINGS.group(0), &[]);
        let group = |label: &str, grid: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: grid.as_entire_binding() }],
            })
        };
        let bind_group = group("heatmap.bind_group", grids.opaque);
        let blended_group = grids.blended.map(|g| group("heatmap.blended.bind_group", g));
        let vpl_group = grids.vpl.map(|g| group("heatmap.vpl.bind_group", g));
        let module = shader_module(device, HEATMAP_BINDINGS.entry, &[])?;
        let pl = pipeline_layout(device, "heatmap.pipeline_layout", &[&layout]);
        let pipeline =
            fullscreen_pipeline(device, "heatmap", &module, "fs_heatmap", &pl, Some(wgpu::BlendState::ALPHA_BLENDING));
        Ok(Self {
            pipeline,
            bind_group,
            blended_group,
            vpl_group,
            enabled: AtomicBool::new(enabled),
            shown: AtomicU8::new(HeatmapOf::Opaque.index()),
        })
    }

    /// Draws the heat map in the next frames, or not.
    pub fn set_enabled(&self, on: bool) {
        self.enabled.store(on, Ordering::Relaxed);
    }

    /// Whether it is drawn.
    pub fn enabled(&self) -> bool {
        self.enabled.load(Ordering::Relaxed)
    }

    /// Shows grid `of` in the next frames. The blended grid is an error when the frame has
    /// no blended geometry, the VPL grid when it has no VPLs (there is no such grid), and
    /// the grid shown stays as it was.
    pub fn set_of(&self, of: HeatmapOf) -> Result<(), GpuError> {
        if !self.has(of) {
            return Err(GpuError::Config(match of {
                HeatmapOf::Vpl => "the heat map of the VPL lists needs VPLs culled into lists of their own: \
                                   VPLs are off (--vpl), or the method has no tiles"
                    .into(),
                _ => "the heat map of the blended lists needs blended lists of their own: this scene has no \
                      alpha-blended geometry, or frustum clusters (--grid clustered without \
                      --cluster-geometry-only) serve it, and the plain heat map shows those clusters"
                    .into(),
            }));
        }
        self.shown.store(of.index(), Ordering::Relaxed);
        Ok(())
    }

    /// The grid shown.
    pub fn of(&self) -> HeatmapOf {
        let i = self.shown.load(Ordering::Relaxed);
        HeatmapOf::ALL.into_iter().find(|o| o.index() == i).unwrap_or_default()
    }

    /// Whether grid `of` can be shown (the frame has it).
    pub fn has(&self, of: HeatmapOf) -> bool {
        self.group(of).is_some()
    }

    /// Whether the blended grid can be shown (the frame has blended geometry).
    pub fn has_blended(&self) -> bool {
        self.has(HeatmapOf::Blended)
    }

    fn group(&self, of: HeatmapOf) -> Option<&wgpu::BindGroup> {
        match of {
            HeatmapOf::Opaque => Some(&self.bind_group),
            HeatmapOf::Blended => self.blended_group.as_ref(),
            HeatmapOf::Vpl => self.vpl_group.as_ref(),
        }
    }

    /// Blends the heat map of the chosen grid over `target` (nothing when disabled).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, target: &wgpu::TextureView) {
        if !self.enabled() {
            return;
        }
        let group = self.group(self.of()).unwrap_or(&self.bind_group);
        fullscreen_pass(encoder, timer, "heatmap", target, wgpu::LoadOp::Load, &self.pipeline, group);
    }
}
