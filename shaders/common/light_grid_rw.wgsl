// The light grid as its writers bind it (the culling kernels, the light-centric
// assignment and the tile-depth pass): the header's counters atomic. The readers' view is
// common/light_grid.wgsl, which this includes; the two headers must stay alike. Also
// the allocation every writer does (grid_allocate, grid_place). The including file
// declares `light_grid: LightGridRw`.
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

// True when lists x lights may reach 2^32 (tiledlight_gpu::light_grid::needs_guard).
override GRID_GUARD: bool = true;

// Allocates `total` indices with one atomic add on the frame's counter and returns the
// first (the capacity when nothing was allocated). With GRID_GUARD (a frame could find
// 2^32 pairs or more: lists x lights, checked on the host) nothing more is allocated once
// the buffer is full, so the counter cannot wrap around onto stored lists; that costs a
// second atomic round trip, and the pairs are then counted apart.
fn grid_allocate(total: u32) -> u32 {
    let cap = light_grid.header.capacity;
    var base = cap;
    if total > 0u {
        if GRID_GUARD {
            atomicAdd(&light_grid.header.pairs, total);
            if atomicLoad(&light_grid.header.allocated) < cap {
                base = atomicAdd(&light_grid.header.allocated, total);
            }
        } else {
            base = atomicAdd(&light_grid.header.allocated, total);
        }
    }
    return base;
}

// Records grid list `list` of `count` lights at `first` (past the end of the buffer:
// nothing stored; light_list clips it), counting the pairs and the list a full buffer
// cut short. Returns how many of its indices are stored.
fn grid_place(list: u32, first: u32, count: u32) -> u32 {
    let cap = light_grid.header.capacity;
    let stored = min(count, cap - min(first, cap));
    if stored < count {
        atomicAdd(&light_grid.header.dropped_pairs, count - stored);
        atomicAdd(&light_grid.header.dropped_lists, 1u);
    }
    light_grid.lists[list] = vec2<u32>(first, count);
    return stored;
}
