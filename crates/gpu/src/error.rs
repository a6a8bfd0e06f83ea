//! The error type of the GPU layer: each variant says what failed and why. A request
//! beyond an adapter limit names the limit, its value and what was asked
//! ([`GpuError::Limit`]); a lost device and an out-of-memory error have variants of their
//! own ([`GpuError::DeviceLost`], [`GpuError::OutOfMemory`]), so a caller can tell a
//! fault of the GPU from a mistake in the input (the lab keeps its results and says how to
//! resume).

/// Errors from device creation, shader loading and resource setup.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter matched, or none exists.
    #[error("no GPU adapter: {0}")]
    NoAdapter(String),
    /// The device could not be created.
    #[error("could not create the GPU device on {adapter}: {reason}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// Reason from wgpu.
        reason: String,
    },
    /// The adapter lacks something this configuration needs.
    #[error("the GPU '{adapter}' does not support {what}")]
    Unsupported {
        /// Adapter name.
        adapter: String,
        /// The missing feature or limit.
        what: String,
    },
    /// A shader failed to preprocess.
    #[error(transparent)]
    Shader(#[from] crate::shader::ShaderError),
    /// wgpu reported a validation or out-of-memory error.
    #[error("GPU error in {context}: {message}")]
    Wgpu {
        /// What was being done.
        context: String,
        /// wgpu's message.
        message: String,
    },
    /// A request beyond one of the device's limits: "the light grid needs 4,000,000 lists:
    /// limit max_storage_buffer_binding_size = 134217728, asked for 32000056 bytes".
    #[error("{what}: limit {name} = {limit}, asked for {asked}")]
    Limit {
        /// What needed it.
        what: String,
        /// The wgpu limit's name (`wgpu::Limits` field).
        name: &'static str,
        /// The device's value of the limit.
        limit: u64,
        /// What was asked for, with its unit.
        asked: String,
    },
    /// The device was lost (driver reset, GPU removed, out of memory in the driver, or
    /// `destroy` called): nothing more can be drawn with it.
    #[error("the GPU device was lost ({reason})")]
    DeviceLost {
        /// wgpu's reason and message.
        reason: String,
    },
    /// wgpu reported that the GPU is out of memory.
    #[error("out of GPU memory while {context}")]
    OutOfMemory {
        /// What was being done.
        context: String,
    },
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// Invalid input data.
    #[error(transparent)]
    Cull(#[from] tiledlight_cull::CullError),
    /// Mapping a buffer for readback failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
}

/// Loop iterations a CPU adapter's driver lets one shader run in all: llvmpipe (Mesa's
/// LP_MAX_TGSI_LOOP_ITERATIONS) stops every loop of a shader after this many iterations,
/// counted per group of lanes and shared by all its loops, and says nothing.
pub const CPU_LOOP_LIMIT: u64 = 65_535;

/// Whether `device`'s driver caps a shader's loops at [`CPU_LOOP_LIMIT`]: a CPU adapter.
pub fn has_cpu_loop_limit(device: &wgpu::Device) -> bool {
    device.adapter_info().device_type == wgpu::DeviceType::Cpu
}

/// Refuses, by name, a shader loop of `iterations` (at least: one a light) on a CPU
/// adapter, whose driver would cut it short at [`CPU_LOOP_LIMIT`] and leave a silently
/// wrong image; `what` names the loop ("brute force's loop over 100,000 lights"). GPUs
/// have no such limit.
pub fn check_cpu_loop_limit(device: &wgpu::Device, iterations: u64, what: &str) -> Result<(), GpuError> {
    if has_cpu_loop_limit(device) && iterations >= CPU_LOOP_LIMIT {
        return Err(GpuError::Unsupported {
            adapter: device.adapter_info().name,
            what: format!(
                "{what}: its driver stops a shader's loops after {CPU_LOOP_LIMIT} iterations in all, which would \
                 leave the image short of light; a tiled method, fewer lights or a GPU renders it"
            ),
        });
    }
    Ok(())
}
