// Light-centric assignment, step 1 (crates/gpu/src/culling/scatter.rs): one workgroup per tile
// of the light grid reduces the view-distance range of the tile's surfaces into the grid's
// tile ranges ((-1, -1) for a tile without geometry) and, with DEPTH_MASK (2.5D) or
// CLUSTERED, its 32-bit depth-occupancy mask (common/depth_mask.wgsl: the 2.5D bins of
// the tile's range, or the clusters' depth slices that hold a surface).
// CPU twins: tiledlight_cull::tiles::tile_depth_bounds_samples, tile_depth_masks,
// cluster_occupancy.
// variants: MSAA DEPTH_MASK CLUSTERED
#include "common/tile_tests.wgsl"
#include "common/depth_range.wgsl"
#include "common/depth_mask.wgsl"
#include "common/light_grid_rw.wgsl"

// Tile side in pixels (8 to 64); the workgroup is WG x WG threads.
override TILE_SIZE: u32 = 16u;
override WG: u32 = 16u;

#ifdef DEPTH_MASK
@group(1) @binding(3) var<storage, read_write> tile_masks: array<u32>;
#else
#ifdef CLUSTERED
@group(1) @binding(3) var<storage, read_write> tile_masks: array<u32>;
#endif
#endif
#ifndef CLUSTERED
// Per block of BLOCK x BLOCK tiles: the largest order_key of its tiles' ~near (x: the
// nearest surface) and of their far (y), cleared to 0 each frame (assign.wgsl's
// visit_block skips blocks out of a light's depth reach).
@group(1) @binding(4) var<storage, read_write> block_ranges: array<atomic<u32>>;
const BLOCK: u32 = 4u;

// A u32 ordered as the float `f` (negative distances too: orthographic near planes),
// never 0 for a finite f.
fn order_key(f: f32) -> u32 {
    let u = bitcast<u32>(f);
    return select(u | 0x80000000u, ~u, (u & 0x80000000u) != 0u);
}
#endif
// The light grid's group (crates/gpu/src/light_grid.rs): only the header and the tile
// ranges are used here.
@group(2) @binding(0) var<storage, read_write> light_grid: LightGridRw;
@group(2) @binding(1) var<storage, read_write> light_indices: array<u32>;
@group(2) @binding(2) var<storage, read_write> tile_ranges: array<vec2<f32>>;

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    let origin = wid.xy * TILE_SIZE;
    let range = region_depth_range(origin, TILE_SIZE, WG, lid.xy, lidx);
    let t = wid.y * light_grid.header.tiles.x + wid.x;
    let geometry = range.y > 0.0;
    var near = 0.0;
    var far = 0.0;
    if geometry {
        // Reversed-Z: the largest depth is the nearest surface (as common/tile_cull.wgsl).
        near = view_distance(range.y);
        far = view_distance(range.x);
    }
#ifdef CLUSTERED
    let mask = region_mask(origin, TILE_SIZE, WG, lid.xy, lidx, light_grid.header.slice_first, light_grid.header.slice_scale, light_grid.header.lists_per_tile);
#else
#ifdef DEPTH_MASK
    let mask = region_mask(origin, TILE_SIZE, WG, lid.xy, lidx, near, far, 0u);
#endif
#endif
    if lidx == 0u {
        tile_ranges[t] = select(vec2<f32>(-1.0), vec2<f32>(near, far), geometry);
#ifndef CLUSTERED
        if geometry {
            let blocks_x = (light_grid.header.tiles.x + BLOCK - 1u) / BLOCK;
            let b = (wid.y / BLOCK) * blocks_x + wid.x / BLOCK;
            atomicMax(&block_ranges[2u * b], ~order_key(near));
            atomicMax(&block_ranges[2u * b + 1u], order_key(far));
        }
#endif
#ifdef DEPTH_MASK
        tile_masks[t] = mask;
#else
#ifdef CLUSTERED
        tile_masks[t] = mask;
#endif
#endif
    }
}
