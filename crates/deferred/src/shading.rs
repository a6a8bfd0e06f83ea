//! Tiled Deferred's one compute pass (`shaders/deferred.wgsl`): per tile, the same culling
//! as Forward+ (`shaders/common/tile_cull.wgsl`, after the shared 64x64-cell pass when
//! two-level culling is on) into workgroup memory, then every pixel of the tile shaded from
//! the G-buffer with that list, into the HDR storage texture. Per-list counts are written
//! for the heat map and tests. Bind group 1 holds everything; it is built once per screen.
//! Depends on tiledlight-gpu and [`crate::gbuffer`].

use tiledlight_cull::reference::{COARSE_SIZE, MAX_CAPACITY};
use tiledlight_cull::TileGrid;
use tiledlight_gpu::frame::FrameBinding;
use tiledlight_gpu::light_cull::{depth_entry, CoarseCulling, CullOptions};
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::{buffer_zeroed, pipeline_layout, shader_module, storage_entry, texture_entry};
use tiledlight_gpu::GpuError;

use crate::gbuffer::GBuffer;

/// The cull-and-shade pass.
pub struct DeferredShading {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    coarse: Option<CoarseCulling>,
    grid: TileGrid,
    /// Per-list light counts of the last frame.
    pub tile_counts: wgpu::Buffer,
}

impl DeferredShading {
    /// Builds the pipeline and bindings for `grid`, reading `depth` and `gbuffer`, writing `hdr`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameBinding,
        depth: &wgpu::TextureView,
        gbuffer: &GBuffer,
        hdr: &wgpu::TextureView,
        lights: &LightBuffers,
        grid: TileGrid,
        options: CullOptions,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        if ![8, 16, 32].contains(&options.tile_size) || grid.tile_size != options.tile_size {
            return Err(GpuError::Config(format!("tile size {} must be 8, 16 or 32", options.tile_size)));
        }
        if options.capacity == 0 || options.capacity > MAX_CAPACITY {
            return Err(GpuError::Config(format!(
                "per-tile capacity {} must be in 1..={MAX_CAPACITY}",
                options.capacity
            )));
        }
        let limit = device.limits().max_compute_workgroup_storage_size;
        let wg_bytes = options.capacity * 4 * options.lists_per_tile() + 16;
        if wg_bytes > limit {
            return Err(GpuError::Config(format!(
                "capacity {} needs {wg_bytes} bytes of workgroup memory; this device allows {limit}",
                options.capacity
            )));
        }
        let cs = wgpu::ShaderStages::COMPUTE;
        let unfilterable = wgpu::TextureSampleType::Float { filterable: false };
        let mut defines = Vec::new();
        let mut entries = vec![
            depth_entry(0),
            storage_entry(1, cs, true),
            storage_entry(2, cs, false),
            texture_entry(3, cs, unfilterable),
            texture_entry(4, cs, unfilterable),
            storage_entry(6, cs, true),
            wgpu::BindGroupLayoutEntry {
                binding: 9,
                visibility: cs,
                ty: wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: tiledlight_gpu::tonemap::HDR_FORMAT,
                    view_dimension: wgpu::TextureViewDimension::D2,
                },
                count: None,
            },
        ];
        let tile_counts = buffer_zeroed(
            device,
            "deferred.tile_counts",
            grid.tile_count() as u64 * options.lists_per_tile() as u64 * 4,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        memory.add("deferred.tile_counts", tile_counts.size());
        let mut bind = vec![
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) },
            wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: tile_counts.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(gbuffer.albedo_view()) },
            wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(gbuffer.normal_view()) },
            wgpu::BindGroupEntry { binding: 6, resource: lights.shading.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::TextureView(hdr) },
        ];
        if let Some(extra) = &gbuffer.extra_view {
            defines.push("EXTRA_RTS");
            entries.push(wgpu::BindGroupLayoutEntry {
                binding: 5,
                visibility: cs,
                ty: wgpu::BindingType::Texture {
                    sample_type: unfilterable,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            });
            bind.push(wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(extra) });
        }
        if let Some(spots) = &lights.spots {
            defines.push("SPOT_LIGHTS");
            if options.spot_cone {
                defines.push("SPOT_CONE");
            }
            entries.push(storage_entry(7, cs, true));
            bind.push(wgpu::BindGroupEntry { binding: 7, resource: spots.as_entire_binding() });
        }
        if options.aabb {
            defines.push("AABB");
        }
        if options.half_z {
            defines.push("HALF_Z");
        }
        let coarse = if options.coarse {
            if !COARSE_SIZE.is_multiple_of(options.tile_size) {
                return Err(GpuError::Config(format!("two-level culling needs a tile size dividing {COARSE_SIZE}")));
            }
            defines.push("COARSE");
            entries.push(storage_entry(8, cs, true));
            Some(CoarseCulling::new(device, frame, depth, lights, &grid, memory)?)
        } else {
            None
        };
        if let Some(c) = &coarse {
            bind.push(wgpu::BindGroupEntry { binding: 8, resource: c.lists.as_entire_binding() });
        }
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("deferred.layout"),
            entries: &entries,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deferred.bind_group"),
            layout: &layout,
            entries: &bind,
        });
        let module = shader_module(device, "deferred.wgsl", &defines)?;
        let mut constants = vec![
            ("TILE_SIZE", options.tile_size as f64),
            ("WG", options.tile_size.min(16) as f64),
            ("CAPACITY", options.capacity as f64),
        ];
        if let Some(c) = &coarse {
            constants.extend(c.constants());
        }
        if gbuffer.extra_view.is_some() {
            constants.push(("NUM_EXTRA", (gbuffer.rts() - 2) as f64));
        }
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("deferred.shade"),
            layout: Some(&pipeline_layout(device, "deferred.pipeline_layout", &[&frame.layout, &layout])),
            module: &module,
            entry_point: Some("main"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        });
        Ok(Self { pipeline, bind_group, coarse, grid, tile_counts })
    }

    /// Records the cell pass (two-level culling) and the cull-and-shade dispatch.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, frame: &FrameBinding) {
        if let Some(c) = &self.coarse {
            let t = timer.begin("deferred.cull_cells", encoder);
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("deferred.cull_cells"),
                    timestamp_writes: t.compute_writes(),
                });
                pass.set_bind_group(0, &frame.bind_group, &[]);
                c.dispatch(&mut pass);
            }
            timer.end(encoder, t);
        }
        let t = timer.begin("deferred.shade", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("deferred.shade"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &frame.bind_group, &[]);
            pass.set_bind_group(1, &self.bind_group, &[]);
            pass.dispatch_workgroups(self.grid.tiles_x, self.grid.tiles_y, 1);
        }
        timer.end(encoder, t);
    }
}
