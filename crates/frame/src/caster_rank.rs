//! Shadow casters chosen by each light's contribution to the frame instead of by
//! brightness: a setup step, run once per light set and camera, the same for every
//! method (so every method shades the same casters).
//!
//! 1. The lights are uploaded with no casters, points first (the order every kernel
//!    indexes them in).
//! 2. A Forward+ frame is rendered single-sampled with plain 16-pixel tiles (one list a
//!    tile; the light grid grown until no list dropped a light): its depth pre-pass and
//!    culling give the visible surfaces and, per tile, the lights that can reach them.
//! 3. The contribution kernel (`tiledlight_gpu::contribution`) sums each light's
//!    brightness-weighted arrival at the surfaces of the tiles that list it.
//! 4. The scores are read back and mapped to the order the lights were given in; the
//!    caller packs the casters by them (`tiledlight_cull::light::CasterRank::Scores`).
//!
//! Which culling tests run does not change the scores: a light listed for a tile it does
//! not reach adds nothing (its windowed falloff is zero there), and culling never misses
//! a light that does (the culling tests' guarantee). Depends on [`crate::renderer`],
//! [`crate::diagnostics`] and tiledlight-gpu.

use tiledlight_cull::contribution::scores_in_input_order;
use tiledlight_cull::{Camera, Light};
use tiledlight_gpu::contribution::{ContributionInputs, LightContribution, CONTRIBUTION_TILE};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::diagnostics::Diagnostics as _;
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

/// Each light's contribution to a `size` frame of `camera` over `scene` (steps 1-4), in
/// the order of `lights`. Errors name what failed: the upload of the lights, the frame,
/// or a light grid that still dropped lights after growing (the scores would be short).
pub fn contribution_scores(
    ctx: &GpuContext,
    scene: &SceneGpu,
    lights: &[Light],
    camera: &Camera,
    size: (u32, u32),
) -> Result<Vec<u64>, GpuError> {
    if lights.is_empty() {
        return Ok(Vec::new());
    }
    let buffers = LightBuffers::new(&ctx.device, lights)?;
    let settings = ranking_settings(buffers.len(), &ctx.device.limits());
    let mut frame = FrameRenderer::new(ctx, scene, &buffers, size.0, size.1, settings)?;
    let mut timer = GpuTimer::new(ctx)?;
    frame.render_once(ctx, &mut timer, scene, camera)?;
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
        let inputs =
            ContributionInputs { depth: &out.targets.depth_view, lights: &buffers, lighting: &shared.lighting, grid };
        let kernel = LightContribution::new(&ctx.device, &shared.views, inputs)?;
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("contribution") });
        kernel.record(&mut encoder, shared.main_view());
        ctx.queue.submit([encoder.finish()]);
        kernel.read(&ctx.device, &ctx.queue, buffers.len())
    })??;
    scores_in_input_order(lights, &scores).map_err(GpuError::from)
}
