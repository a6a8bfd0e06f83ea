//! What a method contributes to a frame ([`MethodFrame`]): its middle steps, recorded
//! between the shared ones with the handles they read, and the light grid it makes. Adding
//! a method: its crate or module with its passes and WGSL, one file here with its frame
//! function (a `MethodFrame` and its target needs), one arm in [`crate::FrameRenderer::new`].
//! Depends on [`crate::handles`] and [`crate::shared`].

use std::any::Any;

use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::handles::Rec;
use crate::shared::SharedSteps;
use tiledlight_gpu::handles::{Depth, Lists};

/// A method's middle steps.
pub trait MethodFrame: Any {
    /// Records the method's steps, in its plan's order: what writes `depth` (drawn into
    /// here), its culling, the shared VPL culling where the method puts it
    /// ([`SharedSteps::record_vpl_cull`]), the shading that writes the HDR image (the
    /// handle its constructor took).
    fn record(&self, rec: &mut Rec<'_>, shared: &SharedSteps, depth: Depth<'_>);
    /// The opaque light grid the method shades with (tiled methods).
    fn lists(&self) -> Option<Lists<'_>>;
    /// Grows that grid's index buffer to `capacity` and rebinds it wherever the method reads
    /// it; returns the grown grid (None without one).
    fn grow_lists(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, capacity: u32) -> Option<&LightGrid>;
    /// Pixels of the last frame that an MSAA edge test sent to per-sample shading, when the
    /// method has such a test (stalls the GPU).
    fn edge_pixels(&self, _ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        Ok(None)
    }
    /// For [`crate::FrameRenderer::passes`]: the method's own type.
    fn as_any(&self) -> &dyn Any;
}
