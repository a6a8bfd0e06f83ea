// Writing a culled tile's lists to the light grid (common/light_grid.wgsl), shared by the
// Forward+ culling pass (cull.wgsl) and Tiled Deferred (deferred.wgsl). Include after
// common/tile_cull.wgsl. The including file declares `light_grid: LightGridRw` and
// `light_indices: array<u32>` (read_write).
//
// Per list, one thread allocates `count` indices with one atomicAdd on the frame's counter
// (no fixed per-list region: the buffer is sized from the frame's real number of pairs).
// A list that fits the workgroup list (count <= CAPACITY) is copied from it; a longer one is
// culled again, every survivor written straight to the grid, so a tile has no ceiling on its
// lights. When the buffer is full the list keeps what fits and the header counts the rest.
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
    _pad0: u32,
}

struct LightGridRw {
    header: LightGridCounters,
    lists: array<vec2<u32>>,
}

var<workgroup> wg_list_first: u32;
var<workgroup> wg_list_stored: u32;
var<workgroup> wg_spill_count: atomic<u32>;

// Entry `i` of workgroup list `k` (0 near, 1 far).
fn wg_list_entry(k: u32, i: u32) -> u32 {
#ifdef HALF_Z
    if k == 1u {
        return wg_list_far[i];
    }
#endif
    return wg_list[i];
}

// Writes workgroup list `k` of the culled tile `t` as grid list `list` and returns its stored
// part. Every thread must call it from uniform control flow (it has barriers).
fn write_list(t: TileCull, k: u32, list: u32, lidx: u32) -> LightList {
    // Spill loops of the previous list may still be counting.
    workgroupBarrier();
    if lidx == 0u {
        let count = atomicLoad(&wg_count[k]);
        let cap = light_grid.header.capacity;
        // `first` past the end stores nothing (light_list clips it). Once the buffer is
        // full nothing more is allocated, so the counter cannot wrap around.
        var first = cap;
        var stored = 0u;
        if count > 0u {
            if atomicLoad(&light_grid.header.allocated) < cap {
                first = atomicAdd(&light_grid.header.allocated, count);
                stored = min(count, cap - min(first, cap));
            }
            atomicAdd(&light_grid.header.pairs, count);
            if stored < count {
                atomicAdd(&light_grid.header.dropped_pairs, count - stored);
                atomicAdd(&light_grid.header.dropped_lists, 1u);
            }
            if count > CAPACITY {
                atomicAdd(&light_grid.header.spilled_lists, 1u);
            }
        }
        light_grid.lists[list] = vec2<u32>(first, count);
        wg_list_first = first;
        wg_list_stored = stored;
        atomicStore(&wg_spill_count, 0u);
    }
    let first = workgroupUniformLoad(&wg_list_first);
    let stored = wg_list_stored;
    if atomicLoad(&wg_count[k]) <= CAPACITY {
        for (var i = lidx; i < stored; i += WG * WG) {
            light_indices[first + i] = wg_list_entry(k, i);
        }
    } else {
        // Longer than the workgroup list: test the candidates again and write every
        // survivor to the grid (the order differs from the first pass; only the set counts).
        for (var c = lidx; c < t.candidates; c += WG * WG) {
            let light = tile_candidate(t, c);
            if tile_hits(t, light)[k] {
                let slot = atomicAdd(&wg_spill_count, 1u);
                if slot < stored {
                    light_indices[first + slot] = light;
                }
            }
        }
    }
    return LightList(first, stored);
}
