//! Histogram matching of RGBA8 images: one image's tone curve mapped onto another's, so a
//! comparison after it (FLIP) shows where the light falls rather than how the two
//! renderers' tonemappers differ (the peer report's "tone curves matched" column).
//!
//! Pure CPU, no dependency beyond this crate.

/// `test` with each colour channel remapped so that its histogram is `reference`'s (each
/// value goes to the reference value at the same cumulative share of pixels). A monotone
/// change of tone curve, exposure or per-channel gain (the renderers' tonemappers differ)
/// disappears; where the light falls does not: a FLIP after this compares places.
pub fn match_histograms(reference: &[u8], test: &[u8]) -> Vec<u8> {
    let mut out = test.to_vec();
    for c in 0..3 {
        let cdf = |img: &[u8]| {
            let mut h = [0u64; 256];
            for p in img.chunks_exact(4) {
                h[p[c] as usize] += 1;
            }
            let mut acc = 0;
            h.map(|n| {
                acc += n;
                acc
            })
        };
        let (cr, ct) = (cdf(reference), cdf(test));
        let (nr, nt) = (cr[255].max(1) as f64, ct[255].max(1) as f64);
        let map: Vec<u8> = (0..256)
            .map(|v| {
                let share = ct[v] as f64 / nt;
                cr.iter().position(|&n| n as f64 / nr >= share - 1e-12).unwrap_or(255) as u8
            })
            .collect();
        for p in out.chunks_exact_mut(4) {
            p[c] = map[p[c] as usize];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 64x36 RGBA8 gradient with a different ramp per channel.
    fn gradient() -> Vec<u8> {
        (0..36u32)
            .flat_map(|y| (0..64u32).flat_map(move |x| [(x * 4) as u8, (y * 7) as u8, ((x + y) * 2) as u8, 255]))
            .collect()
    }

    #[test]
    fn a_monotone_tone_curve_is_undone_and_a_moved_light_is_not() {
        let reference = gradient();
        // Another tone curve: darker, a gamma per channel (monotone, so the order of
        // values and their histogram ranks are kept).
        let curved: Vec<u8> = reference
            .chunks_exact(4)
            .flat_map(|p| {
                let f = |v: u8, g: f32| ((v as f32 / 255.0).powf(g) * 200.0).round() as u8;
                [f(p[0], 1.8), f(p[1], 0.7), f(p[2], 1.3), 255]
            })
            .collect();
        let matched = match_histograms(&reference, &curved);
        let worst = reference.iter().zip(&matched).map(|(a, b)| (*a as i32 - *b as i32).abs()).max().unwrap();
        // Only values the curve merged (a 0..200 range holds fewer levels) stay apart.
        assert!(worst <= 8, "a tone curve left {worst} levels of difference");
        let flip = |t: &[u8]| crate::flip(64, 36, &reference, t).summary(0.99).mean;
        assert!(flip(&matched) < 0.25 * flip(&curved), "{} vs {}", flip(&matched), flip(&curved));
        // The same image with its ramp mirrored (light in other places): the histograms
        // are the same, so matching changes nothing and the error stays.
        let moved: Vec<u8> = (0..36u32)
            .flat_map(|y| {
                (0..64u32).flat_map(move |x| [((63 - x) * 4) as u8, (y * 7) as u8, ((63 - x + y) * 2) as u8, 255])
            })
            .collect();
        assert_eq!(match_histograms(&reference, &moved), moved);
        assert!(flip(&moved) > 0.1, "{}", flip(&moved));
    }
}
