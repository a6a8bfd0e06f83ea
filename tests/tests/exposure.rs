//! Automatic exposure (`tiledlight_gpu::exposure::AutoExposure`, `shaders/exposure.wgsl`)
//! against its CPU twin (`tiledlight_cull::exposure::auto_exposure`) on the frame's own HDR
//! image, in both methods:
//! - the GPU's exposure equals the CPU twin's within 1e-3 relative (the GPU sums log2 in
//!   f32 per 256 pixels and then over the workgroups, the CPU in f64: 2^-24 per addition
//!   over 57,600 pixels stays far below that; a wrong pixel count or a missed workgroup is
//!   percents off);
//! - the tonemapped image equals the one a fixed exposure of that value gives (to one
//!   8-bit step: the two exposures agree to 1e-3);
//! - the GPU's tonemapped image equals the CPU tonemap twin (`tiledlight_metrics::tonemap`)
//!   of its HDR image to one 8-bit step;
//! - an unlit view (only sky) keeps exposure 1, and a fixed exposure has no exposure pass.

use glam::Vec3;
use tiledlight_cull::exposure::auto_exposure;
use tiledlight_cull::Camera;
use tiledlight_frame::{FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

fn check(name: &str, auto: &mut FrameRenderer, fixed: impl Fn(f32) -> FrameRenderer, sg: &SceneGpu, cam: &Camera) {
    let ctx = gpu();
    let f = render_frame(ctx, auto, sg, cam);
    let gpu_e = auto.auto_exposure(ctx).unwrap().expect("automatic exposure");
    let cpu_e = auto_exposure(f.hdr.as_flattened());
    assert!((gpu_e / cpu_e - 1.0).abs() < 1e-3, "{name}: GPU exposure {gpu_e}, CPU twin {cpu_e}");
    // The courtyard's log-average luminance with these lights is far from the key (the
    // exposure is about 5 on lavapipe): a pass that wrote nothing would read 0 or 1.
    assert!((gpu_e - 1.0).abs() > 0.5, "{name}: exposure {gpu_e} did not adapt");
    let mut r = fixed(gpu_e);
    assert_eq!(r.auto_exposure(ctx).unwrap(), None, "{name}: a fixed exposure has no exposure pass");
    let g = render_frame(ctx, &mut r, sg, cam);
    let worst = f.ldr.iter().zip(&g.ldr).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(0);
    assert!(worst <= 1, "{name}: the automatic image differs from the fixed one by {worst} steps");
    // The tonemap itself against its CPU twin (the comparison above shares the GPU's curve
    // on both sides, so it cannot see a wrong ACES coefficient or sRGB encode): one 8-bit
    // step, for f32 rounding of the curve and `pow` near a rounding boundary.
    let twin = tiledlight_metrics::tonemap::tonemap(&g.hdr, gpu_e);
    let (worst, at) =
        g.ldr.iter().zip(&twin).enumerate().map(|(i, (a, b))| (a.abs_diff(*b), i)).max().unwrap_or((0, 0));
    assert!(worst <= 1, "{name}: the GPU tonemap differs from its CPU twin by {worst} steps at byte {at}");
    let distinct: std::collections::BTreeSet<u8> = twin.iter().copied().collect();
    assert!(distinct.len() > 100, "{name}: the image must span the curve ({} distinct values)", distinct.len());
}

#[test]
fn automatic_exposure_matches_the_cpu_twin_in_both_methods() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 1024, 0, 7)).unwrap();
    let cam = scenes::courtyard_camera(&scene, W, H);
    let s = FrameSettings { auto_exposure: true, ..Default::default() };
    let mut fp = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
    let fixed = |exposure| -> FrameRenderer {
        let s = FrameSettings { exposure, ..Default::default() };
        FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap()
    };
    check("forward", &mut fp, fixed, &sg, &cam);
    let s = FrameSettings { method: Method::TiledDeferred, auto_exposure: true, ..Default::default() };
    let mut td = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
    let fixed = |exposure| -> FrameRenderer {
        let s = FrameSettings { method: Method::TiledDeferred, exposure, ..Default::default() };
        FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap()
    };
    check("deferred", &mut td, fixed, &sg, &cam);
}

#[test]
fn an_unlit_view_keeps_exposure_one() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 16, 0, 7)).unwrap();
    // High above the courtyard looking up: only sky, which is 0.
    let b = scene.compute_bounds();
    let eye = Vec3::new(b.center().x, b.max.y + 50.0, b.center().z);
    let cam = Camera::perspective(eye, eye + Vec3::Y, Vec3::Z, 1.0, W as f32 / H as f32, 0.1, None).unwrap();
    let s = FrameSettings { auto_exposure: true, ..Default::default() };
    let mut fp = FrameRenderer::new(ctx, &sg, &lights, W, H, s).unwrap();
    let f = render_frame(ctx, &mut fp, &sg, &cam);
    assert!(f.hdr.iter().all(|p| p[0] + p[1] + p[2] == 0.0), "the view must see only sky");
    assert_eq!(fp.auto_exposure(ctx).unwrap(), Some(1.0));
}
