//! The error type of the culling math: every rejected input names what was wrong.

/// Invalid input to the culling math.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CullError {
    /// A camera parameter is NaN, infinite or out of range.
    #[error("invalid camera: {0}")]
    InvalidCamera(String),
    /// A light parameter is NaN, infinite or out of range.
    #[error("invalid light: {0}")]
    InvalidLight(String),
    /// A screen or tile size is zero or too large.
    #[error("invalid screen/tile size: {0}")]
    InvalidSize(String),
    /// A shadow setting is out of range or the casters do not fit the atlas.
    #[error("invalid shadow settings: {0}")]
    InvalidShadow(String),
    /// A virtual-point-light setting is out of range (RSM size, block, thresholds, cap).
    #[error("invalid VPL settings: {0}")]
    InvalidVpl(String),
    /// A depth buffer does not match the screen.
    #[error("invalid depth buffer: {0}")]
    InvalidDepth(String),
    /// The inputs of the contribution estimate ([`crate::contribution`]) do not match.
    #[error("invalid contribution estimate input: {0}")]
    InvalidEstimate(String),
}
