//! [`FrameRenderer`]: one frame of any method, built once for a scene, light set, screen and
//! [`FrameSettings`]; the [`Renderer`] trait (recording and named outputs). The whole frame
//! reads in [`FrameRenderer::record`]: shared steps, the method's middle, shared steps.
//! Diagnostics (read-backs, statistics) are [`crate::diagnostics`]. Depends on the rest of
//! this crate.

use std::cell::RefCell;

use crate::methods::Method;
use crate::plan::FramePlan;
use glam::Vec3;
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::{Camera, TileGrid};
use tiledlight_gpu::blended::BlendedPath;
use tiledlight_gpu::draw_order::{DrawOrder, DrawOrderMode};
use tiledlight_gpu::features::{Features, Raster};
use tiledlight_gpu::heatmap::HeatmapPass;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::light_grid::{GridStatus, LightGrid};
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::targets::DisplayTargets;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::handles::Rec;
use crate::method::MethodFrame;
use crate::settings::{FrameSettings, TestHooks};
use crate::shared::{SharedSteps, Vpls};
use tiledlight_gpu::targets::target_handles;

/// What a renderer's last frame left to read, by name.
#[derive(Clone, Copy)]
pub struct Outputs<'a> {
    /// Depth, HDR and display images.
    pub targets: &'a DisplayTargets,
    /// The tiling of the screen.
    pub grid: TileGrid,
    /// The opaque light grid the frame was shaded with (tiled methods).
    pub light_grid: Option<&'a LightGrid>,
    /// The VPLs' own light grid (tiled methods with VPLs): one list a tile, a fixed budget
    /// that never grows, so a frame can drop VPLs from lists.
    pub vpl_light_grid: Option<&'a LightGrid>,
    /// The blended geometry's passes (its instance count, light grid and memory).
    pub blended: Option<&'a BlendedPath>,
    /// The shadow atlas, when some light casts a shadow.
    pub shadow_atlas: Option<&'a ShadowAtlas>,
    /// GPU memory of the renderer, its scene and lights, by category.
    pub memory: &'a MemoryReport,
}

/// What happened between two frames ([`Renderer::between_frames`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct BetweenFrames {
    /// The opaque grid's header of the latest finished frame, when it was read.
    pub status: Option<GridStatus>,
    /// The blended geometry's grid header of the latest finished frame, when it was read.
    pub blended: Option<GridStatus>,
    /// The VPL grid's header, when its copy has arrived (that grid never grows: its status
    /// is only reported).
    pub vpl: Option<GridStatus>,
    /// Some grid grew (the frame that dropped lights can be drawn again without drops).
    pub grew: bool,
}

/// A renderer: records frames and names what they write.
pub trait Renderer {
    /// Writes the frame's uniforms and records every pass of one frame.
    fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        scene: &SceneGpu,
        camera: &Camera,
    );
    /// The targets and grids of the last frame.
    fn outputs(&self) -> Outputs<'_>;
    /// Call between frames: takes the light-grid headers of the latest finished frame
    /// (`wait`: reads them now, stalling, as single renders and tests do; otherwise only a
    /// copy that has arrived) and grows every grid whose frame dropped lights because it was
    /// full.
    fn between_frames(&mut self, ctx: &GpuContext, wait: bool) -> Result<BetweenFrames, GpuError>;
}

/// One frame of any method.
pub struct FrameRenderer {
    settings: FrameSettings,
    shared: SharedSteps,
    method: Box<dyn MethodFrame>,
    /// With [`DrawOrderMode::FrontToBack`]: the eye the order was last sorted for, and
    /// that order (sorted again only when the eye moves).
    order: RefCell<Option<(Vec3, DrawOrder)>>,
    /// The last recorded frame's head step was given that order ([`Self::last_draw_order`]).
    order_given: std::cell::Cell<bool>,
}

impl FrameRenderer {
    /// Builds every pipeline, target and buffer of the frame for a `width` x `height`
    /// screen.
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneGpu,
        lights: &LightBuffers,
        width: u32,
        height: u32,
        settings: FrameSettings,
    ) -> Result<Self, GpuError> {
        Self::with_hooks(ctx, (scene, lights), (width, height), settings, TestHooks::default())
    }

    /// [`FrameRenderer::new`] with test hooks: deliberate faults that tests use to prove a
    /// comparison catches them ([`TestHooks`]).
    pub fn with_hooks(
        ctx: &GpuContext,
        (scene, lights): (&SceneGpu, &LightBuffers),
        (width, height): (u32, u32),
        settings: FrameSettings,
        hooks: TestHooks,
    ) -> Result<Self, GpuError> {
        let mut settings = settings;
        settings.cull.samples = settings.msaa;
        let raster = &mut settings.knobs.raster;
        if settings.method.uses_visibility_buffer() {
            *raster = raster.pick(ctx.info.device_type, ctx.device.features(), settings.msaa);
            if *raster == Raster::Compute {
                tiledlight_visibility::compute_raster::check_support(ctx.device.features(), settings.msaa)?;
            }
        } else if *raster == Raster::Compute {
            return Err(GpuError::Config(format!(
                "the compute raster draws the visibility buffer only, not {}",
                settings.method.label()
            )));
        }
        let s = &settings;
        let features =
            Features::new(scene, lights, s.method.traits(), &s.cull, (s.msaa, s.knobs), (s.shadows, s.vpl.is_some()));
        if features.vpl && features.shadows.is_none() {
            return Err(GpuError::Config(
                "VPLs are made from the shadow-casting lights' reflective shadow maps: no light casts a shadow".into(),
            ));
        }
        if hooks.wrong_id.is_some() && s.method != Method::Visibility {
            return Err(GpuError::Config("the wrong-ID test hook needs the visibility method".into()));
        }
        if !s.method.is_tiled() {
            if hooks.drop_light.is_some() {
                return Err(GpuError::Config(
                    "the drop-light test hook needs a tiled method (brute force has no tiles)".into(),
                ));
            }
            if s.heatmap {
                return Err(GpuError::Config("the heat map needs a tiled method (brute force has no tiles)".into()));
            }
        }
        // The method's registration: its target needs, its steps and its frame.
        let method = crate::registry::registration(s.method);
        let (needs, build, what) = ((method.targets)(&features), method.build, method.building);
        let plan = FramePlan::new(&features, &(method.steps)(&features));
        let mut shared = SharedSteps::new(ctx, scene, lights, features, (s, (width, height)), (needs, plan))?;
        shared.hooks = hooks;
        let method = ctx.checked(what, || {
            shared.build_vpls(ctx, scene, lights, s)?;
            let mut memory = std::mem::take(&mut shared.memory);
            let method = build(ctx, &shared, (scene, lights), s, &mut memory);
            shared.memory = memory;
            let method = method?;
            shared.finish(&ctx.device, (scene, lights), s, method.lists())?;
            Ok::<_, GpuError>(method)
        })??;
        Ok(Self { settings, shared, method, order: RefCell::new(None), order_given: Default::default() })
    }

    /// The settings it was built with (`cull.samples` set from `msaa`).
    pub fn settings(&self) -> &FrameSettings {
        &self.settings
    }
    /// What the frame models.
    pub fn features(&self) -> &Features {
        &self.shared.features
    }
    /// The frame's steps.
    pub fn plan(&self) -> &FramePlan {
        &self.shared.plan
    }
    /// The shared steps (targets, views, shadows, VPLs, blended geometry, tonemap, heat map).
    pub fn shared(&self) -> &SharedSteps {
        &self.shared
    }
    /// The method's own passes, as their type: `passes::<ForwardFrame>()` (Forward+ and
    /// brute force) or `passes::<DeferredFrame>()`; None for another method.
    pub fn passes<T: MethodFrame>(&self) -> Option<&T> {
        self.method.as_any().downcast_ref::<T>()
    }
    /// The VPLs (with `settings.vpl`).
    pub fn vpls(&self) -> Option<&Vpls> {
        self.shared.vpls.as_ref()
    }
    /// The heat map pass (tiled methods): switch it with `HeatmapPass::set_enabled` between
    /// frames, nothing is rebuilt.
    pub fn heatmap(&self) -> Option<&HeatmapPass> {
        self.shared.heatmap.as_ref()
    }
    /// Sets the exposure of the next frames (the tonemap's own uniform: nothing is rebuilt).
    pub fn set_exposure(&self, queue: &wgpu::Queue, exposure: f32) -> Result<(), GpuError> {
        self.shared.tonemap.set_exposure(queue, exposure)
    }
    /// Starts the stochastic method's history again (its frames' mean and its temporal
    /// reuse: the next frame is the first since a change); nothing for the other methods.
    /// The lab calls it after its warm-up, so that a measured frame's history holds the
    /// measured frames alone, however many frames the warm-up took.
    pub fn restart_history(&self) {
        self.method.scene_changed();
    }

    /// Call after the lights moved on the GPU (their buffers rewritten), with the lights as
    /// now uploaded: the next frame redraws the shadow faces (and the RSM) of the casters
    /// that moved, and the stochastic method starts its history again.
    pub fn lights_moved(&self, queue: &wgpu::Queue, lights: &PackedLights) -> Result<(), GpuError> {
        self.restart_history();
        self.method.lights_changed(queue, lights);
        let Some(atlas) = &self.shared.shadows else { return Ok(()) };
        atlas.update(queue, &self.shared.views, lights)?;
        if let Some(v) = &self.shared.vpls {
            v.path.update(queue, atlas, lights);
        }
        Ok(())
    }
    /// Grows the opaque light grid's index buffer to `capacity` indices and binds it again
    /// wherever it is read (methods without a grid ignore it).
    pub fn grow_light_grid(&mut self, ctx: &GpuContext, capacity: u32) {
        let Some(grid) = self.method.grow_lists(&ctx.device, &ctx.queue, capacity) else { return };
        if let Some(b) = &mut self.shared.blended {
            b.frame_grid_grew(&ctx.device, grid);
        }
        for (category, bytes) in grid.memory().entries {
            self.shared.memory.set(&category, bytes);
        }
    }
    /// The targets and grids of the last frame ([`Renderer::outputs`]).
    pub fn outputs(&self) -> Outputs<'_> {
        let f = &self.shared;
        Outputs {
            targets: &f.targets,
            grid: f.grid,
            light_grid: self.method.lists().map(|l| l.grid),
            vpl_light_grid: f.vpls.as_ref().and_then(|v| v.culling.as_ref()).map(|c| &c.grid),
            blended: f.blended.as_ref(),
            shadow_atlas: f.shadows.as_ref(),
            memory: &f.memory,
        }
    }

    /// The draw order the last recorded frame gave its depth pre-pass or G-buffer, with the
    /// eye it was sorted for; None when it gave none (the instance buffer's order). Tests
    /// read it to see that `FrameSettings::draw_order` took effect (it changes no pixel
    /// but where surfaces tie).
    pub fn last_draw_order(&self) -> Option<(Vec3, DrawOrder)> {
        if self.order_given.get() {
            self.order.borrow().clone()
        } else {
            None
        }
    }

    /// The method's frame (diagnostics).
    pub(crate) fn method(&self) -> &dyn MethodFrame {
        self.method.as_ref()
    }
}

impl Renderer for FrameRenderer {
    fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        scene: &SceneGpu,
        camera: &Camera,
    ) {
        let f = &self.shared;
        f.write_view(queue, camera);
        self.method.prepare(queue, camera);
        let (depth, hdr, ldr) = target_handles(&f.targets);
        let mut cached = self.order.borrow_mut();
        if self.settings.knobs.draw_order == DrawOrderMode::FrontToBack {
            let eye = camera.eye();
            if cached.as_ref().is_none_or(|(e, _)| *e != eye) {
                *cached = Some((eye, scene.front_to_back(eye)));
            }
        }
        let order = match self.settings.knobs.draw_order {
            DrawOrderMode::FrontToBack => cached.as_ref().map(|(_, o)| o),
            DrawOrderMode::Submission => None,
        };
        self.order_given.set(order.is_some());
        let mut rec = Rec::new(encoder, timer, f.main_view(), (scene, order), &f.plan);
        f.record_shadows(&mut rec);
        f.record_vpls(&mut rec);
        self.method.record(&mut rec, f, depth);
        f.record_blended(&mut rec, camera, depth, hdr);
        f.record_tail(&mut rec, ldr);
        rec.finish();
    }

    fn outputs(&self) -> Outputs<'_> {
        FrameRenderer::outputs(self)
    }

    fn between_frames(&mut self, ctx: &GpuContext, wait: bool) -> Result<BetweenFrames, GpuError> {
        let mut grew = false;
        let mut blended = None;
        if let Some(b) = &mut self.shared.blended {
            grew |= b.grow_if_dropped(&ctx.device, &ctx.queue, wait)?;
            blended = b.take_status();
        }
        let status = match self.method.lists() {
            Some(l) if wait => Some(l.grid.status(&ctx.device, &ctx.queue)?),
            Some(l) => l.grid.poll_status(),
            None => None,
        };
        let growth = status.and_then(|st| {
            let grid = self.method.lists()?.grid;
            grid.growth(st.needed()).filter(|_| !wait || !st.complete())
        });
        if let Some(capacity) = growth {
            self.grow_light_grid(ctx, capacity);
            grew = true;
        }
        let vpl = self.outputs().vpl_light_grid.and_then(|g| g.poll_status());
        Ok(BetweenFrames { status, blended, vpl, grew })
    }
}
