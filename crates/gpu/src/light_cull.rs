//! The tiled light-culling compute pass shared by both methods: one workgroup per tile
//! (8, 16 or 32 pixels a side), min/max depth reduced in workgroup memory, lights tested in
//! parallel against the tile's volume and appended to a workgroup list, then written to the
//! tile's region of a global index buffer with the true count. Never writes more than the
//! capacity; overflowing lists are counted. The CPU reference is
//! `tiledlight_cull::reference::cull_tiles`. Depends on wgpu, [`crate::frame`],
//! [`crate::lights_gpu`].

use tiledlight_cull::reference::{COARSE_CAPACITY, COARSE_SIZE, MAX_CAPACITY};
use tiledlight_cull::TileGrid;

use crate::error::GpuError;
use crate::frame::FrameBinding;
use crate::lights_gpu::LightBuffers;
use crate::memory::MemoryReport;
use crate::readback::read_buffer;
use crate::timer::GpuTimer;
use crate::util::{buffer_zeroed, compute_pipeline, shader_module, storage_entry};

/// Options of the culling pass (mirrors `tiledlight_cull::CullConfig`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CullOptions {
    /// Tile side: 8, 16 or 32.
    pub tile_size: u32,
    /// Indices stored per list.
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
        }
    }
}

impl CullOptions {
    /// The CPU reference configuration running the same tests.
    pub fn to_config(&self, has_spots: bool) -> tiledlight_cull::CullConfig {
        tiledlight_cull::CullConfig {
            tile_size: self.tile_size,
            capacity: self.capacity,
            aabb: self.aabb,
            half_z: self.half_z,
            spot_cone: self.spot_cone && has_spots,
            coarse: self.coarse,
            inflate: 0.0,
            samples: self.samples,
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

    /// The depth-range defines and override constants every kernel reading the depth
    /// buffer needs (`shaders/common/depth_range.wgsl`).
    pub fn depth_variant(&self) -> (Option<&'static str>, Option<(&'static str, f64)>) {
        if self.samples > 1 {
            (Some("MSAA"), Some(("SAMPLES", self.samples as f64)))
        } else {
            (None, None)
        }
    }

    /// Lists per tile.
    pub fn lists_per_tile(&self) -> u32 {
        if self.half_z {
            2
        } else {
            1
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

    /// The define and override constants of the hook, to add to a kernel that includes
    /// `common/tile_cull.wgsl`.
    pub fn variant(drop: Option<DropLight>) -> (Option<&'static str>, Vec<(&'static str, f64)>) {
        match drop {
            Some(d) => (Some("DROP_LIGHT"), vec![("DROP_TILE", d.tile as f64), ("DROP_INDEX", d.light as f64)]),
            None => (None, Vec::new()),
        }
    }
}

/// Workgroup memory of the culling kernel besides its lists (bytes): the depth range and
/// the two list counts (`shaders/common/depth_range.wgsl`, `common/tile_cull.wgsl`).
pub const CULL_WORKGROUP_BYTES: u32 = 16;

/// Per-tile lists as read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuTileLists {
    /// True light count per list.
    pub counts: Vec<u32>,
    /// Stored indices per list (at most the capacity each), in the GPU's order.
    pub lists: Vec<Vec<u32>>,
    /// Lists that overflowed, as counted on the GPU.
    pub overflowing: u32,
    /// (tile, light) pairs found, as counted on the GPU.
    pub pairs: u32,
}

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
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameBinding,
        depth: &wgpu::TextureView,
        lights: &LightBuffers,
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
            return Err(GpuError::Config(format!(
                "cell lists need {bytes} bytes ({n} cells x {capacity} lights); this device binds at most {}",
                device.limits().max_storage_buffer_binding_size
            )));
        }
        let lists = buffer_zeroed(device, "cull.cell_lists", bytes, usage);
        memory.add("cull.cell_lists", lists.size());
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cull_coarse.layout"),
            entries: &[depth_entry(0, options.samples), storage_entry(1, cs, true), storage_entry(2, cs, false)],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cull_coarse.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) },
                wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: lists.as_entire_binding() },
            ],
        });
        let (msaa, samples) = options.depth_variant();
        let module = shader_module(device, "cull_coarse.wgsl", &msaa.into_iter().collect::<Vec<_>>())?;
        let mut constants = coarse_constants(capacity).to_vec();
        constants.extend(samples);
        let pipeline = compute_pipeline(device, "cull_coarse", &[&frame.layout, &layout], &module, &constants);
        Ok(Self { pipeline, bind_group, cells, lists, capacity })
    }

    /// The override constants the per-tile kernel needs to read these cells.
    pub fn constants(&self) -> [(&'static str, f64); 2] {
        coarse_constants(self.capacity)
    }

    /// Records the cell dispatch into `pass` (group 0, the frame, must be bound).
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.cells.tiles_x, self.cells.tiles_y, 1);
    }
}

/// Override constants shared by both levels: the cell size and the cell capacity.
fn coarse_constants(capacity: u32) -> [(&'static str, f64); 2] {
    [("CELL", COARSE_SIZE as f64), ("COARSE_CAPACITY", capacity as f64)]
}

/// Layout entry for the depth texture a compute kernel reads (multisampled when `samples` > 1).
pub fn depth_entry(binding: u32, samples: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: samples > 1,
        },
        count: None,
    }
}

/// The culling pass and its output buffers, sized to one screen and tile size.
pub struct LightCulling {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// The first level of two-level culling, when enabled.
    coarse: Option<CoarseCulling>,
    /// Per-list light counts.
    pub tile_counts: wgpu::Buffer,
    /// Per-list light indices (`capacity` per list).
    pub tile_indices: wgpu::Buffer,
    /// Per-tile depth ranges (half-z only).
    pub tile_ranges: Option<wgpu::Buffer>,
    stats: wgpu::Buffer,
    /// The tiling.
    pub grid: TileGrid,
    /// The options it was built with.
    pub options: CullOptions,
    /// Bytes allocated.
    pub memory: MemoryReport,
}

impl LightCulling {
    /// Builds the pipeline and buffers for `grid`, reading `depth` (a `Depth32Float` view
    /// of the pre-pass with `options.samples` samples per pixel).
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameBinding,
        depth: &wgpu::TextureView,
        lights: &LightBuffers,
        grid: TileGrid,
        options: CullOptions,
    ) -> Result<Self, GpuError> {
        Self::with_drop_light(device, frame, depth, lights, grid, options, None)
    }

    /// [`LightCulling::new`] with the test-only [`DropLight`] hook (`None`: the same).
    pub fn with_drop_light(
        device: &wgpu::Device,
        frame: &FrameBinding,
        depth: &wgpu::TextureView,
        lights: &LightBuffers,
        grid: TileGrid,
        options: CullOptions,
        drop: Option<DropLight>,
    ) -> Result<Self, GpuError> {
        if ![8, 16, 32].contains(&options.tile_size) || grid.tile_size != options.tile_size {
            return Err(GpuError::Config(format!(
                "tile size {} must be 8, 16 or 32 (and match the grid's {})",
                options.tile_size, grid.tile_size
            )));
        }
        if options.capacity == 0 || options.capacity > MAX_CAPACITY {
            return Err(GpuError::Config(format!(
                "per-tile capacity {} must be in 1..={MAX_CAPACITY}",
                options.capacity
            )));
        }
        let lists = grid.tile_count() as u64 * options.lists_per_tile() as u64;
        let limits = device.limits();
        let wg_bytes = options.capacity * 4 * options.lists_per_tile() + CULL_WORKGROUP_BYTES;
        if wg_bytes > limits.max_compute_workgroup_storage_size {
            return Err(GpuError::Config(format!(
                "capacity {} needs {wg_bytes} bytes of workgroup memory; this device allows {}",
                options.capacity, limits.max_compute_workgroup_storage_size
            )));
        }
        let index_bytes = lists * options.capacity as u64 * 4;
        if index_bytes > limits.max_storage_buffer_binding_size {
            return Err(GpuError::Config(format!(
                "tile lists need {index_bytes} bytes ({lists} lists x {} indices); this device binds at most {}",
                options.capacity, limits.max_storage_buffer_binding_size
            )));
        }
        let spot_cone = options.spot_cone && lights.has_spots();
        let mut defines = Vec::new();
        if options.aabb {
            defines.push("AABB");
        }
        if options.half_z {
            defines.push("HALF_Z");
        }
        if spot_cone {
            defines.push("SPOT_CONE");
        }
        let (msaa, samples) = options.depth_variant();
        defines.extend(msaa);
        if options.coarse {
            if !COARSE_SIZE.is_multiple_of(options.tile_size) {
                return Err(GpuError::Config(format!("two-level culling needs a tile size dividing {COARSE_SIZE}")));
            }
            defines.push("COARSE");
        }
        let cs = wgpu::ShaderStages::COMPUTE;
        let mut entries = vec![
            depth_entry(0, options.samples),
            storage_entry(1, cs, true),
            storage_entry(2, cs, false),
            storage_entry(3, cs, false),
            storage_entry(4, cs, false),
        ];
        let out_usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let tile_counts = buffer_zeroed(device, "cull.tile_counts", lists * 4, out_usage);
        let tile_indices = buffer_zeroed(device, "cull.tile_indices", index_bytes, out_usage);
        let stats = buffer_zeroed(device, "cull.stats", 8, out_usage);
        let tile_ranges =
            options.half_z.then(|| buffer_zeroed(device, "cull.tile_ranges", grid.tile_count() as u64 * 8, out_usage));
        let mut memory = MemoryReport::default();
        memory.add("cull.tile_lists", tile_counts.size() + tile_indices.size() + stats.size());
        if let Some(r) = &tile_ranges {
            entries.push(storage_entry(5, cs, false));
            memory.add("cull.tile_ranges", r.size());
        }
        if spot_cone {
            entries.push(storage_entry(6, cs, true));
            entries.push(storage_entry(7, cs, true));
        }
        let coarse = if options.coarse {
            let c = CoarseCulling::new(device, frame, depth, lights, &grid, &options, &mut memory)?;
            entries.push(storage_entry(8, cs, true));
            Some(c)
        } else {
            None
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cull.layout"),
            entries: &entries,
        });
        let mut bind = vec![
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) },
            wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: tile_counts.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: tile_indices.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: stats.as_entire_binding() },
        ];
        if let Some(r) = &tile_ranges {
            bind.push(wgpu::BindGroupEntry { binding: 5, resource: r.as_entire_binding() });
        }
        if let (true, Some(spots)) = (spot_cone, &lights.spots) {
            bind.push(wgpu::BindGroupEntry { binding: 6, resource: lights.shading.as_entire_binding() });
            bind.push(wgpu::BindGroupEntry { binding: 7, resource: spots.as_entire_binding() });
        }
        if let Some(c) = &coarse {
            bind.push(wgpu::BindGroupEntry { binding: 8, resource: c.lists.as_entire_binding() });
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cull.bind_group"),
            layout: &layout,
            entries: &bind,
        });
        if let Some(d) = &drop {
            d.check(&grid, lights.len())?;
        }
        let (drop_define, drop_constants) = DropLight::variant(drop);
        defines.extend(drop_define);
        let module = shader_module(device, "cull.wgsl", &defines)?;
        let wg = options.tile_size.min(16);
        let mut constants =
            vec![("TILE_SIZE", options.tile_size as f64), ("WG", wg as f64), ("CAPACITY", options.capacity as f64)];
        if let Some(c) = &coarse {
            constants.extend(c.constants());
        }
        constants.extend(samples);
        constants.extend(drop_constants);
        let pipeline = compute_pipeline(device, "cull", &[&frame.layout, &layout], &module, &constants);
        Ok(Self { pipeline, bind_group, coarse, tile_counts, tile_indices, tile_ranges, stats, grid, options, memory })
    }

    /// Records the culling dispatch (one workgroup per tile) after clearing the counters.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, frame: &FrameBinding, label: &str) {
        encoder.clear_buffer(&self.stats, 0, None);
        let t = timer.begin(label, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_bind_group(0, &frame.bind_group, &[]);
            if let Some(c) = &self.coarse {
                c.dispatch(&mut pass);
            }
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(1, &self.bind_group, &[]);
            pass.dispatch_workgroups(self.grid.tiles_x, self.grid.tiles_y, 1);
        }
        timer.end(encoder, t);
    }

    /// Reads the lists of the last culled frame back (tests, statistics; stalls the GPU).
    pub fn read_lists(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<GpuTileLists, GpuError> {
        let stats: Vec<u32> = read_buffer(device, queue, &self.stats)?;
        let mut lists =
            read_tile_lists(device, queue, &self.tile_counts, &self.tile_indices, &self.grid, &self.options)?;
        lists.overflowing = stats[0];
        lists.pairs = stats[1];
        Ok(lists)
    }
}

/// Reads per-tile lists laid out as the culling pass writes them: `counts` holds the true
/// light count of every list (list `t * lists_per_tile + k` for tile `t`), `indices` holds
/// `options.capacity` slots per list of which the first `min(count, capacity)` are valid.
/// The culling pass and Tiled Deferred's debug output (`DeferredSettings::debug_lists`)
/// share this layout and this reader. `overflowing` and `pairs` are derived from the counts
/// here; [`LightCulling::read_lists`] replaces them with its kernel's own tallies.
pub fn read_tile_lists(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    counts: &wgpu::Buffer,
    indices: &wgpu::Buffer,
    grid: &TileGrid,
    options: &CullOptions,
) -> Result<GpuTileLists, GpuError> {
    let counts: Vec<u32> = read_buffer(device, queue, counts)?;
    let indices: Vec<u32> = read_buffer(device, queue, indices)?;
    let cap = options.capacity as usize;
    let n = grid.tile_count() * options.lists_per_tile() as usize;
    if counts.len() < n || indices.len() < n * cap {
        return Err(GpuError::Readback(format!(
            "{} counts and {} indices read back for {n} lists of capacity {cap}",
            counts.len(),
            indices.len()
        )));
    }
    let lists = (0..n).map(|i| indices[i * cap..i * cap + (counts[i] as usize).min(cap)].to_vec()).collect();
    let counts = counts[..n].to_vec();
    let overflowing = counts.iter().filter(|&&c| c as usize > cap).count() as u32;
    let pairs = counts.iter().sum();
    Ok(GpuTileLists { counts, lists, overflowing, pairs })
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
        assert_eq!(CullOptions::capacity_for(100_000, true, r, &limits), 2046);
        let small = wgpu::Limits { max_compute_workgroup_storage_size: 4096, ..limits };
        assert_eq!(CullOptions::capacity_for(100_000, true, r, &small), 510);
        // A 16 px tile's MSAA edge queue (1 KiB + 8 bytes) comes out of the lists.
        assert_eq!(CullOptions::capacity_for(100_000, true, r + 8 + 1024, &limits), 1917);
    }
}
