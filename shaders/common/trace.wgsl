// Shadow rays through a BVH in a compute kernel: the traced reference's visibility (issue
// 30). CPU twin: tiledlight_cull::trace (FlatBvh::occluded: the same f32 operations in the
// same order; its module doc numbers the steps); tests/tests/traced.rs compares them per ray
// and both with the f64 ray cast (tiledlight_cull::raycast).
//
// The including file declares `trace_nodes: array<TraceNode>` and `trace_tris:
// array<vec4<f32>>` (three a triangle: its vertices, the first one's w the mask slot as
// bits), and with TRACE_MASKS `trace_uvs: array<vec2<f32>>` (three a triangle, after the
// texture transform), `trace_mask_slots: array<vec4<u32>>` (width, height, wrap, first word)
// and `trace_mask_bits: array<u32>` (crates/gpu/src/bvh.rs).

#include "common/trace_types.wgsl"

struct TraceRay {
    o: vec3<f32>,
    inv_d: vec3<f32>,
    // Ray-space axes x, y, z (z: the direction's largest component).
    k: vec3<u32>,
    // The shear (Sx, Sy, Sz).
    s: vec3<f32>,
    t_lo: f32,
    t_hi: f32,
    valid: bool,
}

// Rays cast by this invocation (the kernel sums them for the frame's statistics).
var<private> trace_ray_count: u32 = 0u;
// Set when a traversal ended without reaching either of its ends (a hit, or an empty
// stack): a driver cut the loop short. llvmpipe stops a shader's loops after 65,535
// iterations in all, counted per group of lanes and shared by every loop of the shader
// (Mesa's LP_MAX_TGSI_LOOP_ITERATIONS): a pixel's thousand lights times their traversals
// pass that, and the rays it would still cast would silently see no occluder.
var<private> trace_cut: bool = false;

fn trace_inv(c: f32) -> f32 {
    // A zero component: a huge finite reciprocal, so (lo - o) * inv is 0, never NaN.
    return select(1.0 / c, 1e30, c == 0.0);
}

// The segment p0 -> p1 with eps world units cut off each end.
fn trace_ray(p0: vec3<f32>, p1: vec3<f32>, eps: f32) -> TraceRay {
    var r: TraceRay;
    let d = p1 - p0;
    let len = length(d);
    let e = max(eps, 0.0);
    r.valid = len > 2.0 * e;
    if !r.valid {
        return r;
    }
    let cut = e / len;
    let a = abs(d);
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z {
        kz = 0u;
    } else if a.y >= a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kz + 2u) % 3u;
    if d[kz] < 0.0 {
        let t = kx;
        kx = ky;
        ky = t;
    }
    r.k = vec3<u32>(kx, ky, kz);
    r.s = vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    r.o = p0;
    r.inv_d = vec3<f32>(trace_inv(d.x), trace_inv(d.y), trace_inv(d.z));
    r.t_lo = cut;
    r.t_hi = 1.0 - cut;
    return r;
}

fn trace_enters(r: TraceRay, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    let a = (lo - r.o) * r.inv_d;
    let b = (hi - r.o) * r.inv_d;
    let mn = min(a, b);
    let mx = max(a, b);
    let near = max(max(max(mn.x, mn.y), mn.z), r.t_lo);
    let far = min(min(min(mx.x, mx.y), mx.z), r.t_hi) * TRACE_FAR_GROW;
    return near <= far;
}

// Woop, Benthin and Wald's watertight test: (hit, u, v) with u, v the weights of the second
// and third vertices (tiledlight_cull::trace::watertight).
fn trace_watertight(r: TraceRay, t: u32) -> vec3<f32> {
    let a = trace_tris[3u * t].xyz - r.o;
    let b = trace_tris[3u * t + 1u].xyz - r.o;
    let c = trace_tris[3u * t + 2u].xyz - r.o;
    let ax = a[r.k.x] - r.s.x * a[r.k.z];
    let ay = a[r.k.y] - r.s.y * a[r.k.z];
    let bx = b[r.k.x] - r.s.x * b[r.k.z];
    let by = b[r.k.y] - r.s.y * b[r.k.z];
    let cx = c[r.k.x] - r.s.x * c[r.k.z];
    let cy = c[r.k.y] - r.s.y * c[r.k.z];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let miss = vec3<f32>(0.0);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return miss;
    }
    let det = u + v + w;
    // Zero, or not finite (inf - inf, NaN): no hit.
    if det == 0.0 || !(abs(det) <= 3.4e38) {
        return miss;
    }
    let tt = u * (r.s.z * a[r.k.z]) + v * (r.s.z * b[r.k.z]) + w * (r.s.z * c[r.k.z]);
    var inside: bool;
    if det > 0.0 {
        inside = tt > r.t_lo * det && tt < r.t_hi * det;
    } else {
        inside = tt < r.t_lo * det && tt > r.t_hi * det;
    }
    if !inside {
        return miss;
    }
    return vec3<f32>(1.0, v / det, w / det);
}

#ifdef TRACE_MASKS
// The texel of coordinate c on an axis of n texels (tiledlight_cull::trace::wrap_texel):
// 0 repeat, 1 clamp, 2 mirrored repeat.
fn trace_mask_texel(c: f32, n: u32, mode: u32) -> u32 {
    let f = floor(c * f32(n));
    // NaN and far-away coordinates land in range.
    var i = 0i;
    if abs(f) <= 1e9 {
        i = i32(f);
    }
    let ni = i32(n);
    if mode == 1u {
        return u32(clamp(i, 0i, ni - 1i));
    }
    if mode == 2u {
        var m = i % (2i * ni);
        if m < 0i {
            m += 2i * ni;
        }
        return u32(select(2i * ni - 1i - m, m, m < ni));
    }
    var m = i % ni;
    if m < 0i {
        m += ni;
    }
    return u32(m);
}

// Whether triangle t blocks at barycentrics (u, v) of its second and third vertices.
fn trace_blocks(t: u32, u: f32, v: f32) -> bool {
    let slot = bitcast<u32>(trace_tris[3u * t].w);
    if slot == TRACE_NO_MASK {
        return true;
    }
    let m = trace_mask_slots[slot];
    if m.x == 0u || m.y == 0u {
        return false;
    }
    let uv = trace_uvs[3u * t] * (1.0 - u - v) + trace_uvs[3u * t + 1u] * u + trace_uvs[3u * t + 2u] * v;
    let x = trace_mask_texel(uv.x, m.x, m.z & 3u);
    let y = trace_mask_texel(uv.y, m.y, (m.z >> 2u) & 3u);
    let i = y * m.x + x;
    return ((trace_mask_bits[m.w + i / 32u] >> (i % 32u)) & 1u) == 1u;
}
#else
fn trace_blocks(t: u32, u: f32, v: f32) -> bool {
    return true;
}
#endif

// Whether a leaf's triangles first .. first + count block the ray (the first hit that is
// not masked away ends the search: a shadow ray needs no nearest hit).
fn trace_leaf_blocks(r: TraceRay, first: u32, count: u32) -> bool {
    for (var t = first; t < first + count; t++) {
        let h = trace_watertight(r, t);
        if h.x != 0.0 && trace_blocks(t, h.y, h.z) {
            return true;
        }
    }
    return false;
}

// Whether some triangle blocks the segment p0 -> p1 (eps off each end).
fn trace_occluded(p0: vec3<f32>, p1: vec3<f32>, eps: f32) -> bool {
    let r = trace_ray(p0, p1, eps);
    if !r.valid || arrayLength(&trace_nodes) == 0u {
        return false;
    }
    trace_ray_count += 1u;
    var stack: array<u32, TRACE_STACK>;
    var len = 0u;
    var node = 0u;
    // The stack ran empty: the only way out of the loop but a hit (trace_cut).
    var done = false;
    loop {
        let n = trace_nodes[node];
        var next_a = TRACE_NO_CHILD;
        var next_b = TRACE_NO_CHILD;
        // Each child: an inner node to visit next, or a leaf tested on the spot.
        if n.a_link != TRACE_NO_CHILD && trace_enters(r, n.a_lo, n.a_hi) {
            if n.a_count == 0u {
                next_a = n.a_link;
            } else if trace_leaf_blocks(r, n.a_link, n.a_count) {
                return true;
            }
        }
        if n.b_link != TRACE_NO_CHILD && trace_enters(r, n.b_lo, n.b_hi) {
            if n.b_count == 0u {
                next_b = n.b_link;
            } else if trace_leaf_blocks(r, n.b_link, n.b_count) {
                return true;
            }
        }
        if next_a != TRACE_NO_CHILD && next_b != TRACE_NO_CHILD {
            stack[len] = next_b;
            len += 1u;
            node = next_a;
        } else if next_a != TRACE_NO_CHILD {
            node = next_a;
        } else if next_b != TRACE_NO_CHILD {
            node = next_b;
        } else {
            if len == 0u {
                done = true;
                break;
            }
            len -= 1u;
            node = stack[len];
        }
    }
    if !done {
        trace_cut = true;
    }
    return false;
}
