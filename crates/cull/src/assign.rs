//! Light-centric assignment: the rectangle of tiles whose four side planes a light's
//! sphere passes, found by binary search instead of testing every tile, and
//! [`cull_tiles_scatter`], the CPU twin of a culler that walks each light over its
//! rectangle instead of each tile over every light. The GPU side (WGSL) mirrors
//! [`light_tile_rect`] operation for operation. Depends on [`crate::camera`]
//! (`clip_edge_plane`), [`crate::tiles`] (the tile NDC edges), [`crate::volumes`] (the
//! per-tile test the scatter culler reuses), [`crate::gather`] (the shared set-up) and
//! [`crate::lists`].
//!
//! A tile's side planes are separable: its left and right planes depend only on its
//! column, its bottom and top planes only on its row. So the tiles passing all four planes
//! are (column set) x (row set), and each set is an interval whenever each plane test is
//! monotone over columns (rows). It is monotone for orthographic cameras (parallel planes)
//! and for perspective ones while the sphere lies wholly in front of the eye plane
//! (`c.z + r < 0`): every side plane passes through the eye, and the sphere then spans an
//! interval of angles about it. A sphere reaching the eye plane gets the tiles its part
//! beyond the near plane can cover ([`near_cap_rect`]): nothing nearer is drawn, so the
//! tiles outside hold no surface it reaches, though their plane tests may pass (the
//! per-tile test's false positives near the eye, which the gather keeps).
//!
//! [`light_tile_rect`]:
//! 1. `!(r > 0)` (zero, negative or NaN): `None`. An infinite radius goes on and gets the
//!    whole grid (every plane test passes), as the per-tile test keeps such a light in
//!    every tile: the CPU culler's `inflate` makes one out of a centre beyond ~1e19 m,
//!    where `|c|` overflows; the GPU never sees one.
//! 2. Perspective and `c.z + r >= 0`: [`near_cap_rect`] (the box `c +- r` cut at
//!    `z <= -near`, its eight corners projected; `None` when the sphere lies wholly nearer
//!    than the near plane, the whole grid when a projection is not finite). Before it
//!    (the whole grid) ~2,800 of the million-light preset's lights got every tile, 80% of
//!    the 100,000-light bench's candidate tiles; after it 72.
//! 3. A plane `p` passes when `dot(p.xyz, c) + p.w >= -r` (the negation of
//!    `sphere_vs_frustum`'s rejection). With the planes built exactly as
//!    [`crate::tiles::TileFrustum::from_parts`] builds them from [`TileGrid::tile_ndc`]:
//!    - `x0` = first column whose right plane passes (monotone false..true);
//!    - `x1` = last column whose left plane passes (monotone true..false);
//!    - `y0` = first row whose bottom plane passes (rows count down the screen);
//!    - `y1` = last row whose top plane passes.
//!
//!    Each by [`lower_bound`] (the first index of a false..true predicate).
//! 4. An empty column or row range: `None`. No widening: in f32 the predicates are
//!    monotone except within rounding of the boundary, where the rectangle and the per-tile
//!    test may disagree by a tile (the property tests bound that by a radius slack).

use glam::{Mat4, Vec3, Vec4};

use crate::camera::{clip_edge_plane, Camera, DepthParams};
use crate::error::CullError;
use crate::gather::cull_setup;
use crate::light::PackedLights;
use crate::lists::{CullConfig, TileLists};
use crate::tiles::TileGrid;
use crate::volumes::{light_in_volume, tile_volumes};

/// An inclusive rectangle of tiles: columns `x0..=x1`, rows `y0..=y1` (row 0 at the top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileRect {
    /// First column.
    pub x0: u32,
    /// Last column (inclusive).
    pub x1: u32,
    /// First row.
    pub y0: u32,
    /// Last row (inclusive).
    pub y1: u32,
}

impl TileRect {
    /// The whole grid.
    pub fn full(grid: &TileGrid) -> Self {
        Self { x0: 0, x1: grid.tiles_x - 1, y0: 0, y1: grid.tiles_y - 1 }
    }

    /// Whether tile (tx, ty) lies inside.
    pub fn contains(&self, tx: u32, ty: u32) -> bool {
        (self.x0..=self.x1).contains(&tx) && (self.y0..=self.y1).contains(&ty)
    }
}

/// The first index in `0..n` where `pred` is true, `n` if none: a plain lower-bound binary
/// search for a predicate that is false then true. WGSL uses the same loop, so both sides
/// evaluate the same indices even where f32 makes a predicate non-monotone.
pub fn lower_bound(n: u32, mut pred: impl FnMut(u32) -> bool) -> u32 {
    let (mut lo, mut hi) = (0u32, n);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if pred(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// Whether the sphere (`c`, `r`) reaches the inside of plane `p`: exactly the negation of
/// `sphere_vs_frustum`'s per-plane rejection `dot + w < -r`.
fn passes(p: Vec4, c: Vec3, r: f32) -> bool {
    p.truncate().dot(c) + p.w >= -r
}

/// The tiles whose four side planes the sphere (view-space centre `c`, radius `r`) passes,
/// as an inclusive rectangle, or `None` when there are none (or `r` is not positive). The depth range of the tiles is not tested. See the module docs for
/// the algorithm, which WGSL mirrors; `proj` and `orthographic` are the camera's.
pub fn light_tile_rect(grid: &TileGrid, proj: &Mat4, dp: &DepthParams, c: Vec3, r: f32) -> Option<TileRect> {
    // Written as in WGSL (`!(r > 0.0)`), so NaN takes this branch.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(r > 0.0) {
        return None;
    }
    if !dp.orthographic && c.z + r >= 0.0 {
        return near_cap_rect(grid, proj, dp.near, c, r);
    }
    // The edges as `tile_ndc` computes them: l, r depend on the column only, b, t on the row.
    let col = |i: u32| grid.tile_ndc(i, 0);
    let row = |j: u32| grid.tile_ndc(0, j);
    let x0 = lower_bound(grid.tiles_x, |i| passes(clip_edge_plane(proj, 0, col(i).1, -1.0), c, r));
    let x1_end = lower_bound(grid.tiles_x, |i| !passes(clip_edge_plane(proj, 0, col(i).0, 1.0), c, r));
    let y0 = lower_bound(grid.tiles_y, |j| passes(clip_edge_plane(proj, 1, row(j).2, 1.0), c, r));
    let y1_end = lower_bound(grid.tiles_y, |j| !passes(clip_edge_plane(proj, 1, row(j).3, -1.0), c, r));
    rect_of(grid, (x0, x1_end), (y0, y1_end))
}

/// Columns `x0..x1_end` and rows `y0..y1_end` as a rectangle, `None` when either is empty.
fn rect_of(grid: &TileGrid, (x0, x1_end): (u32, u32), (y0, y1_end): (u32, u32)) -> Option<TileRect> {
    if x0 == grid.tiles_x || x1_end == 0 || y0 == grid.tiles_y || y1_end == 0 {
        return None;
    }
    let (x1, y1) = (x1_end - 1, y1_end - 1);
    (x0 <= x1 && y0 <= y1).then_some(TileRect { x0, x1, y0, y1 })
}

/// Step 2 of [`light_tile_rect`]: the tiles that the part of a perspective sphere reaching
/// the eye plane in front of the near plane (nothing nearer is drawn) can cover. `None`
/// when the sphere lies wholly nearer than the near plane; the whole grid when a corner's
/// projection is not finite (a centre or radius near f32's range).
///
/// Why the corners bound it (exactly, not by sampling):
/// 1. Every surface point `p` a sample can show that the light reaches has `|p - c| <= r`
///    and `p.z <= -near` (nothing nearer is drawn), so it lies in the box
///    `B = [c.x - r, c.x + r] x [c.y - r, c.y + r] x [c.z - r, min(c.z + r, -near)]`,
///    wholly in front of the eye (`z <= -near < 0`).
/// 2. The camera's projection is glam's symmetric perspective, so
///    `ndc.x = P00 * x / -z` (and `ndc.y = P11 * y / -z`): a linear-fractional function
///    with a positive denominator on `B`. Its level sets are planes through the eye, so on
///    any segment of `B` it is monotone, and its minimum and maximum over the convex box
///    are attained at vertices: the eight corners. So `[lo, hi]` below contains the NDC of
///    every such `p`.
/// 3. A sample lies inside its pixel, at least 1/16 pixel from the pixel's edges (8x
///    MSAA's outermost standard position), so its tile's right edge is `>= ndc.x >= lo.x`
///    and its left edge `<= ndc.x <= hi.x`; the searches keep exactly the columns (rows)
///    with those two properties, the edges being monotone in the column.
/// 4. f32: each corner coordinate is one correctly rounded sum (half an ulp of itself),
///    the projection one product (`P00 * x`, the other terms exact zeros) and one division,
///    so a corner's NDC is within ~2 ulps relative of the exact value: under 1e-6 for a
///    bound that lies on the screen (`|ndc| <= 1`), far inside the 1/16 pixel margin of
///    step 3 (7.6e-6 in NDC at 16,384 px).
///
/// `crates/cull/tests/assign.rs` checks this against the exact (f64, tangent-line)
/// projected extent of the sphere's part beyond the near plane on every tile, edges
/// included, and checks that the projection has the assumed form.
pub fn near_cap_rect(grid: &TileGrid, proj: &Mat4, near: f32, c: Vec3, r: f32) -> Option<TileRect> {
    let z_lo = c.z - r;
    let z_hi = (c.z + r).min(-near);
    // Written as in WGSL, so NaN takes this branch.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(z_lo <= z_hi) {
        return None;
    }
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
    let mut finite = true;
    for corner in 0..8u32 {
        let p = Vec3::new(
            if corner & 1 == 0 { c.x - r } else { c.x + r },
            if corner & 2 == 0 { c.y - r } else { c.y + r },
            if corner & 4 == 0 { z_lo } else { z_hi },
        );
        let clip = *proj * p.extend(1.0);
        let ndc = glam::Vec2::new(clip.x, clip.y) / clip.w;
        finite &= ndc.is_finite();
        lo = lo.min(ndc);
        hi = hi.max(ndc);
    }
    if !finite {
        return Some(TileRect::full(grid));
    }
    // Columns whose right edge reaches lo.x and whose left edge stays below hi.x; rows (down
    // the screen) whose bottom edge is at most hi.y and whose top edge reaches lo.y.
    let x0 = lower_bound(grid.tiles_x, |i| grid.tile_ndc(i, 0).1 >= lo.x);
    let x1_end = lower_bound(grid.tiles_x, |i| grid.tile_ndc(i, 0).0 > hi.x);
    let y0 = lower_bound(grid.tiles_y, |j| grid.tile_ndc(0, j).2 <= hi.y);
    let y1_end = lower_bound(grid.tiles_y, |j| grid.tile_ndc(0, j).3 < lo.y);
    rect_of(grid, (x0, x1_end), (y0, y1_end))
}

/// The light-centric twin of [`crate::gather::cull_tiles_gather`]: same inputs, same per-tile
/// test (side planes, depth range, AABB, cone, half-z, depth mask, two-level candidates),
/// but each light only visits the tiles of its [`light_tile_rect`]. The lists come out
/// ascending as light indices are visited in order.
///
/// Equal to `cull_tiles` for every light wholly in front of the eye plane (the rectangle
/// holds every tile whose side planes the light passes, up to f32 rounding at the
/// boundary: none seen in the property tests); a light reaching the eye plane is missing
/// from tiles outside its [`near_cap_rect`], where it can reach no surface.
pub fn cull_tiles_scatter(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
    config: &CullConfig,
) -> Result<TileLists, CullError> {
    let (grid, vls, cells) = cull_setup(depth, (width, height), camera, lights, config)?;
    let proj = camera.proj();
    let dp = camera.depth_params();
    let ortho = dp.orthographic;
    let (volumes, masks, ranges) = tile_volumes(&grid, depth, camera, config);
    let per = config.lists_per_tile();
    let mut lists = vec![Vec::new(); grid.tile_count() * per];
    for (i, l) in vls.iter().enumerate() {
        let Some(rect) = light_tile_rect(&grid, &proj, &dp, l.center, l.radius) else { continue };
        for ty in rect.y0..=rect.y1 {
            for tx in rect.x0..=rect.x1 {
                let t = (ty * grid.tiles_x + tx) as usize;
                let Some(vols) = &volumes[t] else { continue };
                // Two-level culling: only the lights the tile's coarse cell kept (every light
                // when the cell overflowed), as `cull_tiles` does.
                if let Some((cgrid, cell_lists)) = &cells {
                    let (px, _, py, _) = grid.tile_pixels(tx, ty);
                    if let Some(cell) = &cell_lists[cgrid.tile_of_pixel(px, py)] {
                        if cell.binary_search(&(i as u32)).is_err() {
                            continue;
                        }
                    }
                }
                for (k, vol) in vols.iter().enumerate() {
                    if light_in_volume(l, vol, &proj, ortho, config, masks.as_ref().map(|m| m[t])) {
                        lists[t * per + k].push(i as u32);
                    }
                }
            }
        }
    }
    Ok(TileLists { grid, config: *config, lists, ranges, cluster: None })
}
