//! Bounding tests between a light's volume and a tile's view volume, exactly as the GPU
//! culling kernel runs them (`shaders/common/cull_tests.wgsl`): sphere vs the tile's side
//! planes and depth range, sphere vs the tile's view-space AABB, and a spot cone vs the
//! tile's bounding sphere. Every test is conservative: it may keep a light that lights no
//! pixel (a false positive), never drop one that does. Depends on glam only.

use glam::{Vec3, Vec4};

use crate::tiles::TileFrustum;

/// Sphere (view-space centre `c`, radius `r`) vs the four side planes and the depth range.
pub fn sphere_vs_frustum(f: &TileFrustum, c: Vec3, r: f32) -> bool {
    for p in f.planes {
        if p.truncate().dot(c) + p.w < -r {
            return false;
        }
    }
    let dist = -c.z;
    dist + r >= f.near && dist - r <= f.far
}

/// Sphere vs an axis-aligned box `[lo, hi]`. Each axis is checked against `r` before any
/// squaring and the squares are taken of `e / r`, so huge coordinates (beyond ~1.8e19,
/// where squaring overflows to infinity and silently culls) cannot break it.
pub fn sphere_vs_aabb(lo: Vec3, hi: Vec3, c: Vec3, r: f32) -> bool {
    let e = (lo - c).max(c - hi).max(Vec3::ZERO);
    if e.x > r || e.y > r || e.z > r {
        return false;
    }
    let q = e / r;
    q.dot(q) <= 1.0
}

/// A spot cone (apex, unit axis, length, cos and sin of the half-angle) vs a sphere:
/// false when the sphere is surely outside the cone ("Cull that cone", Wronski 2017).
/// The distance from the axis uses the perpendicular component directly instead of
/// `sqrt(|v|^2 - t^2)`, which cancels catastrophically far from the apex.
pub fn cone_vs_sphere(apex: Vec3, axis: Vec3, len: f32, cos_a: f32, sin_a: f32, center: Vec3, radius: f32) -> bool {
    let v = center - apex;
    let t = v.dot(axis);
    // Scaled by its largest component before squaring: beyond ~1.8e19 the square overflows
    // to inf and would reject a sphere that is inside the cone.
    let w = v - axis * t;
    let m = w.abs().max_element();
    let perp = if m > 0.0 { (w / m).length() * m } else { 0.0 };
    let closest = cos_a * perp - t * sin_a;
    // `center - apex` loses up to an ulp of the larger coordinate (1 m at 1e7 m from the
    // eye, far more than a narrow cone's width there): widen the sphere by a few of those.
    let radius = radius + 4.0 * f32::EPSILON * (center.abs().max_element() + apex.abs().max_element());
    !(closest > radius || t > radius + len || t < -radius)
}

/// The sphere around an AABB (centre, radius), the tile volume's bound for the cone test.
pub fn aabb_sphere(lo: Vec3, hi: Vec3) -> (Vec3, f32) {
    // The radius reaches the farthest corner from the rounded centre, not half the
    // diagonal: far from the origin the centre rounds off the middle by up to half an ulp
    // of |lo + hi|, which can exceed the box's half-size (a 3 m deep tile 1e7 m away).
    let c = (lo + hi) * 0.5;
    (c, (hi - c).max(c - lo).length())
}

/// Transforms a world-space point by a view matrix given as columns, in the same order
/// of operations as WGSL's `(view * vec4(p, 1.0)).xyz`.
pub fn to_view(view: &glam::Mat4, p: Vec3) -> Vec3 {
    (*view * Vec4::from((p, 1.0))).truncate()
}
