//! Screen tiling and per-tile view volumes: the tile grid for any screen and tile size
//! (partial edge tiles), each tile's four side planes and its depth range from the min/max
//! of its pixels' reversed-Z depths (sky pixels, depth 0, excluded). Depends on glam and
//! [`crate::camera`].

use glam::{Mat4, Vec3, Vec4};

use crate::camera::{clip_edge_plane, view_point_at, Camera, DepthParams};
use crate::error::CullError;

/// Largest screen side accepted (wgpu's texture limit on most adapters).
pub const MAX_SCREEN_SIDE: u32 = 16384;

/// A screen divided into square tiles; the last row and column may be partial.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileGrid {
    /// Screen width in pixels.
    pub width: u32,
    /// Screen height in pixels.
    pub height: u32,
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Tiles per row.
    pub tiles_x: u32,
    /// Tiles per column.
    pub tiles_y: u32,
}

impl TileGrid {
    /// A grid for a `width` x `height` screen with `tile_size` square tiles.
    pub fn new(width: u32, height: u32, tile_size: u32) -> Result<Self, CullError> {
        if width == 0 || height == 0 {
            return Err(CullError::InvalidSize(format!("screen {width}x{height} has no pixels")));
        }
        if width > MAX_SCREEN_SIDE || height > MAX_SCREEN_SIDE {
            return Err(CullError::InvalidSize(format!(
                "screen {width}x{height} exceeds {MAX_SCREEN_SIDE} pixels a side"
            )));
        }
        if tile_size == 0 || tile_size > 64 {
            return Err(CullError::InvalidSize(format!("tile size {tile_size} must be in 1..=64")));
        }
        Ok(Self { width, height, tile_size, tiles_x: width.div_ceil(tile_size), tiles_y: height.div_ceil(tile_size) })
    }

    /// Number of tiles.
    pub fn tile_count(&self) -> usize {
        self.tiles_x as usize * self.tiles_y as usize
    }

    /// Tile index (row-major) of pixel (x, y).
    pub fn tile_of_pixel(&self, x: u32, y: u32) -> usize {
        (y / self.tile_size) as usize * self.tiles_x as usize + (x / self.tile_size) as usize
    }

    /// Pixel bounds `[x0, x1) x [y0, y1)` of a tile (row 0 at the top of the screen).
    pub fn tile_pixels(&self, tx: u32, ty: u32) -> (u32, u32, u32, u32) {
        let x0 = tx * self.tile_size;
        let y0 = ty * self.tile_size;
        (x0, (x0 + self.tile_size).min(self.width), y0, (y0 + self.tile_size).min(self.height))
    }

    /// NDC rectangle of a tile: (left, right, bottom, top), y up. Same arithmetic as
    /// `tile_ndc` in `shaders/common/cull_tests.wgsl`.
    pub fn tile_ndc(&self, tx: u32, ty: u32) -> (f32, f32, f32, f32) {
        let (x0, x1, y0, y1) = self.tile_pixels(tx, ty);
        (
            pixel_to_ndc_x(x0 as f32, self.width),
            pixel_to_ndc_x(x1 as f32, self.width),
            pixel_to_ndc_y(y1 as f32, self.height),
            pixel_to_ndc_y(y0 as f32, self.height),
        )
    }
}

/// NDC x of a pixel-space x coordinate (pixel edges at integers, centres at +0.5).
pub fn pixel_to_ndc_x(x: f32, width: u32) -> f32 {
    2.0 * x / width as f32 - 1.0
}

/// NDC y (up) of a pixel-space y coordinate (row 0 at the top).
pub fn pixel_to_ndc_y(y: f32, height: u32) -> f32 {
    1.0 - 2.0 * y / height as f32
}

/// The min/max reversed-Z depth of a tile's non-sky pixels, or `None` when all are sky.
/// `max_depth` is the nearest surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthBounds {
    /// Smallest depth (farthest surface).
    pub min_depth: f32,
    /// Largest depth (nearest surface).
    pub max_depth: f32,
}

/// Min/max over the non-sky (depth > 0) pixels of tile (tx, ty) of a row-major depth buffer.
pub fn tile_depth_bounds(grid: &TileGrid, depth: &[f32], tx: u32, ty: u32) -> Option<DepthBounds> {
    tile_depth_bounds_samples(grid, depth, 1, tx, ty)
}

/// Min/max over the non-sky samples of tile (tx, ty) of a row-major depth buffer holding
/// `samples` values per pixel, pixel-major (a multisampled buffer read back sample by sample).
pub fn tile_depth_bounds_samples(
    grid: &TileGrid,
    depth: &[f32],
    samples: u32,
    tx: u32,
    ty: u32,
) -> Option<DepthBounds> {
    let mut lo = f32::INFINITY;
    let mut hi = 0.0f32;
    for span in tile_sample_spans(grid, samples, tx, ty) {
        for &d in &depth[span] {
            if d > 0.0 {
                lo = lo.min(d);
                hi = hi.max(d);
            }
        }
    }
    (hi > 0.0).then_some(DepthBounds { min_depth: lo, max_depth: hi })
}

/// The index ranges of tile (tx, ty)'s samples in a row-major buffer holding `samples`
/// values per pixel, pixel-major: one range per pixel row of the tile.
pub fn tile_sample_spans(
    grid: &TileGrid,
    samples: u32,
    tx: u32,
    ty: u32,
) -> impl Iterator<Item = std::ops::Range<usize>> {
    let (x0, x1, y0, y1) = grid.tile_pixels(tx, ty);
    let (s, width) = (samples as usize, grid.width as usize);
    (y0 as usize..y1 as usize).map(move |y| (y * width + x0 as usize) * s..(y * width + x1 as usize) * s)
}

/// A tile's view volume: four side planes (normals inward, view space) and the view
/// distance range of its surfaces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileFrustum {
    /// Left, right, bottom, top planes: `dot(p.xyz, x) + p.w >= 0` inside.
    pub planes: [Vec4; 4],
    /// NDC rectangle (left, right, bottom, top).
    pub ndc: (f32, f32, f32, f32),
    /// Nearest surface distance (from the max depth).
    pub near: f32,
    /// Farthest surface distance (from the min depth).
    pub far: f32,
}

impl TileFrustum {
    /// The view volume of tile (tx, ty) between the distances of `bounds`.
    pub fn new(grid: &TileGrid, camera: &Camera, tx: u32, ty: u32, bounds: DepthBounds) -> Self {
        let dp = camera.depth_params();
        Self::from_parts(
            &camera.proj(),
            &dp,
            grid.tile_ndc(tx, ty),
            dp.view_distance(bounds.max_depth),
            dp.view_distance(bounds.min_depth),
        )
    }

    /// From a projection, NDC rectangle and distance range (used by the half-z split too).
    pub fn from_parts(proj: &Mat4, _dp: &DepthParams, ndc: (f32, f32, f32, f32), near: f32, far: f32) -> Self {
        let (l, r, b, t) = ndc;
        let planes = [
            clip_edge_plane(proj, 0, l, 1.0),
            clip_edge_plane(proj, 0, r, -1.0),
            clip_edge_plane(proj, 1, b, 1.0),
            clip_edge_plane(proj, 1, t, -1.0),
        ];
        Self { planes, ndc, near, far }
    }

    /// The same side planes over another distance range.
    pub fn with_range(&self, near: f32, far: f32) -> Self {
        Self { near, far, ..*self }
    }

    /// The view-space AABB of the volume: the tile's four corner rays between `near` and `far`.
    pub fn aabb(&self, proj: &Mat4, orthographic: bool) -> (Vec3, Vec3) {
        let (l, r, b, t) = self.ndc;
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for d in [self.near, self.far] {
            for (x, y) in [(l, b), (r, b), (l, t), (r, t)] {
                let p = view_point_at(proj, orthographic, x, y, d);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo, hi)
    }
}
