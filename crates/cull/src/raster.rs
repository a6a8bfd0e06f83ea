//! The visibility buffer's compute rasteriser on the CPU (issue 29, step 1): the rules a
//! GPU kernel writing `(depth, ID)` with 64-bit `atomicMax` must follow, stated once here
//! and tested at the extremes (`tests/raster.rs`). Per triangle:
//!
//! 1. **Clip** (homogeneous, f32): against the near plane `z <= w` (reversed-Z: depth 1,
//!    which also removes everything behind the eye), the far plane `z >= 0` and a guard band
//!    `|x|, |y| <= GUARD_NDC w` that keeps window coordinates inside the fixed-point range.
//!    A triangle inside every plane is kept as it is; otherwise the polygon Sutherland-
//!    Hodgman leaves is fanned from its first vertex.
//! 2. **Window coordinates** (f32): `((x/w + 1) W/2, (1 - y/w) H/2)`, y down, depth `z/w`.
//! 3. **Snap** to the sub-pixel grid: 1/256 px ([`SUBPIXEL_BITS`], the hardware's on
//!    lavapipe and the H200), rounded to nearest with ties to even (WGSL's `round`), in i64.
//! 4. **Set up**: the signed area (i64, exact). Zero: nothing drawn. Counter-clockwise in
//!    NDC (y up) is the front face, as wgpu's `FrontFace::Ccw` says; with [`Cull::Back`]
//!    back faces are dropped. The vertices are then ordered so the area is positive.
//! 5. **Cover** pixel centres `(x + 1/2, y + 1/2)` strictly inside all three edges, or on
//!    an edge that is a top or a left edge (the top-left rule: a point on an edge two
//!    triangles share belongs to exactly one of them, so a mesh is watertight and drawn
//!    once). Edge functions are exact (i64), so this rule is exact.
//! 6. **Depth**: `z/w` interpolated affinely in window space with the snapped barycentrics,
//!    in f32.
//! 7. **Resolve**: `(depth bits << 32) | ID` kept by maximum ([`pack`]): reversed-Z puts the
//!    nearer surface at the larger depth, and a positive f32's bits order as its value. A tie
//!    in depth goes to the larger ID, deterministically (hardware keeps the later draw).
//!
//! The WGSL is `shaders/common/compute_raster.wgsl`, the same operations in the same order.
//! Depends on glam and [`crate::visibility`] (the clear value).

use glam::Vec4;

use crate::visibility::NO_TRIANGLE;

/// Fractional bits of the sub-pixel grid (1/256 px).
pub const SUBPIXEL_BITS: u32 = 8;

/// The guard band, in NDC: a triangle reaching further is clipped there (window
/// coordinates stay within 33 screens of the origin, ~2^27 sub-pixel steps at 16,384 px,
/// so every edge-function product fits an i64).
pub const GUARD_NDC: f32 = 64.0;

/// Which faces are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cull {
    /// Both (double-sided materials).
    None,
    /// Front faces only (counter-clockwise in NDC).
    Back,
}

/// The 64-bit texel of a depth and an ID: what `atomicMax` resolves.
pub fn pack(depth: f32, id: u32) -> u64 {
    (u64::from(depth.max(0.0).to_bits()) << 32) | u64::from(id)
}

/// The depth and ID of a texel.
pub fn unpack(texel: u64) -> (f32, u32) {
    (f32::from_bits((texel >> 32) as u32), texel as u32)
}

/// The clear value: depth 0 (infinitely far) and no triangle.
pub const CLEAR: u64 = NO_TRIANGLE as u64;

/// A `width` x `height` target of packed (depth, ID) texels, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Raster {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Packed texels ([`pack`]), [`CLEAR`] where nothing was drawn.
    pub texels: Vec<u64>,
}

/// One covered pixel of a triangle: where, its depth, and the triangle's facing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// Reversed-Z depth at the pixel centre.
    pub depth: f32,
    /// The triangle faces the viewer (counter-clockwise in NDC).
    pub front: bool,
}

impl Raster {
    /// A cleared target.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, texels: vec![CLEAR; width as usize * height as usize] }
    }

    /// Draws triangle `clip` (clip-space vertices) with `id`.
    pub fn draw(&mut self, clip: [Vec4; 3], id: u32, cull: Cull) {
        let w = self.width as usize;
        let texels = &mut self.texels;
        rasterize(clip, (self.width, self.height), cull, |f| {
            let t = &mut texels[f.y as usize * w + f.x as usize];
            *t = (*t).max(pack(f.depth, id));
        });
    }
}

/// A clip-space vertex's side of each plane: `>= 0` inside.
fn planes(v: Vec4) -> [f32; 6] {
    [v.w - v.z, v.z, GUARD_NDC * v.w - v.x, GUARD_NDC * v.w + v.x, GUARD_NDC * v.w - v.y, GUARD_NDC * v.w + v.y]
}

/// The triangle clipped by every plane, as a convex polygon (empty when nothing is left).
pub fn clip_triangle(clip: [Vec4; 3]) -> Vec<Vec4> {
    if clip.iter().all(|&v| planes(v).iter().all(|&d| d >= 0.0)) {
        return clip.to_vec();
    }
    let mut poly = clip.to_vec();
    for plane in 0..6 {
        if poly.is_empty() {
            break;
        }
        let mut out = Vec::with_capacity(poly.len() + 1);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (da, db) = (planes(a)[plane], planes(b)[plane]);
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let t = da / (da - db);
                out.push(a + (b - a) * t);
            }
        }
        poly = out;
    }
    poly
}

/// A vertex in window space: snapped x and y (1/256 px) and depth.
#[derive(Clone, Copy, Debug)]
struct Snapped {
    x: i64,
    y: i64,
    depth: f32,
}

fn snap(v: Vec4, (w, h): (u32, u32)) -> Snapped {
    let scale = (1u32 << SUBPIXEL_BITS) as f32;
    let (nx, ny) = (v.x / v.w, v.y / v.w);
    let wx = (nx + 1.0) * 0.5 * w as f32;
    let wy = (1.0 - ny) * 0.5 * h as f32;
    Snapped { x: (wx * scale).round_ties_even() as i64, y: (wy * scale).round_ties_even() as i64, depth: v.z / v.w }
}

/// Calls `emit` for every pixel of a `size` target that triangle `clip` covers (the
/// module's rules; a pixel at most once per triangle even where clipping fans it).
pub fn rasterize(clip: [Vec4; 3], size: (u32, u32), cull: Cull, mut emit: impl FnMut(Fragment)) {
    let Some((s, front)) = setup(clip, size, cull) else {
        return;
    };
    for i in 1..s.len() - 1 {
        if let Some(p) = Prepared::new(s[0], s[i], s[i + 1], size) {
            p.fill(front, &mut emit);
        }
    }
}

/// Steps 1 to 4 (module doc): the snapped polygon (a fan from its first vertex) and
/// whether it faces the viewer; `None` when nothing of it is drawn.
fn setup(clip: [Vec4; 3], size: (u32, u32), cull: Cull) -> Option<(Vec<Snapped>, bool)> {
    if clip.iter().any(|v| !v.is_finite()) || size.0 == 0 || size.1 == 0 {
        return None;
    }
    let poly = clip_triangle(clip);
    if poly.len() < 3 {
        return None;
    }
    let s: Vec<Snapped> = poly.iter().map(|&v| snap(v, size)).collect();
    // The facing of the whole triangle (the fan's pieces share it; a clipped-away
    // degenerate piece must not decide it).
    let area = |a: Snapped, b: Snapped, c: Snapped| (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    let total: i64 = (1..s.len() - 1).map(|i| area(s[0], s[i], s[i + 1])).sum();
    if total == 0 {
        return None;
    }
    // Window y points down: counter-clockwise in NDC is a negative area here.
    let front = total < 0;
    if cull == Cull::Back && !front {
        return None;
    }
    Some((s, front))
}

/// Side of the screen tiles the large triangles are filled by (`LARGE_TILE` in
/// `shaders/visibility_raster.wgsl`: one workgroup of 16 x 16 lanes a tile).
pub const LARGE_TILE: u32 = 16;

/// The work a large triangle is split into (the compute raster's `cs_large`, issue 49):
/// `[piece, tile x, tile y]` for every piece of its clipped fan (0 = the first) and every
/// [`LARGE_TILE`] tile of the screen within the piece's pixel bounds that no edge rules
/// out. An edge function is linear, so its largest value over the tile's pixel centres
/// (clipped to the bounds) is at one of their four corners: a tile is left out only when
/// an edge is negative at all four, where no centre can be covered. Every covered pixel
/// lies in a listed tile of its piece; a listed tile may cover none.
pub fn large_tiles(clip: [Vec4; 3], size: (u32, u32), cull: Cull) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    let Some((s, _)) = setup(clip, size, cull) else {
        return out;
    };
    let t = i64::from(LARGE_TILE);
    for i in 1..s.len() - 1 {
        let Some(p) = Prepared::new(s[0], s[i], s[i + 1], size).filter(|p| p.x0 <= p.x1 && p.y0 <= p.y1) else {
            continue;
        };
        for ty in p.y0 / t..=p.y1 / t {
            for tx in p.x0 / t..=p.x1 / t {
                let (x0, x1) = ((tx * t).max(p.x0), (tx * t + t - 1).min(p.x1));
                let (y0, y1) = ((ty * t).max(p.y0), (ty * t + t - 1).min(p.y1));
                let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| p.edges(x, y));
                if (0..3).all(|k| corners.iter().any(|e| e[k] >= 0)) {
                    out.push([i as u32 - 1, tx as u32, ty as u32]);
                }
            }
        }
    }
    out
}

/// Whether the edge from `a` to `b` of a positive-area triangle (window y down) is a top
/// edge (horizontal, interior below) or a left edge (going up).
fn top_left(a: Snapped, b: Snapped) -> bool {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    (dy == 0 && dx > 0) || dy < 0
}

/// The edge function of `a -> b` at `(px, py)`: positive inside a positive-area triangle.
fn edge(a: Snapped, b: Snapped, px: i64, py: i64) -> i64 {
    (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x)
}

/// A snapped triangle ready to fill (`RasterFill` in the WGSL): vertices ordered to a
/// positive area and the pixels its bounds hold on screen (`x0..=x1`, `y0..=y1`; empty
/// when `x1 < x0` or `y1 < y0`).
struct Prepared {
    v: [Snapped; 3],
    area: i64,
    x0: i64,
    x1: i64,
    y0: i64,
    y1: i64,
}

impl Prepared {
    /// `None` for a zero area.
    fn new(a: Snapped, b: Snapped, c: Snapped, (w, h): (u32, u32)) -> Option<Self> {
        let ab = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if ab == 0 {
            return None;
        }
        // Positive area: swap two vertices of a negative one.
        let v = if ab > 0 { [a, b, c] } else { [a, c, b] };
        let one = 1i64 << SUBPIXEL_BITS;
        let half = one / 2;
        // Pixels whose centres the bounding box can hold (one more at the low end is harmless).
        let lo = |m: i64| (m - half).div_euclid(one).max(0);
        let hi = |m: i64, n: u32| ((m - half).div_euclid(one)).min(i64::from(n) - 1);
        let (xs, ys) = (v.map(|p| p.x), v.map(|p| p.y));
        let (min, max) = (|a: [i64; 3]| a[0].min(a[1]).min(a[2]), |a: [i64; 3]| a[0].max(a[1]).max(a[2]));
        Some(Self { v, area: ab.abs(), x0: lo(min(xs)), x1: hi(max(xs), w), y0: lo(min(ys)), y1: hi(max(ys), h) })
    }

    /// The three edge functions at the centre of pixel `(px, py)`: edge k is opposite
    /// vertex k (so it weighs that vertex).
    fn edges(&self, px: i64, py: i64) -> [i64; 3] {
        let one = 1i64 << SUBPIXEL_BITS;
        let (cx, cy) = (px * one + one / 2, py * one + one / 2);
        let [v0, v1, v2] = self.v;
        [(v1, v2), (v2, v0), (v0, v1)].map(|(p, q)| edge(p, q, cx, cy))
    }

    fn fill(&self, front: bool, emit: &mut impl FnMut(Fragment)) {
        let [v0, v1, v2] = self.v;
        let owns = [(v1, v2), (v2, v0), (v0, v1)].map(|(p, q)| top_left(p, q));
        for py in self.y0..=self.y1 {
            for px in self.x0..=self.x1 {
                let e = self.edges(px, py);
                let inside = (0..3).all(|k| e[k] > 0 || (e[k] == 0 && owns[k]));
                if !inside {
                    continue;
                }
                let inv = 1.0 / self.area as f32;
                let depth =
                    (e[0] as f32 * inv) * v0.depth + (e[1] as f32 * inv) * v1.depth + (e[2] as f32 * inv) * v2.depth;
                emit(Fragment { x: px as u32, y: py as u32, depth, front });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ndc(x: f32, y: f32, d: f32) -> Vec4 {
        Vec4::new(x, y, d, 1.0)
    }

    fn covered(clip: [Vec4; 3], size: (u32, u32), cull: Cull) -> Vec<(u32, u32)> {
        let mut v = Vec::new();
        rasterize(clip, size, cull, |f| v.push((f.x, f.y)));
        v
    }

    /// A full-screen quad as two triangles covers every pixel exactly once (the shared
    /// diagonal goes to one of them), and a triangle's winding decides what back-face
    /// culling keeps.
    #[test]
    fn a_quad_covers_every_pixel_once_and_winding_culls() {
        let (w, h) = (7u32, 5u32);
        let (a, b, c, d) = (ndc(-1.0, -1.0, 0.5), ndc(1.0, -1.0, 0.5), ndc(1.0, 1.0, 0.5), ndc(-1.0, 1.0, 0.5));
        let mut count = vec![0; (w * h) as usize];
        for t in [[a, b, c], [a, c, d]] {
            for (x, y) in covered(t, (w, h), Cull::Back) {
                count[(y * w + x) as usize] += 1;
            }
        }
        assert!(count.iter().all(|&n| n == 1), "{count:?}");
        // Clockwise in NDC is a back face.
        assert!(covered([a, c, b], (w, h), Cull::Back).is_empty());
        assert_eq!(covered([a, c, b], (w, h), Cull::None).len(), covered([a, b, c], (w, h), Cull::Back).len());
    }

    /// Packed texels order by depth first, then ID; the clear value loses to any surface.
    #[test]
    fn packing_orders_by_depth_then_id() {
        assert!(pack(0.5, 1) > pack(0.25, 9));
        assert!(pack(0.5, 2) > pack(0.5, 1));
        assert!(pack(1e-30, 0) > CLEAR);
        assert_eq!(unpack(pack(0.75, 42)), (0.75, 42));
    }

    /// A triangle wholly behind the eye or beyond the near plane draws nothing; NaN draws
    /// nothing.
    #[test]
    fn behind_the_eye_and_nan_draw_nothing() {
        let behind = [Vec4::new(0.0, 0.0, 0.1, -1.0), Vec4::new(1.0, 0.0, 0.1, -1.0), Vec4::new(0.0, 1.0, 0.1, -1.0)];
        assert!(covered(behind, (8, 8), Cull::None).is_empty());
        let nan = [ndc(f32::NAN, 0.0, 0.5), ndc(1.0, 0.0, 0.5), ndc(0.0, 1.0, 0.5)];
        assert!(covered(nan, (8, 8), Cull::None).is_empty());
    }
}
