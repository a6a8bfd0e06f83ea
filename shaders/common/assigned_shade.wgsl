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

// Linear HDR of one surface sample of pixel `p`, lit by its list in the grid.
fn shade_lights_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    if g.sky {
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
    var color = g.unlit;
    let l = pixel_list(p, g.dist);
    for (var i = 0u; i < l.count; i++) {
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
    // The lists are in the grid already; the barrier orders the reset above.
    workgroupBarrier();
    shade_tile_pixels(wid, lid, lidx);
}
