//! Diagnostics shared by tests, the app and the lab: reading a renderer's outputs back
//! and rendering single frames, for any [`Renderer`] through the [`Diagnostics`] extension
//! trait (`use tiledlight_gpu::diagnostics::Diagnostics as _`). These stall the GPU: never
//! on a per-frame path. The renderers themselves only record frames and name their outputs.
//! Culling statistics over the light grid are `tiledlight_setup::culling_stats`. Depends on
//! [`crate::targets`] and [`crate::readback`].

use tiledlight_cull::Camera;

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::readback::{read_depth, read_hdr, read_texture};
use crate::scene_gpu::SceneGpu;
use crate::targets::Renderer;
use crate::timer::GpuTimer;

/// Readback and single frames for every renderer.
pub trait Diagnostics: Renderer {
    /// Reads the depth buffer of the last frame: row-major, with MSAA `samples` values per
    /// pixel, pixel-major.
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
    /// Records, submits and waits for one frame (tests, single renders). When the frame
    /// dropped lights because the light grid was full, grows the grid and renders it
    /// again (once: the header counts every pair found, so the new size holds them), unless
    /// the budget is fixed or the device cannot bind more; [`crate::light_grid::LightGrid::status`] then says
    /// what was dropped.
    fn render_once(
        &mut self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        scene: &SceneGpu,
        camera: &Camera,
    ) -> Result<(), GpuError> {
        for _ in 0..2 {
            ctx.checked("rendering a frame", || {
                let mut encoder =
                    ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
                self.record(&ctx.queue, &mut encoder, timer, scene, camera);
                timer.resolve(&mut encoder);
                ctx.queue.submit([encoder.finish()]);
            })?;
            timer.end_frame()?;
            ctx.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
            let mut grew = false;
            if let Some(grid) = self.light_grid() {
                let status = grid.status(&ctx.device, &ctx.queue)?;
                if let (Some(capacity), false) = (grid.growth(status.needed()), status.complete()) {
                    self.grow_light_grid(ctx, capacity);
                    grew = true;
                }
            }
            if let Some(b) = self.blended_mut() {
                grew |= b.grow_if_dropped(&ctx.device, &ctx.queue, true)?;
            }
            if !grew {
                break;
            }
        }
        Ok(())
    }
}

impl<R: Renderer + ?Sized> Diagnostics for R {}
