//! Display passes shared by both methods: tonemapping of the linear HDR image into an
//! sRGB target, and the lights-per-tile heat map blended over it. Bind groups are made
//! once per target set, never per frame. Depends on wgpu and [`crate::frame`].

use crate::error::GpuError;
use crate::frame::FrameBinding;
use crate::timer::GpuTimer;
use crate::util::{pipeline_layout, shader_module, storage_entry, texture_entry};

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
    groups: [&wgpu::BindGroup; 2],
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
        pass.set_bind_group(0, groups[0], &[]);
        pass.set_bind_group(1, groups[1], &[]);
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

/// Tonemapping: HDR texture -> sRGB display target.
pub struct TonemapPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl TonemapPass {
    /// Builds the pipeline.
    pub fn new(device: &wgpu::Device, frame: &FrameBinding) -> Result<Self, GpuError> {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tonemap.layout"),
            entries: &[texture_entry(
                0,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::TextureSampleType::Float { filterable: false },
            )],
        });
        let module = shader_module(device, "tonemap.wgsl", &[])?;
        let pl = pipeline_layout(device, "tonemap.pipeline_layout", &[&frame.layout, &layout]);
        Ok(Self { pipeline: fullscreen_pipeline(device, "tonemap", &module, "fs_tonemap", &pl, None), layout })
    }

    /// The bind group reading `hdr` (make once per target).
    pub fn bind(&self, device: &wgpu::Device, hdr: &wgpu::TextureView) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap.bind_group"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) }],
        })
    }

    /// Writes the tonemapped image to `target`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        frame: &FrameBinding,
        input: &wgpu::BindGroup,
        target: &wgpu::TextureView,
    ) {
        fullscreen_pass(
            encoder,
            timer,
            "tonemap",
            target,
            wgpu::LoadOp::Clear(wgpu::Color::BLACK),
            &self.pipeline,
            [&frame.bind_group, input],
        );
    }
}

/// Heat map of lights per tile, blended over the display target.
pub struct HeatmapPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl HeatmapPass {
    /// Builds the pipeline.
    pub fn new(device: &wgpu::Device, frame: &FrameBinding) -> Result<Self, GpuError> {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("heatmap.layout"),
            entries: &[storage_entry(0, wgpu::ShaderStages::FRAGMENT, true)],
        });
        let module = shader_module(device, "heatmap.wgsl", &[])?;
        let pl = pipeline_layout(device, "heatmap.pipeline_layout", &[&frame.layout, &layout]);
        Ok(Self {
            pipeline: fullscreen_pipeline(
                device,
                "heatmap",
                &module,
                "fs_heatmap",
                &pl,
                Some(wgpu::BlendState::ALPHA_BLENDING),
            ),
            layout,
        })
    }

    /// The bind group reading the light grid's lists (`LightGrid::grid`, which never
    /// changes size; make once per culling setup).
    pub fn bind(&self, device: &wgpu::Device, light_grid: &wgpu::Buffer) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("heatmap.bind_group"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: light_grid.as_entire_binding() }],
        })
    }

    /// Blends the heat map over `target`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        frame: &FrameBinding,
        input: &wgpu::BindGroup,
        target: &wgpu::TextureView,
    ) {
        fullscreen_pass(
            encoder,
            timer,
            "heatmap",
            target,
            wgpu::LoadOp::Load,
            &self.pipeline,
            [&frame.bind_group, input],
        );
    }
}
