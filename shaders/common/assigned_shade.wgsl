// The shading kernel over lists in the light grid before it (deferred_assigned.wgsl: Tiled
// Deferred with light-centric assignment; visibility.wgsl, visibility_msaa.wgsl: the
// visibility buffer, whose lists come from Forward+'s culling pass or its assignment):
// nothing is culled here, and each pixel of the workgroup's tile reads its own list from
// the grid (common/light_grid_pixel.wgsl: its tile's, its half's with HALF_Z, its cluster's
// with CLUSTERED) and is shaded from its surface (common/deferred_shade.wgsl, MSAA
// included: a G-buffer sample, or with VISIBILITY the visibility buffer's triangle).
#include "common/deferred_shade.wgsl"
// The shading workgroup's tile (independent of the grid's tiles, which the lookup reads
// from the grid header).
override TILE_SIZE: u32 = 16u;
override WG: u32 = 16u;

// Per grid tile: near and far view distance (the half-z lookup).
#ifdef VISIBILITY
@group(3) @binding(2) var<storage, read_write> tile_ranges: array<vec2<f32>>;
#else
@group(2) @binding(2) var<storage, read_write> tile_ranges: array<vec2<f32>>;
#endif
#include "common/light_grid_pixel.wgsl"

#ifdef VISIBILITY
// The pass settings' row `stage-lights` (the visibility buffer; the host sets it only with
// tile lists, where the workgroup's tile is the grid's and every pixel reads one list): the
// workgroup copies its list's first STAGE_CAP indices and shading records into workgroup
// memory once, and its pixels read them from there instead of each fetching every record
// from the light buffer. The sum is the same in the same order: the image does not change.
// Only the visibility buffer's kernels declare it (Tiled Deferred's assigned-list kernel
// never stages: no workgroup memory for it there).
override STAGE_LIGHTS: bool = false;
const STAGE_CAP: u32 = 256u;
var<workgroup> staged_index: array<u32, STAGE_CAP>;
var<workgroup> staged_light: array<ShadingLight, STAGE_CAP>;
var<workgroup> staged_count: u32;

// Copies the first lights of workgroup `wid`'s tile list (call before the barrier that
// starts the shading).
fn stage_lights(wid: vec3<u32>, lidx: u32) {
    let l = light_list(light_grid.lists[wid.y * light_grid.header.tiles.x + wid.x], light_grid.header.capacity);
    let n = min(l.count, STAGE_CAP);
    for (var k = lidx; k < n; k += WG * WG) {
        let i = light_indices[l.first + k];
        staged_index[k] = i;
        staged_light[k] = shading_lights[i];
    }
    if lidx == 0u {
        staged_count = n;
    }
}
#endif

// Linear HDR of one surface sample of pixel `p`, lit by its list in the grid.
fn shade_lights_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    if g.sky {
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
    var color = g.unlit;
    let l = pixel_list(p, g.dist);
    var i = 0u;
#ifdef VISIBILITY
    if STAGE_LIGHTS {
        // The pixel's list is the workgroup's: its first lights are staged.
        for (; i < staged_count; i++) {
            color += shade_light_record(staged_index[i], staged_light[i], g.world, g.normal, v, g.surface);
        }
    }
#endif
    for (; i < l.count; i++) {
        color += shade_light(light_indices[l.first + i], g.world, g.normal, v, g.surface);
    }
    return color;
}

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
#ifdef MSAA
    if lidx == 0u {
        atomicStore(&wg_edge_count, 0u);
    }
#endif
#ifdef VISIBILITY
    if STAGE_LIGHTS {
        stage_lights(wid, lidx);
    }
#endif
    // The lists are in the grid already; the barrier orders the reset and the staging above.
    workgroupBarrier();
    shade_tile_pixels(wid, lid, lidx);
}
