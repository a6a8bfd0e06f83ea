//! The image comparisons with the brute-force reference that the Forward+ and Tiled
//! Deferred tests make, as functions returning their numbers and verdicts, so a test can
//! assert that a comparison passes (`forward_vs_reference.rs`, `deferred.rs`) or that it
//! fails on a deliberately broken frame (`negative.rs`, which proves the thresholds bite).
//! The thresholds live here once, with the reasons for them.

use glam::Vec3;
use tiledlight_cull::brdf::windowed_attenuation;
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::Camera;
use tiledlight_forward::{ForwardRenderer, ForwardSettings, Method};
use tiledlight_gpu::diagnostics::Diagnostics as _;
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::Renderer;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;

use crate::images::{assert_flip, max_relative_error, save_png, FlipResult, FlipThresholds};

/// A rendered frame: linear HDR and the tonemapped sRGB image (RGBA8).
#[derive(Clone)]
pub struct Frame {
    /// Linear HDR, row-major.
    pub hdr: Vec<[f32; 4]>,
    /// Tonemapped sRGB, RGBA8, row-major.
    pub ldr: Vec<u8>,
    /// Per pixel, an absolute HDR difference a comparison with this frame as the reference
    /// forgives before the relative limit applies (empty: none); see
    /// [`Frame::allow_gbuffer_normals`].
    pub allowance: Vec<f32>,
}

/// How far an f16 G-buffer normal's rounding can move `n.l` (half an ulp, 2^-12, per
/// component below 1, so at most sqrt(3) 2^-12 = 4.2e-4; 2^-11 with margin).
pub const F16_NORMAL_ERROR: f32 = 1.0 / 2048.0;

impl Frame {
    /// Adds, per pixel, what Tiled Deferred's f16 normal may legitimately change: each
    /// light's diffuse term is `radiance x attenuation x albedo / pi x n.l`, and the rounded
    /// normal moves `n.l` by up to [`F16_NORMAL_ERROR`], so up to `radiance x attenuation /
    /// pi x F16_NORMAL_ERROR` (albedo at most 1, spot falloff at most 1) a light. Relative to
    /// the pixel that is small except for lights at grazing incidence: measured on the H200,
    /// a courtyard pixel whose brightest light arrives at `n.l` = 0.0036 moved 3.1%, and the
    /// CPU BRDF fed that pixel's G-buffer normal gives the deferred value to 1e-4. A light
    /// missing from a pixel is far outside this allowance (it is a light's whole
    /// contribution, the allowance 5e-4 / n.l of it).
    pub fn allow_gbuffer_normals(mut self, depth: &[f32], w: u32, camera: &Camera, lights: &PackedLights) -> Self {
        let h = (self.hdr.len() / w as usize) as u32;
        let inv_view = camera.view().inverse();
        self.allowance = (0..self.hdr.len())
            .map(|i| {
                let (x, y) = (i as u32 % w, i as u32 / w);
                let Some(pv) = pixel_view_position(camera, w, h, x, y, depth[i]) else { return 0.0 };
                let p = (inv_view * pv.extend(1.0)).truncate();
                let sum: f32 = lights
                    .shading
                    .iter()
                    .map(|l| {
                        let d2 = (Vec3::from(l.position) - p).length_squared();
                        if d2 >= l.radius * l.radius {
                            return 0.0;
                        }
                        Vec3::from(l.radiance).max_element() * windowed_attenuation(d2, l.radius)
                    })
                    .sum();
                sum / std::f32::consts::PI * F16_NORMAL_ERROR
            })
            .collect();
        self
    }
}

/// Renders one frame with `r` and reads both images back.
pub fn render_frame(ctx: &GpuContext, r: &mut dyn Renderer, scene: &SceneGpu, camera: &Camera) -> Frame {
    let mut timer = GpuTimer::new(ctx).expect("timer");
    r.render_once(ctx, &mut timer, scene, camera).expect("render");
    Frame { hdr: r.read_hdr(ctx).expect("read HDR"), ldr: r.read_ldr(ctx).expect("read LDR"), allowance: Vec::new() }
}

/// Renders the brute-force reference (same BRDF, radius cutoff on) of `scene` lit by
/// `lights` at `size` through `camera`: what every renderer's image is compared with.
pub fn reference_frame(
    ctx: &GpuContext,
    scene: &SceneGpu,
    lights: &LightBuffers,
    (w, h): (u32, u32),
    camera: &Camera,
) -> Frame {
    let settings = ForwardSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() };
    let mut r = ForwardRenderer::new(ctx, scene, lights, w, h, settings).expect("brute-force renderer");
    render_frame(ctx, &mut r, scene, camera)
}

/// The limits of one comparison with the reference.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    /// Largest relative error of a linear HDR channel.
    pub hdr_rel: f32,
    /// Absolute floor of the relative error's denominator (near-black pixels).
    pub hdr_floor: f32,
    /// Limits on FLIP of the tonemapped images.
    pub flip: FlipThresholds,
}

/// Forward+ vs the brute-force reference (same BRDF, same radius cutoff): the lights are
/// summed in a different order (tile list order vs index order) in f32 and stored as f16,
/// so a pixel may differ by about one f16 ulp (2^-10 relative); 4e-3 relative (floor 1e-3
/// absolute for near-black) allows that with margin, while a single missing light
/// (typically >5% of a lit pixel) fails. On the tonemapped image, FLIP mean <= 1e-3 and
/// 99th percentile <= 1e-2.
pub const FORWARD_VS_REFERENCE: Tolerance =
    Tolerance { hdr_rel: 4e-3, hdr_floor: 1e-3, flip: FlipThresholds { mean: 1e-3, percentile: (0.99, 1e-2) } };

/// Tiled Deferred vs the brute-force reference (same BRDF and cutoff): the G-buffer stores
/// the albedo in 8-bit sRGB, as real deferred renderers do: half an sRGB step is about 1%
/// of the linear value in mid-dark tones (sRGB 100/255), so lit pixels differ by up to
/// ~1.5% everywhere. Measured on the courtyard: max relative HDR error 1.3e-2, FLIP mean
/// 0.0104 (p99 0.031); with an f16 albedo instead (tried, not kept: 4 more bytes a pixel)
/// 6.3e-3 and 0.0023, the rest coming from the f16 normal (~5e-4 rad moves GGX highlights
/// by ~2.5% at roughness 0.2) and positions rebuilt from depth. Limits: HDR 3e-2 relative
/// (floor 1e-2), FLIP mean 0.015 and p99 0.05; a missing light changes a lit pixel by well
/// over 5% and fails. The f16 normal's effect on lights at grazing incidence (where `n.l`
/// is tiny, a 4e-4 shift is many percent) is not a relative error: a reference for Tiled
/// Deferred carries it per pixel ([`Frame::allow_gbuffer_normals`]).
pub const DEFERRED_VS_REFERENCE: Tolerance =
    Tolerance { hdr_rel: 3e-2, hdr_floor: 1e-2, flip: FlipThresholds { mean: 0.015, percentile: (0.99, 0.05) } };

/// The numbers and verdicts of one comparison.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Worst relative HDR error.
    pub hdr_error: f32,
    /// Pixel index of the worst HDR error.
    pub hdr_at: usize,
    /// FLIP of the tonemapped images (mean, the tolerance's percentile, max).
    pub flip: FlipResult,
    /// The HDR error is within the tolerance.
    pub hdr_ok: bool,
    /// FLIP mean and percentile are within the tolerance.
    pub flip_ok: bool,
}

impl Comparison {
    /// Both checks pass.
    pub fn passes(&self) -> bool {
        self.hdr_ok && self.flip_ok
    }
}

/// Compares `actual` with `reference` (both `w` x `h`) under `t`, and prints the numbers
/// under `name`.
pub fn compare_with_reference(name: &str, w: u32, reference: &Frame, actual: &Frame, t: Tolerance) -> Comparison {
    let (hdr_error, hdr_at) = if reference.allowance.is_empty() {
        max_relative_error(&reference.hdr, &actual.hdr, t.hdr_floor)
    } else {
        // What the reference's allowance forgives, then relative as above.
        let mut worst = (0.0f32, 0usize);
        for (i, (e, a)) in reference.hdr.iter().zip(&actual.hdr).enumerate() {
            for c in 0..3 {
                let err = ((a[c] - e[c]).abs() - reference.allowance[i]).max(0.0) / e[c].abs().max(t.hdr_floor);
                let err = if err.is_nan() { f32::INFINITY } else { err };
                if err > worst.0 {
                    worst = (err, i);
                }
            }
        }
        worst
    };
    let h = (reference.hdr.len() / w as usize) as u32;
    let map = tiledlight_metrics::flip(w, h, &reference.ldr, &actual.ldr);
    let flip = map.summary(t.flip.percentile.0);
    eprintln!(
        "{name}: max relative HDR error {hdr_error:.2e} at ({}, {}); FLIP mean {:.5}, p{} {:.5}, max {:.5}",
        hdr_at as u32 % w,
        hdr_at as u32 / w,
        flip.mean,
        t.flip.percentile.0 * 100.0,
        flip.percentile,
        flip.max
    );
    let flip_ok = flip.mean <= t.flip.mean && flip.percentile <= t.flip.percentile.1;
    Comparison { hdr_error, hdr_at, hdr_ok: hdr_error <= t.hdr_rel, flip, flip_ok }
}

/// Asserts that `actual` matches `reference` under `t` (HDR first, then FLIP); on failure
/// writes `<name>-actual.png`, `<name>-expected.png` (and for FLIP `<name>-difference.png`)
/// to [`crate::output_dir`] and panics with the numbers.
pub fn assert_matches_reference_frame(name: &str, w: u32, reference: &Frame, actual: &Frame, t: Tolerance) {
    let c = compare_with_reference(name, w, reference, actual, t);
    let h = (reference.hdr.len() / w as usize) as u32;
    if !c.hdr_ok {
        let dir = crate::output_dir();
        save_png(&dir.join(format!("{name}-actual.png")), w, h, &actual.ldr);
        save_png(&dir.join(format!("{name}-expected.png")), w, h, &reference.ldr);
        let at = c.hdr_at;
        panic!(
            "{name}: HDR error {} (limit {}) at pixel ({}, {}): expected {:?}, got {:?}; images in {}",
            c.hdr_error,
            t.hdr_rel,
            at as u32 % w,
            at as u32 / w,
            reference.hdr[at],
            actual.hdr[at],
            dir.display()
        );
    }
    if !c.flip_ok {
        // Writes the three images and panics with the numbers.
        assert_flip(name, w, h, &reference.ldr, &actual.ldr, t.flip);
        unreachable!("assert_flip passed a comparison that failed");
    }
}
