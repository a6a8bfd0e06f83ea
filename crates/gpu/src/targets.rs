//! What every renderer draws into and how a frame is driven: the depth / HDR / display
//! targets of one screen size, the [`Renderer`] trait both methods implement, and
//! [`render_once`] for tests and single images. Depends on wgpu and the rest of this crate.

use tiledlight_cull::{Camera, TileGrid};

use crate::context::GpuContext;
use crate::depth_prepass::DEPTH_FORMAT;
use crate::error::GpuError;
use crate::memory::MemoryReport;
use crate::readback::{read_depth, read_hdr, read_texture};
use crate::scene_gpu::SceneGpu;
use crate::timer::GpuTimer;
use crate::tonemap::{HDR_FORMAT, LDR_FORMAT};

/// A labelled single-sampled 2D texture.
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (w, h): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Depth, linear HDR and tonemapped display targets of one screen.
pub struct DisplayTargets {
    /// Reversed-Z depth.
    pub depth: wgpu::Texture,
    /// Linear HDR lighting.
    pub hdr: wgpu::Texture,
    /// Tonemapped sRGB image.
    pub ldr: wgpu::Texture,
    /// View of `depth`.
    pub depth_view: wgpu::TextureView,
    /// View of `hdr`.
    pub hdr_view: wgpu::TextureView,
    /// View of `ldr`.
    pub ldr_view: wgpu::TextureView,
}

impl DisplayTargets {
    /// Targets for `w` x `h`; `hdr_usage` adds how the method writes the HDR image
    /// (render attachment for Forward+, storage for Tiled Deferred's compute shading).
    pub fn new(device: &wgpu::Device, prefix: &str, w: u32, h: u32, hdr_usage: wgpu::TextureUsages) -> Self {
        use wgpu::TextureUsages as U;
        let depth = texture_2d(
            device,
            &format!("{prefix}.depth"),
            (w, h),
            DEPTH_FORMAT,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        let hdr = texture_2d(
            device,
            &format!("{prefix}.hdr"),
            (w, h),
            HDR_FORMAT,
            hdr_usage | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        let ldr = texture_2d(device, &format!("{prefix}.ldr"), (w, h), LDR_FORMAT, U::RENDER_ATTACHMENT | U::COPY_SRC);
        Self {
            depth_view: depth.create_view(&Default::default()),
            hdr_view: hdr.create_view(&Default::default()),
            ldr_view: ldr.create_view(&Default::default()),
            depth,
            hdr,
            ldr,
        }
    }

    /// Bytes of the three targets.
    pub fn bytes(&self) -> u64 {
        let px = self.depth.width() as u64 * self.depth.height() as u64;
        px * (4 + 8 + 4)
    }
}

/// A renderer of either method: built once for a scene, light set, screen and settings.
pub trait Renderer {
    /// Writes the frame's uniforms and records every pass of one frame.
    fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        scene: &SceneGpu,
        camera: &Camera,
    );
    /// The render targets.
    fn targets(&self) -> &DisplayTargets;
    /// The tile grid.
    fn grid(&self) -> TileGrid;
    /// GPU memory allocated for the renderer, its scene and lights, by category.
    fn memory(&self) -> &MemoryReport;
    /// Per-list light counts of the last frame (tiled methods), for statistics and tests.
    fn tile_counts(&self) -> Option<&wgpu::Buffer>;

    /// Reads the depth buffer of the last frame.
    fn read_depth(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        read_depth(&ctx.device, &ctx.queue, &self.targets().depth)
    }
    /// Reads the linear HDR image of the last frame.
    fn read_hdr(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        read_hdr(&ctx.device, &ctx.queue, &self.targets().hdr)
    }
    /// Reads the tonemapped sRGB image (RGBA8) of the last frame.
    fn read_ldr(&self, ctx: &GpuContext) -> Result<Vec<u8>, GpuError> {
        read_texture(&ctx.device, &ctx.queue, &self.targets().ldr, wgpu::TextureAspect::All, 4)
    }
    /// Records, submits and waits for one frame (tests, single renders).
    fn render_once(
        &self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        scene: &SceneGpu,
        camera: &Camera,
    ) -> Result<(), GpuError> {
        ctx.checked("rendering a frame", || {
            let mut encoder =
                ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
            self.record(&ctx.queue, &mut encoder, timer, scene, camera);
            timer.resolve(&mut encoder);
            ctx.queue.submit([encoder.finish()]);
        })?;
        timer.end_frame()?;
        ctx.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
        Ok(())
    }
}
