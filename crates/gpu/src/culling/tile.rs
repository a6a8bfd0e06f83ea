//! The tile-centric (gather) culling kernel shared by both methods: one workgroup per tile
//! (8, 16 or 32 pixels a side), min/max depth reduced in workgroup memory, lights tested in
//! parallel against the tile's volume and appended to a workgroup list of `capacity`
//! indices, then written to the light grid ([`crate::light_grid`]); a list longer than the
//! workgroup list is culled again straight into the grid, so no list is ever truncated
//! while the grid has room. Two-level culling first culls lights per 64x64-pixel cell
//! ([`CoarseCulling`]). The CPU reference is `tiledlight_cull::gather` (through
//! `tiledlight_cull::cull_tiles`). Also the gather code's defines and override constants
//! ([`CullOptions::tests`], [`CullOptions::cull_constants`]), which Tiled
//! Deferred's fused cull-and-shade kernel uses too.
//! Depends on wgpu, [`super::options`], [`crate::view`], [`crate::light_grid`],
//! [`crate::light_buffers`].

use crate::define::Define;
use tiledlight_cull::lists::{COARSE_CAPACITY, COARSE_SIZE};
use tiledlight_cull::TileGrid;

use crate::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::light_buffers::LightBuffers;
use crate::light_grid::LightGrid;
use crate::memory::MemoryReport;
use crate::timer::GpuTimer;
use crate::util::{buffer_zeroed, check_storage_binding, compute_pipeline, keyed_module};
use crate::variants::{CullCoarseKey, CullKey, CullTests, ShaderKey};
use crate::view::Views;

use super::options::{CullOptions, DropLight, DEPTH_BINDING};

/// The gather kernel's variant of [`CullOptions`].
impl CullOptions {
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
    /// box and spot-cone tests, the cells' (two-level), the depth samples' and the test
    /// hook's.
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
            // The light tests that are constants, not defines (common/tile_tests.wgsl).
            ("AABB_TEST", f64::from(u8::from(self.aabb))),
            ("SPOT_CONE_TEST", f64::from(u8::from(self.spot_cone))),
        ];
        if let Some(c) = coarse {
            constants.extend(c.constants());
        }
        constants.extend(self.depth_variant().1);
        constants.extend(DropLight::variant(drop).1);
        constants
    }
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
        check_storage_binding(&device.limits(), bytes, || {
            format!("the cell lists of two-level culling ({n} cells x {capacity} lights)")
        })?;
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

/// The bindings of [`super::LightCulling`] (`shaders/cull.wgsl`). Group 1: depth (0), bounding
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
                Binding::storage(6, wgpu::ShaderStages::COMPUTE).when(Cond::Defined(Define::SpotCone)),
                Binding::storage(7, wgpu::ShaderStages::COMPUTE).when(Cond::Defined(Define::SpotCone)),
                Binding::storage(8, wgpu::ShaderStages::COMPUTE).when(Cond::Defined(Define::Coarse)),
                Binding::texture(10, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Float { filterable: false })
                    .multisampled_when(Cond::Defined(Define::Msaa))
                    .when(Cond::Defined(Define::Blended)),
            ],
        ),
        PassGroup::new(2, &crate::light_grid::compute_bindings(Cond::Defined(Define::HalfZ))),
    ],
};

/// The tile-centric kernel of a [`super::LightCulling`]: a workgroup per tile tests the
/// lights (of its cell, two-level) and writes the tile's lists into the light grid.
pub(super) struct Gather {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// The first level of two-level culling, when enabled.
    coarse: Option<CoarseCulling>,
}

impl Gather {
    /// The pipeline filling `light_grid` (built for `grid` and `options`) from `depth`, and
    /// with `blended` the blended geometry's depth (`BLENDED`). `prefix` labels its objects.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        device: &wgpu::Device,
        views: &Views,
        (depth, blended): (&wgpu::TextureView, Option<&wgpu::TextureView>),
        (lights, lighting): (&LightBuffers, &wgpu::Buffer),
        grid: &TileGrid,
        options: &CullOptions,
        drop: Option<DropLight>,
        (light_grid, prefix): (&LightGrid, &str),
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
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
        let coarse = if options.coarse {
            Some(CoarseCulling::new(device, views, depth, lights, lighting, grid, options, memory)?)
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
        let constants = options.cull_constants(coarse.as_ref(), drop, (light_grid, lights.len()));
        let pipeline =
            compute_pipeline(device, prefix, &[&views.layout, &layout, light_grid.layout()], &module, &constants);
        Ok(Self { pipeline, bind_group, coarse })
    }

    /// Records the culling dispatch (one workgroup per tile) of view slot `view` into `grid`
    /// (the one it was built for) after clearing the grid's counters, as one timed compute
    /// pass `label`.
    pub(super) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        (views, view): (&Views, u32),
        grid: &LightGrid,
        label: &str,
    ) {
        grid.record_clear(encoder);
        let t = timer.begin(label, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
            if let Some(c) = &self.coarse {
                c.dispatch(&mut pass);
            }
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(1, &self.bind_group, &[]);
            pass.set_bind_group(2, grid.bind_group(), &[]);
            pass.dispatch_workgroups(grid.tiles.tiles_x, grid.tiles.tiles_y, 1);
        }
        timer.end(encoder, t);
        grid.record_readback(encoder);
    }
}
