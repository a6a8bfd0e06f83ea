//! What culling produces and how it is laid out: the tile layouts' options
//! ([`CullConfig`]: tiles, half-z, 2.5D, two-level, light-centric), the clustered layout
//! ([`ClusterConfig`]), the per-list lights ([`TileLists`]) and the limits the GPU kernels
//! share (capacities, the coarse cells). The building block every culler and its users
//! start from: no culling code here.
//! Depends on [`crate::tiles`] (the grid) and [`crate::error`].

use crate::error::CullError;
use crate::tiles::TileGrid;

/// Default per-list capacity of the library types (the app picks the light count, up to
/// 2048, instead). Enough for the default scene up to about 4k lights (longest list 306 at
/// 4,096 lights; 1,209 at 16,384, which overflows it).
pub const DEFAULT_CAPACITY: u32 = 512;
/// Largest per-list capacity the GPU kernel accepts (its workgroup list lives in 16 KiB).
pub const MAX_CAPACITY: u32 = 2048;
/// Side in pixels of the coarse cells of two-level culling (a multiple of every tile size).
pub const COARSE_SIZE: u32 = 64;
/// Light indices a coarse cell stores; a cell with more falls back to testing every light.
pub const COARSE_CAPACITY: u32 = 8192;

/// What the culler tests and how lists are stored. Mirrors the GPU pass's options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CullConfig {
    /// Tile side in pixels (8, 16 or 32 on the GPU; any 1..=64 on the CPU).
    pub tile_size: u32,
    /// Indices stored per list at most; the count still reports every light found.
    pub capacity: u32,
    /// Also test the sphere against the tile's view-space AABB (removes the large-sphere
    /// false positives of plane tests).
    pub aabb: bool,
    /// Two lists per tile, split at the middle of the tile's depth range.
    pub half_z: bool,
    /// Also test spot cones against the tile's bounding sphere.
    pub spot_cone: bool,
    /// Two-level culling: lights are first culled against 64x64-pixel cells (planes and
    /// depth range only), and each tile tests only its cell's survivors (every light when
    /// the cell overflowed [`COARSE_CAPACITY`]). The cell volume contains the tile's, so
    /// this stays conservative; it may drop a false positive the flat test would keep.
    pub coarse: bool,
    /// CPU only: grow (>0) or shrink (<0) every light's radius by this fraction of
    /// `radius + |centre|`, to find decisions within float error of the boundary.
    pub inflate: f32,
    /// Depth samples per pixel (MSAA: 1, 2, 4 or 8). The depth buffer holds `samples`
    /// values per pixel, pixel-major; a tile's depth range covers every sample, as the
    /// GPU kernel's does over a multisampled depth buffer.
    pub samples: u32,
    /// 2.5D culling (Harada 2012): each tile also keeps a 32-bit mask of the depth bins
    /// (of its own depth range) that hold a surface, and a light must overlap one of them
    /// ([`crate::depth_mask`]). One list per tile: not with `half_z`.
    pub depth_mask: bool,
    /// Light-centric assignment's lists: each light visits only the tiles of its
    /// [`crate::assign::light_tile_rect`], which for a light reaching the eye plane leaves
    /// out tiles its part beyond the near plane cannot cover (the per-tile test's false
    /// positives there); [`crate::cull_tiles`] then runs [`crate::assign::cull_tiles_scatter`].
    pub scatter: bool,
}

impl Default for CullConfig {
    fn default() -> Self {
        Self {
            tile_size: 16,
            capacity: DEFAULT_CAPACITY,
            aabb: false,
            half_z: false,
            spot_cone: false,
            coarse: false,
            inflate: 0.0,
            samples: 1,
            depth_mask: false,
            scatter: false,
        }
    }
}

impl CullConfig {
    /// Lists per tile: 2 with half-z, else 1.
    pub fn lists_per_tile(&self) -> usize {
        if self.half_z {
            2
        } else {
            1
        }
    }

    /// Checks the options the GPU kernel relies on.
    pub fn validate(&self) -> Result<(), CullError> {
        if self.capacity == 0 || self.capacity > MAX_CAPACITY {
            return Err(CullError::InvalidSize(format!(
                "per-tile capacity {} must be in 1..={MAX_CAPACITY}",
                self.capacity
            )));
        }
        if self.coarse && !COARSE_SIZE.is_multiple_of(self.tile_size) {
            return Err(CullError::InvalidSize(format!(
                "two-level culling needs a tile size dividing {COARSE_SIZE}, not {}",
                self.tile_size
            )));
        }
        if !matches!(self.samples, 1 | 2 | 4 | 8) {
            return Err(CullError::InvalidSize(format!(
                "{} depth samples per pixel: must be 1, 2, 4 or 8",
                self.samples
            )));
        }
        if self.depth_mask && self.half_z {
            return Err(CullError::InvalidSize(
                "depth_mask (2.5D) and half_z are alternative layouts of one tile's depth range; turn one off".into(),
            ));
        }
        if !self.inflate.is_finite() {
            return Err(CullError::InvalidSize(format!("inflate {} is not finite", self.inflate)));
        }
        Ok(())
    }
}

/// Per-tile light lists. List `i` of tile `t` is `lists[t * lists_per_tile + i]`
/// ([`TileLists::lists_per_tile`]); with half-z, list 0 covers the near half of the tile's
/// depth range; with clusters (`cluster` is `Some`), list `i` is depth slice `i`. Which
/// layout made them: `cluster`, `config.half_z`, `config.depth_mask`.
#[derive(Clone, Debug, PartialEq)]
pub struct TileLists {
    /// The tiling.
    pub grid: TileGrid,
    /// The options used.
    pub config: CullConfig,
    /// Every light found per list, ascending (not truncated: the GPU stores at most
    /// `capacity` of them, in no particular order).
    pub lists: Vec<Vec<u32>>,
    /// Per tile, the view-distance range of its surfaces (None for all-sky tiles). For
    /// blended lists ([`crate::cull_tiles_blended`]): from the nearest blended surface to the
    /// farthest opaque one behind it (`f32::INFINITY` where that is sky under an infinite
    /// far plane), None for tiles without blended geometry.
    pub ranges: Vec<Option<(f32, f32)>>,
    /// `Some` for clustered lists ([`crate::cluster::cull_clusters`]): `slices` lists per
    /// tile, list `t * slices + s` for depth slice `s`; `None` for the tile layouts, whose
    /// lists per tile `config` gives.
    pub cluster: Option<ClusterConfig>,
}

impl TileLists {
    /// Number of lists whose light count exceeds the capacity.
    pub fn overflowing_lists(&self) -> usize {
        self.lists.iter().filter(|l| l.len() > self.config.capacity as usize).count()
    }

    /// Lists per tile: the cluster slices, else 2 with half-z, else 1.
    pub fn lists_per_tile(&self) -> usize {
        self.cluster.map_or(self.config.lists_per_tile(), |c| c.slices as usize)
    }

    /// The list a pixel at view distance `dist` of tile `tile` uses.
    pub fn list_index(&self, tile: usize, dist: f32) -> usize {
        if let Some(c) = &self.cluster {
            return tile * c.slices as usize + c.slice_of(dist) as usize;
        }
        if !self.config.half_z {
            return tile;
        }
        match self.ranges[tile] {
            Some((near, far)) if dist > half_z_split(near, far) => tile * 2 + 1,
            _ => tile * 2,
        }
    }
}

/// The distance where half-z splits a tile's range `[near, far]`.
pub fn half_z_split(near: f32, far: f32) -> f32 {
    0.5 * (near + far)
}

/// Per coarse cell, its lights, or `None` when the cell overflowed.
pub type CellLists = Vec<Option<Vec<u32>>>;

/// Largest number of depth slices (one bit each in the occupancy mask).
pub const MAX_SLICES: u32 = 32;

/// The cluster layout: tile size, depth slices and where they start and end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterConfig {
    /// Tile side in pixels, 8..=512.
    pub tile_size: u32,
    /// Depth slices, 1..=32.
    pub slices: u32,
    /// Far end of slice 0 (metres, > 0): slice 0 is `[0, first)`.
    pub first: f32,
    /// End of the exponential slices (metres, > `first`); the last slice runs on to infinity.
    pub last: f32,
    /// Keep a light only in slices that hold a surface of the tile (its occupancy mask).
    pub geometry_only: bool,
}

impl Default for ClusterConfig {
    /// 64 px tiles, 16 slices, first slice 5 m, exponential slices to 500 m.
    fn default() -> Self {
        Self { tile_size: 64, slices: 16, first: 5.0, last: 500.0, geometry_only: false }
    }
}

impl ClusterConfig {
    /// Checks the ranges (and that `ln(last / first)` is positive in f32, so `scale` is
    /// finite).
    pub fn validate(&self) -> Result<(), CullError> {
        let bad = |m: String| Err(CullError::InvalidSize(m));
        if !(8..=512).contains(&self.tile_size) {
            return bad(format!("cluster tile size {} must be in 8..=512", self.tile_size));
        }
        if !(1..=MAX_SLICES).contains(&self.slices) {
            return bad(format!("{} cluster slices: must be in 1..={MAX_SLICES}", self.slices));
        }
        if !(self.first.is_finite() && self.first > 0.0) {
            return bad(format!("first slice end {} must be finite and positive", self.first));
        }
        if !(self.last.is_finite() && self.last > self.first) {
            return bad(format!("last slice end {} must be finite and beyond first {}", self.last, self.first));
        }
        let scale = self.scale();
        if self.slices > 1 && !(scale.is_finite() && scale > 0.0) {
            return bad(format!(
                "last {} / first {} is too close to 1 for {} slices (scale {scale})",
                self.last, self.first, self.slices
            ));
        }
        Ok(())
    }

    /// Exponential slices per unit of `ln(d / first)`: `(slices - 1) / ln(last / first)`,
    /// 0 with one slice.
    pub fn scale(&self) -> f32 {
        if self.slices == 1 {
            0.0
        } else {
            (self.slices - 1) as f32 / (self.last / self.first).ln()
        }
    }

    /// The slice of view distance `d`: 0 below `first` (and for 0, negative or NaN
    /// distances), else `1 + min(ln(d / first) * scale, slices - 2)` truncated; monotone
    /// non-decreasing in `d`, `slices - 1` for `d = inf`.
    pub fn slice_of(&self, d: f32) -> u32 {
        // Written as in WGSL, so NaN takes this branch.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if self.slices == 1 || !(d >= self.first) {
            return 0;
        }
        // d >= first, so d / first >= 1 and x >= 0 (inf for d = inf, clamped below).
        let x = (d / self.first).ln() * self.scale();
        1 + x.min((self.slices - 2) as f32) as u32
    }

    /// The view-distance range `[start, end)` of slice `s`, for documentation and
    /// statistics (assignment uses [`Self::slice_of`] only): slice 0 is `[0, first)`, slice
    /// `s >= 1` is `[first * q^((s - 1) / (S - 1)), first * q^(s / (S - 1)))` with
    /// `q = last / first`, and the last slice ends at infinity.
    pub fn slice_range(&self, s: u32) -> (f32, f32) {
        let n = self.slices;
        let at = |k: u32| self.first * (self.last / self.first).powf(k as f32 / (n - 1) as f32);
        let start = if s == 0 { 0.0 } else { at(s - 1) };
        let end = if s + 1 >= n {
            f32::INFINITY
        } else if s == 0 {
            self.first
        } else {
            at(s)
        };
        (start, end)
    }

    /// The tile grid of a `width` x `height` screen (the screen checked as
    /// [`TileGrid::new`] checks it; tiles may be larger than its 64 px limit).
    pub fn grid(&self, width: u32, height: u32) -> Result<TileGrid, CullError> {
        self.validate()?;
        TileGrid::new(width, height, 1)?;
        let ts = self.tile_size;
        Ok(TileGrid { width, height, tile_size: ts, tiles_x: width.div_ceil(ts), tiles_y: height.div_ceil(ts) })
    }
}
