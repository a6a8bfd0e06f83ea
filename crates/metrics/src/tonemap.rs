//! The CPU twin of the GPU's tonemap (`shaders/tonemap.wgsl`): the ACES filmic fit and
//! the sRGB encoding, so a lab can tonemap an image it computed on the CPU (a ray-cast
//! reference) exactly as the GPU would, and check the GPU's own output against it.
//!
//! Pure CPU, no dependency.

/// The ACES filmic fit and sRGB encoding of `shaders/tonemap.wgsl` on the CPU: linear HDR
/// (times `exposure`) to RGBA8 sRGB, as the GPU's tonemap pass writes it (to rounding:
/// the run reports the largest difference from the GPU's image).
pub fn tonemap(hdr: &[[f32; 4]], exposure: f32) -> Vec<u8> {
    let aces = |x: f32| ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0);
    let srgb = |c: f32| if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    let byte = |c: f32| (srgb(aces(c * exposure)) * 255.0).round().clamp(0.0, 255.0) as u8;
    hdr.iter().flat_map(|p| [byte(p[0]), byte(p[1]), byte(p[2]), 255]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tonemap_matches_the_curve() {
        let px = tonemap(&[[0.0, 1.0, 100.0, 1.0], [0.18, 0.5, 2.0, 1.0]], 1.0);
        // aces(1) = 2.54 / 3.16 = 0.8038 -> sRGB 0.9082 -> 232; aces(100) clamps to 1.
        assert_eq!(&px[..4], &[0, 232, 255, 255]);
        // aces(0.18) = 0.2669 -> sRGB 0.5535 -> 141.
        assert_eq!(px[4], 141);
        assert!(px[5] < px[6]);
    }
}
