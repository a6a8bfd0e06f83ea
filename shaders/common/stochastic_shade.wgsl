// The stochastic method's light loop (issue 48: every light shadowed), included by the
// traced kernel's body (common/traced_shade.wgsl) with STOCHASTIC in place of the traced
// reference's loop over every light:
//
// 1. Candidates from two sources that split the lights (CPU twin:
//    tiledlight_cull::stochastic::resample_near_far, the same draws): `candidates` drawn
//    uniformly from the pixel's list in the light grid, counted only when the light's
//    radius reaches the point (the culling lists every such light), and `far_candidates`
//    drawn uniformly from every light, counted only when it does not. Each candidate's
//    target is the luminance of its unshadowed contribution with no cutoff
//    (common/shade.wgsl with STOCHASTIC casts no ray), its weight p_hat / (q M_source)
//    times the total M; one is kept in a reservoir (common/stochastic.wgsl).
// 2. One shadow ray to the kept light through the BVH (traced_visibility); the pixel's
//    light is f(y) V(y) W, unbiased for the sum over every light of f V (with no far
//    candidates, over the lights whose radius reaches the point: the cutoff's bias).
// 3. Temporal accumulation: the running mean of the frames since the camera or the lights
//    last changed (`traced_band.accumulated` of them before this one, 0 after a change:
//    nothing of another view remains), kept per pixel in `stochastic_history` with the mean
//    of the squared luminance of each frame's light over the albedo (the denoiser's
//    variance). The count stops at the `accumulate` setting, where the mean becomes a moving
//    average.
// 4. With DENOISE, the denoiser's guide: the pixel's normal and view distance (0: sky), the
//    albedo the light is divided by and the unlit term (stochastic_denoise.wgsl filters the
//    history with it).
// 5. With REUSE, spatial reuse (tiledlight_cull::reuse, whose doc numbers the steps): the
//    pass runs twice. The first (REUSE_PASS 0) stops after step 1 and leaves each pixel's
//    reservoir as a record (the kept light, W, the normal, view distance and material); the second
//    (REUSE_PASS 1) merges its own record with REUSE_NEIGHBOURS neighbours' of a similar
//    surface, each light weighed by the target at this pixel and its balance-heuristic
//    share (common/reuse.wgsl), and goes on with steps 2-4.

#include "common/stochastic.wgsl"

// The light grid (group 3, as the visibility kernel binds it; common/deferred_shade.wgsl
// declares it for the kernels without TRACED) and, per grid tile, near and far view
// distance (the half-z lookup).
#include "common/light_grid_rw.wgsl"
@group(3) @binding(0) var<storage, read_write> light_grid: LightGridRw;
@group(3) @binding(1) var<storage, read_write> light_indices: array<u32>;
@group(3) @binding(2) var<storage, read_write> tile_ranges: array<vec2<f32>>;
#include "common/light_grid_pixel.wgsl"

// The accumulated image: one linear HDR colour a pixel (a: the mean squared luminance of
// the frames' light over the albedo), row-major at the screen's width.
@group(1) @binding(40) var<storage, read_write> stochastic_history: array<vec4<f32>>;

// The smallest albedo the light is divided by (tiledlight_cull::denoise::DEMOD_FLOOR).
override DEMOD_FLOOR: f32;

#ifdef DENOISE
// The denoiser's guide (stochastic_denoise.wgsl's binding 0): three planes of one vec4 a
// pixel, the surface (normal, view distance; 0: sky), the albedo, the unlit term.
@group(1) @binding(41) var<storage, read_write> denoise_guide: array<vec4<f32>>;
#endif

#ifdef REUSE
#include "common/reuse.wgsl"
// Which run of the pass this is: 0 samples and leaves the records, 1 reuses them (step 5).
override REUSE_PASS: u32 = 0u;
// Neighbours merged a pixel; the box's half side in pixels; the similarity test's normal
// cosine and distance share; the first random draw of the reuse (tiledlight_cull::reuse's
// constants, passed by the host).
override REUSE_NEIGHBOURS: u32 = 0u;
override REUSE_RADIUS: i32;
override REUSE_NORMAL_COS: f32;
override REUSE_DISTANCE_SHARE: f32;
override REUSE_DRAW_BASE: u32;
// One record a pixel, row-major, two vec4s each (common/reuse.wgsl, RecordWords).
@group(1) @binding(42) var<storage, read_write> stochastic_records: array<vec4<u32>>;
#endif

#include "common/luminance.wgsl"

// True when the light's radius reaches point `p`: the windowed falloff's `in_range`
// (common/shade.wgsl), so the light is in the list of every tile that holds `p`.
fn reaches(light: u32, p: vec3<f32>) -> bool {
    let d = shading_lights[light].position - p;
    let r = shading_lights[light].radius;
    return dot(d, d) < r * r;
}

// Step 1: the pixel's reservoir of this frame's candidates.
fn stochastic_sample(g: GSample, p: vec2<u32>, pixel: u32, v: vec3<f32>) -> Reservoir {
    let n = lighting.num_lights;
    let frame = traced_band.frame;
    let list = pixel_list(p, g.dist);
    let m_near = select(0u, traced_band.candidates, list.count > 0u);
    let m_far = traced_band.far_candidates;
    let total = f32(m_near + m_far);
    var r = reservoir_empty();
    for (var k = 0u; k < m_near + m_far; k++) {
        let near = k < m_near;
        let count = select(n, list.count, near);
        let i = min(u32(rand01(pixel, frame, 2u * k) * f32(count)), count - 1u);
        let light = select(i, light_indices[list.first + i], near);
        var p_hat = 0.0;
        if reaches(light, g.world) == near {
            p_hat = luminance(shade_light(light, g.world, g.normal, v, g.surface));
        }
        let m = select(m_far, m_near, near);
        reservoir_update(&r, light, p_hat * f32(count) * total / f32(m), p_hat, rand01(pixel, frame, 2u * k + 1u));
    }
    return r;
}

#ifdef REUSE
// The surface the reuse weighs lights at (common/reuse.wgsl's reuse_target), set before
// reuse_combine.
var<private> reuse_surface: GSample;
var<private> reuse_view: vec3<f32>;

fn reuse_record(index: u32) -> RecordWords {
    return RecordWords(stochastic_records[2u * index], stochastic_records[2u * index + 1u]);
}

fn reuse_target(light: u32) -> f32 {
    let g = reuse_surface;
    return luminance(shade_light(light, g.world, g.normal, reuse_view, g.surface));
}

fn reuse_position(q: vec2<u32>, dist: f32) -> vec3<f32> {
    let v = view_point_at(pixel_to_ndc(vec2<f32>(q) + vec2<f32>(0.5)), dist);
    return (view.view_to_world * vec4<f32>(v, 1.0)).xyz;
}

// The balance heuristic's p' (tiledlight_cull::reuse, step 4): the target at another
// pixel's point, normal and material.
fn reuse_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    let m = unpack4x8unorm(s.x);
    let surface = Surface(m.rgb, m.a, bitcast<f32>(s.y));
    return luminance(shade_light(light, x, n, view_vector(x), surface));
}

// Step 5's second run: the pixel's own record and its neighbours' merged.
fn stochastic_reuse(g: GSample, p: vec2<u32>, v: vec3<f32>) -> Reservoir {
    reuse_surface = g;
    reuse_view = v;
    let c = ReuseParams(view.screen.xy, traced_band.frame, traced_band.candidates, traced_band.far_candidates,
        REUSE_NEIGHBOURS, REUSE_RADIUS, REUSE_NORMAL_COS, REUSE_DISTANCE_SHARE, REUSE_DRAW_BASE);
    return reuse_combine(p, c);
}
#endif

// This frame's estimate of the pixel's light (steps 1 and 2, with REUSE step 5), without
// the unlit term.
fn stochastic_estimate(g: GSample, p: vec2<u32>, pixel: u32) -> vec3<f32> {
    if lighting.num_lights == 0u {
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
#ifdef REUSE
    let r = stochastic_reuse(g, p, v);
#else
    let r = stochastic_sample(g, p, pixel, v);
#endif
    let w = reservoir_weight(r);
    if w <= 0.0 {
        return vec3<f32>(0.0);
    }
    let f = shade_light(r.light, g.world, g.normal, v, g.surface);
    // p_hat > 0: the light is on the normal's side, as the ray assumes.
    return f * (w * traced_visibility(g.world, g.normal, shading_lights[r.light].position));
}

// Linear HDR of one surface sample: the unlit term and the accumulated estimate (steps 3
// and 4).
fn shade_lights_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    let pixel = p.y * view.screen.x + p.x;
#ifdef REUSE
    if REUSE_PASS == 0u {
        // Step 5's first run: the record, no ray, nothing accumulated.
        var w = RecordWords(vec4<u32>(0u), vec4<u32>(0u));
        if !g.sky && lighting.num_lights > 0u {
            let r = stochastic_sample(g, p, pixel, view_vector(g.world));
            let s = g.surface;
            // More candidates than the far ones: the list had some.
            w = record_pack(ReuseRecord(r.light, r.m > traced_band.far_candidates, reservoir_weight(r), g.normal, g.dist,
                surface_pack(s.albedo, s.roughness, s.metallic)));
        }
        stochastic_records[2u * pixel] = w.head;
        stochastic_records[2u * pixel + 1u] = w.surface;
        return vec3<f32>(0.0);
    }
#endif
    if g.sky {
#ifdef DENOISE
        denoise_guide[pixel] = vec4<f32>(0.0);
#endif
        return vec3<f32>(0.0);
    }
    let c = stochastic_estimate(g, p, pixel);
    let albedo = max(g.surface.albedo, vec3<f32>(DEMOD_FLOOR));
    let l = luminance(c / albedo);
    let n = traced_band.accumulated;
    var mean = c;
    var squares = l * l;
    if n > 0u {
        let h = stochastic_history[pixel];
        mean = h.rgb + (c - h.rgb) / f32(n + 1u);
        squares = h.a + (l * l - h.a) / f32(n + 1u);
    }
    stochastic_history[pixel] = vec4<f32>(mean, squares);
#ifdef DENOISE
    let plane = view.screen.x * view.screen.y;
    denoise_guide[pixel] = vec4<f32>(g.normal, g.dist);
    denoise_guide[plane + pixel] = vec4<f32>(albedo, 0.0);
    denoise_guide[2u * plane + pixel] = vec4<f32>(g.unlit, 0.0);
#endif
    return g.unlit + mean;
}
