//! State a renderer carries from one frame to the next, over three frames with the camera
//! AND the lights moving between them, each frame compared with a fresh renderer built for
//! that frame's camera and lights (issue 43, class 5: tests of one frame or of a new
//! renderer never see a reset skipped, a sort or a redraw not redone, or a grown buffer
//! not bound):
//!
//! - **The compute raster** (visibility buffer, `Raster::Compute`): its 64-bit texels and
//!   its large-triangle list are reset by the finalize kernel at the end of each frame (no
//!   clear pass). A single-sided wall, large enough for the large list, faces the first
//!   two cameras and shows its back to the third: a large list kept from an earlier frame
//!   would draw it there (the large kernel does not cull back faces: the cluster pass did),
//!   and kept texels would keep nearer depths of the frame before.
//! - **The draw order** (`DrawOrderMode::FrontToBack`, Tiled Deferred's G-buffer): sorted
//!   again when the eye moves. Two coplanar plates tie exactly in depth under a camera
//!   looking straight down, so the later draw keeps the pixel (`draw_order.rs`); the eye
//!   moves so that the nearer plate changes from frame to frame, and an order kept from
//!   an earlier eye shows the other plate.
//! - **Shadow faces and VPLs** (Forward+ and Tiled Deferred): after the lights move (their
//!   buffers rewritten and `Renderer::lights_moved`, as the viewer's animation does) the
//!   moved casters' faces are drawn again and the VPLs generated again.
//! - **The light grid growing** (Forward+, Tiled Deferred, visibility buffer): the lights
//!   come down into the view, so each frame needs more tile-light pairs than the grid of
//!   the frame before holds; it grows (asserted) and the frame is drawn with the bigger
//!   grid bound everywhere it is read. The fresh renderer has a fixed budget that holds
//!   every frame (it never grows), and neither drops a pair (asserted).
//!
//! Comparison: on lavapipe bit for bit (`compare::assert_same_hdr`; the same kernels on
//! the same inputs run the same way every time there); on a parallel GPU one f16 step (a
//! list's order, and with it the summation order, varies from run to run), and the frames
//! with VPLs within `FORWARD_VS_REFERENCE` (their generation appends VPLs with an atomic
//! counter, so their order and the lists' differ between runs there: `vpl.rs` does the
//! same). The compute raster's IDs and depths are exact everywhere (an `atomicMax` of the
//! same values ends the same in any order).
//!
//! 160x90 (a quarter of the usual 320x180: each case draws six to eighteen frames).

use std::f32::consts::FRAC_PI_2;

use glam::{Mat4, Quat, Vec3};
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_cull::vpl::VplConfig;
use tiledlight_cull::{Camera, Light, LightKind};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method, VisibilityFrame};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::draw_order::DrawOrderMode;
use tiledlight_gpu::features::Raster;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::{random_lights, Aabb, Instance, LightOptions, Material, Scene, DEFAULT_INTENSITY_RANGE};
use tiledlight_tests::compare::{assert_matches_reference_frame, assert_same_hdr, render_frame, FORWARD_VS_REFERENCE};
use tiledlight_tests::{gpu, is_lavapipe, scenes};

const W: u32 = 160;
const H: u32 = 90;
/// Frames each case draws on one renderer.
const FRAMES: usize = 3;

/// A camera at `eye` looking at `target` (55 degrees, no far plane).
fn camera(eye: Vec3, target: Vec3, up: Vec3) -> Camera {
    Camera::perspective(eye, target, up, 55f32.to_radians(), W as f32 / H as f32, 0.1, None).expect("camera")
}

/// Lights in the slab between heights `y0` and `y1` over `scene`'s footprint, four times
/// the default intensities (radii 3 m to 8 m): with tens of lights, the default radii
/// leave most of a 160x90 frame of the walled scene unlit, and an unlit pixel tests no
/// light state.
fn bright_lights(scene: &Scene, (y0, y1): (f32, f32), n_point: u32, n_spot: u32, seed: u64) -> Vec<Light> {
    let b = &scene.bounds;
    let slab = Aabb::new(Vec3::new(b.min.x, y0, b.min.z), Vec3::new(b.max.x, y1, b.max.z));
    let (lo, hi) = DEFAULT_INTENSITY_RANGE;
    let options = LightOptions {
        num_point: n_point,
        num_spot: n_spot,
        seed,
        intensity_range: (4.0 * lo, 4.0 * hi),
        ..Default::default()
    };
    random_lights(&slab, &options).expect("lights")
}

/// `lights` turned by `angle` about the vertical axis through the origin (positions and
/// spot directions): how each frame moves them. The carried renderers start from
/// `moved(base, 0)` too: renormalising a spot direction can move its last bit, and frame
/// 0's carried and fresh lights must be the same bits.
fn moved(lights: &[Light], angle: f32) -> Vec<Light> {
    let rot = Quat::from_rotation_y(angle);
    lights
        .iter()
        .map(|l| {
            let mut l = *l;
            l.position = rot * l.position;
            if let LightKind::Spot { direction, .. } = &mut l.kind {
                *direction = (rot * *direction).normalize();
            }
            l
        })
        .collect()
}

/// Moves the lights of a renderer built over `carried` to those of `now` as a program
/// does: the same buffers rewritten in place, then `Renderer::lights_moved` (which marks
/// the moved casters' faces and the VPLs for the next frame).
fn move_lights(r: &FrameRenderer, carried: &mut LightBuffers, now: &LightBuffers) {
    let ctx = gpu();
    let p = &now.packed;
    assert_eq!((p.len(), p.num_point), (carried.packed.len(), carried.packed.num_point), "same light counts");
    ctx.queue.write_buffer(&carried.cull, 0, bytemuck::cast_slice(&p.cull));
    ctx.queue.write_buffer(&carried.shading, 0, bytemuck::cast_slice(&p.shading));
    if let Some(spots) = &carried.spots {
        ctx.queue.write_buffer(spots, 0, bytemuck::cast_slice(&p.spots));
    }
    carried.packed = p.clone();
    r.lights_moved(&ctx.queue, p).expect("lights moved");
}

/// The mixed scene with a single-sided wall (the box material, not double-sided) standing
/// at z = 5, facing +z, 4 m wide: 45-75 px across at 160x90, past the compute raster's
/// 32 px large-triangle bound.
fn walled_scene() -> Scene {
    let mut scene = scenes::mixed_scene();
    assert!(!scene.materials[1].double_sided, "the wall must be single-sided");
    scene.meshes.push(scenes::quad("wall", 4.0));
    let upright = Mat4::from_rotation_x(FRAC_PI_2);
    let transform = Mat4::from_translation(Vec3::new(0.5, 2.0, 5.0)) * upright;
    scene.instances.push(Instance { mesh: scene.meshes.len() - 1, material: 1, transform });
    scene.bounds = scene.compute_bounds();
    scene.bounds.max.y = scene.bounds.max.y.max(4.0);
    scene.validate().expect("walled scene");
    scene
}

/// The three cameras of the walled scene: in front of the wall, to its side, behind it
/// (its back face towards the eye, the floor beyond it in view).
fn walled_cameras() -> [Camera; FRAMES] {
    [
        camera(Vec3::new(3.0, 3.0, 12.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y),
        camera(Vec3::new(9.0, 4.0, 3.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y),
        camera(Vec3::new(-1.0, 2.5, -8.0), Vec3::new(0.5, 1.5, 6.0), Vec3::Y),
    ]
}

/// Compares a carried frame with the fresh one: bit for bit on lavapipe, one f16 step
/// elsewhere (module doc).
fn assert_same_frame(carried: &[[f32; 4]], fresh: &[[f32; 4]], what: &str) {
    let lit = fresh.iter().filter(|p| p[0] + p[1] + p[2] > 0.05).count();
    assert!(lit * 4 > fresh.len(), "{what}: the frame is mostly unlit ({lit} lit pixels): it tests nothing");
    assert_same_hdr(carried, fresh, W, is_lavapipe(gpu()), what);
}

/// The compute raster over three frames of a moving camera and moving lights: each
/// frame's triangle IDs and depths are a fresh renderer's bit for bit, its HDR image the
/// same (module doc). The back of the wall in the third frame catches a large list that
/// is not emptied; a texel reset skipped (or done only once) keeps the nearer depth of the
/// frame before.
#[test]
fn the_compute_raster_starts_every_frame_clean() {
    let ctx = gpu();
    let scene = walled_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let base = bright_lights(&scene, (2.0, 4.0), 24, 8, 43);
    let settings = FrameSettings {
        method: Method::Visibility,
        knobs: Knobs { raster: Raster::Compute, ..Knobs::default() },
        ..Default::default()
    };
    let mut carried_lights = LightBuffers::new(&ctx.device, &moved(&base, 0.0)).unwrap();
    let mut carried = FrameRenderer::new(ctx, &sg, &carried_lights, W, H, settings).unwrap();
    assert_eq!(carried.settings().knobs.raster, Raster::Compute);
    let read = |r: &FrameRenderer| {
        let ids = r.passes::<VisibilityFrame>().unwrap().raster().read_ids(&ctx.device, &ctx.queue).unwrap();
        (r.read_depth(ctx).unwrap(), ids)
    };
    let mut seen = Vec::new();
    for (k, cam) in walled_cameras().iter().enumerate() {
        let now = LightBuffers::new(&ctx.device, &moved(&base, 0.4 * k as f32)).unwrap();
        if k > 0 {
            move_lights(&carried, &mut carried_lights, &now);
        }
        let a = render_frame(ctx, &mut carried, &sg, cam);
        let (a_depth, a_ids) = read(&carried);
        let mut fresh = FrameRenderer::new(ctx, &sg, &now, W, H, settings).unwrap();
        let b = render_frame(ctx, &mut fresh, &sg, cam);
        let (b_depth, b_ids) = read(&fresh);
        let what = format!("frame {k}, carried vs fresh");
        let differ = a_ids.iter().zip(&b_ids).filter(|(x, y)| x != y).count();
        assert_eq!(differ, 0, "{what}: {differ} pixels hold another triangle (a texel or large triangle kept?)");
        let differ = a_depth.iter().zip(&b_depth).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        assert_eq!(differ, 0, "{what}: {differ} depths differ");
        assert_same_frame(&a.hdr, &b.hdr, &what);
        seen.push(b_ids);
    }
    // Each camera must see other triangles than the one before over a good part of the
    // frame (a third; the floor's large triangles stay in view from the first two eyes),
    // or a kept texel or large triangle would hardly show.
    for k in 1..FRAMES {
        let changed = seen[k].iter().zip(&seen[k - 1]).filter(|(x, y)| x != y).count();
        assert!(
            changed * 3 > seen[k].len(),
            "frames {} and {k} see mostly the same triangles ({changed} of {} pixels changed)",
            k - 1,
            seen[k].len()
        );
    }
}

/// The coplanar plates of `draw_order.rs` (a large red one centred at x = 3, stored
/// first; a small green one at the origin), both 9 m under eyes looking straight down,
/// so they tie exactly in depth where they overlap; two point lights over them.
fn plates_scene() -> Scene {
    let mut scene = scenes::floor_scene(0.8, 0.0, vec![]);
    let plate = |name: &str, c: [f32; 4]| Material { name: name.into(), base_color: c, ..Material::default() };
    scene.materials.push(plate("red", [0.8, 0.1, 0.1, 1.0]));
    scene.materials.push(plate("green", [0.1, 0.8, 0.1, 1.0]));
    scene.meshes.push(scenes::quad("large", 8.0));
    scene.meshes.push(scenes::quad("small", 2.0));
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 1.0, 0.0));
    scene.instances.push(Instance { mesh: 1, material: 1, transform: at(3.0) });
    scene.instances.push(Instance { mesh: 2, material: 2, transform: at(0.0) });
    scene
}

/// Tiled Deferred nearest first over three eyes straight above the plates: over x = 0
/// the green plate's centre is the nearer (red drawn last keeps the overlap), over x = 4.5
/// the red one's (green drawn last keeps it), then over x = -0.5 green again; the lights
/// move too. Each frame is a fresh renderer's; an order not sorted again when the eye
/// moves shows the other plate in the overlap. The case tests something only if the order
/// shows: the first eye's frame drawn in the instance buffer's order must differ.
#[test]
fn the_draw_order_is_sorted_again_when_the_eye_moves() {
    let ctx = gpu();
    let scene = plates_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let base = vec![
        Light::point(Vec3::new(2.0, 4.0, 1.0), Vec3::new(1.0, 0.9, 0.8), 30.0, 0.05).unwrap(),
        Light::point(Vec3::new(-1.0, 3.0, -2.0), Vec3::new(0.6, 0.7, 1.0), 20.0, 0.05).unwrap(),
    ];
    let settings = |draw_order| FrameSettings {
        method: Method::TiledDeferred,
        ambient: Vec3::splat(0.5),
        knobs: Knobs { draw_order, ..Knobs::default() },
        ..Default::default()
    };
    let eyes = [Vec3::new(0.0, 10.0, 0.0), Vec3::new(4.5, 10.0, 0.0), Vec3::new(-0.5, 10.0, 0.5)];
    let cam = |eye: Vec3| camera(eye, eye * Vec3::new(1.0, 0.0, 1.0), -Vec3::Z);
    let front_to_back = settings(DrawOrderMode::FrontToBack);
    let mut carried_lights = LightBuffers::new(&ctx.device, &moved(&base, 0.0)).unwrap();
    let mut carried = FrameRenderer::new(ctx, &sg, &carried_lights, W, H, front_to_back).unwrap();
    for (k, &eye) in eyes.iter().enumerate() {
        let now = LightBuffers::new(&ctx.device, &moved(&base, 0.5 * k as f32)).unwrap();
        if k > 0 {
            move_lights(&carried, &mut carried_lights, &now);
        }
        let a = render_frame(ctx, &mut carried, &sg, &cam(eye));
        let mut fresh = FrameRenderer::new(ctx, &sg, &now, W, H, front_to_back).unwrap();
        let b = render_frame(ctx, &mut fresh, &sg, &cam(eye));
        if k == 0 {
            let mut unsorted = FrameRenderer::new(ctx, &sg, &now, W, H, settings(DrawOrderMode::Submission)).unwrap();
            let c = render_frame(ctx, &mut unsorted, &sg, &cam(eye));
            let differ = b.hdr.iter().zip(&c.hdr).filter(|(p, q)| p != q).count();
            assert!(differ > 100, "the order must show in the overlap ({differ} pixels differ between the orders)");
        }
        assert_same_frame(&a.hdr, &b.hdr, &format!("frame {k} (eye {eye}), carried vs fresh"));
    }
}

/// Forward+ and Tiled Deferred with two point and two spot shadow casters and VPLs, over
/// three frames in which the camera and every light move: each frame is a fresh
/// renderer's (module doc for the tolerance), with the same VPL count, and the carried
/// renderer redrew shadow faces in every frame (a moved caster's faces). Catches faces of
/// a moved caster not drawn again, VPLs not generated again, and either reading the
/// lights of the frame before.
#[test]
fn shadows_and_vpls_follow_lights_that_move_every_frame() {
    let ctx = gpu();
    let scene = walled_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let base = bright_lights(&scene, (2.0, 4.0), 10, 6, 7);
    let casters = (2, 2);
    let cams = walled_cameras();
    for method in [Method::ForwardPlus, Method::TiledDeferred] {
        let settings = FrameSettings {
            method,
            shadows: ShadowOptions { tile_size: 128, ..Default::default() },
            vpl: Some(VplConfig::default()),
            ..Default::default()
        };
        let mut carried_lights = LightBuffers::with_casters(&ctx.device, &moved(&base, 0.0), casters).unwrap();
        let mut carried = FrameRenderer::new(ctx, &sg, &carried_lights, W, H, settings).unwrap();
        for (k, cam) in cams.iter().enumerate() {
            let now = LightBuffers::with_casters(&ctx.device, &moved(&base, 0.35 * k as f32), casters).unwrap();
            if k > 0 {
                move_lights(&carried, &mut carried_lights, &now);
            }
            let a = render_frame(ctx, &mut carried, &sg, cam);
            let drawn = carried.outputs().shadow_atlas.expect("an atlas").faces_drawn_last_frame();
            assert_eq!(drawn, 2 * 6 + 2, "{}: frame {k} must draw every moved caster's faces", method.label());
            let mut fresh = FrameRenderer::new(ctx, &sg, &now, W, H, settings).unwrap();
            let b = render_frame(ctx, &mut fresh, &sg, cam);
            let what = format!("{}, frame {k}, carried vs fresh", method.label());
            let (va, vb) = (carried.vpl_count(ctx).unwrap(), fresh.vpl_count(ctx).unwrap());
            assert!(vb.is_some_and(|(kept, _)| kept > 20), "{what}: too few VPLs to test ({vb:?})");
            assert_eq!(va, vb, "{what}: VPLs kept and refused");
            if is_lavapipe(ctx) {
                assert_same_frame(&a.hdr, &b.hdr, &what);
            } else {
                assert_matches_reference_frame(&what, W, &b, &a, FORWARD_VS_REFERENCE);
            }
        }
    }
}

/// The light grid growing from frame to frame, in every tiled method: 400 lights of 4 m
/// radius, a third of them in the room and the rest 40 m over it (no tile meets those),
/// come down in two steps (two thirds, then all) while the camera moves; each step needs more pairs
/// than the grid of the frame before holds. The carried renderer's automatic grid grows
/// (its capacity rises in some frame after the first) and no frame drops a pair; the fresh
/// renderer's fixed budget holds every frame. An index buffer grown but not bound where it
/// is read, or a capacity not given to the culling, gives another image.
#[test]
fn the_light_grid_grows_as_the_lights_come_into_view() {
    let ctx = gpu();
    let scene = walled_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let mut base = scenes::lights_in_slab(&scene, 0.5, 3.5, 400, 0, 11);
    for l in &mut base {
        l.radius = 4.0;
    }
    // Frame k: the first (k + 1) / 3 of the lights in the room, the rest 40 m up.
    let frame_lights = |k: usize| -> Vec<Light> {
        let down = base.len() * (k + 1) / FRAMES;
        let turned = moved(&base, 0.2 * k as f32);
        turned
            .into_iter()
            .enumerate()
            .map(|(i, mut l)| {
                if i >= down {
                    l.position.y += 40.0;
                }
                l
            })
            .collect()
    };
    let cams = [
        camera(Vec3::new(7.0, 4.5, 9.0), Vec3::new(0.0, 0.5, 0.0), Vec3::Y),
        camera(Vec3::new(6.0, 4.0, 8.5), Vec3::new(0.0, 0.8, 0.0), Vec3::Y),
        camera(Vec3::new(5.0, 4.0, 8.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y),
    ];
    // 60 tiles x 400 lights: every pair there can be.
    let fixed = CullOptions { grid_pairs: Some(60 * 400), ..CullOptions::default() };
    for method in [Method::ForwardPlus, Method::TiledDeferred, Method::Visibility] {
        let settings =
            FrameSettings { method, knobs: Knobs { raster: Raster::Auto, ..Knobs::default() }, ..Default::default() };
        let mut carried_lights = LightBuffers::new(&ctx.device, &frame_lights(0)).unwrap();
        let mut carried = FrameRenderer::new(ctx, &sg, &carried_lights, W, H, settings).unwrap();
        let mut capacities = Vec::new();
        for (k, cam) in cams.iter().enumerate() {
            let now = LightBuffers::new(&ctx.device, &frame_lights(k)).unwrap();
            if k > 0 {
                move_lights(&carried, &mut carried_lights, &now);
            }
            let before = carried.outputs().light_grid.unwrap().capacity();
            let a = render_frame(ctx, &mut carried, &sg, cam);
            let grid = carried.outputs().light_grid.unwrap();
            let status = grid.status(&ctx.device, &ctx.queue).unwrap();
            let what = format!("{}, frame {k}", method.label());
            assert!(status.complete(), "{what}: the carried grid dropped pairs: {status}");
            capacities.push((before, grid.capacity(), status.header.pairs));
            let mut fresh =
                FrameRenderer::new(ctx, &sg, &now, W, H, FrameSettings { cull: fixed, ..settings }).unwrap();
            let b = render_frame(ctx, &mut fresh, &sg, cam);
            let status = fresh.outputs().light_grid.unwrap().status(&ctx.device, &ctx.queue).unwrap();
            assert!(status.complete(), "{what}: the fixed budget dropped pairs: {status}");
            assert_same_frame(&a.hdr, &b.hdr, &format!("{what}, carried vs fresh"));
        }
        eprintln!("{}: (capacity before, after, pairs) per frame: {capacities:?}", method.label());
        assert!(
            capacities.iter().skip(1).any(|&(before, after, _)| after > before),
            "{}: the grid never grew after the first frame: the case tests nothing ({capacities:?})",
            method.label()
        );
    }
}
