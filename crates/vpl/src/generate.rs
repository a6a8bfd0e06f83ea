//! VPL generation on the GPU (`shaders/vpl_generate.wgsl`; CPU twin
//! `tiledlight_cull::vpl::generate`): one compute thread per `block x block` texels of each
//! RSM face makes at most one VPL, keeps it above the colour and brightness thresholds, and
//! appends it with an atomic counter up to the cap.
//!
//! The VPL buffers ([`VplBuffers`]) are shading data (`GpuVpl`, 48 bytes) and culling
//! spheres (`GpuCullLight`, 16 bytes, as the lights keep them apart), `cap` of each, and a
//! 4-byte counter. The counter counts every candidate, so nothing reads it back in a frame:
//! the passes after generation read `min(count, cap)` VPLs from the GPU, and `count - cap`
//! is what the cap refused ([`VplBuffers::read_count`], a debug readback for tests and for
//! the app's `warning:` line). Depends on tiledlight-gpu, tiledlight-cull and
//! [`crate::rsm`].

use tiledlight_cull::light::{GpuCullLight, PackedLights};
use tiledlight_cull::vpl::{GpuVpl, GpuVplParams};
use tiledlight_gpu::bindings::{create_layout, Binding, PassBindings, PassGroup};
use tiledlight_gpu::light_buffers::{LightBuffers, LightingUniforms};
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::read_buffer;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::{buffer_init, buffer_zeroed, compute_pipeline, shader_module};
use tiledlight_gpu::GpuError;

use crate::rsm::Rsm;

const C: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// The bindings of the generation pass (`shaders/vpl_generate.wgsl`).
pub const VPL_GENERATE_BINDINGS: PassBindings = PassBindings {
    entry: "vpl_generate.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::uniform(0, C),
            Binding::storage(1, C),
            Binding::texture(2, C, wgpu::TextureSampleType::Depth),
            Binding::texture(3, C, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::texture(4, C, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::storage_rw(5, C),
            Binding::storage_rw(6, C),
            Binding::storage_rw(7, C),
            Binding::storage_rw(8, C),
        ],
    )],
};

/// Threads per workgroup side (8 x 8 blocks of one face).
const WORKGROUP: u32 = 8;

/// The VPLs: what generation writes and culling and shading read.
pub struct VplBuffers {
    /// Shading data (`array<Vpl>`), `cap` entries.
    pub vpls: wgpu::Buffer,
    /// Culling spheres (`array<CullLight>`), `cap` entries.
    pub cull: wgpu::Buffer,
    /// The candidates' counter (`atomic<u32>`): `min(count, cap)` VPLs exist.
    pub count: wgpu::Buffer,
    /// The VPLs' `Lighting` uniform for the culling pass: zero but for `num_lights`, which
    /// the generation sets to `min(count, cap)` on the GPU.
    pub lighting: wgpu::Buffer,
    /// Most VPLs.
    pub cap: u32,
    /// Their bytes.
    pub memory: MemoryReport,
}

/// The VPL count as read back: kept and refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VplCount {
    /// VPLs in the buffers: `min(candidates, cap)`.
    pub kept: u32,
    /// Candidates the cap refused.
    pub refused: u32,
}

impl VplBuffers {
    /// Buffers for `cap` VPLs; errors naming the limit when they do not fit the device.
    pub fn new(device: &wgpu::Device, cap: u32) -> Result<Self, GpuError> {
        let bytes = cap as u64 * std::mem::size_of::<GpuVpl>() as u64;
        let limits = device.limits();
        let max = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        if bytes > max {
            return Err(GpuError::Limit {
                what: format!("--vpl-cap {cap} ({} bytes a VPL)", std::mem::size_of::<GpuVpl>()),
                name: "max_storage_buffer_binding_size",
                limit: max,
                asked: format!("{bytes} bytes"),
            });
        }
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let vpls = buffer_zeroed(device, "vpl.vpls", bytes.max(16), usage);
        let cull =
            buffer_zeroed(device, "vpl.cull", (cap as u64 * std::mem::size_of::<GpuCullLight>() as u64).max(16), usage);
        let count = buffer_zeroed(device, "vpl.count", 4, usage | wgpu::BufferUsages::COPY_DST);
        let lighting = buffer_zeroed(
            device,
            "vpl.lighting",
            std::mem::size_of::<LightingUniforms>() as u64,
            usage | wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let mut memory = MemoryReport::default();
        memory.add("vpl.vpls", vpls.size());
        memory.add("vpl.cull", cull.size());
        memory.add("vpl.count", count.size());
        memory.add("vpl.lighting", lighting.size());
        Ok(Self { vpls, cull, count, lighting, cap, memory })
    }

    /// The VPLs as a light set for `tiledlight_gpu`'s culling pass (`LightCulling`): their
    /// culling spheres and shading buffer, no spots, and `cap` empty CPU entries standing
    /// for the lights so that the pass sizes its lists for the cap. The real number of VPLs
    /// is on the GPU only ([`Self::lighting`]), so the CPU data must never be read as lights.
    pub fn as_lights(&self) -> LightBuffers {
        let packed = PackedLights {
            cull: vec![GpuCullLight::default(); self.cap as usize],
            num_point: self.cap,
            ..Default::default()
        };
        LightBuffers {
            cull: self.cull.clone(),
            shading: self.vpls.clone(),
            spots: None,
            packed,
            memory: MemoryReport::default(),
        }
    }

    /// Reads the counter back (a debug path: it waits for the GPU).
    pub fn read_count(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<VplCount, GpuError> {
        let count = read_buffer::<u32>(device, queue, &self.count)?[0];
        Ok(VplCount { kept: count.min(self.cap), refused: count.saturating_sub(self.cap) })
    }

    /// Reads the kept VPLs back (a debug path: it waits for the GPU).
    pub fn read_vpls(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<GpuVpl>, GpuError> {
        let kept = self.read_count(device, queue)?.kept as usize;
        let mut v = read_buffer::<GpuVpl>(device, queue, &self.vpls)?;
        v.truncate(kept);
        Ok(v)
    }

    /// Reads the kept VPLs' culling spheres back (a debug path).
    pub fn read_cull(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<GpuCullLight>, GpuError> {
        let kept = self.read_count(device, queue)?.kept as usize;
        let mut v = read_buffer::<GpuCullLight>(device, queue, &self.cull)?;
        v.truncate(kept);
        Ok(v)
    }
}

/// The generation pass over one RSM into one set of VPL buffers.
pub struct VplGenerate {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// Kept alive for the bind group.
    _params: wgpu::Buffer,
    workgroups: (u32, u32, u32),
}

impl VplGenerate {
    /// The pass reading `rsm` (its settings: block, thresholds, cap) into `buffers`.
    pub fn new(device: &wgpu::Device, rsm: &Rsm, buffers: &VplBuffers) -> Result<Self, GpuError> {
        let cfg = &rsm.config;
        if cfg.cap != buffers.cap {
            return Err(GpuError::Config(format!(
                "the VPL buffers hold {} VPLs; the settings' cap is {}",
                buffers.cap, cfg.cap
            )));
        }
        let faces = rsm.layout.faces;
        let max_groups = device.limits().max_compute_workgroups_per_dimension;
        if faces > max_groups {
            return Err(GpuError::Limit {
                what: format!("VPL generation over {faces} RSM faces (one workgroup layer each)"),
                name: "max_compute_workgroups_per_dimension",
                limit: max_groups.into(),
                asked: format!("{faces} workgroups"),
            });
        }
        let params = buffer_init(
            device,
            "vpl.generate.params",
            bytemuck::bytes_of(&GpuVplParams::new(cfg, faces)),
            wgpu::BufferUsages::UNIFORM,
        );
        let layout = create_layout(device, "vpl.generate.layout", VPL_GENERATE_BINDINGS.group(0), &[]);
        let module = shader_module(device, VPL_GENERATE_BINDINGS.entry, &[])?;
        let pipeline = compute_pipeline(device, "vpl.generate", &[&layout], &module, &[]);
        use tiledlight_gpu::util::{buffer_entry as buf, view_entry as tex};
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vpl.generate.bind_group"),
            layout: &layout,
            entries: &[
                buf(0, &params),
                buf(1, &rsm.faces),
                tex(2, &rsm.depth_view),
                tex(3, &rsm.albedo_view),
                tex(4, &rsm.normal_view),
                buf(5, &buffers.vpls),
                buf(6, &buffers.cull),
                buf(7, &buffers.count),
                buf(8, &buffers.lighting),
            ],
        });
        let n = cfg.blocks_per_side().div_ceil(WORKGROUP);
        Ok(Self { pipeline, bind_group, _params: params, workgroups: (n, n, faces) })
    }

    /// Zeroes the counter and makes the VPLs (`vpl.generate`).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, buffers: &VplBuffers) {
        encoder.clear_buffer(&buffers.count, 0, None);
        encoder.clear_buffer(&buffers.lighting, 0, None);
        if self.workgroups.2 == 0 {
            return;
        }
        let t = timer.begin("vpl.generate", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("vpl.generate"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            let (x, y, z) = self.workgroups;
            pass.dispatch_workgroups(x, y, z);
        }
        timer.end(encoder, t);
    }
}
