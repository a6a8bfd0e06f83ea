// The light-grid lookup of a shaded pixel (Forward+ now; transparency and VPLs next): the
// list of its tile, and with HALF_Z the near or far half's. The including file declares
// `light_grid`, `light_indices` (common/light_grid.wgsl) and, with HALF_Z,
// `tile_ranges: array<vec2<f32>>` (near and far view distance per tile).
// CPU twin: tiledlight_cull::reference::TileLists::list_index.
#include "common/light_grid.wgsl"

// The list a pixel at window position `pixel` and view distance `dist` uses.
fn pixel_list(pixel: vec2<u32>, dist: f32) -> LightList {
    let tile = pixel / light_grid.header.tile_size;
    let tile_index = tile.y * light_grid.header.tiles.x + tile.x;
#ifdef HALF_Z
    let range = tile_ranges[tile_index];
    let l = tile_index * 2u + select(0u, 1u, dist > 0.5 * (range.x + range.y));
#else
    let l = tile_index;
#endif
    return light_list(light_grid.lists[l], light_grid.header.capacity);
}
