// The light-grid lookup of a shaded pixel (Forward+, Tiled Deferred with assigned lists,
// transparency): the list of its tile, with HALF_Z the near or far half's, with CLUSTERED
// its depth slice's. The including file declares `light_grid`, `light_indices` (common/light_grid.wgsl) and, with HALF_Z,
// `tile_ranges: array<vec2<f32>>` (near and far view distance per tile).
// CPU twin: tiledlight_cull::lists::TileLists::list_index.
#include "common/light_grid.wgsl"

// The list a pixel at window position `pixel` and view distance `dist` uses.
fn pixel_list(pixel: vec2<u32>, dist: f32) -> LightList {
    let tile = pixel / light_grid.header.tile_size;
    let tile_index = tile.y * light_grid.header.tiles.x + tile.x;
#ifdef HALF_Z
    let range = tile_ranges[tile_index];
    let l = tile_index * 2u + select(0u, 1u, dist > 0.5 * (range.x + range.y));
#else
#ifdef CLUSTERED
    let h = &light_grid.header;
    let l = tile_index * (*h).lists_per_tile + cluster_slice(dist, (*h).slice_first, (*h).slice_scale, (*h).lists_per_tile);
#else
    let l = tile_index;
#endif
#endif
    return light_list(light_grid.lists[l], light_grid.header.capacity);
}
