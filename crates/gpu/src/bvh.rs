//! The scene's BVH on the GPU for the traced reference's shadow rays
//! (`shaders/common/trace.wgsl`): [`GpuBvh`] uploads a [`TraceGeometry`] (nodes, triangles
//! with their mask slots, and with alpha-masked casters the masks), built once per scene
//! and only when the traced reference is asked for ([`crate::scene_gpu::SceneGpu::add_trace`]).
//! [`RayQueries`] casts a list of segments through it, one a thread
//! (`shaders/trace_rays.wgsl`): the twin test's kernel. Depends on tiledlight-cull's
//! `trace` (layout and CPU twin), tiledlight-scene's `trace` (what casts) and this crate's
//! helpers.

use crate::define::Define;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use tiledlight_cull::trace::{FlatNode, NO_MASK};
use tiledlight_scene::trace::TraceGeometry;

use crate::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use crate::memory::MemoryReport;
use crate::readback::read_buffer;
use crate::util::{buffer_entry, buffer_init, buffer_zeroed, check_storage_binding, compute_pipeline, keyed_module};
use crate::variants::{ShaderKey, TraceRaysKey};
use crate::GpuError;

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// The hierarchy, triangles and masks (the first `count` bindings of a group, numbered
/// from `base`): nodes, triangles, and with `TRACE_MASKS` uvs, mask slots and bits.
pub const fn trace_bindings(base: u32) -> [Binding; 5] {
    [
        Binding::storage(base, CS),
        Binding::storage(base + 1, CS),
        Binding::storage(base + 2, CS).when(Cond::Defined(Define::TraceMasks)),
        Binding::storage(base + 3, CS).when(Cond::Defined(Define::TraceMasks)),
        Binding::storage(base + 4, CS).when(Cond::Defined(Define::TraceMasks)),
    ]
}

const RAYS_GROUP: &[Binding] = &{
    let t = trace_bindings(0);
    [t[0], t[1], t[2], t[3], t[4], Binding::storage(5, CS), Binding::storage_rw(6, CS)]
};

/// The bindings of `shaders/trace_rays.wgsl`: the hierarchy (0-4, [`trace_bindings`]),
/// the segments (5) and the answers (6).
pub const TRACE_RAYS_BINDINGS: PassBindings =
    PassBindings { entry: "trace_rays.wgsl", source: file!(), groups: &[PassGroup::new(0, RAYS_GROUP)] };

/// The mask buffers.
pub struct MaskBuffers {
    /// Per triangle (leaf order) three texture coordinates.
    pub uvs: wgpu::Buffer,
    /// Per mask: width, height, wrap, first word.
    pub slots: wgpu::Buffer,
    /// The bits.
    pub bits: wgpu::Buffer,
}

/// The uploaded hierarchy.
pub struct GpuBvh {
    /// `array<TraceNode>` (64 bytes a node).
    pub nodes: wgpu::Buffer,
    /// `array<vec4<f32>>`, three a triangle: its vertices, the first one's w its mask slot.
    pub triangles: wgpu::Buffer,
    /// With alpha-masked casters.
    pub masks: Option<MaskBuffers>,
    /// Triangles in it.
    pub triangle_count: u32,
    /// Nodes in it.
    pub node_count: u32,
    /// Node levels below the root.
    pub depth: u32,
    /// Seconds the CPU took to build and flatten it.
    pub build_seconds: f64,
    /// The scene's size the rays' offset is bounded by ([`TraceGeometry::scale`]).
    pub scale: f32,
    /// Its buffers' bytes.
    pub memory: MemoryReport,
}

/// A triangle vertex as uploaded.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct TraceVertex {
    p: [f32; 3],
    w: u32,
}

/// Bytes of the triangle buffer a triangle takes: three `TraceVertex`es.
const TRIANGLE_BYTES: u64 = 3 * size_of::<TraceVertex>() as u64;

/// Whether `triangles` casting triangles fit one binding of the triangle buffer.
fn check_triangles(limits: &wgpu::Limits, triangles: u64) -> Result<(), GpuError> {
    check_storage_binding(limits, triangles * TRIANGLE_BYTES, || {
        format!("the traced reference's {triangles} triangles ({TRIANGLE_BYTES} bytes each)")
    })
}

impl GpuBvh {
    /// Builds the hierarchy of `scene`'s casting geometry on the CPU and uploads it.
    pub fn of_scene(device: &wgpu::Device, scene: &tiledlight_scene::Scene) -> Result<Self, GpuError> {
        // Refused before the build, which takes about a second and a few hundred MB of CPU
        // memory a million triangles.
        check_triangles(&device.limits(), TraceGeometry::casting_triangles(scene))?;
        let start = Instant::now();
        let geometry = TraceGeometry::of(scene);
        let seconds = start.elapsed().as_secs_f64();
        let mut bvh = Self::new(device, &geometry)?;
        bvh.build_seconds = seconds;
        Ok(bvh)
    }

    /// Uploads `geometry`. A scene past the GPU's storage-buffer size is refused by name.
    pub fn new(device: &wgpu::Device, geometry: &TraceGeometry) -> Result<Self, GpuError> {
        let flat = &geometry.flat;
        let usage = wgpu::BufferUsages::STORAGE;
        let limits = device.limits();
        check_triangles(&limits, flat.triangles.len() as u64)?;
        check_storage_binding(&limits, (flat.nodes.len() * size_of::<FlatNode>()) as u64, || {
            format!("the traced reference's {} BVH nodes", flat.nodes.len())
        })?;
        let slot_of =
            |leaf: usize| -> u32 { geometry.masks.as_ref().map_or(NO_MASK, |m| m.slots[flat.ids[leaf] as usize]) };
        let vertices: Vec<TraceVertex> = flat
            .triangles
            .iter()
            .enumerate()
            .flat_map(|(i, t)| {
                let w = slot_of(i);
                let v = |p: Vec3, w: u32| TraceVertex { p: p.to_array(), w };
                [v(t[0], w), v(t[1], 0), v(t[2], 0)]
            })
            .collect();
        let nodes = buffer_init(device, "trace.nodes", bytemuck::cast_slice(&flat.nodes), usage);
        let triangles = buffer_init(device, "trace.triangles", bytemuck::cast_slice(&vertices), usage);
        let mut memory = MemoryReport::default();
        memory.add("trace.nodes", nodes.size());
        memory.add("trace.triangles", triangles.size());
        let masks = geometry.masks.as_ref().map(|m| {
            let uvs: Vec<[f32; 2]> =
                flat.ids.iter().flat_map(|&id| m.uvs[id as usize].map(|uv| uv.to_array())).collect();
            let b = MaskBuffers {
                uvs: buffer_init(device, "trace.uvs", bytemuck::cast_slice(&uvs), usage),
                slots: buffer_init(device, "trace.mask_slots", bytemuck::cast_slice(&m.masks.slots), usage),
                bits: buffer_init(device, "trace.mask_bits", bytemuck::cast_slice(&m.masks.bits), usage),
            };
            memory.add("trace.masks", b.uvs.size() + b.slots.size() + b.bits.size());
            b
        });
        Ok(Self {
            nodes,
            triangles,
            masks,
            triangle_count: flat.triangles.len() as u32,
            node_count: flat.nodes.len() as u32,
            depth: flat.depth,
            build_seconds: 0.0,
            scale: geometry.scale,
            memory,
        })
    }

    /// The bind group entries of [`trace_bindings`]`(base)`.
    pub fn entries(&self, base: u32) -> Vec<wgpu::BindGroupEntry<'_>> {
        let mut e = vec![buffer_entry(base, &self.nodes), buffer_entry(base + 1, &self.triangles)];
        if let Some(m) = &self.masks {
            e.extend([
                buffer_entry(base + 2, &m.uvs),
                buffer_entry(base + 3, &m.slots),
                buffer_entry(base + 4, &m.bits),
            ]);
        }
        e
    }
}

/// Segments cast through a [`GpuBvh`], one a thread: the twin test's kernel.
pub struct RayQueries {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    masks: bool,
}

impl RayQueries {
    /// Builds the kernel for `bvh` (its mask variant).
    pub fn new(device: &wgpu::Device, bvh: &GpuBvh) -> Result<Self, GpuError> {
        let key = TraceRaysKey { masks: bvh.masks.is_some() };
        let defines = key.defines();
        let layout = create_layout(device, "trace_rays.layout", RAYS_GROUP, &defines);
        let module = keyed_module(device, &key)?;
        let pipeline = compute_pipeline(device, "trace_rays", &[&layout], &module, &[]);
        Ok(Self { pipeline, layout, masks: key.masks })
    }

    /// Whether each segment `(from, to, eps)` is blocked, as the GPU casts it.
    pub fn cast(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        bvh: &GpuBvh,
        segments: &[(Vec3, Vec3, f32)],
    ) -> Result<Vec<bool>, GpuError> {
        if segments.is_empty() {
            return Ok(Vec::new());
        }
        if self.masks != bvh.masks.is_some() {
            return Err(GpuError::Config("the ray kernel was built for another hierarchy's masks".into()));
        }
        let data: Vec<[f32; 4]> =
            segments.iter().flat_map(|(a, b, eps)| [a.extend(*eps).to_array(), b.extend(0.0).to_array()]).collect();
        let input =
            buffer_init(device, "trace_rays.segments", bytemuck::cast_slice(&data), wgpu::BufferUsages::STORAGE);
        let n = segments.len() as u64;
        let output = buffer_zeroed(
            device,
            "trace_rays.blocked",
            n * 4,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let mut entries = bvh.entries(0);
        entries.push(buffer_entry(5, &input));
        entries.push(wgpu::BindGroupEntry {
            binding: 6,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &output,
                offset: 0,
                size: wgpu::BufferSize::new(n * 4),
            }),
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace_rays.group"),
            layout: &self.layout,
            entries: &entries,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("trace_rays") });
        {
            let mut pass = encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("trace_rays"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
        }
        queue.submit([encoder.finish()]);
        let out: Vec<u32> = read_buffer(device, queue, &output)?;
        Ok(out.into_iter().map(|b| b != 0).collect())
    }
}

/// The Rust structs shared with `shaders/common/trace.wgsl`.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(
        FlatNode,
        "TraceNode",
        "common/trace_types.wgsl",
        [a_lo, a_link, a_hi, a_count, b_lo, b_link, b_hi, b_count]
    )]
}
