//! The Forward+ renderer and the brute-force reference: the shared half of a frame
//! (`tiledlight_gpu::frame::FrameCommon`: targets, views, tonemap) plus this method's
//! passes, recorded in the order of the frame plan (`tiledlight_gpu::plan`): depth
//! pre-pass -> light culling into the light grid (Forward+ only) -> forward shading into
//! linear HDR -> tonemap (-> heat map). With MSAA the pre-pass and shading pass are
//! multisampled (hardware MSAA), culling bounds every sample's depth, and the shading pass
//! resolves into the HDR image. Built once for a scene, light set, screen size and
//! settings; `record` only writes the view and records passes. With VPLs the casters'
//! reflective shadow maps and VPL generation (tiledlight-vpl) follow the shadow maps; the
//! VPLs are culled into a light grid of their own (Forward+) and the shading pass reads
//! their lists (brute force sums every VPL). Depends on
//! tiledlight-gpu, tiledlight-vpl and tiledlight-cull.

use glam::Vec3;
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_cull::{Camera, TileGrid};
use tiledlight_gpu::blended::BlendedPath;
use tiledlight_gpu::culling::{CullOptions, DropLight, LightCulling};
use tiledlight_gpu::depth_prepass::{DepthPrepass, DEPTH_FORMAT};
use tiledlight_gpu::features::BlendMode;
use tiledlight_gpu::features::{self, Features};
use tiledlight_gpu::frame::{CommonSettings, FrameCommon};
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::plan::{FramePlan, Step};
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::targets::{texture_2d_msaa, DisplayTargets, Renderer};
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::tonemap::{HeatmapGrids, HeatmapOf, HeatmapPass, HDR_FORMAT};
use tiledlight_gpu::{GpuContext, GpuError};

use tiledlight_cull::vpl::VplConfig;
use tiledlight_vpl::VplPath;

use crate::shading::{LightLoop, ShadingPass};

/// Which renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Tiled culling then forward shading of each tile's list.
    ForwardPlus,
    /// Every light for every pixel: the reference. `cutoff: false` drops the radius window
    /// (plain inverse-square), the reference for the cutoff's error.
    BruteForce {
        /// Keep the windowed falloff with its radius cutoff.
        cutoff: bool,
    },
}

/// Renderer settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForwardSettings {
    /// Forward+ or brute force.
    pub method: Method,
    /// Culling options (tile size, capacity, tests); the tile size also sets the heat map's.
    pub cull: CullOptions,
    /// Exposure before tonemapping.
    pub exposure: f32,
    /// Compute the exposure from each frame's image instead (`exposure` unused; default
    /// off: images compared across renderers need one fixed exposure).
    pub auto_exposure: bool,
    /// Ambient radiance (times base colour), so unlit areas are not black.
    pub ambient: Vec3,
    /// Draw the lights-per-tile heat map over the image (Forward+ only).
    pub heatmap: bool,
    /// Which light grid the heat map shows (Forward+ only); [`HeatmapOf::Blended`] needs
    /// blended geometry and [`HeatmapOf::Vpl`] needs `vpl` (an error otherwise, even with
    /// the heat map off: the setting asks for a grid the frame does not have).
    pub heatmap_of: HeatmapOf,
    /// MSAA samples per pixel: 1, 2, 4 or 8 (as the adapter supports). Also sets
    /// `cull.samples`.
    pub msaa: u32,
    /// Test-only: leave one light out of one tile's list (Forward+ only; see
    /// [`DropLight`]). `None` by default; production never sets it.
    pub test_drop_light: Option<DropLight>,
    /// How shadows are drawn (tile size, filter, format); used only when the lights were
    /// uploaded with shadow casters (`LightBuffers::with_casters`).
    pub shadows: ShadowOptions,
    /// How blended geometry is composited (used only when the scene has some).
    pub blend: BlendMode,
    /// Virtual point lights from the shadow casters' reflective shadow maps
    /// (tiledlight-vpl); `None` (the default): none of their passes, buffers or variants.
    /// Forward+ culls them into a light grid of their own (one list per tile); brute force
    /// shades every one.
    pub vpl: Option<VplConfig>,
}

impl Default for ForwardSettings {
    fn default() -> Self {
        Self {
            method: Method::ForwardPlus,
            cull: CullOptions::default(),
            exposure: 1.0,
            auto_exposure: false,
            ambient: Vec3::splat(0.02),
            heatmap: false,
            heatmap_of: HeatmapOf::Opaque,
            msaa: 1,
            test_drop_light: None,
            shadows: ShadowOptions::default(),
            blend: BlendMode::Sorted,
            vpl: None,
        }
    }
}

/// A Forward+ (or brute-force) renderer for one scene, light set and screen size.
pub struct ForwardRenderer {
    settings: ForwardSettings,
    common: FrameCommon,
    /// Alpha-blended geometry's passes (only when the scene has some).
    blended: Option<BlendedPath>,
    prepass: DepthPrepass,
    culling: Option<LightCulling>,
    shading: ShadingPass,
    /// Forward+ only (it reads the light grid); drawn when enabled.
    heatmap: Option<HeatmapPass>,
    /// The multisampled HDR target the shading pass draws into and resolves (MSAA only).
    hdr_msaa: Option<(wgpu::Texture, wgpu::TextureView)>,
    /// The VPLs (with `settings.vpl` only).
    vpl: Option<VplPath>,
    /// Forward+'s culling of the VPLs into their own light grid (with `settings.vpl`).
    vpl_culling: Option<LightCulling>,
}

impl Method {
    /// The frame's method.
    pub fn features_method(self) -> features::Method {
        match self {
            Method::ForwardPlus => features::Method::ForwardPlus,
            Method::BruteForce { cutoff } => features::Method::BruteForce { cutoff },
        }
    }
}

impl ForwardRenderer {
    /// Builds every pipeline, target and buffer for a `width` x `height` screen.
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneGpu,
        lights: &LightBuffers,
        width: u32,
        height: u32,
        settings: ForwardSettings,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let mut settings = settings;
        settings.cull.samples = settings.msaa;
        let mut features = Features::new(
            scene,
            lights,
            settings.method.features_method(),
            &settings.cull,
            (settings.msaa, 0),
            settings.shadows,
        );
        features.blend_mode = settings.blend;
        features.vpl = settings.vpl.is_some();
        if features.vpl && features.shadows.is_none() {
            return Err(GpuError::Config(
                "VPLs are made from the shadow-casting lights' reflective shadow maps: no light casts a shadow".into(),
            ));
        }
        if !features.method.is_tiled() {
            if settings.test_drop_light.is_some() {
                return Err(GpuError::Config(
                    "the drop-light test hook needs a tiled method (brute force has no tiles)".into(),
                ));
            }
            if settings.heatmap {
                return Err(GpuError::Config("the heat map needs a tiled method (brute force has no tiles)".into()));
            }
        }
        let common = FrameCommon::new(
            ctx,
            scene,
            lights,
            features,
            CommonSettings {
                prefix: "forward",
                size: (width, height),
                tile_size: settings.cull.tile_size,
                msaa_formats: &[DEPTH_FORMAT, HDR_FORMAT],
                hdr_usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                exposure: settings.exposure,
                auto_exposure: settings.auto_exposure,
                ambient: settings.ambient,
            },
        )?;
        ctx.checked("building the Forward+ renderer", || {
            let (features, views, targets, lighting) =
                (&common.features, &common.views, &common.targets, &common.lighting);
            let hdr_msaa = (features.msaa > 1).then(|| {
                let t = texture_2d_msaa(
                    device,
                    "forward.hdr_msaa",
                    (width, height),
                    HDR_FORMAT,
                    features.msaa,
                    wgpu::TextureUsages::RENDER_ATTACHMENT,
                );
                let v = t.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("forward.hdr_msaa.view"),
                    ..Default::default()
                });
                (t, v)
            });
            let prepass = DepthPrepass::new(device, views, scene, features)?;
            let plan = &common.plan;
            let culling = plan
                .has(Step::Cull)
                .then(|| {
                    LightCulling::with_drop_light(
                        device,
                        views,
                        &targets.depth_view,
                        (lights, lighting),
                        common.grid,
                        settings.cull,
                        settings.test_drop_light,
                    )
                })
                .transpose()?;
            let vpl = match (settings.vpl, common.shadows.as_ref()) {
                (Some(cfg), Some(atlas)) => {
                    let path = VplPath::new(device, &ctx.queue, scene, atlas, &lights.packed, &cfg)?;
                    // Forward+: the VPLs' own grid, culled by the same pass as the lights
                    // (sphere and planes, one list per tile), their count from the GPU.
                    let culling = plan
                        .has(Step::VplCull)
                        .then(|| path.culling(device, views, &targets.depth_view, (common.grid, &settings.cull)))
                        .transpose()?;
                    let bindings = path.bindings(device, culling.as_ref());
                    Some((path, bindings, culling))
                }
                _ => None,
            };
            let light_loop = match settings.method {
                Method::ForwardPlus => LightLoop::Tiled { half_z: features.half_z },
                Method::BruteForce { cutoff } => LightLoop::All { cutoff },
            };
            let shading = ShadingPass::new(
                device,
                views,
                scene,
                (lights, lighting),
                culling.as_ref(),
                light_loop,
                (features, common.shadows.as_ref()),
                vpl.as_ref().map(|v| v.1.clone()),
            )?;
            let (vpl, vpl_culling) = vpl.map_or((None, None), |v| (Some(v.0), v.2));
            let blended =
                common.blended_path(device, scene, lights, settings.cull, culling.as_ref().map(|c| &c.grid))?;
            let heatmap = match (&culling, plan.has(Step::Heatmap)) {
                (Some(c), true) => {
                    let grids = HeatmapGrids {
                        opaque: &c.grid.grid,
                        blended: blended.as_ref().and_then(|b| b.culling.as_ref()).map(|c| &c.grid.grid),
                        vpl: vpl_culling.as_ref().map(|c| &c.grid.grid),
                    };
                    let h = HeatmapPass::new(device, grids, settings.heatmap)?;
                    h.set_of(settings.heatmap_of)?;
                    Some(h)
                }
                _ => None,
            };
            Ok((prepass, culling, shading, heatmap, hdr_msaa, (blended, vpl, vpl_culling)))
        })?
        .map(|(prepass, culling, shading, heatmap, hdr_msaa, (blended, vpl, vpl_culling))| {
            let mut r =
                Self { settings, common, blended, prepass, culling, shading, heatmap, hdr_msaa, vpl, vpl_culling };
            if let Some(v) = &r.vpl {
                r.common.memory.extend(&v.memory);
            }
            if let Some(c) = &r.vpl_culling {
                for (category, bytes) in c.memory.entries.iter() {
                    r.common.memory.add(&format!("vpl.{category}"), *bytes);
                }
            }
            if let Some(b) = &r.blended {
                r.common.memory.extend(&b.memory);
            }
            if let Some((t, _)) = &r.hdr_msaa {
                let bytes = t.width() as u64 * t.height() as u64 * r.common.features.msaa as u64 * 8;
                r.common.memory.add("forward.hdr_msaa", bytes);
            }
            if let Some(c) = &r.culling {
                r.common.memory.extend(&c.memory);
            }
            r
        })
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &ForwardSettings {
        &self.settings
    }
    /// The culling pass (Forward+ only).
    pub fn culling(&self) -> Option<&LightCulling> {
        self.culling.as_ref()
    }
    /// The blended-geometry path (scenes with blended materials).
    pub fn blended(&self) -> Option<&BlendedPath> {
        self.blended.as_ref()
    }
    /// The VPLs (with `settings.vpl`).
    pub fn vpl(&self) -> Option<&VplPath> {
        self.vpl.as_ref()
    }
    /// The culling of the VPLs into their own grid (Forward+ with `settings.vpl`).
    pub fn vpl_culling(&self) -> Option<&LightCulling> {
        self.vpl_culling.as_ref()
    }
    /// What the frame models.
    pub fn features(&self) -> &Features {
        &self.common.features
    }
    /// The frame's steps.
    pub fn plan(&self) -> &FramePlan {
        &self.common.plan
    }
}

impl Renderer for ForwardRenderer {
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
                    if let Some(v) = &self.vpl {
                        v.record(encoder, timer, scene);
                    }
                }
                Step::DepthPrepass => self.prepass.record(encoder, timer, view, scene, &targets.depth_view),
                Step::Cull => {
                    if let Some(cull) = &self.culling {
                        cull.record(encoder, timer, view, "forward.cull");
                    }
                }
                Step::VplCull => {
                    if let Some(cull) = &self.vpl_culling {
                        cull.record(encoder, timer, view, "forward.cull_vpls");
                    }
                }
                Step::ForwardShade | Step::BruteForceShade => {
                    // With MSAA the pass draws the multisampled target and resolves it into
                    // the HDR image.
                    let (hdr, resolve) = match &self.hdr_msaa {
                        Some((_, v)) => (v, Some(&targets.hdr_view)),
                        None => (&targets.hdr_view, None),
                    };
                    self.shading.record(encoder, timer, view, scene, hdr, resolve, &targets.depth_view);
                }
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
                Step::Heatmap => {
                    if let Some(h) = &self.heatmap {
                        h.record(encoder, timer, &targets.ldr_view);
                    }
                }
                // Tiled Deferred's steps: never in a Forward+ plan (plan.rs tests it).
                Step::GBuffer | Step::DeferredShade | Step::DeferredResolve => {}
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
        self.heatmap.as_ref()
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
    fn light_grid(&self) -> Option<&LightGrid> {
        self.culling.as_ref().map(|c| &c.grid)
    }
    fn vpl_light_grid(&self) -> Option<&LightGrid> {
        self.vpl_culling.as_ref().map(|c| &c.grid)
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
        match self.vpl.as_ref() {
            Some(v) => v.buffers.read_count(&ctx.device, &ctx.queue).map(|c| Some((c.kept, c.refused))),
            None => Ok(None),
        }
    }
    fn lights_moved(&self, queue: &wgpu::Queue, lights: &PackedLights) -> Result<(), GpuError> {
        self.common.lights_moved(queue, lights)?;
        if let (Some(v), Some(atlas)) = (&self.vpl, &self.common.shadows) {
            v.update(queue, atlas, lights);
        }
        Ok(())
    }
    fn grow_light_grid(&mut self, ctx: &GpuContext, capacity: u32) {
        if let Some(c) = &mut self.culling {
            c.grid.grow(&ctx.device, &ctx.queue, capacity);
            self.shading.rebind(&ctx.device, &c.grid);
            if let Some(b) = &mut self.blended {
                b.frame_grid_grew(&ctx.device, &c.grid);
            }
            for (category, bytes) in c.grid.memory().entries {
                self.common.memory.set(&category, bytes);
            }
        }
    }
}
