// The per-tile light culling shared by the culling pass (cull.wgsl, Forward+) and the
// deferred pass (deferred.wgsl, Tiled Deferred): one WG x WG workgroup per tile reduces
// the min/max depth of the tile's non-sky pixels, builds the tile's view volume and tests
// the candidate lights (every light, or its 64x64-pixel cell's with COARSE) in parallel,
// appending survivors to workgroup lists (two with HALF_Z). The CPU reference is
// crates/cull/src/reference.rs (cull_tiles).
//
// The depth buffer is declared by common/depth_range.wgsl (group 1, binding 0).
// The including file declares: `cull_lights:
// array<CullLight>`, with COARSE `cell_lists: array<u32>`, with SPOT_CONE `shading_lights`
// and `spot_lights`.
#include "common/tile_tests.wgsl"
#include "common/depth_range.wgsl"
#ifdef DEPTH_MASK
#include "common/depth_mask.wgsl"
#endif

// Tile side in pixels; the workgroup is WG x WG threads, each reducing (TILE_SIZE / WG)^2 pixels.
override TILE_SIZE: u32 = 16u;
override WG: u32 = 16u;
// Indices stored per list.
override CAPACITY: u32 = 512u;

#ifdef DROP_LIGHT
// Test-only (tiledlight_gpu::culling::DropLight, never set in production): tile DROP_TILE
// leaves light DROP_INDEX out of its lists, so tests can prove the image comparisons with
// the brute-force reference fail when one light is missing from one tile.
override DROP_TILE: u32 = 0u;
override DROP_INDEX: u32 = 0u;
#endif

#ifdef COARSE
// Cell side and the indices a cell stores (tiledlight_cull::lists::{COARSE_SIZE, COARSE_CAPACITY}).
override CELL: u32 = 64u;
override COARSE_CAPACITY: u32 = 8192u;
#endif

var<workgroup> wg_count: array<atomic<u32>, 2>;
var<workgroup> wg_list: array<u32, CAPACITY>;
#ifdef HALF_Z
var<workgroup> wg_list_far: array<u32, CAPACITY>;
#endif

fn append(list: u32, light: u32) {
    let slot = atomicAdd(&wg_count[list], 1u);
    if slot < CAPACITY {
#ifdef HALF_Z
        if list == 1u {
            wg_list_far[slot] = light;
            return;
        }
#endif
        wg_list[slot] = light;
    }
}

// What cull_tile found out about its tile: its volumes and candidates, so the light loop
// can be run again (write_list in common/light_grid_write.wgsl re-tests a list longer than
// the workgroup list, writing straight to the light grid).
struct TileCull {
    index: u32,
    tile: vec2<u32>,
    // View distances of the nearest and farthest surface (0, 0 for an all-sky tile).
    near: f32,
    far: f32,
    // Lights to test: every light, or (COARSE, cell not overflowed) the cell's list from
    // cell_lists[cell_first].
    candidates: u32,
    from_cell: bool,
    cell_first: u32,
    // DEPTH_MASK (2.5D): the bins of [near, far] holding a surface of the tile.
    mask: u32,
}

// Lists a tile has: 2 with HALF_Z.
fn lists_per_tile() -> u32 {
#ifdef HALF_Z
    return 2u;
#else
    return 1u;
#endif
}

// Light index of candidate `k` of the tile.
fn tile_candidate(t: TileCull, k: u32) -> u32 {
#ifdef COARSE
    if t.from_cell {
        return cell_lists[t.cell_first + k];
    }
#endif
    return k;
}

// The near (or only) list's volume, and the far list's with HALF_Z. Recomputed where it is
// needed (the same arithmetic gives the same planes) rather than kept in TileCull: a
// second pass over a long list is rare, and registers held across the grid writing would
// cost every tile.
fn tile_volumes(t: TileCull) -> TileVolumes {
    return tile_volumes_at(t.tile, TILE_SIZE, t.near, t.far);
}

// Whether `light` belongs to the tile's near (x) and far (y, HALF_Z only) list.
fn tile_hits(t: TileCull, vols: TileVolumes, light: u32) -> vec2<bool> {
    let cl = cull_lights[light];
    let c = (view.world_to_view * vec4<f32>(cl.center, 1.0)).xyz;
    let r = cl.radius;
    if r <= 0.0 {
        return vec2<bool>(false);
    }
#ifdef DROP_LIGHT
    if t.index == DROP_TILE && light == DROP_INDEX {
        return vec2<bool>(false);
    }
#endif
    var hit = volume_hits(vols, light, c, r);
#ifdef DEPTH_MASK
    // 2.5D: the light's depth bins must meet a bin holding a surface of the tile.
    if (t.mask & depth_mask_between(-c.z - r, -c.z + r, t.near, t.far)) == 0u {
        hit.x = false;
    }
#endif
    return hit;
}

// Culls the workgroup's tile into wg_list (and wg_list_far with HALF_Z); wg_count holds the
// true counts. Must be called from uniform control flow (it has barriers) by every thread.
fn cull_tile(tile: vec2<u32>, lid: vec2<u32>, lidx: u32) -> TileCull {
    if lidx == 0u {
        atomicStore(&wg_count[0], 0u);
        atomicStore(&wg_count[1], 0u);
    }
    let origin = tile * TILE_SIZE;
    let range = region_depth_range(origin, TILE_SIZE, WG, lid, lidx);

    var t: TileCull;
    t.index = tile.y * ((view.screen.x + TILE_SIZE - 1u) / TILE_SIZE) + tile.x;
    t.tile = tile;
    let min_depth = range.x;
    let max_depth = range.y;
    if max_depth > 0.0 {
        // Reversed-Z: the largest depth is the nearest surface.
        t.near = view_distance(max_depth);
        t.far = view_distance(min_depth);
    }
#ifdef DEPTH_MASK
    // Out here: region_mask has barriers (uniform control flow). All sky: 0.
    t.mask = region_mask(origin, TILE_SIZE, WG, lid, lidx, t.near, t.far, 0u);
#endif
    if max_depth > 0.0 {
        let vols = tile_volumes(t);
        t.candidates = lighting.num_lights;
#ifdef COARSE
        let cells = (view.screen + CELL - 1u) / CELL;
        let cell_index = (origin.y / CELL) * cells.x + origin.x / CELL;
        t.cell_first = cells.x * cells.y + cell_index * COARSE_CAPACITY;
        let cell_count = cell_lists[cell_index];
        t.from_cell = cell_count <= COARSE_CAPACITY;
        if t.from_cell {
            t.candidates = cell_count;
        }
#endif
        for (var k = lidx; k < t.candidates; k += WG * WG) {
            let light = tile_candidate(t, k);
            let hit = tile_hits(t, vols, light);
            if hit.x {
                append(0u, light);
            }
#ifdef HALF_Z
            if hit.y {
                append(1u, light);
            }
#endif
        }
    }
    workgroupBarrier();
    return t;
}
