//! The stochastic method's denoiser (issue 48, step 4; `shaders/stochastic_denoise.wgsl`,
//! CPU twin `tiledlight_cull::denoise`, whose module doc numbers the steps): after the
//! shading pass has updated the history and left each pixel's normal, view distance,
//! albedo and unlit term (its binding 41, `DENOISE`), one compute pass of `iterations + 1`
//! dispatches: the history divided by the albedo with the variance of its mean, then
//! à-trous iterations at steps 1, 2, 4, ... between two buffers, the last one writing the
//! HDR image. Exists only with `--denoise N` > 0 on the stochastic method. Depends on
//! tiledlight-gpu (bindings, timer, utilities) and tiledlight-cull (the constants).

use tiledlight_cull::denoise::{EPS_L, EPS_Z, MAX_ITERATIONS, SHORT_HISTORY, SIGMA_L, SIGMA_Z};
use tiledlight_gpu::bindings::{create_layout, Binding, PassBindings, PassGroup};
use tiledlight_gpu::handles::Hdr;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::recording::Recording;
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::util::{buffer_entry, buffer_init, buffer_zeroed, compute_pipeline_at, shader_module, view_entry};
use tiledlight_gpu::GpuError;

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// Bytes a pixel of the shading pass's guide: three planes of a `vec4<f32>` (surface,
/// albedo, unlit).
pub const GUIDE_BYTES_PER_PIXEL: u64 = 48;

/// The stride of one dispatch's parameters in the uniform buffer (a dynamic offset's
/// alignment).
const PARAMS_STRIDE: u64 = 256;

/// The bindings of [`StochasticDenoise`] (`shaders/stochastic_denoise.wgsl`): the guide
/// (0), the source (1) and destination (2) buffers, the dispatch's parameters (3, a dynamic
/// offset a dispatch) and the HDR image the last one writes (4).
pub const DENOISE_BINDINGS: PassBindings = PassBindings {
    entry: "stochastic_denoise.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::storage(0, CS),
            Binding::storage(1, CS),
            Binding::storage_rw(2, CS),
            Binding::uniform(3, CS).dynamic_offset(16),
            Binding::storage_texture(4, CS, HDR_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
        ],
    )],
};

/// The denoiser's pipelines, buffers and bind groups, built once.
pub struct StochasticDenoise {
    demodulate: wgpu::ComputePipeline,
    atrous: wgpu::ComputePipeline,
    last: wgpu::ComputePipeline,
    /// history -> ping, ping -> pong, pong -> ping.
    groups: [wgpu::BindGroup; 3],
    params: wgpu::Buffer,
    /// The working buffers (`[f32; 4]` a pixel: light over albedo, variance), held with
    /// the bind groups that read and write them.
    _working: [wgpu::Buffer; 2],
    iterations: u32,
    size: (u32, u32),
}

impl StochasticDenoise {
    /// The pass over the shading pass's `history` and `guide` buffers, writing `hdr`
    /// (`size` pixels); `iterations` from 1 to [`MAX_ITERATIONS`].
    pub fn new(
        device: &wgpu::Device,
        (history, guide): (&wgpu::Buffer, &wgpu::Buffer),
        hdr: Hdr<'_>,
        size: (u32, u32),
        iterations: u32,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        if !(1..=MAX_ITERATIONS).contains(&iterations) {
            return Err(GpuError::Config(format!(
                "the stochastic denoiser runs 1 to {MAX_ITERATIONS} iterations, not {iterations}"
            )));
        }
        let bytes = u64::from(size.0) * u64::from(size.1) * 16;
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let ping = buffer_zeroed(device, "stochastic.denoise.ping", bytes, usage);
        let pong = buffer_zeroed(device, "stochastic.denoise.pong", bytes, usage);
        memory.add("stochastic.denoise", 2 * bytes);
        // Every dispatch's size and step, written once; the frames in the history's mean
        // are rewritten each frame ([`Self::write_frame`]).
        let mut data = vec![0u8; (PARAMS_STRIDE * u64::from(iterations + 1)) as usize];
        for k in 0..=iterations {
            // Dispatch 0 demodulates (its step unused); dispatch k is iteration k - 1.
            let words = [size.0, size.1, 1u32 << k.saturating_sub(1), 1];
            let at = (PARAMS_STRIDE * u64::from(k)) as usize;
            data[at..at + 16].copy_from_slice(bytemuck::cast_slice(&words));
        }
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let params = buffer_init(device, "stochastic.denoise.params", &data, usage);
        let layout = create_layout(device, "stochastic.denoise.layout", DENOISE_BINDINGS.group(0), &[]);
        let group = |label: &str, src: &wgpu::Buffer, dst: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &[
                    buffer_entry(0, guide),
                    buffer_entry(1, src),
                    buffer_entry(2, dst),
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &params,
                            offset: 0,
                            size: wgpu::BufferSize::new(16),
                        }),
                    },
                    view_entry(4, hdr.view),
                ],
            })
        };
        let groups = [
            group("stochastic.denoise.history_to_ping", history, &ping),
            group("stochastic.denoise.ping_to_pong", &ping, &pong),
            group("stochastic.denoise.pong_to_ping", &pong, &ping),
        ];
        let module = shader_module(device, DENOISE_BINDINGS.entry, &[])?;
        // `LAST`: the last iteration writes the HDR image (one entry point, two pipelines).
        let pipeline = |label: &str, entry: &str, last: bool| {
            let constants = [
                ("SHORT_HISTORY", f64::from(SHORT_HISTORY)),
                ("SIGMA_L", f64::from(SIGMA_L)),
                ("SIGMA_Z", f64::from(SIGMA_Z)),
                ("EPS_L", f64::from(EPS_L)),
                ("EPS_Z", f64::from(EPS_Z)),
                ("LAST", f64::from(u8::from(last))),
            ];
            compute_pipeline_at(device, (label, entry), &[&layout], &module, &constants)
        };
        Ok(Self {
            demodulate: pipeline("stochastic.denoise.demodulate", "demodulate", false),
            atrous: pipeline("stochastic.denoise.atrous", "atrous", false),
            last: pipeline("stochastic.denoise.atrous_last", "atrous", true),
            groups,
            params,
            _working: [ping, pong],
            iterations,
            size,
        })
    }

    /// Writes the frames in the history's mean (`frames`, at least 1) into every
    /// dispatch's parameters: one word each, nothing allocated.
    pub fn write_frame(&self, queue: &wgpu::Queue, frames: u32) {
        for k in 0..=self.iterations {
            queue.write_buffer(&self.params, PARAMS_STRIDE * u64::from(k) + 12, bytemuck::bytes_of(&frames.max(1)));
        }
    }

    /// Records the pass: demodulation, then the iterations, the last into the HDR image.
    pub fn record(&self, r: &mut Recording<'_>) {
        let (encoder, timer) = (&mut *r.encoder, r.timer);
        let t = timer.begin("stochastic.denoise", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("stochastic.denoise"),
                timestamp_writes: t.compute_writes(),
            });
            let groups = (self.size.0.div_ceil(8), self.size.1.div_ceil(8));
            let offset = |k: u32| [(PARAMS_STRIDE * u64::from(k)) as u32];
            pass.set_pipeline(&self.demodulate);
            pass.set_bind_group(0, &self.groups[0], &offset(0));
            pass.dispatch_workgroups(groups.0, groups.1, 1);
            for k in 0..self.iterations {
                // Iteration k reads ping (even k) or pong (odd k).
                let group = if k % 2 == 0 { &self.groups[1] } else { &self.groups[2] };
                pass.set_pipeline(if k + 1 == self.iterations { &self.last } else { &self.atrous });
                pass.set_bind_group(0, group, &offset(k + 1));
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
        }
        timer.end(encoder, t);
    }
}
