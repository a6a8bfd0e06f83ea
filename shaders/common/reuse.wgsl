// The stochastic method's spatial reuse (issue 48, item 3): tiledlight_cull::reuse's steps
// 1-4 (its module doc numbers them) with the reservoir of common/stochastic.wgsl. The
// includer defines where the records are and what a light's target is at the pixel:
//
//   fn reuse_record(index: u32) -> vec4<u32>   // the record of pixel `index` (row-major)
//   fn reuse_target(light: u32) -> f32         // p_hat of `light` at this pixel's surface
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

// Step 1: a pixel's reservoir as the sampling run leaves it (Record::pack).
struct ReuseRecord {
    light: u32,
    near: bool,
    weight: f32,
    normal: vec3<f32>,
    dist: f32,
}

fn record_pack(r: ReuseRecord) -> vec4<u32> {
    return vec4<u32>(r.light | select(0u, REUSE_NEAR_BIT, r.near), bitcast<u32>(r.weight),
        pack2x16snorm(oct_map(r.normal)), bitcast<u32>(r.dist));
}

fn record_unpack(w: vec4<u32>) -> ReuseRecord {
    return ReuseRecord(w.x & ~REUSE_NEAR_BIT, (w.x & REUSE_NEAR_BIT) != 0u, bitcast<f32>(w.y),
        oct_unmap(unpack2x16snorm(w.z)), bitcast<f32>(w.w));
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

// Step 4: a record offered to the merged reservoir, its light weighed at this surface.
fn reuse_offer(r: ptr<function, Reservoir>, rec: ReuseRecord, u: f32, c: ReuseParams) {
    var p_hat = 0.0;
    if rec.weight > 0.0 {
        p_hat = reuse_target(rec.light);
    }
    let m = select(0u, c.candidates, rec.near) + c.far_candidates;
    let before = (*r).m;
    reservoir_update(r, rec.light, p_hat * rec.weight * f32(m), p_hat, u);
    (*r).m = before + m;
}

// Steps 2-4 (tiledlight_cull::reuse::combine): pixel p's own record and its similar
// neighbours' merged into one reservoir.
fn reuse_combine(p: vec2<u32>, c: ReuseParams) -> Reservoir {
    let pixel = p.y * c.screen.x + p.x;
    let own = record_unpack(reuse_record(pixel));
    var r = reservoir_empty();
    reuse_offer(&r, own, rand01(pixel, c.frame, c.draw_base - 1u), c);
    for (var j = 0u; j < c.neighbours; j++) {
        let q = reuse_neighbour(p, pixel, j, c);
        if q.x < 0 {
            continue;
        }
        let other = record_unpack(reuse_record(u32(q.y) * c.screen.x + u32(q.x)));
        if reuse_similar(own, other, c) {
            reuse_offer(&r, other, rand01(pixel, c.frame, c.draw_base + 3u * j + 2u), c);
        }
    }
    return r;
}
