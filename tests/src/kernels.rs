//! Running a WGSL function on the GPU for its twin test: a test shader that includes the
//! function from `shaders/` ([`test_module`]), and a one-dispatch kernel over an input and
//! an output buffer ([`run_cases`]), and the small seeded generator the twin tests draw
//! their cases with ([`Rng`]). Depends on tiledlight-gpu and wgpu.

use tiledlight_gpu::GpuContext;

/// The shader module of test source `source` (named `name` in errors), whose `#include`s
/// come from the embedded `shaders/` tree.
pub fn test_module(ctx: &GpuContext, name: &str, source: &str) -> wgpu::ShaderModule {
    let files = |p: &str| {
        if p == name {
            Some(source.to_string())
        } else {
            tiledlight_gpu::shader::embedded(p).map(str::to_owned)
        }
    };
    let text = tiledlight_gpu::shader::preprocess_with(&files, name, &[]).expect("preprocess").text;
    ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Wgsl(text.into()),
    })
}

/// Runs entry `main` of `source` once over `cases` invocations (workgroups of 64), its
/// group 0 holding `input` (binding 0, read-only storage) and an output of `output_bytes`
/// (binding 1, read-write storage, zeroed), and reads the output back as f32s.
pub fn run_cases(ctx: &GpuContext, name: &str, source: &str, input: &[u8], cases: u32, output_bytes: u64) -> Vec<f32> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let module = test_module(ctx, name, source);
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input = tiledlight_gpu::util::buffer_init(device, &format!("{name}.cases"), input, usage);
    let output = tiledlight_gpu::util::buffer_zeroed(device, &format!("{name}.out"), output_bytes, usage);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(name),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(name),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: output.as_entire_binding() },
        ],
    });
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) });
    {
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(name), timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(cases.div_ceil(64), 1, 1);
    }
    queue.submit([enc.finish()]);
    tiledlight_gpu::readback::read_buffer(device, queue, &output).expect("readback")
}

/// A xorshift generator of f32s in [0, 1): the twin tests' cases, reproducible from the
/// seed (no dependency on the cull crate's test helpers).
pub struct Rng(pub u32);

impl Rng {
    /// The next value in [0, 1).
    pub fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    /// Log-uniform in [lo, hi) (both positive).
    pub fn log(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }
}
