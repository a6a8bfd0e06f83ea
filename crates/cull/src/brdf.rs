//! The shading maths every renderer shares, as the CPU twin of `shaders/common/brdf.wgsl`:
//! windowed inverse-square attenuation, the spot falloff and a GGX/Lambert BRDF.
//! Tests use it to check GPU pixels. Depends on glam only.

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
/// direction `l` (both pointing away from the surface). Lambert diffuse plus GGX
/// specular with height-correlated Smith visibility and Schlick Fresnel.
pub fn brdf_cos(n: Vec3, v: Vec3, l: Vec3, s: &Surface) -> Vec3 {
    let n_dot_l = n.dot(l).clamp(0.0, 1.0);
    if n_dot_l <= 0.0 {
        return Vec3::ZERO;
    }
    let n_dot_v = n.dot(v).max(1e-4);
    let h = (v + l).normalize_or_zero();
    let n_dot_h = n.dot(h).clamp(0.0, 1.0);
    let v_dot_h = v.dot(h).clamp(0.0, 1.0);
    let rough = s.roughness.clamp(MIN_ROUGHNESS, 1.0);
    let a = rough * rough;
    let a2 = a * a;
    // The NDF's 1 - n.h^2 (1 - a^2), written as n.h^2 a^2 + |n x h|^2 (Lagrange's identity):
    // near the peak n.h is within an ulp of 1 and the first form cancels in f32, which made a
    // white metal reflect 2% more light than it receives at the roughness clamp.
    let n_cross_h = n.cross(h);
    let dd = n_dot_h * n_dot_h * a2 + n_cross_h.length_squared();
    let d = a2 / (std::f32::consts::PI * dd * dd);
    let gv = n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
    let gl = n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt();
    let vis = 0.5 / (gv + gl);
    let f0 = Vec3::splat(0.04).lerp(s.albedo, s.metallic);
    let f = f0 + (Vec3::ONE - f0) * (1.0 - v_dot_h).powi(5);
    let diffuse = s.albedo * ((1.0 - s.metallic) / std::f32::consts::PI);
    (diffuse + f * (d * vis)) * n_dot_l
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
}
