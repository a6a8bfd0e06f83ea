//! The tiled light-culling compute pass shared by both methods: one workgroup per tile
//! (8, 16 or 32 pixels a side), min/max depth reduced in workgroup memory, lights tested in
//! parallel against the tile's volume and appended to a workgroup list of `capacity`
//! indices, then written to the light grid ([`crate::light_grid`]); a list longer than the
//! workgroup list is culled again straight into the grid, so no list is ever truncated
//! while the grid has room. The CPU reference is `tiledlight_cull::reference::cull_tiles`.
//! Depends on wgpu, [`crate::view`], [`crate::light_grid`], [`crate::lights_gpu`].

use tiledlight_cull::reference::{COARSE_CAPACITY, COARSE_SIZE, MAX_CAPACITY};
use tiledlight_cull::TileGrid;

use crate::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use crate::error::GpuError;
pub use crate::light_assign::ClusterOptions;
use crate::light_assign::LightAssign;
pub use crate::light_grid::GpuTileLists;
use crate::light_grid::{GridLayout, LightGrid};
use crate::lights_gpu::LightBuffers;
use crate::memory::MemoryReport;
use crate::timer::GpuTimer;
use crate::util::{buffer_zeroed, compute_pipeline, keyed_module};
use crate::variants::{CullCoarseKey, CullKey, CullTests, ShaderKey};
use crate::view::Views;

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
    /// Light-centric assignment ([`crate::light_assign`]): each light scatters itself into
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
            capacity: tiledlight_cull::reference::DEFAULT_CAPACITY,
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
            c.validate()?;
            if !crate::light_assign::CLUSTER_TILE_SIZES.contains(&c.tile_size) {
                return Err(GpuError::Config(format!(
                    "cluster tile size {} must be one of {:?} on the GPU",
                    c.tile_size,
                    crate::light_assign::CLUSTER_TILE_SIZES
                )));
            }
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

    /// The light tests of the culling code (`common/tile_cull.wgsl`) for these options on a
    /// scene with or without spot lights (the spot-cone test only with spots).
    pub fn tests(&self, has_spots: bool) -> CullTests {
        CullTests {
            aabb: self.aabb,
            half_z: self.half_z,
            spot_cone: self.spot_cone && has_spots,
            coarse: self.coarse,
            depth_mask: self.depth_mask,
        }
    }

    /// The override constants of the culling code: tile and workgroup size, capacity, the
    /// cells' (two-level), the depth samples' and the test hook's.
    /// `grid` is the light grid the kernel writes (its lists and the light count decide
    /// whether its allocation counter needs the wrap guard: [`LightGrid::needs_guard`]).
    pub fn cull_constants(
        &self,
        coarse: Option<&CoarseCulling>,
        drop: Option<DropLight>,
        grid: (&LightGrid, u32),
    ) -> Vec<(&'static str, f64)> {
        let mut constants = vec![
            ("TILE_SIZE", self.tile_size as f64),
            ("WG", self.tile_size.min(16) as f64),
            ("CAPACITY", self.capacity as f64),
            ("GRID_GUARD", f64::from(u8::from(grid.0.needs_guard(grid.1)))),
        ];
        if let Some(c) = coarse {
            constants.extend(c.constants());
        }
        constants.extend(self.depth_variant().1);
        constants.extend(DropLight::variant(drop).1);
        constants
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

/// The first level of two-level culling: per 64x64-pixel cell, the lights that may touch
/// it (`shaders/cull_coarse.wgsl`). Shared by Forward+'s culling pass and Tiled Deferred.
pub struct CoarseCulling {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// The cell grid.
    pub cells: TileGrid,
    /// Cell counts, then `capacity` indices per cell; bind it read-only as `cell_lists` in
    /// the per-tile kernel.
    pub lists: wgpu::Buffer,
    /// Indices a cell stores: `COARSE_CAPACITY`, or the light count when smaller (a cell
    /// cannot hold more lights than exist, so overflow means the same as on the CPU).
    pub capacity: u32,
}

impl CoarseCulling {
    /// Pipeline and cell buffer for `grid`'s screen, reading `depth`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        depth: &wgpu::TextureView,
        lights: &LightBuffers,
        lighting: &wgpu::Buffer,
        grid: &TileGrid,
        options: &CullOptions,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let cells = TileGrid::new(grid.width, grid.height, COARSE_SIZE)?;
        let capacity = COARSE_CAPACITY.min(lights.len().max(1));
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        // Counts first, then COARSE_CAPACITY indices per cell: one binding, since a stage
        // has only 8 storage buffers and the per-tile pass already uses up to 7.
        let n = cells.tile_count() as u64;
        let bytes = (n + n * capacity as u64) * 4;
        if bytes > device.limits().max_storage_buffer_binding_size {
            return Err(GpuError::Limit {
                what: format!("the cell lists of two-level culling ({n} cells x {capacity} lights)"),
                name: "max_storage_buffer_binding_size",
                limit: device.limits().max_storage_buffer_binding_size,
                asked: format!("{bytes} bytes"),
            });
        }
        let lists = buffer_zeroed(device, "cull.cell_lists", bytes, usage);
        memory.add("cull.cell_lists", lists.size());
        let (msaa, samples) = options.depth_variant();
        let key = CullCoarseKey { msaa };
        let layout = create_layout(device, "cull_coarse.layout", CULL_COARSE_BINDINGS.group(1), &key.defines());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cull_coarse.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) },
                wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: lists.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: lighting.as_entire_binding() },
            ],
        });
        let module = keyed_module(device, &key)?;
        let mut constants = coarse_constants(capacity).to_vec();
        constants.extend(samples);
        let pipeline = compute_pipeline(device, "cull_coarse", &[&views.layout, &layout], &module, &constants);
        Ok(Self { pipeline, bind_group, cells, lists, capacity })
    }

    /// The override constants the per-tile kernel needs to read these cells.
    pub fn constants(&self) -> [(&'static str, f64); 2] {
        coarse_constants(self.capacity)
    }

    /// Records the cell dispatch into `pass` (group 0, the view, must be bound).
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.cells.tiles_x, self.cells.tiles_y, 1);
    }
}

/// The depth texture a culling kernel reads at group 1 binding 0
/// (`shaders/common/depth_range.wgsl`): multisampled with `MSAA`.
pub const DEPTH_BINDING: Binding = Binding::texture(0, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Depth)
    .multisampled_when(Cond::Defined("MSAA"));

/// The bindings of [`CoarseCulling`] (`shaders/cull_coarse.wgsl`). Group 1: depth (0),
/// bounding spheres (1), the cell lists it writes (2), the lighting uniform (3).
pub const CULL_COARSE_BINDINGS: PassBindings = PassBindings {
    entry: "cull_coarse.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, crate::view::BINDINGS),
        PassGroup::new(
            1,
            &[
                DEPTH_BINDING,
                Binding::storage(1, wgpu::ShaderStages::COMPUTE),
                Binding::storage_rw(2, wgpu::ShaderStages::COMPUTE),
                Binding::uniform(3, wgpu::ShaderStages::COMPUTE),
            ],
        ),
    ],
};

/// Override constants shared by both levels: the cell size and the cell capacity.
fn coarse_constants(capacity: u32) -> [(&'static str, f64); 2] {
    [("CELL", COARSE_SIZE as f64), ("COARSE_CAPACITY", capacity as f64)]
}

/// The bindings of [`LightCulling`] (`shaders/cull.wgsl`). Group 1: depth (0), bounding
/// spheres (1), the lighting uniform (9), with `SPOT_CONE` the shading lights (6) and spots
/// (7), with `COARSE` the cell lists (8), with `BLENDED` the blended depth (10). Group 2:
/// the light grid, with tile ranges under `HALF_Z`.
pub const CULL_BINDINGS: PassBindings = PassBindings {
    entry: "cull.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, crate::view::BINDINGS),
        PassGroup::new(
            1,
            &[
                DEPTH_BINDING,
                Binding::storage(1, wgpu::ShaderStages::COMPUTE),
                Binding::uniform(9, wgpu::ShaderStages::COMPUTE),
                Binding::storage(6, wgpu::ShaderStages::COMPUTE).when(Cond::Defined("SPOT_CONE")),
                Binding::storage(7, wgpu::ShaderStages::COMPUTE).when(Cond::Defined("SPOT_CONE")),
                Binding::storage(8, wgpu::ShaderStages::COMPUTE).when(Cond::Defined("COARSE")),
                Binding::texture(10, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Depth)
                    .multisampled_when(Cond::Defined("MSAA"))
                    .when(Cond::Defined("BLENDED")),
            ],
        ),
        PassGroup::new(2, &crate::light_grid::compute_bindings(Cond::Defined("HALF_Z"))),
    ],
};

/// How a [`LightCulling`] fills its grid.
enum CullKernel {
    /// Tile-centric: a workgroup per tile tests the lights (of its cell, two-level).
    Gather {
        pipeline: wgpu::ComputePipeline,
        bind_group: wgpu::BindGroup,
        /// The first level of two-level culling, when enabled.
        coarse: Option<CoarseCulling>,
    },
    /// Light-centric ([`crate::light_assign`]).
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
    /// of the pre-pass with `options.samples` samples per pixel).
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        depth: &wgpu::TextureView,
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
        depth: &wgpu::TextureView,
        lights: (&LightBuffers, &wgpu::Buffer),
        grid: TileGrid,
        options: CullOptions,
        drop: Option<DropLight>,
    ) -> Result<Self, GpuError> {
        Self::build(device, views, (depth, None), lights, grid, options, drop)
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
        if options.assigned() {
            if drop.is_some() || blended.is_some() {
                return Err(GpuError::Config(
                    "light-centric assignment has no test hook and does not serve blended geometry yet".into(),
                ));
            }
            let mut memory = light_grid.memory();
            let assign =
                LightAssign::new(device, views, depth, (lights, lighting), &light_grid, &options, &mut memory)?;
            return Ok(Self { kernel: CullKernel::Scatter(assign), grid: light_grid, options, memory });
        }
        let spot_cone = options.spot_cone && lights.has_spots();
        let key = CullKey {
            tests: options.tests(lights.has_spots()),
            msaa: options.depth_variant().0,
            blended: blended.is_some(),
            drop_light: DropLight::variant(drop).0,
        };
        let defines = key.defines();
        let mut bind = vec![
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) },
            wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: lighting.as_entire_binding() },
        ];
        if let Some(b) = blended {
            bind.push(wgpu::BindGroupEntry { binding: 10, resource: wgpu::BindingResource::TextureView(b) });
        }
        if let (true, Some(spots)) = (spot_cone, &lights.spots) {
            bind.push(wgpu::BindGroupEntry { binding: 6, resource: lights.shading.as_entire_binding() });
            bind.push(wgpu::BindGroupEntry { binding: 7, resource: spots.as_entire_binding() });
        }
        let mut memory = light_grid.memory();
        let coarse = if options.coarse {
            Some(CoarseCulling::new(device, views, depth, lights, lighting, &grid, &options, &mut memory)?)
        } else {
            None
        };
        if let Some(c) = &coarse {
            bind.push(wgpu::BindGroupEntry { binding: 8, resource: c.lists.as_entire_binding() });
        }
        let layout = create_layout(device, &format!("{prefix}.layout"), CULL_BINDINGS.group(1), &defines);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&format!("{prefix}.bind_group")),
            layout: &layout,
            entries: &bind,
        });
        let module = keyed_module(device, &key)?;
        let constants = options.cull_constants(coarse.as_ref(), drop, (&light_grid, lights.len()));
        let pipeline =
            compute_pipeline(device, prefix, &[&views.layout, &layout, light_grid.layout()], &module, &constants);
        Ok(Self { kernel: CullKernel::Gather { pipeline, bind_group, coarse }, grid: light_grid, options, memory })
    }

    /// Records the culling dispatch (one workgroup per tile) of view slot `view` after
    /// clearing the counters.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        (views, view): (&Views, u32),
        label: &str,
    ) {
        let CullKernel::Gather { pipeline, bind_group, coarse } = &self.kernel else {
            if let CullKernel::Scatter(assign) = &self.kernel {
                assign.record(encoder, timer, (views, view), &self.grid, label);
            }
            return;
        };
        self.grid.record_clear(encoder);
        let t = timer.begin(label, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
            if let Some(c) = coarse {
                c.dispatch(&mut pass);
            }
            pass.set_pipeline(pipeline);
            pass.set_bind_group(1, bind_group, &[]);
            pass.set_bind_group(2, self.grid.bind_group(), &[]);
            pass.dispatch_workgroups(self.grid.tiles.tiles_x, self.grid.tiles.tiles_y, 1);
        }
        timer.end(encoder, t);
        self.grid.record_readback(encoder);
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
