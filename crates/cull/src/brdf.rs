//! The shading maths every renderer shares, as the CPU twin of `shaders/common/brdf.wgsl`:
//! windowed inverse-square attenuation, the spot falloff and the BRDF: GGX specular plus
//! Ashikhmin and Shirley's energy-conserving diffuse term ([`diffuse`]), and the bounds on
//! that diffuse term the image comparisons' allowances use ([`MAX_DIFFUSE_COS`],
//! [`MAX_DIFFUSE_LIGHT_SLOPE`], [`MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT`], [`MAX_DIFFUSE_SLOPE`]). Tests use it to check GPU pixels.
//! Depends on glam only.

use glam::Vec3;

/// Squared size of a light's emitter (1 cm): keeps `1/d^2` finite at the light.
pub const LIGHT_SIZE_SQ: f32 = 1e-4;

/// Smallest perceptual roughness: GGX with roughness 0 is a delta and aliases.
pub const MIN_ROUGHNESS: f32 = 0.045;

/// Windowed inverse-square falloff: `saturate(1 - (d/r)^4)^2 / max(d^2, eps^2)`
/// (UE4, Frostbite, Filament). Zero at and beyond `r`.
pub fn windowed_attenuation(dist_sq: f32, radius: f32) -> f32 {
    let x = dist_sq / (radius * radius);
    let w = (1.0 - x * x).clamp(0.0, 1.0);
    w * w / dist_sq.max(LIGHT_SIZE_SQ)
}

/// Inverse-square falloff with no cutoff, for the brute-force reference without radius.
pub fn unwindowed_attenuation(dist_sq: f32) -> f32 {
    1.0 / dist_sq.max(LIGHT_SIZE_SQ)
}

/// Spot angular falloff: `saturate(cos_angle * scale + offset)^2`.
pub fn spot_falloff(cos_angle: f32, scale: f32, offset: f32) -> f32 {
    let t = (cos_angle * scale + offset).clamp(0.0, 1.0);
    t * t
}

/// Specular reflectance at normal incidence of every dielectric (F0 of glTF's metallic-
/// roughness model); a surface's F0 is `lerp(DIELECTRIC_F0, albedo, metallic)`.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Ashikhmin and Shirley's diffuse normalisation `28 / (23 pi)` (2000, "An Anisotropic
/// Phong BRDF Model", eq. 5). With `g(x) = 1 - (1 - x/2)^5`, `int_0^1 x g(x) dx = 23/56`,
/// so the term's directional albedo is `R_d (1 - R_s) g(n.v)` (closed form; at most
/// `31/32 R_d (1 - R_s)`, head-on).
pub const DIFFUSE_SCALE: f32 = 28.0 / (23.0 * std::f32::consts::PI);

/// The diffuse term's largest weight `R_d (1 - R_s) = albedo (1 - metallic) (1 - F0)` over
/// albedo and metallic in [0, 1]: with `u = 1 - metallic`, it is at most `u (1 - 0.04 u)`
/// (dropping `- albedo metallic`), which grows with `u` on [0, 1]; 0.96 at albedo 1,
/// metallic 0 (a white dielectric).
const MAX_DIFFUSE_WEIGHT: f32 = 1.0 - DIELECTRIC_F0;

/// The largest value of the diffuse term times the cosine, `diffuse(n.l, n.v) x n.l`,
/// over every albedo and metallic in [0, 1] and every geometry: `x g(x)` grows on [0, 1],
/// so the maximum is at `n.l = n.v = 1`: `28 / (23 pi) x 0.96 x (31/32)^2` = 0.3491
/// (Lambert's was `1/pi` = 0.3183).
pub const MAX_DIFFUSE_COS: f32 = DIFFUSE_SCALE * MAX_DIFFUSE_WEIGHT * (31.0 / 32.0) * (31.0 / 32.0);

/// The largest change of `diffuse(n.l, n.v) x n.l` per unit change of `n.l` (n.v fixed),
/// over every albedo and metallic in [0, 1]: `d/dx [x g(x)] = 1 - s^5 + 5 x s^4 / 2` with
/// `s = 1 - x/2` is `1 + 5 s^4 - 6 s^5`, whose derivative `10 s^3 (2 - 3 s)` vanishes at
/// `s = 2/3` (`x = 2/3`): at most `1 + 16/81 = 97/81`; times `g(n.v) <= 31/32` and
/// `28 / (23 pi) x 0.96`: 0.4316. Non-negative (it is 0 at `x = 0` and `s = 1`): more light
/// from above never darkens the term.
pub const MAX_DIFFUSE_LIGHT_SLOPE: f32 = DIFFUSE_SCALE * MAX_DIFFUSE_WEIGHT * (97.0 / 81.0) * (31.0 / 32.0);

/// The largest change of the diffuse term times the cosine, `T = diffuse(n.l, n.v) x n.l`,
/// per radian of rotation of the normal, over every albedo and metallic in [0, 1]: what an
/// error in the normal (an f16 G-buffer, say) can do to a light's diffuse contribution
/// (per unit of the light's radiance times attenuation).
///
/// Derivation: rotating `n` by `e` moves `n.l` and `n.v` each by at most `|n' - n| <= e`,
/// and both partial derivatives of `T` are non-negative, so `|dT| <= e max(dT/d(n.l) +
/// dT/d(n.v))`. With `C = 28 / (23 pi) x 0.96`, `g(x) = 1 - (1 - x/2)^5`, `a(x) = d/dx
/// [x g(x)]` and `b(x) = x g(x)`, the sum is `C h`, `h = a(n.l) g(n.v) + b(n.l) g'(n.v)`,
/// `g'(y) = 5/2 t^4` with `t = 1 - y/2` in [1/2, 1]. For fixed `n.l`, `dh/dt = 5 t^3 (2 b -
/// a t)`: `h` rises in `t` up to `t* = 2b/a`. Where `2b >= a`, the maximum is at `t = 1`
/// (`n.v = 0`): `5/2 b(n.l) <= 5/2 x 31/32 = 155/64` (b grows). Where `2b < a`, it is
/// `h(t*) = a + 8 b^5 / a^4 < 1.25 a <= 1.25 x 97/81 = 1.50` ([`MAX_DIFFUSE_LIGHT_SLOPE`]
/// says why `a <= 97/81`). So `max h = 155/64`, reached at `n.l = 1`, `n.v -> 0`, where
/// the rotation's whole effect is on `n.v` (v lies in the tangent plane) and the bound is
/// attained: `C x 155/64` = 0.9010. It also bounds `dT/d(n.v)` alone. (Lambert's was `1/pi`
/// = 0.3183: the Ashikhmin-Shirley term depends on the view, steepest at grazing view.)
/// The same argument bounds any perturbation that moves `n.l` and `n.v` each by at most
/// `e` (an unnormalised or rounded normal): the change is at most `MAX_DIFFUSE_SLOPE x e`.
pub const MAX_DIFFUSE_SLOPE: f32 = DIFFUSE_SCALE * MAX_DIFFUSE_WEIGHT * (155.0 / 64.0);

/// The largest ratio of `dT/d(n.l)` to `sqrt(T)`, `T = diffuse(n.l, n.v) x n.l`, over
/// every albedo and metallic in [0, 1] and every geometry: with the names of
/// [`MAX_DIFFUSE_SLOPE`] and `w = albedo (1 - metallic) (1 - F0) <= 0.96`,
/// `(dT/d(n.l))^2 / T = 28 / (23 pi) w g(n.v) a^2 / (n.l g(n.l))`, and `a(x)^2 <= 10 x
/// g(x)` on [0, 1]: with `u = x/2`, `10 x g - a^2 = u^3 (400 - 1500 u + 2800 u^2 - 3200 u^3 +
/// 2360 u^4 - 1105 u^5 + 300 u^6 - 36 u^7)`, whose bracket is at least 67.4 on [0, 1/2]
/// (at u = 1/2; 400 at 0), equality in the limit `x -> 0` (`a ~ 5x`, `x g ~ 5x^2 / 2`). So
/// `sqrt(10 x 28 / (23 pi) x 0.96 x 31/32)` = 1.8984. Where `T` is small (light at grazing
/// incidence, view at grazing angles) its slope is small too: a change of `n.l` by `t`
/// moves `T` by at most `K t sqrt(T)`, far below `MAX_DIFFUSE_LIGHT_SLOPE x t` there.
pub const MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT: f32 = 1.898_373_4;

/// Ashikhmin and Shirley's `g(x) = 1 - (1 - x/2)^5`, written as `x/2 (1 + q + q^2 + q^3 +
/// q^4)` with `q = 1 - x/2` (`1 - q^5` factored): every term positive, so no f32
/// cancellation where `x` is small (grazing angles, where `g` is about `5x/2`).
fn diffuse_falloff(x: f32) -> f32 {
    let q = 1.0 - 0.5 * x;
    0.5 * x * (1.0 + q * (1.0 + q * (1.0 + q * (1.0 + q))))
}

/// The diffuse BRDF (without the cosine): Ashikhmin and Shirley's 2000 term with `R_d =
/// albedo (1 - metallic)` and `R_s = F0` per channel, `28 / (23 pi) R_d (1 - R_s) (1 - (1 -
/// n.l/2)^5) (1 - (1 - n.v/2)^5)`. Reciprocal; with the specular lobe it keeps a white
/// dielectric's hemispherical albedo below 1 (at most 0.970 over roughness 0 to 1 and views
/// 0 to 89 degrees, where Lambert without `(1 - F)` reached 1.503:
/// `tests/brdf_reference.rs`), 9.7% brighter than Lambert head-on (`28/23 x 0.96 x
/// (31/32)^2`) and 0 at grazing view. `n_dot_l` and `n_dot_v` as [`brdf_cos`] clamps them
/// (in [0, 1]).
pub fn diffuse(albedo: Vec3, metallic: f32, n_dot_l: f32, n_dot_v: f32) -> Vec3 {
    let f0 = Vec3::splat(DIELECTRIC_F0).lerp(albedo, metallic);
    diffuse_with_f0(albedo, metallic, f0, n_dot_l, n_dot_v)
}

/// [`diffuse`] for a known F0: `brdf_cos` shares it with the specular term.
fn diffuse_with_f0(albedo: Vec3, metallic: f32, f0: Vec3, n_dot_l: f32, n_dot_v: f32) -> Vec3 {
    albedo * (1.0 - metallic) * (Vec3::ONE - f0) * (DIFFUSE_SCALE * diffuse_falloff(n_dot_l) * diffuse_falloff(n_dot_v))
}

/// The GGX (Trowbridge-Reitz) normal distribution `D(h)` for unit normal `n`, unit half
/// vector `h` and `a2 = alpha^2`: `a2 / (pi (1 - n.h^2 (1 - a2))^2)` where `n.h > 0`, and 0
/// where `n.h <= 0` (the chi+ factor of Walter et al. 2007, eq. 33: no microfacet faces
/// away from the macro-surface). Never above its peak [`ggx_peak`] `1 / (pi a2)`.
///
/// The chi+ factor matters where the eye is behind the shading surface (`n.v < 0`: smooth-
/// shaded silhouettes, normal maps) and the light nearly opposite it, so that `h` tends to
/// `-n`: a clamped `n.h` of 0 with `|n x h| -> 0` made the denominator vanish and `D` grow
/// without bound (3,300 where the lobe's peak is 3, the error budget's worst pixel).
pub fn ggx_ndf(n: Vec3, h: Vec3, a2: f32) -> f32 {
    ggx_denominator(n, h, a2).map_or(0.0, |dd| a2 / (std::f32::consts::PI * dd * dd))
}

/// `1 - n.h^2 (1 - a2)` of [`ggx_ndf`] (`D = a2 / (pi dd^2)`), `None` where `n.h <= 0`.
fn ggx_denominator(n: Vec3, h: Vec3, a2: f32) -> Option<f32> {
    let n_dot_h = n.dot(h);
    if n_dot_h <= 0.0 {
        return None;
    }
    // 1 - n.h^2 (1 - a^2), written as n.h^2 a^2 + |n x h|^2 (Lagrange's identity): near the
    // peak n.h is within an ulp of 1 and the first form cancels in f32, which made a white
    // metal reflect 2% more light than it receives at the roughness clamp.
    let n_cross_h = n.cross(h);
    Some(n_dot_h * n_dot_h * a2 + n_cross_h.length_squared())
}

/// The peak of [`ggx_ndf`], at `h = n`: `1 / (pi a2)`.
pub fn ggx_peak(a2: f32) -> f32 {
    1.0 / (std::f32::consts::PI * a2)
}

/// An upper bound of every channel of [`brdf_cos`] for perceptual roughness `roughness`
/// and any unit `n`, `v`, `l` (the eye behind the surface included): the diffuse term is
/// at most `DIFFUSE_SCALE` (its falloffs are at most 1), Fresnel at most 1, the NDF at most
/// [`ggx_peak`], and the visibility term times `n.l`, `0.5 n.l / (n.l sqrt(n.v^2 (1 - a2) +
/// a2) + n.v sqrt(..))`, at most `0.5 / a`. So `brdf_cos <= DIFFUSE_SCALE + 1 / (2 pi a^3)`.
pub fn brdf_cos_bound(roughness: f32) -> f32 {
    let rough = roughness.clamp(MIN_ROUGHNESS, 1.0);
    let a = rough * rough;
    DIFFUSE_SCALE + ggx_peak(a * a) * 0.5 / a
}

/// Surface parameters the BRDF needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Linear base colour.
    pub albedo: Vec3,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// Metalness in [0, 1].
    pub metallic: f32,
}

/// BRDF times cosine for unit normal `n`, unit view direction `v` and unit light
/// direction `l` (both pointing away from the surface). Ashikhmin-Shirley diffuse
/// ([`diffuse`]) plus GGX specular with height-correlated Smith visibility and Schlick
/// Fresnel. As the WGSL computes it (issue 49): `D` times the visibility term by one
/// division, the fifth power by multiplies.
pub fn brdf_cos(n: Vec3, v: Vec3, l: Vec3, s: &Surface) -> Vec3 {
    let n_dot_l = n.dot(l).clamp(0.0, 1.0);
    if n_dot_l <= 0.0 {
        return Vec3::ZERO;
    }
    let n_dot_v = n.dot(v).max(1e-4);
    let h = (v + l).normalize_or_zero();
    let v_dot_h = v.dot(h).clamp(0.0, 1.0);
    let rough = s.roughness.clamp(MIN_ROUGHNESS, 1.0);
    let a = rough * rough;
    let a2 = a * a;
    let gv = n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
    let gl = n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt();
    // D vis = a2 / (pi dd^2) x 0.5 / (gv + gl).
    let d_vis = ggx_denominator(n, h, a2).map_or(0.0, |dd| (0.5 * a2) / (std::f32::consts::PI * dd * dd * (gv + gl)));
    let f0 = Vec3::splat(DIELECTRIC_F0).lerp(s.albedo, s.metallic);
    let m = 1.0 - v_dot_h;
    let m2 = m * m;
    let f = f0 + (Vec3::ONE - f0) * (m2 * m2 * m);
    let diffuse = diffuse_with_f0(s.albedo, s.metallic, f0, n_dot_l, n_dot_v);
    (diffuse + f * d_vis) * n_dot_l
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_is_zero_at_radius_and_smooth_inside() {
        assert_eq!(windowed_attenuation(4.0, 2.0), 0.0);
        assert_eq!(windowed_attenuation(9.0, 2.0), 0.0);
        let near = windowed_attenuation(0.01, 2.0);
        assert!((near / unwindowed_attenuation(0.01) - 1.0).abs() < 1e-4);
        assert!(windowed_attenuation(0.0, 2.0).is_finite());
    }

    #[test]
    fn brdf_is_non_negative_and_energy_bounded() {
        let s = Surface { albedo: Vec3::ONE, roughness: 0.5, metallic: 0.0 };
        let n = Vec3::Y;
        let mut sum = 0.0;
        let steps = 64;
        for i in 0..steps {
            for j in 0..steps * 4 {
                let th = (i as f32 + 0.5) / steps as f32 * std::f32::consts::FRAC_PI_2;
                let ph = (j as f32 + 0.5) / (steps * 4) as f32 * std::f32::consts::TAU;
                let l = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
                let f = brdf_cos(n, Vec3::new(0.3, 0.9, 0.1).normalize(), l, &s);
                assert!(f.min_element() >= 0.0);
                let dw = th.sin()
                    * (std::f32::consts::FRAC_PI_2 / steps as f32)
                    * (std::f32::consts::TAU / (steps * 4) as f32);
                sum += f.x * dw;
            }
        }
        assert!(sum < 1.05 && sum > 0.8, "white-furnace albedo {sum}");
    }

    /// `T(n.l, n.v) = diffuse x n.l` for a white dielectric (the largest weight).
    fn white_t(nl: f32, nv: f32) -> f32 {
        diffuse(Vec3::ONE, 0.0, nl, nv).x * nl
    }

    /// The factored `1 - (1 - x/2)^5` equals the paper's form (in f64) to a few ulps,
    /// relative, down to tiny `x`.
    #[test]
    fn diffuse_falloff_is_the_papers_without_cancellation() {
        assert_eq!(diffuse_falloff(0.0), 0.0);
        for i in 0..2000 {
            let x = if i < 1000 { 1e-6 * 1.01f32.powi(i) } else { (i - 999) as f32 / 1000.0 };
            let want = 1.0 - (1.0 - f64::from(x) / 2.0).powi(5);
            let got = f64::from(diffuse_falloff(x));
            assert!(((got - want) / want).abs() < 4.0 * f64::from(f32::EPSILON), "x {x}: {got} vs {want}");
        }
    }

    /// The bounds against a fine grid of `(n.l, n.v)` on [0, 1]^2 (h = 1/512): no value of
    /// `T` above [`MAX_DIFFUSE_COS`]; no step of `n.l` alone above [`MAX_DIFFUSE_LIGHT_SLOPE`];
    /// no step of both by `h` (any signs: what a rotation by `h` can do at most) above
    /// [`MAX_DIFFUSE_SLOPE`]; each largest within 10% of its bound (a loose bound fails). By
    /// the mean value theorem a difference quotient is the derivative somewhere on its step,
    /// so it never exceeds a true bound; the slack covers f32 rounding (T ~ 0.35, 1e-7 / h).
    #[test]
    fn diffuse_bounds_hold_and_are_tight() {
        let n: i32 = 512;
        let h = 1.0 / n as f32;
        let slack = 1e-4;
        let (mut max_t, mut max_l, mut max_both, mut at) = (0.0f32, 0.0f32, 0.0f32, (0.0, 0.0));
        for i in 0..=n {
            for j in 0..=n {
                let (x, y) = (i as f32 * h, j as f32 * h);
                let t = white_t(x, y);
                max_t = max_t.max(t);
                if i < n {
                    max_l = max_l.max((white_t(x + h, y) - t).abs() / h);
                }
                for (di, dj) in [(1, 1), (1, -1), (-1, 1), (-1, -1)] {
                    let (i2, j2) = (i + di, j + dj);
                    if !(0..=n).contains(&i2) || !(0..=n).contains(&j2) {
                        continue;
                    }
                    let q = (white_t(i2 as f32 * h, j2 as f32 * h) - t).abs() / h;
                    if q > max_both {
                        (max_both, at) = (q, (x, y));
                    }
                }
            }
        }
        eprintln!(
            "diffuse x n.l: max {max_t} (bound {MAX_DIFFUSE_COS}); slope in n.l {max_l} (bound \
             {MAX_DIFFUSE_LIGHT_SLOPE}); slope in both {max_both} at n.l, n.v = {at:?} (bound {MAX_DIFFUSE_SLOPE})"
        );
        for (name, got, bound) in [
            ("MAX_DIFFUSE_COS", max_t, MAX_DIFFUSE_COS),
            ("MAX_DIFFUSE_LIGHT_SLOPE", max_l, MAX_DIFFUSE_LIGHT_SLOPE),
            ("MAX_DIFFUSE_SLOPE", max_both, MAX_DIFFUSE_SLOPE),
        ] {
            assert!(got <= bound * (1.0 + slack), "{name}: {got} exceeds the bound {bound}");
            assert!(got >= 0.9 * bound, "{name}: the bound {bound} is loose (largest found {got})");
        }
    }

    /// [`MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT`]: its value is the formula of its doc; steps of
    /// `n.l` by 1/256 of itself, from 1e-3 to 1 and `n.v` over [0, 1], never change `T` by more
    /// than `K sqrt(T(end of step))` per unit (mean value theorem; T grows with `n.l`), and
    /// reach 90% of it (near `n.l` = 0).
    #[test]
    fn diffuse_light_slope_per_sqrt_holds_and_is_tight() {
        let k = (10.0 * f64::from(DIFFUSE_SCALE) * 0.96 * 31.0 / 32.0).sqrt();
        assert!((f64::from(MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT) / k - 1.0).abs() < 1e-6, "{k}");
        let mut worst = 0.0f32;
        for i in 0..=300 {
            let x = 1e-3 * 1000f32.powf(i as f32 / 300.0);
            let h = x / 256.0;
            for j in 0..=64 {
                let y = j as f32 / 64.0;
                let (t0, t1) = (white_t(x, y), white_t(x + h, y));
                let q = (t1 - t0) / h;
                assert!(q <= MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT * t1.sqrt() * 1.001, "n.l {x} n.v {y}: {q}");
                if t0 > 0.0 {
                    worst = worst.max(q / t0.sqrt());
                }
            }
        }
        assert!(worst >= 0.9 * MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT, "largest slope / sqrt(T) {worst}");
    }

    /// [`MAX_DIFFUSE_SLOPE`] as its doc states it, per radian of an actual rotation of the
    /// normal: for normals over the hemisphere, light and view directions including grazing
    /// ones, and rotations by 0.01 rad about several axes, the white dielectric's diffuse
    /// term times the cosine changes by at most the bound times the angle; and some rotation
    /// reaches 90% of it (view in the tangent plane, light along the normal).
    #[test]
    fn diffuse_slope_bounds_a_rotation_of_the_normal() {
        let dir = |theta: f32, phi: f32| Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
        let t = |n: Vec3, v: Vec3, l: Vec3| {
            let nl = n.dot(l).clamp(0.0, 1.0);
            white_t(nl, n.dot(v).clamp(1e-4, 1.0))
        };
        let e = 1e-2f32;
        let mut worst = 0.0f32;
        let axes = [Vec3::X, Vec3::Z, Vec3::new(1.0, 0.0, 1.0).normalize(), Vec3::new(0.3, 0.5, -0.8).normalize()];
        for it in 0..=18 {
            for iv in 0..=18 {
                for ip in 0..12 {
                    let l = dir(it as f32 * 5f32.to_radians(), 0.0);
                    let v = dir(iv as f32 * 5f32.to_radians(), ip as f32 * 30f32.to_radians());
                    for axis in axes {
                        for sign in [-1.0, 1.0] {
                            let n2 = glam::Quat::from_axis_angle(axis, sign * e) * Vec3::Y;
                            let q = (t(n2, v, l) - t(Vec3::Y, v, l)).abs() / e;
                            assert!(q <= MAX_DIFFUSE_SLOPE * 1.001, "l {l} v {v} axis {axis}: {q}");
                            worst = worst.max(q);
                        }
                    }
                }
            }
        }
        assert!(worst >= 0.9 * MAX_DIFFUSE_SLOPE, "largest change per radian {worst}");
    }
}
