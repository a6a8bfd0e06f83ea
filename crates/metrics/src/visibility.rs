//! The visibility error of a shadowed image against a reference with exact visibility
//! (shadow-accuracy's ray cast): the share of the light misplaced, split into light lost
//! (darker than the reference) and leaked (brighter), and a picture of where.
//!
//! Pure CPU; uses [`crate::luminance`] and [`crate::tonemap`].

use crate::luminance;
use crate::tonemap::tonemap;

/// The visibility error of `test` against `reference` over the pixels in `scored`:
/// (misplaced, lost, leaked) luminance, each over the reference's luminance there.
pub fn visibility_error(reference: &[[f32; 4]], test: &[[f32; 4]], scored: &[bool]) -> (f64, f64, f64) {
    let (mut total, mut lost, mut leaked) = (0.0f64, 0.0f64, 0.0f64);
    for ((r, t), &s) in reference.iter().zip(test).zip(scored) {
        if !s {
            continue;
        }
        let (lr, lt) = (luminance(r), luminance(t));
        total += lr;
        if lt < lr {
            lost += lr - lt;
        } else {
            leaked += lt - lr;
        }
    }
    if total <= 0.0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    ((lost + leaked) / total, lost / total, leaked / total)
}

/// A picture of where `test` misplaces light against `reference` (RGB8): the reference's
/// tonemapped luminance in dim grey, light lost (test darker) in red and light leaked
/// (test brighter) in green, with brightness `sqrt(|difference| / largest difference)` so
/// that small differences show.
pub fn misplaced_rgb(reference: &[[f32; 4]], test: &[[f32; 4]], exposure: f32) -> Vec<u8> {
    let grey: Vec<[f32; 4]> = reference.iter().map(|p| [luminance(p) as f32; 4]).collect();
    let base = tonemap(&grey, exposure);
    let diff: Vec<f64> = reference.iter().zip(test).map(|(r, t)| luminance(t) - luminance(r)).collect();
    let largest = diff.iter().fold(0.0f64, |m, d| m.max(d.abs())).max(f64::MIN_POSITIVE);
    let level = |d: f64| ((d / largest).sqrt() * 255.0).round() as u8;
    diff.iter()
        .enumerate()
        .flat_map(|(i, &d)| {
            let b = base[i * 4] / 3;
            if d < 0.0 {
                [b.max(level(-d)), b, b]
            } else {
                [b, b.max(level(d)), b]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visibility_error_splits_lost_and_leaked() {
        let r = vec![[1.0, 1.0, 1.0, 1.0]; 4];
        let mut s = r.clone();
        s[0] = [0.0, 0.0, 0.0, 1.0];
        s[1] = [1.5, 1.5, 1.5, 1.0];
        let (v, lost, leaked) = visibility_error(&r, &s, &[true; 4]);
        assert!((v - 0.375).abs() < 1e-12 && (lost - 0.25).abs() < 1e-12 && (leaked - 0.125).abs() < 1e-12);
        let (v, ..) = visibility_error(&r, &s, &[false, false, true, true]);
        assert_eq!(v, 0.0, "unscored pixels do not count");
        assert!(visibility_error(&r, &s, &[false; 4]).0.is_nan());
    }
}
