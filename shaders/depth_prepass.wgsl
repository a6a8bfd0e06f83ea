// Depth pre-pass: reversed-Z depth of opaque geometry (no fragment stage), and a variant for
// alpha-masked materials that samples alpha and discards (its base colour texture may read
// texture coordinate set 1: UV1).
//
// With IDS it is the visibility buffer's raster pass (issue 28): every fragment also writes
// its R32Uint ID, (instance << TRIANGLE_BITS) | triangle, the triangle counted within its
// instance's draw (@builtin(primitive_index), wgpu's PRIMITIVE_INDEX feature); the split
// is tiledlight_cull::visibility::IdLayout, chosen per scene. Masked materials test alpha
// here with the hardware's derivatives, so the compute pass never sees a masked-out texel.
// With ATOMIC (and IDS, ALPHA_MASK) it draws the alpha-masked instances for the visibility
// buffer's compute raster (visibility_raster.wgsl): no depth test; each fragment that
// passes the alpha test resolves its (depth bits << 32) | ID texel into the raster's
// buffer by atomicMax, as the compute pass does.
// variants: ALPHA_MASK TEXTURES UV1 IDS ATOMIC
#ifdef IDS
enable primitive_index;
#endif
#include "common/scene.wgsl"

#ifdef IDS
// Low bits of an ID holding the triangle (IdLayout::triangle_bits; 32 when the scene has one
// instance, whose index is then 0).
override TRIANGLE_BITS: u32 = 16u;

fn pack_id(instance: u32, triangle: u32) -> u32 {
    return select(instance << TRIANGLE_BITS, 0u, TRIANGLE_BITS >= 32u) | triangle;
}
#endif

#ifdef ATOMIC
// The compute raster's texels (after the material textures, when the scene has them).
#ifdef TEXTURES
@group(3) @binding(0) var<storage, read_write> raster_texels: array<atomic<u64>>;
#else
@group(2) @binding(0) var<storage, read_write> raster_texels: array<atomic<u64>>;
#endif

// Resolves ID `id` at fragment `clip` into the texels; returns `id`.
fn resolve_id(clip: vec4<f32>, id: u32) -> u32 {
    let texel = (u64(bitcast<u32>(max(clip.z, 0.0))) << 32u) | u64(id);
    atomicMax(&raster_texels[u32(clip.y) * view.screen.x + u32(clip.x)], texel);
    return id;
}
#endif

#ifdef ALPHA_MASK
struct MaskedIn {
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
    @location(2) uv: vec2<f32>,
#ifdef UV1
    @location(4) uv1: vec2<f32>,
#endif
}

// Texture coordinates at the pixel centre, as the shading and G-buffer passes read them
// (common/scene.wgsl says why not at the centroid): the alpha test of a partly covered pixel
// must decide the triangle's samples as Tiled Deferred's G-buffer pass decides them, so every
// pass interpolates at the same point.
struct MaskedOut {
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) material: u32,
#ifdef UV1
    @location(2) uv1: vec2<f32>,
#endif
#ifdef IDS
    @location(3) @interpolate(flat) instance: u32,
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
#ifdef IDS
    out.instance = v.instance;
#endif
    return out;
}

fn alpha_test(in: MaskedOut) {
#ifdef UV1
    let uv1 = in.uv1;
#else
    let uv1 = in.uv;
#endif
    if material_color(in.material, uv_sets(in.uv, uv1)).a < materials[in.material].alpha_cutoff {
        discard;
    }
}

#ifdef IDS
@fragment
fn fs_masked(in: MaskedOut, @builtin(primitive_index) triangle: u32) -> @location(0) u32 {
    alpha_test(in);
#ifdef ATOMIC
    return resolve_id(in.clip, pack_id(in.instance, triangle));
#else
    return pack_id(in.instance, triangle);
#endif
}
#else
@fragment
fn fs_masked(in: MaskedOut) {
    alpha_test(in);
}
#endif
#else
struct DepthOut {
    @invariant @builtin(position) clip: vec4<f32>,
#ifdef IDS
    @location(0) @interpolate(flat) instance: u32,
#endif
}

@vertex
fn vs_main(@builtin(instance_index) instance: u32, @location(0) position: vec3<f32>) -> DepthOut {
#ifdef IDS
    return DepthOut(transform_position(instance, position), instance);
#else
    return DepthOut(transform_position(instance, position));
#endif
}

#ifdef IDS
@fragment
fn fs_main(in: DepthOut, @builtin(primitive_index) triangle: u32) -> @location(0) u32 {
    return pack_id(in.instance, triangle);
}
#endif
#endif
