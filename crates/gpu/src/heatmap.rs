//! The lights-per-tile heat map, blended over the display image after the tonemap: of the
//! opaque light grid, of the blended geometry's own, or of the VPLs'. It reads only a
//! light grid (whose header says the tiling), so it switches between grids, on and off,
//! without rebuilding anything. Its palette has a CPU twin here ([`heatmap_palette`]).
//! Depends on wgpu, [`crate::tonemap`] (the full-screen helpers) and this crate's utilities.

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use crate::bindings::{create_layout, Binding, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::timer::GpuTimer;
use crate::tonemap::{fullscreen_pass, fullscreen_pipeline};
use crate::util::{pipeline_layout, shader_module};

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

/// The bindings of [`HeatmapPass`] (`shaders/heatmap.wgsl`): group 0, the light grid (0).
pub const HEATMAP_BINDINGS: PassBindings = PassBindings {
    entry: "heatmap.wgsl",
    source: file!(),
    groups: &[PassGroup::new(0, &[Binding::storage(0, wgpu::ShaderStages::FRAGMENT)])],
};

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
        fullscreen_pass(encoder, Some(timer), "heatmap", target, wgpu::LoadOp::Load, &self.pipeline, group);
    }
}
