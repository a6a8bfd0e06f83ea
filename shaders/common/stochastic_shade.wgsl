// The stochastic method's light loop (issue 48: every light shadowed), included by the
// traced kernel's body (common/traced_shade.wgsl) with STOCHASTIC in place of the traced
// reference's loop over every light:
//
// 1. Candidates from two sources that split the lights (CPU twin:
//    tiledlight_cull::stochastic::resample_near_far, the same draws): `candidates` drawn
//    from the pixel's list in the light grid, counted only when the light's
//    radius reaches the point (the culling lists every such light; stratified over the
//    list, at most one a light: with candidates >= the list's length every light once),
//    and `far_candidates`
//    drawn from every light, uniformly or (FAR_FROM_TREE) from the light tree
//    (common/light_tree.wgsl: in proportion to each light's power over its distance),
//    counted only when its radius does not reach. Each candidate's
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
// 5. With REUSE, reservoir reuse (common/reuse.wgsl; tiledlight_cull::reuse and ::temporal,
//    whose docs number the steps). Spatial (REUSE_NEIGHBOURS > 0): the pass runs twice. The
//    first (REUSE_PASS 0) stops after step 1 and leaves each pixel's reservoir as a record
//    (the kept light, the candidates it stands for, W, the normal, view distance and
//    material); the second (REUSE_PASS 1) merges its own record with REUSE_NEIGHBOURS
//    neighbours' of a similar surface, each light weighed by the target at this pixel and
//    its balance-heuristic share, and goes on with steps 2-4. Temporal (TEMPORAL_CAP > 0):
//    step 1's reservoir is merged with the history's record of the same surface, found by
//    reprojecting the pixel's point into the previous view (in the first run, or with no
//    spatial reuse in the one run, REUSE_PASS 2, which reads a copy of the history the
//    host made in the records: it overwrites the history as it goes); the run that shades
//    leaves each pixel's final reservoir in the history for the next frame.

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
// Which run of the pass this is (step 5): 0 samples and leaves the records, 1 reuses the
// neighbours' and shades, 2 (temporal reuse alone) samples, reuses the history and shades.
override REUSE_PASS: u32 = 0u;
// Neighbours merged a pixel; the box's half side in pixels; the similarity test's normal
// cosine and distance share; the first random draw of the reuse (tiledlight_cull::reuse's
// constants, passed by the host); the history's count at most TEMPORAL_CAP times a
// frame's (0: no temporal reuse).
override REUSE_NEIGHBOURS: u32 = 0u;
override REUSE_RADIUS: i32;
override REUSE_NORMAL_COS: f32;
override REUSE_DISTANCE_SHARE: f32;
override REUSE_DRAW_BASE: u32;
override TEMPORAL_CAP: u32 = 0u;
// One record a pixel, row-major, two vec4s each (common/reuse.wgsl, RecordWords).
@group(1) @binding(42) var<storage, read_write> stochastic_records: array<vec4<u32>>;
// The history (temporal reuse): the view the previous frame was seen through, then its
// pixels' final records. Without temporal reuse the host binds the records here (never
// read).
struct ReuseHistory {
    view: View,
    records: array<vec4<u32>>,
}
@group(1) @binding(43) var<storage, read_write> reuse_history: ReuseHistory;
#endif

#include "common/luminance.wgsl"

// The light tree the far candidates are drawn from with FAR_FROM_TREE 1
// (tiledlight_cull::light_tree; else uniformly, and the host binds one zero node here,
// never read).
override FAR_FROM_TREE: u32 = 0u;
@group(1) @binding(44) var<storage, read> light_tree: array<LightNode>;
#include "common/light_tree.wgsl"

// Shadow rays a pixel (tiledlight_cull::stochastic::MAX_RAYS at most): pick 0 is the
// reservoir step 1 returns (and reuse merges), picks 1 to RAYS - 1 reservoirs over the same
// candidates deciding with ray_number, left in `more_picks` by stochastic_sample; the
// pixel's light is the mean of the picks' estimates.
override RAYS: u32 = 1u;
var<private> more_picks: array<Reservoir, 7>;

// True when the light's radius reaches point `p`: the windowed falloff's `in_range`
// (common/shade.wgsl), so the light is in the list of every tile that holds `p`.
fn reaches(light: u32, p: vec3<f32>) -> bool {
    let d = shading_lights[light].position - p;
    let r = shading_lights[light].radius;
    return dot(d, d) < r * r;
}

// The light tree's leaves left to the list (common/light_tree.wgsl).
fn tree_reaches(light: u32, p: vec3<f32>) -> bool {
    return reaches(light, p);
}

// Step 1: the pixel's reservoir of this frame's candidates.
fn stochastic_sample(g: GSample, p: vec2<u32>, pixel: u32, v: vec3<f32>) -> Reservoir {
    let n = lighting.num_lights;
    let frame = traced_band.frame;
    let list = pixel_list(p, g.dist);
    // Stratified over the list, at most one draw a light (tiledlight_cull::stochastic::
    // near_count and near_draw).
    let m_near = min(traced_band.candidates, list.count);
    let m_far = traced_band.far_candidates;
    let total = f32(m_near + m_far);
    var r = reservoir_empty();
    var more: array<Reservoir, 7>;
    for (var k = 0u; k < m_near + m_far; k++) {
        let near = k < m_near;
        let count = select(n, list.count, near);
        let u = rand01(pixel, frame, 2u * k);
        var light = min(u32(u * f32(count)), count - 1u);
        // One over the light's probability: uniform over every light, or the tree's; from
        // a stratum of the list, the stratum's size times the near draws (the weight's
        // division by m_near leaves the size).
        var inv_q = f32(count);
        if near {
            let d = near_draw(k, m_near, count, u);
            light = light_indices[list.first + d.x];
            inv_q = f32(d.y) * f32(m_near);
        }
        if !near && FAR_FROM_TREE != 0u {
            let t = tree_sample(g.world, pixel, frame, 2u * k);
            light = t.x;
            let q = bitcast<f32>(t.y);
            inv_q = select(0.0, 1.0 / q, q > 0.0);
        }
        var p_hat = 0.0;
        if reaches(light, g.world) == near && inv_q > 0.0 {
            p_hat = luminance(shade_light(light, g.world, g.normal, v, g.surface));
        }
        let m = select(m_far, m_near, near);
        let w = p_hat * inv_q * total / f32(m);
        let ur = rand01(pixel, frame, 2u * k + 1u);
        reservoir_update(&r, light, w, p_hat, ur);
        for (var j = 1u; j < RAYS; j++) {
            // Through a copy: naga's SPIR-V writer fails on a pointer to a dynamically
            // indexed element passed to a function (naga 30, "Expression is not cached").
            var q = more[j - 1u];
            reservoir_update(&q, light, w, p_hat, ray_number(ur, j, RAYS));
            more[j - 1u] = q;
        }
    }
    if RAYS > 1u {
        more_picks = more;
    }
    return r;
}

// One pick's estimate f(y) V(y) W (0 when nothing was kept).
fn pick_estimate(r: Reservoir, g: GSample, v: vec3<f32>) -> vec3<f32> {
    let w = reservoir_weight(r);
    if w <= 0.0 {
        return vec3<f32>(0.0);
    }
    let f = shade_light(r.light, g.world, g.normal, v, g.surface);
    // p_hat > 0: the light is on the normal's side, as the ray assumes.
    return f * (w * traced_visibility(g.world, g.normal, shading_lights[r.light].position));
}

#ifdef REUSE
// The surface the reuse weighs lights at (common/reuse.wgsl's reuse_target), set before
// reuse_combine and temporal_merge.
var<private> reuse_surface: GSample;
var<private> reuse_view: vec3<f32>;

fn reuse_params() -> ReuseParams {
    return ReuseParams(view.screen.xy, traced_band.frame, REUSE_NEIGHBOURS, REUSE_RADIUS, REUSE_NORMAL_COS,
        REUSE_DISTANCE_SHARE, REUSE_DRAW_BASE);
}

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

// The target of `light` at point x, normal n and packed material s, seen along v.
fn target_at(light: u32, x: vec3<f32>, n: vec3<f32>, v: vec3<f32>, s: vec2<u32>) -> f32 {
    let m = unpack4x8unorm(s.x);
    return luminance(shade_light(light, x, n, v, Surface(m.rgb, m.a, bitcast<f32>(s.y))));
}

// The balance heuristic's p' (tiledlight_cull::reuse, step 4): the target at another
// pixel's point, normal and material.
fn reuse_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    return target_at(light, x, n, view_vector(x), s);
}

// The same for the history's record (tiledlight_cull::temporal, step 5), seen from the
// previous frame's eye.
fn temporal_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    let h = reuse_history.view;
    return target_at(light, x, n, vector_to_viewer(h.view_to_world, h.eye, h.orthographic, x), s);
}

// The history's record of pixel `index`: the history itself in the first run, the host's
// copy of it in the records in the only one (REUSE_PASS 2, which overwrites the history).
fn history_record(index: u32) -> RecordWords {
    if REUSE_PASS == 0u {
        return RecordWords(reuse_history.records[2u * index], reuse_history.records[2u * index + 1u]);
    }
    return reuse_record(index);
}

// Leaves pixel `pixel`'s final record in the history (with temporal reuse).
fn history_write(pixel: u32, w: RecordWords) {
    if TEMPORAL_CAP > 0u {
        reuse_history.records[2u * pixel] = w.head;
        reuse_history.records[2u * pixel + 1u] = w.surface;
    }
}

// The record of the pixel's merged reservoir `m` at surface g.
fn record_of(g: GSample, m: Merged) -> RecordWords {
    let s = g.surface;
    return record_pack(ReuseRecord(m.r.light, m.count, reservoir_weight(m.r), g.normal, g.dist,
        surface_pack(s.albedo, s.roughness, s.metallic)));
}

// Step 1's reservoir, with temporal reuse (tiledlight_cull::temporal, steps 2-5) merged
// with the history's record of the same surface (none after a reset, behind the previous
// camera, off its screen or where the surface was hidden). Only while the frames' mean
// starts again each frame (the view moves, or no mean is kept): once a still view
// accumulates, its frames must be independent for the mean to converge (reused
// reservoirs repeat their lights: on lavapipe's courtyard 8 frames' FLIP 0.19 -> 0.33), so
// the mean takes over and the history only follows along for the next move.
fn stochastic_own(g: GSample, p: vec2<u32>, pixel: u32, v: vec3<f32>) -> Merged {
    let r = stochastic_sample(g, p, pixel, v);
    if TEMPORAL_CAP == 0u || traced_band.accumulated > 0u {
        return Merged(r, r.m);
    }
    reuse_surface = g;
    reuse_view = v;
    let c = reuse_params();
    var h = ReuseRecord(0u, 0u, 0.0, vec3<f32>(0.0, 0.0, 1.0), 0.0, vec2<u32>(0u));
    var x = vec3<f32>(0.0);
    var kept = false;
    if traced_band.history != 0u {
        let prev = reuse_history.view;
        let q = temporal_reproject(g.world, prev.world_to_clip, prev.world_to_view, view.screen.xy);
        if q.pixel.x >= 0 {
            h = record_unpack(history_record(u32(q.pixel.y) * view.screen.x + u32(q.pixel.x)));
            kept = h.light < lighting.num_lights && temporal_same_surface(g.normal, q.dist, h, c);
            let at = point_in_view(prev.view_to_clip, prev.orthographic, pixel_to_ndc(vec2<f32>(q.pixel) + 0.5),
                h.dist);
            x = (prev.view_to_world * vec4<f32>(at, 1.0)).xyz;
        }
    }
    return temporal_merge(r, h, x, kept, pixel, c, TEMPORAL_CAP);
}
#endif

// This frame's estimate of the pixel's light (steps 1 and 2, with REUSE step 5), without
// the unlit term.
fn stochastic_estimate(g: GSample, p: vec2<u32>, pixel: u32) -> vec3<f32> {
    if lighting.num_lights == 0u {
#ifdef REUSE
        history_write(pixel, RecordWords(vec4<u32>(0u), vec4<u32>(0u)));
#endif
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
#ifdef REUSE
    var m: Merged;
    if REUSE_PASS == 1u {
        reuse_surface = g;
        reuse_view = v;
        m = reuse_combine(p, reuse_params());
        if RAYS > 1u {
            // The other picks are this pixel's own: its candidates drawn again (the same
            // numbers as the sampling run's, so the same candidates).
            _ = stochastic_sample(g, p, pixel, v);
        }
    } else {
        m = stochastic_own(g, p, pixel, v);
    }
    history_write(pixel, record_of(g, m));
    let r = m.r;
#else
    let r = stochastic_sample(g, p, pixel, v);
#endif
    var c = pick_estimate(r, g, v);
    for (var j = 1u; j < RAYS; j++) {
        c += pick_estimate(more_picks[j - 1u], g, v);
    }
    return c / f32(RAYS);
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
            w = record_of(g, stochastic_own(g, p, pixel, view_vector(g.world)));
        }
        stochastic_records[2u * pixel] = w.head;
        stochastic_records[2u * pixel + 1u] = w.surface;
        return vec3<f32>(0.0);
    }
#endif
    if g.sky {
#ifdef REUSE
        history_write(pixel, RecordWords(vec4<u32>(0u), vec4<u32>(0u)));
#endif
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
