//! A run on the GPU ([`Prepared`]): the device, the uploaded scene and lights, the camera,
//! the renderer built from the settings, a change of settings carried out as
//! [`crate::rebuild_plan`] decides ([`Prepared::reconfigure`]), GPU errors collected
//! instead of panicking, and the report lines about it all.
//!
//! Depends on tiledlight-gpu (context, scene and light buffers, the `Renderer` trait),
//! tiledlight-forward and tiledlight-deferred (the renderers), tiledlight-cull, and the
//! crate's other modules.

use std::sync::{Arc, Mutex};

use anyhow::{bail, ensure, Context, Result};
use tiledlight_cull::light::{try_pack_lights_ranked, CasterRank};
use tiledlight_cull::Camera;
use tiledlight_frame::caster_rank::{contribution_scores, CasterRanking};
use tiledlight_frame::{FrameRenderer, FrameSettings};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::heatmap::HeatmapOf;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::{ContextOptions, GpuContext, GpuError};
use tiledlight_scene::{Aabb, CameraDesc, Light};

use crate::camera::choose_camera;
use crate::load::{build_lights, FittedLights, LightSummary, SceneCpu, SurfacePlacement, Surfaces};
use crate::rebuild::{rebuild_plan, Rebuild, Reload};
use crate::settings::{CasterChoice, Settings};
use crate::stats::{blended_stats, culling_stats, group_digits, BlendedStats, CullingStats};

/// Everything a run needs before a renderer exists: the GPU, the uploaded scene and
/// lights, the camera, and what to print about them.
pub struct Prepared {
    /// The settings in use, with the list capacity chosen for the lights when the
    /// settings left it open (`capacity` is always `Some`).
    pub settings: Settings,
    /// Device, queue and adapter.
    pub ctx: GpuContext,
    /// The scene's name.
    pub scene_name: String,
    /// Instances drawn.
    pub instances: usize,
    /// The scene on the GPU.
    pub scene_gpu: SceneGpu,
    /// The lights on the GPU.
    pub lights: LightBuffers,
    /// Light counts.
    pub light_summary: LightSummary,
    /// The camera (aspect = width / height).
    pub camera: Camera,
    /// Where the camera came from, for the report.
    pub camera_source: String,
    /// The scene's bounds (random lights are placed in them).
    pub bounds: Aabb,
    /// The lights the scene file brought along (before the random ones).
    pub file_lights: Vec<Light>,
    /// How the point lights were placed on the surfaces (None when they were not).
    pub surface_placement: Option<SurfacePlacement>,
    /// How the other random lights of a loaded scene were fitted to it.
    pub fitted: FittedLights,
    /// The current scene's load warnings ([`SceneCpu::warnings`]): replaced when
    /// [`Prepared::reconfigure`] reloads the scene, which callers should show then too.
    pub scene_warnings: Vec<String>,
    /// With casters chosen by contribution: the scores they were chosen by and the ranking's
    /// GPU cost (None otherwise).
    pub caster_ranking: Option<CasterRanking>,
    /// Some material of the scene is alpha-blended (transparent grid objects, a glTF
    /// `BLEND` material): renderers draw it through their blended path.
    pub has_blend: bool,
    /// The settings as given (capacity possibly open): what [`Prepared::reconfigure`]
    /// plans from.
    requested: Settings,
    /// The scene file's own camera, if any (the camera is rebuilt from it on a new aspect).
    scene_camera: Option<CameraDesc>,
    /// The scene's surfaces sampled by area, kept while lights are placed on them (new
    /// surface lights need no new scene).
    surfaces: Surfaces,
    gpu_errors: Arc<Mutex<Vec<GpuFault>>>,
}

/// A GPU error wgpu raised outside an error scope.
#[derive(Clone, Debug)]
struct GpuFault {
    /// wgpu said the GPU is out of memory.
    oom: bool,
    /// wgpu's message.
    message: String,
}

/// Uploads the scene and its lights (with the settings' shadow casters, and the ranking
/// that chose them by contribution).
fn upload(
    ctx: &GpuContext,
    cpu: &SceneCpu,
    settings: &Settings,
) -> Result<(SceneGpu, LightBuffers, Option<CasterRanking>)> {
    let mut scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &cpu.scene)
        .with_context(|| format!("uploading scene '{}'", cpu.scene.name))?;
    // The traced reference's BVH only when it is asked for (a second a million triangles).
    if settings.method.is_traced() {
        scene_gpu
            .add_trace(&ctx.device, &cpu.scene)
            .with_context(|| format!("building the BVH of scene '{}' for the traced reference", cpu.scene.name))?;
    }
    let (lights, ranking) = upload_lights(ctx, &scene_gpu, (&cpu.lights, &cpu.camera), settings)?;
    Ok((scene_gpu, lights, ranking))
}

/// What an upload of the lights is called in its errors: the caster flags are named when
/// some are asked for (the scene may have fewer lights of a kind than that).
fn lights_context(settings: &Settings) -> String {
    let (points, spots) = settings.shadow_casters();
    if settings.has_shadows() {
        format!("uploading the lights with --shadow-point-lights {points} --shadow-spot-lights {spots}")
    } else {
        "uploading the lights".into()
    }
}

/// Uploads `lights` into new buffers, the casters of each kind chosen as the settings ask
/// ([`caster_scores`]).
fn upload_lights(
    ctx: &GpuContext,
    scene: &SceneGpu,
    (lights, camera): (&[Light], &Camera),
    settings: &Settings,
) -> Result<(LightBuffers, Option<CasterRanking>)> {
    let ranking = caster_ranking(ctx, scene, (lights, camera), settings)?;
    let rank = ranking.as_ref().map_or(CasterRank::Brightest, |r| CasterRank::Scores(&r.scores));
    let buffers = LightBuffers::ranked(&ctx.device, lights, settings.shadow_casters(), rank)
        .with_context(|| lights_context(settings))?;
    Ok((buffers, ranking))
}

/// With casters chosen by contribution, each light's contribution to a frame of `camera`
/// at the settings' size (`tiledlight_frame::caster_rank`); None when the casters are the
/// brightest or there are none (no frame is rendered then).
fn caster_ranking(
    ctx: &GpuContext,
    scene: &SceneGpu,
    (lights, camera): (&[Light], &Camera),
    settings: &Settings,
) -> Result<Option<CasterRanking>> {
    if settings.casters_by != CasterChoice::Contribution || !settings.has_shadows() {
        return Ok(None);
    }
    let ranking = contribution_scores(ctx, scene, lights, camera, (settings.width, settings.height))
        .context("choosing the shadow casters by their contribution to the frame (--casters-by contribution)")?;
    Ok(Some(ranking))
}

/// `settings` with the per-list capacity chosen for `lights` lights when it has none
/// (what the device's workgroup memory holds, up to the light count).
fn with_capacity(settings: &Settings, lights: u32, limits: &wgpu::Limits) -> Settings {
    let mut settings = settings.clone();
    if settings.capacity.is_none() {
        settings.capacity =
            Some(CullOptions::capacity_for(lights, settings.half_z, settings.reserved_workgroup_bytes(), limits));
    }
    settings
}

impl Prepared {
    /// Checks the settings, builds the scene and lights on the CPU (so file errors come
    /// before the slow device creation), then creates the device and uploads them.
    pub fn new(settings: &Settings) -> Result<Self> {
        let cpu = SceneCpu::load(settings)?;
        let ctx = GpuContext::headless(ContextOptions::default())
            .context("creating the GPU device (set WGPU_ADAPTER_NAME to pick an adapter)")?;
        Self::with_context(settings, cpu, ctx)
    }

    /// Uploads a loaded scene and its lights to an existing device (the viewer's, made for
    /// its window).
    pub fn with_context(settings: &Settings, cpu: SceneCpu, ctx: GpuContext) -> Result<Self> {
        // wgpu panics on errors raised outside an error scope; collect them instead so a
        // GPU problem during the frame loop ends the run with an error message.
        let gpu_errors = Arc::new(Mutex::new(Vec::new()));
        let sink = gpu_errors.clone();
        ctx.device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            log::debug!("GPU error: {e}");
            let oom = matches!(e, wgpu::Error::OutOfMemory { .. });
            if let Ok(mut v) = sink.lock() {
                v.push(GpuFault { oom, message: e.to_string() });
            }
        }));
        let (scene_gpu, lights, caster_ranking) = upload(&ctx, &cpu, settings)?;
        Ok(Self {
            caster_ranking,
            settings: with_capacity(settings, lights.len(), &ctx.device.limits()),
            requested: settings.clone(),
            ctx,
            scene_name: cpu.scene.name.clone(),
            instances: cpu.scene.instances.len(),
            scene_gpu,
            lights,
            light_summary: LightSummary::of(&cpu.lights, cpu.file_lights),
            camera: cpu.camera,
            camera_source: cpu.camera_source,
            bounds: cpu.scene.bounds,
            has_blend: cpu.scene.has_blend(),
            file_lights: cpu.scene.lights,
            scene_camera: cpu.scene.camera,
            surface_placement: cpu.surface_placement,
            fitted: cpu.fitted,
            scene_warnings: cpu.warnings,
            surfaces: cpu.surfaces,
            gpu_errors,
        })
    }

    /// The settings as last given to [`Prepared::new`], [`Prepared::with_context`] or
    /// [`Prepared::reconfigure`] (the capacity left open if it was).
    pub fn requested(&self) -> &Settings {
        &self.requested
    }

    /// Switches to `settings` on the same GPU device, rebuilding only what
    /// [`rebuild_plan`] says they change (from the settings last given): the scene, the
    /// lights (in place when their counts stay), the camera. Returns that plan: when its
    /// `renderer` is set, renderers built before must be rebuilt ([`Prepared::renderer`]);
    /// when only the light data was rewritten ([`Reload::LightData`]) and lights cast
    /// shadows, renderers built before must be given the new lights
    /// (`Renderer::lights_moved` with `lights.packed`) to redraw their shadows.
    /// Sweeps use it so that a GPU context is created once per run, not once per point.
    ///
    /// On error nothing has changed, except for GPU errors raised by the new uploads
    /// (after which the new scene or lights are in use).
    pub fn reconfigure(&mut self, settings: &Settings) -> Result<Rebuild> {
        settings.validate()?;
        let plan = rebuild_plan(&self.requested, settings);
        // The traced reference needs the scene's BVH, built from the scene on the CPU,
        // which is not kept: the scene is loaded again once.
        let needs_trace = settings.method.is_traced() && self.scene_gpu.trace.is_none();
        match plan.reload {
            _ if needs_trace => self.replace_scene(settings, SceneCpu::load(settings)?)?,
            Reload::Scene => self.replace_scene(settings, SceneCpu::load(settings)?)?,
            reload => {
                let camera = if plan.camera {
                    Some(choose_camera(settings, self.scene_camera.as_ref(), &self.bounds)?)
                } else {
                    None
                };
                if reload != Reload::Nothing {
                    // The new camera: casters chosen by contribution are ranked from it.
                    let cam = camera.as_ref().map_or(self.camera, |(c, _)| *c);
                    self.replace_lights(settings, reload, &cam)?;
                }
                if let Some((camera, source)) = camera {
                    (self.camera, self.camera_source) = (camera, source);
                }
            }
        }
        self.requested = settings.clone();
        self.settings = with_capacity(settings, self.lights.len(), &self.ctx.device.limits());
        self.check_gpu_errors()?;
        Ok(plan)
    }

    /// Replaces the scene and lights by a newly loaded one (with its camera). Nothing
    /// changes when the upload fails.
    fn replace_scene(&mut self, settings: &Settings, cpu: SceneCpu) -> Result<()> {
        let (scene_gpu, lights, caster_ranking) = upload(&self.ctx, &cpu, settings)?;
        self.caster_ranking = caster_ranking;
        self.settings = with_capacity(settings, lights.len(), &self.ctx.device.limits());
        self.scene_name = cpu.scene.name.clone();
        self.instances = cpu.scene.instances.len();
        self.scene_gpu = scene_gpu;
        self.lights = lights;
        self.light_summary = LightSummary::of(&cpu.lights, cpu.file_lights);
        self.camera = cpu.camera;
        self.camera_source = cpu.camera_source;
        self.bounds = cpu.scene.bounds;
        self.has_blend = cpu.scene.has_blend();
        self.file_lights = cpu.scene.lights;
        self.scene_camera = cpu.scene.camera;
        self.surface_placement = cpu.surface_placement;
        self.fitted = cpu.fitted;
        self.scene_warnings = cpu.warnings;
        self.surfaces = cpu.surfaces;
        Ok(())
    }

    /// Regenerates the random lights for `settings` (counts, seed, threshold) in the
    /// current scene: written over the existing buffers for [`Reload::LightData`] (the
    /// counts and shadow casters must be the same; renderers built before with shadow
    /// casters must be told, `Renderer::lights_moved`), into new buffers for
    /// [`Reload::LightBuffers`] (renderers built before must be rebuilt). Nothing changes
    /// on error.
    fn replace_lights(&mut self, settings: &Settings, reload: Reload, camera: &Camera) -> Result<()> {
        let built = build_lights(settings, &self.bounds, self.surfaces.as_deref(), &self.file_lights)?;
        let lights = built.lights;
        let summary = LightSummary::of(&lights, self.file_lights.len());
        if reload == Reload::LightData {
            let same_shape = summary.point == self.light_summary.point && summary.spot == self.light_summary.spot;
            ensure!(
                same_shape,
                "internal: light data rewritten in place with other counts ({} point, {} spot instead of {} and {})",
                summary.point,
                summary.spot,
                self.light_summary.point,
                self.light_summary.spot
            );
            // Validated and ordered like every upload (`upload_lights` does the same): the
            // casters chosen among the new lights as the settings ask.
            let ranking = caster_ranking(&self.ctx, &self.scene_gpu, (&lights, camera), settings)?;
            let rank = ranking.as_ref().map_or(CasterRank::Brightest, |r| CasterRank::Scores(&r.scores));
            let packed = try_pack_lights_ranked(&lights, settings.shadow_casters(), rank)
                .with_context(|| lights_context(settings))?;
            let (old, new) = (&self.lights.packed, &packed);
            ensure!(
                (new.shadow_points, new.shadow_spots) == (old.shadow_points, old.shadow_spots),
                "internal: light data rewritten in place with other shadow casters ({} point, {} spot instead of {} and {})",
                new.shadow_points,
                new.shadow_spots,
                old.shadow_points,
                old.shadow_spots
            );
            if !packed.is_empty() {
                let q = &self.ctx.queue;
                q.write_buffer(&self.lights.cull, 0, bytemuck::cast_slice(&packed.cull));
                q.write_buffer(&self.lights.shading, 0, bytemuck::cast_slice(&packed.shading));
                if let Some(spots) = &self.lights.spots {
                    q.write_buffer(spots, 0, bytemuck::cast_slice(&packed.spots));
                }
            }
            self.lights.packed = packed;
            self.caster_ranking = ranking;
        } else {
            (self.lights, self.caster_ranking) =
                upload_lights(&self.ctx, &self.scene_gpu, (&lights, camera), settings)?;
        }
        self.light_summary = summary;
        self.surface_placement = built.surface_placement;
        self.fitted = built.fitted;
        Ok(())
    }

    /// Takes the GPU errors raised outside an error scope since the last call (the viewer
    /// shows them and goes on; `check_gpu_errors` ends a headless run instead).
    pub fn take_gpu_errors(&self) -> Vec<String> {
        let faults = self.gpu_errors.lock().map(|mut v| std::mem::take(&mut *v)).unwrap_or_default();
        let line = |f: GpuFault| if f.oom { format!("out of GPU memory ({})", f.message) } else { f.message };
        faults.into_iter().map(line).collect()
    }

    /// Builds a renderer for the settings' method, screen and culling options, with the
    /// heat map of the opaque lists when `heatmap` ([`Prepared::renderer_with_heatmap`]).
    pub fn renderer(&self, heatmap: bool) -> Result<FrameRenderer> {
        self.renderer_with_heatmap(heatmap.then_some(HeatmapOf::Opaque))
    }

    /// Whether the scene has alpha-blended geometry (the blended path, its lists and their
    /// heat map exist).
    pub fn has_blended_geometry(&self) -> bool {
        self.scene_gpu.draws.iter().any(|d| d.kind.blended && !d.instances.is_empty())
    }

    /// Builds a renderer for the settings' method, screen and culling options, drawing the
    /// heat map of grid `heatmap` when given. The blended lists' heat map needs a tiled
    /// method and blended geometry, the VPL lists' VPLs.
    pub fn renderer_with_heatmap(&self, heatmap: Option<HeatmapOf>) -> Result<FrameRenderer> {
        let a = &self.settings;
        if heatmap.is_some() && !a.method.is_tiled() {
            bail!("--heatmap needs a tiled method, forward-plus or deferred ({} has no tiles)", a.method.name());
        }
        if heatmap == Some(HeatmapOf::Blended) && !self.has_blended_geometry() {
            bail!(
                "--heatmap blended shows the alpha-blended geometry's light lists, and this scene has no blended \
                 geometry (add --transparent-objects N, or a glTF scene with BLEND materials)"
            );
        }
        if heatmap == Some(HeatmapOf::Vpl) && a.vpl.is_none() {
            bail!(
                "--heatmap vpl shows the virtual point lights' own light lists, and VPLs are off (add --vpl, \
                 with shadow-casting lights: --shadow-spot-lights or --shadow-point-lights)"
            );
        }
        let of = heatmap.unwrap_or_default();
        let r = FrameRenderer::new(
            &self.ctx,
            &self.scene_gpu,
            &self.lights,
            a.width,
            a.height,
            FrameSettings { heatmap_of: of, ..a.frame_settings(heatmap.is_some()) },
        );
        let what = format!("building the {} renderer at {}x{}", a.method.name(), a.width, a.height);
        let r = r.with_context(|| what.clone())?;
        self.check_gpu_errors_while(&what)?;
        Ok(r)
    }

    /// The culling statistics of the last frame `renderer` (built by this run) drew:
    /// [`culling_stats`] with this run's device and culling options.
    pub fn culling_stats(&self, renderer: &FrameRenderer) -> Result<Option<CullingStats>> {
        culling_stats(&self.ctx, renderer, &self.settings.cull_options())
    }

    /// The blended geometry of the last frame `renderer` (built by this run) drew:
    /// [`blended_stats`] with this run's device; None without blended geometry.
    pub fn blended_stats(&self, renderer: &FrameRenderer) -> Result<Option<BlendedStats>> {
        blended_stats(&self.ctx, renderer)
    }

    /// Fails when the device was lost ([`GpuError::DeviceLost`]) or wgpu raised an error
    /// outside an error scope: out of memory first ([`GpuError::OutOfMemory`], "while
    /// rendering"), else the first error.
    pub fn check_gpu_errors(&self) -> Result<()> {
        self.check_gpu_errors_while("rendering")
    }

    /// [`Prepared::check_gpu_errors`], an out-of-memory error saying "while `doing`".
    pub fn check_gpu_errors_while(&self, doing: &str) -> Result<()> {
        // A lost device fails every later call with "invalid" errors: the loss is the news.
        if let Some(lost) = self.ctx.device_lost() {
            return Err(lost.into());
        }
        let errors = self.gpu_errors.lock().map(|v| v.clone()).unwrap_or_default();
        if let Some(f) = errors.iter().find(|f| f.oom) {
            let context = format!("{doing} (wgpu: {})", f.message);
            return Err(GpuError::OutOfMemory { context }.into());
        }
        match errors.first() {
            Some(e) => bail!("GPU error ({} in all): {}", errors.len(), e.message),
            None => Ok(()),
        }
    }

    /// The device-lost error once the device was lost (a frame loop checks it when a
    /// step fails, so the loss is named rather than its consequences).
    pub fn device_lost(&self) -> Option<GpuError> {
        self.ctx.device_lost()
    }

    /// The report lines about adapter, scene, lights, screen and method.
    pub fn describe(&self) -> Vec<(String, String)> {
        let a = &self.settings;
        let l = &self.light_summary;
        let mut lights = format!("{} point, {} spot", l.point, l.spot);
        lights.push_str(&lights_description(l, a, self.surface_placement.as_ref(), &self.fitted));
        let grid = tiledlight_cull::TileGrid::new(a.width, a.height, a.tile_size).ok();
        let mut res = format!("{}x{}", a.width, a.height);
        if let Some(g) = grid {
            res.push_str(&format!(
                ", {} px tiles: {}x{} = {} tiles",
                g.tile_size,
                g.tiles_x,
                g.tiles_y,
                g.tile_count()
            ));
        }
        // The method's line from its traits (a new method needs no arm here): its name,
        // then what its traits add.
        let t = a.method.traits();
        let mut parts: Vec<String> = Vec::new();
        if t.tiled {
            parts.push(a.culling_description());
        }
        if t.gbuffer {
            parts.push(format!("{} G-buffer targets, drawn {}", a.knobs.gbuffer_rts, a.knobs.draw_order.label()));
        }
        if t.visibility_buffer && !t.traced {
            parts.push("32-bit triangle IDs".into());
        }
        if t.stochastic {
            let history = match a.knobs.accumulate {
                0 => "no history (each frame's own estimate)".to_string(),
                n => format!("a still view's last {n} frames accumulated"),
            };
            parts.push(format!(
                "{} candidates a pixel from its list and {} from every light, one kept by its contribution and \
                 shadowed by a ray, no cutoff, {history}",
                a.knobs.candidates, a.knobs.far_candidates
            ));
        } else if t.traced {
            let falloff = if t.cutoff { "the radius cutoff" } else { "no cutoff" };
            parts.push(match &self.scene_gpu.trace {
                Some(tr) => format!(
                    "every light, {falloff}, a shadow ray each through a BVH of {} triangles, {} nodes, depth {}, \
                     built in {:.2} s",
                    tr.triangle_count, tr.node_count, tr.depth, tr.build_seconds
                ),
                None => format!("every light, {falloff}, a shadow ray each"),
            });
        } else if t.is_reference() {
            parts.push("every light for every pixel".into());
        }
        let method = format!("{} ({})", a.method.name(), parts.join(", "));
        let method = if a.knobs.early_outs {
            method
        } else {
            format!("{method}; ABLATION --no-early-outs: every listed light shaded in full, none skipped")
        };
        if a.msaa > 1 {
            res.push_str(&format!(", MSAA {}x", a.msaa));
            // The edge test of the methods that shade a pixel once unless it is an edge.
            let by_surface = t.gbuffer || (t.visibility_buffer && a.knobs.surface_edges);
            if t.visibility_buffer && !a.knobs.surface_edges {
                res.push_str(" (edge test: samples with different triangle IDs)");
            } else if by_surface {
                let ids =
                    if t.visibility_buffer { "two triangles whose surfaces differ: another material, " } else { "" };
                res.push_str(&format!(
                    " (edge test: {ids}{} of the view distance off the tangent plane, or normals {} deg apart)",
                    a.knobs.edge_distance, a.knobs.edge_normal_deg
                ));
            }
        }
        let mut lines = vec![
            ("adapter".into(), self.ctx.describe()),
            (
                "scene".into(),
                format!(
                    "{}: {} triangles, {} instances, camera: {}",
                    self.scene_name,
                    group_digits(self.scene_gpu.triangles),
                    self.instances,
                    self.camera_source
                ),
            ),
            ("lights".into(), lights),
            ("resolution".into(), res),
            ("method".into(), method),
        ];
        // Only when some light casts a shadow.
        if let Some(mut shadows) = a.shadow_description() {
            if let Some(cost) = self.caster_ranking.as_ref().and_then(CasterRanking::describe_cost) {
                shadows.push_str(&format!("; casters ranked in {cost}"));
            }
            lines.push(("shadows".into(), shadows));
        }
        // Only when the scene has blended geometry.
        if let Some(blended) = a.blend_description(self.has_blend) {
            lines.push(("blended".into(), blended));
        }
        lines
    }
}

/// The parenthesis after the `lights:` counts: where the lights came from, and for
/// random ones how they were chosen ("(random, seed 1, threshold 0.1)" for the courtyard's;
/// with the placement and radii of each kind for a loaded scene's).
pub(crate) fn lights_description(
    l: &LightSummary,
    a: &Settings,
    surface: Option<&SurfacePlacement>,
    fitted: &FittedLights,
) -> String {
    // A demo's own lights stand where a file's would.
    let own = match (a.demo, &a.scene) {
        (Some(d), _) => format!("placed by --demo {}", d.name()),
        (None, crate::SceneSource::Peer(p)) => format!("of {}", p.name()),
        (None, _) => "from the glTF file".to_string(),
    };
    let source = match (l.from_file, l.random) {
        (0, 0) => return String::new(),
        (f, 0) => return format!(" (all {f} {own})"),
        (0, _) => "random".to_string(),
        (f, r) => format!("{f} {own} + {r} random"),
    };
    let mut text = format!(" ({source}, seed {}, threshold {}", a.seed, a.threshold);
    if let Some(p) = surface {
        let exposure = if a.auto_exposure { "automatic".to_string() } else { format!("{:.3}", a.exposure) };
        text.push_str(&format!(", exposure {exposure}; point lights: {p}"));
    }
    if let Some(s) = &fitted.spots {
        text.push_str(&format!("; spot lights: {s}"));
    }
    if let Some(b) = &fitted.bounds {
        text.push_str(&format!("; {b}"));
    }
    text.push(')');
    text
}
