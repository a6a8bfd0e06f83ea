//! Every light-grid layout and both ways of filling it, on images (issue 13's tests; the
//! lists themselves are compared with the CPU twins in `cull_gpu_vs_cpu.rs`):
//! - tiles, half-z, 2.5D and clusters, gathered and scattered, in Forward+ and Tiled
//!   Deferred, each against the brute-force reference with the same cutoff (the layouts
//!   only change which lights each pixel loops over, never the light it gets: the
//!   tolerances are the methods' usual ones, FORWARD_VS_REFERENCE and
//!   DEFERRED_VS_REFERENCE, whose reasons are in `tiledlight_tests::compare`);
//! - a million lights on the courtyard's surfaces at 320x180, light-centric: no
//!   (list, light) pair dropped, and the tiled, 2.5D and clustered images the same.
//!
//! On lavapipe a brute-force reference over a million lights cannot run (llvmpipe ends an
//! invocation's loops after 65,535 iterations: docs/GPU-TESTS.md), so the million-light
//! frames are compared with each other, and with the reference at 2,000 lights.

use tiledlight_deferred::{DeferredRenderer, DeferredSettings};
use tiledlight_forward::{ForwardRenderer, ForwardSettings, Method};
use tiledlight_gpu::diagnostics::Diagnostics as _;
use tiledlight_gpu::light_cull::{ClusterOptions, CullOptions};
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::Renderer;
use tiledlight_scene::{SurfaceLightOptions, SurfaceSampler};
use tiledlight_tests::compare::{
    assert_matches_reference_frame, reference_frame, render_frame, DEFERRED_VS_REFERENCE, FORWARD_VS_REFERENCE,
};
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

/// llvmpipe ends an invocation's loops after this many iterations in all
/// (docs/GPU-TESTS.md): a pixel's light loop must stay below it for its image to mean
/// anything there.
const LAVAPIPE_LOOP_LIMIT: u32 = 65_535;

/// 16 px clusters, 32 slices from 1 m to 100 m, only where there is geometry.
const SMALL_CLUSTERS: ClusterOptions =
    ClusterOptions { tile_size: 16, slices: 32, first: 1.0, last: 100.0, geometry_only: true };

/// The layouts and assignments under test, named.
fn layouts() -> Vec<(&'static str, CullOptions)> {
    let d = CullOptions::default();
    let small = ClusterOptions { tile_size: 16, slices: 24, first: 2.0, last: 60.0, geometry_only: true };
    vec![
        ("tiled-gather", d),
        ("tiled-scatter", CullOptions { scatter: true, ..d }),
        ("half-z-scatter", CullOptions { half_z: true, scatter: true, ..d }),
        ("2.5d-gather", CullOptions { depth_mask: true, ..d }),
        ("2.5d-scatter", CullOptions { depth_mask: true, scatter: true, ..d }),
        ("clustered", CullOptions { clusters: Some(ClusterOptions::default()), ..d }),
        ("clustered-16px-geometry", CullOptions { clusters: Some(small), ..d }),
    ]
}

#[test]
fn every_layout_matches_brute_force_in_both_methods() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 1600, 400, 21)).unwrap();
    let cam = scenes::mixed_camera(W, H);
    let reference = reference_frame(ctx, &sg, &lights, (W, H), &cam);
    let mut fp = ForwardRenderer::new(ctx, &sg, &lights, W, H, ForwardSettings::default()).unwrap();
    let depth = {
        render_frame(ctx, &mut fp, &sg, &cam);
        fp.read_depth(ctx).unwrap()
    };
    let deferred_reference = reference.clone().allow_gbuffer_normals(&depth, W, &cam, &lights.packed);
    for (name, cull) in layouts() {
        let s = ForwardSettings { method: Method::ForwardPlus, cull, ..Default::default() };
        let mut r = ForwardRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
        let f = render_frame(ctx, &mut r, &sg, &cam);
        assert_matches_reference_frame(&format!("layout-{name}-forward"), W, &reference, &f, FORWARD_VS_REFERENCE);
        let s = DeferredSettings { cull, ..Default::default() };
        let mut r = DeferredRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
        let d = render_frame(ctx, &mut r, &sg, &cam);
        assert_matches_reference_frame(
            &format!("layout-{name}-deferred"),
            W,
            &deferred_reference,
            &d,
            DEFERRED_VS_REFERENCE,
        );
    }
}

/// A million lights on the courtyard's surfaces (the `--light-preset million` lights) at
/// 320x180, Tiled Deferred with light-centric assignment: every pair is stored (the grid
/// grows until the frame fits; none dropped), and the tiled, 2.5D and clustered frames
/// agree: each is shaded with every light that reaches the pixel, so they differ only in
/// summation order (1 step of 8 bits at most, in a few pixels).
#[test]
fn a_million_lights_render_with_no_dropped_pair() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let sampler = SurfaceSampler::of_scene(&scene).unwrap();
    let placed = sampler.lights(&SurfaceLightOptions::default()).unwrap();
    assert_eq!(placed.lights.len(), 1_000_000);
    let lights = LightBuffers::new(&ctx.device, &placed.lights).unwrap();
    let cam = scenes::courtyard_camera(&scene, W, H);
    let mut frames = Vec::new();
    for (name, cull) in [
        ("tiled", CullOptions { scatter: true, ..Default::default() }),
        ("2.5d", CullOptions { depth_mask: true, scatter: true, ..Default::default() }),
        // Small clusters and a near first slice: the default's 64 px slice 0 holds 67,043
        // of these lights in one list, past llvmpipe's 65,535 loop iterations (the pixels
        // reading it lose lights on lavapipe only; see the module doc).
        ("clustered", CullOptions { clusters: Some(SMALL_CLUSTERS), ..Default::default() }),
    ] {
        let mut r =
            DeferredRenderer::new(ctx, &sg, &lights, W, H, DeferredSettings { cull, ..Default::default() }).unwrap();
        let f = render_frame(ctx, &mut r, &sg, &cam);
        let grid = r.light_grid().unwrap();
        let status = grid.status(&ctx.device, &ctx.queue).unwrap();
        let longest = grid.read_counts(&ctx.device, &ctx.queue).unwrap().into_iter().max().unwrap_or(0);
        println!("{name}: {status}; longest list {longest}");
        assert!(longest < LAVAPIPE_LOOP_LIMIT, "{name}: a list of {longest} lights: lavapipe would cut its loop");
        assert!(status.complete(), "{name}: {status}");
        assert!(
            status.header.pairs > 100_000,
            "{name}: only {} pairs: the lights do not reach the frame",
            status.header.pairs
        );
        frames.push((name, f));
    }
    let (first, rest) = frames.split_first().unwrap();
    for (name, f) in rest {
        let mut worst = 0u8;
        let mut differing = 0usize;
        for (a, b) in first.1.ldr.iter().zip(&f.ldr) {
            let d = a.abs_diff(*b);
            worst = worst.max(d);
            differing += usize::from(d > 0);
        }
        println!("{} vs {name}: {differing} channel values differ, by at most {worst}", first.0);
        assert!(worst <= 1, "{} vs {name}: a channel differs by {worst} steps", first.0);
        assert!(differing * 100 <= first.1.ldr.len(), "{} vs {name}: {differing} values differ", first.0);
    }
    let lit = first.1.ldr.chunks(4).filter(|p| p[0] > 8 || p[1] > 8 || p[2] > 8).count();
    assert!(lit * 2 > (W * H) as usize, "only {lit} of {} pixels lit: the frame shows nothing", W * H);
}
