//! The steps every method shares, built and recorded once by the frame ([`SharedSteps`]):
//!
//! 1. before the method: the views, the `Lighting` uniform, the display targets (depth,
//!    HDR, display image; the method says which formats it multisamples and how it writes
//!    the HDR image), the shadow atlas and its step, the VPLs (RSM + generation) and their
//!    culling into a light grid of their own (the method says where in its middle the
//!    VPL culling runs, [`SharedSteps::record_vpl_cull`]);
//! 2. after the method, from the lists it made: blended geometry (depth, its own lists,
//!    shading + composite over the HDR image), tonemap and automatic exposure, the heat map
//!    of any of the frame's light grids.
//!
//! A new shared step is one field here, its build in [`SharedSteps::new`] or
//! [`SharedSteps::finish`], its `record_*` call in `FrameRenderer::record`, one plan step.
//! Depends on tiledlight-gpu (passes, targets) and tiledlight-vpl.

use crate::plan::{FramePlan, Step};
use tiledlight_cull::shadow::AtlasLayout;
use tiledlight_cull::{Camera, TileGrid};
use tiledlight_gpu::blended::{BlendedInputs, BlendedPath};
use tiledlight_gpu::culling::LightCulling;
use tiledlight_gpu::features::Features;
use tiledlight_gpu::heatmap::{HeatmapGrids, HeatmapPass};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::lights_group::{LightingInputs, VplBindings};
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::targets::{check_msaa, DisplayTargets};
use tiledlight_gpu::tonemap::TonemapPass;
use tiledlight_gpu::view::{ViewUniforms, Views, MAIN_VIEW};
use tiledlight_gpu::{GpuContext, GpuError};
use tiledlight_vpl::VplPath;

use crate::handles::Rec;
use crate::settings::{FrameSettings, TestHooks};
use tiledlight_gpu::handles::{Depth, Hdr, Ldr, Lists};
use tiledlight_gpu::targets::target_handles;

/// What a method asks of the shared display targets.
#[derive(Clone, Debug)]
pub struct TargetNeeds {
    /// Label prefix of the targets and of the VPL culling's timer ("forward", "deferred").
    pub prefix: &'static str,
    /// Formats the method renders multisampled (checked against the adapter's MSAA support).
    pub msaa_formats: Vec<wgpu::TextureFormat>,
    /// How the method writes the HDR image (render attachment or storage).
    pub hdr_usage: wgpu::TextureUsages,
    /// Another depth target than the `Depth32Float` attachment: its format and usage.
    pub depth: Option<(wgpu::TextureFormat, wgpu::TextureUsages)>,
}

/// The VPLs of a frame: the RSM and generation, their culling (tiled methods) and what a
/// shading pass binds of them.
pub struct Vpls {
    /// RSM, generation pass, VPL buffers.
    pub path: VplPath,
    /// Their culling into their own light grid (tiled methods).
    pub culling: Option<LightCulling>,
    /// What the method's shading binds.
    pub bindings: VplBindings,
}

/// The shared steps of one frame.
pub struct SharedSteps {
    /// What the scene and the settings require.
    pub features: Features,
    /// The frame's steps, in order.
    pub plan: FramePlan,
    /// The tiling of the screen.
    pub grid: TileGrid,
    /// The views (slot [`MAIN_VIEW`]: the camera; then the shadow faces).
    pub views: Views,
    /// The `Lighting` uniform (light counts, ambient, shadow atlas constants).
    pub lighting: wgpu::Buffer,
    /// Depth, HDR and display images.
    pub targets: DisplayTargets,
    /// HDR to display, with the exposure (fixed or automatic).
    pub tonemap: TonemapPass,
    /// The shadow atlas (only when some light casts a shadow).
    pub shadows: Option<ShadowAtlas>,
    /// The VPLs (only with `FrameSettings::vpl`).
    pub vpls: Option<Vpls>,
    /// Alpha-blended geometry's passes (only when the scene has some).
    pub blended: Option<BlendedPath>,
    /// The heat map over the display image (tiled methods; drawn when switched on).
    pub heatmap: Option<HeatmapPass>,
    /// GPU memory of the scene, lights, targets and every step, by category.
    pub memory: MemoryReport,
    /// The test hooks the renderer was built with ([`crate::FrameRenderer::with_hooks`]);
    /// none in production.
    pub hooks: TestHooks,
    vpl_cull_label: String,
}

impl SharedSteps {
    /// What a method's lighting pass is built from: `device`, `views`, `lights` and
    /// `features` with this frame's lighting uniform, shadow atlas and VPLs.
    pub fn lighting_inputs<'a>(
        &'a self,
        device: &'a wgpu::Device,
        views: &'a Views,
        lights: &'a LightBuffers,
        features: &'a Features,
    ) -> LightingInputs<'a> {
        LightingInputs {
            device,
            views,
            lights,
            lighting: &self.lighting,
            features,
            atlas: self.shadows.as_ref(),
            vpls: self.vpls.as_ref().map(|v| &v.bindings),
        }
    }

    /// Checks the MSAA sample count and the screen size, then builds what comes before the
    /// method: views, shadow atlas, lighting uniform, targets, tonemap.
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneGpu,
        lights: &LightBuffers,
        features: Features,
        (settings, size): (&FrameSettings, (u32, u32)),
        (needs, plan): (TargetNeeds, FramePlan),
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        check_msaa(ctx, features.msaa, &needs.msaa_formats)?;
        let (width, height) = size;
        let limits = device.limits();
        let max_side = limits.max_texture_dimension_2d;
        if width > max_side || height > max_side {
            return Err(GpuError::Limit {
                what: format!("a {width}x{height} screen"),
                name: "max_texture_dimension_2d",
                limit: max_side.into(),
                asked: format!("{} pixels", width.max(height)),
            });
        }
        let grid = TileGrid::new(width, height, settings.cull.tile_size)?;
        let layout = features
            .shadows
            .map(|sh| {
                AtlasLayout::new(
                    sh.options.tile_size,
                    sh.points,
                    sh.spots,
                    limits.max_texture_dimension_2d,
                    limits.max_texture_array_layers,
                )
            })
            .transpose()?;
        let views = Views::new(device, 1 + layout.map_or(0, |l| l.faces()));
        let shadows = match (layout, features.shadows) {
            (Some(layout), Some(sh)) => {
                let atlas = ShadowAtlas::new(device, &views, scene, &features, layout, sh.options, MAIN_VIEW + 1)?;
                atlas.update(&ctx.queue, &views, &lights.packed)?;
                Some(atlas)
            }
            _ => None,
        };
        let mut lighting_u = lights.lighting_uniforms(settings.ambient);
        if let Some(a) = &shadows {
            let (texel, tile) = a.texel_and_tile_uv();
            lighting_u.shadow_texel_uv = texel;
            lighting_u.shadow_tile_uv = tile;
            lighting_u.shadow_depth_bias = a.options.format.depth_bias();
        }
        let lighting = LightBuffers::upload_lighting(device, &lighting_u);
        let targets =
            DisplayTargets::with_depth(device, needs.prefix, size, features.msaa, needs.hdr_usage, needs.depth);
        let tonemap = TonemapPass::new(
            device,
            (target_handles(&targets).1, target_handles(&targets).2),
            size,
            (settings.exposure, settings.auto_exposure),
        )?;
        let mut memory = MemoryReport::default();
        memory.extend(&scene.memory);
        memory.extend(&lights.memory);
        memory.add("targets (depth+hdr+ldr)", targets.bytes());
        if let Some(a) = &shadows {
            memory.extend(&a.memory);
        }
        Ok(Self {
            features,
            plan,
            grid,
            views,
            lighting,
            targets,
            tonemap,
            shadows,
            vpls: None,
            blended: None,
            heatmap: None,
            memory,
            hooks: TestHooks::default(),
            vpl_cull_label: format!("{}.cull_vpls", needs.prefix),
        })
    }

    /// Builds the VPLs (with `settings.vpl`): RSM and generation from the shadow atlas's
    /// casters, and, when the plan culls them, their culling over the frame's depth.
    pub fn build_vpls(
        &mut self,
        ctx: &GpuContext,
        scene: &SceneGpu,
        lights: &LightBuffers,
        settings: &FrameSettings,
    ) -> Result<(), GpuError> {
        let (Some(cfg), Some(atlas)) = (settings.vpl, self.shadows.as_ref()) else { return Ok(()) };
        let device = &ctx.device;
        let path = VplPath::new(device, &ctx.queue, scene, atlas, &lights.packed, &cfg)?;
        // The VPLs' own grid, culled by the lights' culling pass (sphere and planes, one
        // list per tile), their count from the GPU.
        let culling = self
            .plan
            .has(Step::VplCull)
            .then(|| path.culling(device, &self.views, target_handles(&self.targets).0, (self.grid, &settings.cull)))
            .transpose()?;
        let bindings = path.bindings(device, culling.as_ref());
        self.memory.extend(&path.memory);
        if let Some(c) = &culling {
            for (category, bytes) in c.memory.entries.iter() {
                self.memory.add(&format!("vpl.{category}"), *bytes);
            }
        }
        self.vpls = Some(Vpls { path, culling, bindings });
        Ok(())
    }

    /// Builds what comes after the method from the lists it made (`lists`: the opaque
    /// light grid of tiled methods): the blended path and the heat map.
    pub fn finish(
        &mut self,
        device: &wgpu::Device,
        (scene, lights): (&SceneGpu, &LightBuffers),
        settings: &FrameSettings,
        lists: Option<Lists<'_>>,
    ) -> Result<(), GpuError> {
        if self.features.blended() {
            let inputs = BlendedInputs {
                views: &self.views,
                scene,
                lights: (lights, &self.lighting),
                features: &self.features,
                cull: (self.grid, settings.cull),
                opaque_depth: target_handles(&self.targets).0,
                shadows: self.shadows.as_ref(),
                frame_grid: lists.map(|l| l.grid),
            };
            let b = BlendedPath::new(device, inputs)?;
            self.memory.extend(&b.memory);
            self.blended = Some(b);
        }
        if let (Some(l), true) = (lists, self.plan.has(Step::Heatmap)) {
            let grids = HeatmapGrids {
                opaque: &l.grid.grid,
                blended: self.blended.as_ref().and_then(|b| b.culling.as_ref()).map(|c| &c.grid.grid),
                vpl: self.vpls.as_ref().and_then(|v| v.culling.as_ref()).map(|c| &c.grid.grid),
            };
            let h = HeatmapPass::new(device, grids, settings.heatmap)?;
            h.set_of(settings.heatmap_of)?;
            self.heatmap = Some(h);
        }
        Ok(())
    }

    /// Writes the main view's uniforms for `camera`.
    pub fn write_view(&self, queue: &wgpu::Queue, camera: &Camera) {
        self.views.write(queue, MAIN_VIEW, &ViewUniforms::new(camera, self.grid.width, self.grid.height));
    }

    /// The main view, as the passes' `record` take it.
    pub fn main_view(&self) -> (&Views, u32) {
        (&self.views, MAIN_VIEW)
    }

    /// The shadow faces of the casters that moved.
    pub fn record_shadows(&self, rec: &mut Rec<'_>) {
        if let Some(a) = &self.shadows {
            rec.step(Step::ShadowMaps);
            let r = &mut rec.recording;
            a.record(r.encoder, r.timer, &self.views, r.scene);
        }
    }

    /// The casters' RSM and VPL generation, when the casters moved.
    pub fn record_vpls(&self, rec: &mut Rec<'_>) {
        if let Some(v) = &self.vpls {
            rec.step(Step::Vpl);
            let r = &mut rec.recording;
            v.path.record(r.encoder, r.timer, r.scene);
        }
    }

    /// The VPLs' culling into their own grid (after the frame's depth exists): the method's
    /// frame function calls it where its plan puts it.
    pub fn record_vpl_cull(&self, rec: &mut Rec<'_>) {
        if let Some(c) = self.vpls.as_ref().and_then(|v| v.culling.as_ref()) {
            rec.step(Step::VplCull);
            let r = &mut rec.recording;
            c.record(r.encoder, r.timer, r.view, &self.vpl_cull_label);
        }
    }

    /// Blended geometry over the opaque depth and HDR image: its depth, its lists, its
    /// shading and composite.
    pub fn record_blended(&self, rec: &mut Rec<'_>, camera: &Camera, depth: Depth<'_>, hdr: Hdr<'_>) {
        let Some(b) = &self.blended else { return };
        if self.plan.has(Step::BlendedDepth) {
            rec.step(Step::BlendedDepth);
            b.record_depth(rec);
        }
        if self.plan.has(Step::BlendedCull) {
            rec.step(Step::BlendedCull);
            let r = &mut rec.recording;
            b.record_cull(r.encoder, r.timer, r.view);
        }
        if self.plan.has(Step::BlendedShade) {
            rec.step(Step::BlendedShade);
            let to_view = camera.view();
            b.record_shade(rec, &to_view, depth, hdr);
        }
    }

    /// HDR to display (with the automatic exposure's passes when on), then the heat map.
    pub fn record_tail(&self, rec: &mut Rec<'_>, ldr: Ldr<'_>) {
        rec.step(Step::Tonemap);
        // The tonemap writes the display image it was built over (`ldr`'s texture).
        let r = &mut rec.recording;
        self.tonemap.record(r.encoder, r.timer);
        if let Some(h) = &self.heatmap {
            rec.step(Step::Heatmap);
            let r = &mut rec.recording;
            h.record(r.encoder, r.timer, ldr.view);
        }
    }
}
