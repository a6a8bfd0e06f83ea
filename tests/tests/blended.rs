//! Alpha-blended geometry (`tiledlight_gpu::blended`) in Forward+, Tiled Deferred and the
//! brute-force reference:
//! - a light that reaches only a transparent pane floating before a far wall lights the
//!   pane (the opaque list, culled against the wall, does not hold it);
//! - the blended lists equal the CPU twin (`cull_tiles_blended`) fed the GPU's blended
//!   depth, with and without MSAA (the kernel's arithmetic);
//! - the blended lists lie within the bounds of lists culled from a blended depth
//!   rasterised independently on the CPU from the pane triangles
//!   (`tiledlight_cull::blended_depth`), at every sample count the adapter has: a blended
//!   depth pass that skips an instance, draws the opaque layer or keeps another depth than
//!   the nearest fails; the check rejects a pane missing from either side;
//! - Forward+ and Tiled Deferred match brute force with the same blending, and with
//!   shadows (a plate's shadow on a pane) and VPLs at every sample count the adapter has
//!   (lavapipe: 1x and 4x; 2x and 8x on the H200 run);
//! - two overlapping panes swap order when the camera crosses between them;
//! - the heat map of the blended lists colours exactly the tiles whose blended list has
//!   lights, and is a clear error without blended geometry;
//! - a scene without blended materials has none of the blended path;
//! - with clusters of the whole frustum, blended geometry reads the frame's clusters (no
//!   blended depth or lists) and both methods still match brute force.

use glam::{Mat4, Vec3};
use tiledlight_cull::blended_depth::raster_depth;
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::plan::Step;
use tiledlight_frame::{DeferredFrame, Diagnostics, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::{ClusterOptions, CullOptions};
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::readback::read_depth;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::{AlphaMode, Instance, Scene};
use tiledlight_tests::compare::{
    assert_matches_reference_frame, assert_visibility_matches, msaa_by_design, render_frame, Frame,
    DEFERRED_VS_REFERENCE, FORWARD_VS_REFERENCE, RASTER_POSITION_ERROR_PX,
};
use tiledlight_tests::lists::{assert_blended_lists_match, compare_blended_lists_independent, CulledFrame};
use tiledlight_tests::{gpu, scenes, visibility_rasters};

const W: u32 = 320;
const H: u32 = 180;

/// A floor (y = -2), optionally a far wall (z = -10), and blended double-sided 2 m panes
/// facing +Z at `panes` (centre, colour with alpha).
fn pane_scene(wall: bool, panes: &[(Vec3, [f32; 4])]) -> Scene {
    let mut materials = vec![scenes::material("wall", [0.7, 0.7, 0.7, 1.0], 0.8, 0.0)];
    let upright = Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let mut instances = vec![Instance { mesh: 0, material: 0, transform: Mat4::from_translation(Vec3::Y * -2.0) }];
    if wall {
        let t = Mat4::from_translation(Vec3::new(0.0, 0.0, -10.0)) * upright;
        instances.push(Instance { mesh: 0, material: 0, transform: t });
    }
    for (i, (c, color)) in panes.iter().enumerate() {
        let mut m = scenes::material(&format!("pane{i}"), *color, 0.3, 0.0);
        m.alpha_mode = AlphaMode::Blend;
        m.double_sided = true;
        materials.push(m);
        let t = Mat4::from_translation(*c) * upright;
        instances.push(Instance { mesh: 1, material: materials.len() - 1, transform: t });
    }
    let mut scene = Scene {
        name: "panes".into(),
        meshes: vec![scenes::quad("big", 20.0), scenes::quad("pane", 2.0)],
        materials,
        textures: vec![],
        instances,
        lights: vec![],
        camera: None,
        bounds: tiledlight_scene::Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate().expect("pane scene");
    scene
}

fn camera(eye: Vec3, target: Vec3) -> Camera {
    Camera::perspective(eye, target, Vec3::Y, 50f32.to_radians(), W as f32 / H as f32, 0.1, None).expect("camera")
}

fn forward(scene: &SceneGpu, lights: &LightBuffers, method: Method, msaa: u32) -> FrameRenderer {
    let s = FrameSettings { method, msaa, ..Default::default() };
    FrameRenderer::new(gpu(), scene, lights, W, H, s).expect("forward renderer")
}

/// A pane 7 m before the wall, and a light 0.6 m before the pane whose radius (1.5 m)
/// reaches the pane but not the wall: tiles over the pane have the wall's depth, so their
/// opaque list cannot hold the light; the blended list must.
#[test]
fn a_light_reaching_only_the_pane_lights_it() {
    let ctx = gpu();
    let scene = pane_scene(true, &[(Vec3::new(0.0, 0.0, -3.0), [0.9, 0.9, 0.9, 0.5])]);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let near =
        Light::with_radius(Vec3::new(0.0, 0.0, -2.4), Vec3::ONE, 3.0, 1.5, tiledlight_cull::LightKind::Point).unwrap();
    let cam = camera(Vec3::new(0.0, 0.0, 4.0), Vec3::new(0.0, 0.0, -10.0));
    let lit = LightBuffers::new(&ctx.device, &[near]).unwrap();
    let dark = LightBuffers::new(&ctx.device, &[]).unwrap();
    let mut r = forward(&sg, &lit, Method::ForwardPlus, 1);
    let with = render_frame(ctx, &mut r, &sg, &cam);
    // The centre pixel sees the pane over the wall: its tile's opaque list lacks the light
    // (culled against the wall), its blended list has it.
    let tile = (H / 2 / 16) * W.div_ceil(16) + W / 2 / 16;
    let opaque = r.read_lists(ctx).unwrap();
    assert!(opaque.lists[tile as usize].is_empty(), "the wall's list must not hold the light");
    let blended = r.outputs().blended.unwrap().culling.as_ref().unwrap().read_lists(&ctx.device, &ctx.queue).unwrap();
    assert_eq!(blended.lists[tile as usize], vec![0], "the pane's list holds the light");
    let mut r = forward(&sg, &dark, Method::ForwardPlus, 1);
    let without = render_frame(ctx, &mut r, &sg, &cam);
    let centre = ((H / 2) * W + W / 2) as usize;
    let gain = with.hdr[centre][0] - without.hdr[centre][0];
    // Diffuse head-on at 0.6 m: 3 / 0.36 * 0.9 * 0.96 * 28 / (23 pi) * (31/32)^2 ~ 2.6, windowed
    // ~0.9, times alpha 0.5: ~1.2.
    assert!(gain > 0.3, "the pane is lit by the light in front of it: +{gain} at the centre");
    // The wall behind is not (beyond the radius): pixels off the pane do not change.
    let off = ((H / 2) * W + 10) as usize;
    assert!((with.hdr[off][0] - without.hdr[off][0]).abs() < 1e-6);
}

/// The opaque depth of one 1-sample Forward+ frame (one value per pixel).
fn opaque_depth(sg: &SceneGpu, lights: &LightBuffers, cam: &Camera) -> Vec<f32> {
    let ctx = gpu();
    let mut r = forward(sg, lights, Method::ForwardPlus, 1);
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, sg, cam).unwrap();
    r.read_depth(ctx).unwrap()
}

fn lights_for_panes() -> Vec<Light> {
    vec![
        Light::point(Vec3::new(0.0, 0.0, -2.0), Vec3::new(1.0, 0.9, 0.8), 2.0, 0.5).unwrap(),
        Light::point(Vec3::new(-2.0, 1.5, -6.0), Vec3::new(0.4, 0.6, 1.0), 20.0, 0.1).unwrap(),
        Light::point(Vec3::new(2.5, -1.0, -4.5), Vec3::new(1.0, 0.5, 0.3), 10.0, 0.1).unwrap(),
        Light::spot(Vec3::new(0.0, 3.0, 1.0), Vec3::new(0.0, -0.6, -1.0).normalize(), Vec3::ONE, 30.0, 0.3, 0.5, 0.1)
            .unwrap(),
    ]
}

fn three_panes(wall: bool) -> Scene {
    pane_scene(
        wall,
        &[
            (Vec3::new(0.0, 0.0, -3.0), [0.2, 0.6, 1.0, 0.5]),
            (Vec3::new(0.8, 0.4, -4.0), [1.0, 0.4, 0.2, 0.6]),
            (Vec3::new(-1.5, -0.5, -6.0), [0.3, 1.0, 0.4, 0.4]),
        ],
    )
}

/// The blended lists equal the CPU twin's, list by list, without and with 4x MSAA; with
/// and without a wall (the sky behind a pane: the range reaches infinitely far).
#[test]
fn blended_lists_match_the_cpu_twin() {
    let ctx = gpu();
    for wall in [true, false] {
        let scene = three_panes(wall);
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let lights = LightBuffers::new(&ctx.device, &lights_for_panes()).unwrap();
        let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
        for msaa in [1, 4] {
            let mut r = forward(&sg, &lights, Method::ForwardPlus, msaa);
            let mut timer = GpuTimer::new(ctx).unwrap();
            r.render_once(ctx, &mut timer, &sg, &cam).unwrap();
            let b = r.outputs().blended.expect("blended path");
            let opaque = r.read_depth(ctx).unwrap();
            let blended = read_depth(&ctx.device, &ctx.queue, &b.depth.as_ref().unwrap().texture).unwrap();
            let c = b.culling.as_ref().unwrap();
            let gpu_lists = c.read_lists(&ctx.device, &ctx.queue).unwrap();
            let frame = CulledFrame { depth: &opaque, width: W, height: H, camera: &cam, lights: &lights.packed };
            let config = c.options.to_config(lights.has_spots());
            let label = format!("blended lists, wall {wall}, MSAA {msaa}");
            let cmp = assert_blended_lists_match(&label, &frame, &blended, &gpu_lists, &config);
            assert!(cmp.nonempty_lists > 20, "{label}: the panes must cover tiles ({} lists)", cmp.nonempty_lists);
        }
    }
}

/// Forward+ against brute force with the same blended layer: the lists are conservative and
/// the blending the same code, so FORWARD_VS_REFERENCE holds (summation order only). Tiled
/// Deferred's opaque layer is its own (8-bit albedo, packed normals:
/// DEFERRED_VS_REFERENCE's reasons); its blended layer is the same forward code. With 4x
/// MSAA, both against brute force at 4x.
#[test]
fn methods_agree_on_blended_geometry() {
    methods_match_brute_force("", CullOptions::default(), |_| {}, |_| {});
}

/// The three panes before the wall, Forward+ and Tiled Deferred with culling `cull`, each
/// against brute force at 1x and 4x MSAA (images named `blended-{method}{name}-msaa{n}`);
/// `check_fp` and `check_td` look at each renderer before it draws.
fn methods_match_brute_force(
    name: &str,
    cull: CullOptions,
    check_fp: impl Fn(&FrameRenderer),
    check_td: impl Fn(&FrameRenderer),
) {
    let ctx = gpu();
    let scene = three_panes(true);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &lights_for_panes()).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    // One depth per pixel for Tiled Deferred's G-buffer-normal allowance (the opaque layer's
    // packed normals move grazing lights: compare::Frame::allow_gbuffer_normals; measured on
    // the H200 at 4x MSAA, a floor pixel 3.1e-2 off without it).
    let depth = opaque_depth(&sg, &lights, &cam);
    for msaa in [1, 4] {
        let mut bf = forward(&sg, &lights, Method::BruteForce { cutoff: true }, msaa);
        let reference = render_frame(ctx, &mut bf, &sg, &cam);
        let s = FrameSettings { method: Method::ForwardPlus, msaa, cull, ..Default::default() };
        let mut fp = FrameRenderer::new(ctx, &sg, &lights, W, H, s).expect("forward renderer");
        check_fp(&fp);
        let f = render_frame(ctx, &mut fp, &sg, &cam);
        let what = format!("blended-forward{name}-msaa{msaa}");
        assert_matches_reference_frame(&what, W, &reference, &f, FORWARD_VS_REFERENCE);
        let s = FrameSettings { method: Method::TiledDeferred, msaa, cull, ..Default::default() };
        let mut td = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
        check_td(&td);
        let d = render_frame(ctx, &mut td, &sg, &cam);
        let reference = reference.allow_gbuffer_normals(&depth, W, &cam, &lights.packed);
        let what = format!("blended-deferred{name}-msaa{msaa}");
        assert_matches_reference_frame(&what, W, &reference, &d, DEFERRED_VS_REFERENCE);
    }
}

/// Clusters of the whole frustum list every light of their volume, so blended geometry
/// reads them: no blended depth, culling or grid exist, and the images match brute force
/// with the same tolerances as the tiled lists above (the lists are conservative; what
/// differs is only the methods' own error).
#[test]
fn frustum_clusters_serve_blended_geometry() {
    // 16 px clusters, 16 slices from 1 m: a few slices over the panes' 3-10 m.
    let clusters = ClusterOptions { tile_size: 16, slices: 16, first: 1.0, last: 60.0, geometry_only: false };
    let cull = CullOptions { clusters: Some(clusters), ..Default::default() };
    let check_fp = |fp: &FrameRenderer| {
        let b = fp.outputs().blended.expect("blended path");
        assert!(b.depth.is_none() && b.culling.is_none(), "no blended depth or lists with frustum clusters");
        assert!(!fp.plan().has(Step::BlendedDepth) && !fp.plan().has(Step::BlendedCull));
        assert!(fp.plan().has(Step::BlendedShade));
    };
    let check_td = |td: &FrameRenderer| assert!(td.outputs().blended.expect("blended path").depth.is_none());
    methods_match_brute_force("-clusters", cull, check_fp, check_td);
    let ctx = gpu();
    let scene = three_panes(true);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &lights_for_panes()).unwrap();
    // Geometry-only clusters have no lists where there is no opaque surface: the blended
    // path keeps its own.
    let only = CullOptions { clusters: Some(ClusterOptions { geometry_only: true, ..clusters }), ..Default::default() };
    let s = FrameSettings { method: Method::ForwardPlus, cull: only, ..Default::default() };
    let fp = FrameRenderer::new(ctx, &sg, &lights, W, H, s).expect("forward renderer");
    assert!(fp.outputs().blended.unwrap().culling.is_some() && fp.plan().has(Step::BlendedDepth));
}

/// Two overlapping panes, red at z = -3 and blue at z = -5, alpha 0.6 each, lit alike:
/// seen from the front the red one is drawn last (nearest) and dominates the overlap; from
/// behind, the blue one does. Over: the front pane weighs 0.6, the back one 0.4 x 0.6, so
/// the front colour's channel is 2.5x the back one's in the diffuse light (1.5x asserted).
#[test]
fn panes_swap_order_when_the_camera_crosses() {
    let ctx = gpu();
    let scene = pane_scene(
        false,
        &[(Vec3::new(0.0, 0.0, -3.0), [1.0, 0.0, 0.0, 0.6]), (Vec3::new(0.0, 0.0, -5.0), [0.0, 0.0, 1.0, 0.6])],
    );
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    // Lights on both sides, so each pane is lit from the side the camera sees.
    let lights = LightBuffers::new(
        &ctx.device,
        &[
            Light::point(Vec3::new(0.0, 0.0, 2.0), Vec3::ONE, 40.0, 0.05).unwrap(),
            Light::point(Vec3::new(0.0, 0.0, -10.0), Vec3::ONE, 40.0, 0.05).unwrap(),
        ],
    )
    .unwrap();
    // Inside both panes but off the lights' specular highlight at the centre (the panes
    // span about 64 and 48 pixels).
    let centre = ((H / 2 + 10) * W + W / 2 + 15) as usize;
    let look = |eye: Vec3| -> Frame {
        let mut r = forward(&sg, &lights, Method::ForwardPlus, 1);
        render_frame(ctx, &mut r, &sg, &camera(eye, Vec3::new(0.0, 0.0, -4.0)))
    };
    let front = look(Vec3::new(0.0, 0.0, 3.0)).hdr[centre];
    let back = look(Vec3::new(0.0, 0.0, -11.0)).hdr[centre];
    assert!(front[0] > 1.5 * front[2], "from the front the red pane is on top: {front:?}");
    assert!(back[2] > 1.5 * back[0], "from behind the blue pane is on top: {back:?}");
}

/// Without blended materials nothing of the path exists: no plan step, no memory.
#[test]
fn no_blended_geometry_no_blended_path() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 8, 2, 1)).unwrap();
    let f = forward(&sg, &lights, Method::ForwardPlus, 1);
    assert!(f.outputs().blended.is_none() && !f.plan().has(Step::BlendedDepth));
    assert!(f.memory().entries.iter().all(|(c, _)| !c.starts_with("blended")));
    let d = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings::of(Method::TiledDeferred)).unwrap();
    assert!(d.outputs().blended.is_none() && !d.plan().has(Step::BlendedShade));
    assert!(d.memory().entries.iter().all(|(c, _)| !c.starts_with("blended")));
    // And with blended materials, every part is reported.
    let panes = SceneGpu::new(&ctx.device, &ctx.queue, &three_panes(true)).unwrap();
    let f = forward(&panes, &lights, Method::ForwardPlus, 1);
    for part in ["blended.depth", "blended.layer", "blended.light_grid"] {
        assert!(f.memory().entries.iter().any(|(c, _)| c.starts_with(part)), "{part} is reported");
    }
}

/// Weighted blended OIT against the sorted result on the three panes: an approximation
/// (where panes overlap, its colour is a depth-weighted average, not "over": at 3 m and
/// 4 m the weights differ only 3.2x, so the far pane shows through far more than 0.5
/// alpha allows); coverage is exact (the revealage is the product of `1 - alpha` in any
/// order), so pixels with one pane match. Measured (lavapipe): FLIP mean 0.0079, p99 0.281
/// (the overlap, ~4% of the pixels); limits 0.012 and 0.35. It must differ at all
/// (>1e-4), or the mode did not take effect.
#[test]
fn weighted_oit_approximates_the_sorted_result() {
    use tiledlight_gpu::features::BlendMode;
    let ctx = gpu();
    let scene = three_panes(true);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &lights_for_panes()).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    let frame = |blend, method| {
        let s = FrameSettings { method, knobs: Knobs { blend_mode: blend, ..Knobs::default() }, ..Default::default() };
        let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
        render_frame(ctx, &mut r, &sg, &cam)
    };
    let sorted = frame(BlendMode::Sorted, Method::ForwardPlus);
    let oit = frame(BlendMode::WeightedOit, Method::ForwardPlus);
    let t = tiledlight_tests::images::FlipThresholds { mean: 0.012, percentile: (0.99, 0.35) };
    let r = tiledlight_tests::images::assert_flip("blended-wboit-vs-sorted", W, H, &sorted.ldr, &oit.ldr, t);
    eprintln!("weighted blended OIT vs sorted: FLIP mean {:.4}, p99 {:.4}", r.mean, r.percentile);
    assert!(r.mean > 1e-4, "weighted blended OIT must change the image (FLIP mean {})", r.mean);
    // Tiled Deferred and brute force run the same blended code.
    let knobs = Knobs { blend_mode: BlendMode::WeightedOit, ..Knobs::default() };
    let s = FrameSettings { method: Method::TiledDeferred, knobs, ..Default::default() };
    let mut td = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
    let d = render_frame(ctx, &mut td, &sg, &cam);
    let bf = frame(BlendMode::WeightedOit, Method::BruteForce { cutoff: true });
    assert_matches_reference_frame("blended-wboit-forward", W, &bf, &oit, FORWARD_VS_REFERENCE);
    let bf = bf.allow_gbuffer_normals(&opaque_depth(&sg, &lights, &cam), W, &cam, &lights.packed);
    assert_matches_reference_frame("blended-wboit-deferred", W, &bf, &d, DEFERRED_VS_REFERENCE);
}

/// Reads the display image of one frame of `r`.
fn ldr_of(r: &mut FrameRenderer, sg: &SceneGpu, cam: &Camera) -> Vec<u8> {
    let ctx = gpu();
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, sg, cam).unwrap();
    r.read_ldr(ctx).unwrap()
}

/// The heat map of the blended lists (`HeatmapOf::Blended`), Forward+ and Tiled Deferred:
/// every pixel of a tile whose blended list holds lights is the documented colour for that
/// count blended over the same frame without the heat map, within 2/255 (8-bit sRGB
/// rounding of two images, as in heatmap_and_brdf.rs); every pixel of the other tiles
/// (no blended geometry, or no light reaching it) is the plain frame's within 1/255 (the
/// lists' order may differ between frames: float summation order). The same pass switched
/// to the opaque lists colours wall-only tiles the blended one leaves alone. Asking for the
/// blended heat map of a scene without blended geometry is an error that says so.
#[test]
fn blended_heat_map_colours_exactly_the_tiles_with_blended_lights() {
    use tiledlight_gpu::heatmap::HeatmapOf;
    use tiledlight_tests::images::{assert_heat_tile, documented_heat_colour};
    let ctx = gpu();
    let scene = three_panes(true);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &lights_for_panes()).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    let of = HeatmapOf::Blended;
    let renderers: Vec<(&str, FrameRenderer)> = vec![
        (
            "forward",
            FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings { heatmap_of: of, ..Default::default() })
                .unwrap(),
        ),
        (
            "deferred",
            FrameRenderer::new(
                ctx,
                &sg,
                &lights,
                W,
                H,
                FrameSettings { method: Method::TiledDeferred, heatmap_of: of, ..Default::default() },
            )
            .unwrap(),
        ),
    ];
    for (name, mut r) in renderers {
        let plain = ldr_of(&mut r, &sg, &cam);
        let h = r.heatmap().expect("tiled methods have a heat map");
        assert_eq!(h.of(), HeatmapOf::Blended);
        h.set_enabled(true);
        // Rendering needs the renderer mutably: the pass is looked up again below.
        let heat = ldr_of(&mut r, &sg, &cam);
        let c = r.outputs().blended.unwrap().culling.as_ref().unwrap();
        let blended = c.read_lists(&ctx.device, &ctx.queue).unwrap();
        let capacity = c.options.capacity;
        let g = r.outputs().grid;
        let (mut coloured, mut untouched) = (0, 0);
        for ty in 0..g.tiles_y {
            for tx in 0..g.tiles_x {
                let t = (ty * g.tiles_x + tx) as usize;
                let count = blended.counts[t];
                let expected = documented_heat_colour(count, capacity, blended.lists[t].len() < count as usize);
                let what = format!("{name}: tile ({tx}, {ty}) with {count} blended lights");
                assert_heat_tile(&heat, &plain, W, g.tile_pixels(tx, ty), expected, &what);
                if expected.is_some() {
                    coloured += 1;
                } else {
                    untouched += 1;
                }
            }
        }
        eprintln!("{name}: blended heat map colours {coloured} tiles, leaves {untouched}");
        assert!(coloured > 20 && untouched > 20, "{name}: the frame must show both kinds of tile");
        // The same pass, switched to the opaque lists: tiles without blended lights that
        // the opaque heat map colours (the wall and floor) change now.
        r.heatmap().unwrap().set_of(HeatmapOf::Opaque).unwrap();
        let opaque_heat = ldr_of(&mut r, &sg, &cam);
        let opaque = r.outputs().light_grid.unwrap().read_lists(&ctx.device, &ctx.queue).unwrap();
        let lists_per_tile = opaque.counts.len() / blended.counts.len();
        let wall_only = (0..blended.counts.len())
            .filter(|&t| blended.counts[t] == 0 && opaque.counts[t * lists_per_tile] > 0)
            .filter(|&t| {
                let (x0, x1, y0, y1) = g.tile_pixels(t as u32 % g.tiles_x, t as u32 / g.tiles_x);
                let i = ((((y0 + y1) / 2) * W + (x0 + x1) / 2) * 4) as usize;
                (0..3).any(|ch| opaque_heat[i + ch].abs_diff(heat[i + ch]) > 2)
            })
            .count();
        assert!(wall_only > 20, "{name}: the opaque heat map colours tiles the blended one leaves ({wall_only})");
    }

    // No blended geometry: no blended lists to show, a clear error (no panic).
    let plain = SceneGpu::new(&ctx.device, &ctx.queue, &pane_scene(true, &[])).unwrap();
    let want =
        "the heat map of the blended lists needs blended lists of their own: this scene has no alpha-blended geometry";
    let s = FrameSettings { heatmap: true, heatmap_of: of, ..Default::default() };
    let e = FrameRenderer::new(ctx, &plain, &lights, W, H, s).err().expect("forward: an error").to_string();
    assert!(e.contains(want), "{e}");
    let s = FrameSettings { method: Method::TiledDeferred, heatmap: true, heatmap_of: of, ..Default::default() };
    let e = FrameRenderer::new(ctx, &plain, &lights, W, H, s).err().expect("deferred: an error").to_string();
    assert!(e.contains(want), "{e}");
    let r = forward(&plain, &lights, Method::ForwardPlus, 1);
    let h = r.heatmap().unwrap();
    assert!(!h.has_blended());
    assert!(h.set_of(of).unwrap_err().to_string().contains(want));
    assert_eq!(h.of(), HeatmapOf::Opaque, "a refused switch leaves the grid shown");
}

/// More blended pairs than the blended light grid's first size (32 indices a tile): the
/// first frame drops lights, and the grid must grow until the frame fits, in both
/// methods (it once never grew: every heavy-glass frame lost lights, silently), and the
/// lists must then equal the CPU twin's.
#[test]
fn the_blended_light_grid_grows_until_the_frame_fits() {
    let ctx = gpu();
    let scene = three_panes(true);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    // Radii of 40 m: every light reaches every pane tile (600 x some 100 pairs).
    let mut lights = scenes::lights(&scene, 600, 0, 9);
    for l in &mut lights {
        l.radius = 40.0;
    }
    let lights = LightBuffers::new(&ctx.device, &lights).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    let deferred = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings::of(Method::TiledDeferred)).unwrap();
    let renderers: [FrameRenderer; 2] = [forward(&sg, &lights, Method::ForwardPlus, 1), deferred];
    for mut r in renderers {
        let first = r.outputs().blended.unwrap().culling.as_ref().unwrap().grid.capacity();
        let mut timer = GpuTimer::new(ctx).unwrap();
        r.render_once(ctx, &mut timer, &sg, &cam).unwrap();
        let b = r.outputs().blended.unwrap();
        let c = b.culling.as_ref().unwrap();
        let status = c.grid.status(&ctx.device, &ctx.queue).unwrap();
        assert!(status.header.pairs > first, "{} pairs fit the first {first} indices: nothing had to grow", status);
        assert!(status.complete() && c.grid.capacity() > first, "the blended grid did not grow: {status}");
        let opaque = r.read_depth(ctx).unwrap();
        let blended = read_depth(&ctx.device, &ctx.queue, &b.depth.as_ref().unwrap().texture).unwrap();
        let gpu_lists = c.read_lists(&ctx.device, &ctx.queue).unwrap();
        let frame = CulledFrame { depth: &opaque, width: W, height: H, camera: &cam, lights: &lights.packed };
        let config = c.options.to_config(lights.has_spots());
        assert_blended_lists_match("grown blended grid", &frame, &blended, &gpu_lists, &config);
    }
}

/// The triangles of `scene`'s alpha-blended instances, in world space.
fn blended_triangles(scene: &Scene) -> Vec<[Vec3; 3]> {
    let mut only = scene.clone();
    only.instances.retain(|i| scene.materials[i.material].alpha_mode == AlphaMode::Blend);
    only.world_triangles()
}

/// How far a GPU may place a projected vertex from the exact one, in pixels: Vulkan
/// guarantees at least 4 sub-pixel bits, so snapping moves a vertex by at most 1/16 px per
/// axis even if it truncates (sqrt(2)/16 = 0.088 px), and f32 rounding of a 320 px
/// viewport adds under 1e-4 px. 1/8 px.
const RASTER_REACH: f64 = 0.125;

/// [`lights_for_panes`] and a small light 0.3 m before the front pane (z = -3), reaching
/// it but not the pane behind it (z = -4): in their overlap the list holds it only if the
/// blended depth is the nearest pane's (a pass keeping the farthest or the last drawn
/// depth drops it).
fn lights_with_front_light() -> Vec<Light> {
    let mut l = lights_for_panes();
    let front =
        Light::with_radius(Vec3::new(0.3, 0.2, -2.7), Vec3::ONE, 1.0, 0.4, tiledlight_cull::LightKind::Point).unwrap();
    l.push(front);
    l
}

/// Both tiled methods' blended lists of one frame of `scene`, with the opaque depth:
/// (method, opaque depth samples, GPU lists, culling config).
fn blended_lists_of(
    sg: &SceneGpu,
    lights: &LightBuffers,
    cam: &Camera,
    msaa: u32,
) -> Vec<(&'static str, Vec<f32>, tiledlight_gpu::culling::GpuTileLists, tiledlight_cull::CullConfig)> {
    let ctx = gpu();
    let d = FrameRenderer::new(
        ctx,
        sg,
        lights,
        W,
        H,
        FrameSettings { method: Method::TiledDeferred, msaa, ..Default::default() },
    )
    .expect("deferred renderer");
    let renderers: [(&str, FrameRenderer); 2] =
        [("forward", forward(sg, lights, Method::ForwardPlus, msaa)), ("deferred", d)];
    renderers
        .into_iter()
        .map(|(name, mut r)| {
            let mut timer = GpuTimer::new(ctx).unwrap();
            r.render_once(ctx, &mut timer, sg, cam).unwrap();
            let opaque = r.read_depth(ctx).unwrap();
            assert_eq!(opaque.len(), (W * H * msaa) as usize, "{name}: {msaa} depth samples a pixel");
            let c = r.outputs().blended.expect("blended path").culling.as_ref().expect("blended lists");
            let lists = c.read_lists(&ctx.device, &ctx.queue).unwrap();
            (name, opaque, lists, c.options.to_config(lights.has_spots()))
        })
        .collect()
}

/// The blended lists of Forward+ and Tiled Deferred against lists culled from a blended
/// depth rasterised on the CPU from the pane triangles alone
/// (`tiledlight_cull::blended_depth::raster_depth`), never the GPU's blended depth, at
/// every sample count the adapter has (lavapipe: 1x and 4x), with and without the wall.
///
/// Tolerance, from first principles (`compare_blended_lists_independent`): a GPU
/// rasterises triangles whose vertices it moved by up to [`RASTER_REACH`] (sub-pixel
/// snapping), so a sample within that of a pane's edge may be covered or not, and a
/// covered sample's depth may move by the plane's slope times it. The CPU raster bounds
/// both per sample; every GPU list must hold the list of the certain samples (lights
/// shrunk by their float error) and lie within the list of the possible ones (lights
/// grown). Printed: how many pairs the bounds leave open, and how many GPU pairs differ
/// from the exact raster's. A pass that skips a pane, draws the opaque layer, or keeps
/// another depth than the nearest fails (the front light of [`lights_with_front_light`]).
#[test]
fn blended_lists_match_an_independent_raster() {
    let ctx = gpu();
    let counts = tiledlight_tests::adapter_sample_counts(gpu());
    let lights = LightBuffers::new(&ctx.device, &lights_with_front_light()).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    for wall in [true, false] {
        let scene = three_panes(wall);
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let tris = blended_triangles(&scene);
        assert_eq!(tris.len(), 6, "three panes of two triangles");
        for &msaa in &counts {
            let raster = raster_depth(&cam, (W, H), msaa, &tris, RASTER_REACH).expect("raster");
            for (name, opaque, lists, config) in blended_lists_of(&sg, &lights, &cam, msaa) {
                let label = format!("{name} blended lists vs the CPU raster, wall {wall}, MSAA {msaa}");
                let frame = CulledFrame { depth: &opaque, width: W, height: H, camera: &cam, lights: &lights.packed };
                let c = compare_blended_lists_independent(&label, &frame, &raster, &lists, &config)
                    .unwrap_or_else(|e| panic!("{e}"));
                eprintln!(
                    "{label}: {} pairs, {} lists that must hold lights, {} pairs left open by the bounds, \
                     {} GPU pairs off the exact raster's",
                    c.pairs, c.certain_lists, c.open_pairs, c.off_exact
                );
                assert!(c.certain_lists > 20, "{label}: the panes must cover tiles ({} lists)", c.certain_lists);
                // The bounds are tight: open pairs come only from silhouette tiles.
                assert!(c.open_pairs * 5 < c.pairs, "{label}: {} of {} pairs open", c.open_pairs, c.pairs);
            }
        }
    }
}

/// Negative tests of the independent check: one pane missing from the CPU raster (the GPU
/// then holds lights where no blended sample can be), and one pane missing from the GPU's
/// frame (its lists lack lights the raster requires, as a blended depth pass skipping an
/// instance would), each pane in turn, must be rejected.
#[test]
fn the_independent_blended_check_rejects_a_missing_pane() {
    let ctx = gpu();
    let lights = LightBuffers::new(&ctx.device, &lights_with_front_light()).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    let scene = three_panes(true);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let tris = blended_triangles(&scene);
    let full = raster_depth(&cam, (W, H), 1, &tris, RASTER_REACH).unwrap();
    let gpu_full = blended_lists_of(&sg, &lights, &cam, 1);
    for pane in 0..3 {
        let mut fewer = tris.clone();
        fewer.drain(2 * pane..2 * pane + 2);
        let raster = raster_depth(&cam, (W, H), 1, &fewer, RASTER_REACH).unwrap();
        for (name, opaque, lists, config) in &gpu_full {
            let frame = CulledFrame { depth: opaque, width: W, height: H, camera: &cam, lights: &lights.packed };
            let label = format!("{name}: the raster without pane {pane}");
            let e = compare_blended_lists_independent(&label, &frame, &raster, lists, config)
                .expect_err("a raster missing a pane must be rejected");
            eprintln!("rejected: {e}");
            assert!(e.contains("reaches no range"), "{e}");
        }
        // The GPU frame without the pane (its blended depth lacks it), against the full raster.
        let mut without = scene.clone();
        let blended: Vec<usize> = (0..scene.instances.len())
            .filter(|&i| scene.materials[scene.instances[i].material].alpha_mode == AlphaMode::Blend)
            .collect();
        without.instances.remove(blended[pane]);
        let sg_without = SceneGpu::new(&ctx.device, &ctx.queue, &without).unwrap();
        for (name, opaque, lists, config) in blended_lists_of(&sg_without, &lights, &cam, 1) {
            let frame = CulledFrame { depth: &opaque, width: W, height: H, camera: &cam, lights: &lights.packed };
            let label = format!("{name}: a GPU frame without pane {pane}");
            let e = compare_blended_lists_independent(&label, &frame, &full, &lists, &config)
                .expect_err("lists of a blended depth missing a pane must be rejected");
            eprintln!("rejected: {e}");
            assert!(e.contains("lacks light"), "{e}");
        }
    }
}

/// The three panes before the wall and a 1 m opaque plate at y = 1.5 between the spot
/// light and the front pane: its shadow falls on the pane's upper right quarter (panes
/// themselves cast no shadow: the shadow passes draw opaque geometry only).
fn panes_under_a_plate() -> Scene {
    let mut scene = three_panes(true);
    let plate = Mat4::from_translation(Vec3::new(0.5, 1.5, -1.5)) * Mat4::from_scale(Vec3::splat(0.5));
    scene.instances.push(Instance { mesh: 1, material: 0, transform: plate });
    scene.bounds = scene.compute_bounds();
    scene.validate().expect("plate scene");
    scene
}

/// Blended geometry with shadows and VPLs, at every sample count the adapter has
/// (lavapipe: 1x and 4x; the H200 run adds 2x and 8x): Forward+ and Tiled Deferred against
/// brute force with the same shadow casters (the brightest point light and the spot) and
/// VPLs, with compare.rs's tolerances (FORWARD_VS_REFERENCE: the same lookups and blending,
/// summation order only; DEFERRED_VS_REFERENCE with the f16-normal allowance: its opaque
/// layer's G-buffer; FLIP only where hardware MSAA and deferred sample a pixel
/// differently by design, `compare::msaa_by_design`, as in `msaa.rs`: measured without
/// it, 5.7e-2 at one 4x wall pixel by the floor that deferred shades per sample). First, that the features are live on the panes: the plate's shadow
/// darkens the front pane (brute force with casters vs without), and the VPLs brighten part
/// of the frame (with vs without VPLs).
#[test]
fn blended_geometry_with_shadows_and_vpls_at_every_sample_count() {
    use tiledlight_cull::shadow::ShadowOptions;
    use tiledlight_cull::vpl::VplConfig;
    let ctx = gpu();
    let scene = panes_under_a_plate();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let light_list = lights_for_panes();
    let casting = LightBuffers::with_casters(&ctx.device, &light_list, (1, 1)).unwrap();
    let plain = LightBuffers::new(&ctx.device, &light_list).unwrap();
    let cam = camera(Vec3::new(0.5, 0.5, 4.0), Vec3::new(0.0, 0.0, -10.0));
    let shadows = ShadowOptions::default();
    let vpl = Some(VplConfig::default());
    let bf = Method::BruteForce { cutoff: true };
    let frame = |lights: &LightBuffers, method, msaa, vpl| {
        let s = FrameSettings { method, msaa, shadows, vpl, ..Default::default() };
        let mut r = FrameRenderer::new(ctx, &sg, lights, W, H, s).expect("forward renderer");
        render_frame(ctx, &mut r, &sg, &cam)
    };
    // The features are live: the shadow on the front pane, light from the VPLs.
    let unshadowed = frame(&plain, bf, 1, None);
    let shadowed = frame(&casting, bf, 1, None);
    let at = |p: Vec3| {
        let c = cam.view_proj() * p.extend(1.0);
        let (x, y) = ((c.x / c.w + 1.0) * 0.5 * W as f32, (1.0 - c.y / c.w) * 0.5 * H as f32);
        y as usize * W as usize + x as usize
    };
    let pane = at(Vec3::new(0.6, 0.5, -3.0));
    let (lit, dark) = (unshadowed.hdr[pane], shadowed.hdr[pane]);
    eprintln!("front pane in the plate's shadow: {lit:?} unshadowed, {dark:?} shadowed");
    assert!(dark[0] < 0.9 * lit[0], "the plate's shadow must darken the front pane: {dark:?} vs {lit:?}");
    let with_vpls = frame(&casting, bf, 1, vpl);
    let brighter = with_vpls.hdr.iter().zip(&shadowed.hdr).filter(|(a, b)| a[0] > 1.01 * b[0] + 1e-4).count();
    eprintln!("{brighter} pixels brightened by VPLs");
    assert!(brighter > 1000, "VPLs must light part of the frame ({brighter} pixels)");
    // One depth per pixel for Tiled Deferred's G-buffer-normal allowance.
    let depth = opaque_depth(&sg, &casting, &cam);
    for msaa in tiledlight_tests::adapter_sample_counts(gpu()) {
        let s = FrameSettings { method: bf, msaa, shadows, vpl, ..Default::default() };
        let mut b = FrameRenderer::new(ctx, &sg, &casting, W, H, s).expect("brute force");
        let reference = render_frame(ctx, &mut b, &sg, &cam);
        let reference_depth = b.read_depth(ctx).unwrap();
        let fp = frame(&casting, Method::ForwardPlus, msaa, vpl);
        let what = format!("blended-shadows-vpls-forward-msaa{msaa}");
        assert_matches_reference_frame(&what, W, &reference, &fp, FORWARD_VS_REFERENCE);
        let s = FrameSettings { method: Method::TiledDeferred, msaa, shadows, vpl, ..Default::default() };
        let mut td = FrameRenderer::new(ctx, &sg, &casting, W, H, s).expect("deferred renderer");
        assert!(td.vpls().map(|v| &v.path).is_some() && td.plan().has(Step::BlendedShade));
        let d = render_frame(ctx, &mut td, &sg, &cam);
        let reference = reference.allow_gbuffer_normals(&depth, W, &cam, &casting.packed);
        let edges = if msaa > 1 {
            td.passes::<DeferredFrame>()
                .expect("Tiled Deferred")
                .shading()
                .read_edge_list(&ctx.device, &ctx.queue)
                .unwrap()
        } else {
            Vec::new()
        };
        let depths = (&reference_depth[..], &td.read_depth(ctx).unwrap()[..]);
        let (reference, forgiven) = reference.forgive_hdr(&msaa_by_design(W, depths, msaa, &edges));
        eprintln!("{msaa}x: {forgiven} pixels compared by FLIP only ({} deferred edge pixels)", edges.len());
        assert!(forgiven * 10 < (W * H) as usize, "{msaa}x: {forgiven} pixels forgiven");
        let what = format!("blended-shadows-vpls-deferred-msaa{msaa}");
        assert_matches_reference_frame(&what, W, &reference, &d, DEFERRED_VS_REFERENCE);
        // The visibility buffer: blended geometry through the same forward path after its
        // compute shading, shadows and VPLs from the same atlas and grid; each raster.
        for raster in visibility_rasters(msaa) {
            let s = FrameSettings {
                method: Method::Visibility,
                msaa,
                shadows,
                vpl,
                knobs: Knobs { raster, ..Knobs::default() },
                ..Default::default()
            };
            let mut vr = FrameRenderer::new(ctx, &sg, &casting, W, H, s).expect("visibility renderer");
            assert!(vr.vpls().is_some() && vr.plan().has(Step::BlendedShade));
            let v = render_frame(ctx, &mut vr, &sg, &cam);
            let edges = if msaa > 1 {
                vr.passes::<tiledlight_frame::VisibilityFrame>()
                    .expect("visibility buffer")
                    .shading()
                    .read_edge_list(&ctx.device, &ctx.queue)
                    .unwrap()
            } else {
                Vec::new()
            };
            let s = FrameSettings { method: bf, msaa, shadows, vpl, ..Default::default() };
            let mut b = FrameRenderer::new(ctx, &sg, &casting, W, H, s).expect("brute force");
            let reference = render_frame(ctx, &mut b, &sg, &cam).allow_position_error(
                &depth,
                W,
                (&cam, &casting.packed),
                RASTER_POSITION_ERROR_PX,
            );
            let depths = (&reference_depth[..], &vr.read_depth(ctx).unwrap()[..]);
            let (reference, forgiven) = reference.forgive_hdr(&msaa_by_design(W, depths, msaa, &edges));
            assert!(forgiven * 10 < (W * H) as usize, "{msaa}x: {forgiven} pixels forgiven");
            let what = format!("blended-shadows-vpls-visibility-{}-msaa{msaa}", raster.name());
            assert_visibility_matches(&what, W, (&reference, &v), msaa > 1);
        }
    }
}
