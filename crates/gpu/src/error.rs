//! The error type of the GPU layer: each variant says what failed and why.

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
