//! The spot light's angular falloff against values derived here, independently of the
//! crate: `light::spot_scale_offset` packs a spot's angles into the scale and offset the
//! shaders use, and `brdf::spot_falloff` (the CPU twin of the WGSL) evaluates them. The GPU
//! tests compute their expected spot images with the same two functions, so this is what
//! makes those expectations mean something.
//!
//! The curve the code documents (`spot_falloff`: `saturate(cos * scale + offset)^2`,
//! `spot_scale_offset`: 0 at the outer angle, 1 at the inner one) is, written in f64 from
//! the angles alone: with `t = (cos(theta) - cos(outer)) / (cos(inner) - cos(outer))`
//! clamped to [0, 1], the falloff is `t^2`, a squared ramp linear in the cosine. It is 1 at
//! and inside the inner angle, 0 at and outside the outer angle; with inner == outer it
//! is a step (1 inside, 0 at and outside).

use tiledlight_cull::brdf::spot_falloff;
use tiledlight_cull::light::{spot_scale_offset, MAX_SPOT_ANGLE, MIN_SPOT_ANGLE};

const EPS: f64 = f32::EPSILON as f64;

/// How far, in cosine, the f32 evaluation may act as if the cosine were off: 2 EPS.
/// Worked out: `cos(inner)` and `cos(outer)` are each correctly rounded f32 near 1 (half
/// an ulp, EPS/4, plus libm's < 1 ulp: EPS/2 each); their difference is exact (Sterbenz);
/// `scale = 1 / diff` adds EPS/2 relative, a shift of at most EPS/2 * diff in cosine;
/// `offset = -cos_outer * scale` and `cos * scale + offset` each round by half an ulp of
/// values up to `scale`, EPS/2 in cosine units each. Total under 2 EPS (4 ulps of a cosine
/// near 1). A guard wider than that (a minimum ramp width) shows up as a shift far larger.
const COS_SLACK: f64 = 2.0 * EPS;
/// Absolute slack on the falloff itself: the final clamp, square and f32 rounding.
const VALUE_SLACK: f64 = 4.0 * EPS;

/// The falloff from the formula in the module docs, in f64, at cosine `c`.
fn expected(c: f64, inner: f64, outer: f64) -> f64 {
    let (ci, co) = (inner.cos(), outer.cos());
    if ci <= co {
        // inner == outer (or rounded equal): a step.
        return if c > co { 1.0 } else { 0.0 };
    }
    let t = ((c - co) / (ci - co)).clamp(0.0, 1.0);
    t * t
}

/// Checks the crate's falloff at cosine `c` (an f32, as the shaders get it) against the
/// formula: it must lie between the formula's values at `c - COS_SLACK` and
/// `c + COS_SLACK` (the ramp is monotone in the cosine), give or take `VALUE_SLACK`.
/// Returns the f32 value.
fn check(c: f32, inner_deg: f64, outer_deg: f64) -> f32 {
    let (inner, outer) = (inner_deg.to_radians(), outer_deg.to_radians());
    let (scale, offset) = spot_scale_offset(inner as f32, outer as f32);
    let got = spot_falloff(c, scale, offset);
    let c64 = f64::from(c);
    let lo = expected(c64 - COS_SLACK, inner, outer) - VALUE_SLACK;
    let hi = expected(c64 + COS_SLACK, inner, outer) + VALUE_SLACK;
    assert!(
        (lo..=hi).contains(&f64::from(got)),
        "inner {inner_deg} deg, outer {outer_deg} deg, cos {c} (angle {} deg): falloff {got}, formula gives [{lo}, {hi}] \
         (scale {scale}, offset {offset})",
        c64.acos().to_degrees()
    );
    got
}

/// Angle pairs (inner, outer) in degrees: the generator's and glTF's usual ones, inner ==
/// outer, inner 0, tiny cones (under the 0.5 degree the constructors clamp to: the packing
/// itself takes any angle), and cones near 90 degrees.
const PAIRS: [(f64, f64); 14] = [
    (10.5, 15.0),
    (0.0, 45.0),
    (31.5, 45.0),
    (20.0, 20.0),
    (0.0, 0.5),
    (0.5, 0.5),
    (0.25, 0.5),
    (0.1, 0.2),
    (0.0, 0.3),
    (0.05, 0.05),
    (60.0, 89.5),
    (89.0, 89.9),
    (89.5, 89.5),
    (0.0, 90.0),
];

/// Every pair, at angles across the whole range, just inside and outside both edges (in
/// steps of an f32 ulp of the cosine), and on the ramp. Catches a ramp linear in the angle
/// instead of the cosine, an unsquared ramp, swapped edges, an off-by-one clamp, and a
/// minimum ramp width: a guard of 1e-4 in cosine (what `spot_scale_offset` had) leaves a
/// 0.5 degree spot at 15% of full intensity on its own axis.
#[test]
fn falloff_follows_the_squared_cosine_ramp() {
    for (inner, outer) in PAIRS {
        // A sweep over [0, min(90, 2 outer)] degrees.
        let top = (2.0 * outer).min(90.0);
        for k in 0..=400 {
            let angle = top * f64::from(k) / 400.0;
            check(angle.to_radians().cos() as f32, inner, outer);
        }
        // Ulp steps around both edges.
        for edge in [inner, outer] {
            let c = edge.to_radians().cos() as f32;
            let mut below = c;
            let mut above = c;
            for _ in 0..8 {
                below = below.next_down();
                above = above.next_up().min(1.0);
                check(below, inner, outer);
                check(above, inner, outer);
            }
            check(c, inner, outer);
        }
    }
}

/// The values the docs promise, exactly where they are exact: 1 on the axis and anywhere
/// inside the inner angle by more than the slack, 0 at the outer angle and beyond, one
/// quarter at the cosine halfway between the edges (t = 1/2). Catches the same breakages
/// as the sweep with no slack to hide in.
#[test]
fn falloff_is_exact_at_its_landmarks() {
    for (inner, outer) in PAIRS {
        let (i, o) = (inner.to_radians(), outer.to_radians());
        let (scale, offset) = spot_scale_offset(i as f32, o as f32);
        let f = |c: f64| spot_falloff(c as f32, scale, offset);
        // On the axis and well inside the inner angle: full intensity.
        assert_eq!(f(1.0), 1.0, "inner {inner} outer {outer}: on the axis");
        if inner > 0.0 {
            assert_eq!(f((0.5 * i).cos()), 1.0, "inner {inner} outer {outer}: half the inner angle");
        }
        // Outside the outer angle, by a margin of a few ulps, and straight sideways.
        assert_eq!(f(o.cos() - 8.0 * EPS), 0.0, "inner {inner} outer {outer}: just outside");
        if outer < 90.0 {
            assert_eq!(f(0.0), 0.0, "inner {inner} outer {outer}: at 90 degrees");
        }
        assert_eq!(f(-1.0), 0.0, "inner {inner} outer {outer}: behind the light");
        // Halfway along the cosine ramp: t = 1/2, falloff 1/4 (wide enough ramps only: on
        // narrower ones the slack is a large share of the ramp).
        let (ci, co) = (i.cos(), o.cos());
        if ci - co > 1e-3 {
            let quarter = f64::from(f(0.5 * (ci + co)));
            assert!((quarter - 0.25).abs() < 1e-4, "inner {inner} outer {outer}: halfway gives {quarter}");
        }
    }
}

/// The angle range the constructors clamp to holds no special case: the narrowest and
/// widest accepted cones, with inner 0 and inner == outer, reach 1 on the axis and 0 just
/// past their edge.
#[test]
fn accepted_extremes_reach_full_and_zero() {
    for outer in [MIN_SPOT_ANGLE, MAX_SPOT_ANGLE] {
        for inner in [0.0, outer] {
            let (scale, offset) = spot_scale_offset(inner, outer);
            assert!(scale.is_finite() && offset.is_finite(), "inner {inner} outer {outer}");
            assert_eq!(spot_falloff(1.0, scale, offset), 1.0, "inner {inner} outer {outer}");
            let past = f64::from(outer).cos() - 8.0 * EPS;
            assert_eq!(spot_falloff(past as f32, scale, offset), 0.0, "inner {inner} outer {outer}");
        }
    }
}
