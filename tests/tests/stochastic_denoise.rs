//! The stochastic method's denoiser (issue 48, step 4) on lavapipe, on the shadow box (a
//! cube over a floor, so lights are occluded and shadows have edges) lit by a ring of point
//! lights and a spot, at 160x90.
//!
//! - **Twin.** The GPU filter's image equals `tiledlight_cull::denoise` run on the history
//!   and guide the GPU's shading pass left (read back), for a first frame (the variance
//!   from the 3x3 neighbours) and a fifth (the history's own), within the HDR target's
//!   half-float rounding; the twin with one iteration fewer is rejected by the same check.
//!   The history's second moment (the variance's source) is checked on its own: the twin
//!   reads it back, so it cannot see a wrong one.
//! - **Error.** Against the traced truth, the denoised image's error is well below the raw
//!   estimate's after one frame and after eight; after 64 frames of a still view it is no
//!   worse than the raw mean's by more than a small margin (the filter converges to the
//!   same truth; it does not hold a bias), and it loses no more light than the raw
//!   estimate's own noise moves (a symmetric luminance tolerance: see the assertion).
//!
//! The sampler itself is `stochastic_method.rs` (with the denoiser off) and
//! `stochastic_twin.rs`.

use glam::Vec3;
use tiledlight_cull::denoise::{denoise, Guide};
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::visibility::VisibilityFrame;
use tiledlight_frame::{FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::readback::read_buffer;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::GpuContext;
use tiledlight_scene::shadow_box_scene;
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::gpu;

const W: u32 = 160;
const H: u32 = 90;

fn lights() -> Vec<Light> {
    let mut v = Vec::new();
    for k in 0..8 {
        let a = k as f32 * std::f32::consts::TAU / 8.0;
        let c = Vec3::new(0.5 + 0.5 * a.cos(), 0.6, 0.5 + 0.5 * a.sin());
        v.push(Light::point(Vec3::new(3.0 * a.cos(), 0.7, 3.0 * a.sin()), c, 6.0, 0.5).expect("light"));
    }
    v.push(Light::point(Vec3::new(0.3, 4.0, 0.2), Vec3::ONE, 12.0, 0.5).expect("light"));
    let spot = Vec3::new(2.5, 3.5, 2.5);
    v.push(
        Light::spot(spot, (Vec3::new(-0.5, 0.0, -0.5) - spot).normalize(), Vec3::ONE, 14.0, 0.4, 0.6, 0.5)
            .expect("spot"),
    );
    v
}

fn camera() -> Camera {
    let eye = Vec3::new(5.0, 5.0, 7.0);
    Camera::perspective(eye, Vec3::new(0.0, 0.5, 0.0), Vec3::Y, 50f32.to_radians(), W as f32 / H as f32, 0.1, None)
        .expect("camera")
}

struct Fixture {
    scene: SceneGpu,
    lights: LightBuffers,
}

fn fixture(ctx: &GpuContext) -> Fixture {
    let scene = shadow_box_scene(0.5);
    let mut sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    sg.add_trace(&ctx.device, &scene).unwrap();
    Fixture { scene: sg, lights: LightBuffers::new(&ctx.device, &lights()).unwrap() }
}

/// The stochastic method with `denoise` iterations and a history of `accumulate` frames.
fn stochastic(ctx: &GpuContext, f: &Fixture, denoise: u32, accumulate: u32) -> FrameRenderer {
    let mut s = FrameSettings::of(Method::Stochastic);
    s.knobs.denoise = denoise;
    s.knobs.accumulate = accumulate;
    FrameRenderer::new(ctx, &f.scene, &f.lights, W, H, s).expect("renderer")
}

/// The history and the guide the last frame's shading pass left, as the twin reads them.
fn read_back(ctx: &GpuContext, r: &FrameRenderer) -> (Vec<[f32; 4]>, [Vec<[f32; 4]>; 3]) {
    let v = r.passes::<VisibilityFrame>().expect("the visibility frame");
    let (history, guide) = v.shading().stochastic_buffers().expect("the stochastic method's buffers");
    let history: Vec<[f32; 4]> = read_buffer(&ctx.device, &ctx.queue, history).unwrap();
    // Three planes of an `[f32; 4]` a pixel: surface, albedo, unlit.
    let texels: Vec<[f32; 4]> = read_buffer(&ctx.device, &ctx.queue, guide.expect("the denoiser's guide")).unwrap();
    let n = (W * H) as usize;
    let part = |k: usize| texels[k * n..(k + 1) * n].to_vec();
    (history[..n].to_vec(), [part(0), part(1), part(2)])
}

/// Pixels where `gpu` (the HDR image) and `cpu` (the twin; None: sky, left alone) differ by
/// more than the half-float target's rounding and f32's transcendental differences: 0.4%
/// of the value plus 2e-4 (a half float keeps 11 bits: 0.05%; exp on the GPU may differ
/// from the CPU's in its last bits, moving a weight by ~1e-6 relative).
fn mismatches(gpu: &[[f32; 4]], cpu: &[Option<[f32; 3]>]) -> Vec<(usize, [f32; 3], [f32; 3])> {
    let mut bad = Vec::new();
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        let Some(c) = c else { continue };
        if (0..3).any(|k| (g[k] - c[k]).abs() > 0.004 * c[k].abs() + 2e-4) {
            bad.push((i, [g[0], g[1], g[2]], *c));
        }
    }
    bad
}

#[test]
fn the_gpu_denoiser_matches_its_cpu_twin() {
    let ctx = gpu();
    let f = fixture(ctx);
    let iterations = 3;
    let mut r = stochastic(ctx, &f, iterations, 64);
    let cam = camera();
    let mut surfaces = 0;
    for frame in 1..=5u32 {
        let hdr = render_frame(ctx, &mut r, &f.scene, &cam).hdr;
        if frame != 1 && frame != 5 {
            continue;
        }
        let (history, [surface, albedo, unlit]) = read_back(ctx, &r);
        if frame == 5 {
            second_moment_is_the_mean_of_squares(&history, &surface, &albedo);
        }
        let g = Guide { width: W, height: H, surface: &surface, albedo: &albedo, unlit: &unlit };
        let cpu = denoise(&history, &g, frame, iterations);
        surfaces = cpu.iter().flatten().count();
        let bad = mismatches(&hdr, &cpu);
        assert!(
            bad.is_empty(),
            "frame {frame}: {} of {surfaces} pixels differ, first {:?}",
            bad.len(),
            &bad[..3.min(bad.len())]
        );
        // The negative test: the twin one iteration short is told apart.
        let short = denoise(&history, &g, frame, iterations - 1);
        assert!(mismatches(&hdr, &short).len() > surfaces / 10, "frame {frame}: the check misses a missing iteration");
    }
    // The scene fills most of the image (the floor and the cube), so the check covers it.
    assert!(surfaces > (W * H / 2) as usize, "{surfaces} surface pixels");
}

/// The history's fourth channel is the mean of the frames' squared luminance (of the light
/// over the albedo), so it is at least the square of the mean's luminance (Jensen), equal
/// where every frame agreed and above it where they did not: a second moment that kept
/// only the last frame's square falls below it wherever that frame was darker than the
/// mean.
fn second_moment_is_the_mean_of_squares(history: &[[f32; 4]], surface: &[[f32; 4]], albedo: &[[f32; 4]]) {
    let (mut below, mut spread, mut surfaces) = (0, 0, 0);
    for ((h, s), a) in history.iter().zip(surface).zip(albedo) {
        if s[3] <= 0.0 {
            continue;
        }
        surfaces += 1;
        let l = tiledlight_cull::exposure::luminance([h[0] / a[0], h[1] / a[1], h[2] / a[2]]);
        let square = l * l;
        // f32 rounding of a running mean: a few ulps of the larger value.
        if h[3] < square * (1.0 - 1e-4) - 1e-12 {
            below += 1;
        }
        if h[3] > square * 1.01 {
            spread += 1;
        }
    }
    assert_eq!(below, 0, "{below} of {surfaces} pixels have a second moment below the mean's square");
    assert!(spread * 5 > surfaces, "only {spread} of {surfaces} pixels show the frames' spread");
}

/// The image's summed luminance.
fn energy(img: &[[f32; 4]]) -> f64 {
    img.iter().map(tiledlight_metrics::luminance).sum()
}

/// Root-mean-square error of the surface pixels' luminance against `truth`.
fn rmse(img: &[[f32; 4]], truth: &[[f32; 4]]) -> f64 {
    let lum = |c: &[f32; 4]| tiledlight_metrics::luminance(c);
    let e: Vec<f64> = img.iter().zip(truth).map(|(a, b)| (lum(a) - lum(b)).powi(2)).collect();
    (e.iter().sum::<f64>() / e.len() as f64).sqrt()
}

#[test]
fn the_denoiser_cuts_the_error_and_converges_to_the_truth() {
    let ctx = gpu();
    let f = fixture(ctx);
    let cam = camera();
    let mut truth = FrameRenderer::new(ctx, &f.scene, &f.lights, W, H, FrameSettings::of(Method::TRUTH)).unwrap();
    let truth = render_frame(ctx, &mut truth, &f.scene, &cam).hdr;
    // Errors and the light lost against the truth after 1, 8 and 64 frames of a still
    // view, raw and denoised.
    let errors = |denoise: u32| {
        let mut r = stochastic(ctx, &f, denoise, 64);
        let (mut out, mut lost) = (Vec::new(), Vec::new());
        for frame in 1..=64 {
            let hdr = render_frame(ctx, &mut r, &f.scene, &cam).hdr;
            if [1, 8, 64].contains(&frame) {
                out.push(rmse(&hdr, &truth));
                lost.push(1.0 - energy(&hdr) / energy(&truth));
            }
        }
        (out, lost)
    };
    let ((raw, raw_lost), (filtered, filtered_lost)) = (errors(0), errors(4));
    eprintln!("luminance RMSE after 1, 8, 64 frames: raw {raw:?}, denoised {filtered:?}");
    eprintln!("light lost after 1, 8, 64 frames: raw {raw_lost:?}, denoised {filtered_lost:?}");
    // The first frame's noise is the filter's to remove: at least half of the error goes.
    assert!(filtered[0] < 0.5 * raw[0], "1 frame: {} vs raw {}", filtered[0], raw[0]);
    assert!(filtered[1] < 0.7 * raw[1], "8 frames: {} vs raw {}", filtered[1], raw[1]);
    // After 64 frames the variance of the mean is small and the filter lets it through:
    // no bias of its own beyond a tenth of the raw mean's error.
    assert!(filtered[2] < 1.1 * raw[2], "64 frames: {} vs raw {}", filtered[2], raw[2]);
    // And the raw estimate itself converges (the comparison means something).
    assert!(raw[2] < 0.3 * raw[0], "raw: {raw:?}");
    // The filter moves light, it must not lose it: within the raw estimate's own
    // first-frame deviation (1.2% here) and a little more for one frame; 2% after 8 and 64.
    // (With each pixel's own variance as the only tolerance, a dark pixel refused a bright
    // neighbour's light that the bright one gave away: 15%, 7% and 3% were lost.)
    assert!(filtered_lost[0].abs() < 0.04, "1 frame lost {:.4}", filtered_lost[0]);
    assert!(filtered_lost[1].abs() < 0.02 && filtered_lost[2].abs() < 0.02, "lost {filtered_lost:?}");
    assert!(raw_lost.iter().all(|l| l.abs() < 0.02), "the raw estimate is unbiased: {raw_lost:?}");
}
