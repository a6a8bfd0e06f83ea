//! Light culling by technique: which lights may touch each tile (or cluster), written into
//! the light grid ([`crate::light_grid`]) that every shading path reads.
//!
//! - [`options`]: [`CullOptions`] (layout, tests, capacity, grid budget), the test-only
//!   [`DropLight`] hook, and what every kernel reads alike ([`DEPTH_BINDING`]).
//! - [`tile`]: tile-centric gather, a workgroup per tile testing every light (of its cell,
//!   with two-level culling: [`CoarseCulling`]); `shaders/cull.wgsl`, `cull_coarse.wgsl`.
//! - [`scatter`]: light-centric assignment, each light writing itself into the tiles or
//!   clusters it covers ([`LightAssign`]); `shaders/tile_depth.wgsl`, `assign.wgsl`.
//! - [`clusters`]: the clustered layout's options ([`ClusterOptions`]) and its variant of
//!   the scatter kernels (clusters are always assigned light-centrically).
//! - This module: the façade [`LightCulling`], which picks the technique from the options
//!   and owns the grid it fills (its growth lives with the grid: [`LightGrid::grow`]).
//!
//! The modules depend downwards only: `options` on `clusters`; `tile` and `scatter` on
//! `options`; this façade on all of them (`cargo xtask circles` checks there is no circle).
//! The CPU twins are in `tiledlight_cull` (`gather`, `assign`, `cluster`).
//! Depends on wgpu, [`crate::light_grid`], [`crate::light_buffers`], [`crate::view`],
//! [`crate::bindings`].

pub mod clusters;
pub mod options;
pub mod scatter;
pub mod tile;

use tiledlight_cull::TileGrid;

use crate::error::GpuError;
use crate::handles::Depth;
use crate::light_buffers::LightBuffers;
use crate::light_grid::LightGrid;
use crate::memory::MemoryReport;
use crate::timer::GpuTimer;
use crate::view::Views;

pub use crate::light_grid::GpuTileLists;
pub use clusters::{ClusterOptions, CLUSTER_TILE_SIZES};
pub use options::{CullOptions, DropLight, CULL_WORKGROUP_BYTES, DEPTH_BINDING};
pub use scatter::LightAssign;
pub use tile::CoarseCulling;

/// How a [`LightCulling`] fills its grid.
enum CullKernel {
    /// Tile-centric: a workgroup per tile tests the lights (of its cell, two-level).
    Gather(tile::Gather),
    /// Light-centric ([`scatter`]).
    Scatter(LightAssign),
}

/// The culling pass and the light grid it writes, sized to one screen and tile size.
pub struct LightCulling {
    kernel: CullKernel,
    /// The lists (read by the shading pass, the heat map, statistics and tests).
    pub grid: LightGrid,
    /// The options it was built with.
    pub options: CullOptions,
    /// Bytes allocated (the grid's at creation: see [`LightGrid::memory`] after growing).
    pub memory: MemoryReport,
}

impl LightCulling {
    /// Builds the pipeline and buffers for `grid`, reading `depth` (a `Depth32Float` view
    /// of the pre-pass with `options.samples` samples per pixel: another count is refused).
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        depth: Depth<'_>,
        lights: &LightBuffers,
        lighting: &wgpu::Buffer,
        grid: TileGrid,
        options: CullOptions,
    ) -> Result<Self, GpuError> {
        Self::with_drop_light(device, views, depth, (lights, lighting), grid, options, None)
    }

    /// [`LightCulling::new`] with the test-only [`DropLight`] hook (`None`: the same).
    pub fn with_drop_light(
        device: &wgpu::Device,
        views: &Views,
        depth: Depth<'_>,
        lights: (&LightBuffers, &wgpu::Buffer),
        grid: TileGrid,
        options: CullOptions,
        drop: Option<DropLight>,
    ) -> Result<Self, GpuError> {
        if depth.samples != options.samples {
            return Err(GpuError::Config(format!(
                "light culling: a depth buffer of {} samples a pixel, culling options for {}",
                depth.samples, options.samples
            )));
        }
        Self::build(device, views, (depth.view, None), lights, grid, options, drop)
    }

    /// The culling pass of blended geometry (`BLENDED`, [`crate::blended`]): tiles with
    /// blended samples in front of the `opaque` depth get a list of the lights reaching the
    /// range from the nearest `blended` depth to the opaque depth behind it, into a light
    /// grid of its own. One list per tile, sphere and plane tests only, one level:
    /// `options`' half-z, two-level, AABB and cone settings do not apply.
    pub fn blended(
        device: &wgpu::Device,
        views: &Views,
        (opaque, blended): (&wgpu::TextureView, &wgpu::TextureView),
        lights: (&LightBuffers, &wgpu::Buffer),
        grid: TileGrid,
        options: CullOptions,
    ) -> Result<Self, GpuError> {
        let options = options.for_blended();
        Self::build(device, views, (opaque, Some(blended)), lights, grid, options, None)
    }

    /// Checks the options, builds the light grid, then the kernel the options pick.
    fn build(
        device: &wgpu::Device,
        views: &Views,
        (depth, blended): (&wgpu::TextureView, Option<&wgpu::TextureView>),
        (lights, lighting): (&LightBuffers, &wgpu::Buffer),
        grid: TileGrid,
        options: CullOptions,
        drop: Option<DropLight>,
    ) -> Result<Self, GpuError> {
        options.validate(&grid, CULL_WORKGROUP_BYTES, &device.limits())?;
        if let Some(d) = &drop {
            d.check(&grid, lights.len())?;
        }
        let prefix = if blended.is_some() { "blended" } else { "cull" };
        let light_grid = LightGrid::new(
            device,
            if blended.is_some() { "blended.light_grid" } else { "cull.light_grid" },
            options.grid_layout(grid, options.half_z)?,
            lights.len(),
            options.grid_pairs,
        )?;
        let mut memory = light_grid.memory();
        let kernel = if options.assigned() {
            if drop.is_some() || blended.is_some() {
                return Err(GpuError::Config(
                    "light-centric assignment has no test hook and does not serve blended geometry yet".into(),
                ));
            }
            CullKernel::Scatter(LightAssign::new(
                device,
                views,
                depth,
                (lights, lighting),
                &light_grid,
                &options,
                &mut memory,
            )?)
        } else {
            CullKernel::Gather(tile::Gather::new(
                device,
                views,
                (depth, blended),
                (lights, lighting),
                &grid,
                &options,
                drop,
                (&light_grid, prefix),
                &mut memory,
            )?)
        };
        Ok(Self { kernel, grid: light_grid, options, memory })
    }

    /// Records the culling of view slot `view` (one workgroup per tile, or the
    /// light-centric passes) after clearing the grid's counters.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        (views, view): (&Views, u32),
        label: &str,
    ) {
        match &self.kernel {
            CullKernel::Gather(gather) => gather.record(encoder, timer, (views, view), &self.grid, label),
            CullKernel::Scatter(assign) => assign.record(encoder, timer, (views, view), &self.grid, label),
        }
    }

    /// The per-tile depth masks of the last frame (2.5D bins or occupied cluster slices;
    /// `None` for layouts without masks or tile-centric culling; stalls the GPU).
    pub fn read_masks(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<Vec<u32>>, GpuError> {
        match &self.kernel {
            CullKernel::Scatter(LightAssign { masks: Some(m), .. }) => {
                let mut v: Vec<u32> = crate::readback::read_buffer(device, queue, m)?;
                v.truncate(self.grid.tiles.tile_count());
                Ok(Some(v))
            }
            _ => Ok(None),
        }
    }

    /// Reads the lists of the last culled frame back (tests, statistics; stalls the GPU).
    pub fn read_lists(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<GpuTileLists, GpuError> {
        self.grid.read_lists(device, queue)
    }
}
