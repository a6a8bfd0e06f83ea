// The stochastic method's spatial reuse (issue 48, item 3): tiledlight_cull::reuse's steps
// 1-5 (its module doc numbers them) with the reservoir of common/stochastic.wgsl. The
// includer defines where the records are, where a pixel is and what a light gives:
//
//   fn reuse_record(index: u32) -> RecordWords // the record of pixel `index` (row-major)
//   fn reuse_target(light: u32) -> f32         // p_hat of `light` at this pixel's surface
//   fn reuse_position(q: vec2<u32>, dist: f32) -> vec3<f32>
//                                              // pixel q's world point at view distance dist
//   fn reuse_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32
//                                              // the balance heuristic's p': the target at
//                                              // a point, normal and packed material
//
// (common/stochastic_shade.wgsl reads its record buffer and shades the light;
// tests/tests/stochastic_twin.rs gives a table.) Include-only; no binding of its own.

#include "common/stochastic.wgsl"
#include "common/octahedral.wgsl"

// What a pixel's reuse needs besides its records: the screen, the frame, the candidates a
// pixel drew (near, far), the neighbours, and tiledlight_cull::reuse's constants.
struct ReuseParams {
    screen: vec2<u32>,
    frame: u32,
    candidates: u32,
    far_candidates: u32,
    neighbours: u32,
    radius: i32,
    normal_cos: f32,
    distance_share: f32,
    draw_base: u32,
}

// Bit 31 of a record's first word: the pixel drew near candidates.
const REUSE_NEAR_BIT: u32 = 0x80000000u;

// Step 1: a pixel's reservoir as the sampling run leaves it (Record::pack): the light, the
// near flag, W, the normal, the view distance and the material's two words
// (tiledlight_cull::reuse::pack_surface).
struct ReuseRecord {
    light: u32,
    near: bool,
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
    let head = vec4<u32>(r.light | select(0u, REUSE_NEAR_BIT, r.near), bitcast<u32>(r.weight),
        pack2x16snorm(oct_map(r.normal)), bitcast<u32>(r.dist));
    return RecordWords(head, vec4<u32>(r.surface, 0u, 0u));
}

fn record_unpack(w: RecordWords) -> ReuseRecord {
    let h = w.head;
    return ReuseRecord(h.x & ~REUSE_NEAR_BIT, (h.x & REUSE_NEAR_BIT) != 0u, bitcast<f32>(h.y),
        oct_unmap(unpack2x16snorm(h.z)), bitcast<f32>(h.w), w.surface.xy);
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
// heuristic share of the light; the reservoir's count is 1 (W = w_sum / p_hat(y)).
fn reuse_combine(p: vec2<u32>, c: ReuseParams) -> Reservoir {
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
        let m = select(0u, c.candidates, rec.near) + c.far_candidates;
        lights[n] = rec.light;
        weights[n] = rec.weight;
        draws[n] = u;
        points[n] = vec4<f32>(reuse_position(vec2<u32>(q), rec.dist), f32(m));
        normals[n] = rec.normal;
        surfaces[n] = rec.surface;
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
    return r;
}
