//! The image comparisons with the brute-force reference that the Forward+ and Tiled
//! Deferred tests make, as functions returning their numbers and verdicts, so a test can
//! assert that a comparison passes (`forward_vs_reference.rs`, `deferred.rs`) or that it
//! fails on a deliberately broken frame (`negative.rs`, which proves the thresholds bite).
//! The thresholds live here once, with the reasons for them.

use tiledlight_cull::Camera;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::Renderer;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;

use crate::images::{assert_flip, max_relative_error, save_png, FlipResult, FlipThresholds};

/// A rendered frame: linear HDR and the tonemapped sRGB image (RGBA8).
pub struct Frame {
    /// Linear HDR, row-major.
    pub hdr: Vec<[f32; 4]>,
    /// Tonemapped sRGB, RGBA8, row-major.
    pub ldr: Vec<u8>,
}

/// Renders one frame with `r` and reads both images back.
pub fn render_frame(ctx: &GpuContext, r: &dyn Renderer, scene: &SceneGpu, camera: &Camera) -> Frame {
    let mut timer = GpuTimer::new(ctx).expect("timer");
    r.render_once(ctx, &mut timer, scene, camera).expect("render");
    Frame { hdr: r.read_hdr(ctx).expect("read HDR"), ldr: r.read_ldr(ctx).expect("read LDR") }
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
/// over 5% and fails.
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
    let (hdr_error, hdr_at) = max_relative_error(&reference.hdr, &actual.hdr, t.hdr_floor);
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
