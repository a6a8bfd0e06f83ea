// The depth buffer the culling kernels read, and the min/max reversed-Z depth of a screen
// region's non-sky samples reduced by a workgroup in workgroup memory; shared by the cell
// pass (cull_coarse.wgsl), the per-tile culling (common/tile_cull.wgsl) and Tiled Deferred.
// With BLENDED (the blended geometry's lists) a second buffer holds the nearest blended
// depth (cleared to 0): only samples where it is in front of the opaque depth count, and
// the range runs from that blended depth to the opaque depth behind it (0, infinitely far,
// over the sky). CPU twin: tiledlight_cull::volumes::blended_tile_bounds.
// With MSAA the buffer is multisampled (SAMPLES per pixel, set by the pipeline) and the
// range covers every sample, so a light reaching any sample stays in the tile's list.
// The CPU reference is tiledlight_cull::tiles::tile_depth_bounds_samples.
// Declared as unfilterable float textures, not depth textures: a Depth32Float view binds
// there as well as the R32Float depth the visibility buffer's compute raster writes.
#include "common/view.wgsl"

#ifdef MSAA
override SAMPLES: u32 = 4u;
@group(1) @binding(0) var depth_texture: texture_multisampled_2d<f32>;
#ifdef BLENDED
@group(1) @binding(10) var blended_depth_texture: texture_multisampled_2d<f32>;
#endif
#else
@group(1) @binding(0) var depth_texture: texture_2d<f32>;
#ifdef BLENDED
@group(1) @binding(10) var blended_depth_texture: texture_2d<f32>;
#endif
#endif

var<workgroup> wg_min_depth: atomic<u32>;
var<workgroup> wg_max_depth: atomic<u32>;

// Depth of sample `s` of pixel `p` (s is 0 without MSAA).
fn load_depth(p: vec2<u32>, s: u32) -> f32 {
#ifdef MSAA
    return textureLoad(depth_texture, p, s).x;
#else
    return textureLoad(depth_texture, p, 0).x;
#endif
}

#ifdef BLENDED
// `r` (min, max) grown by sample `s` of pixel `p` when a blended surface lies in front of
// the opaque one there: min takes the opaque depth, max the blended one.
fn grow_blended(r: vec4<f32>, p: vec2<u32>, s: u32) -> vec4<f32> {
#ifdef MSAA
    let o = textureLoad(depth_texture, p, s).x;
    let b = textureLoad(blended_depth_texture, p, s).x;
#else
    let o = textureLoad(depth_texture, p, 0).x;
    let b = textureLoad(blended_depth_texture, p, 0).x;
#endif
    // x: min, y: max, z: 1 when any sample counted.
    return select(r, vec4<f32>(min(r.x, o), max(r.y, b), 1.0, 0.0), b > o);
}
#endif

#ifdef MSAA
// `r` (min, max) grown by depth `d` unless it is sky (0, the clear value).
fn grow_range(r: vec2<f32>, d: f32) -> vec2<f32> {
    return select(r, vec2<f32>(min(r.x, d), max(r.y, d)), d > 0.0);
}

// Min (x) and max (y) non-sky depth of pixel `p`'s samples (3.4e38, 0 when all are sky).
fn sample_range(p: vec2<u32>) -> vec2<f32> {
    var r = vec2<f32>(3.4e38, 0.0);
    r = grow_range(r, textureLoad(depth_texture, p, 0).x);
    r = grow_range(r, textureLoad(depth_texture, p, 1).x);
    if SAMPLES > 2u {
        r = grow_range(r, textureLoad(depth_texture, p, 2).x);
        r = grow_range(r, textureLoad(depth_texture, p, 3).x);
    }
    if SAMPLES > 4u {
        r = grow_range(r, textureLoad(depth_texture, p, 4).x);
        r = grow_range(r, textureLoad(depth_texture, p, 5).x);
        r = grow_range(r, textureLoad(depth_texture, p, 6).x);
        r = grow_range(r, textureLoad(depth_texture, p, 7).x);
    }
    return r;
}
#endif

// Min (x) and max (y) depth of the `size` x `size` pixels at `origin`, clipped to the screen,
// reduced by a `threads` x `threads` workgroup (this thread is `lid`). Max 0 means all sky.
// Every thread must call it from uniform control flow: it has barriers.
fn region_depth_range(origin: vec2<u32>, size: u32, threads: u32, lid: vec2<u32>, lidx: u32) -> vec2<f32> {
    if lidx == 0u {
        // Depth is in [0, 1]: non-negative floats order like their bit patterns.
        atomicStore(&wg_min_depth, 0x7f800000u);
        atomicStore(&wg_max_depth, 0u);
    }
    workgroupBarrier();
    var lo = 3.4e38;
    var hi = 0.0;
    let steps = size / threads;
#ifdef BLENDED
    var found = false;
#endif
    for (var j = 0u; j < steps; j++) {
        for (var i = 0u; i < steps; i++) {
            let p = origin + lid + vec2<u32>(i, j) * threads;
            if p.x < view.screen.x && p.y < view.screen.y {
#ifdef BLENDED
                var r = vec4<f32>(lo, hi, 0.0, 0.0);
#ifdef MSAA
                for (var s = 0u; s < SAMPLES; s++) {
                    r = grow_blended(r, p, s);
                }
#else
                r = grow_blended(r, p, 0u);
#endif
                lo = r.x;
                hi = r.y;
                found = found || r.z > 0.0;
#else
#ifdef MSAA
                // Unrolled by hand (SAMPLES is a pipeline constant, so the untaken branches
                // fold away): the H100's driver did not unroll the loop, and culling ran 3x
                // slower with it.
                let r = sample_range(p);
                lo = min(lo, r.x);
                hi = max(hi, r.y);
#else
                let d = textureLoad(depth_texture, p, 0).x;
                // Sky (depth 0, the clear value) is no surface.
                if d > 0.0 {
                    lo = min(lo, d);
                    hi = max(hi, d);
                }
#endif
#endif
            }
        }
    }
#ifdef BLENDED
    // Blended in front of the sky: min 0 (infinitely far) is a valid bound here.
    if found {
        atomicMin(&wg_min_depth, bitcast<u32>(lo));
        atomicMax(&wg_max_depth, bitcast<u32>(hi));
    }
#else
    if hi > 0.0 {
        atomicMin(&wg_min_depth, bitcast<u32>(lo));
        atomicMax(&wg_max_depth, bitcast<u32>(hi));
    }
#endif
    workgroupBarrier();
    return vec2<f32>(bitcast<f32>(atomicLoad(&wg_min_depth)), bitcast<f32>(atomicLoad(&wg_max_depth)));
}
