//! The Forward+ renderer and the brute-force reference: depth pre-pass -> light culling
//! (Forward+ only) -> forward shading into linear HDR -> tonemap (-> heat map). With MSAA the
//! pre-pass and shading pass are multisampled (hardware MSAA), culling bounds every sample's
//! depth, and the shading pass resolves into the HDR image. Built once
//! for a scene, light set, screen size and settings; `record` only writes uniforms and
//! records passes. Depends on tiledlight-gpu and tiledlight-cull.

use glam::Vec3;
use tiledlight_cull::{Camera, TileGrid};
use tiledlight_gpu::depth_prepass::{DepthPrepass, DEPTH_FORMAT};
use tiledlight_gpu::light_cull::{CullOptions, DropLight, LightCulling};
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::{check_msaa, texture_2d_msaa, DisplayTargets, Renderer};
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::tonemap::{HeatmapPass, TonemapPass, HDR_FORMAT};
use tiledlight_gpu::view::{ViewUniforms, Views, MAIN_VIEW};
use tiledlight_gpu::{GpuContext, GpuError};

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
    /// Ambient radiance (times base colour), so unlit areas are not black.
    pub ambient: Vec3,
    /// Draw the lights-per-tile heat map over the image (Forward+ only).
    pub heatmap: bool,
    /// MSAA samples per pixel: 1, 2, 4 or 8 (as the adapter supports). Also sets
    /// `cull.samples`.
    pub msaa: u32,
    /// Test-only: leave one light out of one tile's list (Forward+ only; see
    /// [`DropLight`]). `None` by default; production never sets it.
    pub test_drop_light: Option<DropLight>,
}

impl Default for ForwardSettings {
    fn default() -> Self {
        Self {
            method: Method::ForwardPlus,
            cull: CullOptions::default(),
            exposure: 1.0,
            ambient: Vec3::splat(0.02),
            heatmap: false,
            msaa: 1,
            test_drop_light: None,
        }
    }
}

/// A Forward+ (or brute-force) renderer for one scene, light set and screen size.
pub struct ForwardRenderer {
    settings: ForwardSettings,
    grid: TileGrid,
    views: Views,
    prepass: DepthPrepass,
    culling: Option<LightCulling>,
    shading: ShadingPass,
    tonemap: TonemapPass,
    /// Forward+ only (it reads the light grid); drawn when enabled.
    heatmap: Option<HeatmapPass>,
    targets: DisplayTargets,
    /// The multisampled HDR target the shading pass draws into and resolves (MSAA only).
    hdr_msaa: Option<(wgpu::Texture, wgpu::TextureView)>,
    memory: MemoryReport,
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
        check_msaa(ctx, settings.msaa, &[DEPTH_FORMAT, HDR_FORMAT])?;
        let grid = TileGrid::new(width, height, settings.cull.tile_size)?;
        if width > device.limits().max_texture_dimension_2d || height > device.limits().max_texture_dimension_2d {
            return Err(GpuError::Config(format!(
                "{width}x{height} exceeds this GPU's {} pixel texture limit",
                device.limits().max_texture_dimension_2d
            )));
        }
        ctx.checked("building the Forward+ renderer", || {
            let views = Views::new(device, 1);
            let lighting = lights.lighting(device, settings.ambient);
            let targets = DisplayTargets::new(
                device,
                "forward",
                (width, height),
                settings.msaa,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            );
            let hdr_msaa = (settings.msaa > 1).then(|| {
                let t = texture_2d_msaa(
                    device,
                    "forward.hdr_msaa",
                    (width, height),
                    HDR_FORMAT,
                    settings.msaa,
                    wgpu::TextureUsages::RENDER_ATTACHMENT,
                );
                let v = t.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("forward.hdr_msaa.view"),
                    ..Default::default()
                });
                (t, v)
            });
            let prepass = DepthPrepass::new(device, &views, scene, settings.msaa)?;
            let (culling, light_loop) = match settings.method {
                Method::ForwardPlus => (
                    Some(LightCulling::with_drop_light(
                        device,
                        &views,
                        &targets.depth_view,
                        (lights, &lighting),
                        grid,
                        settings.cull,
                        settings.test_drop_light,
                    )?),
                    LightLoop::Tiled { half_z: settings.cull.half_z },
                ),
                Method::BruteForce { .. } if settings.test_drop_light.is_some() => {
                    return Err(GpuError::Config(
                        "the drop-light test hook needs a tiled method (brute force has no tiles)".into(),
                    ))
                }
                Method::BruteForce { cutoff } => (None, LightLoop::All { cutoff }),
            };
            let shading = ShadingPass::new(
                device,
                &views,
                scene,
                (lights, &lighting),
                culling.as_ref(),
                light_loop,
                settings.msaa,
            )?;
            let tonemap = TonemapPass::new(device, &targets.hdr_view, settings.exposure)?;
            if settings.heatmap && culling.is_none() {
                return Err(GpuError::Config("the heat map needs a tiled method (brute force has no tiles)".into()));
            }
            let heatmap =
                culling.as_ref().map(|c| HeatmapPass::new(device, &c.grid.grid, settings.heatmap)).transpose()?;
            let mut memory = MemoryReport::default();
            memory.extend(&scene.memory);
            memory.extend(&lights.memory);
            memory.add("targets (depth+hdr+ldr)", targets.bytes());
            if let Some((t, _)) = &hdr_msaa {
                memory.add("forward.hdr_msaa", t.width() as u64 * t.height() as u64 * settings.msaa as u64 * 8);
            }
            if let Some(c) = &culling {
                memory.extend(&c.memory);
            }
            Ok(Self { settings, grid, views, prepass, culling, shading, tonemap, heatmap, targets, hdr_msaa, memory })
        })?
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &ForwardSettings {
        &self.settings
    }
    /// The culling pass (Forward+ only).
    pub fn culling(&self) -> Option<&LightCulling> {
        self.culling.as_ref()
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
        self.views.write(queue, MAIN_VIEW, &ViewUniforms::new(camera, self.grid.width, self.grid.height));
        let view = (&self.views, MAIN_VIEW);
        self.prepass.record(encoder, timer, view, scene, &self.targets.depth_view);
        if let Some(c) = &self.culling {
            c.record(encoder, timer, view, "forward.cull");
        }
        // With MSAA the pass draws the multisampled target and resolves it into the HDR image.
        let (hdr, resolve) = match &self.hdr_msaa {
            Some((_, v)) => (v, Some(&self.targets.hdr_view)),
            None => (&self.targets.hdr_view, None),
        };
        self.shading.record(encoder, timer, view, scene, hdr, resolve, &self.targets.depth_view);
        self.tonemap.record(encoder, timer, &self.targets.ldr_view);
        if let Some(h) = &self.heatmap {
            h.record(encoder, timer, &self.targets.ldr_view);
        }
    }
    fn set_exposure(&self, queue: &wgpu::Queue, exposure: f32) -> Result<(), GpuError> {
        self.tonemap.set_exposure(queue, exposure)
    }
    fn heatmap(&self) -> Option<&HeatmapPass> {
        self.heatmap.as_ref()
    }
    fn targets(&self) -> &DisplayTargets {
        &self.targets
    }
    fn grid(&self) -> TileGrid {
        self.grid
    }
    fn memory(&self) -> &MemoryReport {
        &self.memory
    }
    fn light_grid(&self) -> Option<&LightGrid> {
        self.culling.as_ref().map(|c| &c.grid)
    }
    fn grow_light_grid(&mut self, ctx: &GpuContext, capacity: u32) {
        if let Some(c) = &mut self.culling {
            c.grid.grow(&ctx.device, &ctx.queue, capacity);
            self.shading.rebind(&ctx.device, &c.grid);
            for (category, bytes) in c.grid.memory().entries {
                self.memory.set(&category, bytes);
            }
        }
    }
}
