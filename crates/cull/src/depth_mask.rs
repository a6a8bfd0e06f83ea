//! 2.5D culling (Harada 2012): a 32-bit depth-occupancy mask per tile, ANDed with each
//! light's mask of the bins its sphere spans, so a light in the empty gap between two
//! surfaces of a tile (a near pane and a far wall) is dropped although it lies inside the
//! tile's min/max depth range. The GPU kernel mirrors these formulas in f32. Depends on
//! [`crate::camera`] (view distances) and [`crate::tiles`] (which samples a tile has).
//!
//! 1. A tile's range `[near, far]` is its frustum's: `view_distance` of its max and min
//!    non-sky depth ([`crate::tiles::TileFrustum::new`]).
//! 2. [`depth_bin`] cuts it into [`DEPTH_MASK_BINS`] equal bins; values outside clamp to
//!    the first or last bin.
//! 3. The tile mask ORs `1 << depth_bin(view_distance(d))` over the tile's non-sky samples.
//! 4. A light (view-space centre `c`, radius `r`, `dist = -c.z`) covers bins
//!    `depth_bin(dist - r) ..= depth_bin(dist + r)` ([`light_depth_mask`]).
//! 5. The light stays in the tile's list when the two masks share a bit (after the side
//!    planes, depth range, AABB and cone tests). `depth_bin` is monotone in `d`, and every
//!    point of the sphere has a view distance in `[dist - r, dist + r]`, so a sample the
//!    light reaches has its bin inside the light's: no false negatives.

use crate::camera::Camera;
use crate::tiles::{tile_depth_bounds_samples, tile_sample_spans, TileGrid};

/// Bins of a tile's depth mask (one `u32`).
pub const DEPTH_MASK_BINS: u32 = 32;

/// The bin of view distance `d` in a tile's range `[near, far]`, in `0..32`.
///
/// `inv = 32 / (far - near)` when `far > near`, else 0, and 0 too when not finite (an
/// infinitely far surface, or a range so thin that the quotient overflows): every value
/// then falls in bin 0. `x = (d - near) * inv`, clamped to `[0, 31]` and truncated.
///
/// NaN: `x` is NaN only when `inv == 0` and `d - near` is infinite or NaN (a sample at
/// infinite distance under an infinite far plane, where `inf * 0 = NaN`). Rust's
/// `f32::max` ignores a NaN operand, so that gives bin 0, the value every finite `d` gets
/// when `inv == 0`. WGSL leaves `max` of NaN undefined, so the GPU must not compute
/// `(d - near) * inv` when `inv == 0`: `x = select((d - near) * inv, 0.0, inv == 0.0)`,
/// which is this function's value for every input. The branch below spells it out.
pub fn depth_bin(d: f32, near: f32, far: f32) -> u32 {
    let mut inv = if far > near { DEPTH_MASK_BINS as f32 / (far - near) } else { 0.0 };
    if !inv.is_finite() {
        inv = 0.0;
    }
    // Identical to `(d - near) * inv` clamped below, for every input (see the docs).
    let x = if inv == 0.0 { 0.0 } else { (d - near) * inv };
    x.max(0.0).min((DEPTH_MASK_BINS - 1) as f32) as u32
}

/// A light's bins in a tile's range `[near, far]`: view distance `dist` of its centre
/// (`-c.z`), radius `r`; bits `depth_bin(dist - r) ..= depth_bin(dist + r)`.
pub fn light_depth_mask(dist: f32, r: f32, near: f32, far: f32) -> u32 {
    let lo = depth_bin(dist - r, near, far);
    let hi = depth_bin(dist + r, near, far);
    (u32::MAX >> (31 - hi)) & (u32::MAX << lo)
}

/// Per tile (row-major), the OR of `1 << depth_bin` of its non-sky samples' view distances
/// over the tile's range; 0 for all-sky tiles. `depth` is reversed-Z, row-major, `samples`
/// values per pixel, pixel-major (as the culler reads it): what the GPU kernel computes,
/// for comparing its masks.
///
/// # Panics
///
/// If `depth` holds fewer than `grid.width * grid.height * samples` values.
pub fn tile_depth_masks(depth: &[f32], grid: &TileGrid, samples: u32, camera: &Camera) -> Vec<u32> {
    let dp = camera.depth_params();
    let mut masks = vec![0u32; grid.tile_count()];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            let Some(b) = tile_depth_bounds_samples(grid, depth, samples, tx, ty) else { continue };
            // The frustum's own range (`TileFrustum::new`): max depth is the nearest.
            let (near, far) = (dp.view_distance(b.max_depth), dp.view_distance(b.min_depth));
            let mut m = 0u32;
            for span in tile_sample_spans(grid, samples, tx, ty) {
                for &d in &depth[span] {
                    if d > 0.0 {
                        m |= 1 << depth_bin(dp.view_distance(d), near, far);
                    }
                }
            }
            masks[(ty * grid.tiles_x + tx) as usize] = m;
        }
    }
    masks
}
