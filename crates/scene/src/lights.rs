//! Random light sets for the stress tests: point and spot lights uniform in a box, with
//! saturated colours and intensities that give radii of a few metres (the built-in
//! courtyard's lights), or radii fitted to any box's size and the light count
//! ([`fitted_intensity_range`]: the same draws, intensities scaled). Deterministic per
//! seed; point and spot lights come from separate random streams so changing one count
//! never changes the other kind. Depends on glam, rand, rand_pcg, tiledlight-cull and
//! this crate's model and error modules.

use std::f32::consts::TAU;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use tiledlight_cull::Light;

use crate::error::SceneError;
use crate::model::Aabb;

/// The most lights (point and spot together) [`random_lights`] generates: 2^20.
pub const MAX_LIGHTS: u64 = 1 << 20;

/// Default intensity threshold: with [`DEFAULT_INTENSITY_RANGE`] it gives radii from
/// 1.5 m to 4 m (`r = sqrt(intensity / threshold)` for a colour whose largest
/// component is 1), a few bays of the default courtyard.
pub const DEFAULT_LIGHT_THRESHOLD: f32 = 0.1;

/// Default intensity range (see [`DEFAULT_LIGHT_THRESHOLD`]): 1.5^2 * 0.1 to 4^2 * 0.1.
pub const DEFAULT_INTENSITY_RANGE: (f32, f32) = (0.225, 1.6);

/// Fraction of the bounds' size kept clear on each side, so lights sit inside the
/// walls rather than in them.
const BOUNDS_MARGIN: f32 = 0.05;

/// Mean-cube radius of intensities uniform in `range` at `threshold`: the radius `r` with
/// `r^3 = E[(I / threshold)^1.5]`, the one whose sphere volume is the lights' mean (so the
/// mean number of lights reaching a point of a box they fill uniformly). 3.09 m for
/// [`DEFAULT_INTENSITY_RANGE`] at [`DEFAULT_LIGHT_THRESHOLD`].
pub fn mean_cube_radius(range: (f32, f32), threshold: f32) -> f32 {
    let (a, b) = (f64::from(range.0), f64::from(range.1));
    // E[I^1.5] for I uniform in [a, b]: (b^2.5 - a^2.5) / (2.5 (b - a)).
    let mean = if b > a { (b.powf(2.5) - a.powf(2.5)) / (2.5 * (b - a)) } else { a.powf(1.5) };
    (mean / f64::from(threshold).powf(1.5)).cbrt() as f32
}

/// The radius that puts `k` lights, on average, within reach of a surface point when
/// `count` lights fill `bounds` (shrunk by [`random_lights`]' 5% margin) uniformly.
///
/// Derivation: the lights have density `s = count / V`. A surface point inside the box sees
/// the lights in the half ball in front of it: `k = s * 2/3 pi r^3`, so
/// `r = cbrt(3 k V / (2 pi count))`. A flat box (a floor, a façade) holds them in a slab
/// thinner than `r`, where a point sees a disc of the slab instead: `k = count / A * pi r^2`
/// with `A` the box's largest face, `r = sqrt(k A / (pi count))`; the larger of the two
/// holds in both cases (at a thickness of `r` the disc gives 2/3 of the ball's count). Each
/// side is counted as at least 1/1000 of the largest, so a box flat in one axis still gets
/// a radius.
///
/// NaN for invalid or point-like bounds, no lights, or a `k` that is not finite and
/// positive.
pub fn bounds_light_radius(bounds: &Aabb, count: u32, k: f32) -> f32 {
    let size = bounds.size().as_dvec3() * (1.0 - 2.0 * f64::from(BOUNDS_MARGIN));
    let largest = size.max_element();
    if !(bounds.is_valid() && largest > 0.0 && largest.is_finite() && count > 0 && k.is_finite() && k > 0.0) {
        return f32::NAN;
    }
    let s = size.max(glam::DVec3::splat(largest * 1e-3));
    let (n, k) = (f64::from(count), f64::from(k));
    let volume = s.x * s.y * s.z;
    let face = (s.x * s.y).max(s.y * s.z).max(s.x * s.z);
    let ball = (3.0 * k * volume / (2.0 * std::f64::consts::PI * n)).cbrt();
    let slab = (k * face / (std::f64::consts::PI * n)).sqrt();
    ball.max(slab) as f32
}

/// The intensity range that makes [`random_lights`] fit `bounds`: [`DEFAULT_INTENSITY_RANGE`]
/// scaled so that the lights' [`mean_cube_radius`] is [`bounds_light_radius`] of `bounds`,
/// `count` and `k`. The same draws as the courtyard's lights (positions, colours, the
/// spread of radii: 0.49 to 1.29 times that radius), only brighter or dimmer; intensities
/// scale with `threshold`, so the radii do not depend on it. None when there is no such
/// radius (see [`bounds_light_radius`]).
pub fn fitted_intensity_range(bounds: &Aabb, count: u32, k: f32, threshold: f32) -> Option<(f32, f32)> {
    let r = bounds_light_radius(bounds, count, k);
    let unit = mean_cube_radius(DEFAULT_INTENSITY_RANGE, 1.0);
    // Radii are sqrt(I / threshold): scaling I by c^2 * threshold scales them by c.
    let scale = threshold * (r / unit).powi(2);
    let range = (DEFAULT_INTENSITY_RANGE.0 * scale, DEFAULT_INTENSITY_RANGE.1 * scale);
    (scale.is_finite() && scale > 0.0 && range.1.is_finite()).then_some(range)
}

/// Options of [`random_lights`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightOptions {
    /// Number of point lights.
    pub num_point: u32,
    /// Number of spot lights.
    pub num_spot: u32,
    /// Random seed: the same seed gives the same lights.
    pub seed: u64,
    /// Intensity threshold that sets each light's radius (positive).
    pub threshold: f32,
    /// Intensities are uniform in `[min, max]` (non-negative, min <= max, max > 0).
    pub intensity_range: (f32, f32),
}

impl Default for LightOptions {
    /// 1024 point lights, no spot lights, seed 1, radii 1.5 m to 4 m.
    fn default() -> Self {
        Self {
            num_point: 1024,
            num_spot: 0,
            seed: 1,
            threshold: DEFAULT_LIGHT_THRESHOLD,
            intensity_range: DEFAULT_INTENSITY_RANGE,
        }
    }
}

/// Stream tags: the point and spot generators differ in their PCG increment, not only
/// in their state, so no seed's spot stream equals another seed's point stream.
const POINT_STREAM: u64 = 0x706f_696e_7473;
const SPOT_STREAM: u64 = 0x0073_706f_7473;

/// SplitMix64's finaliser: spreads nearby seeds (1, 2, 3...) over the whole state.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

pub(crate) fn stream_rng(seed: u64, stream: u64) -> Pcg64 {
    let words = [mix(seed), mix(seed ^ 0x5bd1_e995), stream, mix(stream)];
    let mut bytes = [0u8; 32];
    for (chunk, w) in bytes.chunks_exact_mut(8).zip(words) {
        chunk.copy_from_slice(&w.to_le_bytes());
    }
    Pcg64::from_seed(bytes)
}

/// A fully saturated colour of hue `h` in [0, 1) (red, yellow, green, cyan, blue,
/// magenta) with its largest component 1: the random lights' colours.
pub fn hue_color(h: f32) -> Vec3 {
    let x = h.rem_euclid(1.0) * 6.0;
    let f = |n: f32| {
        let k = (n + x) % 6.0;
        1.0 - (k.min(4.0 - k).clamp(0.0, 1.0))
    };
    // The HSV-to-RGB formula with saturation and value 1.
    Vec3::new(f(5.0), f(3.0), f(1.0))
}

fn check_options(bounds: &Aabb, opts: &LightOptions) -> Result<(), SceneError> {
    let requested = u64::from(opts.num_point) + u64::from(opts.num_spot);
    if requested > MAX_LIGHTS {
        return Err(SceneError::TooManyLights { requested, limit: MAX_LIGHTS });
    }
    if requested == 0 {
        return Ok(());
    }
    if !opts.threshold.is_finite() || opts.threshold <= 0.0 {
        return Err(SceneError::InvalidArgument(format!(
            "light threshold {} must be finite and positive",
            opts.threshold
        )));
    }
    let (lo, hi) = opts.intensity_range;
    if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo <= hi && hi > 0.0) {
        return Err(SceneError::InvalidArgument(format!(
            "light intensity range ({lo}, {hi}) must be finite with 0 <= min <= max and max > 0"
        )));
    }
    if !bounds.is_valid() {
        return Err(SceneError::InvalidArgument(format!(
            "light bounds {:?}..{:?} are empty or not finite",
            bounds.min, bounds.max
        )));
    }
    Ok(())
}

/// Draws a position, colour and intensity. Intensities of 0 would give a light no
/// radius, so the draw is kept above a tiny floor.
fn draw_common(rng: &mut Pcg64, min: Vec3, size: Vec3, range: (f32, f32)) -> (Vec3, Vec3, f32) {
    let position = min + size * Vec3::new(rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>());
    let color = hue_color(rng.random::<f32>());
    let intensity = (range.0 + (range.1 - range.0) * rng.random::<f32>()).max(range.1 * 1e-6);
    (position, color, intensity)
}

/// Generates `num_point` point lights then `num_spot` spot lights, uniformly inside
/// `bounds` shrunk by 5% of its size on every side. Colours are saturated hues (largest
/// component 1); intensities are uniform in `intensity_range`; radii follow from
/// `threshold`. Spot lights point within 60 degrees of straight down, with outer
/// half-angles of 15 to 45 degrees and inner = 0.7 * outer.
///
/// Errors: more than [`MAX_LIGHTS`] in total; a non-positive threshold; a bad intensity
/// range; invalid bounds (the last three only when some light is asked for).
pub fn random_lights(bounds: &Aabb, opts: &LightOptions) -> Result<Vec<Light>, SceneError> {
    check_options(bounds, opts)?;
    let total = opts.num_point as usize + opts.num_spot as usize;
    let mut lights = Vec::with_capacity(total);
    if total == 0 {
        return Ok(lights);
    }
    let margin = bounds.size() * BOUNDS_MARGIN;
    let (min, size) = (bounds.min + margin, bounds.size() - 2.0 * margin);
    let wrap = |e: tiledlight_cull::CullError| SceneError::InvalidArgument(format!("cannot build a random light: {e}"));

    let mut rng = stream_rng(opts.seed, POINT_STREAM);
    for _ in 0..opts.num_point {
        let (p, c, i) = draw_common(&mut rng, min, size, opts.intensity_range);
        lights.push(Light::point(p, c, i, opts.threshold).map_err(wrap)?);
    }

    let mut rng = stream_rng(opts.seed, SPOT_STREAM);
    let cos_max_tilt = 60f32.to_radians().cos();
    for _ in 0..opts.num_spot {
        let (p, c, i) = draw_common(&mut rng, min, size, opts.intensity_range);
        // Uniform over the spherical cap around -Y: cos(tilt) uniform in [cos 60, 1].
        let cos_tilt = cos_max_tilt + (1.0 - cos_max_tilt) * rng.random::<f32>();
        let sin_tilt = (1.0 - cos_tilt * cos_tilt).max(0.0).sqrt();
        let azimuth = TAU * rng.random::<f32>();
        let direction = Vec3::new(sin_tilt * azimuth.cos(), -cos_tilt, sin_tilt * azimuth.sin());
        let outer = (15.0 + 30.0 * rng.random::<f32>()).to_radians();
        lights.push(Light::spot(p, direction, c, i, 0.7 * outer, outer, opts.threshold).map_err(wrap)?);
    }
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_cull::LightKind;

    fn courtyard() -> Aabb {
        Aabb::new(Vec3::new(-8.5, 0.0, -18.5), Vec3::new(8.5, 13.0, 18.5))
    }

    #[test]
    fn deterministic_and_exact_counts() {
        let opts = LightOptions { num_point: 300, num_spot: 200, seed: 7, ..LightOptions::default() };
        let a = random_lights(&courtyard(), &opts).unwrap();
        let b = random_lights(&courtyard(), &opts).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.len(), 500);
        assert_eq!(a.iter().filter(|l| l.is_spot()).count(), 200);
        assert!(a[..300].iter().all(|l| !l.is_spot()), "points come first");
        let c = random_lights(&courtyard(), &LightOptions { seed: 8, ..opts }).unwrap();
        assert_ne!(a, c, "another seed gives other lights");
    }

    #[test]
    fn default_lights_fit_the_courtyard() {
        let bounds = courtyard();
        let lights = random_lights(&bounds, &LightOptions { num_spot: 256, ..LightOptions::default() }).unwrap();
        assert_eq!(lights.len(), 1024 + 256);
        let inner = Aabb::new(bounds.min + bounds.size() * 0.05 - 1e-4, bounds.max - bounds.size() * 0.05 + 1e-4);
        for l in &lights {
            assert!(inner.contains(l.position), "{} outside {inner:?}", l.position);
            assert!((l.color.max_element() - 1.0).abs() < 1e-6 && l.color.min_element() >= 0.0, "{}", l.color);
            assert!(l.radius >= 1.5 - 1e-4 && l.radius <= 4.0 + 1e-4, "radius {}", l.radius);
            if let LightKind::Spot { direction, inner_angle, outer_angle } = l.kind {
                assert!(direction.dot(Vec3::NEG_Y) >= 60f32.to_radians().cos() - 1e-5, "{direction}");
                assert!((direction.length() - 1.0).abs() < 1e-5);
                let deg = outer_angle.to_degrees();
                assert!((15.0 - 1e-3..=45.0 + 1e-3).contains(&deg), "outer {deg}");
                assert!((inner_angle - 0.7 * outer_angle).abs() < 1e-6);
            }
        }
        // Hues are spread: some light is mostly red, some mostly green, some mostly blue.
        for axis in 0..3 {
            assert!(lights.iter().any(|l| l.color[axis] == 1.0 && l.color.min_element() < 0.2));
        }
    }

    #[test]
    fn point_and_spot_streams_are_independent() {
        let bounds = courtyard();
        let base = LightOptions { num_point: 64, num_spot: 0, seed: 3, ..LightOptions::default() };
        let points_only = random_lights(&bounds, &base).unwrap();
        let with_spots = random_lights(&bounds, &LightOptions { num_spot: 50, ..base }).unwrap();
        assert_eq!(points_only[..], with_spots[..64]);
        let more_points = random_lights(&bounds, &LightOptions { num_point: 100, num_spot: 50, ..base }).unwrap();
        assert_eq!(with_spots[64..], more_points[100..], "spots do not depend on the point count");
        assert_eq!(points_only[..], more_points[..64], "more points extend the same sequence");
    }

    #[test]
    fn counts_and_arguments_are_checked() {
        let bounds = courtyard();
        let err = random_lights(&bounds, &LightOptions { num_point: 1 << 20, num_spot: 1, ..LightOptions::default() })
            .unwrap_err();
        assert!(matches!(err, SceneError::TooManyLights { requested: 1_048_577, limit: 1_048_576 }));
        assert!(err.to_string().contains("1048576"), "{err}");
        let none = LightOptions { num_point: 0, num_spot: 0, ..LightOptions::default() };
        assert!(random_lights(&bounds, &none).unwrap().is_empty());
        assert!(random_lights(&Aabb::empty(), &none).unwrap().is_empty());
        let one = LightOptions { num_point: 1, ..none };
        assert!(random_lights(&Aabb::empty(), &one).is_err());
        assert!(random_lights(&bounds, &LightOptions { threshold: 0.0, ..one }).is_err());
        assert!(random_lights(&bounds, &LightOptions { threshold: f32::NAN, ..one }).is_err());
        assert!(random_lights(&bounds, &LightOptions { intensity_range: (2.0, 1.0), ..one }).is_err());
        assert!(random_lights(&bounds, &LightOptions { intensity_range: (0.0, f32::INFINITY), ..one }).is_err());
        // A flat box (a plane scene) still works.
        let flat = Aabb::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0));
        assert_eq!(random_lights(&flat, &LightOptions { num_point: 10, ..none }).unwrap().len(), 10);
    }

    #[test]
    fn fitted_radii_follow_the_size_and_the_count() {
        let cube = |side: f32| Aabb::new(Vec3::ZERO, Vec3::splat(side));
        let radii = |bounds: &Aabb, count: u32| {
            let range = fitted_intensity_range(bounds, count, 8.0, DEFAULT_LIGHT_THRESHOLD).unwrap();
            let opts = LightOptions { num_point: count, intensity_range: range, ..LightOptions::default() };
            random_lights(bounds, &opts).unwrap().iter().map(|l| l.radius).collect::<Vec<_>>()
        };
        // A 2 m model and a 100 m scene: the same lights, radii 50 times as large.
        let (small, large) = (radii(&cube(2.0), 1024), radii(&cube(100.0), 1024));
        for (s, l) in small.iter().zip(&large) {
            assert!((l / s - 50.0).abs() < 50.0 * 1e-4, "{s} vs {l}");
        }
        // The radii keep the courtyard's spread around the fitted radius (0.49 to 1.29 of it).
        let r = bounds_light_radius(&cube(2.0), 1024, 8.0);
        let (lo, hi) = small.iter().fold((f32::MAX, 0f32), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(lo >= 0.48 * r && hi <= 1.30 * r && hi > 1.2 * r && lo < 0.6 * r, "{lo}..{hi} around {r}");
        // Their mean cube is the fitted radius, within the sampling error of 1024 draws (~3%).
        let mean_cube = (small.iter().map(|x| f64::from(x.powi(3))).sum::<f64>() / small.len() as f64).cbrt();
        assert!((mean_cube as f32 / r - 1.0).abs() < 0.03, "{mean_cube} vs {r}");
        // Eight times the lights in the same box: half the radius (the ball formula).
        let r8 = bounds_light_radius(&cube(2.0), 8 * 1024, 8.0);
        assert!((r / r8 - 2.0).abs() < 1e-4, "{r} {r8}");
        // The threshold sets intensities, not radii.
        let dim = fitted_intensity_range(&cube(2.0), 1024, 8.0, 0.01).unwrap();
        let bright = fitted_intensity_range(&cube(2.0), 1024, 8.0, 1.0).unwrap();
        assert!((bright.1 / dim.1 - 100.0).abs() < 1e-2);
        // k lights per point: the ball formula solved back.
        let v = 1.8f64.powi(3);
        let k = 1024.0 / v * 2.0 / 3.0 * std::f64::consts::PI * f64::from(r).powi(3);
        assert!((k - 8.0).abs() < 1e-3, "k {k}");
    }

    #[test]
    fn a_flat_box_gets_the_slab_radius_and_bad_boxes_none() {
        // A 100 m x 100 m floor: the slab formula, k = n / A * pi r^2.
        let floor = Aabb::new(Vec3::new(-50.0, 0.0, -50.0), Vec3::new(50.0, 0.0, 50.0));
        let r = bounds_light_radius(&floor, 1000, 8.0);
        let a = 90.0f64 * 90.0;
        assert!((f64::from(r) - (8.0 * a / (std::f64::consts::PI * 1000.0)).sqrt()).abs() < 1e-3, "{r}");
        assert!(bounds_light_radius(&Aabb::empty(), 10, 8.0).is_nan());
        assert!(bounds_light_radius(&Aabb::new(Vec3::ONE, Vec3::ONE), 10, 8.0).is_nan());
        assert!(bounds_light_radius(&floor, 0, 8.0).is_nan());
        assert!(bounds_light_radius(&floor, 10, 0.0).is_nan());
        assert_eq!(fitted_intensity_range(&Aabb::empty(), 10, 8.0, 0.1), None);
        // The courtyard's own range: a mean-cube radius of 3.09 m.
        let m = mean_cube_radius(DEFAULT_INTENSITY_RANGE, DEFAULT_LIGHT_THRESHOLD);
        assert!((m - 3.093).abs() < 1e-3, "{m}");
    }

    #[test]
    fn hues_are_saturated() {
        for i in 0..60 {
            let c = hue_color(i as f32 / 60.0);
            assert!((c.max_element() - 1.0).abs() < 1e-6 && c.min_element().abs() < 1e-6, "{c}");
        }
        assert_eq!(hue_color(0.0), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(hue_color(1.0 / 3.0), Vec3::new(0.0, 1.0, 0.0));
    }
}
