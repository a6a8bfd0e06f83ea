// Tile view volumes and the bounding tests of the light-culling kernel.
// The CPU reference is crates/cull/src/{tiles,bounds}.rs; keep the arithmetic identical.
#include "common/view.wgsl"

struct TileVolume {
    // Left, right, bottom, top planes, normals inward: dot(p.xyz, x) + p.w >= 0 inside.
    planes: array<vec4<f32>, 4>,
    // NDC rectangle: left, right, bottom, top.
    ndc: vec4<f32>,
    near: f32,
    far: f32,
}

struct Aabb {
    lo: vec3<f32>,
    hi: vec3<f32>,
}

// Plane where clip-space row `row` equals `edge * clip.w`, built from the projection's rows
// (no cross products of nearly parallel corner rays).
fn clip_edge_plane(row: u32, edge: f32, sign: f32) -> vec4<f32> {
    let p = view.view_to_clip;
    let r = vec4<f32>(p[0][row], p[1][row], p[2][row], p[3][row]);
    let w = vec4<f32>(p[0][3], p[1][3], p[2][3], p[3][3]);
    let q = (r - w * edge) * sign;
    return q / length(q.xyz);
}

// NDC rectangle (l, r, b, t) of a tile, clipped to the screen (partial edge tiles).
fn tile_ndc(tile: vec2<u32>, tile_size: u32) -> vec4<f32> {
    let x0 = tile.x * tile_size;
    let y0 = tile.y * tile_size;
    let x1 = min(x0 + tile_size, view.screen.x);
    let y1 = min(y0 + tile_size, view.screen.y);
    let s = vec2<f32>(view.screen);
    return vec4<f32>(
        2.0 * f32(x0) / s.x - 1.0,
        2.0 * f32(x1) / s.x - 1.0,
        1.0 - 2.0 * f32(y1) / s.y,
        1.0 - 2.0 * f32(y0) / s.y,
    );
}

fn tile_volume(ndc: vec4<f32>, near: f32, far: f32) -> TileVolume {
    var v: TileVolume;
    v.planes[0] = clip_edge_plane(0u, ndc.x, 1.0);
    v.planes[1] = clip_edge_plane(0u, ndc.y, -1.0);
    v.planes[2] = clip_edge_plane(1u, ndc.z, 1.0);
    v.planes[3] = clip_edge_plane(1u, ndc.w, -1.0);
    v.ndc = ndc;
    v.near = near;
    v.far = far;
    return v;
}

fn sphere_vs_frustum(v: TileVolume, c: vec3<f32>, r: f32) -> bool {
    for (var i = 0u; i < 4u; i++) {
        if dot(v.planes[i].xyz, c) + v.planes[i].w < -r {
            return false;
        }
    }
    let dist = -c.z;
    return dist + r >= v.near && dist - r <= v.far;
}

fn volume_aabb(v: TileVolume) -> Aabb {
    var lo = vec3<f32>(3.4e38);
    var hi = vec3<f32>(-3.4e38);
    for (var k = 0u; k < 2u; k++) {
        let d = select(v.far, v.near, k == 0u);
        let c0 = view_point_at(vec2<f32>(v.ndc.x, v.ndc.z), d);
        let c1 = view_point_at(vec2<f32>(v.ndc.y, v.ndc.z), d);
        let c2 = view_point_at(vec2<f32>(v.ndc.x, v.ndc.w), d);
        let c3 = view_point_at(vec2<f32>(v.ndc.y, v.ndc.w), d);
        lo = min(lo, min(min(c0, c1), min(c2, c3)));
        hi = max(hi, max(max(c0, c1), max(c2, c3)));
    }
    return Aabb(lo, hi);
}

// Each axis is compared with r before squaring, and (e / r)^2 is summed, so coordinates
// beyond ~1.8e19 cannot overflow to infinity and silently cull.
fn sphere_vs_aabb(b: Aabb, c: vec3<f32>, r: f32) -> bool {
    let e = max(max(b.lo - c, c - b.hi), vec3<f32>(0.0));
    if e.x > r || e.y > r || e.z > r {
        return false;
    }
    let q = e / r;
    return dot(q, q) <= 1.0;
}

// Spot cone vs sphere ("Cull that cone", Wronski 2017); false when surely disjoint.
fn cone_vs_sphere(apex: vec3<f32>, axis: vec3<f32>, len: f32, cos_a: f32, sin_a: f32, center: vec3<f32>, radius: f32) -> bool {
    let v = center - apex;
    let t = dot(v, axis);
    // Scaled by its largest component before squaring: beyond ~1.8e19 the square would
    // overflow to inf and reject a sphere inside the cone (crates/cull/src/bounds.rs).
    let w = v - axis * t;
    let m = max(max(abs(w.x), abs(w.y)), abs(w.z));
    var perp = 0.0;
    if m > 0.0 {
        perp = length(w / m) * m;
    }
    let closest = cos_a * perp - t * sin_a;
    // `center - apex` loses up to an ulp of the larger coordinate (1 m at 1e7 m from the
    // eye, far more than a narrow cone's width there): widen the sphere by a few of those.
    let slack = 4.0 * 1.1920929e-7 * (max(max(abs(center.x), abs(center.y)), abs(center.z)) + max(max(abs(apex.x), abs(apex.y)), abs(apex.z)));
    let r = radius + slack;
    return !(closest > r || t > r + len || t < -r);
}
