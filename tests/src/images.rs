//! Image comparison for tests: FLIP (`tiledlight_metrics::flip`) on tonemapped sRGB images (mean and a percentile
//! against stated thresholds) and relative error on linear HDR. On failure, writes
//! `<name>-actual.png`, `<name>-expected.png` and `<name>-difference.png` (FLIP heat map) to
//! `target/test-output`. Stored reference images are only rewritten when
//! `TILEDLIGHT_UPDATE_REFERENCES=1`.

use std::path::Path;

/// Thresholds for a FLIP comparison.
#[derive(Clone, Copy, Debug)]
pub struct FlipThresholds {
    /// Largest mean FLIP error accepted.
    pub mean: f32,
    /// Percentile to check (e.g. 0.99) and its largest accepted value.
    pub percentile: (f32, f32),
}

pub use tiledlight_metrics::FlipResult;

/// Writes RGBA8 pixels as a PNG.
pub fn save_png(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    image::save_buffer(path, rgba, w, h, image::ExtendedColorType::Rgba8)
        .unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

/// Compares `actual` with `expected` (RGBA8 sRGB) and panics with the numbers when a
/// threshold is exceeded, after writing the artefacts named `name`.
pub fn assert_flip(name: &str, w: u32, h: u32, expected: &[u8], actual: &[u8], t: FlipThresholds) -> FlipResult {
    let map = tiledlight_metrics::flip(w, h, expected, actual);
    let res = map.summary(t.percentile.0);
    eprintln!(
        "{name}: FLIP mean {:.5}, p{} {:.5}, max {:.5}",
        res.mean,
        t.percentile.0 * 100.0,
        res.percentile,
        res.max
    );
    if res.mean > t.mean || res.percentile > t.percentile.1 {
        let dir = crate::output_dir();
        save_png(&dir.join(format!("{name}-actual.png")), w, h, actual);
        save_png(&dir.join(format!("{name}-expected.png")), w, h, expected);
        let diff = map.heat_rgb();
        image::save_buffer(dir.join(format!("{name}-difference.png")), &diff, w, h, image::ExtendedColorType::Rgb8)
            .expect("write difference");
        panic!(
            "{name}: FLIP mean {} (limit {}), p{} {} (limit {}); images in {}",
            res.mean,
            t.mean,
            t.percentile.0 * 100.0,
            res.percentile,
            t.percentile.1,
            dir.display()
        );
    }
    res
}

/// Compares with a stored reference PNG under `tests/reference/<name>.png`; with
/// `TILEDLIGHT_UPDATE_REFERENCES=1` the reference is (re)written instead. A missing
/// reference fails the test with the command that creates it.
pub fn assert_matches_reference(name: &str, w: u32, h: u32, actual: &[u8], t: FlipThresholds) -> FlipResult {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("reference").join(format!("{name}.png"));
    if std::env::var("TILEDLIGHT_UPDATE_REFERENCES").as_deref() == Ok("1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        save_png(&path, w, h, actual);
        eprintln!("updated reference {}", path.display());
    }
    let expected = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "reference {} unreadable ({e}); create it with TILEDLIGHT_UPDATE_REFERENCES=1 cargo xtask test",
                path.display()
            )
        })
        .to_rgba8();
    assert_eq!((expected.width(), expected.height()), (w, h), "reference {} has another size", path.display());
    assert_flip(name, w, h, expected.as_raw(), actual, t)
}

/// Largest error of linear HDR `actual` vs `expected`, per channel, relative to
/// `max(|expected|, floor)`.
pub fn max_relative_error(expected: &[[f32; 4]], actual: &[[f32; 4]], floor: f32) -> (f32, usize) {
    let mut worst = (0.0f32, 0usize);
    for (i, (e, a)) in expected.iter().zip(actual).enumerate() {
        for c in 0..3 {
            // NaN counts as infinitely wrong.
            let err = (a[c] - e[c]).abs() / e[c].abs().max(floor);
            let err = if err.is_nan() { f32::INFINITY } else { err };
            if err > worst.0 {
                worst = (err, i);
            }
        }
    }
    worst
}

/// sRGB-encoded value in [0, 1] to linear (the exact sRGB curve, as GPUs decode
/// `*Srgb` formats).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear value in [0, 1] to sRGB-encoded (the exact sRGB curve, as GPUs encode `*Srgb`
/// formats).
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The heat map's colours as the README's legend documents them, written here
/// independently of `tiledlight_gpu::tonemap`'s palette: a log scale (`t = log2(count) /
/// log2(capacity)`) through blue, cyan, green, yellow and red at t = 0, 1/4, 1/2, 3/4, 1
/// (counts past the capacity red too), blended over the image at 60%; tiles that lost
/// lights (`dropped`: the light grid was full) magenta at 75%; tiles without lights
/// untouched.
pub fn documented_heat_colour(count: u32, capacity: u32, dropped: bool) -> Option<(glam::Vec3, f32)> {
    const ANCHORS: [[f32; 3]; 5] =
        [[0.0, 0.0, 1.0], [0.0, 1.0, 1.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
    if count == 0 {
        return None;
    }
    if dropped {
        return Some((glam::Vec3::new(1.0, 0.0, 1.0), 0.75));
    }
    let t = ((count as f64).log2() / (capacity as f64).log2()).min(1.0) * 4.0;
    let k = (t.floor() as usize).min(3);
    let f = (t - k as f64) as f32;
    let (a, b) = (glam::Vec3::from(ANCHORS[k]), glam::Vec3::from(ANCHORS[k + 1]));
    Some((a + (b - a) * f, 0.6))
}

/// What each channel of a heat-map pixel should be, in 8-bit sRGB steps, with the
/// tolerance in the same steps: `plain` (the frame's RGBA8 sRGB pixel without the heat
/// map) where the tile is untouched (`expected` None: within 1, rounding), else the
/// documented colour ([`documented_heat_colour`]) blended over it in linear space (within
/// 2: the GPU blends and rounds the encoded value once more).
pub fn expected_heat_pixel(expected: Option<(glam::Vec3, f32)>, plain: &[u8]) -> ([f32; 3], f32) {
    match expected {
        None => (std::array::from_fn(|c| plain[c] as f32), 1.0),
        Some((colour, alpha)) => (
            std::array::from_fn(|c| {
                let under = srgb_to_linear(plain[c] as f32 / 255.0);
                linear_to_srgb(colour[c] * alpha + under * (1.0 - alpha)) * 255.0
            }),
            2.0,
        ),
    }
}

/// Asserts that every pixel of one tile (`x0, x1, y0, y1`, half-open) of the heat map
/// `heat` is [`expected_heat_pixel`] of the same pixel of `plain` (both RGBA8 sRGB, `width`
/// pixels a row); `what` names the tile and its count in the failure.
pub fn assert_heat_tile(
    heat: &[u8],
    plain: &[u8],
    width: u32,
    (x0, x1, y0, y1): (u32, u32, u32, u32),
    expected: Option<(glam::Vec3, f32)>,
    what: &str,
) {
    for (x, y) in (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y))) {
        let i = ((y * width + x) * 4) as usize;
        let (wants, tolerance) = expected_heat_pixel(expected, &plain[i..i + 3]);
        for (ch, want) in wants.into_iter().enumerate() {
            let got = heat[i + ch] as f32;
            assert!(
                (got - want).abs() <= tolerance,
                "{what}, pixel ({x}, {y}) channel {ch}: {got}, expected {want:.1} (within {tolerance})"
            );
        }
    }
}
