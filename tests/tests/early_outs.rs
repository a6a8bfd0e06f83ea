//! The shading's early-outs and their ablation (`--no-early-outs`, the `EARLY_OUTS`
//! pipeline constant in `shaders/common/brdf.wgsl`), and Bevy's many_lights scene whose
//! lights all sit behind the surface they reach (`tiledlight_scene::peer`):
//!
//! - **The ablation changes no pixel.** Every method that shades lights gives the same HDR
//!   image with and without the early-outs, on the courtyard with point and spot lights:
//!   the ablation evaluates the whole BRDF of a light beyond its radius or behind the
//!   surface and then discards it, so only time may change. On lavapipe bit for bit; on a
//!   parallel GPU within one f16 step (a tile's list order, and with it the summation
//!   order, varies from run to run).
//! - **Bevy's many_lights adds no light to the picture.** Its 100,000 lights draw exactly
//!   what one light that reaches nothing draws (ambient alone), with the early-outs and
//!   without them: without, every listed light goes through the BRDF at n.l = 0, where
//!   terms can be infinite, so this is also the test that the ablation's `select` keeps
//!   NaN out of the image.

use glam::Vec3;
use tiledlight_cull::{Light, LightKind};
use tiledlight_frame::{FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::{default_scene, DefaultSceneOptions};
use tiledlight_tests::compare::{assert_same_hdr, render_frame};
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

/// Asserts `a` and `b` are the same HDR image ([`assert_same_hdr`]), and finite (NaN
/// already fails the comparison; an infinity in both would not).
fn assert_same(a: &[[f32; 4]], b: &[[f32; 4]], exact: bool, what: &str) {
    assert_same_hdr(a, b, W, exact, what);
    assert!(a.iter().chain(b).all(|p| p[..3].iter().all(|c| c.is_finite())), "{what}: a pixel is not finite");
}

#[test]
fn the_ablation_changes_no_pixel() {
    let ctx = gpu();
    let scene = default_scene(&DefaultSceneOptions { grid_objects: 40, ..Default::default() }).unwrap();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 512, 128, 7)).unwrap();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let exact = tiledlight_tests::is_lavapipe(ctx);
    for method in [Method::ForwardPlus, Method::TiledDeferred, Method::Visibility, Method::BruteForce { cutoff: true }]
    {
        let image = |early_outs| {
            let s = FrameSettings { method, knobs: Knobs { early_outs, ..Knobs::default() }, ..Default::default() };
            let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
            render_frame(ctx, &mut r, &sg, &camera).hdr
        };
        let (a, b) = (image(true), image(false));
        let lit = a.iter().filter(|p| p[0] + p[1] + p[2] > 0.1).count();
        assert!(lit * 4 > a.len(), "{}: frame mostly unlit ({lit} lit pixels)", method.label());
        assert_same(&a, &b, exact, &format!("{} with and without the early-outs", method.label()));
    }
}

#[test]
fn bevys_many_lights_add_nothing_to_the_picture() {
    let ctx = gpu();
    let scene = tiledlight_scene::peer::bevy_many_lights();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let all = LightBuffers::new(&ctx.device, &scene.lights).unwrap();
    // One light of the same kind outside the sphere, reaching nothing.
    let none = vec![Light::with_radius(Vec3::new(0.0, 0.0, 200.0), Vec3::ONE, 80.0, 0.3, LightKind::Point).unwrap()];
    let none = LightBuffers::new(&ctx.device, &none).unwrap();
    let c = scene.camera.unwrap();
    let camera =
        tiledlight_cull::Camera::perspective(c.eye, c.target, c.up, c.fov_y, W as f32 / H as f32, c.near, c.far)
            .unwrap();
    let exact = tiledlight_tests::is_lavapipe(ctx);
    for method in [Method::ForwardPlus, Method::TiledDeferred] {
        let image = |lights: &LightBuffers, early_outs| {
            let s = FrameSettings { method, knobs: Knobs { early_outs, ..Knobs::default() }, ..Default::default() };
            let mut r = FrameRenderer::new(ctx, &sg, lights, W, H, s).unwrap();
            let f = render_frame(ctx, &mut r, &sg, &camera);
            let grid = r.outputs().light_grid.expect("a tiled method has a light grid");
            let pairs = grid.status(&ctx.device, &ctx.queue).unwrap().header.pairs;
            (f.hdr, pairs)
        };
        let (ambient, _) = image(&none, true);
        let lit = ambient.iter().filter(|p| p[0] > 0.0).count();
        assert_eq!(lit, ambient.len(), "{}: the ambient light should reach every pixel of the sphere", method.label());
        for early_outs in [true, false] {
            let (img, pairs) = image(&all, early_outs);
            // The lights do reach the faces, so the lists are not empty: the shading
            // really walks them.
            assert!(pairs > 1000, "{}: {pairs} tile-light pairs", method.label());
            let what = format!("{}, 100,000 lights behind the surface, early-outs {early_outs}", method.label());
            assert_same(&ambient, &img, exact, &what);
        }
    }
}
