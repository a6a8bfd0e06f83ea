//! What every renderer draws into and how a frame is driven: the depth / HDR / display
//! targets of one screen size and the [`Renderer`] trait both methods implement (recording
//! and named outputs; readback and single frames are [`crate::diagnostics`]). Depends on
//! wgpu and the rest of this crate.

use tiledlight_cull::{Camera, TileGrid};

use crate::blended::BlendedPath;
use crate::context::GpuContext;
use crate::depth_prepass::DEPTH_FORMAT;
use crate::error::GpuError;
use crate::light_grid::{GridStatus, LightGrid};
use crate::memory::MemoryReport;
use crate::scene_gpu::SceneGpu;
use crate::shadow_atlas::ShadowAtlas;
use crate::timer::GpuTimer;
use crate::tonemap::{HeatmapPass, HDR_FORMAT, LDR_FORMAT};
use tiledlight_cull::light::PackedLights;

pub use crate::util::{texture_2d, texture_2d_msaa};

/// Fails with a message naming the format and the adapter's sample counts when `samples`
/// is not 1, 2, 4 or 8 or when the adapter cannot multisample `formats` that many times
/// (WebGPU guarantees only 1 and 4; 2 and 8 need adapter-specific format features).
pub fn check_msaa(ctx: &GpuContext, samples: u32, formats: &[wgpu::TextureFormat]) -> Result<(), GpuError> {
    if !matches!(samples, 1 | 2 | 4 | 8) {
        return Err(GpuError::Config(format!("MSAA {samples}x: the sample count must be 1, 2, 4 or 8")));
    }
    if samples == 1 {
        return Ok(());
    }
    let specific = ctx.device.features().contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);
    for &format in formats {
        let ok = if specific {
            ctx.adapter.get_texture_format_features(format).flags.sample_count_supported(samples)
        } else {
            samples == 4
        };
        if !ok {
            let counts: Vec<String> = [2, 4, 8]
                .into_iter()
                .filter(|&n| {
                    if specific {
                        ctx.adapter.get_texture_format_features(format).flags.sample_count_supported(n)
                    } else {
                        n == 4
                    }
                })
                .map(|n| format!("{n}x"))
                .collect();
            return Err(GpuError::Config(format!(
                "MSAA {samples}x is not supported by {} for {format:?} render targets (it supports: 1x{}{})",
                ctx.info.name,
                if counts.is_empty() { "" } else { ", " },
                counts.join(", ")
            )));
        }
    }
    Ok(())
}

/// Depth, linear HDR and tonemapped display targets of one screen.
pub struct DisplayTargets {
    /// Reversed-Z depth, with `samples` samples per pixel.
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
    /// MSAA samples per pixel of `depth` (the HDR and display images are resolved).
    pub samples: u32,
}

impl DisplayTargets {
    /// Targets for `w` x `h` with a `samples`-sample depth buffer; `hdr_usage` adds how the
    /// method writes the HDR image (render attachment for Forward+, storage for Tiled
    /// Deferred's compute shading).
    pub fn new(
        device: &wgpu::Device,
        prefix: &str,
        (w, h): (u32, u32),
        samples: u32,
        hdr_usage: wgpu::TextureUsages,
    ) -> Self {
        use wgpu::TextureUsages as U;
        // A multisampled texture cannot be copied: read_depth uses a kernel for it.
        let copy = if samples == 1 { U::COPY_SRC } else { U::empty() };
        let depth = texture_2d_msaa(
            device,
            &format!("{prefix}.depth"),
            (w, h),
            DEPTH_FORMAT,
            samples,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | copy,
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
            depth_view: depth.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{prefix}.depth.view")),
                ..Default::default()
            }),
            hdr_view: hdr.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{prefix}.hdr.view")),
                ..Default::default()
            }),
            ldr_view: ldr.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{prefix}.ldr.view")),
                ..Default::default()
            }),
            depth,
            hdr,
            ldr,
            samples,
        }
    }

    /// Bytes of the three targets (the depth buffer has `samples` values a pixel).
    pub fn bytes(&self) -> u64 {
        let px = self.depth.width() as u64 * self.depth.height() as u64;
        px * (4 * self.samples as u64 + 8 + 4)
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
    /// Sets the exposure of the next frames (the tonemap's own uniform: nothing is rebuilt).
    fn set_exposure(&self, queue: &wgpu::Queue, exposure: f32) -> Result<(), GpuError>;
    /// The automatic exposure the last finished frame used (a read-back that waits for the
    /// GPU); None when the exposure is fixed.
    fn auto_exposure(&self, ctx: &GpuContext) -> Result<Option<f32>, GpuError>;
    /// The heat map pass (tiled methods): switch it with `HeatmapPass::set_enabled`
    /// between frames, nothing is rebuilt.
    fn heatmap(&self) -> Option<&HeatmapPass> {
        None
    }
    /// The render targets.
    fn targets(&self) -> &DisplayTargets;
    /// The tile grid.
    fn grid(&self) -> TileGrid;
    /// GPU memory allocated for the renderer, its scene and lights, by category.
    fn memory(&self) -> &MemoryReport;
    /// The light grid the last frame was shaded with (tiled methods): lists, counts and
    /// its header, for statistics, the heat map and tests.
    fn light_grid(&self) -> Option<&LightGrid>;
    /// The virtual point lights' own light grid (tiled methods with VPLs): one list a tile,
    /// a fixed budget that never grows, so a frame can drop VPLs from lists; its header is
    /// copied after each culling like the light grid's ([`LightGrid::poll_status`]).
    fn vpl_light_grid(&self) -> Option<&LightGrid> {
        None
    }
    /// Grows the light grid's index buffer to `capacity` indices and binds it again
    /// wherever it is read (methods without a grid ignore it).
    fn grow_light_grid(&mut self, _ctx: &GpuContext, _capacity: u32) {}

    /// Call between frames: takes the light-grid header of the latest finished frame when
    /// its copy has arrived (never waits) and, when that frame dropped lights because the
    /// grid was full, grows the grid for the next frame (the blended geometry's grid too).
    /// Returns the opaque grid's header, if any.
    fn prepare(&mut self, ctx: &GpuContext) -> Option<GridStatus> {
        if let Some(b) = self.blended_mut() {
            // Never waits, so it cannot fail on a readback.
            let _ = b.grow_if_dropped(&ctx.device, &ctx.queue, false);
        }
        let status = self.light_grid()?.poll_status()?;
        if let Some(capacity) = self.light_grid().and_then(|g| g.growth(status.needed())) {
            self.grow_light_grid(ctx, capacity);
        }
        Some(status)
    }
    /// Pixels of the last frame that the edge test sent to per-sample shading, when the
    /// method has such a test (Tiled Deferred with MSAA).
    fn edge_pixels(&self, _ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        Ok(None)
    }
    /// The shadow atlas, when some light casts a shadow.
    fn shadow_atlas(&self) -> Option<&ShadowAtlas> {
        None
    }
    /// With virtual point lights (tiledlight-vpl), the last generation's VPLs kept and
    /// refused by the cap, read back (stalls the GPU: reports and tests, never a frame).
    fn vpl_count(&self, _ctx: &GpuContext) -> Result<Option<(u32, u32)>, GpuError> {
        Ok(None)
    }
    /// The alpha-blended geometry's passes, when the scene has blended materials (reports
    /// read its instance count, light grid and memory through a `dyn Renderer`).
    fn blended(&self) -> Option<&BlendedPath> {
        None
    }
    /// [`Self::blended`], to grow its light grid.
    fn blended_mut(&mut self) -> Option<&mut BlendedPath> {
        None
    }
    /// Call after the lights moved on the GPU (their buffers rewritten), with the lights as
    /// now uploaded: the next frame redraws the shadow faces of the casters that moved.
    fn lights_moved(&self, _queue: &wgpu::Queue, _lights: &PackedLights) -> Result<(), GpuError> {
        Ok(())
    }
}
