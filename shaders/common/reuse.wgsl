// The stochastic method's reservoir reuse (issue 48, item 3): spatial, tiledlight_cull::
// reuse's steps 1-5, and temporal, tiledlight_cull::temporal's steps 2-5 (their module
// docs number them), with the reservoir of common/stochastic.wgsl. The includer defines
// where the records are, where a pixel is and what a light gives:
//
//   fn reuse_record(index: u32) -> RecordWords // the record of pixel `index` (row-major)
//   fn reuse_target(light: u32) -> f32         // p_hat of `light` at this pixel's surface
//   fn reuse_position(q: vec2<u32>, dist: f32) -> vec3<f32>
//                                              // pixel q's world point at view distance dist
//   fn reuse_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32
//                                              // the balance heuristic's p': the target at
//                                              // a point, normal and packed material
//   fn temporal_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32
//                                              // the same seen from the previous eye
//
// (common/stochastic_shade.wgsl reads its record buffer and shades the light;
// tests/tests/stochastic_twin.rs gives a table.) Include-only; no binding of its own.

#include "common/stochastic.wgsl"
#include "common/octahedral.wgsl"

// What a pixel's reuse needs besides its records: the screen, the frame, the neighbours,
// and tiledlight_cull::reuse's constants.
struct ReuseParams {
    screen: vec2<u32>,
    frame: u32,
    neighbours: u32,
    radius: i32,
    normal_cos: f32,
    distance_share: f32,
    draw_base: u32,
}

// Step 1: a pixel's reservoir as the sampling run leaves it (Record::pack): the light, the
// candidates it stands for, W, the normal, the view distance and the material's two words
// (tiledlight_cull::reuse::pack_surface).
struct ReuseRecord {
    light: u32,
    count: u32,
    weight: f32,
    normal: vec3<f32>,
    dist: f32,
    surface: vec2<u32>,
}

// A record's eight words, as stored (two vec4s a pixel).
struct RecordWords {
    head: vec4<u32>,
    surface: vec4<u32>,
}

fn record_pack(r: ReuseRecord) -> RecordWords {
    let head = vec4<u32>(r.light, bitcast<u32>(r.weight), pack2x16snorm(oct_map(r.normal)), bitcast<u32>(r.dist));
    return RecordWords(head, vec4<u32>(r.surface, r.count, 0u));
}

fn record_unpack(w: RecordWords) -> ReuseRecord {
    let h = w.head;
    return ReuseRecord(h.x, w.surface.z, bitcast<f32>(h.y), oct_unmap(unpack2x16snorm(h.z)), bitcast<f32>(h.w),
        w.surface.xy);
}

// A merged reservoir (count 1: reservoir_weight is W) and the candidates it stands for.
struct Merged {
    r: Reservoir,
    count: u32,
}

// tiledlight_cull::reuse::pack_surface.
fn surface_pack(albedo: vec3<f32>, roughness: f32, metallic: f32) -> vec2<u32> {
    return vec2<u32>(pack4x8unorm(vec4<f32>(albedo, roughness)), bitcast<u32>(metallic));
}

// Step 2: neighbour j of pixel p, or (-1, -1) off the screen or on p itself.
fn reuse_neighbour(p: vec2<u32>, pixel: u32, j: u32, c: ReuseParams) -> vec2<i32> {
    let side = f32(2 * c.radius + 1);
    let d = vec2<i32>(i32(rand01(pixel, c.frame, c.draw_base + 3u * j) * side),
        i32(rand01(pixel, c.frame, c.draw_base + 3u * j + 1u) * side)) - vec2<i32>(c.radius);
    let q = vec2<i32>(p) + d;
    let on = all(q >= vec2<i32>(0)) && all(q < vec2<i32>(c.screen)) && any(d != vec2<i32>(0));
    return select(vec2<i32>(-1), q, on);
}

// Step 3: a neighbour's surface close enough to lend its reservoir.
fn reuse_similar(a: ReuseRecord, b: ReuseRecord, c: ReuseParams) -> bool {
    return a.dist > 0.0 && b.dist > 0.0 && dot(a.normal, b.normal) >= c.normal_cos
        && abs(a.dist - b.dist) <= c.distance_share * a.dist;
}

// The merge's inputs at most: the pixel's own record and tiledlight_cull::reuse::
// MAX_NEIGHBOURS neighbours' (the setting's limit).
const REUSE_MAX_INPUTS: u32 = 17u;

// Steps 2-5 (tiledlight_cull::reuse::offers and combine): pixel p's own record and its
// similar neighbours' merged into one reservoir, each input weighed by its balance-
// heuristic share of the light; the reservoir's count is 1 (W = w_sum / p_hat(y)), the
// merged records' counts summed beside it.
fn reuse_combine(p: vec2<u32>, c: ReuseParams) -> Merged {
    let pixel = p.y * c.screen.x + p.x;
    let own = record_unpack(reuse_record(pixel));
    var lights: array<u32, REUSE_MAX_INPUTS>;
    var weights: array<f32, REUSE_MAX_INPUTS>;
    var draws: array<f32, REUSE_MAX_INPUTS>;
    // Each input's world point and count, and its normal.
    var points: array<vec4<f32>, REUSE_MAX_INPUTS>;
    var normals: array<vec3<f32>, REUSE_MAX_INPUTS>;
    var surfaces: array<vec2<u32>, REUSE_MAX_INPUTS>;
    var n = 0u;
    var count = 0u;
    var rec = own;
    var q = vec2<i32>(p);
    var u = rand01(pixel, c.frame, c.draw_base - 1u);
    let k = min(c.neighbours, REUSE_MAX_INPUTS - 1u);
    for (var j = 0u; j <= k; j++) {
        if j > 0u {
            q = reuse_neighbour(p, pixel, j - 1u, c);
            if q.x < 0 {
                continue;
            }
            rec = record_unpack(reuse_record(u32(q.y) * c.screen.x + u32(q.x)));
            if !reuse_similar(own, rec, c) {
                continue;
            }
            u = rand01(pixel, c.frame, c.draw_base + 3u * (j - 1u) + 2u);
        }
        let m = rec.count;
        lights[n] = rec.light;
        weights[n] = rec.weight;
        draws[n] = u;
        points[n] = vec4<f32>(reuse_position(vec2<u32>(q), rec.dist), f32(m));
        normals[n] = rec.normal;
        surfaces[n] = rec.surface;
        count += m;
        n++;
    }
    var r = reservoir_empty();
    for (var i = 0u; i < n; i++) {
        var w = 0.0;
        var p_hat = 0.0;
        if weights[i] > 0.0 {
            // Input i's own term is one of the sum's: kept, not evaluated again.
            var total = 0.0;
            var mine = 0.0;
            for (var j = 0u; j < n; j++) {
                let term = points[j].w * reuse_proxy(lights[i], points[j].xyz, normals[j], surfaces[j]);
                total += term;
                if j == i {
                    mine = term;
                }
            }
            p_hat = reuse_target(lights[i]);
            if total > 0.0 {
                w = mine / total * p_hat * weights[i];
            }
        }
        reservoir_update(&r, lights[i], w, p_hat, draws[i]);
    }
    r.m = 1u;
    return Merged(r, count);
}

// Temporal reuse (tiledlight_cull::temporal). Step 2: the previous frame's pixel that
// showed world point `x` through `world_to_clip` on `screen`, and the view distance the
// point had there (-z through `world_to_view`); pixel (-1, -1) behind the camera or off the
// screen.
struct Reprojected {
    pixel: vec2<i32>,
    dist: f32,
}

fn temporal_reproject(x: vec3<f32>, world_to_clip: mat4x4<f32>, world_to_view: mat4x4<f32>, screen: vec2<u32>)
    -> Reprojected {
    let clip = world_to_clip * vec4<f32>(x, 1.0);
    let dist = -(world_to_view * vec4<f32>(x, 1.0)).z;
    let s = vec2<f32>(screen);
    let f = vec2<f32>((clip.x / clip.w + 1.0) * 0.5 * s.x, (1.0 - clip.y / clip.w) * 0.5 * s.y);
    if clip.w <= 0.0 || !(all(f >= vec2<f32>(0.0)) && all(f < s)) {
        return Reprojected(vec2<i32>(-1), dist);
    }
    return Reprojected(vec2<i32>(vec2<u32>(f)), dist);
}

// Step 3: the history's record `h` shows the surface of normal `n` this pixel sees,
// expected at view distance `dist` there.
fn temporal_same_surface(n: vec3<f32>, dist: f32, h: ReuseRecord, c: ReuseParams) -> bool {
    return reuse_similar(ReuseRecord(0u, 0u, 0.0, n, dist, vec2<u32>(0u)), h, c);
}

// Step 4: the count the history enters with, at most `cap` times this frame's.
fn temporal_capped(history: u32, own: u32, cap: u32) -> u32 {
    // Saturating own * cap (tiledlight_cull::temporal::capped).
    let limit = select(own * cap, 0xffffffffu, cap > 0u && own > 0xffffffffu / cap);
    return min(history, limit);
}

// Steps 4-5: this frame's reservoir `own` (its count is its m) and, with `kept`, the
// history's record `h` at world point `x` merged by the balance heuristic, the history's
// count capped at `cap` times own's (tiledlight_cull::temporal::merge).
fn temporal_merge(own: Reservoir, h: ReuseRecord, x: vec3<f32>, kept: bool, pixel: u32, c: ReuseParams, cap: u32)
    -> Merged {
    let m_own = own.m;
    let m_history = select(0u, temporal_capped(h.count, m_own, cap), kept);
    let a = f32(m_own);
    let b = f32(m_history);
    var r = reservoir_empty();
    let w0 = reservoir_weight(own);
    var w = 0.0;
    if w0 > 0.0 {
        let p = own.p_hat;
        var q = 0.0;
        if m_history > 0u {
            q = temporal_proxy(own.light, x, h.normal, h.surface);
        }
        w = a * p / (a * p + b * q) * p * w0;
    }
    reservoir_update(&r, own.light, w, own.p_hat, 0.0);
    if m_history > 0u && h.weight > 0.0 {
        let p = reuse_target(h.light);
        let q = temporal_proxy(h.light, x, h.normal, h.surface);
        let total = a * p + b * q;
        var wh = 0.0;
        if total > 0.0 {
            wh = b * q / total * p * h.weight;
        }
        reservoir_update(&r, h.light, wh, p, rand01(pixel, c.frame, c.draw_base - 2u));
    }
    r.m = 1u;
    return Merged(r, m_own + m_history);
}
