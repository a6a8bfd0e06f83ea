//! Automatic exposure: the frame's log-average luminance, computed on the GPU before the
//! tonemap reads it (exists only when the exposure is automatic). CPU twin:
//! `tiledlight_cull::exposure`. Depends on wgpu and this crate's utilities.

use crate::bindings::{create_layout, Binding, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::timer::GpuTimer;
use crate::util::{buffer_zeroed, compute_pipeline_at, shader_module};

/// The bindings of [`AutoExposure`] (`shaders/exposure.wgsl`): the HDR image (0), the
/// per-workgroup sums (1) and the exposure (2).
pub const EXPOSURE_BINDINGS: PassBindings = PassBindings {
    entry: "exposure.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, wgpu::ShaderStages::COMPUTE, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::storage_rw(1, wgpu::ShaderStages::COMPUTE),
            Binding::storage_rw(2, wgpu::ShaderStages::COMPUTE),
        ],
    )],
};

/// Automatic exposure (`shaders/exposure.wgsl`; CPU twin
/// `tiledlight_cull::exposure::auto_exposure`): two compute dispatches before the tonemap,
/// a workgroup per 16 x 16 pixels summing log2 luminance, then one workgroup turning the
/// sums into the exposure the tonemap reads. Exists only when the exposure is automatic.
pub struct AutoExposure {
    reduce: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    groups: (u32, u32),
    /// The exposure (one f32) the tonemap reads; COPY_SRC for [`crate::tonemap::TonemapPass::read_exposure`].
    pub(crate) exposure: wgpu::Buffer,
}

impl AutoExposure {
    pub(crate) fn new(device: &wgpu::Device, hdr: &wgpu::TextureView, size: (u32, u32)) -> Result<Self, GpuError> {
        use tiledlight_cull::exposure::{AUTO_EXPOSURE_KEY, MAX_EXPOSURE, MIN_LUMINANCE};
        let groups = (size.0.div_ceil(16), size.1.div_ceil(16));
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let partials = buffer_zeroed(device, "exposure.partials", u64::from(groups.0 * groups.1) * 8, usage);
        let exposure = buffer_zeroed(device, "exposure.value", 4, usage);
        let layout = create_layout(device, "exposure.layout", EXPOSURE_BINDINGS.group(0), &[]);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("exposure.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) },
                wgpu::BindGroupEntry { binding: 1, resource: partials.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: exposure.as_entire_binding() },
            ],
        });
        let module = shader_module(device, EXPOSURE_BINDINGS.entry, &[])?;
        let constants = [
            ("KEY", f64::from(AUTO_EXPOSURE_KEY)),
            ("MIN_LUMINANCE", f64::from(MIN_LUMINANCE)),
            ("MAX_EXPOSURE", f64::from(MAX_EXPOSURE)),
        ];
        let pipeline =
            |label: &str, entry: &str| compute_pipeline_at(device, (label, entry), &[&layout], &module, &constants);
        Ok(Self {
            reduce: pipeline("exposure.reduce", "reduce"),
            finish: pipeline("exposure.finish", "finish"),
            group,
            groups,
            exposure,
        })
    }

    pub(crate) fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer) {
        let t = timer.begin("exposure", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("exposure"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_bind_group(0, &self.group, &[]);
            pass.set_pipeline(&self.reduce);
            pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
            pass.set_pipeline(&self.finish);
            pass.dispatch_workgroups(1, 1, 1);
        }
        timer.end(encoder, t);
    }
}
