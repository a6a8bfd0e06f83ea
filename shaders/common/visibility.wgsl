// The visibility buffer's reconstruction (issue 28): perspective-correct barycentrics of a
// triangle at a pixel centre, from its three clip-space vertices, with their one-pixel
// screen derivatives, for the material pass's interpolation and textureSampleGrad.
// CPU twin: tiledlight_cull::visibility::barycentrics (same operations in the same order;
// tests/tests/visibility.rs compares them). Homogeneous form (Olano and Greer 1997) built
// from the edges at vertex 0, so no vertex is divided by its w (a triangle crossing the
// eye plane needs no clipping) and a small triangle far away keeps its precision.

// A neighbour's weight sum is kept at least this share of the pixel's, of its sign
// (tiledlight_cull::visibility::NEIGHBOUR_SUM_FLOOR).
const VIS_NEIGHBOUR_SUM_FLOOR: f32 = 1e-6;

struct VisBary {
    // Weights of the three vertices at the pixel centre (sum 1).
    lambda: vec3<f32>,
    // The weights one pixel to the right and one pixel down, minus `lambda`.
    ddx: vec3<f32>,
    ddy: vec3<f32>,
    // False where the pixel's ray lies in the triangle's plane (nothing to shade).
    valid: bool,
}

// Unnormalised weights at q = (x, y, 1) (a point) or (dx, dy, 0) (a step): rows n (their
// sum), a and b (weights 1 and 2); weight 0 is the sum minus the other two.
fn vis_weights(n: vec3<f32>, a: vec3<f32>, b: vec3<f32>, q: vec3<f32>) -> vec3<f32> {
    let s = dot(n, q);
    let u1 = dot(a, q);
    let u2 = dot(b, q);
    return vec3<f32>(s - u1 - u2, u1, u2);
}

// The weights' change to a neighbour whose unnormalised weights are u + d (d's sum given
// on its own): (d sum - u sum(d)) / (sum next), components summing to zero, `next` kept
// at least VIS_NEIGHBOUR_SUM_FLOOR of the sum and of its sign so it stays finite.
fn vis_neighbour_step(u: vec3<f32>, sum: f32, d: vec3<f32>, d_sum: f32) -> vec3<f32> {
    let floor = abs(sum) * VIS_NEIGHBOUR_SUM_FLOOR;
    let next = max((sum + d_sum) * sign(sum), floor) * sign(sum);
    return (d * sum - u * d_sum) / (sum * next);
}

// Barycentrics of the triangle (c0, c1, c2) (clip space) at NDC `ndc` on a target of
// `size` pixels.
fn vis_barycentrics(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, ndc: vec2<f32>, size: vec2<f32>) -> VisBary {
    let v0 = c0.xyw;
    let e1 = c1.xyw - v0;
    let e2 = c2.xyw - v0;
    let n = cross(e1, e2);
    let a = cross(e2, v0);
    let b = cross(v0, e1);
    let q = vec3<f32>(ndc, 1.0);
    let u = vis_weights(n, a, b, q);
    let sum = dot(n, q);
    var r: VisBary;
    r.valid = sum != 0.0;
    if !r.valid {
        return r;
    }
    r.lambda = u / sum;
    let qx = vec3<f32>(2.0 / size.x, 0.0, 0.0);
    let qy = vec3<f32>(0.0, -2.0 / size.y, 0.0);
    r.ddx = vis_neighbour_step(u, sum, vis_weights(n, a, b, qx), dot(n, qx));
    r.ddy = vis_neighbour_step(u, sum, vis_weights(n, a, b, qy), dot(n, qy));
    return r;
}
