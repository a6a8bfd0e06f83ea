//! Presenting a lit image on a window surface (the viewer's last pass): the renderer's
//! tonemapped target is copied into a sampled texture (the renderers' `ldr` target is a
//! render attachment and copy source only) and drawn over the surface with
//! `shaders/viewer_blit.wgsl`, whatever the surface's format. The pipeline is built once per
//! surface format, the texture and bind group once per renderer (screen size), never per
//! frame. Here and not in the app so that an engine's own window can present a frame the
//! same way, and `cargo xtask validate-shaders` checks [`BLIT_BINDINGS`] like every pass's.
//! Depends on the crate's bindings, tonemap, timer and util modules.

use crate::bindings::{create_layout, Binding, PassBindings, PassGroup};
use crate::timer::GpuTimer;
use crate::tonemap::{full_triangle_pipeline, fullscreen_pass};
use crate::util::{pipeline_layout, shader_module};
use crate::GpuError;

/// The bindings of the blit (`shaders/viewer_blit.wgsl`): group 0, the display image (0)
/// and its sampler (1).
pub const BLIT_BINDINGS: PassBindings = PassBindings {
    entry: "viewer_blit.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, wgpu::ShaderStages::FRAGMENT, wgpu::TextureSampleType::Float { filterable: true }),
            Binding::sampler(1, wgpu::ShaderStages::FRAGMENT, wgpu::SamplerBindingType::Filtering),
        ],
    )],
};

/// The blit pipeline for one surface format.
pub struct Blit {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
}

/// A sampled copy of a renderer's display image, with its bind group.
pub struct DisplayImage {
    texture: wgpu::Texture,
    bind_group: wgpu::BindGroup,
}

impl Blit {
    /// Builds the pipeline writing `format`.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Result<Self, GpuError> {
        let layout = create_layout(device, "viewer.blit.layout", BLIT_BINDINGS.group(0), &[]);
        let module = shader_module(device, BLIT_BINDINGS.entry, &[])?;
        let pl = pipeline_layout(device, "viewer.blit.pipeline_layout", &[&layout]);
        let pipeline =
            full_triangle_pipeline(device, "viewer.blit", (&module, "vs_blit", "fs_blit"), &pl, (format, None));
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("viewer.blit.sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Ok(Self { pipeline, layout, sampler })
    }

    /// The sampled texture a renderer's `ldr` target of `size` is copied into.
    pub fn display_image(&self, device: &wgpu::Device, size: (u32, u32)) -> DisplayImage {
        // The renderer's display image's format (copied as is), sampled through its sRGB
        // view so the filtering and the sRGB swapchain see linear values.
        let texture = crate::tonemap::ldr_texture(
            device,
            "viewer.display",
            size,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        let view = crate::tonemap::ldr_srgb_view(&texture, "viewer.display.view");
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewer.blit.bind_group"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        DisplayImage { texture, bind_group }
    }

    /// Copies `ldr` into `image` and draws it over all of `target`; timed as
    /// `viewer.present` when `timer` is given.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&GpuTimer>,
        ldr: &wgpu::Texture,
        image: &DisplayImage,
        target: &wgpu::TextureView,
    ) {
        if ldr.size() == image.texture.size() {
            encoder.copy_texture_to_texture(ldr.as_image_copy(), image.texture.as_image_copy(), ldr.size());
        }
        let clear = wgpu::LoadOp::Clear(wgpu::Color::BLACK);
        fullscreen_pass(encoder, timer, "viewer.present", target, clear, &self.pipeline, &image.bind_group);
    }
}
