// The traced reference's kernel body (traced.wgsl, traced_msaa.wgsl; issue 30): the
// visibility buffer's surface and MSAA machinery (common/deferred_shade.wgsl with
// VISIBILITY), and a light loop over every light with no cutoff (NO_CUTOFF) whose shadows
// are rays (common/shade.wgsl with TRACED calls traced_visibility), not shadow maps.
//
// A frame is cast in bands of tile rows, one dispatch each (crates/visibility/src/
// shading.rs, Traced): `traced_band.first_row` (a dynamic offset) says where this dispatch
// starts, so a long render can be submitted band by band and report its progress. With
// STOCHASTIC the light loop is the sampler's (common/stochastic_shade.wgsl; one band). Each
// workgroup adds the rays its threads cast to `trace_stats` (a 64-bit count in two words).
#include "common/deferred_shade.wgsl"
#include "common/trace.wgsl"

override TILE_SIZE: u32 = 16u;
override WG: u32 = 16u;
// The ray's ends are moved off the surface and off the light by TRACE_EPS of the point's
// largest coordinate, bounded by the scene's size TRACE_SCALE, plus 1 m, and TRACE_POSITION_EPS
// of that coordinate for the reconstructed position's rounding
// (tiledlight_cull::trace::surface_eps): a surface never shadows itself, and a scene far
// from the origin keeps its contact shadows.
override TRACE_EPS: f32 = 0.000244140625;
override TRACE_POSITION_EPS: f32 = 0.0000019073486328125;
override TRACE_SCALE: f32;

@group(1) @binding(33) var<storage, read> trace_nodes: array<TraceNode>;
@group(1) @binding(34) var<storage, read> trace_tris: array<vec4<f32>>;
#ifdef TRACE_MASKS
@group(1) @binding(35) var<storage, read> trace_uvs: array<vec2<f32>>;
@group(1) @binding(36) var<storage, read> trace_mask_slots: array<vec4<u32>>;
@group(1) @binding(37) var<storage, read> trace_mask_bits: array<u32>;
#endif
// A band's first row; the stochastic method's frame (its one band is rewritten each
// frame): the seed, the near and far candidates a pixel, the frames its history holds and
// whether its temporal reuse has a previous frame (crates/visibility/src/stochastic.rs,
// FrameParams; 0 for the traced reference).
struct TracedBand {
    first_row: u32,
    frame: u32,
    candidates: u32,
    accumulated: u32,
    far_candidates: u32,
    history: u32,
    // The traced reference's lights of this dispatch, [light_first, light_end): all of
    // them (0, u32 max) but on a CPU adapter, whose driver caps a shader's loops
    // (crates/visibility/src/shading.rs, CPU_TRACED_CHUNK_LIGHTS).
    light_first: u32,
    light_end: u32,
}
@group(1) @binding(38) var<uniform> traced_band: TracedBand;
// Rays cast: low word, high word; then the invocations whose loops a driver cut short
// (common/trace.wgsl, trace_cut).
@group(1) @binding(39) var<storage, read_write> trace_stats: array<atomic<u32>, 3>;

var<workgroup> wg_rays: atomic<u32>;

// Visibility (0 or 1) of the light at `light_pos` from surface point `p` with normal `n`
// (the light is on the normal's side): the segment from p, lifted along n, to the light.
fn traced_visibility(p: vec3<f32>, n: vec3<f32>, light_pos: vec3<f32>) -> f32 {
    let a = abs(p);
    let m = max(a.x, max(a.y, a.z));
    let eps = TRACE_EPS * (min(m, TRACE_SCALE) + 1.0) + TRACE_POSITION_EPS * m;
    return select(1.0, 0.0, trace_occluded(p + n * eps, light_pos, eps));
}

#ifdef STOCHASTIC
#include "common/stochastic_shade.wgsl"
#else
#ifndef MSAA
// The sum of the lights the band's earlier dispatches shaded, one linear HDR colour a
// pixel, row-major (a 16-byte placeholder, never touched, when one dispatch shades every
// light).
@group(1) @binding(40) var<storage, read_write> traced_sum: array<vec4<f32>>;
#endif

// Linear HDR of one surface sample: the dispatch's lights (every light, but on a CPU
// adapter), each shadowed by its ray, plus what the earlier dispatches summed.
fn shade_lights_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    if g.sky {
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
    let first = traced_band.light_first;
    let end = min(traced_band.light_end, lighting.num_lights);
    var color = select(vec3<f32>(0.0), g.unlit, first == 0u);
    var i = first;
    loop {
        if i >= end {
            break;
        }
        color += shade_light(i, g.world, g.normal, v, g.surface);
        i++;
    }
    // Left before the last light: a driver's loop limit (trace_cut).
    if i < end {
        trace_cut = true;
    }
#ifndef MSAA
    if end < lighting.num_lights || first > 0u {
        let pixel = p.y * view.screen.x + p.x;
        if first > 0u {
            color += traced_sum[pixel].rgb;
        }
        traced_sum[pixel] = vec4<f32>(color, 0.0);
    }
#endif
    return color;
}
#endif

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    if lidx == 0u {
        atomicStore(&wg_rays, 0u);
#ifdef MSAA
        atomicStore(&wg_edge_count, 0u);
#endif
    }
    workgroupBarrier();
    shade_tile_pixels(vec3<u32>(wid.x, wid.y + traced_band.first_row, 0u), lid, lidx);
    atomicAdd(&wg_rays, trace_ray_count);
    if trace_cut {
        atomicAdd(&trace_stats[2], 1u);
    }
    workgroupBarrier();
    if lidx == 0u {
        let n = atomicLoad(&wg_rays);
        let before = atomicAdd(&trace_stats[0], n);
        if before + n < before {
            atomicAdd(&trace_stats[1], 1u);
        }
    }
}
