//! Settings that must not change the image, checked for taking effect (issue 43, class 6).
//! Their image tests (`early_outs.rs`, `draw_order.rs`, `layouts.rs`, `compute_raster.rs`)
//! pass just as well when the setting never reaches the GPU; these read what was built or
//! recorded instead:
//!
//! - **The early-outs' ablation** (`--no-early-outs`): the `EARLY_OUTS` pipeline constant
//!   every lighting pipeline was built with (`constants()` of Forward+'s and brute force's
//!   shading, Tiled Deferred's and the visibility buffer's shading, the blended shading):
//!   false (0) with the ablation, left at the shader's default (true) without it, next to
//!   the shadow filter's `SHADOW_RADIUS`, which must survive either way.
//! - **The draw order** (`--draw-order`): the order the last frame gave its pre-pass or
//!   G-buffer (`FrameRenderer::last_draw_order`) is nearest first by this test's own
//!   distances (instance bounds' centres to the eye), for the eye of that frame, sorted
//!   again when the eye moves; none in the instance buffer's order. The depth pre-pass's
//!   draw calls (`DepthPrepass::drawn_last`: one call per run of consecutive instance slots)
//!   are those of the order given, which breaks the grid objects' draw into more runs
//!   than the instance buffer's order (so the pass really drew in that order).
//! - **Light-centric assignment** (`cull.scatter`), **the visibility buffer's raster**
//!   (`Raster`) and **who draws the compute raster's large triangles** (`LargeRaster`):
//!   the passes a frame ran, by the GPU timer's pass labels (timestamps: lavapipe has them).
//!   Scatter runs the assignment's passes (`*.cull.count`, `*.cull.write`, ...) and no
//!   tile-centric `*.cull`; the compute raster its kernels (`visibility.raster.compute`,
//!   `.finalize`), the hardware raster none of them; large triangles by compute run
//!   `visibility.raster.large` and no hardware pass (no masked material in the scene), by
//!   the hardware the reverse.
//!
//! The G-buffer's target count is already seen taking effect (`negative.rs`, its extra
//! targets' test values).

use glam::Vec3;
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_cull::Camera;
use tiledlight_frame::{
    DeferredFrame, Diagnostics as _, ForwardFrame, FrameRenderer, FrameSettings, Method, VisibilityFrame,
};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::draw_order::{DrawOrder, DrawOrderMode};
use tiledlight_gpu::features::Raster;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::{default_scene, AlphaMode, DefaultSceneOptions, Instance, Scene};
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::{gpu, scenes};
use tiledlight_visibility::compute_raster::LargeRaster;

const W: u32 = 128;
const H: u32 = 72;

/// The value of pipeline constant `name` in `constants`, if set.
fn constant(constants: &[(String, f64)], name: &str) -> Option<f64> {
    constants.iter().find(|(k, _)| k == name).map(|&(_, v)| v)
}

/// Whether `constants` build the early-outs in: `EARLY_OUTS` unset (the WGSL default,
/// `override EARLY_OUTS: bool = true`) or set non-zero.
fn early_outs_in(constants: &[(String, f64)]) -> bool {
    constant(constants, "EARLY_OUTS").is_none_or(|v| v != 0.0)
}

/// The mixed scene with one alpha-blended pane (the blended path and its shading exist).
fn scene_with_a_pane() -> Scene {
    let mut scene = scenes::mixed_scene();
    let mut glass = scenes::material("glass", [0.3, 0.5, 0.9, 0.4], 0.3, 0.0);
    glass.alpha_mode = AlphaMode::Blend;
    glass.double_sided = true;
    scene.materials.push(glass);
    let upright = glam::Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let transform = glam::Mat4::from_translation(Vec3::new(1.0, 1.5, 4.0)) * upright;
    scene.instances.push(Instance { mesh: 2, material: scene.materials.len() - 1, transform });
    scene.validate().expect("scene with a pane");
    scene
}

/// Every pipeline that shades lights, by name, with the constants it was built with.
fn lighting_constants(r: &FrameRenderer) -> Vec<(&'static str, Vec<(String, f64)>)> {
    let mut out = Vec::new();
    if let Some(f) = r.passes::<ForwardFrame>() {
        out.push(("forward/brute-force shading", f.shading().constants().to_vec()));
    }
    if let Some(d) = r.passes::<DeferredFrame>() {
        out.push(("deferred shading", d.shading().constants().to_vec()));
    }
    if let Some(v) = r.passes::<VisibilityFrame>() {
        out.push(("visibility shading", v.shading().constants().to_vec()));
    }
    if let Some(b) = r.outputs().blended {
        out.push(("blended shading", b.constants().to_vec()));
    }
    out
}

/// `--no-early-outs` reaches every lighting pipeline of every method, and only it: the
/// pipelines are built with `EARLY_OUTS` = 0 with the ablation and without the constant
/// otherwise; `SHADOW_RADIUS` (one point caster) stays in both. Each method must have its
/// own shading pipeline and the blended one (the scene has a pane).
#[test]
fn the_early_outs_ablation_reaches_every_lighting_pipeline() {
    let ctx = gpu();
    let scene = scene_with_a_pane();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights =
        LightBuffers::with_casters(&ctx.device, &scenes::lights_in_slab(&scene, 2.0, 4.0, 8, 4, 3), (1, 0)).unwrap();
    let shadows = ShadowOptions { tile_size: 128, ..Default::default() };
    let radius = f64::from(shadows.filter.radius());
    for method in [Method::ForwardPlus, Method::TiledDeferred, Method::Visibility, Method::BruteForce { cutoff: true }]
    {
        for early_outs in [true, false] {
            let s = FrameSettings {
                method,
                knobs: Knobs { early_outs, ..Knobs::default() },
                shadows,
                ..Default::default()
            };
            let r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
            let pipelines = lighting_constants(&r);
            let what = format!("{}, early-outs {early_outs}", method.label());
            assert_eq!(pipelines.len(), 2, "{what}: its shading and the blended shading: {pipelines:?}");
            for (name, constants) in &pipelines {
                assert_eq!(early_outs_in(constants), early_outs, "{what}: {name} was built with {constants:?}");
                assert_eq!(constant(constants, "SHADOW_RADIUS"), Some(radius), "{what}: {name}: {constants:?}");
            }
        }
    }
}

/// Draw calls of `order` over `sg`'s opaque draws with every instance visible: one per run
/// of consecutive instance slots (`SceneGpu::record_draws_of`).
fn calls_of(sg: &SceneGpu, order: &DrawOrder) -> u32 {
    let opaque: Vec<_> = sg.opaque_kinds();
    sg.draws
        .iter()
        .filter(|d| opaque.contains(&d.kind))
        .map(|d| order.runs(d.instances.clone(), None).len() as u32)
        .sum()
}

/// Asserts `order` draws every draw's instances nearest first from `eye`, by distances
/// computed here from the instance bounds (squared distance of the centre to the eye, ties by slot).
fn assert_nearest_first(sg: &SceneGpu, order: &DrawOrder, eye: Vec3, what: &str) {
    let distance = |slot: u32| {
        let (lo, hi) = sg.instance_bounds[slot as usize];
        ((lo + hi) * 0.5).distance_squared(eye)
    };
    for d in &sg.draws {
        let slots: Vec<u32> = order.runs(d.instances.clone(), None).into_iter().flatten().collect();
        let mut expected: Vec<u32> = d.instances.clone().collect();
        expected.sort_by(|&a, &b| distance(a).total_cmp(&distance(b)).then(a.cmp(&b)));
        assert_eq!(slots, expected, "{what}: a draw's instances are not nearest first from {eye}");
    }
}

/// `--draw-order` reaches the frame: with nearest first (the default) the last frame's
/// pre-pass or G-buffer was given the order sorted for that frame's eye, nearest first by
/// this test's distances, and sorted again after the eye moved; Forward+'s and brute
/// force's pre-pass recorded that order's draw calls, more than the instance buffer's
/// order has (the case can tell them apart). With the instance buffer's order no order is
/// given and the pre-pass records its calls.
#[test]
fn the_draw_order_reaches_the_passes() {
    let ctx = gpu();
    let scene = default_scene(&DefaultSceneOptions { grid_objects: 40, ..Default::default() }).unwrap();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 64, 0, 5)).unwrap();
    let first = scenes::courtyard_camera(&scene, W, H);
    let c = scene.camera.unwrap();
    let second = Camera::perspective(
        c.target + (c.eye - c.target) * Vec3::new(-1.0, 1.0, -0.5),
        c.target,
        c.up,
        c.fov_y,
        W as f32 / H as f32,
        c.near,
        c.far,
    )
    .unwrap();
    let submission_calls = calls_of(&sg, &sg.submission);
    for method in [Method::ForwardPlus, Method::BruteForce { cutoff: true }, Method::TiledDeferred] {
        let mut sorted_calls = Vec::new();
        for mode in [DrawOrderMode::FrontToBack, DrawOrderMode::Submission] {
            let s =
                FrameSettings { method, knobs: Knobs { draw_order: mode, ..Knobs::default() }, ..Default::default() };
            let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
            for cam in [&first, &second] {
                render_frame(ctx, &mut r, &sg, cam);
                let what = format!("{}, {}, eye {}", method.label(), mode.label(), cam.eye());
                let given = r.last_draw_order();
                let order = match (mode, &given) {
                    (DrawOrderMode::FrontToBack, Some((eye, order))) => {
                        assert_eq!(*eye, cam.eye(), "{what}: the order was sorted for another eye");
                        assert_nearest_first(&sg, order, cam.eye(), &what);
                        sorted_calls.push(calls_of(&sg, order));
                        order
                    }
                    (DrawOrderMode::Submission, None) => &sg.submission,
                    _ => panic!("{what}: the frame was given {:?}", given.map(|(eye, _)| eye)),
                };
                if let Some(f) = r.passes::<ForwardFrame>() {
                    let drawn = f.prepass().drawn_last();
                    assert_eq!(drawn.calls, calls_of(&sg, order), "{what}: the pre-pass drew another order");
                    assert_eq!(drawn.instances as usize, scene.instances.len(), "{what}: instances drawn");
                }
            }
        }
        assert!(
            sorted_calls.iter().all(|&c| c > submission_calls),
            "{}: nearest first must take more draw calls ({sorted_calls:?}) than the instance buffer's order \
             ({submission_calls}) for the pre-pass's count to tell them apart",
            method.label()
        );
    }
}

/// The labels of the passes a frame of `r` ran (the GPU timer's, of the last finished
/// frame out of four).
fn passes_run(r: &mut FrameRenderer, sg: &SceneGpu, camera: &Camera) -> Vec<String> {
    let ctx = gpu();
    assert!(ctx.timestamps, "this test reads the passes from the GPU timer: the adapter needs TIMESTAMP_QUERY");
    let mut timer = GpuTimer::new(ctx).unwrap();
    let mut last = None;
    for _ in 0..4 {
        r.render_once(ctx, &mut timer, sg, camera).unwrap();
        last = std::iter::from_fn(|| timer.finished_frame()).last().or(last);
    }
    last.expect("a finished frame").into_iter().map(|t| t.label).collect()
}

/// Asserts each of `want` is among `labels` and none of `not`.
fn assert_passes(labels: &[String], want: &[&str], not: &[&str], what: &str) {
    for w in want {
        assert!(labels.iter().any(|l| l == w), "{what}: no pass {w} in {labels:?}");
    }
    for n in not {
        assert!(!labels.iter().any(|l| l == n), "{what}: pass {n} ran: {labels:?}");
    }
}

/// Light-centric assignment (`cull.scatter`) runs the assignment's passes instead of the
/// tile-centric culling pass, in every tiled method; the tile-centric default the reverse.
#[test]
fn light_centric_assignment_runs_its_passes() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights_in_slab(&scene, 0.5, 3.5, 32, 8, 9)).unwrap();
    let camera = scenes::mixed_camera(W, H);
    for (method, cull) in [
        (Method::ForwardPlus, "forward.cull"),
        (Method::TiledDeferred, "deferred.assign"),
        (Method::Visibility, "visibility.cull"),
    ] {
        for scatter in [false, true] {
            let s =
                FrameSettings { method, cull: CullOptions { scatter, ..CullOptions::default() }, ..Default::default() };
            let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
            let labels = passes_run(&mut r, &sg, &camera);
            let what = format!("{}, scatter {scatter}", method.label());
            let assignment = ["count", "allocate", "write"].map(|step| format!("{cull}.{step}"));
            let assignment: Vec<&str> = assignment.iter().map(String::as_str).collect();
            if scatter {
                // Tiled Deferred's own pass then only shades; the others have no tile pass.
                let gather: &[&str] = if method == Method::TiledDeferred { &[] } else { &[cull] };
                assert_passes(&labels, &assignment, gather, &what);
            } else if method == Method::TiledDeferred {
                assert_passes(&labels, &["deferred.shade"], &assignment, &what);
            } else {
                assert_passes(&labels, &[cull], &assignment, &what);
            }
        }
    }
}

/// The visibility buffer's raster is the one asked for: the compute raster runs its
/// kernels (and, with large triangles by compute and no masked material, no hardware
/// pass; by the hardware, its pass and no large kernel), the hardware raster none of them.
/// `Raster::Auto` on lavapipe is the hardware raster ([`Raster::pick`]: the compute raster
/// is the slower there), elsewhere as picked.
#[test]
fn the_visibility_raster_is_the_one_asked_for() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 32, 0, 2)).unwrap();
    let camera = scenes::courtyard_camera(&scene, W, H);
    assert!(!sg.draws.iter().any(|d| d.kind.masked), "the courtyard must have no masked material");
    let compute = ["visibility.raster.compute", "visibility.raster.finalize"];
    let cases = [
        (Raster::Compute, LargeRaster::Compute),
        (Raster::Compute, LargeRaster::Hardware),
        (Raster::Hardware, LargeRaster::Compute),
        (Raster::Auto, LargeRaster::Compute),
    ];
    for (raster, large) in cases {
        let knobs = Knobs { raster, raster_large: large, ..Knobs::default() };
        let s = FrameSettings { method: Method::Visibility, knobs, ..Default::default() };
        let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
        let built = r.settings().knobs.raster;
        let what = format!("raster {} (built {}), large by {}", raster.name(), built.name(), large.name());
        let expected = raster.pick(ctx.info.device_type, ctx.device.features(), 1);
        assert_eq!(built, expected, "{what}");
        if tiledlight_tests::is_lavapipe(ctx) && raster == Raster::Auto {
            assert_eq!(built, Raster::Hardware, "{what}: lavapipe's pick");
        }
        let has_compute = r.passes::<VisibilityFrame>().unwrap().raster().compute().is_some();
        assert_eq!(has_compute, built == Raster::Compute, "{what}: the raster pass built");
        let labels = passes_run(&mut r, &sg, &camera);
        match (built, large) {
            (Raster::Compute, LargeRaster::Compute) => assert_passes(
                &labels,
                &[compute[0], compute[1], "visibility.raster.large"],
                &["visibility.raster.hardware"],
                &what,
            ),
            (Raster::Compute, _) => assert_passes(
                &labels,
                &[compute[0], compute[1], "visibility.raster.hardware"],
                &["visibility.raster.large"],
                &what,
            ),
            _ => assert_passes(&labels, &[], &[compute[0], compute[1], "visibility.raster.large"], &what),
        }
    }
}

/// The visibility buffer's light staging (on by default, `--no-stage-lights` off; the `STAGE_LIGHTS` pipeline
/// constant of `shaders/common/assigned_shade.wgsl`): built in with tile lists only (half-z
/// and clusters give a workgroup several lists: built without it), and the image the same
/// as without it on a frame whose tiles hold both fewer and more lights than the stage's 256
/// (so both the staged records and those read from the light buffer are shaded). Bit for
/// bit on lavapipe; within an f16 step on a parallel GPU (a tile's list order, and with it
/// the summation order, varies from run to run).
#[test]
fn light_staging_reaches_the_visibility_pass_and_changes_no_pixel() {
    use tiledlight_tests::compare::assert_same_hdr;
    let ctx = gpu();
    let scene = default_scene(&DefaultSceneOptions { grid_objects: 40, ..Default::default() }).unwrap();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 4000, 400, 11)).unwrap();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let frame = |stage_lights, cull| {
        let knobs = Knobs { stage_lights, ..Knobs::default() };
        let s = FrameSettings { method: Method::Visibility, cull, knobs, ..Default::default() };
        let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
        let hdr = render_frame(ctx, &mut r, &sg, &camera).hdr;
        let shading = r.passes::<VisibilityFrame>().expect("visibility buffer").shading();
        (hdr, constant(shading.constants(), "STAGE_LIGHTS"), r.read_lists(ctx).unwrap().counts)
    };
    let (off, built_off, _) = frame(false, CullOptions::default());
    let (on, built_on, counts) = frame(true, CullOptions::default());
    assert_eq!((built_off, built_on), (None, Some(1.0)), "STAGE_LIGHTS follows the row");
    let (few, many) =
        (counts.iter().filter(|&&c| (1..=256).contains(&c)).count(), counts.iter().filter(|&&c| c > 256).count());
    assert!(few > 0 && many > 0, "tiles below and above the stage: {few} and {many} ({counts:?})");
    assert_same_hdr(&off, &on, W, tiledlight_tests::is_lavapipe(ctx), "the visibility buffer with and without staging");
    let (_, built_half_z, _) = frame(true, CullOptions { half_z: true, ..CullOptions::default() });
    assert_eq!(built_half_z, None, "half-z gives a workgroup two lists: no staging");
}
