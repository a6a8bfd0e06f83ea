//! Diagnostics, all in one place, shared by tests, the app and the lab: reading a
//! renderer's outputs back and rendering single frames, for any [`Renderer`] through the
//! [`Diagnostics`] extension trait (`use tiledlight_frame::Diagnostics as _`), and what
//! only a [`FrameRenderer`] can say (VPL counts, MSAA edge pixels, the automatic exposure,
//! light lists). These stall the GPU: never on a per-frame path. The renderers themselves
//! only record frames and name their outputs. Culling statistics over the light grid are
//! `tiledlight_setup::culling_stats`. Depends on [`crate::renderer`] and
//! tiledlight-gpu's readback.

use tiledlight_cull::Camera;
use tiledlight_gpu::culling::GpuTileLists;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::{read_depth, read_hdr, read_texture};
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::renderer::{FrameRenderer, Renderer};

/// Readback and single frames for every renderer.
pub trait Diagnostics: Renderer {
    /// Reads the depth buffer of the last frame: row-major, with MSAA `samples` values per
    /// pixel, pixel-major.
    fn read_depth(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        read_depth(&ctx.device, &ctx.queue, &self.outputs().targets.depth)
    }
    /// Reads the linear HDR image of the last frame.
    fn read_hdr(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        read_hdr(&ctx.device, &ctx.queue, &self.outputs().targets.hdr)
    }
    /// Reads the tonemapped sRGB image (RGBA8) of the last frame.
    fn read_ldr(&self, ctx: &GpuContext) -> Result<Vec<u8>, GpuError> {
        read_texture(&ctx.device, &ctx.queue, &self.outputs().targets.ldr, wgpu::TextureAspect::All, 4)
    }
    /// Records, submits and waits for one frame (tests, single renders). When the frame
    /// dropped lights because the light grid was full, grows the grid and renders it
    /// again (once: the header counts every pair found, so the new size holds them), unless
    /// the budget is fixed or the device cannot bind more; `LightGrid::status` then says
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
            if !self.between_frames(ctx, true)?.grew {
                break;
            }
        }
        Ok(())
    }
}

impl<R: Renderer + ?Sized> Diagnostics for R {}

impl FrameRenderer {
    /// GPU memory allocated for the renderer, its scene and lights, by category.
    pub fn memory(&self) -> &MemoryReport {
        self.outputs().memory
    }
    /// The automatic exposure the last finished frame used (a read-back that waits for the
    /// GPU); None when the exposure is fixed.
    pub fn auto_exposure(&self, ctx: &GpuContext) -> Result<Option<f32>, GpuError> {
        self.shared().tonemap.read_exposure(&ctx.device, &ctx.queue)
    }
    /// With virtual point lights, the last generation's VPLs kept and refused by the cap.
    pub fn vpl_count(&self, ctx: &GpuContext) -> Result<Option<(u32, u32)>, GpuError> {
        match self.vpls() {
            Some(v) => v.path.buffers.read_count(&ctx.device, &ctx.queue).map(|c| Some((c.kept, c.refused))),
            None => Ok(None),
        }
    }
    /// Pixels of the last frame that the edge test sent to per-sample shading, when the
    /// method has such a test (Tiled Deferred with MSAA).
    pub fn edge_pixels(&self, ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        self.method().edge_pixels(ctx)
    }
    /// Screen tiles the last frame listed for its large triangles (the visibility buffer's
    /// compute raster with the large triangles by compute).
    pub fn large_tiles(&self, ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        self.method().large_tiles(ctx)
    }
    /// An error naming the problem when the last frame traced rays (the traced reference,
    /// the stochastic method) and the driver cut some invocations' loops short
    /// (`tiledlight_visibility::shading::TracedStats::cut`: llvmpipe's loop limit); Ok
    /// otherwise, and for methods that trace nothing.
    pub fn check_traced_complete(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        match self.passes::<crate::VisibilityFrame>() {
            Some(v) => v.shading().check_traced_complete(ctx),
            None => Ok(()),
        }
    }
    /// The opaque light grid's lists the last frame was shaded with (tiled methods).
    pub fn read_lists(&self, ctx: &GpuContext) -> Result<GpuTileLists, GpuError> {
        match self.outputs().light_grid {
            Some(g) => g.read_lists(&ctx.device, &ctx.queue),
            None => Err(GpuError::Config(format!("{:?} has no light grid", self.settings().method))),
        }
    }
}
