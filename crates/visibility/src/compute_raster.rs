//! The visibility buffer's compute raster (issue 29): the raster pass's second path,
//! drawing the scene's opaque triangles with compute into 64-bit texels, `(depth bits <<
//! 32) | ID`, resolved by `atomicMax` (reversed-Z), by the rules of the CPU twin
//! [`tiledlight_cull::raster`] (`shaders/common/compute_raster.wgsl`). A frame:
//!
//! 1. **Clusters** (`visibility_raster.wgsl` `cs_clusters`): one workgroup per (instance,
//!    cluster) pair of the scene's opaque draws ([`SceneGpu::clusters`], at most 128
//!    triangles each). The cluster's bounds are tested against the frustum on the GPU
//!    (per cluster; an instance off screen loses all its clusters there); each lane then
//!    sets up one triangle (clip, snap, cull back faces of single-sided materials) and
//!    fills it, unless its bounds span more than [`ComputeRasterOptions::large_px`] pixels
//!    either way: those go to the large list. With the large triangles by compute, a
//!    triangle that needs clipping goes there too, before its set-up, with its culling
//!    flag (their kernels clip; the hot kernel keeps no polygon arrays).
//! 2. **Large triangles** ([`LargeRaster`]): by compute (the default, one timed pass of two
//!    dispatches: `cs_large`, a workgroup per triangle listing the 16 px screen tiles its
//!    edges do not rule out, [`tiledlight_cull::raster::large_tiles`]; then
//!    `cs_large_tiles`, 32 lanes per listed tile, eight pixels a lane, by the same
//!    rules), or by the hardware (`visibility_raster_large.wgsl`, one indirect draw). The
//!    tile list holds [`TILE_CAPACITY_SCREENS`] screens of tiles; past that a tile is filled
//!    by the lane that lists it (slower, nothing dropped).
//! 3. **Hardware** (`depth_prepass.wgsl` with `IDS ATOMIC`, and the large triangles when
//!    the hardware draws them): the alpha-masked instances (their alpha test with the
//!    hardware's derivatives), each fragment resolving its texel by the same `atomicMax`.
//!    The pass exists only with something to draw.
//! 4. **Finalize** (`cs_finalize`): per pixel, the depth to the frame's `R32Float` depth
//!    target and the ID to the ID target (what culling and shading read, as they read the
//!    hardware raster's), the texel back to the clear value and the large list emptied,
//!    so no clear pass runs.
//!
//! One sample a pixel: MSAA is refused by name (use the hardware raster). Needs wgpu's
//! `SHADER_INT64` and `SHADER_INT64_ATOMIC_MIN_MAX`, refused by name where missing.
//! Depends on tiledlight-gpu and the scene's clusters.

use bytemuck::{Pod, Zeroable};
use tiledlight_cull::visibility::IdLayout;
use tiledlight_gpu::bindings::{create_layout, Binding, PassBindings, PassGroup};
use tiledlight_gpu::depth_prepass::{DepthPrepass, ATOMIC_TEXELS, ID_FORMAT};
use tiledlight_gpu::features::Features;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::{read_buffer, read_buffer_range};
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::{
    buffer_entry as buf, buffer_init, check_storage_binding, compute_pipeline_at, keyed_module, pipeline_layout,
    view_entry,
};
use tiledlight_gpu::variants::ComputeRasterKey;
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;
const VS: wgpu::ShaderStages = wgpu::ShaderStages::VERTEX;
const FS: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT;

/// The compute raster's depth format: written by its finalize kernel, read by the culling
/// and shading passes as they read a `Depth32Float` target.
pub const COMPUTE_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

pub use tiledlight_gpu::context::COMPUTE_RASTER_FEATURES;

/// Whether the compute raster can draw on a device with `features` at `msaa` samples: an
/// error naming what is missing otherwise (checked before any target is made).
pub fn check_support(features: wgpu::Features, msaa: u32) -> Result<(), GpuError> {
    let missing = COMPUTE_RASTER_FEATURES.difference(features);
    if !missing.is_empty() {
        return Err(GpuError::Config(format!(
            "the compute raster resolves 64-bit (depth, ID) texels with atomicMax: it needs wgpu's {missing:?} \
             (Vulkan shaderInt64, shaderBufferInt64Atomics), which this device lacks; use --raster hardware"
        )));
    }
    if msaa > 1 {
        return Err(GpuError::Config(format!(
            "the compute raster draws one sample a pixel, not {msaa}x MSAA; use --raster hardware for MSAA"
        )));
    }
    Ok(())
}

/// Group 1 of the compute kernels (`visibility_raster.wgsl`): the scene's instances (24),
/// materials (25), indices (26) and positions (27) at the visibility group's numbers; the
/// parameters (40), entries (41), clusters (42), texels as atomics (43) and as words (44),
/// the large list (45) and its draw arguments and tile count (46), the depth (47) and ID
/// (48) outputs, the clusters' triangle order (50, [`SceneGpu::cluster_triangles`]), the
/// large triangles' tile list (51).
pub const COMPUTE_RASTER_GROUP: &[Binding] = &[
    Binding::storage(24, CS),
    Binding::storage(25, CS),
    Binding::storage(26, CS),
    Binding::storage(27, CS),
    Binding::uniform(40, CS),
    Binding::storage(41, CS),
    Binding::storage(42, CS),
    Binding::storage_rw(43, CS),
    Binding::storage_rw(44, CS),
    Binding::storage_rw(45, CS),
    Binding::storage_rw(46, CS),
    Binding::storage_texture(47, CS, COMPUTE_DEPTH_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
    Binding::storage_texture(48, CS, ID_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
    Binding::storage(50, CS),
    Binding::storage_rw(51, CS),
];

/// The compute kernels' bindings: the view (0) and [`COMPUTE_RASTER_GROUP`] (1).
pub const COMPUTE_RASTER_BINDINGS: PassBindings = PassBindings {
    entry: "visibility_raster.wgsl",
    source: file!(),
    groups: &[PassGroup::new(0, tiledlight_gpu::view::BINDINGS), PassGroup::new(1, COMPUTE_RASTER_GROUP)],
};

/// Group 1 of the large triangles' draw (`visibility_raster_large.wgsl`): instances (24),
/// materials (25), indices (26), positions (27) and the large list (49) for the vertex
/// stage, the texels (43) for the fragment stage.
pub const LARGE_GROUP: &[Binding] = &[
    Binding::storage(24, VS),
    Binding::storage(25, VS),
    Binding::storage(26, VS),
    Binding::storage(27, VS),
    Binding::storage_rw(43, FS),
    Binding::storage(49, VS),
];

/// The large triangles' draw bindings: the view (0) and [`LARGE_GROUP`] (1).
pub const LARGE_BINDINGS: PassBindings = PassBindings {
    entry: "visibility_raster_large.wgsl",
    source: file!(),
    groups: &[PassGroup::new(0, tiledlight_gpu::view::BINDINGS), PassGroup::new(1, LARGE_GROUP)],
};

/// Who draws the compute raster's large triangles (declared beside [`tiledlight_gpu::features::Raster`]:
/// the pass settings' table holds it).
pub use tiledlight_gpu::features::LargeRaster;

/// How the compute raster splits its work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ComputeRasterOptions {
    /// A triangle whose clipped bounds span more than this many pixels (columns or rows)
    /// is large: drawn by `large`, not one thread; `u32::MAX`: none is.
    pub large_px: u32,
    /// Who draws the large triangles.
    pub large: LargeRaster,
}

impl ComputeRasterOptions {
    /// The options the pass settings' rows `raster-large-px` and `raster-large` state.
    pub fn of(knobs: &tiledlight_gpu::knobs::Knobs) -> Self {
        Self { large_px: knobs.raster_large_px, large: knobs.raster_large }
    }
}

impl Default for ComputeRasterOptions {
    /// The pass settings' defaults (rows `raster-large-px` and `raster-large`).
    fn default() -> Self {
        Self::of(&tiledlight_gpu::knobs::Knobs::default())
    }
}

/// Workgroups of the large-triangle kernel (`LARGE_GROUPS` in the WGSL).
const LARGE_GROUPS: u32 = 1024;

/// The large triangles' tile list holds this many screens' worth of 16 px tiles (the
/// large triangles' overdraw it fits without the slower fallback).
pub const TILE_CAPACITY_SCREENS: u32 = 16;

/// The large triangles by compute: the listing kernel, the tiles' kernel, the tile list.
struct LargeCompute {
    list: wgpu::ComputePipeline,
    tiles: wgpu::ComputePipeline,
    items: wgpu::Buffer,
    capacity: u32,
}

/// One listed tile of a large triangle (read back for tests,
/// [`ComputeRaster::read_large_tiles`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct LargeTile {
    /// The triangle's instance.
    pub instance: u32,
    /// The triangle within its instance's mesh.
    pub triangle: u32,
    /// The piece of its clipped fan (0: the first, or the triangle itself).
    pub piece: u32,
    /// The tile's column and row (16 px tiles).
    pub tile: (u32, u32),
}

/// The tiles a frame listed for its large triangles ([`ComputeRaster::read_large_tiles`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LargeTiles {
    /// The listed tiles kept in the list, sorted.
    pub tiles: Vec<LargeTile>,
    /// How many were listed in all: more than `capacity` when some were filled by the lane
    /// that listed them (those are not in `tiles`).
    pub listed: u32,
    /// The list's capacity.
    pub capacity: u32,
}

/// An (instance, cluster) pair (`Entry` in the WGSL).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuEntry {
    instance: u32,
    /// Index into the clusters; the top bit: back faces culled.
    cluster: u32,
}

/// A cluster (`Cluster` in the WGSL).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuCluster {
    bounds_min: [f32; 3],
    first: u32,
    bounds_max: [f32; 3],
    count: u32,
}

/// `RasterParams` in the WGSL.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RasterParams {
    entries: u32,
    groups_x: u32,
    large_px: u32,
    triangle_bits: u32,
    tile_capacity: u32,
    pad: [u32; 3],
}

/// Workgroups per row of the clusters' 2D dispatch (below every adapter's 65,535).
const GROUPS_X: u32 = 32_768;

/// The compute raster's passes and buffers.
pub struct ComputeRaster {
    clusters: wgpu::ComputePipeline,
    /// The large triangles by compute (with [`LargeRaster::Compute`]).
    large_compute: Option<LargeCompute>,
    finalize: wgpu::ComputePipeline,
    /// The large triangles by the hardware (with [`LargeRaster::Hardware`]) and its group.
    large: Option<(wgpu::RenderPipeline, wgpu::BindGroup)>,
    compute_group: wgpu::BindGroup,
    /// The masked instances' pipelines and the texels' group for them.
    masked: Option<(DepthPrepass, wgpu::BindGroup, u32)>,
    large_args: wgpu::Buffer,
    large_list: wgpu::Buffer,
    dispatch: (u32, u32),
    screen: (u32, u32),
}

impl ComputeRaster {
    /// The passes for `scene` on a `size` screen writing `depth` (an [`COMPUTE_DEPTH_FORMAT`]
    /// view) and `ids` (the ID target's view), with IDs split by `layout`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        (size, layout, options): ((u32, u32), IdLayout, ComputeRasterOptions),
        (depth, ids): (&wgpu::TextureView, &wgpu::TextureView),
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        check_support(device.features(), features.msaa)?;
        // Every opaque draw's instances times its mesh's clusters.
        let mut entries = Vec::new();
        let mut triangles = 0u64;
        for d in scene.draws.iter().filter(|d| !d.kind.masked && !d.kind.blended) {
            let cull = if d.kind.double_sided { 0 } else { 1 << 31 };
            for instance in d.instances.clone() {
                for c in d.clusters.clone() {
                    entries.push(GpuEntry { instance, cluster: c | cull });
                    triangles += u64::from(scene.clusters[c as usize].triangles);
                }
            }
        }
        let clusters: Vec<GpuCluster> = scene
            .clusters
            .iter()
            .map(|c| GpuCluster {
                bounds_min: c.bounds.min.to_array(),
                first: c.first_triangle,
                bounds_max: c.bounds.max.to_array(),
                count: c.triangles,
            })
            .collect();
        // The per-triangle and per-cluster buffers grow with the triangles drawn (instances
        // times their mesh's), not the scene's own buffers: refused by the limit they pass.
        let limits = device.limits();
        let large_bytes = (triangles.max(1) * 8).max(16);
        check_storage_binding(&limits, large_bytes, || {
            format!("the compute raster's list of large triangles (8 bytes for each of {triangles} triangles drawn)")
        })?;
        check_storage_binding(&limits, entries.len() as u64 * 8, || {
            format!("the compute raster's {} (instance, cluster) entries", entries.len())
        })?;
        // At most 2^29 entries once their buffer fits a binding (at most 4 GiB).
        let n = entries.len() as u32;
        let dispatch = (n.clamp(1, GROUPS_X), n.div_ceil(GROUPS_X).max(1));
        let tile = tiledlight_cull::raster::LARGE_TILE;
        let screen_tiles = size.0.div_ceil(tile) * size.1.div_ceil(tile);
        let tile_capacity =
            if options.large == LargeRaster::Compute { screen_tiles * TILE_CAPACITY_SCREENS } else { 1 };
        let params = RasterParams {
            entries: n,
            groups_x: dispatch.0,
            large_px: options.large_px,
            triangle_bits: layout.triangle_bits,
            tile_capacity,
            pad: [0; 3],
        };
        use wgpu::BufferUsages as U;
        let params = buffer_init(device, "visibility.compute_raster.params", bytemuck::bytes_of(&params), U::UNIFORM);
        let entry_buf =
            buffer_init(device, "visibility.compute_raster.entries", bytemuck::cast_slice(&entries), U::STORAGE);
        let cluster_buf =
            buffer_init(device, "visibility.compute_raster.clusters", bytemuck::cast_slice(&clusters), U::STORAGE);
        let order_buf = buffer_init(
            device,
            "visibility.compute_raster.order",
            bytemuck::cast_slice(&scene.cluster_triangles),
            U::STORAGE,
        );
        let pixels = size.0 as usize * size.1 as usize;
        // Cleared once here; the finalize kernel clears them after each frame.
        let clear: Vec<u64> = vec![tiledlight_cull::raster::CLEAR; pixels];
        let texels = buffer_init(device, "visibility.compute_raster.texels", bytemuck::cast_slice(&clear), U::STORAGE);
        // Every triangle could be large: the list never overflows.
        let large_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visibility.compute_raster.large"),
            size: large_bytes,
            usage: U::STORAGE | U::COPY_SRC,
            mapped_at_creation: false,
        });
        let large_args = buffer_init(
            device,
            "visibility.compute_raster.large_args",
            bytemuck::cast_slice(&[0u32, 1, 0, 0, 0, 0, 0, 0]),
            U::STORAGE | U::COPY_SRC | if options.large == LargeRaster::Hardware { U::INDIRECT } else { U::empty() },
        );
        // (large list index << 3 | piece, tile x | tile y << 16) a listed tile.
        let tile_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visibility.compute_raster.large_tiles"),
            size: u64::from(tile_capacity) * 8,
            usage: U::STORAGE | U::COPY_SRC,
            mapped_at_creation: false,
        });
        memory.add("visibility.compute_raster.texels", pixels as u64 * 8);
        memory.add("visibility.compute_raster.large", large_buf.size());
        if options.large == LargeRaster::Compute {
            memory.add("visibility.compute_raster.large_tiles", tile_buf.size());
        }
        memory.add(
            "visibility.compute_raster.clusters",
            (entries.len() * 8 + clusters.len() * 32 + scene.cluster_triangles.len() * 4) as u64,
        );

        let compute_layout = create_layout(device, "visibility.compute_raster.layout", COMPUTE_RASTER_GROUP, &[]);
        let compute_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility.compute_raster.group"),
            layout: &compute_layout,
            entries: &[
                buf(24, &scene.instances),
                buf(25, &scene.materials),
                buf(26, &scene.indices),
                buf(27, &scene.positions),
                buf(40, &params),
                buf(41, &entry_buf),
                buf(42, &cluster_buf),
                buf(43, &texels),
                buf(44, &texels),
                buf(45, &large_buf),
                buf(46, &large_args),
                view_entry(47, depth),
                view_entry(48, ids),
                buf(50, &order_buf),
                buf(51, &tile_buf),
            ],
        });
        let module = keyed_module(device, &ComputeRasterKey::Clusters)?;
        let groups = [&views.layout, &compute_layout];
        // With the large triangles by compute, the clusters' kernel hands the triangles that
        // need clipping to them (the clipped polygon's arrays out of the hot kernel).
        let clipped_to_large = [("CLIPPED_TO_LARGE", f64::from(u8::from(options.large == LargeRaster::Compute)))];
        let clusters_pipeline = compute_pipeline_at(
            device,
            ("visibility.compute_raster.clusters", "cs_clusters"),
            &groups,
            &module,
            &clipped_to_large,
        );
        let finalize =
            compute_pipeline_at(device, ("visibility.compute_raster.finalize", "cs_finalize"), &groups, &module, &[]);
        let large_compute = (options.large == LargeRaster::Compute).then(|| LargeCompute {
            list: compute_pipeline_at(
                device,
                ("visibility.compute_raster.large_compute", "cs_large"),
                &groups,
                &module,
                &[],
            ),
            tiles: compute_pipeline_at(
                device,
                ("visibility.compute_raster.large_tiles", "cs_large_tiles"),
                &groups,
                &module,
                &[],
            ),
            items: tile_buf,
            capacity: tile_capacity,
        });

        let large = (options.large == LargeRaster::Hardware)
            .then(|| -> Result<_, GpuError> {
                let large_layout = create_layout(device, "visibility.compute_raster.large.layout", LARGE_GROUP, &[]);
                let large_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("visibility.compute_raster.large.group"),
                    layout: &large_layout,
                    entries: &[
                        buf(24, &scene.instances),
                        buf(25, &scene.materials),
                        buf(26, &scene.indices),
                        buf(27, &scene.positions),
                        buf(43, &texels),
                        buf(49, &large_buf),
                    ],
                });
                let large_module = keyed_module(device, &ComputeRasterKey::Large)?;
                let constants = [("TRIANGLE_BITS", f64::from(layout.triangle_bits))];
                let options =
                    wgpu::PipelineCompilationOptions { constants: &constants, zero_initialize_workgroup_memory: false };
                let large = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("visibility.compute_raster.large"),
                    layout: Some(&pipeline_layout(
                        device,
                        "visibility.compute_raster.large.pipeline_layout",
                        &[&views.layout, &large_layout],
                    )),
                    vertex: wgpu::VertexState {
                        module: &large_module,
                        entry_point: Some("vs_large"),
                        compilation_options: options.clone(),
                        buffers: &[],
                    },
                    // The compute pass culled back faces already.
                    primitive: wgpu::PrimitiveState::default(),
                    depth_stencil: None,
                    multisample: wgpu::MultisampleState::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &large_module,
                        entry_point: Some("fs_large"),
                        compilation_options: options,
                        targets: &[Some(wgpu::ColorTargetState {
                            format: ID_FORMAT,
                            blend: None,
                            write_mask: wgpu::ColorWrites::empty(),
                        })],
                    }),
                    multiview_mask: None,
                    cache: None,
                });
                Ok((large, large_group))
            })
            .transpose()?;
        let masked = if features.draw_kinds.iter().any(|k| k.masked && !k.blended) {
            let texels_layout = create_layout(device, "visibility.compute_raster.masked.layout", ATOMIC_TEXELS, &[]);
            let pass =
                DepthPrepass::with_atomic_ids(device, views, scene, features, (layout.triangle_bits, &texels_layout))?;
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("visibility.compute_raster.masked.group"),
                layout: &texels_layout,
                entries: &[buf(0, &texels)],
            });
            Some((pass, group, if scene.textures.is_some() && features.textures { 3 } else { 2 }))
        } else {
            None
        };
        Ok(Self {
            clusters: clusters_pipeline,
            large_compute,
            finalize,
            large,
            compute_group,
            masked,
            large_args,
            large_list: large_buf,
            dispatch,
            screen: size,
        })
    }

    /// Records the three steps (module doc): clusters, the hardware's share, finalize.
    /// `ids` is the ID target, attached (writes masked) to the hardware's pass.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        (views, view): (&Views, u32),
        scene: &SceneGpu,
        ids: &wgpu::TextureView,
    ) {
        timer.compute_pass(encoder, "visibility.raster.compute", |pass| {
            pass.set_pipeline(&self.clusters);
            pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
            pass.set_bind_group(1, &self.compute_group, &[]);
            pass.dispatch_workgroups(self.dispatch.0, self.dispatch.1, 1);
        });
        if let Some(large) = &self.large_compute {
            let tile = tiledlight_cull::raster::LARGE_TILE;
            timer.compute_pass(encoder, "visibility.raster.large", |pass| {
                pass.set_pipeline(&large.list);
                pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
                pass.set_bind_group(1, &self.compute_group, &[]);
                pass.dispatch_workgroups(LARGE_GROUPS, 1, 1);
                // As many workgroups (two items each) as the screen has tiles, looping.
                pass.set_pipeline(&large.tiles);
                pass.dispatch_workgroups(self.screen.0.div_ceil(tile), self.screen.1.div_ceil(tile), 1);
            });
            if self.masked.is_none() {
                // Nothing left for the hardware.
                return self.record_finalize(encoder, timer, (views, view));
            }
        }
        let t = timer.begin("visibility.raster.hardware", encoder);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visibility.raster.hardware"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: ids,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: t.render_writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let Some((large, group)) = &self.large {
                pass.set_pipeline(large);
                pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
                pass.set_bind_group(1, group, &[]);
                pass.draw_indirect(&self.large_args, 0);
            }
            if let Some((masked, group, index)) = &self.masked {
                pass.set_bind_group(*index, group, &[]);
                masked.draw(&mut pass, (views, view), scene, None, None);
            }
        }
        timer.end(encoder, t);
        self.record_finalize(encoder, timer, (views, view));
    }

    /// How many tiles the last frame listed for its large triangles (with
    /// [`LargeRaster::Compute`], else `None`). Stalls the GPU.
    pub fn read_large_tile_count(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<u32>, GpuError> {
        if self.large_compute.is_none() {
            return Ok(None);
        }
        let args: Vec<u32> = read_buffer(device, queue, &self.large_args)?;
        Ok(Some(args[5]))
    }

    /// The tiles the last frame listed for its large triangles (with [`LargeRaster::Compute`],
    /// else `None`). Stalls the GPU.
    pub fn read_large_tiles(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<LargeTiles>, GpuError> {
        let (Some(large), Some(listed)) = (&self.large_compute, self.read_large_tile_count(device, queue)?) else {
            return Ok(None);
        };
        let kept = listed.min(large.capacity);
        let capacity = large.capacity;
        if kept == 0 {
            return Ok(Some(LargeTiles { tiles: Vec::new(), listed, capacity }));
        }
        let items: Vec<[u32; 2]> = read_buffer_range(device, queue, &large.items, 0, u64::from(kept) * 8)?;
        let list: Vec<[u32; 2]> = read_buffer(device, queue, &self.large_list)?;
        let mut tiles: Vec<LargeTile> = items
            .iter()
            .map(|&[t, xy]| {
                let [instance, triangle] = list[(t >> 3) as usize];
                // The top bit: a clipped triangle's culling flag.
                LargeTile { instance, triangle: triangle & 0x7fff_ffff, piece: t & 7, tile: (xy & 0xffff, xy >> 16) }
            })
            .collect();
        tiles.sort_unstable();
        Ok(Some(LargeTiles { tiles, listed, capacity }))
    }

    /// Step 3: the texels to the depth and ID targets, reset for the next frame.
    fn record_finalize(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, (views, view): (&Views, u32)) {
        timer.compute_pass(encoder, "visibility.raster.finalize", |pass| {
            pass.set_pipeline(&self.finalize);
            pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
            pass.set_bind_group(1, &self.compute_group, &[]);
            pass.dispatch_workgroups(self.screen.0.div_ceil(8), self.screen.1.div_ceil(8), 1);
        });
    }
}
