//! The CPU ray-cast visibility reference for shadow tests: world-space triangles in a
//! bounding volume hierarchy, answering "is the segment from a surface point to a light
//! blocked by scene geometry?" ([`Triangles::occluded`]). The GPU shadow maps are
//! compared with it. Also the surface points a depth buffer shows ([`surface_points`]:
//! where those segments start). Pure CPU; depends on glam and [`crate::Camera`].
//!
//! Precision: triangles and query points are f32, as the scene stores them, but every
//! query runs in f64 (box tests and the Möller–Trumbore triangle test), so rounding is
//! about 1e-16 relative and a query far from the origin (1e6 m) is as exact as one near
//! it. The f32 inputs themselves are what limits accuracy there: a surface point at 1e6 m
//! is only known to ~0.06 m (one f32 step), so pick `eps` accordingly.
//!
//! The BVH gives exactly the answers of a loop over every triangle (tolerance zero; the
//! property tests compare them, edge and vertex hits included): both run the same
//! triangle test, and each box is padded outward by 2^-20 of its size plus its distance
//! from the world origin, so the hierarchy never skips a triangle that the test accepts.
//! The padding exceeds both the f64 box test's rounding (~1e-16 of the ray origin's
//! distance from the box) and the triangle test's hit point error (under ~1e-9 of it, as
//! rays within 1e-7 rad of a triangle's plane count as missing it) whenever the ray starts
//! within about 100 times the box's scale (its distance from the world origin plus its
//! size) of it; only a grazing ray from much farther away could, in principle, see the
//! BVH miss a hit that the loop finds.

use glam::{DVec3, Vec3};

use crate::Camera;

/// Triangles per leaf that end the split without asking the SAH.
const MIN_LEAF: usize = 2;
/// Largest leaf: bigger nodes are split even when the SAH prefers a leaf (a leaf's
/// triangles are tested one by one, so a huge leaf would make queries linear).
const MAX_LEAF: usize = 8;
/// Centroid bins per axis of the binned SAH (16 is the usual quality/speed point).
const BINS: usize = 16;
/// Depth after which nodes are split at the median instead of by the SAH. The SAH can
/// peel a few triangles off per level on adversarial inputs (exponentially spaced
/// triangles); median splits halve the count, so the tree is at most
/// `SAH_DEPTH + 32` levels deep and the fixed traversal stack below cannot overflow.
const SAH_DEPTH: u32 = 64;
/// Traversal stack entries: the deepest tree has `SAH_DEPTH + 32` levels, and the stack
/// holds at most one entry per level plus one.
const STACK: usize = 128;
/// Boxes are grown by this fraction of (largest coordinate + largest extent): 2^-20, eight
/// f32 steps of the coordinate, far above the ~1e-16 relative error of the f64 box and
/// triangle tests.
const PAD: f32 = 1.0 / 1_048_576.0;
/// A ray counts as parallel to a triangle (a miss) when the sine of the angle between
/// the ray and the triangle's plane is at most this. Such a triangle is seen edge-on and
/// blocks nothing of measure; the threshold also rejects zero-area triangles (normal 0)
/// and bounds the f64 test's error (which grows as 1 / sine) so the box padding covers it.
const PARALLEL: f64 = 1e-7;

/// World-space triangles with a BVH built once, for visibility queries.
///
/// Triangles are two-sided (winding is ignored). Triangles with a NaN or infinite
/// coordinate are dropped when built: they never occlude. Zero-area (degenerate)
/// triangles are kept but never hit (see [`Triangles::occluded`]).
#[derive(Clone, Debug, Default)]
pub struct Triangles {
    /// The kept triangles, in leaf order.
    tris: Vec<[Vec3; 3]>,
    /// Node 0 is the root; an interior node's children are adjacent. Empty when there are
    /// no triangles.
    nodes: Vec<Node>,
    /// Levels below the root (0 for a root leaf).
    depth: u32,
    /// Per triangle in leaf order, its index in the list given to [`Triangles::new`]
    /// (dropped non-finite triangles counted), for [`Triangles::occluded_where`].
    ids: Vec<u32>,
}

/// A BVH node: a leaf when `count > 0` (triangles `first..first + count`), otherwise an
/// interior node whose children are `first` and `first + 1`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Node {
    /// Padded bounds (see [`PAD`]).
    pub(crate) lo: Vec3,
    pub(crate) hi: Vec3,
    pub(crate) first: u32,
    pub(crate) count: u32,
}

impl Node {
    pub(crate) fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// A query in f64: origin, direction and the open parameter interval `(t_lo, t_hi)`
/// whose hits count.
#[derive(Clone, Copy, Debug)]
struct Ray {
    o: DVec3,
    d: DVec3,
    inv_d: DVec3,
    /// `|d|^2`, for the parallel test.
    d_len2: f64,
    t_lo: f64,
    t_hi: f64,
}

impl Ray {
    fn new(o: DVec3, d: DVec3, t_lo: f64, t_hi: f64) -> Self {
        // 1/0 = inf on an axis the ray does not move along; `slab` handles that axis
        // separately. Any non-zero f64 component has a finite inverse (the smallest
        // possible, from f32 inputs, is ~1e-45).
        Self { o, d, inv_d: d.recip(), d_len2: d.length_squared(), t_lo, t_hi }
    }

    /// The segment `from -> to` with `eps` world units cut off each end (`t` in units of
    /// the segment, 0 at `from`, 1 at `to`); `None` when nothing of it is left or an input
    /// is not finite.
    fn segment(from: Vec3, to: Vec3, eps: f32) -> Option<Self> {
        if !from.is_finite() || !to.is_finite() || eps.is_nan() {
            return None;
        }
        let o = from.as_dvec3();
        let d = to.as_dvec3() - o;
        let len = d.length();
        let eps = f64::from(eps.max(0.0));
        // Written so NaN fails it; also false for a zero-length segment and eps = inf.
        let something_left = len > 2.0 * eps;
        if !something_left {
            return None;
        }
        Some(Self::new(o, d, eps / len, 1.0 - eps / len))
    }

    /// The ray from `origin` along `dir` (normalised, so `t` is a world distance) with
    /// hits in `(0, t_max)`; `None` for a non-finite origin or direction, a zero
    /// direction or a NaN or non-positive `t_max`.
    fn half_line(origin: Vec3, dir: Vec3, t_max: f32) -> Option<Self> {
        let positive = t_max > 0.0;
        if !origin.is_finite() || !dir.is_finite() || !positive {
            return None;
        }
        let d = dir.as_dvec3();
        let len = d.length();
        if len == 0.0 {
            return None;
        }
        Some(Self::new(origin.as_dvec3(), d / len, 0.0, f64::from(t_max)))
    }

    /// Entry parameter of the ray into the node's box within `(t_lo, t_hi)`, or `None`
    /// when it misses. Inclusive: a ray grazing the box's surface enters it.
    fn slab(&self, n: &Node, t_hi: f64) -> Option<f64> {
        let (lo, hi) = (n.lo.as_dvec3(), n.hi.as_dvec3());
        let (mut t0, mut t1) = (self.t_lo, t_hi);
        for k in 0..3 {
            if self.d[k] == 0.0 {
                // Parallel to this slab: inside it for every t or for none. Computing
                // (lo - o) * inf would give NaN for an origin on the slab's plane.
                if self.o[k] < lo[k] || self.o[k] > hi[k] {
                    return None;
                }
                continue;
            }
            let a = (lo[k] - self.o[k]) * self.inv_d[k];
            let b = (hi[k] - self.o[k]) * self.inv_d[k];
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1).then_some(t0)
    }
}

/// True when every coordinate of the triangle is finite (the triangles [`Triangles::new`] keeps).
fn finite_triangle(t: &[Vec3; 3]) -> bool {
    t.iter().all(|v| v.is_finite())
}

/// What Möller–Trumbore computes of a triangle and a ray before any test: the first
/// vertex, the two edges from it, `p = d x e2`, the determinant `e1 . p` and the normal
/// `e1 x e2` (shared by [`intersect_uv`] and [`grazes`]).
struct Setup {
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
    p: DVec3,
    det: f64,
    n: DVec3,
}

impl Setup {
    fn new(tri: &[Vec3; 3], ray: &Ray) -> Self {
        let v0 = tri[0].as_dvec3();
        let e1 = tri[1].as_dvec3() - v0;
        let e2 = tri[2].as_dvec3() - v0;
        let p = ray.d.cross(e2);
        Self { v0, e1, e2, p, det: e1.dot(p), n: e1.cross(e2) }
    }
}

/// Möller–Trumbore in f64, two-sided: the hit parameter `t` in the open interval
/// `(ray.t_lo, t_hi)`, or `None`.
///
/// - Edges and vertices belong to the triangle (the barycentric tests are inclusive), so
///   a ray through an edge shared by two triangles hits both (to f64 rounding, ~1e-16
///   relative) and cannot slip through a closed mesh.
/// - Parallel rays and zero-area triangles miss: when the sine of the angle between the
///   ray and the triangle's plane is at most [`PARALLEL`] (`|det| <= PARALLEL |d| |n|`,
///   compared squared so no square root is taken), and always when the normal `n` is 0.
///   A segment lying in a triangle's plane is therefore not blocked by it.
/// - NaN anywhere makes a comparison false, so it is a miss, never a panic.
fn intersect(tri: &[Vec3; 3], ray: &Ray, t_hi: f64) -> Option<f64> {
    intersect_uv(tri, ray, t_hi).map(|(t, _, _)| t)
}

/// [`intersect`] with the hit's barycentrics: `(t, u, v)`, the hit point being
/// `tri[0] + u (tri[1] - tri[0]) + v (tri[2] - tri[0])`.
fn intersect_uv(tri: &[Vec3; 3], ray: &Ray, t_hi: f64) -> Option<(f64, f64, f64)> {
    let Setup { v0, e1, e2, p, det, n } = Setup::new(tri, ray);
    // det = d . (e2 x e1) = -d . n, so det^2 = |d|^2 |n|^2 sin^2(angle to the plane).
    // Written so NaN fails it.
    let crosses = det * det > PARALLEL * PARALLEL * ray.d_len2 * n.length_squared();
    if !crosses {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = ray.o - v0;
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.d.dot(q) * inv_det;
    let inside = v >= 0.0 && u + v <= 1.0;
    if !inside {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    (t > ray.t_lo && t < t_hi).then_some((t, u, v))
}

/// Whether the segment `ray` crosses triangle `tri` within `tol` of deciding otherwise
/// ([`Triangles::grazing`]).
fn grazes(tri: &[Vec3; 3], ray: &Ray, tol: f64) -> bool {
    let Setup { v0, e1, e2, p, det, n } = Setup::new(tri, ray);
    let scale = ray.d_len2 * n.length_squared();
    // Written so NaN fails it (a zero-area triangle or a zero-length segment).
    let measurable = scale > 0.0;
    if !measurable {
        return false;
    }
    let sin2 = det * det / scale;
    if sin2 <= tol * tol {
        // Edge-on within tol: grazing if the segment comes near the triangle at all.
        let to_plane = |q: DVec3| (q - v0).dot(n).abs() / n.length();
        let size = e1.length().max(e2.length());
        return to_plane(ray.o + ray.d * ray.t_lo).min(to_plane(ray.o + ray.d * ray.t_hi)) <= size;
    }
    let inv_det = 1.0 / det;
    let s = ray.o - v0;
    let u = s.dot(p) * inv_det;
    let q = s.cross(e1);
    let v = ray.d.dot(q) * inv_det;
    let t = e2.dot(q) * inv_det;
    let inside_by = u.min(v).min(1.0 - u - v);
    let within_by = (t - ray.t_lo).min(ray.t_hi - t);
    // Inside by less than tol on one test and not clearly out on the other.
    (inside_by.abs() <= tol && within_by >= -tol) || (within_by.abs() <= tol && inside_by >= -tol)
}

impl Triangles {
    /// Builds the BVH (binned SAH, 16 bins per axis, median splits past depth 64) over
    /// `triangles`. Drops triangles with a NaN or infinite coordinate. About a second
    /// for a million triangles in a release build.
    ///
    /// # Panics
    ///
    /// With more than `u32::MAX` finite triangles.
    pub fn new(triangles: Vec<[Vec3; 3]>) -> Self {
        let (kept, tris): (Vec<u32>, Vec<[Vec3; 3]>) =
            triangles.into_iter().enumerate().filter(|(_, t)| finite_triangle(t)).map(|(i, t)| (i as u32, t)).unzip();
        let n = tris.len();
        assert!(u32::try_from(n).is_ok(), "Triangles::new: {n} triangles, at most u32::MAX supported");
        if n == 0 {
            return Self::default();
        }
        let boxes: Vec<(Vec3, Vec3)> =
            tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
        // Halves before adding: lo + hi overflows to inf for coordinates near f32::MAX.
        let centroids: Vec<Vec3> = boxes.iter().map(|(lo, hi)| *lo * 0.5 + *hi * 0.5).collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = vec![Node::default()];
        let mut depth = 0;
        // (node, first, end, depth): an explicit stack, as the tree may be ~96 levels deep.
        let mut todo = vec![(0usize, 0usize, n, 0u32)];
        while let Some((node, start, end, level)) = todo.pop() {
            depth = depth.max(level);
            let (lo, hi) = order[start..end]
                .iter()
                .map(|&i| boxes[i as usize])
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)));
            let (lo, hi) = padded(lo, hi);
            match split(&mut order[start..end], &centroids, &boxes, lo, hi, level) {
                None => nodes[node] = Node { lo, hi, first: start as u32, count: (end - start) as u32 },
                Some(mid) => {
                    let left = nodes.len();
                    nodes.push(Node::default());
                    nodes.push(Node::default());
                    nodes[node] = Node { lo, hi, first: left as u32, count: 0 };
                    todo.push((left + 1, start + mid, end, level + 1));
                    todo.push((left, start, start + mid, level + 1));
                }
            }
        }
        debug_assert!((depth as usize) < STACK - 1, "BVH depth {depth}");
        let tris = order.iter().map(|&i| tris[i as usize]).collect();
        let ids = order.iter().map(|&i| kept[i as usize]).collect();
        Self { tris, nodes, depth, ids }
    }

    /// Number of triangles kept (the finite ones).
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when no triangle was kept.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Levels of the BVH below its root (0 for a single leaf or no triangles): at most
    /// 96 whatever the input, typically about `log2(len / 4)`.
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// True if some triangle intersects the open segment `from -> to` at more than `eps`
    /// world units from both ends, so a receiver lying on a triangle does not shadow
    /// itself and a light inside a lamp's surface is not blocked by it.
    ///
    /// Two-sided. Edges and vertices count as part of a triangle; a triangle seen edge-on
    /// (within 1e-7 rad of parallel: a segment lying in its plane) or of zero area never
    /// blocks. A negative `eps` counts as 0; a segment no longer than `2 eps` (including a
    /// zero-length one) is never occluded. Returns false when `from` or `to` has a NaN or
    /// infinite coordinate or `eps` is NaN.
    pub fn occluded(&self, from: Vec3, to: Vec3, eps: f32) -> bool {
        let Some(ray) = Ray::segment(from, to, eps) else {
            return false;
        };
        self.any_hit(&ray, &|_, _, _| true)
    }

    /// [`Triangles::occluded`] where a hit blocks only if `blocks(index, u, v)` says so:
    /// `index` is the triangle's position in the list given to [`Triangles::new`] and
    /// `(u, v)` the hit's barycentrics (the point `t[0] + u (t[1] - t[0]) + v (t[2] - t[0])`).
    /// An alpha-masked surface passes light through its holes this way (the shadow tests
    /// look up the material's alpha at the hit's texture coordinates). Same segment, `eps`
    /// and triangle rules as [`Triangles::occluded`]; `|_, _, _| true` gives its answer.
    pub fn occluded_where(&self, from: Vec3, to: Vec3, eps: f32, blocks: &dyn Fn(usize, f32, f32) -> bool) -> bool {
        let Some(ray) = Ray::segment(from, to, eps) else {
            return false;
        };
        self.any_hit(&ray, blocks)
    }

    /// Distance from `origin` to the nearest triangle along `dir`, counting hits at
    /// distances in the open interval `(0, t_max)`; `t_max` may be infinite. `dir` need
    /// not be unit length: it is normalised, so the distance is in world units either
    /// way. Same triangle test as [`Triangles::occluded`] (two-sided, edge-on and
    /// zero-area triangles miss) without an `eps`: start the ray off the surface to avoid
    /// hitting it. `None` when nothing is hit, or when `origin` or `dir` has a NaN or
    /// infinite coordinate, `dir` is zero, or `t_max` is NaN or not positive.
    pub fn first_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let ray = Ray::half_line(origin, dir, t_max)?;
        self.closest_hit(&ray).map(|t| t as f32)
    }

    /// The hierarchy as built: nodes (node 0 the root), triangles in leaf order and their
    /// indices in the input ([`crate::trace::FlatBvh`] flattens it for the GPU).
    pub(crate) fn parts(&self) -> (&[Node], &[[Vec3; 3]], &[u32]) {
        (&self.nodes, &self.tris, &self.ids)
    }

    /// True when the segment's answer could change if some triangle moved by a little:
    /// some triangle is crossed within `tol` (in barycentric units) of its boundary, seen
    /// within `tol` radians of edge-on, or hit within `tol` of either end of the open
    /// interval `(eps, len - eps)` (in units of the segment). Answers differing between two
    /// exact-enough tests (this f64 one and the GPU's f32 watertight one) are allowed only
    /// for such grazing segments (`tests/tests/traced.rs`). A loop over every triangle:
    /// for tests.
    pub fn grazing(&self, from: Vec3, to: Vec3, eps: f32, tol: f64) -> bool {
        let Some(ray) = Ray::segment(from, to, eps) else {
            return false;
        };
        self.tris.iter().any(|t| grazes(t, &ray, tol))
    }

    fn leaf_tris(&self, n: &Node) -> &[[Vec3; 3]] {
        &self.tris[n.first as usize..(n.first + n.count) as usize]
    }

    fn any_hit(&self, ray: &Ray, blocks: &dyn Fn(usize, f32, f32) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = [0u32; STACK];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let node = &self.nodes[stack[len] as usize];
            if ray.slab(node, ray.t_hi).is_none() {
                continue;
            }
            if node.is_leaf() {
                let first = node.first as usize;
                let hit = self.leaf_tris(node).iter().enumerate().any(|(k, t)| {
                    intersect_uv(t, ray, ray.t_hi)
                        .is_some_and(|(_, u, v)| blocks(self.ids[first + k] as usize, u as f32, v as f32))
                });
                if hit {
                    return true;
                }
            } else {
                stack[len] = node.first;
                stack[len + 1] = node.first + 1;
                len += 2;
            }
        }
        false
    }

    fn closest_hit(&self, ray: &Ray) -> Option<f64> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<f64> = None;
        let mut t_hi = ray.t_hi;
        // (node, entry t): a node is skipped when a hit closer than its entry was found
        // after it was pushed.
        let mut stack = [(0u32, 0.0f64); STACK];
        let mut len = 0;
        if let Some(t) = ray.slab(&self.nodes[0], t_hi) {
            stack[0] = (0, t);
            len = 1;
        }
        while len > 0 {
            len -= 1;
            let (index, entry) = stack[len];
            if entry > t_hi {
                continue;
            }
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                for tri in self.leaf_tris(node) {
                    if let Some(t) = intersect(tri, ray, t_hi) {
                        t_hi = t;
                        best = Some(t);
                    }
                }
                continue;
            }
            let (a, b) = (node.first, node.first + 1);
            let ta = ray.slab(&self.nodes[a as usize], t_hi);
            let tb = ray.slab(&self.nodes[b as usize], t_hi);
            // Push the farther child first so the nearer one is searched first and its
            // hits prune the other.
            let mut children = [(a, ta), (b, tb)];
            if ta.unwrap_or(f64::INFINITY) < tb.unwrap_or(f64::INFINITY) {
                children.swap(0, 1);
            }
            for (c, t) in children {
                if let Some(t) = t {
                    stack[len] = (c, t);
                    len += 1;
                }
            }
        }
        best
    }
}

/// Bounds grown by [`PAD`] of (largest coordinate + largest extent), plus the smallest
/// normal f32 so a box of zero size at the origin still grows. An overflow to infinity
/// only makes the box larger, which is safe.
fn padded(lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let size = lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element();
    let pad = size * PAD + f32::MIN_POSITIVE;
    (lo - Vec3::splat(pad), hi + Vec3::splat(pad))
}

/// Half the surface area of a box, in f64 (f32 extents can overflow).
fn half_area(lo: Vec3, hi: Vec3) -> f64 {
    if !lo.cmple(hi).all() {
        return 0.0;
    }
    let e = hi.as_dvec3() - lo.as_dvec3();
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Bin of a centroid coordinate (out-of-range values clamp; NaN cannot occur, as
/// triangles are finite).
fn bin_of(c: f32, lo: f64, scale: f64) -> usize {
    (((f64::from(c) - lo) * scale) as usize).min(BINS - 1)
}

/// Chooses how to split a node holding `order`'s triangles, reordering `order` so the
/// first `mid` go left; `None` makes the node a leaf.
fn split(
    order: &mut [u32],
    centroids: &[Vec3],
    boxes: &[(Vec3, Vec3)],
    lo: Vec3,
    hi: Vec3,
    level: u32,
) -> Option<usize> {
    let count = order.len();
    if count <= MIN_LEAF {
        return None;
    }
    let (c_lo, c_hi) = order
        .iter()
        .map(|&i| centroids[i as usize])
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)));
    let extent = c_hi.as_dvec3() - c_lo.as_dvec3();
    if extent.max_element() <= 0.0 {
        // Every centroid is the same point: no plane separates them. Split the list in
        // halves (the children overlap, but the tree stays shallow) unless it is small.
        return (count > MAX_LEAF).then_some(count / 2);
    }
    if level < SAH_DEPTH {
        if let Some(mid) = sah_split(order, centroids, boxes, c_lo, extent, half_area(lo, hi)) {
            return mid;
        }
    }
    // Median along the widest centroid axis: always makes progress.
    let axis = extent.max_position();
    let mid = count / 2;
    order.select_nth_unstable_by(mid, |&a, &b| centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]));
    Some(mid)
}

/// The binned SAH: `Some(None)` when a leaf is cheaper (and allowed), `Some(Some(mid))`
/// for a split, `None` when no bin boundary separates the triangles.
fn sah_split(
    order: &mut [u32],
    centroids: &[Vec3],
    boxes: &[(Vec3, Vec3)],
    c_lo: Vec3,
    extent: DVec3,
    parent_area: f64,
) -> Option<Option<usize>> {
    #[derive(Clone, Copy)]
    struct Bin {
        count: usize,
        lo: Vec3,
        hi: Vec3,
    }
    let empty = Bin { count: 0, lo: Vec3::INFINITY, hi: Vec3::NEG_INFINITY };
    let mut bins = [[empty; BINS]; 3];
    let lo64 = c_lo.as_dvec3();
    let scale = DVec3::select(extent.cmpgt(DVec3::ZERO), BINS as f64 / extent, DVec3::ZERO);
    for &i in order.iter() {
        let (c, (blo, bhi)) = (centroids[i as usize], boxes[i as usize]);
        for k in 0..3 {
            let b = &mut bins[k][bin_of(c[k], lo64[k], scale[k])];
            b.count += 1;
            b.lo = b.lo.min(blo);
            b.hi = b.hi.max(bhi);
        }
    }
    // Cost of a split: traversal (the parent's area) plus each side's area times its
    // triangle count; a leaf costs the parent's area times its count.
    let mut best: Option<(f64, usize, usize)> = None;
    for (k, axis_bins) in bins.iter().enumerate() {
        if extent[k] <= 0.0 {
            continue;
        }
        // right[s] = the bins from s to the end.
        let mut right = [empty; BINS];
        let mut acc = empty;
        for s in (1..BINS).rev() {
            let b = axis_bins[s];
            acc = Bin { count: acc.count + b.count, lo: acc.lo.min(b.lo), hi: acc.hi.max(b.hi) };
            right[s] = acc;
        }
        let mut left = empty;
        for s in 1..BINS {
            let b = axis_bins[s - 1];
            left = Bin { count: left.count + b.count, lo: left.lo.min(b.lo), hi: left.hi.max(b.hi) };
            let r = right[s];
            if left.count == 0 || r.count == 0 {
                continue;
            }
            let cost =
                parent_area + half_area(left.lo, left.hi) * left.count as f64 + half_area(r.lo, r.hi) * r.count as f64;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, k, s));
            }
        }
    }
    let (cost, axis, s) = best?;
    if cost >= parent_area * order.len() as f64 && order.len() <= MAX_LEAF {
        return Some(None);
    }
    // Partition in place with the same bin formula, so the sides hold exactly the
    // counts the SAH saw (both non-empty).
    let goes_left = |i: u32| bin_of(centroids[i as usize][axis], lo64[axis], scale[axis]) < s;
    let mut mid = 0;
    for j in 0..order.len() {
        if goes_left(order[j]) {
            order.swap(mid, j);
            mid += 1;
        }
    }
    Some(Some(mid))
}

/// The surface a pixel sees: world position and unit normal ([`surface_points`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// World position of the pixel centre's depth.
    pub position: Vec3,
    /// Unit normal, on the side facing the camera.
    pub normal: Vec3,
}

/// The surface each pixel of a `width` x `height` reversed-Z depth buffer (row-major, top
/// row first, one depth per pixel, as `camera` rendered it) shows: world positions
/// unprojected at the pixel centres, and normals from the depth buffer alone, for ray casts
/// from the surfaces (shadow references) without the scene's normals.
///
/// - **Position**: the pixel centre at its depth ([`Camera::unproject_view`]), to world.
/// - **Normal**: the cross product of the horizontal and vertical position differences,
///   each the shorter of the one-sided differences with the two neighbours (the one on
///   the same surface, at a crease or an edge), turned to face the camera.
/// - **None** at the sky (no position: depth 0 with an infinite far plane), where no
///   neighbour in a direction has a position, and at depth discontinuities: when a chosen
///   difference is longer than 4 pixels' footprint at that distance
///   (`distance to the eye * 4 / height`), the pixel sits on a silhouette and its normal
///   is unknown.
///
/// # Panics
/// When `depth` does not hold `width * height` values (a caller bug).
pub fn surface_points(camera: &Camera, width: u32, height: u32, depth: &[f32]) -> Vec<Option<SurfacePoint>> {
    assert_eq!(
        depth.len() as u64,
        u64::from(width) * u64::from(height),
        "surface_points: the depth buffer must hold {width}x{height} values"
    );
    let to_world = camera.view().inverse();
    (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| at(camera, &to_world, (width, height, depth), x, y))
        .collect()
}

/// The surface pixel (`x`, `y`) shows, as [`surface_points`] finds it (the same
/// neighbours, the same silhouette rule), for one pixel: what the lab's worst-pixel
/// attribution needs without reconstructing a whole 1080p frame. None outside the screen.
///
/// # Panics
/// When `depth` does not hold `width * height` values (a caller bug).
pub fn surface_point(camera: &Camera, width: u32, height: u32, depth: &[f32], x: u32, y: u32) -> Option<SurfacePoint> {
    assert_eq!(
        depth.len() as u64,
        u64::from(width) * u64::from(height),
        "surface_point: the depth buffer must hold {width}x{height} values"
    );
    if x >= width || y >= height {
        return None;
    }
    at(camera, &camera.view().inverse(), (width, height, depth), x, y)
}

/// The world position of pixel (`x`, `y`)'s centre at its depth (None for the sky or off
/// the screen): [`surface_point`]'s position without the normal, so also at a silhouette.
///
/// # Panics
/// When `depth` does not hold `width * height` values (a caller bug).
pub fn pixel_position(camera: &Camera, width: u32, height: u32, depth: &[f32], x: u32, y: u32) -> Option<Vec3> {
    assert_eq!(
        depth.len() as u64,
        u64::from(width) * u64::from(height),
        "pixel_position: the depth buffer must hold {width}x{height} values"
    );
    position_at(camera, &camera.view().inverse(), (width, height, depth), i64::from(x), i64::from(y))
}

/// [`pixel_position`] with the inverse view given.
fn position_at(
    camera: &Camera,
    to_world: &glam::Mat4,
    (width, height, depth): (u32, u32, &[f32]),
    x: i64,
    y: i64,
) -> Option<Vec3> {
    let (w, h) = (i64::from(width), i64::from(height));
    if x < 0 || y < 0 || x >= w || y >= h {
        return None;
    }
    let d = depth[(y * w + x) as usize];
    let ndc = ((x as f32 + 0.5) / width as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / height as f32 * 2.0);
    camera.unproject_view(ndc.0, ndc.1, d).map(|v| to_world.transform_point3(v))
}

/// One pixel of [`surface_points`]; `to_world` is the inverse of the camera's view.
fn at(
    camera: &Camera,
    to_world: &glam::Mat4,
    (width, height, depth): (u32, u32, &[f32]),
    x: u32,
    y: u32,
) -> Option<SurfacePoint> {
    let pos = |x: i64, y: i64| position_at(camera, to_world, (width, height, depth), x, y);
    let (x, y) = (i64::from(x), i64::from(y));
    let eye = camera.eye();
    let p = pos(x, y)?;
    let pick = |a: Option<Vec3>, b: Option<Vec3>| -> Option<Vec3> {
        let da = a.map(|a| a - p);
        let db = b.map(|b| p - b);
        match (da, db) {
            (Some(a), Some(b)) => Some(if a.length() < b.length() { a } else { b }),
            (a, b) => a.or(b),
        }
    };
    let dx = pick(pos(x + 1, y), pos(x - 1, y))?;
    let dy = pick(pos(x, y + 1), pos(x, y - 1))?;
    let n = dx.cross(dy).normalize_or_zero();
    // A silhouette: the differences are far longer than a pixel's footprint.
    let footprint = (p - eye).length() * 4.0 / height as f32;
    if n == Vec3::ZERO || dx.length() > footprint || dy.length() > footprint {
        return None;
    }
    let n = if n.dot(eye - p) < 0.0 { -n } else { n };
    Some(SurfacePoint { position: p, normal: n })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// The reference for the reference: every finite triangle, no hierarchy.
    fn brute_occluded(tris: &[[Vec3; 3]], from: Vec3, to: Vec3, eps: f32) -> bool {
        let Some(ray) = Ray::segment(from, to, eps) else {
            return false;
        };
        tris.iter().filter(|t| finite_triangle(t)).any(|t| intersect(t, &ray, ray.t_hi).is_some())
    }

    fn brute_first_hit(tris: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let ray = Ray::half_line(origin, dir, t_max)?;
        tris.iter()
            .filter(|t| finite_triangle(t))
            .filter_map(|t| intersect(t, &ray, ray.t_hi))
            .min_by(f64::total_cmp)
            .map(|t| t as f32)
    }

    /// Checks the BVH's invariants: every triangle in exactly one leaf, every leaf's
    /// triangles inside its box and every child box inside its parent's.
    fn check_tree(bvh: &Triangles) {
        if bvh.is_empty() {
            assert!(bvh.nodes.is_empty());
            return;
        }
        let mut seen = vec![0u32; bvh.len()];
        let mut todo = vec![(0usize, 0u32)];
        let mut max_level = 0;
        while let Some((i, level)) = todo.pop() {
            max_level = max_level.max(level);
            let n = bvh.nodes[i];
            assert!(n.lo.cmple(n.hi).all());
            if n.is_leaf() {
                assert!(n.count as usize <= MAX_LEAF, "leaf of {}", n.count);
                for k in n.first..n.first + n.count {
                    seen[k as usize] += 1;
                    for v in bvh.tris[k as usize] {
                        assert!(v.cmpge(n.lo).all() && v.cmple(n.hi).all());
                    }
                }
            } else {
                for c in [n.first, n.first + 1] {
                    let child = bvh.nodes[c as usize];
                    assert!(child.lo.cmpge(n.lo).all() && child.hi.cmple(n.hi).all());
                    todo.push((c as usize, level + 1));
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "every triangle in exactly one leaf");
        assert_eq!(max_level, bvh.depth);
        assert!((bvh.depth as usize) < STACK - 1);
    }

    fn quad(y: f32, half: f32) -> Vec<[Vec3; 3]> {
        let (a, b, c, d) = (
            Vec3::new(-half, y, -half),
            Vec3::new(half, y, -half),
            Vec3::new(half, y, half),
            Vec3::new(-half, y, half),
        );
        vec![[a, b, c], [a, c, d]]
    }

    /// A depth buffer of the plane `y = plane_y` as `cam` sees it (depth 0 where the pixel's
    /// ray misses it: sky), computed by intersecting each pixel-centre ray with the plane.
    fn plane_depth(cam: &crate::Camera, w: u32, h: u32, plane_y: f32) -> Vec<f32> {
        let to_world = cam.view().inverse();
        let params = cam.depth_params();
        let mut depth = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let ndc = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / h as f32 * 2.0);
                let dir = to_world.transform_point3(cam.view_point_at(ndc.0, ndc.1, 1.0)) - cam.eye();
                let t = (plane_y - cam.eye().y) / dir.y;
                let d = if t > 0.0 {
                    let hit = cam.eye() + dir * t;
                    params.depth(-cam.view().transform_point3(hit).z)
                } else {
                    0.0
                };
                depth.push(d);
            }
        }
        depth
    }

    /// A plane seen from above and from below, horizon in view: every pixel with a surface
    /// lies on the plane with the plane's normal turned to the camera; the sky has none.
    /// Every plane pixel whose ray meets the plane at more than 20 degrees has one: a row
    /// step there spans `fov / h / sin(angle)` of the distance, under the 4-footprint
    /// limit (`4 / h`) while `sin(angle) > fov / 4 = 0.26`, i.e. above ~15 degrees.
    #[test]
    fn surface_points_of_a_plane() {
        let (w, h) = (64u32, 40u32);
        for (eye, normal) in [(Vec3::new(1.0, 3.0, 6.0), Vec3::Y), (Vec3::new(1.0, -2.0, 6.0), Vec3::NEG_Y)] {
            let target = Vec3::new(0.0, 0.5 * eye.y, 0.0);
            let cam = crate::Camera::perspective(eye, target, Vec3::Y, 60f32.to_radians(), 1.6, 0.1, None).unwrap();
            let depth = plane_depth(&cam, w, h, 0.5);
            let points = surface_points(&cam, w, h, &depth);
            assert_eq!(points.len(), (w * h) as usize);
            let (mut steep, mut sky) = (0, 0);
            for (i, (s, &d)) in points.iter().zip(&depth).enumerate() {
                if d == 0.0 {
                    assert!(s.is_none(), "pixel {i}: the sky has no surface");
                    sky += 1;
                    continue;
                }
                let (x, y) = (i as u32 % w, i as u32 / w);
                let ndc = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / h as f32 * 2.0);
                let ray = cam.view().inverse().transform_vector3(cam.view_point_at(ndc.0, ndc.1, 1.0)).normalize();
                if ray.y.abs() > 20f32.to_radians().sin() {
                    steep += 1;
                    assert!(s.is_some(), "pixel {i}: a plane pixel seen at more than 20 degrees has a surface");
                }
                let Some(s) = s else { continue };
                let dist = (s.position - eye).length();
                assert!((s.position.y - 0.5).abs() < 1e-4 * dist, "pixel {i}: {} off the plane", s.position);
                assert!(s.normal.dot(normal) > 0.9999, "pixel {i}: normal {} for {normal}", s.normal);
                assert!((s.normal.length() - 1.0).abs() < 1e-5);
            }
            assert!(steep > 500 && sky > 100, "the view must hold both: {steep} steep plane pixels, {sky} sky");
        }
    }

    /// A step between two planes: the pixels along it have no surface (silhouette), the
    /// others keep theirs.
    #[test]
    fn surface_points_none_at_a_depth_step() {
        let (w, h) = (32u32, 32u32);
        let cam =
            crate::Camera::perspective(Vec3::new(0.0, 10.0, 0.01), Vec3::ZERO, Vec3::Y, 0.5, 1.0, 0.1, None).unwrap();
        let (low, high) = (plane_depth(&cam, w, h, 0.0), plane_depth(&cam, w, h, 5.0));
        // The left half sees the high plane, the right half the low one.
        let depth: Vec<f32> =
            (0..(w * h) as usize).map(|i| if i % (w as usize) < 16 { high[i] } else { low[i] }).collect();
        let points = surface_points(&cam, w, h, &depth);
        for (i, s) in points.iter().enumerate() {
            let x = i % w as usize;
            let s = s.unwrap_or_else(|| panic!("pixel {i} (x {x}): no surface; the one-sided difference fits"));
            let y = if x < 16 { 5.0 } else { 0.0 };
            assert!((s.position.y - y).abs() < 1e-3, "pixel {i}: {}", s.position);
            assert!(s.normal.dot(Vec3::Y) > 0.9999);
        }
        // Both neighbours across the step: a single-pixel ledge has no surface.
        let ledge: Vec<f32> =
            (0..(w * h) as usize).map(|i| if i % w as usize == 16 { high[i] } else { low[i] }).collect();
        let points = surface_points(&cam, w, h, &ledge);
        assert!((0..h as usize).all(|y| points[y * w as usize + 16].is_none()), "a 1-pixel ledge is a silhouette");
        assert!(points[5 * w as usize + 10].is_some());
    }

    /// One pixel's surface ([`surface_point`], the lab's worst-pixel attribution) is the
    /// whole frame's at that pixel, on a step, a ledge and the screen's edges; off the
    /// screen there is none.
    #[test]
    fn one_pixels_surface_is_the_frames() {
        let (w, h) = (32u32, 24u32);
        let cam =
            crate::Camera::perspective(Vec3::new(0.0, 10.0, 0.01), Vec3::ZERO, Vec3::Y, 0.5, 1.3, 0.1, None).unwrap();
        let (low, high) = (plane_depth(&cam, w, h, 0.0), plane_depth(&cam, w, h, 5.0));
        let mut silhouettes = 0;
        for split in [|i: usize, w: usize| i % w < 16, |i: usize, w: usize| i % w == 16] {
            let depth: Vec<f32> =
                (0..(w * h) as usize).map(|i| if split(i, w as usize) { high[i] } else { low[i] }).collect();
            let frame = surface_points(&cam, w, h, &depth);
            assert!(frame.iter().any(Option::is_some));
            silhouettes += frame.iter().filter(|s| s.is_none()).count();
            for (i, want) in frame.iter().enumerate() {
                let (x, y) = (i as u32 % w, i as u32 / w);
                assert_eq!(surface_point(&cam, w, h, &depth, x, y), *want, "pixel ({x}, {y})");
            }
            for (i, want) in frame.iter().enumerate() {
                let (x, y) = (i as u32 % w, i as u32 / w);
                let p = pixel_position(&cam, w, h, &depth, x, y).expect("every pixel sees a plane");
                assert!(want.is_none_or(|s| s.position == p), "pixel ({x}, {y})");
            }
            assert_eq!(pixel_position(&cam, w, h, &depth, 0, h), None);
            assert_eq!(surface_point(&cam, w, h, &depth, w, 0), None);
            assert_eq!(surface_point(&cam, w, h, &depth, 0, h), None);
        }
        assert!(silhouettes >= h as usize, "the ledge's column has no surface");
    }

    #[test]
    fn blocker_between_points() {
        let bvh = Triangles::new(quad(1.0, 1.0));
        let (below, above) = (Vec3::new(0.2, 0.0, 0.3), Vec3::new(0.2, 2.0, 0.3));
        assert!(bvh.occluded(below, above, 0.0));
        assert!(bvh.occluded(above, below, 0.0), "symmetric");
        // Beside the quad.
        assert!(!bvh.occluded(Vec3::new(1.5, 0.0, 0.0), Vec3::new(1.5, 2.0, 0.0), 0.0));
        // Both points on the same side.
        assert!(!bvh.occluded(below, Vec3::new(0.0, 0.9, 0.0), 0.0));
        assert_eq!(bvh.first_hit(below, Vec3::Y, f32::INFINITY), Some(1.0));
        assert_eq!(bvh.first_hit(below, Vec3::Y * 7.0, f32::INFINITY), Some(1.0), "dir is normalised");
        assert_eq!(bvh.first_hit(below, Vec3::Y, 1.0), None, "t_max is exclusive");
        assert_eq!(bvh.first_hit(below, Vec3::NEG_Y, f32::INFINITY), None);
        let slanted = bvh.first_hit(Vec3::ZERO, Vec3::new(0.5, 1.0, 0.0), 10.0).unwrap();
        assert!((slanted - 1.25f32.sqrt()).abs() < 1e-6, "{slanted}");
    }

    #[test]
    fn two_sided() {
        for tri in [
            [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 1.0, -1.0), Vec3::new(0.0, 1.0, 1.0)],
            [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 1.0, -1.0)],
        ] {
            let bvh = Triangles::new(vec![tri]);
            assert!(bvh.occluded(Vec3::ZERO, Vec3::Y * 2.0, 0.0));
            assert!(bvh.occluded(Vec3::Y * 2.0, Vec3::ZERO, 0.0));
        }
    }

    #[test]
    fn eps_ignores_hits_at_the_ends() {
        let bvh = Triangles::new(quad(0.0, 1.0));
        let light = Vec3::new(0.0, 3.0, 0.0);
        // A receiver on the quad and a light on it: neither shadows itself with eps.
        assert!(!bvh.occluded(Vec3::new(0.3, 0.0, 0.1), light, 1e-4));
        assert!(!bvh.occluded(light, Vec3::new(0.3, 0.0, 0.1), 1e-4));
        // Within eps of the far end, and just beyond it.
        assert!(!bvh.occluded(Vec3::new(0.3, -1e-5, 0.1), light, 1e-4));
        assert!(bvh.occluded(Vec3::new(0.3, -2e-4, 0.1), light, 1e-4));
        // The open segment: endpoints exactly on the quad with eps 0 do not count.
        assert!(!bvh.occluded(Vec3::new(0.3, 0.0, 0.1), light, 0.0));
        assert!(bvh.occluded(Vec3::new(0.3, -1.0, 0.1), light, 0.0));
        // A segment shorter than 2 eps, zero length, negative and infinite eps.
        assert!(!bvh.occluded(Vec3::new(0.0, -0.1, 0.0), Vec3::new(0.0, 0.1, 0.0), 0.1));
        assert!(bvh.occluded(Vec3::new(0.0, -0.1, 0.0), Vec3::new(0.0, 0.1, 0.0), -5.0));
        assert!(!bvh.occluded(Vec3::new(0.0, -0.1, 0.0), Vec3::new(0.0, 0.1, 0.0), f32::INFINITY));
        assert!(!bvh.occluded(Vec3::ZERO, Vec3::ZERO, 0.0));
    }

    #[test]
    fn parallel_and_degenerate_miss() {
        let bvh = Triangles::new(quad(0.0, 1.0));
        // In the quad's plane, across it.
        assert!(!bvh.occluded(Vec3::new(-2.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), 0.0));
        assert_eq!(bvh.first_hit(Vec3::new(-2.0, 0.0, 0.0), Vec3::X, f32::INFINITY), None);
        // A grazing but not parallel segment still hits.
        assert!(bvh.occluded(Vec3::new(-2.0, 1e-3, 0.0), Vec3::new(2.0, -1e-3, 0.0), 0.0));
        // Zero-area triangles: collinear, and all three corners the same point.
        let p = Vec3::new(0.0, 1.0, 0.0);
        let degenerate =
            Triangles::new(vec![[p - Vec3::X, p, p + Vec3::X], [p, p, p], [p - Vec3::Z, p + Vec3::Z, p + Vec3::Z]]);
        assert_eq!(degenerate.len(), 3);
        check_tree(&degenerate);
        for to in [Vec3::Y * 2.0, Vec3::new(1.0, 2.0, 0.0), Vec3::new(0.0, 2.0, 1.0)] {
            assert!(!degenerate.occluded(Vec3::ZERO, to, 0.0));
        }
        assert_eq!(degenerate.first_hit(Vec3::ZERO, Vec3::Y, f32::INFINITY), None);
    }

    #[test]
    fn nan_and_infinity_inputs() {
        let mut soup = quad(1.0, 1.0);
        soup.push([Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y, Vec3::X]);
        soup.push([Vec3::new(0.0, 1.5, f32::INFINITY), Vec3::new(-1.0, 1.5, 0.0), Vec3::new(1.0, 1.5, 0.0)]);
        let bvh = Triangles::new(soup);
        assert_eq!(bvh.len(), 2, "non-finite triangles are dropped");
        check_tree(&bvh);
        let (a, b) = (Vec3::ZERO, Vec3::Y * 2.0);
        assert!(bvh.occluded(a, b, 0.0));
        for bad in [Vec3::NAN, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::new(f32::NEG_INFINITY, 0.0, 0.0)] {
            assert!(!bvh.occluded(bad, b, 0.0));
            assert!(!bvh.occluded(a, bad, 0.0));
            assert_eq!(bvh.first_hit(bad, Vec3::Y, 10.0), None);
            assert_eq!(bvh.first_hit(a, bad, 10.0), None);
        }
        assert!(!bvh.occluded(a, b, f32::NAN));
        assert_eq!(bvh.first_hit(a, Vec3::Y, f32::NAN), None);
        assert_eq!(bvh.first_hit(a, Vec3::Y, 0.0), None);
        assert_eq!(bvh.first_hit(a, Vec3::Y, -1.0), None);
        assert_eq!(bvh.first_hit(a, Vec3::ZERO, 10.0), None);
    }

    #[test]
    fn empty_sets() {
        for bvh in [Triangles::new(Vec::new()), Triangles::new(vec![[Vec3::NAN; 3]]), Triangles::default()] {
            assert!(bvh.is_empty());
            assert!(!bvh.occluded(Vec3::ZERO, Vec3::ONE, 0.0));
            assert_eq!(bvh.first_hit(Vec3::ZERO, Vec3::ONE, f32::INFINITY), None);
            check_tree(&bvh);
        }
    }

    #[test]
    fn closed_box_is_watertight_through_edges_and_vertices() {
        // A unit cube of 12 triangles; rays from its centre through every vertex, edge
        // midpoint and face centre (where neighbouring triangles meet) all hit it.
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let v = [
            c(0., 0., 0.),
            c(1., 0., 0.),
            c(1., 1., 0.),
            c(0., 1., 0.),
            c(0., 0., 1.),
            c(1., 0., 1.),
            c(1., 1., 1.),
            c(0., 1., 1.),
        ];
        let faces = [[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 5, 4], [3, 2, 6, 7], [0, 3, 7, 4], [1, 2, 6, 5]];
        let tris: Vec<[Vec3; 3]> =
            faces.iter().flat_map(|f| [[v[f[0]], v[f[1]], v[f[2]]], [v[f[0]], v[f[2]], v[f[3]]]]).collect();
        let bvh = Triangles::new(tris.clone());
        let centre = Vec3::splat(0.5);
        for x in [0.0f32, 0.5, 1.0] {
            for y in [0.0f32, 0.5, 1.0] {
                for z in [0.0f32, 0.5, 1.0] {
                    let p = c(x, y, z);
                    if p == centre {
                        continue;
                    }
                    let dir = p - centre;
                    let t = bvh.first_hit(centre, dir, 10.0).unwrap_or_else(|| panic!("ray to {p} escaped"));
                    assert!((t - dir.length()).abs() < 1e-6, "{p}: {t}");
                    assert!(bvh.occluded(centre, centre + dir * 3.0, 0.0), "{p}");
                    assert_eq!(brute_first_hit(&tris, centre, dir, 10.0), Some(t));
                }
            }
        }
    }

    #[test]
    fn adversarial_inputs_stay_shallow() {
        // 5000 copies of one triangle: identical centroids.
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let same = Triangles::new(vec![t; 5000]);
        check_tree(&same);
        assert!(same.depth <= 12, "depth {}", same.depth);
        assert!(same.occluded(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.2, 0.2, 1.0), 0.0));
        // Exponentially spaced triangles: the SAH peels one off per level.
        let tris: Vec<[Vec3; 3]> = (0..120)
            .map(|i| {
                let x = 1.5f32.powi(i);
                [Vec3::new(x, 0.0, 0.0), Vec3::new(x, 1.0, 0.0), Vec3::new(x, 0.0, 1.0)]
            })
            .collect();
        let exp = Triangles::new(tris.clone());
        check_tree(&exp);
        for i in [0, 50, 119] {
            let x = 1.5f32.powi(i);
            let from = Vec3::new(x * 0.9 - 1.0, 0.25, 0.25);
            let hit = exp.first_hit(from, Vec3::X, f32::INFINITY);
            assert!(hit.is_some());
            assert_eq!(hit, brute_first_hit(&tris, from, Vec3::X, f32::INFINITY));
            assert!(exp.occluded(from, Vec3::new(x * 1.1 + 1.0, 0.25, 0.25), 0.0));
        }
    }

    /// A random soup (many triangles, some long and thin, some tiny) and random
    /// segments, checked against brute force with a fixed seed, big enough that the tree
    /// has many levels.
    #[test]
    fn larger_soup_matches_brute_force() {
        let mut rng = Pcg64::seed_from_u64(7);
        let tris: Vec<[Vec3; 3]> = (0..3000)
            .map(|_| {
                let c = Vec3::new(
                    rng.random_range(-50.0..50.0),
                    rng.random_range(-5.0..5.0),
                    rng.random_range(-50.0..50.0),
                );
                let size = 10f32.powf(rng.random_range(-3.0..0.7));
                let mut corner = || {
                    c + Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
                        * size
                };
                [corner(), corner(), corner()]
            })
            .collect();
        let bvh = Triangles::new(tris.clone());
        check_tree(&bvh);
        let mut hits = 0;
        for _ in 0..2000 {
            let mut p =
                || Vec3::new(rng.random_range(-60.0..60.0), rng.random_range(-8.0..8.0), rng.random_range(-60.0..60.0));
            let (a, b) = (p(), p());
            let occ = bvh.occluded(a, b, 1e-3);
            assert_eq!(occ, brute_occluded(&tris, a, b, 1e-3), "{a} -> {b}");
            hits += usize::from(occ);
            assert_eq!(bvh.first_hit(a, b - a, f32::INFINITY), brute_first_hit(&tris, a, b - a, f32::INFINITY));
        }
        // Not vacuous either way.
        assert!((200..1800).contains(&hits), "{hits} of 2000 occluded");
    }

    /// `occluded_where` against a loop over every triangle with the same predicate, with
    /// non-finite triangles in the input (so leaf order, input order and the kept list all
    /// differ): a predicate that depends on the input index and on the barycentrics (half
    /// of each odd triangle lets light through) gives identical answers, and the always-true
    /// predicate gives `occluded`'s.
    #[test]
    fn occluded_where_passes_the_input_index_and_barycentrics() {
        let mut rng = Pcg64::seed_from_u64(11);
        let mut tris: Vec<[Vec3; 3]> = (0..400)
            .map(|_| {
                let c =
                    Vec3::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
                let mut corner = || {
                    c + Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
                };
                [corner(), corner(), corner()]
            })
            .collect();
        for i in [0, 17, 200] {
            tris[i][1].x = f32::NAN;
        }
        let bvh = Triangles::new(tris.clone());
        let blocks = |i: usize, u: f32, v: f32| i.is_multiple_of(2) || u + 0.5 * v < 0.4;
        let brute = |a: Vec3, b: Vec3| {
            let Some(ray) = Ray::segment(a, b, 1e-3) else { return false };
            tris.iter()
                .enumerate()
                .filter(|(_, t)| finite_triangle(t))
                .any(|(i, t)| intersect_uv(t, &ray, ray.t_hi).is_some_and(|(_, u, v)| blocks(i, u as f32, v as f32)))
        };
        let (mut differ, mut hits) = (0, 0);
        for _ in 0..3000 {
            let mut p =
                || Vec3::new(rng.random_range(-7.0..7.0), rng.random_range(-7.0..7.0), rng.random_range(-7.0..7.0));
            let (a, b) = (p(), p());
            let masked = bvh.occluded_where(a, b, 1e-3, &blocks);
            assert_eq!(masked, brute(a, b), "{a} -> {b}");
            assert_eq!(bvh.occluded_where(a, b, 1e-3, &|_, _, _| true), bvh.occluded(a, b, 1e-3));
            differ += usize::from(masked != bvh.occluded(a, b, 1e-3));
            hits += usize::from(masked);
        }
        // The predicate mattered, and not everything is blocked.
        assert!(differ > 50 && hits > 300 && hits < 2900, "{differ} changed by the predicate, {hits} blocked");
        // A quad with a hole where u + v < 0.5 of its first triangle: a segment through
        // the hole passes, one beside it is blocked.
        let q = quad(0.0, 1.0);
        let bvh = Triangles::new(q.clone());
        let hole = |i: usize, u: f32, v: f32| !(i == 0 && u + v < 0.5);
        let through = q[0][0] * 0.8 + q[0][1] * 0.1 + q[0][2] * 0.1;
        let beside = q[0][0] * 0.1 + q[0][1] * 0.45 + q[0][2] * 0.45;
        for (p, blocked) in [(through, false), (beside, true)] {
            assert_eq!(bvh.occluded_where(p - Vec3::Y, p + Vec3::Y, 0.0, &hole), blocked, "{p}");
            assert!(bvh.occluded(p - Vec3::Y, p + Vec3::Y, 0.0));
        }
    }

    /// A point on triangle `t` at barycentrics (`u`, `v`), clamped into the triangle.
    fn on_triangle(t: &[Vec3; 3], u: f32, v: f32) -> Vec3 {
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v
    }

    /// A point in `[-range, range]^3` (also `trace`'s tests).
    pub(crate) fn vec3(range: f32) -> impl Strategy<Value = Vec3> {
        (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    /// Triangles with corners within `spread` of a centre in `[-range, range]^3`.
    pub(crate) fn soup(range: f32, spread: f32, max: usize) -> impl Strategy<Value = Vec<[Vec3; 3]>> {
        prop::collection::vec((vec3(range), vec3(spread), vec3(spread), vec3(spread)), 0..max)
            .prop_map(|v| v.into_iter().map(|(c, a, b, d)| [c + a, c + b, c + d]).collect())
    }

    /// Segment queries that touch triangles' vertices, edges and interiors: a point on a
    /// triangle (a vertex, an edge point or an interior point, by barycentrics) and a
    /// random direction, with the segment passing through the point, or starting or
    /// ending on it.
    fn touching(tris: &[[Vec3; 3]], pick: usize, kind: u8, dir: Vec3, a: f32, b: f32, uv: (f32, f32)) -> (Vec3, Vec3) {
        let t = &tris[pick % tris.len()];
        let p = match kind % 4 {
            0 => t[pick % 3],
            1 => t[pick % 3].lerp(t[(pick + 1) % 3], 0.5),
            2 => t[pick % 3].lerp(t[(pick + 1) % 3], uv.0),
            _ => on_triangle(t, uv.0, uv.1),
        };
        match kind / 4 % 3 {
            0 => (p - dir * a, p + dir * b),
            1 => (p, p + dir * b),
            _ => (p - dir * a, p),
        }
    }

    /// Checks BVH against brute force for one segment, with eps 0 and 1e-3 (and the
    /// half-line from its start).
    fn agree(bvh: &Triangles, tris: &[[Vec3; 3]], a: Vec3, b: Vec3) -> Result<(), TestCaseError> {
        for eps in [0.0, 1e-3] {
            prop_assert_eq!(bvh.occluded(a, b, eps), brute_occluded(tris, a, b, eps), "{} -> {} eps {}", a, b, eps);
        }
        prop_assert_eq!(
            bvh.first_hit(a, b - a, (b - a).length()),
            brute_first_hit(tris, a, b - a, (b - a).length()),
            "{} -> {}",
            a,
            b
        );
        prop_assert_eq!(bvh.first_hit(a, b - a, f32::INFINITY), brute_first_hit(tris, a, b - a, f32::INFINITY));
        Ok(())
    }

    proptest! {
        #![proptest_config(crate::test_seed::proptest_config(256))]

        /// Tolerance zero: the BVH and the brute-force loop give identical booleans and
        /// identical f32 distances, for random segments and for segments through (or
        /// ending on) triangles' vertices, edges and interiors.
        #[test]
        fn bvh_matches_brute_force(
            tris in soup(10.0, 3.0, 60),
            segments in prop::collection::vec((vec3(15.0), vec3(15.0)), 1..16),
            touches in prop::collection::vec(
                (any::<usize>(), any::<u8>(), vec3(1.0), 0.0f32..5.0, 0.0f32..5.0, (0.0f32..1.0, 0.0f32..1.0)),
                0..16,
            ),
        ) {
            let bvh = Triangles::new(tris.clone());
            check_tree(&bvh);
            for (a, b) in segments {
                agree(&bvh, &tris, a, b)?;
            }
            if !tris.is_empty() {
                for (pick, kind, dir, s0, s1, uv) in touches {
                    let (a, b) = touching(&tris, pick, kind, dir, s0, s1, uv);
                    agree(&bvh, &tris, a, b)?;
                }
            }
        }

        /// Axis-aligned triangles and segments on a coarse grid: exact hits on edges,
        /// vertices and box faces, and directions with zero components.
        #[test]
        fn grid_aligned_matches_brute_force(
            tris in prop::collection::vec(prop::collection::vec((-4i32..4, -4i32..4, -4i32..4), 3), 0..40),
            segments in prop::collection::vec(((-6i32..6, -6i32..6, -6i32..6), (-6i32..6, -6i32..6, -6i32..6)), 1..24),
        ) {
            let p = |(x, y, z): (i32, i32, i32)| Vec3::new(x as f32, y as f32, z as f32) * 0.5;
            let tris: Vec<[Vec3; 3]> = tris.into_iter().map(|t| [p(t[0]), p(t[1]), p(t[2])]).collect();
            let bvh = Triangles::new(tris.clone());
            check_tree(&bvh);
            for (a, b) in segments {
                agree(&bvh, &tris, p(a), p(b))?;
            }
        }

        /// Zero-length segments are never occluded, whatever eps.
        #[test]
        fn zero_length_never_occluded(tris in soup(2.0, 2.0, 30), p in vec3(3.0), pick in any::<usize>(), eps in 0.0f32..1.0) {
            let bvh = Triangles::new(tris.clone());
            prop_assert!(!bvh.occluded(p, p, eps));
            if !tris.is_empty() {
                let on = tris[pick % tris.len()][pick % 3];
                prop_assert!(!bvh.occluded(on, on, eps));
                prop_assert!(!brute_occluded(&tris, on, on, eps));
            }
        }

        /// Scenes around 1e6 m from the origin (triangles 1 cm to 10 m) and tiny
        /// triangles (0.1 mm) near the origin.
        #[test]
        fn huge_coordinates_and_tiny_triangles(
            offset in vec3(1.0e6),
            spread in prop_oneof![Just(0.01f32), Just(1.0f32), Just(10.0f32)],
            rel in prop::collection::vec((vec3(20.0), vec3(1.0), vec3(1.0), vec3(1.0)), 1..40),
            segments in prop::collection::vec((vec3(25.0), vec3(25.0)), 1..12),
            touches in prop::collection::vec((any::<usize>(), any::<u8>(), vec3(1.0), 0.0f32..5.0, 0.0f32..5.0, (0.0f32..1.0, 0.0f32..1.0)), 0..12),
            tiny_touches in prop::collection::vec((any::<usize>(), any::<u8>(), vec3(1.0), 0.0f32..1e-3, 0.0f32..1e-3, (0.0f32..1.0, 0.0f32..1.0)), 0..12),
        ) {
            for (origin, size, scale) in [(offset, spread, 1.0f32), (Vec3::ZERO, 1e-4, 1e-3)] {
                let tris: Vec<[Vec3; 3]> =
                    rel.iter().map(|(c, a, b, d)| [*c * scale + origin + *a * size, *c * scale + origin + *b * size, *c * scale + origin + *d * size]).collect();
                let bvh = Triangles::new(tris.clone());
                check_tree(&bvh);
                for (a, b) in &segments {
                    agree(&bvh, &tris, *a * scale + origin, *b * scale + origin)?;
                }
                let ts = if scale < 1.0 { &tiny_touches } else { &touches };
                for &(pick, kind, dir, s0, s1, uv) in ts {
                    let (a, b) = touching(&tris, pick, kind, dir, s0, s1, uv);
                    agree(&bvh, &tris, a, b)?;
                }
            }
        }
    }
}
