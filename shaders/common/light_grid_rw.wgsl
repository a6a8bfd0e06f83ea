// The light grid as its writers bind it (the culling kernels, the light-centric
// assignment and the tile-depth pass): the header's counters atomic. The readers' view is
// common/light_grid.wgsl, which this includes; the two headers must stay alike.
#include "common/light_grid.wgsl"

struct LightGridCounters {
    allocated: atomic<u32>,
    pairs: atomic<u32>,
    dropped_pairs: atomic<u32>,
    dropped_lists: atomic<u32>,
    spilled_lists: atomic<u32>,
    capacity: u32,
    tiles: vec2<u32>,
    tile_size: u32,
    lists_per_tile: u32,
    list_capacity: u32,
    slice_first: f32,
    slice_scale: f32,
    _pad0: u32,
}

struct LightGridRw {
    header: LightGridCounters,
    lists: array<vec2<u32>>,
}
