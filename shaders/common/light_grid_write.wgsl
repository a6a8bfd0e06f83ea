// Writing a culled tile's lists to the light grid (common/light_grid.wgsl), shared by the
// Forward+ culling pass (cull.wgsl) and Tiled Deferred (deferred.wgsl). Include after
// common/tile_cull.wgsl. The including file declares `light_grid: LightGridRw` and
// `light_indices: array<u32>` (read_write).
//
// Per list, one thread allocates `count` indices with one atomicAdd on the frame's counter
// (no fixed per-list region: the buffer is sized from the frame's real number of pairs);
// the GRID_GUARD constant (set by the host when a frame could find 2^32 pairs) keeps the
// counter from wrapping.
// A list that fits the workgroup list (count <= CAPACITY) is copied from it; a longer one is
// culled again, every survivor written straight to the grid, so a tile has no ceiling on its
// lights. When the buffer is full the list keeps what fits and the header counts the rest.
#include "common/light_grid_rw.wgsl"

// Per list (0 near, 1 far): its first index and stored count, and the spill counter.
var<workgroup> wg_grid_first: array<u32, 2>;
var<workgroup> wg_grid_stored: array<u32, 2>;
var<workgroup> wg_spill_count: array<atomic<u32>, 2>;

// Entry `i` of workgroup list `k` (0 near, 1 far).
fn wg_list_entry(k: u32, i: u32) -> u32 {
#ifdef HALF_Z
    if k == 1u {
        return wg_list_far[i];
    }
#endif
    return wg_list[i];
}

// Records workgroup list `k` (`count` lights) as grid list `list` at `first` (past the end
// of the buffer: nothing stored; light_list clips it).
fn place_list(k: u32, list: u32, first: u32, count: u32) {
    let stored = grid_place(list, first, count);
    if count > CAPACITY {
        atomicAdd(&light_grid.header.spilled_lists, 1u);
    }
    wg_grid_first[k] = min(first, light_grid.header.capacity);
    wg_grid_stored[k] = stored;
    atomicStore(&wg_spill_count[k], 0u);
}

// Allocates the tile's lists (both with HALF_Z, one after the other) with one atomic add on
// the frame's counter: one thread of the workgroup calls it. Every workgroup adds to the
// same address, so the adds are few: one a tile (the frame's pair count is then the
// counter; with GRID_GUARD, a separate count).
fn allocate_lists(list0: u32) {
    let c0 = atomicLoad(&wg_count[0]);
    var c1 = 0u;
#ifdef HALF_Z
    c1 = atomicLoad(&wg_count[1]);
#endif
    let cap = light_grid.header.capacity;
    let base = grid_allocate(c0 + c1);
    place_list(0u, list0, base, c0);
#ifdef HALF_Z
    // base + c0 cannot wrap: without the guard a frame's pairs stay below 2^32, with it
    // base is below the capacity (at most 2^30) plus the adds in flight.
    place_list(1u, list0 + 1u, select(base + c0, cap, base >= cap), c1);
#endif
}

// Writes the stored part of workgroup list `k`: a copy when it fits the workgroup list,
// else the tile's candidates tested again and every survivor written straight to the grid
// (the order differs from the first pass; only the set counts).
fn fill_list(t: TileCull, k: u32, lidx: u32) {
    let first = wg_grid_first[k];
    let stored = wg_grid_stored[k];
    if atomicLoad(&wg_count[k]) <= CAPACITY {
        for (var i = lidx; i < stored; i += WG * WG) {
            light_indices[first + i] = wg_list_entry(k, i);
        }
        return;
    }
    let vols = tile_volumes(t);
    for (var c = lidx; c < t.candidates; c += WG * WG) {
        let light = tile_candidate(t, c);
        if tile_hits(t, vols, light)[k] {
            let slot = atomicAdd(&wg_spill_count[k], 1u);
            if slot < stored {
                light_indices[first + slot] = light;
            }
        }
    }
}

// Writes the culled tile `t`'s lists to the grid (grid lists `list0`, and `list0 + 1` with
// HALF_Z) and returns their stored parts. Every thread must call it from uniform control
// flow, after cull_tile (whose last barrier orders the workgroup lists before this).
fn write_lists(t: TileCull, list0: u32, lidx: u32) -> array<LightList, 2> {
    if lidx == 0u {
        allocate_lists(list0);
    }
    workgroupBarrier();
    fill_list(t, 0u, lidx);
#ifdef HALF_Z
    fill_list(t, 1u, lidx);
#endif
    return array<LightList, 2>(
        LightList(wg_grid_first[0], wg_grid_stored[0]),
        LightList(wg_grid_first[1], wg_grid_stored[1]),
    );
}
