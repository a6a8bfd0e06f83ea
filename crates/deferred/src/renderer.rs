//! The Tiled Deferred renderer: the shared half of a frame
//! (`tiledlight_gpu::frame::FrameCommon`: targets, views, tonemap) plus this method's
//! passes, recorded in the order of the frame plan (`tiledlight_gpu::plan`): G-buffer pass
//! -> (cell culling) -> one compute pass that culls each tile's lights into the light grid
//! and shades its pixels (-> MSAA resolve of edge pixels) -> tonemap (-> heat map). Built
//! once for a scene, light set, screen and settings. Depends on tiledlight-gpu and
//! [`crate::gbuffer`], [`crate::shading`].

use glam::Vec3;
use tiledlight_cull::vpl::VplConfig;
use tiledlight_cull::{Camera, TileGrid};
use tiledlight_gpu::culling::{CullOptions, DropLight, GpuTileLists, LightCulling};
use tiledlight_gpu::depth_prepass::DEPTH_FORMAT;
use tiledlight_gpu::features::{Features, Method};
use tiledlight_gpu::frame::{CommonSettings, FrameCommon};
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::plan::{FramePlan, Step};
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::{DisplayTargets, Renderer};
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::tonemap::{HeatmapGrids, HeatmapOf, HeatmapPass};
use tiledlight_gpu::{GpuContext, GpuError};
use tiledlight_vpl::VplPath;

use crate::gbuffer::{GBuffer, GBufferPass};
use crate::gbuffer::{ALBEDO_FORMAT, EXTRA_FORMAT, NORMAL_FORMAT};
use crate::shading::{DeferredShading, EdgeTest};
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_gpu::blended::BlendedPath;
use tiledlight_gpu::features::BlendMode;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::tonemap::HDR_FORMAT;

/// Tiled Deferred settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeferredSettings {
    /// Culling options (tile size, capacity, tests), as for Forward+.
    pub cull: CullOptions,
    /// G-buffer render targets, 2..=5 (extra ones are written white and read back).
    pub gbuffer_rts: u32,
    /// Exposure before tonemapping.
    pub exposure: f32,
    /// Compute the exposure from each frame's image instead (`exposure` unused; default
    /// off: images compared across renderers need one fixed exposure).
    pub auto_exposure: bool,
    /// Ambient radiance (times albedo).
    pub ambient: Vec3,
    /// Draw the lights-per-tile heat map over the image.
    pub heatmap: bool,
    /// Which light grid the heat map shows; [`HeatmapOf::Blended`] needs blended geometry
    /// and [`HeatmapOf::Vpl`] needs `vpl` (an error otherwise, even with the heat map off:
    /// the setting asks for a grid the frame does not have).
    pub heatmap_of: HeatmapOf,
    /// MSAA samples per pixel: 1, 2, 4 or 8 (as the adapter supports). Also sets
    /// `cull.samples`.
    pub msaa: u32,
    /// The MSAA edge test's thresholds (unused without MSAA).
    pub edge: EdgeTest,
    /// Test-only: leave one light out of one tile's list (see [`DropLight`]). `None` by
    /// default; production never sets it.
    pub test_drop_light: Option<DropLight>,
    /// Test-only: the extra G-buffer targets hold
    /// [`crate::gbuffer::EXTRA_TEST_VALUES`] instead of white, so tests can prove the
    /// shading pass reads and multiplies each of them. `false` by default; production never
    /// sets it.
    pub test_gbuffer_values: bool,
    /// How shadows are drawn (tile size, filter, format); used only when the lights were
    /// uploaded with shadow casters (`LightBuffers::with_casters`).
    pub shadows: ShadowOptions,
    /// How blended geometry is composited (used only when the scene has some).
    pub blend: BlendMode,
    /// Virtual point lights from the shadow casters' reflective shadow maps
    /// (tiledlight-vpl), culled into a light grid of their own after the G-buffer and shaded
    /// by the cull-and-shade pass; `None` (the default): none of their passes, buffers or
    /// variants.
    pub vpl: Option<VplConfig>,
}

impl Default for DeferredSettings {
    fn default() -> Self {
        Self {
            cull: CullOptions::default(),
            gbuffer_rts: 2,
            exposure: 1.0,
            auto_exposure: false,
            ambient: Vec3::splat(0.02),
            heatmap: false,
            heatmap_of: HeatmapOf::Opaque,
            msaa: 1,
            edge: EdgeTest::default(),
            test_drop_light: None,
            test_gbuffer_values: false,
            shadows: ShadowOptions::default(),
            blend: BlendMode::Sorted,
            vpl: None,
        }
    }
}

/// A Tiled Deferred renderer for one scene, light set and screen size.
pub struct DeferredRenderer {
    settings: DeferredSettings,
    common: FrameCommon,
    gbuffer_pass: GBufferPass,
    gbuffer: GBuffer,
    shading: DeferredShading,
    /// Drawn when enabled.
    heatmap: HeatmapPass,
    /// Alpha-blended geometry's passes, the same as Forward+'s (only when the scene has some).
    blended: Option<BlendedPath>,
    /// The VPLs and their culling (with `settings.vpl` only).
    vpl: Option<(VplPath, LightCulling)>,
}

impl DeferredRenderer {
    /// Builds every pipeline, target and buffer for a `width` x `height` screen.
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneGpu,
        lights: &LightBuffers,
        width: u32,
        height: u32,
        settings: DeferredSettings,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let mut settings = settings;
        settings.cull.samples = settings.msaa;
        let mut features = Features::new(
            scene,
            lights,
            Method::TiledDeferred,
            &settings.cull,
            (settings.msaa, settings.gbuffer_rts),
            settings.shadows,
        );
        features.blend_mode = settings.blend;
        features.vpl = settings.vpl.is_some();
        if features.vpl && features.shadows.is_none() {
            return Err(GpuError::Config(
                "VPLs are made from the shadow-casting lights' reflective shadow maps: no light casts a shadow".into(),
            ));
        }
        let mut formats = vec![DEPTH_FORMAT, ALBEDO_FORMAT, NORMAL_FORMAT];
        if features.extra_targets > 0 {
            formats.push(EXTRA_FORMAT);
        }
        // Blended geometry: a multisampled transparent layer, composited onto the HDR image
        // by a render pass.
        let mut hdr_usage = wgpu::TextureUsages::STORAGE_BINDING;
        if features.blended() {
            formats.push(HDR_FORMAT);
            hdr_usage |= wgpu::TextureUsages::RENDER_ATTACHMENT;
        }
        let common = FrameCommon::new(
            ctx,
            scene,
            lights,
            features,
            CommonSettings {
                prefix: "deferred",
                size: (width, height),
                tile_size: settings.cull.tile_size,
                msaa_formats: &formats,
                hdr_usage,
                exposure: settings.exposure,
                auto_exposure: settings.auto_exposure,
                ambient: settings.ambient,
            },
        )?;
        let mut memory = common.memory.clone();
        ctx.checked("building the Tiled Deferred renderer", || {
            let (features, views, targets) = (&common.features, &common.views, &common.targets);
            let emission = features.materials.emission_target();
            let gbuffer = GBuffer::new(device, (width, height), settings.gbuffer_rts, features.msaa, emission)?;
            let gbuffer_pass = GBufferPass::new(
                device,
                views,
                scene,
                settings.gbuffer_rts,
                features.msaa,
                settings.test_gbuffer_values,
            )?;
            memory.add("deferred.gbuffer", gbuffer.bytes());
            let vpl = match (settings.vpl, common.shadows.as_ref()) {
                (Some(cfg), Some(atlas)) => {
                    let path = VplPath::new(device, &ctx.queue, scene, atlas, &lights.packed, &cfg)?;
                    let culling = path.culling(device, views, &targets.depth_view, (common.grid, &settings.cull))?;
                    let bindings = path.bindings(device, Some(&culling));
                    memory.extend(&path.memory);
                    for (category, bytes) in culling.memory.entries.iter() {
                        memory.add(&format!("vpl.{category}"), *bytes);
                    }
                    Some((path, culling, bindings))
                }
                _ => None,
            };
            let shading = DeferredShading::new(
                device,
                views,
                &targets.depth_view,
                &gbuffer,
                &targets.hdr_view,
                (lights, &common.lighting),
                common.grid,
                settings.cull,
                settings.edge,
                settings.test_drop_light,
                (features, common.shadows.as_ref()),
                &mut memory,
                vpl.as_ref().map(|v| &v.2),
            )?;
            let vpl = vpl.map(|(p, c, _)| (p, c));
            let blended = common.blended_path(device, scene, lights, settings.cull, Some(&shading.light_grid))?;
            let grids = HeatmapGrids {
                opaque: &shading.light_grid.grid,
                blended: blended.as_ref().and_then(|b| b.culling.as_ref()).map(|c| &c.grid.grid),
                vpl: vpl.as_ref().map(|v| &v.1.grid.grid),
            };
            let heatmap = HeatmapPass::new(device, grids, settings.heatmap)?;
            heatmap.set_of(settings.heatmap_of)?;
            if let Some(b) = &blended {
                memory.extend(&b.memory);
            }
            Ok((gbuffer_pass, gbuffer, shading, heatmap, (blended, vpl)))
        })?
        .map(|(gbuffer_pass, gbuffer, shading, heatmap, (blended, vpl))| {
            let mut common = common;
            common.memory = memory;
            Self { settings, common, gbuffer_pass, gbuffer, shading, heatmap, blended, vpl }
        })
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &DeferredSettings {
        &self.settings
    }

    /// The blended-geometry path (scenes with blended materials).
    pub fn blended(&self) -> Option<&BlendedPath> {
        self.blended.as_ref()
    }

    /// The VPLs (with `settings.vpl`).
    pub fn vpl(&self) -> Option<&VplPath> {
        self.vpl.as_ref().map(|v| &v.0)
    }

    /// The culling of the VPLs into their own grid (with `settings.vpl`).
    pub fn vpl_culling(&self) -> Option<&LightCulling> {
        self.vpl.as_ref().map(|v| &v.1)
    }

    /// The G-buffer.
    pub fn gbuffer(&self) -> &GBuffer {
        &self.gbuffer
    }

    /// The cull-and-shade pass (edge statistics, MSAA sample texture).
    pub fn shading(&self) -> &DeferredShading {
        &self.shading
    }

    /// What the frame models.
    pub fn features(&self) -> &Features {
        &self.common.features
    }

    /// The frame's steps.
    pub fn plan(&self) -> &FramePlan {
        &self.common.plan
    }

    /// The per-tile light lists the last frame was shaded with (tests; stalls the GPU).
    pub fn read_lists(&self, ctx: &GpuContext) -> Result<GpuTileLists, GpuError> {
        self.shading.read_lists(&ctx.device, &ctx.queue)
    }
}

impl Renderer for DeferredRenderer {
    fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        scene: &SceneGpu,
        camera: &Camera,
    ) {
        let c = &self.common;
        c.write_view(queue, camera);
        let view = c.main_view();
        let targets = &c.targets;
        for step in c.plan.steps() {
            match step {
                Step::ShadowMaps => c.record_shadows(encoder, timer, scene),
                Step::Vpl => {
                    if let Some((v, _)) = &self.vpl {
                        v.record(encoder, timer, scene);
                    }
                }
                Step::VplCull => {
                    if let Some((_, cull)) = &self.vpl {
                        cull.record(encoder, timer, view, "deferred.cull_vpls");
                    }
                }
                Step::GBuffer => {
                    self.gbuffer_pass.record(encoder, timer, view, scene, &self.gbuffer, &targets.depth_view)
                }
                Step::DeferredShade => self.shading.record(encoder, timer, view),
                Step::DeferredResolve => self.shading.record_resolve(encoder, timer),
                Step::BlendedDepth | Step::BlendedCull | Step::BlendedShade => {
                    if let Some(b) = &self.blended {
                        b.record_step(
                            *step,
                            encoder,
                            timer,
                            (view, scene, camera),
                            (&targets.depth_view, &targets.hdr_view),
                        );
                    }
                }
                Step::Tonemap => c.tonemap.record(encoder, timer, &targets.ldr_view),
                Step::Heatmap => self.heatmap.record(encoder, timer, &targets.ldr_view),
                // Forward steps: never in a Tiled Deferred plan (plan.rs tests it).
                Step::DepthPrepass | Step::Cull | Step::ForwardShade | Step::BruteForceShade => {}
            }
        }
    }
    fn set_exposure(&self, queue: &wgpu::Queue, exposure: f32) -> Result<(), GpuError> {
        self.common.tonemap.set_exposure(queue, exposure)
    }
    fn auto_exposure(&self, ctx: &GpuContext) -> Result<Option<f32>, GpuError> {
        self.common.tonemap.read_exposure(&ctx.device, &ctx.queue)
    }
    fn heatmap(&self) -> Option<&HeatmapPass> {
        Some(&self.heatmap)
    }
    fn targets(&self) -> &DisplayTargets {
        &self.common.targets
    }
    fn grid(&self) -> TileGrid {
        self.common.grid
    }
    fn memory(&self) -> &MemoryReport {
        &self.common.memory
    }
    fn shadow_atlas(&self) -> Option<&ShadowAtlas> {
        self.common.shadows.as_ref()
    }
    fn blended(&self) -> Option<&BlendedPath> {
        self.blended.as_ref()
    }
    fn blended_mut(&mut self) -> Option<&mut BlendedPath> {
        self.blended.as_mut()
    }
    fn vpl_count(&self, ctx: &GpuContext) -> Result<Option<(u32, u32)>, GpuError> {
        match self.vpl.as_ref().map(|v| &v.0) {
            Some(v) => v.buffers.read_count(&ctx.device, &ctx.queue).map(|c| Some((c.kept, c.refused))),
            None => Ok(None),
        }
    }
    fn lights_moved(&self, queue: &wgpu::Queue, lights: &PackedLights) -> Result<(), GpuError> {
        self.common.lights_moved(queue, lights)?;
        if let (Some((v, _)), Some(atlas)) = (&self.vpl, &self.common.shadows) {
            v.update(queue, atlas, lights);
        }
        Ok(())
    }
    fn light_grid(&self) -> Option<&LightGrid> {
        Some(&self.shading.light_grid)
    }
    fn vpl_light_grid(&self) -> Option<&LightGrid> {
        self.vpl.as_ref().map(|v| &v.1.grid)
    }
    fn grow_light_grid(&mut self, ctx: &GpuContext, capacity: u32) {
        let grid = &mut self.shading.light_grid;
        grid.grow(&ctx.device, &ctx.queue, capacity);
        if let Some(b) = &mut self.blended {
            b.frame_grid_grew(&ctx.device, grid);
        }
        for (category, bytes) in grid.memory().entries {
            self.common.memory.set(&category, bytes);
        }
    }
    fn edge_pixels(&self, ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        self.shading.read_edge_pixels(&ctx.device, &ctx.queue)
    }
}
