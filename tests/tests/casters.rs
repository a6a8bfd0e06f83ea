//! Shadow casters chosen by contribution (issue 30): the GPU contribution kernel
//! (`shaders/light_contribution.wgsl`) against its CPU twin
//! (`tiledlight_cull::contribution`) over the same depth and lists, a shifted list that
//! the comparison must reject, and the setup step (`tiledlight_frame::caster_rank`) that
//! packs the casters by the scores.

use tiledlight_cull::contribution::light_scores;
use tiledlight_cull::light::{try_pack_lights_ranked, CasterRank};
use tiledlight_cull::{Camera, Light, TileGrid};
use tiledlight_frame::caster_rank::{contribution_scores, ranking_settings};
use tiledlight_frame::{Diagnostics as _, FrameRenderer};
use tiledlight_gpu::contribution::{ContributionInputs, LightContribution};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

/// Relative allowance between a GPU score and its twin's: both sum the same f32 terms in
/// the same order from the same matrices; only fused multiply-adds and the GPU's
/// transcendental rounding (sqrt for spots) differ, a few ulps a term (~1e-6), so 1e-4
/// keeps two orders of margin.
const REL: f64 = 1e-4;

/// Absolute allowance per (tile, light) pair: each pair's value is truncated to whole
/// units on both sides, so one unit a pair may differ even when the sums agree.
const UNITS_PER_PAIR: u64 = 1;

/// What the comparison found: lights outside the allowance and the largest relative
/// difference among the others.
#[derive(Debug)]
struct ScoreVerdict {
    wrong: Vec<(usize, u64, u64)>,
    max_rel: f64,
}

/// Compares GPU scores with the twin's, light by light, allowing [`REL`] of the larger and
/// [`UNITS_PER_PAIR`] for each tile that lists the light (`pairs[i]`).
fn compare_scores(gpu: &[u64], cpu: &[u64], pairs: &[u64]) -> ScoreVerdict {
    assert_eq!(gpu.len(), cpu.len(), "one score a light on both sides");
    let mut v = ScoreVerdict { wrong: Vec::new(), max_rel: 0.0 };
    for (i, (&g, &c)) in gpu.iter().zip(cpu).enumerate() {
        let diff = g.abs_diff(c);
        let allowed = (REL * g.max(c) as f64) as u64 + UNITS_PER_PAIR * pairs[i];
        if diff > allowed {
            v.wrong.push((i, g, c));
        } else if g.max(c) > 0 {
            v.max_rel = v.max_rel.max(diff as f64 / g.max(c) as f64);
        }
    }
    v
}

/// The ranking frame's depth and lists, and the GPU kernel's scores (packed order).
struct Run {
    depth: Vec<f32>,
    lists: Vec<Vec<u32>>,
    grid: TileGrid,
    scale: f32,
    gpu: Vec<u64>,
    packed: tiledlight_cull::light::PackedLights,
}

fn run(ctx: &GpuContext, scene: &tiledlight_scene::Scene, lights: &[Light], camera: &Camera) -> Run {
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, lights).unwrap();
    let settings = ranking_settings(lb.len(), &ctx.device.limits());
    let mut r = FrameRenderer::new(ctx, &sg, &lb, W, H, settings).unwrap();
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, &sg, camera).unwrap();
    let out = r.outputs();
    let grid = out.light_grid.expect("Forward+ has a light grid");
    let inputs = ContributionInputs {
        depth: tiledlight_gpu::targets::target_handles(out.targets).0,
        lights: &lb,
        lighting: &r.shared().lighting,
        grid,
    };
    let kernel = LightContribution::new(&ctx.device, &r.shared().views, inputs).unwrap();
    let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test") });
    kernel.record(&mut encoder, &timer, r.shared().main_view());
    ctx.queue.submit([encoder.finish()]);
    let gpu = kernel.read(&ctx.device, &ctx.queue, lb.len()).unwrap();
    let lists = r.read_lists(ctx).unwrap();
    assert_eq!(lists.overflowing, 0, "the ranking frame's grid holds every pair");
    Run {
        depth: r.read_depth(ctx).unwrap(),
        lists: lists.lists,
        grid: r.shared().grid,
        scale: kernel.scale,
        gpu,
        packed: lb.packed.clone(),
    }
}

/// Tiles listing each light.
fn pairs(lists: &[Vec<u32>], n: usize) -> Vec<u64> {
    let mut p = vec![0u64; n];
    lists.iter().flatten().for_each(|&i| p[i as usize] += 1);
    p
}

/// The courtyard with point and spot lights: the GPU's scores equal the twin's over the
/// GPU's own depth and lists; a list shifted by one tile (a stale or mis-indexed grid)
/// must fail the same comparison.
#[test]
fn gpu_contribution_scores_match_the_cpu_twin() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let lights = scenes::lights(&scene, 96, 32, 7);
    let r = run(ctx, &scene, &lights, &camera);
    let n = r.packed.len();
    let cpu = light_scores(&camera, &r.depth, (&r.grid, &r.lists), &r.packed, r.scale).unwrap();
    let p = pairs(&r.lists, n);
    let v = compare_scores(&r.gpu, &cpu, &p);
    println!("{n} lights, {} pairs; largest relative difference {:.2e}", p.iter().sum::<u64>(), v.max_rel);
    assert!(v.wrong.is_empty(), "lights outside the allowance (index, gpu, cpu): {:?}", v.wrong);
    let lit = r.gpu.iter().filter(|&&s| s > 0).count();
    assert!(lit > n / 4 && lit < n, "a frame with lights on and off screen ({lit} of {n} score)");
    assert!(r.packed.num_point < n as u32, "spots are in the comparison");
    assert!(
        r.gpu[r.packed.num_point as usize..].iter().any(|&s| s > 0),
        "some spot lights the frame (the SPOTS path ran)"
    );

    // Negative: the twin over lists shifted by one tile.
    let mut shifted = r.lists.clone();
    shifted.rotate_right(1);
    let wrong = light_scores(&camera, &r.depth, (&r.grid, &shifted), &r.packed, r.scale).unwrap();
    let bad = compare_scores(&r.gpu, &wrong, &p);
    assert!(bad.wrong.len() > n / 10, "a shifted grid must fail: only {} lights differ", bad.wrong.len());
}

/// The setup step's scores are the kernel's, in the lights' input order, and pack as
/// casters the highest-scoring lights of each kind; on the courtyard they are not the
/// brightest (the point of choosing by contribution).
#[test]
fn casters_by_contribution_are_the_highest_scores() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    // Spots before points in the input: the scores must come back in this order.
    let mut lights = scenes::lights(&scene, 0, 24, 3);
    lights.extend(scenes::lights(&scene, 64, 0, 4));
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let ranking = contribution_scores(ctx, &sg, &lights, &camera, (W, H)).unwrap();
    // The ranking's GPU cost: the passes the estimate reads, and the estimate itself.
    let labels: Vec<&str> = ranking.passes.iter().map(|p| p.label.as_str()).collect();
    assert!(ctx.timestamps, "lavapipe and the H200 have timestamp queries");
    assert_eq!(labels, ["depth_prepass", "forward.cull", "contribution"], "{:?}", ranking.describe_cost());
    let scores = ranking.scores;
    assert_eq!(scores.len(), lights.len());
    // The kernel's own run packs points first: map its scores by light position.
    let r = run(ctx, &scene, &lights, &camera);
    for (l, s) in lights.iter().zip(&scores) {
        let k = r.packed.shading.iter().position(|p| p.position == l.position.to_array()).unwrap();
        assert_eq!(*s, r.gpu[k], "the score of the light at {} (deterministic integer sums)", l.position);
    }
    let casters = (4, 2);
    let packed = try_pack_lights_ranked(&lights, casters, CasterRank::Scores(&scores)).unwrap();
    let score_of = |pos: [f32; 3]| scores[lights.iter().position(|l| l.position.to_array() == pos).unwrap()];
    let np = packed.num_point as usize;
    for (range, kind) in [(0..np, "point"), (np..packed.len(), "spot")] {
        let n = if kind == "point" { casters.0 } else { casters.1 } as usize;
        let mut all: Vec<u64> = packed.shading[range.clone()].iter().map(|l| score_of(l.position)).collect();
        let chosen: Vec<u64> = all[..n].to_vec();
        all.sort_unstable_by(|a, b| b.cmp(a));
        let min_chosen = *chosen.iter().min().unwrap();
        assert!(min_chosen >= all[n], "{kind} casters {chosen:?} must be the top {n} of {:?}", &all[..n + 1]);
    }
    let bright = try_pack_lights_ranked(&lights, casters, CasterRank::Brightest).unwrap();
    assert_ne!(
        bright.shading[..casters.0 as usize],
        packed.shading[..casters.0 as usize],
        "on the courtyard the largest contributions are not the brightest lights"
    );
}

/// Lights so wide that the ranking's first light grid (32 indices a tile) overflows: the
/// ranking grows it and scores every pair, as a full frame grown the same way does.
#[test]
fn a_grid_that_must_grow_ranks_every_pair() {
    use tiledlight_scene::{random_lights, LightOptions};
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let opts = LightOptions { num_point: 200, seed: 5, threshold: 1e-4, ..Default::default() };
    let lights = random_lights(&scene.bounds, &opts).unwrap();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let ranking = contribution_scores(ctx, &sg, &lights, &camera, (W, H)).unwrap();
    let r = run(ctx, &scene, &lights, &camera);
    let found: u64 = pairs(&r.lists, lights.len()).iter().sum();
    assert!(found > 32 * r.grid.tile_count() as u64, "the first grid must overflow: {found} pairs");
    // Points only: the packed order is the input order.
    assert_eq!(ranking.scores, r.gpu);
}
