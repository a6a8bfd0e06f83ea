//! The culling property on the GPU: for random cameras, scenes, lights and settings, the
//! lists both methods culled on the GPU (Forward+'s culling pass, and the lists Tiled
//! Deferred shades with, as it writes them to the light grid) equal the CPU reference culler's list for
//! list (the shared comparison, `tiledlight_tests::lists`), and no light that reaches a
//! depth sample's surface point is missing from the list that sample reads (ground truth
//! `tiledlight_cull::reference::lights_reaching`, margin 0, as the CPU property
//! `crates/cull/tests/no_false_negatives.rs` checks it).
//!
//! Cases: cameras perspective with finite and infinite far and orthographic (near 0
//! included), FOV 1..170 degrees, near 1e-4..10, far 1e2..1e7, eye up to 1e3 from the
//! origin, any orientation; screens 40x24..97x61; a small random scene rendered by the GPU
//! (1 to 5 quads and boxes at the near plane, straddling it, at middle distances and near or
//! past the far plane, facing the camera or tilted, plus sometimes a background wall):
//! depth buffers with sky, constant, planar and mixed tiles; 1 to 39 lights from the CPU
//! property's generator (`crates/cull/tests/common`: spheres containing the eye or
//! straddling the near plane, cones asked for down to 0.2 degrees, which the light
//! constructors clamp to 0.5, radii 1e-4..1e6, half of them within reach of a surface)
//! plus 1 to 3 near-eye lights (`near_eye_lights`: spheres reaching both the eye plane and
//! a surface, whose assigned lists come from `near_cap_rect`); every grid (tiles, half-z,
//! 2.5D depth masks, clusters of random layout: tile 8..256 px, 1..32 slices, first slice
//! end 1e-3..1e3 m, geometry-only or not) with both assignments (gather, and light-centric
//! `CullOptions::scatter`; clusters are always light-centric), the lists compared with the
//! matching CPU twin (`cull_tiles`, its scatter and 2.5D forms, `cull_clusters`); tile
//! size 8/16/32, AABB, spot cone and two-level culling each on or off; MSAA 1x and 4x,
//! plus 2x and 8x where the adapter
//! multisamples every target format that many times (`targets::check_msaa`; lavapipe has
//! only 1x and 4x, so CI never runs 2x or 8x). The run requires every (grid, assignment)
//! to have run, and reaching pairs of near-eye lights in assigned lists.
//!
//! Exclusions, no looser than the CPU property's: (sample, light) pairs that f32 cannot
//! resolve (`common::spot_pair_unresolvable`, the same function) are skipped. With MSAA a
//! sample's surface point is rebuilt at its standard sample position. A half-z sample picks
//! its list by the CPU's tile range, computed from the same depth buffer with the GPU's
//! formula.
//!
//! Float-borderline decisions (`tiledlight_tests::lists`) must stay under 0.1% of the list
//! pairs over the run, as in every GPU-vs-CPU comparison; each is printed with its case.
//! Measured: 2 of 11,590 (41 cases), 12 of 18,570 (61), 4 of 23,826 (101), 14 of 75,022
//! (251). The one examined (saved below) culls 0.17 mm tiles seen from an eye 170 m from
//! the origin, where a world-coordinate ulp is a tenth of the tile.
//!
//! Catches: culling tests that drop lights (radii shrunk by 1% in the kernel failed within
//! 10 cases), a deferred pass whose lists hold the right number of wrong lights, a kernel
//! bounding fewer depth samples than the CPU does, false negatives either culler shares,
//! and in the light-centric kernel (`shaders/assign.wgsl`) a rectangle a tile short (its
//! `near_cap_rect` included), a hit written to another list, or a wrong 2.5D bin.
//!
//! Cost: 60 cases by default (two renderers built, one frame each, per case), plus the
//! saved ones: 76 s on lavapipe in the dev profile with CI's seed (2 CPU cores; 11 s
//! before the grid and assignment axes and the near-eye lights: clusters and near-eye
//! spheres bring far more reaching pairs to check, 2.7 million in the 62 cases), but the
//! cost varies widely between cases (257 cases of the old shape took 354 s, 251 with
//! another seed 529 s); the H200 ran 1,001 cases of the old shape in 190 s.
//! `PROPTEST_CASES=n` runs more; `PROPTEST_RNG_SEED=s` draws other cases (by default the
//! workspace's fixed seed, `crates/cull/tests/common/seed.rs`, so plain `cargo test` and CI
//! draw the same ones). Failures are saved to `gpu_properties.proptest-regressions` and replayed
//! first. That file keeps seeds, which replay other cases once the strategy changes, so
//! the case it held for the old shape (the world-scale spot cone decision described in
//! `tiledlight_tests::lists`) is written out in `saved_cases` and runs first.

#[path = "../../crates/cull/tests/common/mod.rs"]
mod cull_common;

use std::cell::RefCell;
use std::time::Instant;

use cull_common::{log_uniform, rng, spot_pair_unresolvable, unit, CamKind, CamSpec};
use glam::{Mat4, Quat, Vec3};
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, TestRunner};
use rand::Rng;
use tiledlight_cull::reference::lights_reaching;
use tiledlight_cull::tiles::{pixel_to_ndc_x, pixel_to_ndc_y};
use tiledlight_cull::{Camera, CullConfig};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::{ClusterOptions, CullOptions, GpuTileLists};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;
use tiledlight_scene::{Aabb, Instance, Scene};
use tiledlight_tests::lists::{compare_cluster_lists, compare_lists, CulledFrame};
use tiledlight_tests::{gpu, scenes};

/// Cases per run unless `PROPTEST_CASES` says otherwise: sized for ~2 minutes on lavapipe.
const DEFAULT_CASES: u32 = 60;

/// One generated case. Everything but the seed-driven parts (scene, lights) shrinks.
#[derive(Clone, Debug)]
struct Case {
    cam: CamSpec,
    width: u32,
    height: u32,
    cull: CullOptions,
    /// Picks the sample count among the adapter's (index modulo their number).
    samples_pick: usize,
    objects: usize,
    background: bool,
    n_lights: usize,
    seed: u64,
}

/// Half the visible height at view distance `d`.
fn half_height_at(spec: &CamSpec, d: f32) -> f32 {
    match spec.kind {
        CamKind::Ortho => spec.half_height,
        _ => d * (spec.fov_deg.to_radians() * 0.5).tan(),
    }
}

/// A view distance for an object: at (or straddling) the near plane, in the middle, near or
/// past the far plane, or anywhere in between (log-uniform).
fn object_distance(r: &mut impl Rng, spec: &CamSpec) -> f32 {
    let lo = spec.near.max(1e-4);
    let far = if spec.kind == CamKind::Infinite { 1e7 } else { spec.far };
    match r.random_range(0..4) {
        0 => lo * r.random_range(0.5..2.0),
        1 => log_uniform(r, lo, far.min(1e3).max(lo * 1.01)),
        2 => far * r.random_range(0.3..1.2),
        _ => log_uniform(r, lo, far),
    }
}

/// A random scene in front of `spec`'s camera and the world points of its surfaces that
/// lights are aimed at.
fn build_scene(c: &Case, r: &mut impl Rng) -> (Scene, Vec<Vec3>) {
    let (fwd, up) = c.cam.basis();
    let right = fwd.cross(up);
    let aspect = c.width as f32 / c.height as f32;
    let facing = Quat::from_rotation_arc(Vec3::Y, -fwd);
    let mut instances = Vec::new();
    let mut targets = Vec::new();
    let mut place = |mesh: usize, d: f32, lateral: f32, size: Vec3, rot: Quat, r: &mut dyn rand::RngCore| {
        let hh = half_height_at(&c.cam, d);
        let centre = c.cam.eye
            + fwd * d
            + right * hh * aspect * lateral * r.random_range(-1.0f32..1.0)
            + up * hh * lateral * r.random_range(-1.0f32..1.0);
        let scale = size * hh;
        instances.push(Instance {
            mesh,
            material: 0,
            transform: Mat4::from_scale_rotation_translation(scale, rot, centre),
        });
        for _ in 0..4 {
            let local = Vec3::new(r.random_range(-0.5..0.5), r.random_range(-0.5..0.5), r.random_range(-0.5..0.5));
            let local = if mesh == 0 { local * Vec3::new(1.0, 0.0, 1.0) } else { local };
            targets.push(centre + rot * (local * scale));
        }
    };
    if c.background {
        // A wall across the whole view, facing the camera or tilted up to 60 degrees.
        let d = object_distance(r, &c.cam);
        let tilt = Quat::from_axis_angle(unit(r), r.random_range(0.0..60f32.to_radians()));
        let rot = if r.random_bool(0.5) { facing } else { tilt * facing };
        let side = 8.0 * aspect.max(1.0);
        place(0, d, 0.0, Vec3::new(side, 1.0, side), rot, r);
    }
    for _ in 0..c.objects {
        let d = object_distance(r, &c.cam);
        let mesh = r.random_range(0..2);
        let size = log_uniform(r, 0.05, 2.0);
        let stretch = Vec3::new(log_uniform(r, 0.3, 3.0), log_uniform(r, 0.3, 3.0), log_uniform(r, 0.3, 3.0));
        let rot = if r.random_bool(0.3) { facing } else { Quat::from_axis_angle(unit(r), r.random_range(0.0..6.3)) };
        place(mesh, d, 1.0, stretch * size, rot, r);
    }
    let mut material = scenes::material("surface", [0.7, 0.7, 0.7, 1.0], 0.5, 0.0);
    // Seen from both sides: a tilted quad's back must still write depth.
    material.double_sided = true;
    let mut scene = Scene {
        name: "gpu-property".into(),
        meshes: vec![scenes::quad("quad", 1.0), scenes::cube("box")],
        materials: vec![material],
        textures: vec![],
        instances,
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate().unwrap_or_else(|e| panic!("generated scene rejected: {e}"));
    (scene, targets)
}

/// One to three lights whose spheres reach both the eye plane and a surface point: centred
/// around the eye (up to half the target's distance ahead of or behind it, as far to the
/// side), radius 1 to 1.5 times the distance to the target, so `-c.z <= d / 2 <= r`; half
/// of them spots aimed at the target. Their assigned lists come from `near_cap_rect`.
fn near_eye_lights(r: &mut impl Rng, spec: &CamSpec, targets: &[Vec3]) -> Vec<tiledlight_cull::Light> {
    let (fwd, up) = spec.basis();
    let right = fwd.cross(up);
    let n = r.random_range(1..=3);
    (0..n)
        .filter_map(|_| {
            let target = *targets.get(r.random_range(0..targets.len().max(1)))?;
            let d = (target - spec.eye).dot(fwd);
            // Behind the eye, on its plane or NaN: no light in front to aim.
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            let c = spec.eye
                + fwd * d * r.random_range(-0.5..0.5)
                + (right * r.random_range(-1.0..1.0) + up * r.random_range(-1.0..1.0)) * d * 0.5;
            let radius = (target - c).length() * r.random_range(1.0..1.5);
            let outer = log_uniform(r, 1f32.to_radians(), 90f32.to_radians());
            let spot = r.random_bool(0.5).then(|| ((target - c).normalize_or(fwd), outer));
            Some(cull_common::random_light(r, c, radius, spot))
        })
        .collect()
}

/// What the run has seen, to show the property was not vacuous.
#[derive(Debug, Default)]
struct Totals {
    cases: usize,
    /// Cases per sample count (index: 1, 2, 4, 8).
    per_samples: [usize; 4],
    /// CPU list pairs compared, and GPU decisions within float error among them.
    list_pairs: usize,
    borderline: usize,
    /// (sample, light) pairs that reach and were found in their list; skipped as
    /// unresolvable; of them spot lights; of them in far half-z lists.
    reach_pairs: usize,
    skipped: usize,
    spot_pairs: usize,
    far_half_pairs: usize,
    /// Cases with at least one reaching pair.
    cases_reached: usize,
    /// Cases per (grid, assignment): [`grid_index`] x (gather, scatter).
    per_layout: [[usize; 2]; 4],
    /// Reaching pairs in lists of assigned layouts (scatter or clusters) whose light's
    /// sphere reaches the eye plane of a perspective camera: the pairs `near_cap_rect`
    /// decides (its rectangle must hold the sample's tile).
    near_eye_pairs: usize,
}

/// The layout axis of a case: 0 tiles, 1 half-z, 2 2.5D, 3 clusters.
fn grid_index(o: &CullOptions) -> usize {
    if o.clusters.is_some() {
        3
    } else if o.depth_mask {
        2
    } else {
        usize::from(o.half_z)
    }
}

/// Checks one method's lists of a frame: against the CPU culler, then against ground truth.
#[allow(clippy::too_many_arguments)]
fn check_method(
    method: &str,
    c: &Case,
    camera: &Camera,
    lights: &LightBuffers,
    depth: &[f32],
    gpu_lists: &GpuTileLists,
    config: &CullConfig,
    totals: &mut Totals,
) -> Result<usize, TestCaseError> {
    let frame = CulledFrame { depth, width: c.width, height: c.height, camera, lights: &lights.packed };
    let cmp = match &c.cull.clusters {
        Some(cluster) => compare_cluster_lists(method, &frame, gpu_lists, config, cluster),
        None => compare_lists(method, &frame, gpu_lists, config),
    }
    .map_err(TestCaseError::fail)?;
    // Lights whose sphere reaches the eye plane: an assigned layout lists them only in the
    // tiles of their `near_cap_rect`.
    let near_eye: Vec<bool> = (0..lights.packed.len())
        .map(|i| {
            let cl = lights.packed.cull[i];
            let v = tiledlight_cull::bounds::to_view(&camera.view(), Vec3::from(cl.center));
            c.cull.assigned() && !camera.depth_params().orthographic && v.z + cl.radius >= 0.0
        })
        .collect();
    if cmp.borderline > 0 {
        eprintln!("{method}: {} borderline decisions of {} pairs: {c:?}", cmp.borderline, cmp.pairs);
    }
    totals.list_pairs += cmp.pairs;
    totals.borderline += cmp.borderline;
    let view = camera.view();
    let dp = camera.depth_params();
    let positions = cull_common::sample_positions(config.samples);
    let packed = &lights.packed;
    let mut reached = 0;
    for y in 0..c.height {
        for x in 0..c.width {
            let tile = cmp.cpu.grid.tile_of_pixel(x, y);
            for (s, &(sx, sy)) in positions.iter().enumerate() {
                let d = depth[(y * c.width + x) as usize * positions.len() + s];
                if d <= 0.0 {
                    continue;
                }
                let ndc = (pixel_to_ndc_x(x as f32 + sx, c.width), pixel_to_ndc_y(y as f32 + sy, c.height));
                let Some(p) = camera.unproject_view(ndc.0, ndc.1, d) else { continue };
                let li = cmp.cpu.list_index(tile, dp.view_distance(d));
                let list = &gpu_lists.lists[li];
                for l in lights_reaching(&view, packed, p, 0.0) {
                    if spot_pair_unresolvable(camera, packed, l, p) {
                        totals.skipped += 1;
                        continue;
                    }
                    if !list.contains(&l) {
                        return Err(TestCaseError::fail(format!(
                            "{method}: false negative: pixel ({x}, {y}) sample {s} depth {d:e} view pos {p} \
                             dist {:e}, tile {tile} list {li} (CPU range {:?}): light {l} (of {}, {} points) \
                             reaches it but the GPU list is {list:?} (CPU {:?})",
                            dp.view_distance(d),
                            cmp.cpu.ranges[tile],
                            packed.len(),
                            packed.num_point,
                            cmp.cpu.lists[li],
                        )));
                    }
                    reached += 1;
                    totals.near_eye_pairs += usize::from(near_eye[l as usize]);
                    totals.spot_pairs += usize::from(l >= packed.num_point);
                    totals.far_half_pairs += usize::from(config.half_z && li % 2 == 1);
                }
            }
        }
    }
    totals.reach_pairs += reached;
    Ok(reached)
}

fn run_case(ctx: &GpuContext, supported: &[u32], c: &Case, totals: &mut Totals) -> Result<(), TestCaseError> {
    let samples = supported[c.samples_pick % supported.len()];
    let mut r = rng(c.seed);
    let (scene, targets) = build_scene(c, &mut r);
    let camera = CamSpec { aspect: c.width as f32 / c.height as f32, ..c.cam }.camera();
    let mut lights = cull_common::random_lights(&mut r, &c.cam, &targets, c.n_lights);
    lights.extend(near_eye_lights(&mut r, &c.cam, &targets));
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let lights = LightBuffers::new(&ctx.device, &lights).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let config = CullOptions { samples, ..c.cull }.to_config(lights.has_spots());
    let fail = |what: &str, e: tiledlight_gpu::GpuError| TestCaseError::fail(format!("{what}: {e}"));
    let mut timer = GpuTimer::new(ctx).map_err(|e| fail("timer", e))?;
    let (w, h) = (c.width, c.height);

    let settings = FrameSettings { method: Method::ForwardPlus, cull: c.cull, msaa: samples, ..Default::default() };
    let mut f = FrameRenderer::new(ctx, &sg, &lights, w, h, settings).map_err(|e| fail("Forward+ renderer", e))?;
    f.render_once(ctx, &mut timer, &sg, &camera).map_err(|e| fail("Forward+ frame", e))?;
    let depth = f.read_depth(ctx).map_err(|e| fail("Forward+ depth", e))?;
    let lists = f.read_lists(ctx);
    let lists = lists.map_err(|e| fail("Forward+ lists", e))?;
    let mut reached = check_method("Forward+", c, &camera, &lights, &depth, &lists, &config, totals)?;

    let settings = FrameSettings { method: Method::TiledDeferred, cull: c.cull, msaa: samples, ..Default::default() };
    let mut d = FrameRenderer::new(ctx, &sg, &lights, w, h, settings).map_err(|e| fail("deferred renderer", e))?;
    d.render_once(ctx, &mut timer, &sg, &camera).map_err(|e| fail("deferred frame", e))?;
    let depth = d.read_depth(ctx).map_err(|e| fail("deferred depth", e))?;
    let lists = d.read_lists(ctx).map_err(|e| fail("deferred lists", e))?;
    // Tiled Deferred assigns 2.5D lists light-centrically even when gathering is asked for
    // (its cull-and-shade kernel has no 2.5D variant: `tiledlight_deferred::shading`), so
    // its twin is the scatter one, without the gather's false positives of lights
    // reaching the eye plane outside their `near_cap_rect`.
    let deferred = CullOptions { samples, scatter: c.cull.scatter || c.cull.depth_mask, ..c.cull };
    let deferred_config = deferred.to_config(lights.has_spots());
    let dc = Case { cull: deferred, ..c.clone() };
    reached += check_method("Tiled Deferred", &dc, &camera, &lights, &depth, &lists, &deferred_config, totals)?;

    totals.cases += 1;
    totals.per_samples[samples.trailing_zeros() as usize] += 1;
    totals.per_layout[grid_index(&c.cull)][usize::from(c.cull.assigned())] += 1;
    totals.cases_reached += usize::from(reached > 0);
    Ok(())
}

/// A random cluster layout the GPU accepts: tile size 8..256 px, 1..=32 slices, the first
/// slice ending 1e-3..1e3 m and the last 1.01..1e6 times farther, with or without
/// `geometry_only`.
fn cluster_strategy() -> impl Strategy<Value = ClusterOptions> {
    (
        prop::sample::select(tiledlight_gpu::culling::CLUSTER_TILE_SIZES.to_vec()),
        1u32..=32,
        cull_common::exp10(-3.0, 3.0),
        cull_common::exp10(0.0044, 6.0),
        any::<bool>(),
    )
        .prop_map(|(tile_size, slices, first, ratio, geometry_only)| ClusterOptions {
            tile_size,
            slices,
            first,
            last: first * ratio,
            geometry_only,
        })
}

fn case_strategy() -> impl Strategy<Value = Case> {
    let tile = prop_oneof![Just(8u32), Just(16), Just(32)];
    let flags = (any::<bool>(), any::<bool>(), any::<bool>());
    // The grid: tiles, half-z, 2.5D or clusters (0..4, `grid_index`), and the assignment:
    // gather or scatter (light-centric; clusters are always assigned so).
    let layout = (0usize..4, any::<bool>(), cluster_strategy());
    (
        // The aspect is set from the screen when the case runs.
        cull_common::cam_strategy(Just(1.0)),
        (40u32..=97, 24u32..=61),
        tile,
        flags,
        layout,
        0usize..4,
        (1usize..=5, any::<bool>()),
        1usize..40,
        any::<u64>(),
    )
        .prop_map(
            |(
                cam,
                (width, height),
                tile_size,
                (aabb, spot_cone, coarse),
                (grid, scatter, cluster),
                samples_pick,
                (objects, background),
                n_lights,
                seed,
            )| {
                let cull = CullOptions {
                    tile_size,
                    aabb,
                    half_z: grid == 1,
                    spot_cone,
                    coarse,
                    depth_mask: grid == 2,
                    scatter: scatter && grid != 3,
                    clusters: (grid == 3).then_some(cluster),
                    ..Default::default()
                };
                Case { cam, width, height, cull, samples_pick, objects, background, n_lights, seed }
            },
        )
}

/// Cases that failed once, written out in the current `Case` shape (proptest's regression
/// file keeps only a seed, which replays another case once the strategy changes), run
/// before the random ones.
fn saved_cases() -> Vec<(&'static str, Case)> {
    vec![(
        // A 0.5 degree spot 4.7 cm from a 0.17 mm tile, seen from 170 m from the origin:
        // decided differently by the GPU, 1.4e-6 m from the boundary (the world-coordinate
        // part of `tiledlight_tests::lists::light_error`).
        "world-scale spot cone",
        Case {
            cam: CamSpec {
                kind: CamKind::Finite,
                near: 0.0001,
                far: 100.0,
                fov_deg: 67.90246,
                half_height: 1.0,
                aspect: 1.0,
                eye: Vec3::new(132.73886, -109.042656, -7.398444),
                euler: Vec3::new(3.5367253, 0.21872522, 2.7141666),
            },
            width: 65,
            height: 35,
            cull: CullOptions { tile_size: 16, spot_cone: true, coarse: false, ..Default::default() },
            samples_pick: 0,
            objects: 3,
            background: true,
            n_lights: 5,
            seed: 12872882313441138408,
        },
    )]
}

#[test]
fn gpu_lists_match_cpu_and_miss_no_reaching_light() {
    let ctx = gpu();
    let supported = tiledlight_tests::adapter_sample_counts(ctx);
    assert!(supported.contains(&1) && supported.contains(&4), "WebGPU guarantees 1x and 4x: {supported:?}");
    // The workspace's shared configuration: DEFAULT_CASES unless PROPTEST_CASES, the
    // fixed seed unless PROPTEST_RNG_SEED (so plain `cargo test` draws CI's cases).
    let defaults = cull_common::proptest_config(DEFAULT_CASES);
    // Shrinking re-renders every candidate: bounded so a failure reports in minutes.
    // Failures are saved next to this file (gpu_properties.proptest-regressions) and
    // replayed first on the next run.
    let config = Config {
        max_shrink_iters: 64,
        source_file: Some(file!()),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..defaults
    };
    let mut runner = TestRunner::new(config);
    let totals = RefCell::new(Totals::default());
    let start = Instant::now();
    for (name, c) in saved_cases() {
        run_case(ctx, &supported, &c, &mut totals.borrow_mut()).unwrap_or_else(|e| panic!("saved case {name}: {e}"));
    }
    let result = runner.run(&case_strategy(), |c| run_case(ctx, &supported, &c, &mut totals.borrow_mut()));
    if let Err(e) = result {
        panic!("{e}");
    }
    let t = totals.into_inner();
    eprintln!(
        "{} cases in {:.1} s (samples 1/2/4/8: {:?}, supported {supported:?}): {t:?}",
        t.cases,
        start.elapsed().as_secs_f64(),
        t.per_samples
    );
    // Borderline decisions stay exceptions, as in every GPU-vs-CPU comparison.
    assert!(t.borderline * 1000 <= t.list_pairs.max(1), "{} borderline of {} pairs", t.borderline, t.list_pairs);
    // Not vacuous: lights reached surfaces in most cases, spots and far half-z lists among
    // them, every supported sample count ran, and the exclusions stayed exceptions.
    assert!(t.cases_reached * 2 >= t.cases, "only {} of {} cases had a light reach a sample", t.cases_reached, t.cases);
    assert!(t.spot_pairs > 0 && t.far_half_pairs > 0 && t.near_eye_pairs > 0, "{t:?}");
    // Every grid with both assignments (clusters have only the light-centric one).
    for (g, n) in t.per_layout.iter().enumerate() {
        let both = if g == 3 { n[0] == 0 && n[1] > 0 } else { n[0] > 0 && n[1] > 0 };
        assert!(both, "grid {g} ran {n:?} (gather, scatter) cases: {t:?}");
    }
    for s in &supported {
        assert!(t.per_samples[s.trailing_zeros() as usize] > 0, "no case ran at {s}x: {t:?}");
    }
    assert!(
        t.skipped * 100 <= t.spot_pairs.max(1),
        "{} of {} spot pairs skipped as unresolvable",
        t.skipped,
        t.spot_pairs
    );
}
