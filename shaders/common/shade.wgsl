// One light's contribution at a surface point. The including file declares
// `shading_lights: array<ShadingLight>` and, with SPOT_LIGHTS, `spot_lights: array<SpotLight>`.
// With NO_CUTOFF the falloff is plain inverse-square (the brute-force reference without radius).
// With SHADOWS, shadow-casting lights that reach the point are looked up in the atlas
// (common/shadow.wgsl); other lights pay one index comparison.
#include "common/view.wgsl"
#include "common/lights.wgsl"
#include "common/brdf.wgsl"
#ifdef SHADOWS
#include "common/shadow.wgsl"
#endif

fn shade_light(i: u32, p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, s: Surface) -> vec3<f32> {
    return shade_light_record(i, shading_lights[i], p, n, v, s);
}

// Light `i`, whose shading record `light` the caller has read (from `shading_lights`, or a
// copy the workgroup staged: common/assigned_shade.wgsl).
fn shade_light_record(i: u32, light: ShadingLight, p: vec3<f32>, n: vec3<f32>, v: vec3<f32>, s: Surface) -> vec3<f32> {
    let to_light = light.position - p;
    let d2 = dot(to_light, to_light);
#ifndef NO_CUTOFF
    let in_range = d2 < light.radius * light.radius;
    if EARLY_OUTS && !in_range {
        return vec3<f32>(0.0);
    }
#endif
    // One inverse square root gives the direction and the inverse-square falloff.
    let r = inverseSqrt(max(d2, 1e-30));
#ifdef NO_CUTOFF
    var atten = inverse_square_rsq(r);
#else
    var atten = windowed_attenuation_rsq(d2, r, light.radius);
#endif
    let l = to_light * r;
#ifdef SPOT_LIGHTS
    if i >= lighting.num_point_lights {
        let spot = spot_lights[i - lighting.num_point_lights];
        atten *= spot_falloff(dot(-l, spot.direction), spot.angle_scale, spot.angle_offset);
    }
#endif
#ifdef TRACED
#ifndef STOCHASTIC
    // Every light's visibility is a shadow ray (common/traced_shade.wgsl), cast only where
    // the light would add something. The stochastic method asks for the unshadowed
    // contribution (its target) and casts one ray for the light it keeps.
    if atten > 0.0 && dot(n, l) > 0.0 {
        atten *= traced_visibility(p, n, light.position);
    }
#endif
#endif
#ifdef SHADOWS
    if casts_shadow(i) && atten > 0.0 && dot(n, l) > 0.0 {
        atten *= shadow_visibility(i, light.position, p, n, l);
    }
#endif
    let c = light.radiance * (atten * brdf_cos(n, v, l, s));
#ifndef NO_CUTOFF
    if !EARLY_OUTS {
        // The early-outs' ablation (common/brdf.wgsl): beyond the radius the window is 0
        // but the BRDF may not be finite.
        return select(c, vec3<f32>(0.0), !in_range);
    }
#endif
    return c;
}
