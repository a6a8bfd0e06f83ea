// Unit vectors as points of the square [-1, 1]^2 (the octahedral map, Meyer et al. 2010;
// CPU twin tiledlight_cull::octahedral): the G-buffer texel's normal and the stochastic
// method's reservoir records (pack2x16snorm of the point). Include-only; no binding.

// The lower half's fold (its own inverse): (1 - |v|, 1 - |u|) with the signs of (u, v).
fn oct_fold(p: vec2<f32>) -> vec2<f32> {
    let sign = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(p.yx)) * sign;
}

// The point of the square [-1, 1]^2 a direction maps to (+Z's, the origin, for a zero one).
fn oct_map(n: vec3<f32>) -> vec2<f32> {
    let a = abs(n);
    let m = max(a.x, max(a.y, a.z));
    if !(m > 0.0) {
        return vec2<f32>(0.0);
    }
    let s = n / m;
    let p = s.xy / (abs(s.x) + abs(s.y) + abs(s.z));
    return select(p, oct_fold(p), s.z < 0.0);
}

fn oct_unmap(p: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - abs(p.x) - abs(p.y);
    let xy = select(p, oct_fold(p), z < 0.0);
    return normalize(vec3<f32>(xy, z));
}
