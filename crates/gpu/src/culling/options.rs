//! The options of light culling, shared by every kernel and the renderers: [`CullOptions`]
//! (the layout, the tests, the capacity, the grid budget; checked against the device and
//! turned into the light grid's layout and the CPU twin's configuration), the test-only
//! [`DropLight`] hook, and what every culling kernel reads the same way (the depth binding,
//! the depth variant). The gather kernel's own defines and constants are in
//! [`super::tile`].
//! Depends on wgpu, [`super::clusters`], [`crate::light_grid`] (the layout), [`crate::bindings`].

use crate::define::Define;
use tiledlight_cull::lists::{COARSE_SIZE, DEFAULT_CAPACITY, MAX_CAPACITY};
use tiledlight_cull::TileGrid;

use super::clusters::{check_on_gpu, ClusterOptions};
use crate::bindings::{Binding, Cond};
use crate::error::GpuError;
use crate::light_grid::GridLayout;

/// Options of the culling pass (mirrors `tiledlight_cull::CullConfig`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CullOptions {
    /// Tile side: 8, 16 or 32.
    pub tile_size: u32,
    /// Indices of the kernel's workgroup list. A longer list is not truncated: it is
    /// culled a second time straight into the light grid (slower, so size it to hold the
    /// usual lists: the app uses the light count up to the workgroup memory).
    pub capacity: u32,
    /// Also test spheres against the tile's view-space AABB.
    pub aabb: bool,
    /// Two lists per tile split at the middle of its depth range.
    pub half_z: bool,
    /// Also test spot cones (ignored when the scene has no spot lights).
    pub spot_cone: bool,
    /// Two-level culling: a first pass culls lights per 64x64-pixel cell and each tile
    /// tests only its cell's survivors (see `tiledlight_cull::CullConfig::coarse`).
    pub coarse: bool,
    /// Samples per pixel of the depth buffer the pass reads (1, 2, 4 or 8): the renderers
    /// set it from their MSAA setting; tiles then bound every sample's depth.
    pub samples: u32,
    /// A fixed light-grid budget in indices (pairs beyond it are dropped and reported);
    /// `None`: sized from the frame's pairs and grown when a frame needs more.
    pub grid_pairs: Option<u32>,
    /// 2.5D culling (Harada 2012): a light must also meet one of 32 depth bins of the
    /// tile's range that holds a surface. One list per tile: not with half-z.
    pub depth_mask: bool,
    /// Light-centric assignment ([`super::scatter`]): each light scatters itself into
    /// the tiles it covers (cost ~ lights + pairs) instead of each tile testing every light
    /// (cost ~ lights x tiles). Same lists. Two-level culling does not apply.
    pub scatter: bool,
    /// The clustered layout instead of tiles (always assigned light-centrically; sphere,
    /// side planes and depth slices only: the AABB and cone tests do not apply).
    pub clusters: Option<ClusterOptions>,
}

impl Default for CullOptions {
    fn default() -> Self {
        Self {
            tile_size: 16,
            capacity: DEFAULT_CAPACITY,
            aabb: false,
            half_z: false,
            spot_cone: false,
            coarse: true,
            samples: 1,
            grid_pairs: None,
            depth_mask: false,
            scatter: false,
            clusters: None,
        }
    }
}

impl CullOptions {
    /// Checks the tile size against `grid` and the capacity against [`MAX_CAPACITY`] and
    /// the workgroup memory left after `reserved` bytes (the rest of the kernel).
    pub fn validate(&self, grid: &TileGrid, reserved: u32, limits: &wgpu::Limits) -> Result<(), GpuError> {
        if ![8, 16, 32].contains(&self.tile_size) || grid.tile_size != self.tile_size {
            return Err(GpuError::Config(format!(
                "tile size {} must be 8, 16 or 32 (and match the grid's {})",
                self.tile_size, grid.tile_size
            )));
        }
        if self.depth_mask && self.half_z {
            return Err(GpuError::Config("2.5D culling and half-z are alternative layouts: pick one".into()));
        }
        if let Some(c) = &self.clusters {
            check_on_gpu(c)?;
            if self.half_z || self.depth_mask {
                return Err(GpuError::Config(
                    "the clustered layout slices depth itself: not with half-z or 2.5D culling".into(),
                ));
            }
        }
        if self.capacity == 0 || self.capacity > MAX_CAPACITY {
            return Err(GpuError::Config(format!("per-tile capacity {} must be in 1..={MAX_CAPACITY}", self.capacity)));
        }
        if self.coarse && !self.assigned() && !COARSE_SIZE.is_multiple_of(self.tile_size) {
            return Err(GpuError::Config(format!("two-level culling needs a tile size dividing {COARSE_SIZE}")));
        }
        let wg_bytes = self.capacity * 4 * if self.half_z { 2 } else { 1 } + reserved;
        if wg_bytes > limits.max_compute_workgroup_storage_size {
            return Err(GpuError::Limit {
                what: format!(
                    "a tile list of capacity {} in workgroup memory{}",
                    self.capacity,
                    if reserved > CULL_WORKGROUP_BYTES { " with the MSAA edge queue" } else { "" }
                ),
                name: "max_compute_workgroup_storage_size",
                limit: limits.max_compute_workgroup_storage_size.into(),
                asked: format!("{wg_bytes} bytes"),
            });
        }
        Ok(())
    }

    /// The light grid's layout for these options on `grid` (`ranges`: keep the half-z
    /// depth ranges for lookups by pixel).
    /// With clusters, the grid's tiles are the clusters' (of their own size); light-centric
    /// assignment always keeps the tile ranges (its tile-depth pass writes them).
    pub fn grid_layout(&self, grid: TileGrid, ranges: bool) -> Result<GridLayout, GpuError> {
        let tiles = match &self.clusters {
            Some(c) => c.grid(grid.width, grid.height)?,
            None => grid,
        };
        Ok(GridLayout {
            tiles,
            lists_per_tile: self.lists_per_tile(),
            list_capacity: self.capacity,
            ranges: ranges || self.assigned(),
            slicing: self.clusters.map(|c| (c.first, c.scale())),
        })
    }

    /// True when the lists are assigned light-centrically ([`Self::scatter`], or clusters).
    pub fn assigned(&self) -> bool {
        self.scatter || self.clusters.is_some()
    }

    /// The CPU reference configuration running the same tests.
    pub fn to_config(&self, has_spots: bool) -> tiledlight_cull::CullConfig {
        tiledlight_cull::CullConfig {
            tile_size: self.tile_size,
            capacity: self.capacity,
            aabb: self.aabb,
            half_z: self.half_z,
            spot_cone: self.spot_cone && has_spots,
            // Two-level culling may drop a false positive the flat test keeps; assignment is
            // flat.
            coarse: self.coarse && !self.assigned(),
            inflate: 0.0,
            samples: self.samples,
            depth_mask: self.depth_mask,
            // The clustered twin uses the same rectangles on its own.
            scatter: self.scatter && self.clusters.is_none(),
        }
    }

    /// The capacity that holds every light of a `num_lights` scene in every list, as far as
    /// the device's workgroup memory allows once `reserved` bytes are set aside for the rest
    /// of the kernel ([`CULL_WORKGROUP_BYTES`] for the culling pass; Tiled Deferred's MSAA
    /// edge queue needs more). With WebGPU's default 16 KiB: 2048 a list without half-z,
    /// 2046 with. Overflow then only happens when a tile really sees more lights.
    pub fn capacity_for(num_lights: u32, half_z: bool, reserved: u32, limits: &wgpu::Limits) -> u32 {
        let lists = if half_z { 2 } else { 1 };
        let fits = (limits.max_compute_workgroup_storage_size.saturating_sub(reserved)) / (4 * lists);
        num_lights.clamp(1, MAX_CAPACITY.min(fits).max(1))
    }

    /// Whether every kernel reading the depth buffer has its `MSAA` variant
    /// (`shaders/common/depth_range.wgsl`), and its override constant.
    pub fn depth_variant(&self) -> (bool, Option<(&'static str, f64)>) {
        if self.samples > 1 {
            (true, Some(("SAMPLES", self.samples as f64)))
        } else {
            (false, None)
        }
    }

    /// The options of the blended geometry's culling: the same tile size, capacity and
    /// samples, one list per tile (no half-z), one level, sphere and plane tests only (the
    /// blended range may reach infinitely far, over the sky, where the AABB and cone tests'
    /// corners are not finite).
    pub fn for_blended(&self) -> Self {
        Self {
            half_z: false,
            coarse: false,
            aabb: false,
            spot_cone: false,
            depth_mask: false,
            scatter: false,
            clusters: None,
            ..*self
        }
    }

    /// Lists per tile: the slices with clusters, 2 with half-z, else 1.
    pub fn lists_per_tile(&self) -> u32 {
        match (&self.clusters, self.half_z) {
            (Some(c), _) => c.slices,
            (None, true) => 2,
            (None, false) => 1,
        }
    }
}

/// Test-only hook: tile `tile` (row-major tile index) leaves light `light` out of its lists
/// (both lists with half-z), as if culling had wrongly rejected it. Tests use it to prove
/// the image comparisons with the brute-force reference fail on one missing light; the
/// renderers' settings default to `None` and production never sets it, so the `DROP_LIGHT`
/// variant of `shaders/common/tile_cull.wgsl` is never compiled there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DropLight {
    /// Row-major tile index.
    pub tile: u32,
    /// Index of the light in the packed (points first) light list.
    pub light: u32,
}

impl DropLight {
    /// Checks the tile and light exist (a hook that names neither would silently drop
    /// nothing, and a negative test relying on it would prove nothing).
    pub fn check(&self, grid: &TileGrid, num_lights: u32) -> Result<(), GpuError> {
        if self.tile as usize >= grid.tile_count() || self.light >= num_lights {
            return Err(GpuError::Config(format!(
                "test hook drops light {} from tile {}, but there are {num_lights} lights and {} tiles",
                self.light,
                self.tile,
                grid.tile_count()
            )));
        }
        Ok(())
    }

    /// Whether a kernel that includes `common/tile_cull.wgsl` has its `DROP_LIGHT` variant,
    /// and the hook's override constants.
    pub fn variant(drop: Option<DropLight>) -> (bool, Vec<(&'static str, f64)>) {
        match drop {
            Some(d) => (true, vec![("DROP_TILE", d.tile as f64), ("DROP_INDEX", d.light as f64)]),
            None => (false, Vec::new()),
        }
    }
}

/// Workgroup memory of the culling kernel besides its lists (bytes): the depth range, the
/// two list counts and, per list, the grid writer's first index, stored count and spill
/// counter (`shaders/common/depth_range.wgsl`, `common/tile_cull.wgsl`,
/// `common/light_grid_write.wgsl`).
pub const CULL_WORKGROUP_BYTES: u32 = 40;

/// The depth texture a culling kernel reads at group 1 binding 0
/// (`shaders/common/depth_range.wgsl`): multisampled with `MSAA`; unfilterable float, so
/// a `Depth32Float` view and the compute raster's `R32Float` depth both bind.
pub const DEPTH_BINDING: Binding =
    Binding::texture(0, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Float { filterable: false })
        .multisampled_when(Cond::Defined(Define::Msaa));

#[cfg(test)]
mod tests {
    use super::{CullOptions, CULL_WORKGROUP_BYTES};

    #[test]
    fn capacity_follows_lights_up_to_workgroup_memory() {
        let limits = wgpu::Limits::default(); // 16 KiB of workgroup memory
        let r = CULL_WORKGROUP_BYTES;
        assert_eq!(CullOptions::capacity_for(0, false, r, &limits), 1);
        assert_eq!(CullOptions::capacity_for(1024, false, r, &limits), 1024);
        assert_eq!(CullOptions::capacity_for(100_000, false, r, &limits), 2048);
        // (16384 - 40) / 8.
        assert_eq!(CullOptions::capacity_for(100_000, true, r, &limits), 2043);
        let small = wgpu::Limits { max_compute_workgroup_storage_size: 4096, ..limits };
        assert_eq!(CullOptions::capacity_for(100_000, true, r, &small), 507);
        // A 16 px tile's MSAA edge queue (1 KiB + 8 bytes) comes out of the lists.
        assert_eq!(CullOptions::capacity_for(100_000, true, r + 8 + 1024, &limits), 1914);
    }
}
