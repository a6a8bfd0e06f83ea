//! Scene features: one value, computed once per renderer from the scene, the lights and the
//! settings, that decides which passes exist (the plan in tiledlight-frame), which buffers are allocated
//! and which shader variants are compiled. Passes read it; nothing re-derives it from the
//! scene or the light buffers.
//!
//! "Model only what the scene requires": a spot buffer, the spot-cone test, texture bind
//! groups, masked pipelines, multisampled targets, the heat map pass exist only when this
//! value says the scene or the settings need them: blended geometry, shadow casters and
//! VPLs included, each with its passes, buffers and variants only when asked for. Depends on [`crate::scene_gpu`],
//! [`crate::light_buffers`] and [`crate::culling`] (the culling options).

use crate::culling::options::CullOptions;
use crate::knobs::Knobs;
use crate::light_buffers::LightBuffers;
pub use crate::method::{LargeRaster, MethodTraits, Raster};
use crate::scene_gpu::{DrawKind, MaterialFeatures, SceneGpu};
use tiledlight_cull::shadow::ShadowOptions;

/// Shadow-casting lights: the atlas, its pass, the `SHADOWS` shading variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shadows {
    /// Shadow-casting point lights (the first lights).
    pub points: u32,
    /// Shadow-casting spot lights (the first spots).
    pub spots: u32,
    /// Tile size, filter, depth format.
    pub options: ShadowOptions,
}

pub use crate::knobs::BlendMode;

/// What the scene, its lights and the settings require of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Features {
    /// What the passes need to know of the frame's method (`tiledlight_frame::Method`
    /// names it).
    pub method: MethodTraits,
    /// Some lights are spot lights: the spot buffer and the `SPOT_LIGHTS` shading variant.
    pub spot_lights: bool,
    /// Spot cones are culled against tiles (`SPOT_CONE`): asked for and spot lights exist.
    pub spot_cone: bool,
    /// Some material has a texture: group 2 and the `TEXTURES` variants.
    pub textures: bool,
    /// The material paths the drawn materials need (textures per slot, normal maps,
    /// emission, the second UV set): their shader defines, bindings, vertex buffers and
    /// (Tiled Deferred) the G-buffer's emission target.
    pub materials: MaterialFeatures,
    /// The draw kinds (masked / double-sided) the scene has: one pipeline each.
    pub draw_kinds: Vec<DrawKind>,
    /// MSAA samples per pixel (1: none of the multisampled resources exist).
    pub msaa: u32,
    /// Two lists per tile (tiled methods).
    pub half_z: bool,
    /// Two-level culling (the 64x64-pixel cell pass; tiled methods).
    pub coarse: bool,
    /// The view-space AABB test (tiled methods).
    pub aabb: bool,
    /// Tiled Deferred's extra G-buffer targets (the stress knob; 0 otherwise).
    pub extra_targets: u32,
    /// The blended draw kinds (empty: no blended geometry, so no blended depth, lists,
    /// pipelines or layer exist).
    pub blended_kinds: Vec<DrawKind>,
    /// How blended geometry is composited (used only with blended kinds).
    pub blend_mode: BlendMode,
    /// Shadow casters, when some light casts a shadow (None: no atlas, no shadow pass, no
    /// shadow variant).
    pub shadows: Option<Shadows>,
    /// The light grid is clusters of the whole frustum (tiled methods, clustered layout
    /// without the geometry-only option): its lists hold every light of every cluster,
    /// surfaces or not, so blended geometry reads them and needs no depth or lists of its
    /// own.
    pub frustum_clusters: bool,
    /// Virtual point lights (`--vpl`, crate tiledlight-vpl): the RSM and generation step
    /// and the `VPLS` shading variant, in every method.
    pub vpl: bool,
    /// The pass settings ([`crate::knobs`](mod@crate::knobs): early-outs, G-buffer targets, draw order,
    /// raster, edge test): every pass reads its own rows here. `early_outs` false is an
    /// ablation (`--no-early-outs`): every light a list holds is evaluated in full and its
    /// result discarded, as a renderer without them pays; the image is the same (the
    /// `EARLY_OUTS` pipeline constant, `shaders/common/brdf.wgsl`).
    pub knobs: Knobs,
}

impl Features {
    /// The features of `scene` lit by `lights` with `method`, culling options `cull`,
    /// `msaa` samples, the pass settings `knobs` (Tiled Deferred's G-buffer targets among
    /// them), shadows drawn
    /// with `shadow` for the casters `lights` were packed with (blended geometry composited
    /// by the `blend_mode` row), and virtual point lights when `vpl`.
    pub fn new(
        scene: &SceneGpu,
        lights: &LightBuffers,
        method: MethodTraits,
        cull: &CullOptions,
        (msaa, knobs): (u32, Knobs),
        (shadow, vpl): (ShadowOptions, bool),
    ) -> Self {
        let (points, spots) = (lights.packed.shadow_points, lights.packed.shadow_spots);
        let tiled = method.tiled;
        let spot_lights = lights.has_spots();
        Self {
            method,
            spot_lights,
            spot_cone: tiled && cull.spot_cone && spot_lights,
            textures: scene.textures.is_some(),
            materials: scene.material_features,
            draw_kinds: scene.opaque_kinds(),
            blended_kinds: scene.kinds().into_iter().filter(|k| k.blended).collect(),
            blend_mode: knobs.blend_mode,
            msaa,
            half_z: tiled && cull.half_z,
            coarse: tiled && cull.coarse,
            aabb: tiled && cull.aabb,
            extra_targets: if method.gbuffer { knobs.gbuffer_rts.saturating_sub(2) } else { 0 },
            // The traced reference's shadows are rays: its atlas exists only for the VPLs'
            // reflective shadow maps.
            shadows: (points + spots > 0 && (!method.traced || vpl)).then_some(Shadows {
                points,
                spots,
                options: shadow,
            }),
            frustum_clusters: tiled && cull.clusters.is_some_and(|c| !c.geometry_only),
            vpl,
            knobs,
        }
    }

    /// Some draw is alpha-blended: the blended path exists.
    pub fn blended(&self) -> bool {
        !self.blended_kinds.is_empty()
    }

    /// Some draw is alpha-masked (masked pre-pass pipelines).
    pub fn masked(&self) -> bool {
        self.draw_kinds.iter().any(|k| k.masked)
    }

    /// The material defines of the scene's raster passes (`shaders/common/scene.wgsl`):
    /// `TEXTURES`, `MR_TEXTURE`, `NORMAL_MAP`, `OCCLUSION`, `EMISSIVE`, `UV1`; those of
    /// [`crate::variants::MaterialKey::of`] the materials, which the passes' keys hold.
    pub fn material_defines(&self) -> Vec<&'static str> {
        crate::variants::MaterialKey::of(&self.materials).defines()
    }

    /// The pipeline constants of the lighting shaders: the shadow filter's radius when
    /// shadows exist (`SHADOW_RADIUS` is declared only in the `SHADOWS` variant), and
    /// `EARLY_OUTS` false for the early-outs' ablation (declared in every lighting shader;
    /// left at its default otherwise).
    pub fn light_constants(&self) -> Vec<(&'static str, f64)> {
        let mut c: Vec<(&'static str, f64)> =
            self.shadows.map(|s| vec![("SHADOW_RADIUS", s.options.filter.radius() as f64)]).unwrap_or_default();
        if !self.knobs.early_outs {
            c.push(("EARLY_OUTS", 0.0));
        }
        c
    }
}
