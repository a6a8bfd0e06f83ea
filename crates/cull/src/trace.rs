//! The traced reference's shadow rays, as the GPU casts them (`shaders/common/trace.wgsl`),
//! in f32 on the CPU: the twin its kernel is compared with, and the layout it uploads.
//!
//! 1. **Flatten** ([`FlatBvh::new`]): the f64-exact SAH hierarchy of [`crate::raycast`]
//!    (padded f32 boxes) becomes nodes holding their two children's boxes ([`FlatNode`],
//!    64 bytes), so one node read tests both children. A child is a leaf (its triangles,
//!    1-8 in a row), another node, or nothing (a single-leaf tree's second child).
//! 2. **Traverse** ([`FlatBvh::occluded`]): any-hit, a short stack of [`TRACE_STACK`]
//!    entries (the deepest tree the builder makes has 96 levels, and traversal pushes at
//!    most one node a level). Both children's boxes are tested; leaf children are tested at
//!    once, node children visited nearer-first is not needed for any-hit, so the second is
//!    pushed. The box test keeps the far bound `(1 + 2^-21)` wider than computed (Ize's
//!    robust traversal, on top of the builder's 2^-20 padding), so rounding never skips a
//!    box that holds a hit.
//! 3. **Intersect** ([`watertight`]): Woop, Benthin and Wald (JCGT 2013): the ray's
//!    dominant axis becomes z, the triangle is sheared into ray space, and the three edge
//!    functions decide coverage; a shared edge is evaluated identically for both triangles,
//!    so no ray slips between them (the f32 test needs no fallback: an edge function of
//!    exactly 0 counts as inside, for both neighbours).
//! 4. **Masks** ([`Masks`]): an alpha-masked triangle blocks only where its material's
//!    alpha at the hit's texture coordinates reaches the cutoff, read as one bit per texel
//!    of mip 0, nearest texel, with the sampler's wrap modes.
//!
//! Segments: from `from` to `to` with `eps` world units cut off each end, as
//! [`crate::raycast::Triangles::occluded`]; `t` runs over `(eps / len, 1 - eps / len)` in
//! units of the unnormalised direction. Answers differ from the f64 reference only for
//! segments grazing an edge, a vertex, an end or a plane
//! ([`crate::raycast::Triangles::grazing`] says which). Depends on glam, bytemuck and
//! [`crate::raycast`].

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::raycast::Triangles;

/// Entries of the traversal stack (the deepest tree [`Triangles::new`] builds has 96
/// levels; `shaders/common/trace.wgsl` has the same constant).
pub const TRACE_STACK: usize = 96;

/// A child link meaning "no child" (a tree of one leaf has one child).
pub const NO_CHILD: u32 = u32::MAX;

/// The slot of a triangle without an alpha mask (always blocks).
pub const NO_MASK: u32 = u32::MAX;

/// How far a shadow ray's ends are moved off the surface (along its normal) and off the
/// light, as a share of the scene's scale ([`surface_eps`]): 2^-12 of the point's largest
/// coordinate plus 1 m, that coordinate bounded by the scene's size, so a surface never
/// shadows itself (about 8 mm at 30 m from the origin, 0.24 mm near it); `TRACE_EPS` in
/// `shaders/common/traced_shade.wgsl`.
pub const SURFACE_EPS: f32 = 1.0 / 4096.0;

/// The share of the point's largest coordinate added to the offset for the rounding of a
/// reconstructed position (2^-19: 16 f32 steps of that coordinate). Without the bound
/// by the scene's size the offset was `2^-12 (max |p| + 1)`: 244 m at 10^6 m from the
/// origin, 2.4 m at 10^4 m (a floor point lifted above a 2 m box never saw its shadow);
/// with it, 2 m and 2 cm there, which f32 positions (an f32 step is 6 cm at 10^6 m) need.
/// `TRACE_POSITION_EPS` in `shaders/common/traced_shade.wgsl`.
pub const POSITION_EPS: f32 = 1.0 / 524_288.0;

/// The offset of a shadow ray from surface point `p` in a scene of size `scale` (the
/// largest side of its shadow geometry's bounds, [`scene_scale`]):
/// `SURFACE_EPS (min(max |p|, scale) + 1) + POSITION_EPS max |p|`.
pub fn surface_eps(p: Vec3, scale: f32) -> f32 {
    let m = p.abs().max_element();
    SURFACE_EPS * (m.min(scale) + 1.0) + POSITION_EPS * m
}

/// The scale [`surface_eps`] bounds a point's coordinate by: the largest side of the
/// triangles' bounding box (0 without triangles; a triangle with a non-finite vertex is
/// skipped, as the hierarchy skips it).
pub fn scene_scale(triangles: &[[Vec3; 3]]) -> f32 {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for v in triangles.iter().filter(|t| t.iter().all(|v| v.is_finite())).flatten() {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    if lo.x > hi.x {
        0.0
    } else {
        (hi - lo).max_element()
    }
}

/// The far bound's widening in the box test: `1 + 2^-21`, four f32 steps at 1 (Ize 2013
/// asks for `1 + 2 gamma_3`, about 3.6e-7).
const FAR_GROW: f32 = 1.0 + 1.0 / 2_097_152.0;

/// One node: both children's boxes and links. A child with `count > 0` is a leaf of
/// triangles `link..link + count`; with `count == 0` it is node `link`, or nothing when
/// `link == NO_CHILD`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FlatNode {
    /// First child's box, low corner.
    pub a_lo: [f32; 3],
    /// First child's link.
    pub a_link: u32,
    /// First child's box, high corner.
    pub a_hi: [f32; 3],
    /// First child's triangle count (0: a node).
    pub a_count: u32,
    /// Second child's box, low corner.
    pub b_lo: [f32; 3],
    /// Second child's link.
    pub b_link: u32,
    /// Second child's box, high corner.
    pub b_hi: [f32; 3],
    /// Second child's triangle count.
    pub b_count: u32,
}

/// The hierarchy as the GPU reads it: nodes and triangles in leaf order.
#[derive(Clone, Debug, Default)]
pub struct FlatBvh {
    /// Node 0 is the root; empty when there are no triangles.
    pub nodes: Vec<FlatNode>,
    /// The triangles in leaf order.
    pub triangles: Vec<[Vec3; 3]>,
    /// Per triangle (leaf order), its index in the list the hierarchy was built from.
    pub ids: Vec<u32>,
    /// Levels of nodes below the root (leaves folded into their parents).
    pub depth: u32,
}

/// A child's box and link, from a node of [`Triangles`].
fn child(n: &crate::raycast::Node, link: u32) -> ([f32; 3], [f32; 3], u32, u32) {
    (n.lo.to_array(), n.hi.to_array(), if n.is_leaf() { n.first } else { link }, n.count)
}

impl FlatBvh {
    /// Flattens `tris`'s hierarchy: one node per interior node (a root leaf gets a node of
    /// its own with one child), in depth-first order.
    pub fn new(tris: &Triangles) -> Self {
        let (nodes, triangles, ids) = tris.parts();
        let mut out = Self { triangles: triangles.to_vec(), ids: ids.to_vec(), ..Self::default() };
        let Some(root) = nodes.first() else { return out };
        if root.is_leaf() {
            let (lo, hi, link, count) = child(root, 0);
            let empty = (Vec3::INFINITY.to_array(), Vec3::NEG_INFINITY.to_array());
            out.nodes.push(FlatNode {
                a_lo: lo,
                a_link: link,
                a_hi: hi,
                a_count: count,
                b_lo: empty.0,
                b_link: NO_CHILD,
                b_hi: empty.1,
                b_count: 0,
            });
            return out;
        }
        out.nodes.push(FlatNode::default());
        // (index in `nodes`, its flat slot, level)
        let mut todo = vec![(0usize, 0usize, 0u32)];
        while let Some((i, slot, level)) = todo.pop() {
            out.depth = out.depth.max(level);
            let n = &nodes[i];
            let (ca, cb) = (n.first as usize, n.first as usize + 1);
            let mut link = [0u32; 2];
            for (k, &c) in [ca, cb].iter().enumerate() {
                if !nodes[c].is_leaf() {
                    link[k] = out.nodes.len() as u32;
                    out.nodes.push(FlatNode::default());
                }
            }
            // The second child first, so the first is flattened next (depth-first order).
            for (k, &c) in [ca, cb].iter().enumerate().rev() {
                if !nodes[c].is_leaf() {
                    todo.push((c, link[k] as usize, level + 1));
                }
            }
            let (a, b) = (child(&nodes[ca], link[0]), child(&nodes[cb], link[1]));
            out.nodes[slot] = FlatNode {
                a_lo: a.0,
                a_link: a.2,
                a_hi: a.1,
                a_count: a.3,
                b_lo: b.0,
                b_link: b.2,
                b_hi: b.1,
                b_count: b.3,
            };
        }
        out
    }

    /// True if a triangle blocks the segment `from -> to` (with `eps` off each end), as the
    /// GPU kernel decides it: the same f32 operations in the same order. `blocks(id, u, v)`
    /// decides a hit on triangle `id` (its index in the input) at barycentrics `(u, v)`
    /// (weights of its second and third vertices): `|_, _, _| true` for opaque scenes,
    /// [`Masks::blocks`] for masked ones. False for a non-finite input or a segment no
    /// longer than `2 eps`. Also returns the node visits (a cost measure).
    pub fn occluded(&self, from: Vec3, to: Vec3, eps: f32, blocks: &dyn Fn(u32, f32, f32) -> bool) -> (bool, u32) {
        let Some(ray) = TraceRay::new(from, to, eps) else { return (false, 0) };
        if self.nodes.is_empty() {
            return (false, 0);
        }
        let mut stack = [0u32; TRACE_STACK];
        let mut len = 0usize;
        let mut node = 0u32;
        let mut visits = 0;
        loop {
            visits += 1;
            let n = &self.nodes[node as usize];
            let children = [(n.a_lo, n.a_hi, n.a_link, n.a_count), (n.b_lo, n.b_hi, n.b_link, n.b_count)];
            let mut next = [NO_CHILD; 2];
            for (k, &(lo, hi, link, count)) in children.iter().enumerate() {
                if link == NO_CHILD || !ray.enters(Vec3::from_array(lo), Vec3::from_array(hi)) {
                    continue;
                }
                if count == 0 {
                    next[k] = link;
                    continue;
                }
                for t in link..link + count {
                    if let Some((u, v)) = ray.watertight(&self.triangles[t as usize]) {
                        if blocks(self.ids[t as usize], u, v) {
                            return (true, visits);
                        }
                    }
                }
            }
            match next {
                [NO_CHILD, NO_CHILD] => {
                    if len == 0 {
                        return (false, visits);
                    }
                    len -= 1;
                    node = stack[len];
                }
                [a, NO_CHILD] => node = a,
                [NO_CHILD, b] => node = b,
                [a, b] => {
                    stack[len] = b;
                    len += 1;
                    node = a;
                }
            }
        }
    }
}

/// A segment as the kernel sets it up: origin, direction (`to - from`), the shear of the
/// watertight test and the reciprocal direction of the box test.
struct TraceRay {
    o: Vec3,
    inv_d: Vec3,
    /// Axes: x and y of ray space, then its z (the direction's largest component).
    k: [usize; 3],
    /// Shear `(Sx, Sy, Sz)`.
    s: Vec3,
    t_lo: f32,
    t_hi: f32,
}

impl TraceRay {
    fn new(from: Vec3, to: Vec3, eps: f32) -> Option<Self> {
        let d = to - from;
        let len = d.length();
        // Written so NaN fails it.
        let something_left = len > 2.0 * eps.max(0.0) && len.is_finite() && from.is_finite();
        if !something_left {
            return None;
        }
        let cut = eps.max(0.0) / len;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Keep the winding: a negative z swaps x and y.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        // A zero component: a huge finite reciprocal instead of inf, so (lo - o) * inv
        // is 0, not NaN, for an origin on the slab's plane.
        let inv = |c: f32| if c == 0.0 { 1e30 } else { 1.0 / c };
        let inv_d = Vec3::new(inv(d.x), inv(d.y), inv(d.z));
        Some(Self { o: from, inv_d, k: [kx, ky, kz], s, t_lo: cut, t_hi: 1.0 - cut })
    }

    /// Whether the segment meets the box (inclusive, far bound widened by [`FAR_GROW`]).
    fn enters(&self, lo: Vec3, hi: Vec3) -> bool {
        let a = (lo - self.o) * self.inv_d;
        let b = (hi - self.o) * self.inv_d;
        let near = a.min(b).max_element().max(self.t_lo);
        let far = a.max(b).min_element().min(self.t_hi) * FAR_GROW;
        near <= far
    }

    /// The watertight test ([`watertight`]).
    fn watertight(&self, tri: &[Vec3; 3]) -> Option<(f32, f32)> {
        watertight(tri, self.o, self.k, self.s, (self.t_lo, self.t_hi))
    }
}

/// Woop, Benthin and Wald's watertight ray-triangle test in f32: the barycentrics `(u, v)`
/// (weights of the second and third vertices) when the ray from `o` sheared by `s` along
/// axes `k` (see `TraceRay`) crosses the triangle at a parameter in the open interval
/// `range`. Two-sided; edges count as inside; a zero-area or edge-on triangle (determinant
/// 0) misses.
pub fn watertight(tri: &[Vec3; 3], o: Vec3, k: [usize; 3], s: Vec3, range: (f32, f32)) -> Option<(f32, f32)> {
    let [kx, ky, kz] = k;
    let (a, b, c) = (tri[0] - o, tri[1] - o, tri[2] - o);
    let ax = a[kx] - s.x * a[kz];
    let ay = a[ky] - s.y * a[kz];
    let bx = b[kx] - s.x * b[kz];
    let by = b[ky] - s.y * b[kz];
    let cx = c[kx] - s.x * c[kz];
    let cy = c[ky] - s.y * c[kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let t = u * (s.z * a[kz]) + v * (s.z * b[kz]) + w * (s.z * c[kz]);
    // t / det inside the range, without dividing: the comparisons flip with det's sign.
    let inside =
        if det > 0.0 { t > range.0 * det && t < range.1 * det } else { t < range.0 * det && t > range.1 * det };
    inside.then(|| (v / det, w / det))
}

/// How a mask's texture coordinates wrap (glTF's sampler modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum MaskWrap {
    /// Repeat.
    Repeat = 0,
    /// Clamp to the edge texel.
    Clamp = 1,
    /// Mirrored repeat.
    Mirror = 2,
}

/// One mask as uploaded: its size, wrap modes (`wrap_u | wrap_v << 2`) and first word.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct MaskSlot {
    /// Texels across (0: the material blocks nowhere).
    pub width: u32,
    /// Texels down.
    pub height: u32,
    /// `wrap_u | wrap_v << 2` ([`MaskWrap`]).
    pub wrap: u32,
    /// First word of its bits in [`Masks::bits`].
    pub first_word: u32,
}

/// The alpha masks of a scene's masked materials, one bit a texel (1: blocks), row-major,
/// each mask starting on a word, with per triangle (leaf order of the hierarchy) its mask
/// slot and texture coordinates (after the texture transform).
#[derive(Clone, Debug, Default)]
pub struct Masks {
    /// One per masked material in use.
    pub slots: Vec<MaskSlot>,
    /// The bits.
    pub bits: Vec<u32>,
}

impl Masks {
    /// Adds a mask of `width` x `height` texels where `texel_blocks(x, y)` says which block;
    /// returns its slot. A 0-texel mask blocks nowhere.
    pub fn add(
        &mut self,
        (width, height): (u32, u32),
        wrap: (MaskWrap, MaskWrap),
        texel_blocks: impl Fn(u32, u32) -> bool,
    ) -> u32 {
        let first_word = self.bits.len() as u32;
        let n = width as usize * height as usize;
        let mut bits = vec![0u32; n.div_ceil(32)];
        for y in 0..height {
            for x in 0..width {
                if texel_blocks(x, y) {
                    let i = (y * width + x) as usize;
                    bits[i / 32] |= 1 << (i % 32);
                }
            }
        }
        self.bits.extend(bits);
        self.slots.push(MaskSlot { width, height, wrap: wrap.0 as u32 | (wrap.1 as u32) << 2, first_word });
        (self.slots.len() - 1) as u32
    }

    /// Whether mask `slot` blocks at texture coordinates `uv` (nearest texel of mip 0);
    /// [`NO_MASK`] always blocks.
    pub fn blocks(&self, slot: u32, uv: Vec2) -> bool {
        if slot == NO_MASK {
            return true;
        }
        let m = self.slots[slot as usize];
        if m.width == 0 || m.height == 0 {
            return false;
        }
        let x = wrap_texel(uv.x, m.width, m.wrap & 3);
        let y = wrap_texel(uv.y, m.height, (m.wrap >> 2) & 3);
        let i = y * m.width + x;
        (self.bits[(m.first_word + i / 32) as usize] >> (i % 32)) & 1 == 1
    }
}

/// The texel of coordinate `c` on an axis of `n` texels with wrap mode `mode` (as
/// `trace_mask_texel` in `shaders/common/trace.wgsl`).
pub fn wrap_texel(c: f32, n: u32, mode: u32) -> u32 {
    let f = (c * n as f32).floor();
    // Far outside the texture (or NaN) every mode lands somewhere valid.
    let i = if f.is_finite() { f.clamp(-1.0e9, 1.0e9) as i64 } else { 0 };
    let n = i64::from(n);
    let t = match mode {
        1 => i.clamp(0, n - 1),
        2 => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
        _ => i.rem_euclid(n),
    };
    t as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raycast::tests::{soup, vec3};
    use proptest::prelude::*;

    /// Barycentric tolerance of a disagreement with the f64 reference: the f32 test's
    /// edge functions carry a relative error of a few 1e-7 of the triangle's size seen
    /// from the ray's origin, 1e-4 leaves a wide margin and still flags under 1% of rays.
    const GRAZE: f64 = 1e-4;

    /// Checks the flat tree's structure: every triangle in exactly one leaf, child boxes
    /// inside the parent's, depth within the stack.
    fn check(flat: &FlatBvh) {
        let mut seen = vec![0u32; flat.triangles.len()];
        for n in &flat.nodes {
            for (lo, hi, link, count) in [(n.a_lo, n.a_hi, n.a_link, n.a_count), (n.b_lo, n.b_hi, n.b_link, n.b_count)]
            {
                if count > 0 {
                    for t in link..link + count {
                        seen[t as usize] += 1;
                        for v in flat.triangles[t as usize] {
                            assert!(v.cmpge(Vec3::from(lo)).all() && v.cmple(Vec3::from(hi)).all());
                        }
                    }
                } else if link != NO_CHILD {
                    assert!((link as usize) < flat.nodes.len());
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        assert!((flat.depth as usize) < TRACE_STACK);
    }

    /// The offset by hand: near the origin 2^-12 (|p| + 1) plus the rounding term; far from
    /// it bounded by the scene's size, yet never under 16 f32 steps of the coordinate (the
    /// reconstructed position's rounding); the scale of a box and of nothing.
    #[test]
    fn the_offset_is_bounded_by_the_scene_not_the_origin() {
        let near = surface_eps(Vec3::new(3.0, -30.0, 1.0), 100.0);
        assert!((near - (31.0 / 4096.0 + 30.0 / 524_288.0)).abs() < 1e-9, "{near}");
        // 10^4 m out in a 20 m scene: 21 / 4096 + 10^4 / 2^19 = 5.1 mm + 19 mm (was 2.4 m).
        let far = surface_eps(Vec3::new(1.0e4, 0.0, 5.0), 20.0);
        assert!((far - (21.0 / 4096.0 + 1.0e4 / 524_288.0)).abs() < 1e-6, "{far}");
        assert!(far < 0.03);
        // 10^6 m out: about 2 m, and 32 f32 steps of the coordinate (0.0625 m each).
        let very = surface_eps(Vec3::new(0.0, 1.0e6, 0.0), 20.0);
        assert!(very > 16.0 * 0.0625 && very < 2.0, "{very}");
        let tri = [Vec3::new(-1.0, 0.0, 2.0), Vec3::new(4.0, 1.0, 2.0), Vec3::new(0.0, 0.5, -7.0)];
        let nan = [Vec3::NAN, Vec3::ZERO, Vec3::splat(50.0)];
        assert_eq!(scene_scale(&[tri, nan]), 9.0);
        assert_eq!(scene_scale(&[]), 0.0);
    }

    proptest! {
        #![proptest_config(crate::test_seed::proptest_config(256))]

        /// The f32 twin agrees with the f64 reference on every segment that does not graze
        /// a triangle (no false negative or positive), and grazing segments are few.
        #[test]
        fn twin_matches_the_f64_reference(
            tris in soup(10.0, 3.0, 60),
            segments in prop::collection::vec((vec3(15.0), vec3(15.0), 0.0f32..0.01), 1..32),
        ) {
            let bvh = Triangles::new(tris.clone());
            let flat = FlatBvh::new(&bvh);
            check(&flat);
            for (a, b, eps) in segments {
                let (twin, _) = flat.occluded(a, b, eps, &|_, _, _| true);
                let exact = bvh.occluded(a, b, eps);
                prop_assert!(twin == exact || bvh.grazing(a, b, eps, GRAZE), "{a} -> {b} eps {eps}: f32 {twin}, f64 {exact}");
            }
        }

        /// At the extremes: a scene 1e6 m from the origin (f32 steps of 6 cm), and 0.1 mm
        /// triangles near it; segments through vertices and edges.
        #[test]
        fn twin_at_the_extremes(
            offset in vec3(1.0e6),
            rel in prop::collection::vec((vec3(20.0), vec3(1.0), vec3(1.0), vec3(1.0)), 1..40),
            picks in prop::collection::vec((any::<usize>(), vec3(1.0), 0.5f32..5.0, 0.0f32..1.0), 1..16),
        ) {
            for (origin, size, scale) in [(offset, 10.0f32, 1.0f32), (Vec3::ZERO, 1e-4, 1e-3)] {
                let tris: Vec<[Vec3; 3]> = rel.iter().map(|(c, a, b, d)| {
                    let c = *c * scale + origin;
                    [c + *a * size, c + *b * size, c + *d * size]
                }).collect();
                let bvh = Triangles::new(tris.clone());
                let flat = FlatBvh::new(&bvh);
                check(&flat);
                for &(pick, dir, len, f) in &picks {
                    let t = &tris[pick % tris.len()];
                    // Through a vertex, an edge point or the centroid.
                    let p = match pick % 3 {
                        0 => t[pick % 3],
                        1 => t[0].lerp(t[1], f),
                        _ => (t[0] + t[1] + t[2]) / 3.0,
                    };
                    let dir = dir.normalize_or(Vec3::Y) * len * scale;
                    let (a, b) = (p - dir, p + dir);
                    let (twin, _) = flat.occluded(a, b, 0.0, &|_, _, _| true);
                    let exact = bvh.occluded(a, b, 0.0);
                    prop_assert!(twin == exact || bvh.grazing(a, b, 0.0, GRAZE), "{a} -> {b}: f32 {twin}, f64 {exact}");
                }
            }
        }
    }

    /// Watertight: segments through a shared edge of a fan of triangles (a closed
    /// umbrella) always hit at least one, at any angle.
    #[test]
    fn no_ray_slips_between_shared_edges() {
        let centre = Vec3::new(0.3, 0.0, -0.1);
        let ring: Vec<Vec3> = (0..7)
            .map(|k| {
                let a = k as f32 / 7.0 * std::f32::consts::TAU;
                Vec3::new(a.cos() * 2.0, 0.1 * a.sin(), a.sin() * 2.0)
            })
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..7).map(|k| [centre, ring[k], ring[(k + 1) % 7]]).collect();
        let flat = FlatBvh::new(&Triangles::new(tris.clone()));
        let mut rays = 0;
        for &rim in &ring {
            // Up to, not including, the rim vertex (the fan's own boundary).
            for s in 0..64 {
                let on_edge = centre.lerp(rim, s as f32 / 64.0);
                for tilt in [-0.7f32, -0.01, 0.0, 0.3] {
                    let d = Vec3::new(tilt, 1.0, 0.37 * tilt);
                    let (hit, _) = flat.occluded(on_edge - d, on_edge + d * 1.3, 0.0, &|_, _, _| true);
                    assert!(hit, "slipped through the edge at {on_edge} along {d}");
                    rays += 1;
                }
            }
        }
        assert_eq!(rays, 7 * 64 * 4);
    }

    /// The negative test: a twin whose triangle test ignores the mask (or a tree missing a
    /// leaf) is caught by the comparison above: removing one leaf's triangles makes some
    /// non-grazing segment disagree.
    #[test]
    fn a_lost_leaf_is_caught() {
        let tris: Vec<[Vec3; 3]> = (0..40)
            .map(|i| {
                let c = Vec3::new((i % 8) as f32 * 2.0, 0.0, (i / 8) as f32 * 2.0);
                [c, c + Vec3::X, c + Vec3::Z]
            })
            .collect();
        let bvh = Triangles::new(tris);
        let mut flat = FlatBvh::new(&bvh);
        let mut caught = 0;
        for n in &mut flat.nodes {
            if n.a_count > 0 {
                n.a_count = 0;
                n.a_link = NO_CHILD;
                break;
            }
        }
        for i in 0..40 {
            let c = Vec3::new((i % 8) as f32 * 2.0 + 0.3, 0.0, (i / 8) as f32 * 2.0 + 0.3);
            let (a, b) = (c - Vec3::Y, c + Vec3::Y);
            let (twin, _) = flat.occluded(a, b, 0.0, &|_, _, _| true);
            if twin != bvh.occluded(a, b, 0.0) && !bvh.grazing(a, b, 0.0, GRAZE) {
                caught += 1;
            }
        }
        assert!(caught > 0, "a tree missing a leaf must disagree somewhere");
    }

    /// Masks: bits, wrap modes and the nearest texel.
    #[test]
    fn masks_read_the_nearest_texel_with_wrap() {
        let mut m = Masks::default();
        // A 4x2 checker.
        let s = m.add((4, 2), (MaskWrap::Repeat, MaskWrap::Clamp), |x, y| (x + y) % 2 == 0);
        let none = m.add((0, 0), (MaskWrap::Repeat, MaskWrap::Repeat), |_, _| true);
        assert!(m.blocks(s, Vec2::new(0.1, 0.2)));
        assert!(!m.blocks(s, Vec2::new(0.3, 0.2)));
        assert!(m.blocks(s, Vec2::new(1.1, 0.2)), "repeat in u");
        assert!(!m.blocks(s, Vec2::new(0.1, 0.9)), "row 1");
        assert!(!m.blocks(s, Vec2::new(0.1, 7.0)), "clamped to row 1");
        assert!(m.blocks(s, Vec2::new(0.1, -3.0)), "clamped to row 0");
        assert!(!m.blocks(none, Vec2::ZERO));
        assert!(m.blocks(NO_MASK, Vec2::ZERO));
        assert_eq!(wrap_texel(-0.1, 4, 2), 0, "mirror");
        assert_eq!(wrap_texel(1.1, 4, 2), 3, "mirror");
        assert_eq!(wrap_texel(f32::NAN, 4, 0), 0);
        assert_eq!(wrap_texel(1e30, 4, 1), 3);
    }
}
