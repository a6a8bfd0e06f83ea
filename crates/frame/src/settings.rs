//! [`FrameSettings`]: every setting of a frame, for every method, in one value (the method,
//! its culling, MSAA, exposure, shadows, blended geometry, VPLs, the heat map, and the
//! knobs only Tiled Deferred or the visibility buffer reads). What the scene itself requires is decided from
//! it and the scene once, in [`tiledlight_gpu::features::Features`]. Depends on
//! tiledlight-gpu (option types), tiledlight-cull (shadow and VPL options) and
//! tiledlight-deferred (its edge test's thresholds).

use glam::Vec3;
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_cull::vpl::VplConfig;
use tiledlight_deferred::EdgeTest;
use tiledlight_gpu::culling::{CullOptions, DropLight};
use tiledlight_gpu::draw_order::DrawOrderMode;
use tiledlight_gpu::features::{BlendMode, Method, Raster};
use tiledlight_gpu::heatmap::HeatmapOf;
use tiledlight_visibility::compute_raster::ComputeRasterOptions;

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
    /// How blended geometry is composited (used only when the scene has some).
    pub blend: BlendMode,
    /// Virtual point lights from the shadow casters' reflective shadow maps
    /// (tiledlight-vpl); `None` (the default): none of their passes, buffers or variants.
    /// Tiled methods cull them into a light grid of their own (one list per tile); brute
    /// force shades every one.
    pub vpl: Option<VplConfig>,
    /// The order the depth pre-pass and the G-buffer draw the scene in: nearest first
    /// (the default; sorted again when the eye moves) or the instance buffer's
    /// ([`tiledlight_gpu::draw_order`]). Images differ only where two surfaces tie in depth.
    pub draw_order: DrawOrderMode,
    /// The shading's early-outs (true, the default); false is the ablation that evaluates
    /// every listed light in full ([`tiledlight_gpu::features::Features::early_outs`]).
    pub early_outs: bool,
    /// Tiled Deferred: G-buffer render targets, 2..=5 (extra ones are written white and
    /// read back: the sample's bandwidth stress knob). Other methods ignore it.
    pub gbuffer_rts: u32,
    /// Tiled Deferred with MSAA: the edge test's thresholds. Other methods ignore it.
    pub edge: EdgeTest,
    /// Test-only: leave one light out of one tile's list (tiled methods; see
    /// [`DropLight`]). `None` by default; production never sets it.
    pub test_drop_light: Option<DropLight>,
    /// Test-only (Tiled Deferred): the extra G-buffer targets hold
    /// `tiledlight_deferred::gbuffer::EXTRA_TEST_VALUES` instead of white, so tests can
    /// prove the shading pass reads and multiplies each of them. `false` by default.
    pub test_gbuffer_values: bool,
    /// The visibility buffer's raster: [`Raster::Auto`] (the default) picks per adapter
    /// ([`Raster::pick`]); [`crate::FrameRenderer::settings`] reports the one built.
    pub raster: Raster,
    /// The compute raster's split with the hardware (large triangles).
    pub compute_raster: ComputeRasterOptions,
    /// Test-only (visibility buffer, one sample): after the raster pass the ID at this
    /// pixel is overwritten with instance 0's triangle 0 (a valid but wrong triangle), so
    /// tests can prove a comparison catches one wrong ID. `None` by default.
    pub test_wrong_id: Option<(u32, u32)>,
    /// The traced reference submits each band of its frame on its own and prints its
    /// progress on stderr (renders of a second or more); untimed. Off by default (one timed
    /// submission, as benchmarks need).
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
            blend: BlendMode::Sorted,
            vpl: None,
            draw_order: DrawOrderMode::FrontToBack,
            early_outs: true,
            gbuffer_rts: 2,
            edge: EdgeTest::default(),
            test_drop_light: None,
            test_gbuffer_values: false,
            test_wrong_id: None,
            raster: Raster::Auto,
            compute_raster: ComputeRasterOptions::default(),
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
