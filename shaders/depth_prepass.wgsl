// Depth pre-pass: reversed-Z depth of opaque geometry (no fragment stage), and a variant for
// alpha-masked materials that samples alpha and discards (its base colour texture may read
// texture coordinate set 1: UV1).
// variants: ALPHA_MASK TEXTURES UV1
#include "common/scene.wgsl"

#ifdef ALPHA_MASK
struct MaskedIn {
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
    @location(2) uv: vec2<f32>,
#ifdef UV1
    @location(4) uv1: vec2<f32>,
#endif
}

// Texture coordinates at the centroid of the covered samples, as the shading and G-buffer
// passes read them (common/scene.wgsl): with MSAA the pixel centre can lie outside a partly
// covered triangle, and an alpha test there (extrapolated coordinates) decided the coverage
// of the triangle's samples otherwise than Tiled Deferred's G-buffer pass did.
struct MaskedOut {
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(1) @interpolate(flat) material: u32,
#ifdef UV1
    @location(2) @interpolate(perspective, centroid) uv1: vec2<f32>,
#endif
}

@vertex
fn vs_masked(v: MaskedIn) -> MaskedOut {
    var out: MaskedOut;
    out.clip = transform_position(v.instance, v.position);
    out.uv = v.uv;
    out.material = instances[v.instance].material;
#ifdef UV1
    out.uv1 = v.uv1;
#endif
    return out;
}

@fragment
fn fs_masked(in: MaskedOut) {
#ifdef UV1
    let uv1 = in.uv1;
#else
    let uv1 = in.uv;
#endif
    if material_color(in.material, uv_sets(in.uv, uv1)).a < materials[in.material].alpha_cutoff {
        discard;
    }
}
#else
struct DepthOut {
    @invariant @builtin(position) clip: vec4<f32>,
}

@vertex
fn vs_main(@builtin(instance_index) instance: u32, @location(0) position: vec3<f32>) -> DepthOut {
    return DepthOut(transform_position(instance, position));
}
#endif
