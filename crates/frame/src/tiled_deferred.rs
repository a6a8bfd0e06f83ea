//! The frame of Tiled Deferred: its middle steps, between the shared ones
//! ([`crate::shared`]), with the handles each reads and writes.
//!
//! ```text
//! GBuffer        scene                       -> Depth, G-buffer (surface, [extra], [emission])
//! [VplCull]      Depth, VPLs                 -> VPL Lists (shared step, with VPLs)
//! DeferredShade  Depth, G-buffer, lights,    -> Lists, Hdr (one compute pass culls each tile
//!                VPL Lists, shadow atlas               and shades it; with light-centric
//!                                                      assignment the assignment's passes
//!                                                      write Lists first, then it only shades)
//! [Resolve]      per-sample shading          -> Hdr (MSAA only: edge pixels averaged)
//! ```
//!
//! Depends on tiledlight-gpu and tiledlight-deferred (G-buffer and shading passes).

use std::any::Any;

use crate::methods::Method;
use crate::plan::Step;
use tiledlight_deferred::gbuffer::{emission_format, GBuffer, GBufferPass, EXTRA_FORMAT, SURFACE_FORMAT};
use tiledlight_deferred::shading::DeferredShading;
use tiledlight_gpu::depth_prepass::DEPTH_FORMAT;
use tiledlight_gpu::edge_samples::EdgeTest;
use tiledlight_gpu::features::Features;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::handles::Rec;
use crate::method::{tiled_steps, MethodFrame, Registration};
use crate::settings::FrameSettings;
use crate::shared::{SharedSteps, TargetNeeds};
use tiledlight_gpu::handles::{Depth, Lists};
use tiledlight_gpu::targets::target_handles;

/// The display targets Tiled Deferred needs: the G-buffer's formats multisampled, the HDR
/// image written by compute (and, with blended geometry, composited onto by a render
/// pass: then the transparent layer is a multisampled HDR target too).
pub fn targets(features: &Features) -> TargetNeeds {
    let mut msaa_formats = vec![DEPTH_FORMAT, SURFACE_FORMAT];
    if features.extra_targets > 0 {
        msaa_formats.push(EXTRA_FORMAT);
    }
    let mut hdr_usage = wgpu::TextureUsages::STORAGE_BINDING;
    if features.blended() {
        msaa_formats.push(HDR_FORMAT);
        hdr_usage |= wgpu::TextureUsages::RENDER_ATTACHMENT;
    }
    TargetNeeds { prefix: "deferred", msaa_formats, hdr_usage, depth: None }
}

/// Tiled Deferred: G-buffer, the VPLs' culling (with VPLs), culling and shading in one
/// pass, the MSAA resolve (with MSAA).
pub const REGISTRATION: Registration = Registration {
    renders: |m| m == Method::TiledDeferred,
    building: "building the Tiled Deferred renderer",
    steps: |f| tiled_steps(f, &[Step::GBuffer], Step::DeferredShade, Some(Step::DeferredResolve)),
    targets,
    build: |c, sh, sl, st, m| Ok(Box::new(DeferredFrame::new(c, sh, sl, st, m)?)),
};

/// Tiled Deferred's passes and G-buffer.
pub struct DeferredFrame {
    gbuffer_pass: GBufferPass,
    gbuffer: GBuffer,
    shading: DeferredShading,
}

impl DeferredFrame {
    /// Builds the G-buffer and the passes over the shared steps' views, targets, shadows and
    /// VPLs.
    pub fn new(
        ctx: &GpuContext,
        shared: &SharedSteps,
        (scene, lights): (&SceneGpu, &LightBuffers),
        settings: &FrameSettings,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let (features, views, targets) = (&shared.features, &shared.views, &shared.targets);
        let size = (targets.hdr.width(), targets.hdr.height());
        let emission = emission_format(device, &features.materials);
        let gbuffer = GBuffer::new((device, &ctx.queue), size, features.knobs.gbuffer_rts, features.msaa, emission)?;
        let gbuffer_pass = GBufferPass::new(
            device,
            views,
            scene,
            features.knobs.gbuffer_rts,
            features.msaa,
            shared.hooks.gbuffer_values,
        )?;
        memory.add("deferred.gbuffer", gbuffer.bytes());
        memory.note("deferred.gbuffer", gbuffer.describe());
        let (depth, hdr) = (target_handles(targets).0, target_handles(targets).1);
        let shading = DeferredShading::new(
            &shared.lighting_inputs(device, views, lights, features),
            (depth, &gbuffer, hdr),
            (shared.grid, settings.cull, EdgeTest::of(&features.knobs)),
            shared.hooks.drop_light,
            memory,
        )?;
        Ok(Self { gbuffer_pass, gbuffer, shading })
    }

    /// The G-buffer.
    pub fn gbuffer(&self) -> &GBuffer {
        &self.gbuffer
    }

    /// The cull-and-shade pass (its lists, edge statistics, MSAA sample texture).
    pub fn shading(&self) -> &DeferredShading {
        &self.shading
    }
}

impl MethodFrame for DeferredFrame {
    fn record(&self, rec: &mut Rec<'_>, shared: &SharedSteps, depth: Depth<'_>) {
        rec.step(Step::GBuffer);
        let order = rec.order;
        self.gbuffer_pass.record(rec, order, &self.gbuffer, depth.view);
        shared.record_vpl_cull(rec);
        // The pass was built over the frame's depth, G-buffer and HDR image.
        rec.step(Step::DeferredShade);
        let r = &mut rec.recording;
        self.shading.record(r.encoder, r.timer, r.view);
        if depth.samples > 1 {
            rec.step(Step::DeferredResolve);
            let r = &mut rec.recording;
            self.shading.record_resolve(r.encoder, r.timer);
        }
    }

    fn lists(&self) -> Option<Lists<'_>> {
        Some(Lists { grid: &self.shading.light_grid })
    }

    fn grow_lists(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, capacity: u32) -> Option<&LightGrid> {
        self.shading.light_grid.grow(device, queue, capacity);
        Some(&self.shading.light_grid)
    }

    fn edge_pixels(&self, ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        self.shading.read_edge_pixels(&ctx.device, &ctx.queue)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
