//! The clustered layout on the GPU (Olsson, Billeter, Assarsson 2012): its options (the CPU
//! twin's [`ClusterOptions`]), the tile sides the GPU supports, and the variant of the
//! light-centric kernels that assigns lights to clusters ([`super::scatter`] builds it;
//! clusters are always assigned light-centrically).
//! Depends on [`crate::error`] only (and tiledlight-cull for the layout).

use crate::error::GpuError;

/// The clustered layout (Olsson, Billeter, Assarsson 2012), shared with the CPU twin:
/// screen tiles times depth slices, slice 0 from the eye to `first` (exponential slicing
/// would crowd the near plane: with near 0.1 and 24 slices, 10 fall within 5 m, so Bevy and
/// Filament start at 5 m), then exponential slices to `last`, the last reaching to
/// infinity. On the GPU the tile side must be 8, 16, 32, 64, 128 or 256 pixels
/// ([`super::CullOptions::validate`]).
pub use tiledlight_cull::ClusterConfig as ClusterOptions;

/// Cluster tile sides the tile-depth pass can reduce (a multiple of its 8 or 16 threads a
/// side).
pub const CLUSTER_TILE_SIZES: [u32; 6] = [8, 16, 32, 64, 128, 256];

/// Checks `c` as the CPU twin does, and its tile side against [`CLUSTER_TILE_SIZES`].
pub(super) fn check_on_gpu(c: &ClusterOptions) -> Result<(), GpuError> {
    c.validate()?;
    if !CLUSTER_TILE_SIZES.contains(&c.tile_size) {
        return Err(GpuError::Config(format!(
            "cluster tile size {} must be one of {:?} on the GPU",
            c.tile_size, CLUSTER_TILE_SIZES
        )));
    }
    Ok(())
}
