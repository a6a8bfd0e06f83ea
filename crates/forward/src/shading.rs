//! The forward shading pass: re-draws the scene with depth test Equal against the pre-pass
//! and, per fragment, sums the lights of its tile list (Forward+) or every light (the
//! brute-force reference) with the shared BRDF into the `Rgba16Float` target. Shader
//! variants are chosen from what the scene has (spot lights, the material paths of
//! `tiledlight_gpu::scene_gpu::MaterialFeatures`) and the settings
//! (half-z, brute force, no cutoff), so unused features cost no code and no buffers.
//! Bind groups: 0 view, 1 scene, 2 material texture (textured scenes only), 3 lights.
//! Depends on tiledlight-gpu.

use tiledlight_gpu::bindings::{create_layout, PassBindings, PassGroup};
use tiledlight_gpu::culling::LightCulling;
use tiledlight_gpu::depth_prepass::DEPTH_FORMAT;
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::lights_group::{LightingInputs, LightsGroup, LIGHTS_GROUP};
use tiledlight_gpu::recording::Recording;
use tiledlight_gpu::scene_gpu::{SceneGpu, SCENE_GROUPS};
use tiledlight_gpu::scene_raster::{begin_pass, cleared, DepthUse, RasterTargets, SceneRaster};
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::util::keyed_module;
use tiledlight_gpu::variants::{ForwardKey, LightLoopKey, MaterialKey, ShaderKey, Shadowing};
use tiledlight_gpu::GpuError;

/// Which lights each fragment loops over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightLoop {
    /// Its tile's culled list (Forward+).
    Tiled {
        /// Two lists per tile; the fragment picks its half.
        half_z: bool,
    },
    /// Every light (reference).
    All {
        /// Windowed falloff with the radius cutoff (as the tiled methods) or plain 1/d^2.
        cutoff: bool,
    },
}

/// The bindings of the shading pass (`shaders/forward.wgsl`, Forward+ over tile lists): the
/// scene's groups 0 to 2, then group 3, the lights ([`LIGHTS_GROUP`], declared once for
/// every forward shading entry in `shaders/common/lights_group.wgsl`).
pub const FORWARD_BINDINGS: PassBindings = PassBindings {
    entry: "forward.wgsl",
    source: file!(),
    groups: &[SCENE_GROUPS[0], SCENE_GROUPS[1], SCENE_GROUPS[2], PassGroup::new(3, LIGHTS_GROUP)],
};

/// [`FORWARD_BINDINGS`] for the Forward+ entry over clusters (`shaders/forward_clustered.wgsl`).
pub const FORWARD_CLUSTERED_BINDINGS: PassBindings =
    PassBindings { entry: "forward_clustered.wgsl", ..FORWARD_BINDINGS };

/// [`FORWARD_BINDINGS`] for the brute-force reference's entry (`shaders/brute_force.wgsl`).
pub const BRUTE_FORCE_BINDINGS: PassBindings = PassBindings { entry: "brute_force.wgsl", ..FORWARD_BINDINGS };

/// The shading pass's pipelines and light bind group.
pub struct ShadingPass {
    /// Pipelines per draw kind and the scene's groups 0-2.
    raster: SceneRaster,
    /// Group 3: the lights, the light grid, the shadow atlas.
    lights: LightsGroup,
    label: &'static str,
}

impl ShadingPass {
    /// Builds one pipeline per draw kind of `scene`. `culling` must be given for
    /// [`LightLoop::Tiled`], `vpls` exactly when the features have VPLs.
    pub fn new(
        inputs: &LightingInputs<'_>,
        scene: &SceneGpu,
        culling: Option<&LightCulling>,
        light_loop: LightLoop,
    ) -> Result<Self, GpuError> {
        let LightingInputs { device, views, lights, lighting, features, atlas, vpls } = *inputs;
        let vpls = vpls.cloned();
        let samples = features.msaa;
        if features.vpl != vpls.is_some() {
            return Err(GpuError::Config("the VPL buffers must be given exactly when the features have VPLs".into()));
        }
        if vpls.as_ref().is_some_and(|v| v.lists.is_some() != matches!(light_loop, LightLoop::Tiled { .. })) {
            return Err(GpuError::Config("the VPLs' light grid must be given exactly to tiled shading".into()));
        }
        let shadowing = Shadowing::of(features.shadows.is_some(), features.vpl)
            .ok_or_else(|| GpuError::Config("VPLs need shadow casters".into()))?;
        let (lights_key, label) = match light_loop {
            LightLoop::Tiled { half_z } => {
                let c = culling.ok_or_else(|| GpuError::Config("tiled shading needs the culling pass".into()))?;
                if c.options.half_z != half_z {
                    return Err(GpuError::Config("half-z must match between culling and shading".into()));
                }
                let key = if c.options.clusters.is_some() {
                    LightLoopKey::Clusters
                } else {
                    LightLoopKey::TileLists { half_z }
                };
                (key, "forward.shade")
            }
            LightLoop::All { cutoff } => {
                let n = lights.packed.len();
                let what = format!("brute force's loop over {n} lights");
                tiledlight_gpu::error::check_cpu_loop_limit(device, n as u64, &what)?;
                (LightLoopKey::Every { cutoff }, "brute_force.shade")
            }
        };
        let key = ForwardKey {
            spots: features.spot_lights,
            shadowing,
            materials: MaterialKey::of(&features.materials),
            lights: lights_key,
            alpha_mask: false,
        };
        let defines = key.defines();
        let lights_layout = create_layout(device, "shade.lights_layout", FORWARD_BINDINGS.group(3), &defines);
        if features.shadows.is_some() != atlas.is_some() {
            return Err(GpuError::Config("the shadow atlas must exist exactly when the features have shadows".into()));
        }
        // The tile ranges are bound only for half-z lookups (light-centric assignment keeps
        // them for every layout).
        let half_z = matches!(light_loop, LightLoop::Tiled { half_z: true });
        let grid = culling.map(|c| (&c.grid, half_z));
        let lights_group = LightsGroup::new(
            device,
            (lights_layout, "shade.lights"),
            (lights, lighting),
            lights.has_spots(),
            atlas,
            grid,
            vpls,
        );
        let target =
            [Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })];
        let raster = SceneRaster::materials(
            device,
            label,
            (views, scene),
            &[lights_group.layout()],
            &features.draw_kinds,
            |kind| keyed_module(device, &ForwardKey { alpha_mask: kind.masked, ..key }),
            &RasterTargets {
                depth: DepthUse::Equal,
                depth_format: DEPTH_FORMAT,
                samples,
                fragment: ("fs_main", &target),
                constants: &features.light_constants(),
            },
        )?;
        Ok(Self { raster, lights: lights_group, label })
    }

    /// The pipeline constants its pipelines were built with (tests: a setting that must
    /// not change the image took effect).
    pub fn constants(&self) -> &[(String, f64)] {
        self.raster.constants()
    }

    /// Binds the light grid again after it grew (its index buffer is a new one).
    pub fn rebind(&mut self, device: &wgpu::Device, grid: &LightGrid) {
        self.lights.rebind(device, grid);
    }

    /// Shades into `hdr` (cleared to black) using the pre-pass `depth`; with MSAA `hdr` is
    /// the multisampled target, resolved into `resolve` and then discarded.
    pub fn record(
        &self,
        r: &mut Recording<'_>,
        hdr: &wgpu::TextureView,
        resolve: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let t = timer.begin(self.label, encoder);
        {
            let hdr = cleared(hdr, resolve, wgpu::Color::BLACK);
            let mut pass = begin_pass(encoder, self.label, &[hdr], (depth, wgpu::LoadOp::Load), t.render_writes());
            self.raster.bind(&mut pass, Some((views, view)), scene);
            pass.set_bind_group(3, &self.lights.group, &[]);
            self.raster.draw(&mut pass, scene, None, None);
        }
        timer.end(encoder, t);
    }
}
