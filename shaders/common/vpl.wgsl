// Virtual point lights (crates/cull/src/vpl.rs, GpuVpl; tiledlight_cull::vpl is the CPU twin):
// one VPL's shading data. Its culling sphere is a CullLight (common/lights.wgsl) of a
// buffer of its own, at the same index. The number of VPLs is min(count, cap), count being
// the generation pass's atomic counter (it counts the candidates the cap refused too).
struct Vpl {
    position: vec3<f32>,
    radius: f32,
    normal: vec3<f32>,
    _pad0: f32,
    flux: vec3<f32>,
    _pad1: f32,
}

// How the shading passes read the VPLs (crates/cull/src/vpl.rs, GpuVplShading).
struct VplShading {
    cap: u32,
    // 0: the sample's model, 1: the physical one.
    model: u32,
    distance_clamp: f32,
    _pad: u32,
}

#include "common/brdf.wgsl"

// The light a VPL sends to the surface point x (tiledlight_cull::vpl::vpl_intensity, keep in
// step): the unit direction towards the VPL, and the factor that multiplies the shared BRDF
// times n.l. Zero (never NaN) at the VPL itself, behind it, and (sample model) at and beyond
// its radius.
//   sample (TiledLighting11):  flux / (pi r^2) x smoothstep(1, 0, d/r) x max(0, n_vpl . -l)
//   physical (Dachsbacher and Stamminger 2005): flux / pi x max(0, n_vpl . -l) / max(d^2, clamp^2)
// The smoothstep is written out: WGSL leaves smoothstep(1, 0, x) (low > high) undefined.
struct VplLight {
    l: vec3<f32>,
    factor: vec3<f32>,
}

fn vpl_light(v: Vpl, x: vec3<f32>, physical: bool, distance_clamp: f32) -> VplLight {
    let to = v.position - x;
    let d2 = dot(to, to);
    var l = vec3<f32>(0.0);
    if (d2 > 0.0) {
        l = to * inverseSqrt(d2);
    }
    let emit = max(dot(v.normal, -l), 0.0);
    var f: f32;
    if (physical) {
        f = emit / (PI * max(d2, distance_clamp * distance_clamp));
    } else {
        let r = max(v.radius, 1.17549435e-38);
        let t = saturate(1.0 - sqrt(d2) / r);
        f = t * t * (3.0 - 2.0 * t) * emit / (PI * r * r);
    }
    return VplLight(l, v.flux * f);
}
