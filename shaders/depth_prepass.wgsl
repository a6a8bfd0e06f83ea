// Depth pre-pass: reversed-Z depth of opaque geometry (no fragment stage), and a variant for
// alpha-masked materials that samples alpha and discards.
// variants: ALPHA_MASK TEXTURES
#include "common/scene.wgsl"

#ifdef ALPHA_MASK
struct MaskedOut {
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) material: u32,
}

@vertex
fn vs_masked(@builtin(instance_index) instance: u32, @location(0) position: vec3<f32>, @location(2) uv: vec2<f32>) -> MaskedOut {
    var out: MaskedOut;
    out.clip = transform_position(instance, position);
    out.uv = uv;
    out.material = instances[instance].material;
    return out;
}

@fragment
fn fs_masked(in: MaskedOut) {
    let m = materials[in.material];
    if material_color(m, in.uv).a < m.alpha_cutoff {
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
