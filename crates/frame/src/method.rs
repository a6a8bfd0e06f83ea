//! What a method contributes to a frame ([`MethodFrame`]): its middle steps, recorded
//! between the shared ones with the handles they read, and the light grid it makes; and
//! every method registered once ([`Registration`], [`METHODS`]): which methods a frame
//! renders, the steps it records, the display targets it needs and its constructor. The
//! plan ([`crate::plan::FramePlan`]) and the renderer ([`crate::FrameRenderer::new`]) read
//! the registration and match on no method. Adding a method: its crate or module with its
//! passes and WGSL, one file here with its frame (a `MethodFrame`, its target needs, its
//! steps and its `REGISTRATION`), one line in [`METHODS`], and its variant of
//! [`Method`] (name, label, summary). Depends on [`crate::handles`], [`crate::shared`] and
//! [`crate::plan`] (the steps).

use std::any::Any;

use tiledlight_gpu::features::{Features, Method};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::handles::Rec;
use crate::plan::Step;
use crate::settings::FrameSettings;
use crate::shared::{SharedSteps, TargetNeeds};
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

/// A method's constructor: its passes over the shared steps, for the scene, lights and
/// settings, adding what it allocates to the memory report.
pub type Build = fn(
    &GpuContext,
    &SharedSteps,
    (&SceneGpu, &LightBuffers),
    &FrameSettings,
    &mut MemoryReport,
) -> Result<Box<dyn MethodFrame>, GpuError>;

/// One method's registration: everything the plan and the renderer need of it. A frame type
/// may render several methods (Forward+'s renders brute force, the visibility buffer's the
/// traced reference), each with its own registration.
pub struct Registration {
    /// The methods it renders.
    pub renders: fn(Method) -> bool,
    /// What a build error says it was doing ("building the Forward+ renderer").
    pub building: &'static str,
    /// Its steps between the shared head (shadow maps, VPLs) and the shared tail (blended
    /// geometry, tonemap, heat map), in recording order, for a frame of `features`: what
    /// writes depth, its culling, the shared VPL culling where it puts it, its shading.
    pub steps: fn(&Features) -> Vec<Step>,
    /// The display targets it needs of the shared steps.
    pub targets: fn(&Features) -> TargetNeeds,
    /// Its constructor.
    pub build: Build,
}

/// Every method, registered once (each of [`Method::ALL`] by exactly one).
pub const METHODS: [&Registration; 5] = [
    &crate::forward_plus::FORWARD_PLUS,
    &crate::forward_plus::BRUTE_FORCE,
    &crate::tiled_deferred::REGISTRATION,
    &crate::visibility::REGISTRATION,
    &crate::visibility::TRACED,
];

/// The registration of `method`.
pub fn registration(method: Method) -> &'static Registration {
    METHODS.into_iter().find(|r| (r.renders)(method)).unwrap_or_else(|| panic!("{method:?} is not registered"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each method is rendered by exactly one registration, and each registration renders
    /// some method.
    #[test]
    fn every_method_is_registered_once() {
        for m in Method::ALL {
            let n = METHODS.iter().filter(|r| (r.renders)(m)).count();
            assert_eq!(n, 1, "{m:?}: {n} registrations");
        }
        for r in METHODS {
            assert!(Method::ALL.into_iter().any(|m| (r.renders)(m)), "{} renders no method", r.building);
        }
    }
}
