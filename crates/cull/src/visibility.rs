//! The visibility buffer's CPU twin (the third method, issue 28): what its raster pass
//! writes per pixel and how its material pass rebuilds a surface from it. The WGSL of the
//! material pass computes the same arithmetic in f32; tests compare it with this module's
//! f32 functions, and those with an independent f64 reference here.
//!
//! 1. **IDs** ([`IdLayout`]): one `R32Uint` per sample holds `(instance << triangle_bits) |
//!    triangle`, the triangle index within its instance's mesh. The split is chosen per
//!    scene from its instance count and its largest mesh; a scene whose IDs need more than
//!    32 bits is refused with an error that says how many it needs (never a wrong image).
//!    [`NO_TRIANGLE`] (all ones, the clear value) marks sky; no valid ID equals it.
//! 2. **Barycentrics** ([`barycentrics`]): perspective-correct barycentrics at a pixel
//!    centre from the triangle's three clip-space vertices, in homogeneous form (Olano and
//!    Greer 1997): with `M` the 3x3 of the vertices' clip `(x, y, w)` as columns, the pixel's
//!    barycentrics are proportional to `adj(M) (ndc_x, ndc_y, 1)`. No vertex is divided by
//!    its `w`, so a triangle crossing the eye plane (a vertex with `w <= 0`, which the
//!    hardware clips) needs no clipping: the formula is that of the visible part. The
//!    adjugate is formed from the edges from vertex 0 (its rows `e1 x e2`, `e2 x c0`,
//!    `c0 x e1`), not from the vertices: from the vertices, a sub-pixel triangle's rows
//!    cancel to nothing in f32. Measured by `tests/visibility.rs` (its five shapes, seed 9):
//!    from the vertices, 31% of the weights it checks were within f32 rounding of
//!    undecided (most of them sub-pixel triangles); from the edges 1.3% (1,062 of 80,000:
//!    slivers and triangles seen edge-on, which hardware rarely covers a pixel centre of).
//! 3. **Screen derivatives** ([`Barycentrics::ddx`], `ddy`): the barycentrics one pixel to
//!    the right and one pixel down minus those at the pixel, exactly (the numerator is
//!    linear in the NDC position), so the UV gradients fed to `textureSampleGrad` are the
//!    finite differences a 2x2 quad's fine derivatives take on the same triangle. Where a
//!    neighbour's ray misses the triangle's plane they stay finite and very large
//!    ([`NEIGHBOUR_SUM_FLOOR`]).
//! 4. **Mip level** ([`mip_level`]): the level a sampler picks from those gradients,
//!    `log2` of the longer gradient in texels (isotropic filtering, as the hardware path's
//!    samplers), for the test that the material pass chooses the hardware's level.
//!
//! Depends on glam and [`crate::error`] only.

use glam::{DVec2, DVec3, DVec4, Vec2, Vec3, Vec4};

use crate::error::CullError;

/// The ID of a sample no triangle covers (the ID target's clear value).
pub const NO_TRIANGLE: u32 = u32::MAX;

/// How a visibility-buffer ID splits into instance and triangle bits (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IdLayout {
    /// Low bits holding the triangle index within its instance's mesh.
    pub triangle_bits: u32,
    /// Instances the scene has.
    pub instances: u32,
    /// Triangles of the largest mesh an instance draws.
    pub max_triangles: u32,
}

/// Bits needed to hold the indices `0..n` (0 for n <= 1).
fn index_bits(n: u32) -> u32 {
    if n <= 1 {
        0
    } else {
        32 - (n - 1).leading_zeros()
    }
}

impl IdLayout {
    /// The layout of a scene with `instances` instances whose largest mesh has
    /// `max_triangles` triangles; an error naming both counts and the bits they need when
    /// they do not fit 32 bits with [`NO_TRIANGLE`] kept free.
    pub fn for_scene(instances: u32, max_triangles: u32) -> Result<Self, CullError> {
        if instances == 0 || max_triangles == 0 {
            return Err(CullError::InvalidSize(format!(
                "a visibility buffer needs geometry: {instances} instances, {max_triangles} triangles in the largest mesh"
            )));
        }
        let triangle_bits = index_bits(max_triangles);
        let instance_bits = index_bits(instances);
        let layout = Self { triangle_bits, instances, max_triangles };
        if triangle_bits + instance_bits > 32 || layout.pack(instances - 1, max_triangles - 1) == NO_TRIANGLE {
            return Err(CullError::InvalidSize(format!(
                "the visibility buffer's 32-bit IDs cannot name {instances} instances ({instance_bits} bits) with up to \
                 {max_triangles} triangles each ({triangle_bits} bits): {} bits needed, at most 32 with one ID kept for \
                 sky; split the largest meshes or use fewer instances",
                triangle_bits + instance_bits
            )));
        }
        Ok(layout)
    }

    /// The ID of triangle `triangle` of instance `instance`.
    pub fn pack(&self, instance: u32, triangle: u32) -> u32 {
        if self.triangle_bits == 32 {
            return triangle;
        }
        (instance << self.triangle_bits) | triangle
    }

    /// The (instance, triangle) of an ID (None for [`NO_TRIANGLE`] or an ID past the
    /// scene's instances or its largest mesh).
    pub fn unpack(&self, id: u32) -> Option<(u32, u32)> {
        if id == NO_TRIANGLE {
            return None;
        }
        let (instance, triangle) = if self.triangle_bits == 32 {
            (0, id)
        } else {
            (id >> self.triangle_bits, id & ((1u32 << self.triangle_bits) - 1))
        };
        (instance < self.instances && triangle < self.max_triangles).then_some((instance, triangle))
    }
}

/// A pixel centre's NDC position: x right, y up, both in [-1, 1] across the target.
pub fn pixel_ndc(pixel: (u32, u32), size: (u32, u32)) -> Vec2 {
    Vec2::new((pixel.0 as f32 + 0.5) / size.0 as f32 * 2.0 - 1.0, 1.0 - (pixel.1 as f32 + 0.5) / size.1 as f32 * 2.0)
}

/// Perspective-correct barycentrics at a pixel and their screen derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Barycentrics {
    /// Weights of the three vertices at the pixel centre (sum 1).
    pub lambda: Vec3,
    /// The weights one pixel to the right minus those at the pixel.
    pub ddx: Vec3,
    /// The weights one pixel down minus those at the pixel.
    pub ddy: Vec3,
}

impl Barycentrics {
    /// An attribute with values `a` at the three vertices, at the pixel and its two
    /// screen derivatives (value, d/dx, d/dy).
    pub fn interpolate<T>(&self, a: [T; 3]) -> (T, T, T)
    where
        T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
    {
        let at = |w: Vec3| a[0] * w.x + a[1] * w.y + a[2] * w.z;
        (at(self.lambda), at(self.ddx), at(self.ddy))
    }
}

/// The barycentrics of the triangle with clip-space vertices `clip` at the pixel centre
/// whose NDC position is `ndc`, on a target of `size` pixels (module doc, steps 2-3), in
/// f32 as the material pass computes them. None when the pixel's ray misses the
/// triangle's plane (a degenerate triangle, or one seen exactly edge-on).
pub fn barycentrics(clip: [Vec4; 3], ndc: Vec2, size: (u32, u32)) -> Option<Barycentrics> {
    let [c0, c1, c2] = clip.map(|c| Vec3::new(c.x, c.y, c.w));
    // adj(M)'s rows relative to vertex 0: the sum's row is the edges' cross product and
    // the other two pair an edge with vertex 0, so no row is a difference of two large
    // nearly equal products (a small triangle far away keeps its precision).
    let e1 = c1 - c0;
    let e2 = c2 - c0;
    let n = e1.cross(e2);
    let a = e2.cross(c0);
    let b = c0.cross(e1);
    // Unnormalised weights at p = (x, y, 1) (or a step (dx, dy, 0)), linear in p.
    let at = |p: Vec3| {
        let (s, u1, u2) = (n.dot(p), a.dot(p), b.dot(p));
        Vec3::new(s - u1 - u2, u1, u2)
    };
    let u = at(ndc.extend(1.0));
    let sum = n.dot(ndc.extend(1.0));
    if sum == 0.0 || !sum.is_finite() {
        return None;
    }
    let lambda = u / sum;
    // One pixel in NDC: 2 / width to the right, -2 / height down.
    // Each step's weights with its own sum, `n . step` (the sum of its three weights
    // would cancel: they are large and nearly opposite where a pixel is large).
    let step = |q: Vec3| neighbour_step(u, sum, at(q), n.dot(q));
    let ddx = step(Vec3::new(2.0 / size.0 as f32, 0.0, 0.0));
    let ddy = step(Vec3::new(0.0, -2.0 / size.1 as f32, 0.0));
    let b = Barycentrics { lambda, ddx, ddy };
    (b.lambda.is_finite() && b.ddx.is_finite() && b.ddy.is_finite()).then_some(b)
}

/// The smallest share of the pixel's weight sum a neighbour's may have before its
/// weights count as unbounded: its sum is kept at least this share, so derivatives stay
/// finite where the neighbour's ray misses the triangle's plane.
pub const NEIGHBOUR_SUM_FLOOR: f32 = 1e-6;

/// The weights' change to a neighbour pixel whose unnormalised weights are `u + d`
/// (`d_sum` the sum of `d`, computed on its own):
/// `(u + d) / s' - u / sum` written as `(d sum - u sum(d)) / (sum s')`, whose three
/// components sum to zero however large they get. `s'` is the neighbour's sum, kept at
/// least [`NEIGHBOUR_SUM_FLOOR`] times the pixel's and of its sign: where the neighbour's
/// ray meets the triangle's plane behind the eye or not at all (the plane seen edge-on
/// between the two pixels; a quad's helper lane there extrapolates to infinity in
/// hardware too) the derivative stays finite and very large, so a sampler picks its
/// coarsest level rather than NaN.
fn neighbour_step(u: Vec3, sum: f32, d: Vec3, d_sum: f32) -> Vec3 {
    let floor = sum.abs() * NEIGHBOUR_SUM_FLOOR;
    let next = (sum + d_sum) * sum.signum();
    let next = next.max(floor) * sum.signum();
    (d * sum - u * d_sum) / (sum * next)
}

/// f32's unit roundoff times the few operations each quantity of [`barycentrics`] passes
/// through (a GPU that fuses a multiply and an add rounds less, never more).
const GAMMA: f32 = 8.0 * f32::EPSILON;

/// Relative error allowed per division: Vulkan lets a GPU's f32 division be 2.5 ulp off.
const DIVISION: f32 = 3.0 * f32::EPSILON;

/// The unnormalised weights at `q` (`(x, y, 1)` a point, `(dx, dy, 0)` a step) as
/// [`barycentrics`] computes them, with each one's and their sum's rounding bound: a row
/// entry is a difference of two products of inputs or edges (an edge carries one rounding
/// of its own size), a weight a three-term dot product, weight 0 the sum minus the others.
struct Weights {
    u: Vec3,
    sum: f32,
    err_u: Vec3,
    err_sum: f32,
}

fn weights(clip: [Vec4; 3], q: Vec3) -> Weights {
    let [c0, c1, c2] = clip.map(|c| Vec3::new(c.x, c.y, c.w));
    let (e1, e2) = (c1 - c0, c2 - c0);
    let (n, a, b) = (e1.cross(e2), e2.cross(c0), c0.cross(e1));
    let cross_abs = |a: Vec3, b: Vec3| Vec3::new(a.y * b.z + a.z * b.y, a.z * b.x + a.x * b.z, a.x * b.y + a.y * b.x);
    let qa = q.abs();
    let (u1, u2, sum) = (a.dot(q), b.dot(q), n.dot(q));
    let err_sum = GAMMA * cross_abs(e1.abs(), e2.abs()).dot(qa);
    let err_1 = GAMMA * cross_abs(e2.abs(), c0.abs()).dot(qa);
    let err_2 = GAMMA * cross_abs(c0.abs(), e1.abs()).dot(qa);
    let u0 = sum - u1 - u2;
    let err_0 = err_sum + err_1 + err_2 + GAMMA * (sum.abs() + u1.abs() + u2.abs());
    Weights { u: Vec3::new(u0, u1, u2), sum, err_u: Vec3::new(err_0, err_1, err_2), err_sum }
}

/// Bounds on the f32 rounding error of [`barycentrics`] for the same inputs, per
/// component (a forward error analysis of its operations, evaluated for this case), so
/// a result can be checked against an exact one with the tolerance its conditioning
/// earns: tight for a triangle seen face-on, loose for a sliver. None where the weights'
/// sum is within its own rounding of zero (the pixel's ray in the triangle's plane as far
/// as f32 can tell: f32 decides nothing there). A derivative's bound is infinite where
/// the neighbour's sum is (or is past) zero as far as f32 can tell, or under
/// [`NEIGHBOUR_SUM_FLOOR`] of the pixel's: there it is unbounded by design.
pub fn rounding_bound(clip: [Vec4; 3], ndc: Vec2, size: (u32, u32)) -> Option<Barycentrics> {
    let p = weights(clip, ndc.extend(1.0));
    let s = p.sum.abs();
    if s <= 2.0 * p.err_sum {
        return None;
    }
    let rel_sum = p.err_sum / (s - p.err_sum);
    let lambda = p.u / p.sum;
    let tol_l = p.err_u / (s - p.err_sum) + lambda.abs() * (rel_sum + DIVISION);
    let derivative = |q: Vec3| {
        let d = weights(clip, q);
        let s_next = (p.sum + d.sum) * p.sum.signum();
        let err_next = p.err_sum + d.err_sum;
        if s_next <= 2.0 * err_next || s_next <= s * NEIGHBOUR_SUM_FLOOR * 2.0 {
            return Vec3::INFINITY;
        }
        let step = (d.u * p.sum - p.u * d.sum) / (p.sum * s_next * p.sum.signum());
        let num = (d.u * p.sum).abs() + (p.u * d.sum).abs();
        let num_err = d.err_u * s + d.u.abs() * p.err_sum + p.err_u * d.sum.abs() + p.u.abs() * d.err_sum + num * GAMMA;
        let rel_den = rel_sum + err_next / (s_next - err_next);
        num_err / (s * s_next) * (1.0 + rel_den) + step.abs() * (rel_den + DIVISION)
    };
    Some(Barycentrics {
        lambda: tol_l,
        ddx: derivative(Vec3::new(2.0 / size.0 as f32, 0.0, 0.0)),
        ddy: derivative(Vec3::new(0.0, -2.0 / size.1 as f32, 0.0)),
    })
}

/// The f64 reference of [`barycentrics`], by another route: the pixel's ray through the
/// NDC point, intersected in clip space with the triangle's plane, and the intersection's
/// barycentrics from the sub-triangle areas; at the pixel and one pixel right and down.
/// None when the ray is parallel to the plane.
pub fn barycentrics_f64(clip: [DVec4; 3], ndc: DVec2, size: (u32, u32)) -> Option<(DVec3, DVec3, DVec3)> {
    let [a, b, c] = clip.map(|v| DVec3::new(v.x, v.y, v.w));
    let at = |p: DVec2| -> Option<DVec3> {
        // Points of the ray: t (p.x, p.y, 1), t != 0, in clip (x, y, w).
        let dir = DVec3::new(p.x, p.y, 1.0);
        let n = (b - a).cross(c - a);
        let denom = n.dot(dir);
        if denom == 0.0 {
            return None;
        }
        let q = dir * (n.dot(a) / denom);
        // Signed areas against the normal: each vertex's weight is the opposite sub-triangle's.
        let nn = n.dot(n);
        let wa = (c - b).cross(q - b).dot(n) / nn;
        let wb = (a - c).cross(q - c).dot(n) / nn;
        Some(DVec3::new(wa, wb, 1.0 - wa - wb))
    };
    let l = at(ndc)?;
    let lx = at(ndc + DVec2::new(2.0 / size.0 as f64, 0.0))?;
    let ly = at(ndc + DVec2::new(0.0, -2.0 / size.1 as f64))?;
    Some((l, lx - l, ly - l))
}

/// The mip level an isotropic sampler picks from UV gradients `ddx`, `ddy` (per pixel,
/// in UV units) on a `size`-texel texture: `log2` of the longer gradient in texels,
/// unclamped (level 0 and the last level are the sampler's clamps).
pub fn mip_level(ddx: Vec2, ddy: Vec2, size: (u32, u32)) -> f32 {
    let s = Vec2::new(size.0 as f32, size.1 as f32);
    let rho2 = (ddx * s).length_squared().max((ddy * s).length_squared());
    0.5 * rho2.log2()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_name_their_limits() {
        let l = IdLayout::for_scene(434, 3_600).unwrap();
        assert_eq!(l.triangle_bits, 12);
        assert_eq!(l.unpack(l.pack(433, 3_599)), Some((433, 3_599)));
        assert_eq!(l.unpack(l.pack(0, 0)), Some((0, 0)));
        assert_eq!(l.unpack(NO_TRIANGLE), None);
        // An ID past the scene (a stale or wrong ID) is not a triangle.
        assert_eq!(l.unpack(l.pack(434, 0)), None);
        assert_eq!(l.unpack(l.pack(0, 3_600)), None);
        // One instance of a mesh with every 32-bit index but the sky's.
        let one = IdLayout::for_scene(1, u32::MAX).unwrap();
        assert_eq!(one.unpack(one.pack(0, u32::MAX - 1)), Some((0, u32::MAX - 1)));
        // Too many: the error says what and how many bits.
        let e = IdLayout::for_scene(70_000, 1 << 17).unwrap_err().to_string();
        assert!(e.contains("70000 instances (17 bits)") && e.contains("34 bits needed"), "{e}");
        // Exactly 32 bits at full capacity would make the sky's ID a triangle's.
        assert!(IdLayout::for_scene(1 << 16, 1 << 16).is_err());
        assert!(IdLayout::for_scene((1 << 16) - 1, 1 << 16).is_ok());
        assert!(IdLayout::for_scene(0, 5).is_err() && IdLayout::for_scene(5, 0).is_err());
    }

    #[test]
    fn barycentrics_of_a_screen_aligned_triangle_are_the_linear_ones() {
        // w = 1 everywhere: perspective-correct = screen-linear; one pixel of a 100 px
        // wide target is 0.02 in NDC.
        let clip = [Vec4::new(-1.0, -1.0, 0.5, 1.0), Vec4::new(1.0, -1.0, 0.5, 1.0), Vec4::new(-1.0, 1.0, 0.5, 1.0)];
        let b = barycentrics(clip, Vec2::new(-0.5, -0.5), (100, 100)).unwrap();
        assert!((b.lambda - Vec3::new(0.5, 0.25, 0.25)).abs().max_element() < 1e-6, "{b:?}");
        assert!((b.ddx - Vec3::new(-0.01, 0.01, 0.0)).abs().max_element() < 1e-6, "{b:?}");
        assert!((b.ddy - Vec3::new(0.01, 0.0, -0.01)).abs().max_element() < 1e-6, "{b:?}");
        let (v, dx, dy) = b.interpolate([Vec2::ZERO, Vec2::X, Vec2::Y]);
        assert!((v - Vec2::splat(0.25)).length() < 1e-6 && (dx - Vec2::new(0.01, 0.0)).length() < 1e-6);
        assert!((dy - Vec2::new(0.0, -0.01)).length() < 1e-6);
    }

    #[test]
    fn the_f64_reference_agrees_and_a_wrong_vertex_is_seen() {
        let clip = [Vec4::new(-2.0, -1.0, 0.1, 3.0), Vec4::new(4.0, -0.5, 0.1, 9.0), Vec4::new(0.0, 5.0, 0.1, 6.0)];
        let ndc = Vec2::new(0.1, 0.2);
        let b = barycentrics(clip, ndc, (320, 180)).unwrap();
        let (l, dx, dy) = barycentrics_f64(clip.map(|c| c.as_dvec4()), ndc.as_dvec2(), (320, 180)).unwrap();
        assert!((b.lambda.as_dvec3() - l).abs().max_element() < 1e-6);
        assert!((b.ddx.as_dvec3() - dx).abs().max_element() < 1e-7);
        assert!((b.ddy.as_dvec3() - dy).abs().max_element() < 1e-7);
        // Negative: the same pixel on a triangle with one vertex moved differs.
        let mut moved = clip;
        moved[1].x += 0.5;
        let m = barycentrics(moved, ndc, (320, 180)).unwrap();
        assert!((m.lambda.as_dvec3() - l).abs().max_element() > 1e-3);
    }

    #[test]
    fn mip_level_is_log2_of_texels_per_pixel() {
        // One texel per pixel: level 0; four: level 2; the longer gradient decides.
        assert!((mip_level(Vec2::new(1.0 / 256.0, 0.0), Vec2::new(0.0, 1.0 / 256.0), (256, 256))).abs() < 1e-6);
        assert!((mip_level(Vec2::new(4.0 / 256.0, 0.0), Vec2::new(0.0, 1.0 / 256.0), (256, 256)) - 2.0).abs() < 1e-6);
        assert!((mip_level(Vec2::new(0.0, 1.0 / 512.0), Vec2::new(0.0, 8.0 / 512.0), (256, 512)) - 3.0).abs() < 1e-6);
    }
}
