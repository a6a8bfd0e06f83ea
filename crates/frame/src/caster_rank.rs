//! Shadow casters chosen by each light's contribution to the frame instead of by
//! brightness: a setup step, run once per light set and camera, the same for every
//! method (so every method shades the same casters).
//!
//! 1. The lights are uploaded with no casters, points first (the order every kernel
//!    indexes them in).
//! 2. The head of a Forward+ frame is recorded single-sampled with plain 16-pixel tiles
//!    (one list a tile; the light grid grown once if a list dropped a light): its depth
//!    pre-pass and culling give the visible surfaces and, per tile, the lights that can
//!    reach them. Its shading is not run.
//! 3. The contribution kernel (`tiledlight_gpu::contribution`) sums each light's
//!    brightness-weighted arrival at the surfaces of the tiles that list it.
//! 4. The scores are read back and mapped to the order the lights were given in; the
//!    caller packs the casters by them (`tiledlight_cull::light::CasterRank::Scores`).
//!
//! Which culling tests run does not change the scores: a light listed for a tile it does
//! not reach adds nothing (its windowed falloff is zero there), and culling never misses
//! a light that does (the culling tests' guarantee). Depends on [`crate::renderer`],
//! [`crate::forward_plus`] and tiledlight-gpu.

use tiledlight_cull::contribution::scores_in_input_order;
use tiledlight_cull::{Camera, Light};
use tiledlight_gpu::contribution::{ContributionInputs, LightContribution, CONTRIBUTION_TILE};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::target_handles;
use tiledlight_gpu::timer::{GpuTimer, PassTime};
use tiledlight_gpu::{GpuContext, GpuError};

use crate::forward_plus::ForwardFrame;
use crate::renderer::FrameRenderer;
use crate::settings::FrameSettings;
use crate::Method;

/// The frame the contribution estimate reads (step 2): Forward+, single-sampled, plain
/// 16-pixel tiles, no shadows or VPLs.
pub fn ranking_settings(num_lights: u32, limits: &wgpu::Limits) -> FrameSettings {
    let capacity = CullOptions::capacity_for(num_lights, false, tiledlight_gpu::culling::CULL_WORKGROUP_BYTES, limits);
    let cull = CullOptions { tile_size: CONTRIBUTION_TILE, capacity, ..CullOptions::default() };
    FrameSettings { cull, ..FrameSettings::of(Method::ForwardPlus) }
}

/// The scores of a ranking and what it cost on the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct CasterRanking {
    /// Each light's contribution, in the order the lights were given.
    pub scores: Vec<u64>,
    /// GPU milliseconds of the passes a ranking runs: the depth pre-pass, the culling and
    /// the estimate (none without timestamp queries).
    pub passes: Vec<PassTime>,
}

impl CasterRanking {
    /// "0.412 ms GPU (depth_prepass 0.301, forward.cull 0.062, contribution 0.049)", or
    /// None without timestamps.
    pub fn describe_cost(&self) -> Option<String> {
        if self.passes.is_empty() {
            return None;
        }
        let total: f64 = self.passes.iter().map(|p| p.ms).sum();
        let parts: Vec<String> = self.passes.iter().map(|p| format!("{} {:.3}", p.label, p.ms)).collect();
        Some(format!("{total:.3} ms GPU ({})", parts.join(", ")))
    }
}

/// Passes of the ranking frame the estimate reads (step 2; two-level culling's first
/// level is timed within the culling pass).
const RANKING_PASSES: [&str; 2] = ["depth_prepass", "forward.cull"];

/// Each light's contribution to a `size` frame of `camera` over `scene` (steps 1-4), in
/// the order of `lights`, with the GPU time of the passes it needed. Errors name what
/// failed: the upload of the lights, the frame, or a light grid that still dropped lights
/// after growing (the scores would be short).
pub fn contribution_scores(
    ctx: &GpuContext,
    scene: &SceneGpu,
    lights: &[Light],
    camera: &Camera,
    size: (u32, u32),
) -> Result<CasterRanking, GpuError> {
    if lights.is_empty() {
        return Ok(CasterRanking { scores: Vec::new(), passes: Vec::new() });
    }
    let buffers = LightBuffers::new(&ctx.device, lights)?;
    let settings = ranking_settings(buffers.len(), &ctx.device.limits());
    let mut frame = FrameRenderer::new(ctx, scene, &buffers, size.0, size.1, settings)?;
    let mut timer = GpuTimer::new(ctx)?;
    frame.shared().write_view(&ctx.queue, camera);
    // The head of the frame (depth and lists; its shading is not needed), again once with
    // a grown grid if the first one dropped lights (the header counts every pair found).
    let mut passes = Vec::new();
    for _ in 0..2 {
        ctx.checked("rendering the contribution estimate's depth and lists", || {
            let head = frame.passes::<ForwardFrame>().expect("the ranking frame is Forward+'s");
            let shared = frame.shared();
            let mut encoder =
                ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ranking") });
            head.record_head(&mut encoder, &timer, shared.main_view(), (scene, target_handles(&shared.targets).0));
            timer.resolve(&mut encoder);
            ctx.queue.submit([encoder.finish()]);
        })?;
        timer.end_frame()?;
        let grid = frame.outputs().light_grid.expect("Forward+ has a light grid");
        let status = grid.status(&ctx.device, &ctx.queue)?;
        while let Some(f) = timer.finished_frame() {
            passes = f;
        }
        match grid.growth(status.needed()).filter(|_| !status.complete()) {
            Some(capacity) => frame.grow_light_grid(ctx, capacity),
            None => break,
        }
    }
    passes.retain(|p| RANKING_PASSES.contains(&p.label.as_str()));
    let scores = ctx.checked("estimating each light's contribution", || {
        let out = frame.outputs();
        let grid = out
            .light_grid
            .ok_or_else(|| GpuError::Config("the contribution estimate's frame made no light grid".into()))?;
        let status = grid.status(&ctx.device, &ctx.queue)?;
        if !status.complete() {
            return Err(GpuError::Config(format!(
                "the contribution estimate's light grid dropped lights ({status}): the scores would be short"
            )));
        }
        let shared = frame.shared();
        let inputs = ContributionInputs {
            depth: target_handles(out.targets).0,
            lights: &buffers,
            lighting: &shared.lighting,
            grid,
        };
        let kernel = LightContribution::new(&ctx.device, &shared.views, inputs)?;
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("contribution") });
        kernel.record(&mut encoder, &timer, shared.main_view());
        timer.resolve(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        timer.end_frame()?;
        kernel.read(&ctx.device, &ctx.queue, buffers.len())
    })??;
    if let Some(f) = timer.finished_frame() {
        passes.extend(f);
    }
    let scores = scores_in_input_order(lights, &scores)?;
    Ok(CasterRanking { scores, passes })
}
