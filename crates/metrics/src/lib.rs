//! tiledlight-metrics: how far an image is from a reference image.
//!
//! - [`flip`]: NVIDIA's FLIP (through the nv-flip crate) on tonemapped sRGB images: the
//!   perceptual error of what a person sees, as a per-pixel map, its mean, a percentile and
//!   its maximum, and a heat-map picture of it (magma palette);
//! - [`HdrError`]: errors on the linear HDR images themselves (PSNR, the largest error) and
//!   the energy (summed luminance) one image loses against the other.
//!
//! Beside them, the CPU image helpers the labs use: [`tonemap`] (the twin of the GPU's
//! ACES tonemap), [`histogram`] (matching one image's tone curve to another's before
//! FLIP) and [`visibility`] (the light a shadowed image misplaces against an exact one).
//!
//! The measurement lab (tiledlight-lab) and the GPU tests both measure with these.
//! Depends on nv-flip only; no GPU, no other tiledlight crate.

pub mod histogram;
pub mod tonemap;
pub mod visibility;

/// Summary of a FLIP error map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipResult {
    /// Mean error over the pixels (0 = identical, 1 = as different as can be).
    pub mean: f32,
    /// Error at the requested percentile.
    pub percentile: f32,
    /// Largest error.
    pub max: f32,
}

/// A FLIP error map of two images, one value in [0, 1] per pixel.
pub struct FlipMap {
    map: nv_flip::FlipImageFloat,
}

fn rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// FLIP error map of `test` against `reference`, both `w` x `h` tightly packed RGBA8 sRGB
/// (alpha ignored), at nv-flip's default viewing distance (67 pixels per degree).
///
/// # Panics
/// When a buffer does not hold `w * h * 4` bytes (a caller bug, not bad input).
pub fn flip(w: u32, h: u32, reference: &[u8], test: &[u8]) -> FlipMap {
    let n = w as usize * h as usize * 4;
    assert!(reference.len() == n && test.len() == n, "FLIP: buffers must hold {w}x{h} RGBA8 pixels");
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(reference));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(test));
    FlipMap { map: nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE) }
}

impl FlipMap {
    /// Mean, the given percentile (e.g. 0.99) and the maximum of the map.
    pub fn summary(&self, percentile: f32) -> FlipResult {
        let mut pool = nv_flip::FlipPool::from_image(&self.map);
        FlipResult { mean: pool.mean(), percentile: pool.get_percentile(percentile, false), max: pool.max_value() }
    }

    /// The map as an RGB8 heat map (magma: black = no error, yellow-white = largest).
    pub fn heat_rgb(&self) -> Vec<u8> {
        self.map.apply_color_lut(&nv_flip::magma_lut()).to_vec()
    }

    /// The per-pixel values, row-major.
    pub fn values(&self) -> Vec<f32> {
        self.map.to_vec()
    }
}

/// Rec. 709 luminance of a linear RGB value.
pub fn luminance(p: &[f32; 4]) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// Errors of a linear HDR image against a reference of the same size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HdrError {
    /// Peak signal-to-noise ratio in dB, `10 log10(peak^2 / MSE)` over the RGB channels,
    /// with `peak` = [`hdr_peak`] of the reference; infinite for identical images.
    pub psnr_db: f64,
    /// Largest absolute channel difference, divided by the same peak.
    pub max_error: f64,
    /// `(E_ref - E_test) / E_ref` with `E` the summed luminance: the share of the
    /// reference's light the test image does not have (negative if it has more).
    pub energy_lost: f64,
    /// The pixel (index into the images) whose channel difference is [`HdrError::max_error`]:
    /// the first such pixel in row-major order; None when the images are identical.
    pub worst_pixel: Option<usize>,
}

/// The percentile of the reference's channel values that PSNR uses as its peak. HDR has no
/// largest possible value, and the true maximum sits on the few pixels next to a light
/// (inverse-square), which would make every image score alike.
pub const PEAK_PERCENTILE: f64 = 0.999;

/// The [`PEAK_PERCENTILE`] of the RGB channel values of `img` (at least `f32::MIN_POSITIVE`,
/// so a black image still divides).
pub fn hdr_peak(img: &[[f32; 4]]) -> f64 {
    let mut v: Vec<f32> = img.iter().flat_map(|p| [p[0], p[1], p[2]]).filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::from(f32::MIN_POSITIVE);
    }
    let k = ((v.len() - 1) as f64 * PEAK_PERCENTILE).round() as usize;
    let (_, x, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    f64::from(x.max(f32::MIN_POSITIVE))
}

impl HdrError {
    /// Compares `test` with `reference` (same length, RGBA with alpha ignored). A NaN or
    /// infinite test value counts as an infinite error.
    pub fn of(reference: &[[f32; 4]], test: &[[f32; 4]]) -> Self {
        assert_eq!(reference.len(), test.len(), "HDR images of different sizes");
        let peak = hdr_peak(reference);
        let (mut sq, mut max) = (0.0f64, 0.0f64);
        let mut worst_pixel = None;
        let (mut e_ref, mut e_test) = (0.0f64, 0.0f64);
        for (i, (r, t)) in reference.iter().zip(test).enumerate() {
            for c in 0..3 {
                let d = (f64::from(t[c]) - f64::from(r[c])).abs();
                let d = if d.is_finite() { d } else { f64::INFINITY };
                sq += d * d;
                if d > max {
                    max = d;
                    worst_pixel = Some(i);
                }
            }
            e_ref += luminance(r);
            e_test += luminance(t);
        }
        let mse = sq / (3 * reference.len().max(1)) as f64;
        let psnr_db = if mse == 0.0 { f64::INFINITY } else { 10.0 * (peak * peak / mse).log10() };
        let energy_lost = if e_ref > 0.0 { (e_ref - e_test) / e_ref } else { 0.0 };
        Self { psnr_db, max_error: max / peak, energy_lost, worst_pixel }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_no_error() {
        let img = vec![[0.5, 0.25, 1.0, 1.0]; 64];
        let e = HdrError::of(&img, &img);
        assert_eq!((e.psnr_db, e.max_error, e.energy_lost, e.worst_pixel), (f64::INFINITY, 0.0, 0.0, None));
        let ldr = vec![128u8; 8 * 8 * 4];
        let f = flip(8, 8, &ldr, &ldr).summary(0.99);
        assert!(f.mean == 0.0 && f.max < 1e-6, "{f:?}");
    }

    #[test]
    fn hdr_error_by_hand() {
        // 1000 pixels of value 1: the peak is 1. Halving one pixel's channels: MSE = 0.25/1000.
        let reference = vec![[1.0, 1.0, 1.0, 1.0]; 1000];
        let mut test = reference.clone();
        test[3] = [0.5, 0.5, 0.5, 1.0];
        let e = HdrError::of(&reference, &test);
        assert!((e.psnr_db - 10.0 * (1.0 / 0.00025f64).log10()).abs() < 1e-9, "{e:?}");
        assert!((e.max_error - 0.5).abs() < 1e-12);
        assert!((e.energy_lost - 0.5 / 1000.0).abs() < 1e-9);
        assert_eq!(e.worst_pixel, Some(3));
        // A tie keeps the first pixel with that difference.
        let mut tie = test.clone();
        tie[5] = [0.5, 0.5, 0.5, 1.0];
        assert_eq!(HdrError::of(&reference, &tie).worst_pixel, Some(3));
        // A smaller difference elsewhere, before and after, does not move the worst pixel;
        // a NaN anywhere is the worst.
        test[1] = [0.9, 1.0, 1.0, 1.0];
        test[7] = [1.0, 1.0, 1.2, 1.0];
        assert_eq!(HdrError::of(&reference, &test).worst_pixel, Some(3));
        test[9] = [1.0, 1.0, 1.7, 1.0];
        assert_eq!(HdrError::of(&reference, &test).worst_pixel, Some(9));
        test[3] = [f32::NAN, 0.0, 0.0, 1.0];
        let e = HdrError::of(&reference, &test);
        assert_eq!((e.max_error, e.worst_pixel), (f64::INFINITY, Some(3)));
    }

    #[test]
    fn peak_ignores_the_brightest_pixels() {
        let mut img = vec![[1.0, 1.0, 1.0, 1.0]; 10_000];
        img[0] = [1e6, 1e6, 1e6, 1.0];
        assert_eq!(hdr_peak(&img), 1.0);
        assert_eq!(hdr_peak(&[]), f64::from(f32::MIN_POSITIVE));
    }

    #[test]
    fn flip_grows_with_the_difference() {
        let a = vec![100u8; 32 * 32 * 4];
        let near: Vec<u8> = a.iter().map(|v| v + 10).collect();
        let far: Vec<u8> = a.iter().map(|v| v + 100).collect();
        let fn_ = flip(32, 32, &a, &near).summary(0.99);
        let ff = flip(32, 32, &a, &far).summary(0.99);
        assert!(fn_.mean > 0.0 && ff.mean > fn_.mean, "{fn_:?} {ff:?}");
        assert_eq!(flip(32, 32, &a, &far).heat_rgb().len(), 32 * 32 * 3);
    }
}
