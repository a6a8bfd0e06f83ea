// The visibility buffer's raster pass (issue 28): reversed-Z depth and one R32Uint ID per
// sample, (instance << TRIANGLE_BITS) | triangle, the triangle counted within its
// instance's draw (@builtin(primitive_index), wgpu's PRIMITIVE_INDEX feature); the split is
// tiledlight_cull::visibility::IdLayout, chosen per scene. Masked materials test alpha here
// with the hardware's derivatives, as the depth pre-pass does (depth_prepass.wgsl), so the
// compute pass never sees a masked-out texel.
// variants: ALPHA_MASK TEXTURES UV1
enable primitive_index;
#include "common/scene.wgsl"

// Low bits of an ID holding the triangle (IdLayout::triangle_bits; 32 when the scene has one
// instance, whose index is then 0).
override TRIANGLE_BITS: u32 = 16u;

fn pack_id(instance: u32, triangle: u32) -> u32 {
    return select(instance << TRIANGLE_BITS, 0u, TRIANGLE_BITS >= 32u) | triangle;
}

#ifdef ALPHA_MASK
struct MaskedIn {
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
    @location(2) uv: vec2<f32>,
#ifdef UV1
    @location(4) uv1: vec2<f32>,
#endif
}

// Texture coordinates at the centroid, as depth_prepass.wgsl reads them.
struct MaskedOut {
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(1) @interpolate(flat) material: u32,
    @location(2) @interpolate(flat) instance: u32,
#ifdef UV1
    @location(3) @interpolate(perspective, centroid) uv1: vec2<f32>,
#endif
}

@vertex
fn vs_masked(v: MaskedIn) -> MaskedOut {
    var out: MaskedOut;
    out.clip = transform_position(v.instance, v.position);
    out.uv = v.uv;
    out.material = instances[v.instance].material;
    out.instance = v.instance;
#ifdef UV1
    out.uv1 = v.uv1;
#endif
    return out;
}

@fragment
fn fs_masked(in: MaskedOut, @builtin(primitive_index) triangle: u32) -> @location(0) u32 {
#ifdef UV1
    let uv1 = in.uv1;
#else
    let uv1 = in.uv;
#endif
    if material_color(in.material, uv_sets(in.uv, uv1)).a < materials[in.material].alpha_cutoff {
        discard;
    }
    return pack_id(in.instance, triangle);
}
#else
struct IdOut {
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) instance: u32,
}

@vertex
fn vs_main(@builtin(instance_index) instance: u32, @location(0) position: vec3<f32>) -> IdOut {
    return IdOut(transform_position(instance, position), instance);
}

@fragment
fn fs_main(in: IdOut, @builtin(primitive_index) triangle: u32) -> @location(0) u32 {
    return pack_id(in.instance, triangle);
}
#endif
