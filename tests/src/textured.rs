//! Independent CPU answers for textured, transformed geometry (`transformed_materials.rs`):
//! a normal-mapped quad mesh with explicit tangents, a CPU ray cast of pixel centres
//! against transformed quads, and the world tangent frame of a normal-mapped instance
//! computed from its model matrix the way the glTF specification defines it (tangents
//! transform as directions, normals by the inverse transpose, the bitangent is the
//! transformed object-space bitangent), not by the shaders' formula (`cross(n, t) * w *
//! det_sign`), so a shader or upload that drops a transform or a sign differs from it.

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4, Vec4Swizzles};
use tiledlight_cull::tiles::{pixel_to_ndc_x, pixel_to_ndc_y};
use tiledlight_cull::Camera;
use tiledlight_scene::{Instance, Mesh};

/// The object-space tangent of [`mapped_quad`]: +x (where u grows), bitangent sign +1
/// (glTF: `bitangent = cross(normal, tangent) * w` = +y, up the image).
pub const QUAD_TANGENT: Vec4 = Vec4::new(1.0, 0.0, 0.0, 1.0);

/// A 2 x 2 quad in the XY plane facing +Z, uv (0, 0) at its top-left corner (-1, 1) and
/// (1, 1) at its bottom-right ([`quad_uv`]), with tangents ([`QUAD_TANGENT`]) and set 1
/// equal to set 0. `mirrored`: the winding reversed, as the glTF loader stores a mesh drawn
/// by a mirroring (negative determinant) instance so that its front faces stay
/// counter-clockwise in world space.
pub fn mapped_quad(mirrored: bool) -> Mesh {
    let corners = [[-1.0f32, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let uvs: Vec<[f32; 2]> = corners.iter().map(|c| quad_uv(Vec2::from(*c)).to_array()).collect();
    Mesh {
        name: if mirrored { "mapped quad (mirrored)" } else { "mapped quad" }.into(),
        positions: corners.iter().map(|c| [c[0], c[1], 0.0]).collect(),
        normals: vec![[0.0, 0.0, 1.0]; 4],
        uvs1: uvs.clone(),
        uvs,
        tangents: vec![QUAD_TANGENT.to_array(); 4],
        indices: if mirrored { vec![0, 2, 1, 0, 3, 2] } else { vec![0, 1, 2, 0, 2, 3] },
    }
}

/// Texture coordinates of [`mapped_quad`] at object point (x, y): u along +x, v down.
pub fn quad_uv(p: Vec2) -> Vec2 {
    Vec2::new((p.x + 1.0) * 0.5, (1.0 - p.y) * 0.5)
}

/// The world direction of the ray through window point (`sx`, `sy`) (pixels) of a `w` x
/// `h` view of `camera`, from its eye.
pub fn pixel_ray(camera: &Camera, (w, h): (u32, u32), sx: f32, sy: f32) -> Vec3 {
    let dir_view = camera.view_point_at(pixel_to_ndc_x(sx, w), pixel_to_ndc_y(sy, h), 1.0);
    (camera.view().inverse() * dir_view.extend(0.0)).xyz().normalize()
}

/// Where a ray meets one of [`mapped_quad`]'s instances.
#[derive(Clone, Copy, Debug)]
pub struct QuadHit {
    /// Index into the instances.
    pub instance: usize,
    /// Ray parameter (distance along the unit direction).
    pub t: f32,
    /// Object-space point on the quad (z = 0).
    pub local: Vec2,
}

/// The nearest front face among `instances` (each drawing a quad of [`mapped_quad`]) that the
/// ray `o + t d` meets; back faces are culled (single-sided), a face being front where the
/// ray runs against the instance's world normal (the object normal +z through the inverse
/// transpose).
pub fn cast_quads(instances: &[Instance], o: Vec3, d: Vec3) -> Option<QuadHit> {
    let mut best: Option<QuadHit> = None;
    for (k, inst) in instances.iter().enumerate() {
        let inv = inst.transform.inverse();
        let lo = (inv * o.extend(1.0)).xyz();
        let ld = (inv * d.extend(0.0)).xyz();
        if ld.z.abs() < 1e-9 {
            continue;
        }
        let s = -lo.z / ld.z;
        let l = lo + ld * s;
        let n = world_normal(inst.transform, Vec3::Z);
        if s <= 0.0 || l.x.abs() > 1.0 || l.y.abs() > 1.0 || n.dot(d) >= 0.0 {
            continue;
        }
        // The parameter is the same in both spaces (the direction is transformed with it).
        if best.is_none_or(|b| s < b.t) {
            best = Some(QuadHit { instance: k, t: s, local: l.truncate() });
        }
    }
    best
}

/// A normal through `m`: by the inverse transpose of its 3x3 part, normalised.
pub fn world_normal(m: Mat4, n: Vec3) -> Vec3 {
    (Mat3::from_mat4(m).inverse().transpose() * n).normalize()
}

/// The world tangent frame (tangent, bitangent, normal; orthonormal) of an instance with
/// model matrix `m` at a point whose object-space normal is `n` and tangent `t` (bitangent
/// sign in w), as the glTF specification defines it: the tangent is a direction on the
/// surface (`m t`), the normal the inverse transpose's, and the bitangent the object-space
/// bitangent `w cross(n, t)` carried by `m` like the tangent, then made orthogonal to the
/// other two (Gram-Schmidt). A mirroring `m` turns that bitangent to the other side of
/// `cross(n', t')` by itself: no determinant is looked at.
pub fn tangent_frame(m: Mat4, n: Vec3, t: Vec4) -> (Vec3, Vec3, Vec3) {
    let m3 = Mat3::from_mat4(m);
    let nw = world_normal(m, n);
    let tw = m3 * t.truncate();
    let tw = (tw - nw * nw.dot(tw)).normalize();
    let bw = m3 * (n.cross(t.truncate()) * t.w);
    let bw = (bw - nw * nw.dot(bw) - tw * tw.dot(bw)).normalize();
    (tw, bw, nw)
}

/// The world shading normal of a tangent-space normal-map texel (linear RGB in [0, 1],
/// glTF's convention, scale 1) in the frame `(t, b, n)` of [`tangent_frame`].
pub fn mapped_normal((t, b, n): (Vec3, Vec3, Vec3), texel: Vec3) -> Vec3 {
    let m = texel * 2.0 - Vec3::ONE;
    (t * m.x + b * m.y + n * m.z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without a mirror the frame is right-handed (b = n x t), with one left-handed; a
    /// rotation carries the object frame rigidly; a non-uniform scale tilts the normal off
    /// `m n` (the inverse transpose keeps it perpendicular to the surface).
    #[test]
    fn the_frame_follows_rotation_scale_and_mirror() {
        let r = Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(-0.4);
        let (t, b, n) = tangent_frame(r, Vec3::Z, QUAD_TANGENT);
        assert!((t - r.transform_vector3(Vec3::X)).length() < 1e-6);
        assert!((b - r.transform_vector3(Vec3::Y)).length() < 1e-6);
        assert!((n - r.transform_vector3(Vec3::Z)).length() < 1e-6);
        let mirror = r * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let (t, b, n) = tangent_frame(mirror, Vec3::Z, QUAD_TANGENT);
        assert!((n.cross(t) + b).length() < 1e-6, "mirrored: b = -(n x t)");
        let s = Mat4::from_scale(Vec3::new(1.0, 3.0, 1.0)) * r;
        let (t, b, n) = tangent_frame(s, Vec3::Z, QUAD_TANGENT);
        // n is perpendicular to the transformed surface's edges.
        for e in [Vec3::X, Vec3::Y] {
            assert!(n.dot(s.transform_vector3(e)).abs() < 1e-5);
        }
        assert!((n - s.transform_vector3(Vec3::Z).normalize()).length() > 0.1, "m n is not the normal");
        assert!((n.cross(t) - b).length() < 1e-5);
    }
}
