//! The tonemap, the frame's last step in every method: the linear HDR image into the sRGB
//! display image, with a fixed exposure or one computed from the frame's own image
//! ([`crate::exposure::AutoExposure`]), and the full-screen helpers the heat map shares.
//! A compute pass (issue 31): one thread a pixel reads the HDR texel and stores its
//! sRGB-encoded bytes into the `Rgba8Unorm` display image (sRGB formats cannot be storage
//! textures); as a full-screen fragment pass it cost 0.295 ms at 1080p on the H200, whose
//! fragment path is 30-50x slower than its compute.
//! It reads no view: its parameters are its own. Bind groups are made once per target
//! set, never per frame. Depends on wgpu, [`crate::exposure`] and this crate's utilities.

use crate::define::Define;
use crate::handles::{Hdr, Ldr};
use bytemuck::{Pod, Zeroable};

use crate::bindings::{create_layout, Binding, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::exposure::AutoExposure;
use crate::timer::GpuTimer;
use crate::util::{buffer_init, keyed_module, pipeline_layout};
use crate::variants::{ShaderKey, TonemapKey};

/// Format of the HDR lighting target.
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the display image (PNG output): sRGB-encoded bytes in a plain `Rgba8Unorm`
/// texture, so the compute tonemap can store them.
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The format render passes and samplers view the display image as (linear blending and
/// filtering): its sRGB twin ([`ldr_srgb_view`]).
pub const LDR_VIEW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// The display image: an `Rgba8Unorm` texture (storage-capable: the compute tonemap writes
/// its sRGB-encoded bytes) that render passes and samplers see through an
/// `Rgba8UnormSrgb` view ([`LDR_VIEW_FORMAT`]), so blending and sampling
/// stay in linear light.
pub fn ldr_texture(device: &wgpu::Device, label: &str, size: (u32, u32), usage: wgpu::TextureUsages) -> wgpu::Texture {
    crate::util::texture_2d_viewed_as(device, label, size, (LDR_FORMAT, 1), usage, &[LDR_VIEW_FORMAT])
}

/// The `Rgba8UnormSrgb` view of a display image made by [`ldr_texture`].
pub fn ldr_srgb_view(texture: &wgpu::Texture, label: &str) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some(label),
        format: Some(LDR_VIEW_FORMAT),
        // Not as storage: sRGB formats cannot be (the plain view is the tonemap's).
        usage: Some(texture.usage() & (wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING)),
        ..Default::default()
    })
}

/// A full-screen triangle pipeline (`vs_fullscreen`) writing the display image's sRGB view.
pub(crate) fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    fs: &str,
    layout: &wgpu::PipelineLayout,
    blend: Option<wgpu::BlendState>,
) -> wgpu::RenderPipeline {
    full_triangle_pipeline(device, label, (module, "vs_fullscreen", fs), layout, (LDR_VIEW_FORMAT, blend))
}

/// A one-triangle pipeline with vertex entry `vs` and fragment entry `fs` of `module`,
/// writing `format` (with `blend`): the full-screen passes' (heat map, the window blit).
pub(crate) fn full_triangle_pipeline(
    device: &wgpu::Device,
    label: &str,
    (module, vs, fs): (&wgpu::ShaderModule, &str, &str),
    layout: &wgpu::PipelineLayout,
    (format, blend): (wgpu::TextureFormat, Option<wgpu::BlendState>),
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vs),
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
            targets: &[Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Records a full-screen pass into `target`, timed as `label` when `timer` is given.
pub(crate) fn fullscreen_pass(
    encoder: &mut wgpu::CommandEncoder,
    timer: Option<&GpuTimer>,
    label: &str,
    target: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
    pipeline: &wgpu::RenderPipeline,
    group: &wgpu::BindGroup,
) {
    let t = timer.map(|timer| timer.begin(label, encoder));
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
            timestamp_writes: t.as_ref().and_then(|t| t.render_writes()),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
    if let (Some(timer), Some(t)) = (timer, t) {
        timer.end(encoder, t);
    }
}

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

/// The bindings of [`TonemapPass`] (`shaders/tonemap.wgsl`): group 0, the HDR image (0),
/// the parameters (1), the display image it writes (3), with `AUTO_EXPOSURE` the computed
/// exposure (2).
pub const TONEMAP_BINDINGS: PassBindings = PassBindings {
    entry: "tonemap.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::uniform(1, wgpu::ShaderStages::COMPUTE),
            Binding::storage(2, wgpu::ShaderStages::COMPUTE).when(crate::bindings::Cond::Defined(Define::AutoExposure)),
            Binding::storage_texture(3, wgpu::ShaderStages::COMPUTE, LDR_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
        ],
    )],
};

/// The tonemap's workgroup edge (8 x 8 threads, a pixel each).
const TONEMAP_WG: u32 = 8;

/// Tonemapping: HDR texture -> sRGB display target, with its exposure in its own uniform
/// (changing it rebuilds nothing: [`TonemapPass::set_exposure`]).
pub struct TonemapPass {
    pipeline: wgpu::ComputePipeline,
    size: (u32, u32),
    params: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// The automatic exposure, when the exposure is not fixed.
    auto: Option<AutoExposure>,
}

impl TonemapPass {
    /// Builds the pipeline and the bind group reading `hdr` and writing `ldr` (the display
    /// image's `Rgba8Unorm` view; both `size` pixels), with the fixed `exposure`, or with
    /// `auto` the exposure computed from each frame's image (`exposure` is then only checked
    /// and kept).
    pub fn new(
        device: &wgpu::Device,
        (hdr, ldr): (Hdr<'_>, Ldr<'_>),
        size: (u32, u32),
        (exposure, auto): (f32, bool),
    ) -> Result<Self, GpuError> {
        // The tonemap reads the HDR image and writes the display image through its storage view.
        let (hdr, ldr) = (hdr.view, ldr.storage);
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
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(ldr) },
            ]
            .into_iter()
            .chain(auto.as_ref().map(|a| wgpu::BindGroupEntry { binding: 2, resource: a.exposure.as_entire_binding() }))
            .collect::<Vec<_>>(),
        });
        let module = keyed_module(device, &key)?;
        let pl = pipeline_layout(device, "tonemap.pipeline_layout", &[&layout]);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("tonemap"),
            layout: Some(&pl),
            module: &module,
            entry_point: Some("cs_tonemap"),
            compilation_options: Default::default(),
            cache: None,
        });
        Ok(Self { pipeline, size, params, bind_group, auto })
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

    /// Writes the tonemapped image into the display image it was built with (after
    /// computing the exposure, when it is automatic).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer) {
        if let Some(a) = &self.auto {
            a.record(encoder, timer);
        }
        let t = timer.begin("tonemap", encoder);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("tonemap"),
            timestamp_writes: t.compute_writes(),
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.size.0.div_ceil(TONEMAP_WG), self.size.1.div_ceil(TONEMAP_WG), 1);
        drop(pass);
        timer.end(encoder, t);
    }
}

fn check_exposure(exposure: f32) -> Result<(), GpuError> {
    if exposure.is_finite() && exposure > 0.0 {
        Ok(())
    } else {
        Err(GpuError::Config(format!("exposure {exposure} must be a positive finite number")))
    }
}
