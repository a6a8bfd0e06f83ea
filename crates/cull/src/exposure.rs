//! Automatic exposure, the CPU twin of `shaders/exposure.wgsl`: the exposure that maps the
//! image's log-average luminance (Reinhard et al. 2002's "key") to [`AUTO_EXPOSURE_KEY`].
//! Pixels darker than [`MIN_LUMINANCE`] (sky, unlit corners) are left out of the average:
//! an image half sky would otherwise be pushed to white. Pure math; depends on nothing.

/// Linear value the log-average luminance is mapped to: about middle grey after the ACES
/// fit and the sRGB encoding (the same target as the surface lights' fixed exposure).
pub const AUTO_EXPOSURE_KEY: f32 = 0.25;

/// Luminance below which a pixel is not counted (unlit: the sky is 0).
pub const MIN_LUMINANCE: f32 = 1e-4;

/// The exposure is kept within [1 / this, this]: a nearly black image is not amplified
/// without bound.
pub const MAX_EXPOSURE: f32 = 1e6;

/// Relative luminance of linear Rec. 709 RGB.
pub fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The automatic exposure of an HDR image given as RGBA texels (`rgba.len()` a multiple
/// of 4): `AUTO_EXPOSURE_KEY / 2^mean(log2 L)` over the pixels with `L >= MIN_LUMINANCE`,
/// clamped to [`MAX_EXPOSURE`]; 1 when no pixel is lit. Non-finite luminances are skipped.
pub fn auto_exposure(rgba: &[f32]) -> f32 {
    let (mut sum, mut count) = (0.0f64, 0u64);
    for px in rgba.chunks_exact(4) {
        let l = luminance([px[0], px[1], px[2]]);
        if l.is_finite() && l >= MIN_LUMINANCE {
            sum += f64::from(l.log2());
            count += 1;
        }
    }
    exposure_from(sum, count)
}

/// The exposure from a sum of `log2` luminances over `count` pixels (the GPU's last step).
pub fn exposure_from(sum_log2: f64, count: u64) -> f32 {
    if count == 0 {
        return 1.0;
    }
    let mean = sum_log2 / count as f64;
    let e = f64::from(AUTO_EXPOSURE_KEY) / mean.exp2();
    (e as f32).clamp(1.0 / MAX_EXPOSURE, MAX_EXPOSURE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[[f32; 3]]) -> Vec<f32> {
        values.iter().flat_map(|c| [c[0], c[1], c[2], 1.0]).collect()
    }

    #[test]
    fn a_uniform_image_maps_to_the_key() {
        let img = image(&[[2.0; 3]; 16]);
        assert!((auto_exposure(&img) - AUTO_EXPOSURE_KEY / 2.0).abs() < 1e-6);
    }

    #[test]
    fn the_log_average_not_the_mean() {
        // 0.5 and 8: log-average 2 (the mean would be 4.25).
        let img = image(&[[0.5; 3], [8.0; 3]]);
        assert!((auto_exposure(&img) - AUTO_EXPOSURE_KEY / 2.0).abs() < 1e-6);
    }

    #[test]
    fn dark_and_broken_pixels_are_left_out() {
        let img = image(&[[1.0; 3], [0.0; 3], [f32::NAN, 0.0, 0.0], [f32::INFINITY; 3], [1e-6; 3]]);
        assert!((auto_exposure(&img) - AUTO_EXPOSURE_KEY).abs() < 1e-6);
        assert_eq!(auto_exposure(&image(&[[0.0; 3]; 4])), 1.0, "nothing lit: exposure 1");
        assert_eq!(auto_exposure(&[]), 1.0, "an empty image");
    }

    #[test]
    fn extremes_are_clamped_and_finite() {
        let bright = auto_exposure(&image(&[[f32::MAX / 4.0; 3]]));
        assert!(bright.is_finite() && bright >= 1.0 / MAX_EXPOSURE);
        let dim = auto_exposure(&image(&[[MIN_LUMINANCE; 3]]));
        assert!(dim.is_finite() && dim <= MAX_EXPOSURE);
    }
}
