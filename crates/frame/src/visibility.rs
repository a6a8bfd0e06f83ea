//! The frame of the visibility buffer: its middle steps, between the shared ones
//! ([`crate::shared`]), with the handles each reads and writes.
//!
//! ```text
//! VisibilityRaster   scene                     -> Depth, IDs (R32Uint per sample)
//! Cull               Depth, lights             -> Lists (Forward+'s culling pass: every
//!                                                        layout, test and assignment)
//! [VplCull]          Depth, VPLs               -> VPL Lists (shared step, with VPLs)
//! VisibilityShade    IDs, scene buffers,       -> Hdr (one compute pass; one dispatch per
//!                    Lists, VPL Lists, atlas           material of a textured scene)
//! [VisibilityResolve] per-sample shading       -> Hdr (MSAA only: edge pixels averaged)
//! ```
//!
//! No G-buffer and no forward shading pipeline exist for this method.
//!
//! The traced reference is this frame without culling:
//!
//! ```text
//! VisibilityRaster   scene                     -> Depth, IDs
//! TracedShade        IDs, scene buffers, BVH,  -> Hdr (every light, a shadow ray each; in
//!                    every VPL                          bands of tile rows)
//! [VisibilityResolve] per-sample shading       -> Hdr (MSAA only)
//! ```
//!
//! The stochastic method (issue 48) is the traced reference's frame with the sampler's
//! light loop and a history (one sample a pixel):
//!
//! ```text
//! VisibilityRaster   scene                     -> Depth, IDs
//! StochasticShade    IDs, scene buffers, BVH,  -> Hdr, history (candidates, one kept, one
//!                    history                           ray a pixel; the frames accumulated),
//!                                                      guide (with the denoiser); with
//!                                                      --reuse N > 0 two dispatches: the
//!                                                      sampling run leaves each pixel's
//!                                                      reservoir record, the shading run
//!                                                      merges N neighbours' and casts the ray
//! [StochasticDenoise] history, guide           -> Hdr (--denoise N > 0: N à-trous iterations)
//! ```
//!
//! Depends on tiledlight-gpu (culling) and tiledlight-visibility (raster and shading passes).

use std::any::Any;

use crate::methods::Method;
use crate::plan::Step;
use tiledlight_cull::Camera;
use tiledlight_gpu::culling::LightCulling;
use tiledlight_gpu::depth_prepass::{DEPTH_FORMAT, ID_FORMAT};
use tiledlight_gpu::edge_samples::EdgeTest;
use tiledlight_gpu::features::Features;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::{GpuContext, GpuError};
use tiledlight_visibility::compute_raster::ComputeRasterOptions;
use tiledlight_visibility::denoise::StochasticDenoise;
use tiledlight_visibility::raster::{depth_target, VisibilityRaster};
use tiledlight_visibility::shading::{ShadeLights, VisibilityShading};
use tiledlight_visibility::stochastic::Accumulation;

use crate::handles::Rec;
use crate::method::{tiled_steps, MethodFrame, Registration};
use crate::settings::FrameSettings;
use crate::shared::{SharedSteps, TargetNeeds};
use tiledlight_gpu::handles::{Depth, Lists};
use tiledlight_gpu::targets::target_handles;

/// The display targets the visibility buffer needs: depth and IDs multisampled, the HDR
/// image written by compute (and, with blended geometry, composited onto by a render pass);
/// with the compute raster (`raster`) an `R32Float` depth it writes from compute, unless
/// blended passes need the depth attachment.
pub fn targets(features: &Features) -> TargetNeeds {
    let raster = features.knobs.raster;
    let mut msaa_formats = vec![DEPTH_FORMAT, ID_FORMAT];
    let mut hdr_usage = wgpu::TextureUsages::STORAGE_BINDING;
    if features.blended() {
        msaa_formats.push(HDR_FORMAT);
        hdr_usage |= wgpu::TextureUsages::RENDER_ATTACHMENT;
    }
    TargetNeeds { prefix: "visibility", msaa_formats, hdr_usage, depth: depth_target(raster, features.blended()) }
}

/// The visibility buffer: its raster, culling, the VPLs' culling (with VPLs), shading, the
/// MSAA resolve (with MSAA).
pub const REGISTRATION: Registration = Registration {
    renders: |m| m == Method::Visibility,
    building: "building the visibility-buffer renderer",
    steps: |f| {
        let head = [Step::VisibilityRaster, Step::Cull];
        tiled_steps(f, &head, Step::VisibilityShade, Some(Step::VisibilityResolve))
    },
    targets,
    build: |c, sh, sl, st, m| Ok(Box::new(VisibilityFrame::new(c, sh, sl, st, m)?)),
};

/// The traced reference (with or without the cutoff): the visibility buffer's raster, every
/// light with a shadow ray each, the MSAA resolve (with MSAA). No culling.
pub const TRACED: Registration = Registration {
    renders: Method::is_traced_reference,
    building: "building the traced reference",
    steps: |f| {
        let mut steps = vec![Step::VisibilityRaster, Step::TracedShade];
        if f.msaa > 1 {
            steps.push(Step::VisibilityResolve);
        }
        steps
    },
    targets,
    build: REGISTRATION.build,
};

/// The stochastic method: the visibility buffer's raster, the lights' culling (its lists
/// are the near candidates' source), the sampler's pass (one sample a pixel: MSAA and VPLs
/// are refused when it is built). No shadow maps.
pub const STOCHASTIC: Registration = Registration {
    renders: |m| m == Method::Stochastic,
    building: "building the stochastic method",
    steps: |f| {
        let mut steps = tiled_steps(f, &[Step::VisibilityRaster, Step::Cull], Step::StochasticShade, None);
        if f.knobs.denoise > 0 {
            steps.push(Step::StochasticDenoise);
        }
        steps
    },
    targets,
    build: REGISTRATION.build,
};

/// The visibility buffer's passes (or the traced reference's).
pub struct VisibilityFrame {
    raster: VisibilityRaster,
    /// The light grid's culling (None: the traced reference).
    culling: Option<LightCulling>,
    shading: VisibilityShading,
    /// The traced reference with progress: the device and queue its bands are submitted to.
    progress: Option<(wgpu::Device, wgpu::Queue)>,
    /// The stochastic method's frame counter and history length.
    accumulation: Option<Accumulation>,
    /// The stochastic method's denoiser (`--denoise N` > 0).
    denoise: Option<StochasticDenoise>,
}

impl VisibilityFrame {
    /// Builds the passes over the shared steps' views, targets, shadows and VPLs. An adapter
    /// without primitive IDs is refused by name.
    pub fn new(
        ctx: &GpuContext,
        shared: &SharedSteps,
        (scene, lights): (&SceneGpu, &LightBuffers),
        settings: &FrameSettings,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        if !ctx.device.features().contains(wgpu::Features::PRIMITIVE_INDEX) {
            return Err(GpuError::Unsupported {
                adapter: ctx.info.name.clone(),
                what: "the visibility buffer: its raster pass writes each fragment's triangle \
                       (wgpu feature PRIMITIVE_INDEX, Vulkan geometryShader)"
                    .into(),
            });
        }
        let device = &ctx.device;
        let (features, views, targets) = (&shared.features, &shared.views, &shared.targets);
        let size = (targets.hdr.width(), targets.hdr.height());
        let raster = VisibilityRaster::new(
            device,
            views,
            scene,
            features,
            (size, shared.hooks.wrong_id),
            (settings.knobs.raster, ComputeRasterOptions::of(&settings.knobs), target_handles(targets).0),
            memory,
        )?;
        let culling = (!settings.method.is_traced_reference())
            .then(|| {
                LightCulling::with_drop_light(
                    device,
                    views,
                    target_handles(targets).0,
                    (lights, &shared.lighting),
                    shared.grid,
                    settings.cull,
                    shared.hooks.drop_light,
                )
            })
            .transpose()?;
        if let Some(c) = &culling {
            memory.extend(&c.memory);
        }
        let bvh = || {
            scene.trace.as_ref().ok_or_else(|| {
                GpuError::Config(format!(
                    "the {} needs the scene's BVH: build it with SceneGpu::add_trace before the renderer",
                    settings.method.label().to_lowercase()
                ))
            })
        };
        let shade = match (&culling, settings.method) {
            (Some(culling), Method::Stochastic) => ShadeLights::Stochastic { bvh: bvh()?, culling },
            (Some(c), _) => ShadeLights::Lists(c),
            (None, m) => ShadeLights::Traced { bvh: bvh()?, cutoff: m.has_cutoff() },
        };
        let shading = VisibilityShading::new(
            &shared.lighting_inputs(device, views, lights, features),
            (target_handles(targets).0, &raster),
            target_handles(targets).1,
            scene,
            (shade, shared.grid, EdgeTest::of(&features.knobs)),
            memory,
        )?;
        let progress = (settings.method.is_traced_reference() && settings.traced_progress)
            .then(|| (ctx.device.clone(), ctx.queue.clone()));
        let knobs = &settings.knobs;
        let accumulation = (settings.method == Method::Stochastic)
            .then(|| Accumulation::new((knobs.candidates, knobs.far_candidates), knobs.accumulate));
        let denoise = match shading.stochastic_buffers() {
            Some((history, Some(guide))) => Some(StochasticDenoise::new(
                device,
                (history, guide),
                target_handles(targets).1,
                size,
                knobs.denoise,
                memory,
            )?),
            _ => None,
        };
        Ok(Self { raster, culling, shading, progress, accumulation, denoise })
    }

    /// The raster pass (its ID layout).
    pub fn raster(&self) -> &VisibilityRaster {
        &self.raster
    }

    /// The culling pass (None for the traced reference).
    pub fn culling(&self) -> Option<&LightCulling> {
        self.culling.as_ref()
    }

    /// The material-and-lights pass.
    pub fn shading(&self) -> &VisibilityShading {
        &self.shading
    }
}

/// Who hears of the traced reference's progress, band by band, in a frame of
/// `FrameSettings::traced_progress`: `(band, bands, time since the frame's first band)`.
pub type BandReporter = dyn Fn(u32, u32, std::time::Duration) + Send + Sync;

static BAND_REPORTER: std::sync::RwLock<Option<std::sync::Arc<BandReporter>>> = std::sync::RwLock::new(None);

/// Installs (or with `None` removes) the process's [`BandReporter`]: the command that
/// renders a traced reference shows a progress bar with it. Without one the bands pass
/// silently (this crate prints nothing of its own).
pub fn set_band_reporter(reporter: Option<std::sync::Arc<BandReporter>>) {
    // A reporter that panicked poisons the lock; the next one replaces it all the same.
    *BAND_REPORTER.write().unwrap_or_else(|e| e.into_inner()) = reporter;
}

fn report_band(band: u32, bands: u32, elapsed: std::time::Duration) {
    let reporter = BAND_REPORTER.read().unwrap_or_else(|e| e.into_inner()).clone();
    if let Some(r) = reporter {
        r(band, bands, elapsed);
    }
}

impl MethodFrame for VisibilityFrame {
    fn record(&self, rec: &mut Rec<'_>, shared: &SharedSteps, depth: Depth<'_>) {
        rec.step(Step::VisibilityRaster);
        self.raster.record(rec, depth.view);
        match &self.culling {
            Some(culling) => {
                rec.step(Step::Cull);
                let r = &mut rec.recording;
                culling.record(r.encoder, r.timer, r.view, "visibility.cull");
                shared.record_vpl_cull(rec);
                if self.accumulation.is_some() {
                    rec.step(Step::StochasticShade);
                    self.shading.record_stochastic(rec, &culling.grid);
                    if let Some(d) = &self.denoise {
                        rec.step(Step::StochasticDenoise);
                        d.record(rec);
                    }
                } else {
                    rec.step(Step::VisibilityShade);
                    self.shading.record(rec, &culling.grid);
                }
            }
            None => {
                rec.step(Step::TracedShade);
                match &self.progress {
                    Some((device, queue)) => {
                        let start = std::time::Instant::now();
                        let mut flush = |encoder: &mut wgpu::CommandEncoder, band: u32, bands: u32| {
                            let done = std::mem::replace(
                                encoder,
                                device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                                    label: Some("traced.band"),
                                }),
                            );
                            queue.submit([done.finish()]);
                            // Progress is only known once the band is done.
                            if let Err(e) = device.poll(wgpu::PollType::wait_indefinitely()) {
                                eprintln!("\ntraced reference: waiting for band {band}: {e}");
                            }
                            report_band(band, bands, start.elapsed());
                        };
                        self.shading.record_traced(rec, Some(&mut flush));
                    }
                    None => self.shading.record_traced(rec, None),
                }
            }
        }
        if depth.samples > 1 {
            rec.step(Step::VisibilityResolve);
            let r = &mut rec.recording;
            self.shading.record_resolve(r.encoder, r.timer);
        }
    }

    fn prepare(&self, queue: &wgpu::Queue, camera: &Camera) {
        if let Some(a) = &self.accumulation {
            let p = a.next(camera.view_proj());
            let (width, height) = self.shading.screen();
            let view = tiledlight_gpu::view::ViewUniforms::new(camera, width, height);
            self.shading.write_stochastic_frame(queue, p, &view);
            if let Some(d) = &self.denoise {
                d.write_frame(queue, p.accumulated + 1);
            }
        }
    }

    fn scene_changed(&self) {
        if let Some(a) = &self.accumulation {
            a.reset();
        }
    }

    fn lights_changed(&self, queue: &wgpu::Queue, lights: &tiledlight_cull::light::PackedLights) {
        self.shading.refit_light_tree(queue, lights);
    }

    fn lists(&self) -> Option<Lists<'_>> {
        self.culling.as_ref().map(|c| Lists { grid: &c.grid })
    }

    fn grow_lists(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, capacity: u32) -> Option<&LightGrid> {
        // The shading pass binds the grid's group at record time: nothing to rebind.
        let culling = self.culling.as_mut()?;
        // The stochastic method's history holds frames that dropped lights (that is why
        // the grid grows): it starts again with the grown grid.
        if let Some(a) = &self.accumulation {
            a.reset();
        }
        culling.grid.grow(device, queue, capacity);
        Some(&culling.grid)
    }

    fn edge_pixels(&self, ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        self.shading.read_edge_pixels(&ctx.device, &ctx.queue)
    }

    fn large_tiles(&self, ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
        let Some(raster) = self.raster.compute() else { return Ok(None) };
        raster.read_large_tile_count(&ctx.device, &ctx.queue)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
