// Shading maths shared by every renderer; the CPU twin is crates/cull/src/brdf.rs.

const PI: f32 = 3.14159265358979;
// Squared emitter size (1 cm): keeps 1/d^2 finite at the light.
const LIGHT_SIZE_SQ: f32 = 1e-4;
const MIN_ROUGHNESS: f32 = 0.045;
// F0 of every dielectric.
const DIELECTRIC_F0: f32 = 0.04;
// Ashikhmin and Shirley's diffuse normalisation 28 / (23 pi).
const DIFFUSE_SCALE: f32 = 0.387507687528093;
// The early-outs' ablation (`--no-early-outs`, pipeline constant false): a light beyond
// its radius or behind the surface is evaluated in full and then discarded (`select`), as
// a renderer that skips nothing does; the image does not change. True (the default, never
// passed) compiles the early returns and nothing else.
override EARLY_OUTS: bool = true;

fn windowed_attenuation(dist_sq: f32, radius: f32) -> f32 {
    let x = dist_sq / (radius * radius);
    let w = saturate(1.0 - x * x);
    return w * w / max(dist_sq, LIGHT_SIZE_SQ);
}

fn unwindowed_attenuation(dist_sq: f32) -> f32 {
    return 1.0 / max(dist_sq, LIGHT_SIZE_SQ);
}

// The two attenuations from r = inverseSqrt(max(dist_sq, 1e-30)), which the shading loop
// computes for the light's direction anyway: 1 / max(dist_sq, LIGHT_SIZE_SQ) is
// min(r^2, 1 / LIGHT_SIZE_SQ), so no division (issue 49). Equal to the forms above up to
// rounding (tiledlight_cull::brdf's twins are those).
fn inverse_square_rsq(r: f32) -> f32 {
    return min(r * r, 1.0 / LIGHT_SIZE_SQ);
}

fn windowed_attenuation_rsq(dist_sq: f32, r: f32, radius: f32) -> f32 {
    let x = dist_sq / (radius * radius);
    let w = saturate(1.0 - x * x);
    return w * w * inverse_square_rsq(r);
}

fn spot_falloff(cos_angle: f32, scale: f32, offset: f32) -> f32 {
    let t = saturate(cos_angle * scale + offset);
    return t * t;
}

struct Surface {
    albedo: vec3<f32>,
    roughness: f32,
    metallic: f32,
}

// Ashikhmin and Shirley's 1 - (1 - x/2)^5 as x/2 (1 + q + q^2 + q^3 + q^4), q = 1 - x/2:
// no f32 cancellation at grazing angles (tiledlight_cull::brdf::diffuse_falloff).
fn diffuse_falloff(x: f32) -> f32 {
    let q = 1.0 - 0.5 * x;
    return 0.5 * x * (1.0 + q * (1.0 + q * (1.0 + q * (1.0 + q))));
}

// 1 - n.h^2 (1 - a^2) of the GGX distribution, D = a2 / (pi dd^2), written as
// n.h^2 a^2 + |n x h|^2: no f32 cancellation near the peak (tiledlight_cull::brdf::ggx_ndf
// says why).
fn ggx_denominator(n: vec3<f32>, h: vec3<f32>, n_dot_h: f32, a2: f32) -> f32 {
    let n_cross_h = cross(n, h);
    return n_dot_h * n_dot_h * a2 + dot(n_cross_h, n_cross_h);
}

// The GGX normal distribution for unit n and h, a2 = alpha^2; 0 where n.h <= 0 (the chi+
// factor: without it h -> -n, met when the eye is behind the shading surface, made the
// denominator vanish). Never above 1 / (pi a2). Twin: tiledlight_cull::brdf::ggx_ndf.
// brdf_cos computes it inline, with the visibility term's division.
fn ggx_ndf(n: vec3<f32>, h: vec3<f32>, a2: f32) -> f32 {
    let n_dot_h = dot(n, h);
    let dd = ggx_denominator(n, h, n_dot_h, a2);
    // select, not an early return: dd may be 0 where n.h <= 0, and the quotient is dropped.
    return select(0.0, a2 / (PI * dd * dd), n_dot_h > 0.0);
}

// BRDF times cosine: Ashikhmin-Shirley diffuse (2000, eq. 5: 28 / (23 pi) R_d (1 - R_s)
// (1 - (1 - n.l/2)^5) (1 - (1 - n.v/2)^5), R_d = albedo (1 - metallic), R_s = F0; energy-
// conserving with the specular lobe) + GGX with height-correlated Smith visibility and
// Schlick Fresnel. n, v, l are unit vectors pointing away from the surface.
fn brdf_cos(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, s: Surface) -> vec3<f32> {
    let n_dot_l = saturate(dot(n, l));
    if EARLY_OUTS && n_dot_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let n_dot_v = max(dot(n, v), 1e-4);
    // Issue 49: three special-function operations a light where there were seven: the
    // half vector by one inverse square root (not a length and a division), the fifth power
    // by multiplies (not exp2 and log2), and D times the visibility term by one division.
    // The surface's own terms (n.v, roughness, F0, the view's falloff) do not depend on the
    // light: a shading loop's compiler hoists them out of it.
    let hv = v + l;
    let hl2 = dot(hv, hv);
    var h = vec3<f32>(0.0);
    if hl2 > 0.0 {
        h = hv * inverseSqrt(hl2);
    }
    let v_dot_h = saturate(dot(v, h));
    let rough = clamp(s.roughness, MIN_ROUGHNESS, 1.0);
    let a = rough * rough;
    let a2 = a * a;
    let n_dot_h = dot(n, h);
    let dd = ggx_denominator(n, h, n_dot_h, a2);
    let gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    let gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    // D vis = a2 / (pi dd^2) x 0.5 / (gv + gl); 0 where n.h <= 0 (the chi+ factor of
    // ggx_ndf; select, not an early return: dd may be 0 there and the quotient is dropped).
    let d_vis = select(0.0, (0.5 * a2) / (PI * dd * dd * (gv + gl)), n_dot_h > 0.0);
    let f0 = mix(vec3<f32>(DIELECTRIC_F0), s.albedo, s.metallic);
    let m = 1.0 - v_dot_h;
    let m2 = m * m;
    let f = f0 + (vec3<f32>(1.0) - f0) * (m2 * m2 * m);
    let diffuse = s.albedo * (1.0 - s.metallic) * (vec3<f32>(1.0) - f0)
        * (DIFFUSE_SCALE * diffuse_falloff(n_dot_l) * diffuse_falloff(n_dot_v));
    let value = (diffuse + f * d_vis) * n_dot_l;
    if EARLY_OUTS {
        return value;
    }
    // Behind the surface the terms may be infinite (h = 0 when l = -v); the select drops
    // them, NaN included.
    return select(value, vec3<f32>(0.0), n_dot_l <= 0.0);
}
