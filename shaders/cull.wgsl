// Tiled light culling for Forward+: one workgroup per tile (common/tile_cull.wgsl). Min/max
// depth of the tile's non-sky pixels
// reduced in workgroup memory, the tile's view volume built, every light tested in parallel,
// survivors appended to a workgroup list and written to the tile's region of the global
// list buffer with the true count (never more than CAPACITY indices: overflow is counted).
// The CPU reference is crates/cull/src/reference.rs (cull_tiles).
// With COARSE, each tile tests only the lights of its 64x64-pixel cell (cull_coarse.wgsl),
// or every light when the cell overflowed.
// With MSAA the depth buffer is multisampled and the tile's range covers every sample.
// variants: AABB HALF_Z SPOT_CONE COARSE MSAA DROP_LIGHT
#include "common/tile_cull.wgsl"

@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
// Per list: the number of lights found (may exceed CAPACITY).
@group(1) @binding(2) var<storage, read_write> tile_counts: array<u32>;
// Per list: CAPACITY light indices.
@group(1) @binding(3) var<storage, read_write> tile_indices: array<u32>;
// [0]: lists that overflowed, [1]: (tile, light) pairs found.
@group(1) @binding(4) var<storage, read_write> cull_stats: array<atomic<u32>, 2>;
#ifdef HALF_Z
// Per tile: near and far view distance of its surfaces (the pixel picks its half).
@group(1) @binding(5) var<storage, read_write> tile_ranges: array<vec2<f32>>;
#endif
#ifdef COARSE
// Cell counts, then COARSE_CAPACITY indices per cell (see cull_coarse.wgsl).
@group(1) @binding(8) var<storage, read> cell_lists: array<u32>;
#endif
#ifdef SPOT_CONE
@group(1) @binding(6) var<storage, read> shading_lights: array<ShadingLight>;
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#endif

fn store_list(list_index: u32, list: u32, lidx: u32) {
    let count = atomicLoad(&wg_count[list]);
    let stored = min(count, CAPACITY);
    for (var i = lidx; i < stored; i += WG * WG) {
#ifdef HALF_Z
        if list == 1u {
            tile_indices[list_index * CAPACITY + i] = wg_list_far[i];
            continue;
        }
#endif
        tile_indices[list_index * CAPACITY + i] = wg_list[i];
    }
    if lidx == 0u {
        tile_counts[list_index] = count;
        atomicAdd(&cull_stats[1], count);
        if count > CAPACITY {
            atomicAdd(&cull_stats[0], 1u);
        }
    }
}

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    let t = cull_tile(wid.xy, lid.xy, lidx);
#ifdef HALF_Z
    if lidx == 0u {
        tile_ranges[t.index] = vec2<f32>(t.near, t.far);
    }
#endif
    store_list(t.index * frame.lists_per_tile, 0u, lidx);
#ifdef HALF_Z
    store_list(t.index * 2u + 1u, 1u, lidx);
#endif
}
