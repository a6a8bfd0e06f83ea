//! The physical bounds of the shared BRDF (`tiledlight_cull::brdf`, twin of
//! `shaders/common/brdf.wgsl`) for every direction pair, not only finite values:
//!
//! - the GGX NDF never exceeds its peak `1 / (pi a^2)` (`ggx_ndf`, `ggx_peak`), and is 0
//!   where `n.h <= 0`;
//! - `brdf_cos` never exceeds `brdf_cos_bound` (the diffuse term's maximum plus the peak
//!   NDF times the visibility term's maximum, `0.5 / a`), including with the eye behind the
//!   shading surface (`n.v < 0`, which smooth-shaded silhouettes and normal maps produce)
//!   and the light nearly opposite the eye, where `h` tends to `-n`.
//!
//! Without the NDF's chi+ factor (`n.h` clamped to 0 and `|n x h| -> 0` as `h -> -n`) the
//! NDF grew without bound: 3,300 for `brdf_cos` at roughness 0.35 against a bound of 87;
//! that was the error budget's worst pixel. The GPU side of the same bound is
//! `tests/tests/heatmap_and_brdf.rs::wgsl_brdf_equals_its_twin_and_stays_under_the_ggx_peak`.

mod common;

use glam::Vec3;
use proptest::prelude::*;
use tiledlight_cull::brdf::{brdf_cos, brdf_cos_bound, ggx_ndf, ggx_peak, Surface, MIN_ROUGHNESS};

/// Relative slack on the bounds: f32 unit vectors are unit only to a few ulps, so `dd =
/// |n|^2 |h|^2 - n.h^2 (1 - a^2)` can fall below `a^2` by a few ulps relative (about 1e-6);
/// 1e-5 leaves a factor of ten over that and is 1e-5 of the peak, far below the 1,000x
/// overshoot this guards against.
const SLACK: f32 = 1e-5;

fn unit_vec() -> impl Strategy<Value = Vec3> {
    (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
        .prop_filter_map("a direction", |(x, y, z)| Vec3::new(x, y, z).try_normalize())
}

/// Perceptual roughness over [0, 1], below the clamp included, weighted towards smooth
/// surfaces (where the peak is highest and the singularity was sharpest).
fn roughness() -> impl Strategy<Value = f32> {
    prop_oneof![0.0f32..0.1, 0.0f32..=1.0, Just(MIN_ROUGHNESS), Just(0.35), Just(1.0)]
}

fn surface(roughness: f32, metallic: f32) -> Surface {
    Surface { albedo: Vec3::ONE, roughness, metallic }
}

fn alpha2(roughness: f32) -> f32 {
    let r = roughness.clamp(MIN_ROUGHNESS, 1.0);
    (r * r) * (r * r)
}

/// The direction pairs that produced the singularity: the half vector `h` within a small
/// angle of `-n` (or of `n`, the peak), the light just above the horizon, the view its
/// mirror image about `h` (so `v + l` is along `h`, with the eye behind the surface when
/// `h` is near `-n`).
fn mirrored_pair() -> impl Strategy<Value = (Vec3, Vec3, Vec3)> {
    (unit_vec(), unit_vec(), 0.0f32..0.3, prop::bool::ANY, 1e-4f32..1.0).prop_filter_map(
        "a light above the horizon",
        |(n, tilt, angle, opposite, lift)| {
            let side = tilt.cross(n).try_normalize()?;
            let axis = if opposite { -n } else { n };
            let h = (axis * angle.cos() + side * angle.sin()).normalize();
            // l: in the plane of n and `side`, `lift` above the horizon.
            let l = (side * (1.0 - lift * lift).sqrt() + n * lift).normalize();
            let v = (2.0 * l.dot(h) * h - l).try_normalize()?;
            (n.dot(l) > 0.0).then_some((n, v, l))
        },
    )
}

proptest! {
    #![proptest_config(common::proptest_config(4096))]

    /// The NDF stays at or below its peak for any unit `n` and `h`, and is 0 where
    /// `n.h <= 0`.
    #[test]
    fn ggx_ndf_never_exceeds_its_peak(n in unit_vec(), h in unit_vec(), r in roughness()) {
        let a2 = alpha2(r);
        let d = ggx_ndf(n, h, a2);
        prop_assert!(d.is_finite() && d >= 0.0, "D = {d}");
        prop_assert!(d <= ggx_peak(a2) * (1.0 + SLACK), "D = {d} above the peak {}", ggx_peak(a2));
        if n.dot(h) <= 0.0 {
            prop_assert_eq!(d, 0.0);
        }
    }

    /// `brdf_cos` stays under its bound for random directions (the eye behind the surface
    /// in half the cases).
    #[test]
    fn brdf_cos_stays_under_its_bound(n in unit_vec(), v in unit_vec(), l in unit_vec(), r in roughness(),
                                      metallic in prop_oneof![Just(0.0f32), Just(1.0f32), 0.0f32..1.0]) {
        let value = brdf_cos(n, v, l, &surface(r, metallic));
        prop_assert!(value.is_finite() && value.min_element() >= 0.0, "{value}");
        prop_assert!(value.max_element() <= brdf_cos_bound(r) * (1.0 + SLACK),
            "brdf_cos {value} above {} (n.v {}, n.l {})", brdf_cos_bound(r), n.dot(v), n.dot(l));
    }

    /// ... and for the mirrored pairs that reach the NDF's peak and its former singularity.
    #[test]
    fn brdf_cos_stays_under_its_bound_with_h_near_minus_n((n, v, l) in mirrored_pair(), r in roughness(),
                                                          metallic in prop_oneof![Just(0.0f32), Just(1.0f32)]) {
        let value = brdf_cos(n, v, l, &surface(r, metallic));
        prop_assert!(value.is_finite() && value.min_element() >= 0.0, "{value}");
        prop_assert!(value.max_element() <= brdf_cos_bound(r) * (1.0 + SLACK),
            "brdf_cos {value} above {} (n.v {}, n.l {}, n.h {})", brdf_cos_bound(r), n.dot(v), n.dot(l),
            n.dot((v + l).normalize()));
    }
}

/// The case the error budget found (roughness 0.35, the eye behind the shading surface, the
/// light nearly opposite it): finite, under the bound, and with no specular term at all
/// (every microfacet normal near `-n` faces away).
#[test]
fn the_budgets_worst_pixel_case_has_no_specular_spike() {
    let n = Vec3::Y;
    let l = Vec3::new(0.995, 0.1, 0.0).normalize();
    // The eye nearly opposite the light and behind the surface, so h = normalize(v + l) lies
    // within a few degrees of -n (h = -n exactly would need v = -l, where h is undefined).
    let v = (-l - 0.05 * n).normalize();
    let h = (v + l).normalize();
    assert!(n.dot(v) < 0.0, "the eye is behind the surface");
    assert!(n.dot(h) < -0.99, "h is near -n: n.h = {}", n.dot(h));
    for r in [MIN_ROUGHNESS, 0.35, 1.0] {
        let s = surface(r, 1.0);
        let value = brdf_cos(n, v, l, &s);
        assert!(value.max_element() <= brdf_cos_bound(r), "roughness {r}: {value} above {}", brdf_cos_bound(r));
        // Metallic 1: no diffuse, so the value is the specular term alone, which is 0.
        assert_eq!(value, Vec3::ZERO, "roughness {r}");
    }
    // The bound is not vacuous: the peak of the mirror configuration reaches a tenth of it.
    let r = 0.35;
    let v = (2.0 * l.dot(n) * n - l).normalize();
    let peak = brdf_cos(n, v, l, &surface(r, 1.0)).max_element();
    assert!(peak > 0.1 * brdf_cos_bound(r) && peak <= brdf_cos_bound(r), "{peak} vs {}", brdf_cos_bound(r));
}
