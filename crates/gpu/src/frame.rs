//! The half of a frame both methods share, built once per renderer ([`FrameCommon`]): the
//! features and the frame plan, the MSAA and texture-size checks, the views, the lighting
//! uniform, the display targets, the tonemap pass and the memory report of the scene,
//! lights and targets. Each method adds its own passes (and the heat map over its light
//! grid) and records the plan's steps. Depends on the rest of this crate; no module it uses
//! depends on it.

use glam::Vec3;
use tiledlight_cull::shadow::AtlasLayout;
use tiledlight_cull::{Camera, TileGrid};

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::features::Features;
use crate::lights_gpu::LightBuffers;
use crate::memory::MemoryReport;
use crate::plan::FramePlan;
use crate::scene_gpu::SceneGpu;
use crate::shadow_atlas::ShadowAtlas;
use crate::targets::{check_msaa, DisplayTargets};
use crate::tonemap::TonemapPass;
use crate::view::{ViewUniforms, Views, MAIN_VIEW};

/// What a renderer needs besides its features to build the shared half.
#[derive(Clone, Copy, Debug)]
pub struct CommonSettings<'a> {
    /// Label prefix of the targets ("forward", "deferred").
    pub prefix: &'a str,
    /// Screen size in pixels.
    pub size: (u32, u32),
    /// Tile side (the grid of tiled methods; also sizes nothing for brute force).
    pub tile_size: u32,
    /// Formats the method renders multisampled (checked against the adapter's MSAA support).
    pub msaa_formats: &'a [wgpu::TextureFormat],
    /// How the method writes the HDR image (render attachment or storage).
    pub hdr_usage: wgpu::TextureUsages,
    /// Exposure before tonemapping.
    pub exposure: f32,
    /// The exposure is computed from each frame's image (`exposure` unused).
    pub auto_exposure: bool,
    /// Ambient radiance (times base colour).
    pub ambient: Vec3,
}

/// The shared half of a renderer.
pub struct FrameCommon {
    /// What the scene and the settings require.
    pub features: Features,
    /// The frame's steps, in order.
    pub plan: FramePlan,
    /// The tiling of the screen.
    pub grid: TileGrid,
    /// The views (slot [`MAIN_VIEW`]: the camera).
    pub views: Views,
    /// The `Lighting` uniform (light counts, ambient).
    pub lighting: wgpu::Buffer,
    /// Depth, HDR and display images.
    pub targets: DisplayTargets,
    /// HDR to display.
    pub tonemap: TonemapPass,
    /// The shadow atlas (only when some light casts a shadow); its faces are view slots
    /// after [`MAIN_VIEW`].
    pub shadows: Option<ShadowAtlas>,
    /// Scene, lights and targets; the method adds its own.
    pub memory: MemoryReport,
}

impl FrameCommon {
    /// Checks the MSAA sample count and the screen size, then builds the shared resources.
    pub fn new(
        ctx: &GpuContext,
        scene: &SceneGpu,
        lights: &LightBuffers,
        features: Features,
        s: CommonSettings<'_>,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        check_msaa(ctx, features.msaa, s.msaa_formats)?;
        let (width, height) = s.size;
        let max_side = device.limits().max_texture_dimension_2d;
        if width > max_side || height > max_side {
            return Err(GpuError::Limit {
                what: format!("a {width}x{height} screen"),
                name: "max_texture_dimension_2d",
                limit: max_side.into(),
                asked: format!("{} pixels", width.max(height)),
            });
        }
        let grid = TileGrid::new(width, height, s.tile_size)?;
        let limits = device.limits();
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
        let mut lighting_u = lights.lighting_uniforms(s.ambient);
        if let Some(a) = &shadows {
            let (texel, tile) = a.texel_and_tile_uv();
            lighting_u.shadow_texel_uv = texel;
            lighting_u.shadow_tile_uv = tile;
            lighting_u.shadow_depth_bias = a.options.format.depth_bias();
        }
        let lighting = LightBuffers::upload_lighting(device, &lighting_u);
        let targets = DisplayTargets::new(device, s.prefix, s.size, features.msaa, s.hdr_usage);
        let tonemap = TonemapPass::new(device, &targets.hdr_view, s.size, (s.exposure, s.auto_exposure))?;
        let mut memory = MemoryReport::default();
        memory.extend(&scene.memory);
        memory.extend(&lights.memory);
        memory.add("targets (depth+hdr+ldr)", targets.bytes());
        if let Some(a) = &shadows {
            memory.extend(&a.memory);
        }
        let plan = FramePlan::new(&features);
        Ok(Self { features, plan, grid, views, lighting, targets, tonemap, shadows, memory })
    }

    /// The blended-geometry path over this frame's views, grid, lighting, opaque depth and
    /// shadows, when the scene has blended geometry (both methods build it alike).
    pub fn blended_path(
        &self,
        device: &wgpu::Device,
        scene: &SceneGpu,
        lights: &LightBuffers,
        cull: crate::culling::CullOptions,
        frame_grid: Option<&crate::light_grid::LightGrid>,
    ) -> Result<Option<crate::blended::BlendedPath>, GpuError> {
        if !self.features.blended() {
            return Ok(None);
        }
        let inputs = crate::blended::BlendedInputs {
            views: &self.views,
            scene,
            lights: (lights, &self.lighting),
            features: &self.features,
            cull: (self.grid, cull),
            opaque_depth: &self.targets.depth_view,
            shadows: self.shadows.as_ref(),
            frame_grid,
        };
        crate::blended::BlendedPath::new(device, inputs).map(Some)
    }

    /// Draws the shadow faces of the casters that moved (the plan's `ShadowMaps` step).
    pub fn record_shadows(&self, encoder: &mut wgpu::CommandEncoder, timer: &crate::timer::GpuTimer, scene: &SceneGpu) {
        if let Some(a) = &self.shadows {
            a.record(encoder, timer, &self.views, scene);
        }
    }

    /// Takes the lights' current positions (after they moved): the shadow faces of casters
    /// that moved are drawn by the next frame. Nothing without shadows.
    pub fn lights_moved(
        &self,
        queue: &wgpu::Queue,
        lights: &tiledlight_cull::light::PackedLights,
    ) -> Result<(), GpuError> {
        match &self.shadows {
            Some(a) => a.update(queue, &self.views, lights),
            None => Ok(()),
        }
    }

    /// Writes the main view's uniforms for `camera`.
    pub fn write_view(&self, queue: &wgpu::Queue, camera: &Camera) {
        self.views.write(queue, MAIN_VIEW, &ViewUniforms::new(camera, self.grid.width, self.grid.height));
    }

    /// The main view, as the passes' `record` take it.
    pub fn main_view(&self) -> (&Views, u32) {
        (&self.views, MAIN_VIEW)
    }
}
