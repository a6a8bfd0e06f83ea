// The stochastic method's light sampler (issue 48): the random numbers, the weighted
// reservoir and its merge, as `tiledlight_cull::stochastic` computes them on the CPU (its
// twin; `tests/tests/stochastic_twin.rs` compares the two). Resampled importance sampling
// (Talbot et al. 2005) into a reservoir (Chao 1982), as ReSTIR DI starts a pixel.
// Include-only; no binding of its own.

// One step of the PCG hash (Jarzynski and Olano, JCGT 2020): the CPU's `pcg_hash`.
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A uniform number in [0, 1) for draw `draw` of `pixel` in `frame`: 24 bits of the hash,
// exact in f32, so the CPU's `rand01` gives the same number.
fn rand01(pixel: u32, frame: u32, draw: u32) -> f32 {
    let h = pcg_hash(pixel ^ pcg_hash(frame ^ pcg_hash(draw)));
    return f32(h >> 8u) / 16777216.0;
}

// Near draw `k` of `m` (at most `count`) over a list of `count` lights with `u` in [0, 1):
// one entry of stratum k (entries k count / m to (k + 1) count / m, no 64-bit product) and
// the stratum's size (tiledlight_cull::stochastic::near_draw).
fn near_draw(k: u32, m: u32, count: u32, u: f32) -> vec2<u32> {
    let q = count / m;
    let r = count % m;
    let first = k * q + k * r / m;
    let size = (k + 1u) * q + (k + 1u) * r / m - first;
    return vec2<u32>(first + min(u32(u * f32(size)), size - 1u), size);
}

// The number pick j of `rays` decides a candidate with, where pick 0 used `u` (from
// rand01): u shifted by j / rays and wrapped, in 24-bit integers
// (tiledlight_cull::stochastic::ray_number, bit for bit).
fn ray_number(u: f32, j: u32, rays: u32) -> f32 {
    let i = u32(u * 16777216.0);
    let step = 16777216u / rays;
    return f32((i + j * step) & 0xFFFFFFu) / 16777216.0;
}

// One light kept of the candidates seen: its index, its target p_hat, the sum of the
// candidates' weights and their count.
struct Reservoir {
    light: u32,
    p_hat: f32,
    w_sum: f32,
    m: u32,
}

fn reservoir_empty() -> Reservoir {
    return Reservoir(0u, 0.0, 0.0, 0u);
}

// Offers candidate `light` of weight `w` (p_hat / q) and target `p_hat`; `u` in [0, 1)
// decides whether it replaces the kept one (probability w / w_sum).
fn reservoir_update(r: ptr<function, Reservoir>, light: u32, w: f32, p_hat: f32, u: f32) {
    (*r).w_sum += w;
    (*r).m += 1u;
    if w > 0.0 && u * (*r).w_sum < w {
        (*r).light = light;
        (*r).p_hat = p_hat;
    }
}

// Merges `other` (a reservoir of the same pixel) in: one candidate of weight its w_sum,
// the counts added.
fn reservoir_merge(r: ptr<function, Reservoir>, other: Reservoir, u: f32) {
    let m = (*r).m;
    reservoir_update(r, other.light, other.w_sum, other.p_hat, u);
    (*r).m = m + other.m;
}

// The contribution weight W = w_sum / (M p_hat(y)); 0 when nothing was kept.
fn reservoir_weight(r: Reservoir) -> f32 {
    if r.m == 0u || r.p_hat <= 0.0 {
        return 0.0;
    }
    return r.w_sum / (f32(r.m) * r.p_hat);
}
