//! Scene features: one value, computed once per renderer from the scene, the lights and the
//! settings, that decides which passes exist ([`crate::plan`]), which buffers are allocated
//! and which shader variants are compiled. Passes read it; nothing re-derives it from the
//! scene or the light buffers.
//!
//! "Model only what the scene requires": a spot buffer, the spot-cone test, texture bind
//! groups, masked pipelines, multisampled targets, the heat map pass exist only when this
//! value says the scene or the settings need them: blended geometry, shadow casters and
//! VPLs included, each with its passes, buffers and variants only when asked for. Depends on [`crate::scene_gpu`],
//! [`crate::light_buffers`] and [`crate::culling`] (the culling options).

use crate::context::COMPUTE_RASTER_FEATURES;
use crate::culling::options::CullOptions;
use crate::light_buffers::LightBuffers;
use crate::scene_gpu::{DrawKind, MaterialFeatures, SceneGpu};
use tiledlight_cull::shadow::ShadowOptions;

/// How a frame is lit: the one method type of every crate (settings, renderers, reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Method {
    /// Depth pre-pass, tiled culling, forward shading of each tile's list.
    #[default]
    ForwardPlus,
    /// G-buffer, then one compute pass that culls each tile and shades it.
    TiledDeferred,
    /// Depth and triangle IDs, tiled culling, then one compute pass that rebuilds each
    /// pixel's surface from its triangle and shades it (the visibility buffer).
    Visibility,
    /// Depth pre-pass, then every light for every pixel (the reference). `cutoff: false`
    /// drops the radius window (plain inverse-square).
    BruteForce {
        /// Keep the windowed falloff with its radius cutoff.
        cutoff: bool,
    },
    /// The truth to measure against: the visibility buffer's surface lit by every light
    /// with no cutoff, each light's share multiplied by a shadow ray through the scene's
    /// BVH (no shadow maps). Seconds a frame, not milliseconds. `cutoff: true` keeps the
    /// windowed falloff (the truth with the tiled methods' cutoff: the lab's error split
    /// measures the cutoff's share of a setting's error with it).
    TracedReference {
        /// Keep the windowed falloff with its radius cutoff.
        cutoff: bool,
    },
}

impl Method {
    /// Every method, in the order reports list them.
    pub const ALL: [Method; 7] = [
        Method::ForwardPlus,
        Method::BruteForce { cutoff: true },
        Method::BruteForce { cutoff: false },
        Method::TiledDeferred,
        Method::Visibility,
        Method::TracedReference { cutoff: false },
        Method::TracedReference { cutoff: true },
    ];

    /// The truth the lab measures against: traced, no cutoff.
    pub const TRUTH: Method = Method::TracedReference { cutoff: false };

    /// True for the methods with tiles (culling, light grid, heat map).
    pub fn is_tiled(self) -> bool {
        !matches!(self, Method::BruteForce { .. } | Method::TracedReference { .. })
    }

    /// True for the methods whose surface is the visibility buffer's (its raster).
    pub fn uses_visibility_buffer(self) -> bool {
        matches!(self, Method::Visibility | Method::TracedReference { .. })
    }

    /// True for the traced references (shadow rays through the scene's BVH).
    pub fn is_traced(self) -> bool {
        matches!(self, Method::TracedReference { .. })
    }

    /// True for the references (every light, no tiles): brute force and the traced one.
    pub fn is_reference(self) -> bool {
        !self.is_tiled()
    }

    /// The flag value, for the command line, reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Method::ForwardPlus => "forward-plus",
            Method::BruteForce { cutoff: true } => "brute-force",
            Method::BruteForce { cutoff: false } => "brute-force-no-cutoff",
            Method::TiledDeferred => "deferred",
            Method::Visibility => "visibility",
            Method::TracedReference { cutoff: false } => "traced-reference",
            Method::TracedReference { cutoff: true } => "traced-reference-cutoff",
        }
    }

    /// The name people read (the viewer's panel, charts).
    pub fn label(self) -> &'static str {
        match self {
            Method::ForwardPlus => "Forward+",
            Method::BruteForce { cutoff: true } => "Brute force",
            Method::BruteForce { cutoff: false } => "Brute force, no cutoff",
            Method::TiledDeferred => "Tiled Deferred",
            Method::Visibility => "Visibility buffer",
            Method::TracedReference { cutoff: false } => "Traced reference",
            Method::TracedReference { cutoff: true } => "Traced, with the cutoff",
        }
    }

    /// What the method does, in one line (the command line's help).
    pub fn summary(self) -> &'static str {
        match self {
            Method::ForwardPlus => "Depth pre-pass, tiled light culling, forward shading of each tile's list",
            Method::BruteForce { cutoff: true } => {
                "Every light for every pixel, with the radius cutoff (the reference for culling)"
            }
            Method::BruteForce { cutoff: false } => {
                "Every light for every pixel, plain inverse-square (the reference for the cutoff)"
            }
            Method::TiledDeferred => "G-buffer pass, then one compute pass that culls each tile's lights and shades it",
            Method::Visibility => {
                "Depth and triangle IDs, tiled light culling, then one compute pass that rebuilds each pixel's \
                 surface from its triangle and shades it"
            }
            Method::TracedReference { cutoff: false } => {
                "Every light for every pixel, no cutoff, each shadowed by a ray through the scene's BVH (the truth; \
                 seconds a frame)"
            }
            Method::TracedReference { cutoff: true } => {
                "The traced reference with the radius cutoff (the truth less the cutoff's light: the cutoff's share \
                 of the error)"
            }
        }
    }

    /// The method of flag value `name` ([`Method::name`]).
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
            format!("method {name:?}: use one of {}", names.join(", "))
        })
    }
}

/// `--method` on a command line (feature `clap`): the values are [`Method::name`], their
/// help [`Method::summary`], so a new method needs no second enum.
#[cfg(feature = "clap")]
impl clap::ValueEnum for Method {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()).help(self.summary()))
    }
}

/// Which rasteriser draws the visibility buffer's depth and triangle IDs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Raster {
    /// The faster of the two on this adapter's class, where the compute raster can run:
    /// [`Raster::pick`].
    #[default]
    Auto,
    /// The hardware raster (the depth pre-pass's pipelines writing IDs).
    Hardware,
    /// The compute raster (64-bit atomics; one sample a pixel).
    Compute,
}

impl Raster {
    /// Every value, in the order the command line lists them.
    pub const ALL: [Raster; 3] = [Raster::Auto, Raster::Hardware, Raster::Compute];

    /// The flag value.
    pub fn name(self) -> &'static str {
        match self {
            Raster::Auto => "auto",
            Raster::Hardware => "hardware",
            Raster::Compute => "compute",
        }
    }

    /// What it does, in one line (the command line's help).
    pub fn summary(self) -> &'static str {
        match self {
            Raster::Auto => "The faster on this adapter class where it can run (measured: docs/PERFORMANCE.md)",
            Raster::Hardware => "The hardware raster: depth pre-pass pipelines writing triangle IDs (any MSAA)",
            Raster::Compute => {
                "Compute: 64-bit atomicMax of (depth, ID) per pixel, large triangles and masked materials                  by the hardware (one sample a pixel; needs 64-bit buffer atomics)"
            }
        }
    }

    /// The value of flag value `name`.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
            format!("raster {name:?}: use one of {}", names.join(", "))
        })
    }

    /// [`Raster::Auto`] made concrete for an adapter of `device_type` whose device has
    /// `features`, drawing `msaa` samples: the compute raster where it can run (64-bit
    /// buffer atomics, one sample) and was measured faster (a discrete GPU: the H200,
    /// docs/PERFORMANCE.md), else the hardware raster (lavapipe's compute raster is the
    /// slower there). An explicit choice is kept as it is.
    pub fn pick(self, device_type: wgpu::DeviceType, features: wgpu::Features, msaa: u32) -> Raster {
        let can = features.contains(COMPUTE_RASTER_FEATURES);
        match self {
            Raster::Auto if can && msaa == 1 && device_type == wgpu::DeviceType::DiscreteGpu => Raster::Compute,
            Raster::Auto => Raster::Hardware,
            r => r,
        }
    }
}

/// `--raster` on a command line (feature `clap`).
#[cfg(feature = "clap")]
impl clap::ValueEnum for Raster {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()).help(self.summary()))
    }
}

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

/// How blended geometry is composited.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BlendMode {
    /// Instances sorted back to front each frame and drawn "over" (TiledLighting11's way).
    #[default]
    Sorted,
    /// Weighted blended order-independent transparency (McGuire and Bavoil 2013): no sort,
    /// an approximation of "over" whose error the lab measures against the sorted result.
    WeightedOit,
}

impl BlendMode {
    /// The flag value.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sorted => "sorted",
            Self::WeightedOit => "wboit",
        }
    }
    /// The mode of flag value `name` (`sorted`, `wboit`).
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "sorted" => Ok(Self::Sorted),
            "wboit" => Ok(Self::WeightedOit),
            _ => Err(format!("blend mode {name:?}: use sorted or wboit")),
        }
    }
}

/// What the scene, its lights and the settings require of a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Features {
    /// The method.
    pub method: Method,
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
    /// The shading's early-outs: a light beyond its radius or behind the surface returns
    /// at once (true, the default). False is an ablation (`--no-early-outs`): every light
    /// a list holds is evaluated in full and its result discarded, as a renderer without
    /// them pays; the image is the same (the `EARLY_OUTS` pipeline constant,
    /// `shaders/common/brdf.wgsl`).
    pub early_outs: bool,
}

impl Features {
    /// The features of `scene` lit by `lights` with `method`, culling options `cull`,
    /// `msaa` samples, (Tiled Deferred) `gbuffer_rts` G-buffer targets, shadows drawn
    /// with `shadow` for the casters `lights` were packed with, blended geometry composited
    /// by `blend_mode`, and virtual point lights when `vpl`.
    pub fn new(
        scene: &SceneGpu,
        lights: &LightBuffers,
        method: Method,
        cull: &CullOptions,
        (msaa, gbuffer_rts): (u32, u32),
        (shadow, blend_mode, vpl): (ShadowOptions, BlendMode, bool),
    ) -> Self {
        let (points, spots) = (lights.packed.shadow_points, lights.packed.shadow_spots);
        let tiled = method.is_tiled();
        let spot_lights = lights.has_spots();
        Self {
            method,
            spot_lights,
            spot_cone: tiled && cull.spot_cone && spot_lights,
            textures: scene.textures.is_some(),
            materials: scene.material_features,
            draw_kinds: scene.opaque_kinds(),
            blended_kinds: scene.kinds().into_iter().filter(|k| k.blended).collect(),
            blend_mode,
            msaa,
            half_z: tiled && cull.half_z,
            coarse: tiled && cull.coarse,
            aabb: tiled && cull.aabb,
            extra_targets: if method == Method::TiledDeferred { gbuffer_rts.saturating_sub(2) } else { 0 },
            // The traced reference's shadows are rays: its atlas exists only for the VPLs'
            // reflective shadow maps.
            shadows: (points + spots > 0 && (!method.is_traced() || vpl)).then_some(Shadows {
                points,
                spots,
                options: shadow,
            }),
            frustum_clusters: tiled && cull.clusters.is_some_and(|c| !c.geometry_only),
            vpl,
            early_outs: true,
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
        if !self.early_outs {
            c.push(("EARLY_OUTS", 0.0));
        }
        c
    }

    /// One line of what the frame models, e.g. "Forward+, points+spots, textures, MSAA 4x".
    pub fn describe(&self) -> String {
        let mut parts = vec![match self.method {
            Method::ForwardPlus => "Forward+".to_string(),
            Method::TiledDeferred => "Tiled Deferred".to_string(),
            Method::Visibility => "visibility buffer".to_string(),
            Method::BruteForce { cutoff: true } => "brute force".to_string(),
            Method::BruteForce { cutoff: false } => "brute force, no cutoff".to_string(),
            Method::TracedReference { cutoff: false } => {
                "traced reference (every light, a shadow ray each)".to_string()
            }
            Method::TracedReference { cutoff: true } => {
                "traced reference with the cutoff (every light in range, a shadow ray each)".to_string()
            }
        }];
        parts.push(if self.spot_lights { "points+spots" } else { "points" }.into());
        parts.extend(self.materials.describe().into_iter().map(String::from));
        if self.masked() {
            parts.push("alpha-masked".into());
        }
        if self.msaa > 1 {
            parts.push(format!("MSAA {}x", self.msaa));
        }
        if let Some(s) = &self.shadows {
            parts.push(format!(
                "shadows: {} point + {} spot casters, {}px tiles, {}x{} PCF, {}",
                s.points,
                s.spots,
                s.options.tile_size,
                s.options.filter.size(),
                s.options.filter.size(),
                s.options.format.name()
            ));
        }
        if self.vpl {
            parts.push("virtual point lights".into());
        }
        if self.blended() {
            parts.push(match self.blend_mode {
                BlendMode::Sorted => "alpha-blended geometry (sorted back to front)".into(),
                BlendMode::WeightedOit => "alpha-blended geometry (weighted blended OIT, unsorted)".into(),
            });
        }
        parts.join(", ")
    }
}
