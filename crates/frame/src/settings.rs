//! [`FrameSettings`]: every setting of a frame, for every method, in one value (the method,
//! its culling, MSAA, exposure, shadows, blended geometry, VPLs, the heat map, and the pass
//! settings' table [`Knobs`]). What the scene itself requires is decided from it and the
//! scene once, in [`tiledlight_gpu::features::Features`]. [`TestHooks`]: what only tests
//! set, given to [`crate::FrameRenderer::with_hooks`] beside the settings. Depends on
//! tiledlight-gpu (option types) and tiledlight-cull (shadow and VPL options).

use crate::methods::Method;
use glam::Vec3;
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_cull::vpl::VplConfig;
use tiledlight_gpu::culling::{CullOptions, DropLight};
use tiledlight_gpu::heatmap::HeatmapOf;
use tiledlight_gpu::knobs::Knobs;

/// How a frame is drawn: built into a renderer once ([`crate::FrameRenderer::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSettings {
    /// Forward+, Tiled Deferred or brute force.
    pub method: Method,
    /// Culling options (tile size, capacity, tests, layout); the tile size also sets the
    /// heat map's. `cull.samples` is set from `msaa`.
    pub cull: CullOptions,
    /// MSAA samples per pixel: 1, 2, 4 or 8 (as the adapter supports).
    pub msaa: u32,
    /// Exposure before tonemapping.
    pub exposure: f32,
    /// Compute the exposure from each frame's image instead (`exposure` unused; default
    /// off: images compared across renderers need one fixed exposure).
    pub auto_exposure: bool,
    /// Ambient radiance (times base colour), so unlit areas are not black.
    pub ambient: Vec3,
    /// Draw the lights-per-tile heat map over the image (tiled methods).
    pub heatmap: bool,
    /// Which light grid the heat map shows (tiled methods); [`HeatmapOf::Blended`] needs
    /// blended geometry and [`HeatmapOf::Vpl`] needs `vpl` (an error otherwise, even with
    /// the heat map off: the setting asks for a grid the frame does not have).
    pub heatmap_of: HeatmapOf,
    /// How shadows are drawn (tile size, filter, format); used only when the lights were
    /// uploaded with shadow casters (`LightBuffers::with_casters`).
    pub shadows: ShadowOptions,
    /// Virtual point lights from the shadow casters' reflective shadow maps
    /// (tiledlight-vpl); `None` (the default): none of their passes, buffers or variants.
    /// Tiled methods cull them into a light grid of their own (one list per tile); brute
    /// force shades every one.
    pub vpl: Option<VplConfig>,
    /// The pass settings (early-outs, G-buffer targets, draw order, the visibility
    /// buffer's raster and its large triangles, the MSAA edge test): one row each in
    /// [`tiledlight_gpu::knobs`](mod@tiledlight_gpu::knobs), read by the passes through
    /// [`tiledlight_gpu::features::Features::knobs`]. `knobs.raster` `Raster::Auto` (the
    /// default) picks per adapter (`Raster::pick`); [`crate::FrameRenderer::settings`]
    /// reports the one built.
    pub knobs: Knobs,
    /// The traced reference submits each band of its frame on its own and reports its
    /// progress to the process's band reporter
    /// ([`crate::visibility::set_band_reporter`]; renders of a second or more); untimed. Off
    /// by default (one timed submission, as benchmarks need).
    pub traced_progress: bool,
}

impl Default for FrameSettings {
    fn default() -> Self {
        Self {
            method: Method::ForwardPlus,
            cull: CullOptions::default(),
            msaa: 1,
            exposure: 1.0,
            auto_exposure: false,
            ambient: Vec3::splat(0.02),
            heatmap: false,
            heatmap_of: HeatmapOf::Opaque,
            shadows: ShadowOptions::default(),
            vpl: None,
            knobs: Knobs::default(),
            traced_progress: false,
        }
    }
}

impl FrameSettings {
    /// The defaults with `method`.
    pub fn of(method: Method) -> Self {
        Self { method, ..Self::default() }
    }
}

/// What only tests set: deliberate faults that prove a comparison catches them. Production
/// builds renderers with [`crate::FrameRenderer::new`], which sets none.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TestHooks {
    /// Leave one light out of one tile's list (tiled methods; see [`DropLight`]).
    pub drop_light: Option<DropLight>,
    /// Tiled Deferred: the extra G-buffer targets hold
    /// `tiledlight_deferred::gbuffer::EXTRA_TEST_VALUES` instead of white, so tests can
    /// prove the shading pass reads and multiplies each of them.
    pub gbuffer_values: bool,
    /// Visibility buffer, one sample: after the raster pass the ID at this pixel is
    /// overwritten with instance 0's triangle 0 (a valid but wrong triangle), so tests can
    /// prove a comparison catches one wrong ID.
    pub wrong_id: Option<(u32, u32)>,
}
