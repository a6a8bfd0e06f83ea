// The visibility buffer's compute raster, its hardware half (issue 29): the triangles the
// compute pass found too large for one thread (visibility_raster.wgsl, the large list),
// drawn by one indirect draw whose vertex stage fetches each triangle's vertices from the
// scene's buffers and whose fragment stage resolves its (depth, ID) texel by the same
// atomicMax. No depth test and no colour write: the texels are the only output (the ID
// target is attached, masked, because a render pass needs an attachment). The hardware's
// coverage rules are the compute raster's (pixel centres, top-left, 1/256 px).
// Bindings: crates/visibility/src/compute_raster.rs.
// variants: VISIBILITY
#include "common/scene.wgsl"

struct Large {
    instance: u32,
    triangle: u32,
}

// Triangle IDs' low bits (tiledlight_cull::visibility::IdLayout::triangle_bits).
override TRIANGLE_BITS: u32 = 16u;

@group(1) @binding(26) var<storage, read> vis_indices: array<u32>;
@group(1) @binding(27) var<storage, read> vis_positions: array<f32>;
@group(1) @binding(43) var<storage, read_write> texels: array<atomic<u64>>;
@group(1) @binding(49) var<storage, read> large: array<Large>;

struct LargeOut {
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
}

@vertex
fn vs_large(@builtin(vertex_index) v: u32) -> LargeOut {
    let l = large[v / 3u];
    let inst = instances[l.instance];
    let p = u32(i32(vis_indices[inst.first_index + 3u * l.triangle + v % 3u]) + inst.base_vertex) * 3u;
    let clip = transform_position(l.instance, vec3<f32>(vis_positions[p], vis_positions[p + 1u], vis_positions[p + 2u]));
    let id = select(l.instance << TRIANGLE_BITS, 0u, TRIANGLE_BITS >= 32u) | l.triangle;
    return LargeOut(clip, id);
}

@fragment
fn fs_large(in: LargeOut) -> @location(0) u32 {
    let texel = (u64(bitcast<u32>(max(in.clip.z, 0.0))) << 32u) | u64(in.id);
    atomicMax(&texels[u32(in.clip.y) * view.screen.x + u32(in.clip.x)], texel);
    return in.id;
}
