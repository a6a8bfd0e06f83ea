// Tiled Deferred's tile kernel (deferred.wgsl, deferred_msaa.wgsl): one compute dispatch
// culls and shades. Each workgroup culls its tile with the same code as Forward+
// (common/tile_cull.wgsl) into workgroup memory and writes its lists to the light grid
// (common/light_grid_write.wgsl: heat map, statistics, tests, and the lists longer than the
// workgroup list), then each thread shades its pixels from the G-buffer with that list (its
// half with HALF_Z) and the shared BRDF, writing linear HDR to a storage texture
// (common/deferred_shade.wgsl). A list that fits the workgroup list is read from workgroup
// memory, as in AMD's sample; a longer one from the grid, so no tile has a ceiling on its
// lights.
#include "common/tile_cull.wgsl"
#include "common/light_grid_write.wgsl"
#include "common/deferred_shade.wgsl"

// The lights a pixel of the tile is shaded with: workgroup list `k` (0 near, 1 far) when
// the list fits it (`in_wg`), else the list's stored part in the light grid.
struct TileList {
    in_wg: bool,
    k: u32,
    grid: LightList,
    count: u32,
}

fn tile_list(k: u32, grid: LightList) -> TileList {
    let found = atomicLoad(&wg_count[k]);
    if found <= CAPACITY {
        return TileList(true, k, grid, found);
    }
    return TileList(false, k, grid, grid.count);
}

// Linear HDR of one G-buffer sample lit by the tile's list (its half with HALF_Z).
fn shade(g: GSample, t: TileCull, near: TileList, far: TileList) -> vec3<f32> {
    if g.sky {
        // Sky: black, as the forward pass's clear.
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
    var color = g.unlit;
    var l = near;
#ifdef HALF_Z
    if g.dist > half_z_split(t.near, t.far) {
        l = far;
    }
#endif
    // The loops are written out per source so the common case reads workgroup memory
    // exactly as before the grid existed.
    if !l.in_wg {
        for (var i = 0u; i < l.count; i++) {
            color += shade_light(light_indices[l.grid.first + i], g.world, g.normal, v, g.surface);
        }
        return color;
    }
#ifdef HALF_Z
    if l.k == 1u {
        for (var i = 0u; i < l.count; i++) {
            color += shade_light(wg_list_far[i], g.world, g.normal, v, g.surface);
        }
        return color;
    }
#endif
    for (var i = 0u; i < l.count; i++) {
        color += shade_light(wg_list[i], g.world, g.normal, v, g.surface);
    }
    return color;
}

// The workgroup's tile and lists, set once by main (so one shade_at serves both variants).
var<private> p_tile: TileCull;
var<private> p_near: TileList;
var<private> p_far: TileList;

fn shade_lights_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    return shade(g, p_tile, p_near, p_far);
}

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
#ifdef MSAA
    if lidx == 0u {
        atomicStore(&wg_edge_count, 0u);
    }
#endif
    // cull_tile's barriers also order the reset above before any use.
    let t = cull_tile(wid.xy, lid.xy, lidx);
    let lists = write_lists(t, t.index * lists_per_tile(), lidx);
    p_tile = t;
    p_near = tile_list(0u, lists[0]);
#ifdef HALF_Z
    p_far = tile_list(1u, lists[1]);
#else
    p_far = p_near;
#endif
    // Lists longer than the workgroup list were written to the grid by every thread.
    storageBarrier();
    shade_tile_pixels(wid, lid, lidx);
}
