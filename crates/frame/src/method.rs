//! What a method contributes to a frame ([`MethodFrame`]): its middle steps, recorded
//! between the shared ones with the handles they read, and the light grid it makes; and
//! what a method registers ([`Registration`]): which methods a frame renders, the steps it
//! records, the display targets it needs and its constructor (the list of registrations is
//! [`crate::registry`]). Depends on [`crate::handles`], [`crate::shared`],
//! [`crate::settings`] and [`crate::plan`] (the steps).

use std::any::Any;

use crate::methods::Method;
use tiledlight_cull::Camera;
use tiledlight_gpu::features::Features;
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
    /// Writes the method's own per-frame uniforms for a frame through `camera`, before it
    /// is recorded (the stochastic method's seed and history length); nothing by default.
    fn prepare(&self, _queue: &wgpu::Queue, _camera: &Camera) {}
    /// The lights or the scene changed between frames: what the method kept of earlier
    /// frames no longer holds (the stochastic method's history); nothing by default.
    fn scene_changed(&self) {}
    /// The lights moved or changed (the same count, `lights` as now uploaded): what the
    /// method built from them is brought up to date (the stochastic method's light tree);
    /// nothing by default.
    fn lights_changed(&self, _queue: &wgpu::Queue, _lights: &tiledlight_cull::light::PackedLights) {}
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
    /// Screen tiles the last frame listed for its large triangles, when the method draws
    /// them by compute tiles (the visibility buffer's compute raster; stalls the GPU).
    fn large_tiles(&self, _ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
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

/// The steps of a tiled method: `head` (what writes depth, and its culling where it culls
/// before shading), the shared VPL culling with VPLs, `shade`, and with MSAA `resolve`.
pub fn tiled_steps(features: &Features, head: &[Step], shade: Step, resolve: Option<Step>) -> Vec<Step> {
    let mut steps = head.to_vec();
    if features.vpl {
        steps.push(Step::VplCull);
    }
    steps.push(shade);
    steps.extend(resolve.filter(|_| features.msaa > 1));
    steps
}
