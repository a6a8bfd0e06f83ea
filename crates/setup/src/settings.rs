//! The settings of a run as plain data: where the scene comes from, the lights, the
//! screen, the method and its culling options ([`Settings`]). Checked in one place
//! ([`Settings::validate`], before any file or GPU work, so bad input gives one clear
//! error line instead of a panic deep inside wgpu), and turned into what the renderers
//! take (culling options, Forward+ and Tiled Deferred settings) and into report text.
//!
//! The error texts name the command-line flag of each field (`--width 0: ...`): the app's
//! flags are these fields, and its users read these messages as they are.
//!
//! Pure data, no GPU work and no files: depends on tiledlight-cull, tiledlight-scene
//! (limits, `GridDensity`, `CameraDesc`) and the renderers' settings types
//! (tiledlight-gpu's `CullOptions` and `BlendMode`, tiledlight-forward, tiledlight-deferred).

use std::fmt;
use std::path::PathBuf;

use tiledlight_cull::lists::DEFAULT_CAPACITY;
use tiledlight_cull::shadow::ShadowOptions;
use tiledlight_cull::vpl::VplConfig;
use tiledlight_deferred::shading::workgroup_bytes_besides_lists;
use tiledlight_frame::FrameSettings;
pub use tiledlight_frame::Method;
use tiledlight_gpu::culling::{ClusterOptions, CullOptions, CULL_WORKGROUP_BYTES};
pub use tiledlight_gpu::draw_order::DrawOrderMode;
use tiledlight_gpu::features::BlendMode;
pub use tiledlight_gpu::features::Raster;
pub use tiledlight_gpu::knobs::Knobs;
use tiledlight_scene::{
    surface_irradiance_factor, CameraDesc, GridDensity, SurfaceLightOptions, DEFAULT_LIGHT_THRESHOLD,
    DEFAULT_SURFACE_OFFSET,
};
pub use tiledlight_visibility::compute_raster::{ComputeRasterOptions, LargeRaster};

/// Random point lights of the default scene when [`Settings::lights`] is not given.
pub const DEFAULT_POINT_LIGHTS: u64 = 1024;

/// Point lights of the million-light preset (`--light-preset million`).
pub const MILLION_LIGHTS: u64 = 1_000_000;

/// Mean lights reaching a surface point in the million-light preset: about 100 lights per
/// 16 px tile at 1080p in the courtyard with [`MILLION_LIGHTS`] (the scene crate's
/// estimate test).
pub const DEFAULT_LIGHTS_PER_POINT: f32 = 8.0;

/// Where the random point lights go.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum LightPlacement {
    /// Uniformly inside the scene's bounds, intensities (so radii) spread over a range.
    #[default]
    Bounds,
    /// On the scene's surfaces (area-weighted, lifted along the normal), one radius for
    /// all chosen so that `lights_per_point` lights reach a surface point on average.
    Surfaces {
        /// Target mean lights per surface point (`k`), the `--lights-per-pixel` flag.
        lights_per_point: f32,
    },
}

impl LightPlacement {
    /// Surfaces with the preset's [`DEFAULT_LIGHTS_PER_POINT`].
    pub const SURFACES: LightPlacement = LightPlacement::Surfaces { lights_per_point: DEFAULT_LIGHTS_PER_POINT };

    /// True for [`LightPlacement::Surfaces`].
    pub fn on_surfaces(self) -> bool {
        matches!(self, LightPlacement::Surfaces { .. })
    }
}

/// Linear value the exposure of surface lights maps the mean surface radiance to: about
/// middle grey after the ACES fit and sRGB (0.25 -> 0.35 -> 0.63).
const SURFACE_EXPOSURE_TARGET: f32 = 0.25;

/// Albedo assumed for the mean radiance (the courtyard's materials are about this bright).
const ASSUMED_ALBEDO: f32 = 0.6;

/// A fixed exposure for surface lights that keeps the image readable at any light count:
/// the radius follows the count, so the mean irradiance of a flat surface is
/// `surface_irradiance_factor(offset) * k * threshold` for a white light; the lights'
/// saturated hues average 0.5 per channel, and a Lambert surface of albedo 0.6 sends
/// `albedo / pi` of it back. The exposure maps that mean radiance to 0.25 (middle grey
/// after the ACES fit and sRGB). Not an automatic exposure (it does not look at the image).
pub fn surface_exposure(lights_per_point: f32, threshold: f32) -> f32 {
    let irradiance = surface_irradiance_factor(DEFAULT_SURFACE_OFFSET) * lights_per_point * threshold * 0.5;
    let radiance = ASSUMED_ALBEDO / std::f32::consts::PI * irradiance;
    SURFACE_EXPOSURE_TARGET / radiance
}

/// How the shadow casters of each kind are chosen among the lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CasterChoice {
    /// The brightest: intensity times the largest colour channel.
    #[default]
    Brightness,
    /// The largest contributions to the frame: each light's brightness-weighted arrival
    /// at the surfaces it reaches on screen, estimated on the GPU from a frame's depth and
    /// light grid (`tiledlight_frame::caster_rank`) for the camera when the lights are
    /// made.
    Contribution,
}

impl CasterChoice {
    /// The flag's value: "brightness" or "contribution".
    pub const fn name(self) -> &'static str {
        match self {
            CasterChoice::Brightness => "brightness",
            CasterChoice::Contribution => "contribution",
        }
    }

    /// How a report says it.
    pub fn describe(self) -> &'static str {
        match self {
            CasterChoice::Brightness => "the brightest of each kind",
            CasterChoice::Contribution => "the largest contributors to the frame of each kind",
        }
    }
}

/// Where the scene comes from.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum SceneSource {
    /// The procedural courtyard.
    #[default]
    Default,
    /// The many-material scene (`materials`: [`tiledlight_scene::materials`]), with
    /// [`Settings::materials`] materials.
    Materials,
    /// A glTF file.
    File(PathBuf),
    /// Another engine's benchmark scene, rebuilt (its own lights and camera).
    Peer(PeerScene),
}

/// The other engines' benchmark scenes `--scene` names (tiledlight-scene's `peer`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PeerScene {
    /// Bevy 0.19's `many_lights`: 100,000 lights of 0.3 m range on a 50 m sphere seen
    /// from inside (`--scene bevy-many-lights`).
    BevyManyLights,
}

impl PeerScene {
    /// Every peer scene.
    pub const ALL: [PeerScene; 1] = [PeerScene::BevyManyLights];

    /// The `--scene` value.
    pub fn name(self) -> &'static str {
        match self {
            PeerScene::BevyManyLights => "bevy-many-lights",
        }
    }

    /// The scene, its lights and camera.
    pub fn build(self) -> tiledlight_scene::Scene {
        match self {
            PeerScene::BevyManyLights => tiledlight_scene::peer::bevy_many_lights(),
        }
    }
}

impl SceneSource {
    /// The source a `--scene` value names: `default` or `materials` (any case), a peer
    /// scene's name (`bevy-many-lights`, any case) or a glTF file.
    pub fn parse(value: &str) -> Self {
        if value.eq_ignore_ascii_case("default") {
            SceneSource::Default
        } else if value.eq_ignore_ascii_case("materials") {
            SceneSource::Materials
        } else if let Some(p) = PeerScene::ALL.into_iter().find(|p| value.eq_ignore_ascii_case(p.name())) {
            SceneSource::Peer(p)
        } else {
            SceneSource::File(PathBuf::from(value))
        }
    }
}

impl fmt::Display for SceneSource {
    /// `default` or the file's path, as `--scene` takes it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneSource::Default => f.write_str("default"),
            SceneSource::Materials => f.write_str("materials"),
            SceneSource::File(path) => write!(f, "{}", path.display()),
            SceneSource::Peer(p) => f.write_str(p.name()),
        }
    }
}

/// A camera the user pinned (a bookmark file, already read: parsing it is the caller's).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraBookmark {
    /// The file it was read from, named in the report and in errors.
    pub path: PathBuf,
    /// The camera (its aspect ratio comes from the screen).
    pub camera: CameraDesc,
}

/// Scene, lights, screen and renderer settings of a run: what `render`, `bench`, the lab
/// and the viewer build from. [`Settings::default`] is the default run (the courtyard,
/// 1024 point lights, 1920x1080, Forward+).
///
/// Numbers are wide (u64 light counts) and range-checked in [`Settings::validate`], so
/// an absurd value gets a message naming the flag and its limit.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The procedural courtyard or a glTF file (.gltf or .glb).
    pub scene: SceneSource,
    /// A demo setup dressing the courtyard (its lights, camera and props;
    /// [`crate::demo`]); its flags are the app's business. None: the plain courtyard.
    pub demo: Option<crate::demo::Demo>,
    /// Random point lights [default: 1024 for the default scene; for a glTF file, random
    /// lights are added to its own lights only when this or `spot_lights` is given].
    pub lights: Option<u64>,
    /// Random spot lights [default: 0].
    pub spot_lights: Option<u64>,
    /// Where the random point lights go (spot lights are always placed in the bounds).
    pub placement: LightPlacement,
    /// Seed of the random lights (the same seed gives the same lights).
    pub seed: u64,
    /// Intensity threshold that sets each light's radius: r = sqrt(intensity / T).
    pub threshold: f32,
    /// Grid objects (instanced spheres) added to the default scene, 0 to 280.
    pub grid_objects: u32,
    /// Materials of the many-material scene (`--scene materials`), 1 to 4096.
    pub materials: u32,
    /// Tessellation of the grid objects.
    pub density: GridDensity,
    /// Grid objects drawn as alpha-blended glass spheres, 0 to `grid_objects` (the default
    /// scene only: a glTF file's `BLEND` materials are drawn blended on their own).
    pub transparent_objects: u32,
    /// The default scene's banners glow (emissive materials: the G-buffer's emission
    /// target and the emission path exist); the default scene only.
    pub emissive: bool,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Renderer.
    pub method: Method,
    /// Tile side in pixels: 8, 16 or 32.
    pub tile_size: u32,
    /// Light indices stored per tile list (more are counted as overflow), 1 to 2048.
    /// None: the light count, up to what the GPU's workgroup memory holds (chosen when the
    /// lights are uploaded, see `Prepared`).
    pub capacity: Option<u32>,
    /// A fixed light-grid budget, in (list, light) indices, for the opaque and the blended
    /// grid: the grid never grows, and pairs beyond it are dropped (and reported). None:
    /// sized from the frame's pairs and grown when a frame needs more. Tests force an
    /// overflow with it (`--grid-budget`, a hidden flag).
    pub grid_pairs: Option<u32>,
    /// Also test light spheres against each tile's view-space AABB.
    pub aabb: bool,
    /// Two lists per tile, split at the middle of its depth range.
    pub half_z: bool,
    /// 2.5D culling (Harada 2012): 32 depth bins per tile; a light must meet one holding a
    /// surface. Not with half-z.
    pub depth_mask: bool,
    /// Light-centric assignment: each light scatters itself into the tiles it covers
    /// (same lists; cost ~ lights + pairs instead of lights x tiles).
    pub scatter: bool,
    /// The clustered layout (3D cells, exponential depth slices) instead of screen tiles;
    /// always assigned light-centrically.
    pub clusters: Option<ClusterOptions>,
    /// Also test spot cones against each tile (needs spot lights to matter).
    pub spot_cone: bool,
    /// One-level culling: every tile tests every light (the default first culls per
    /// 64x64-pixel cell, and tiles test only their cell's lights).
    pub flat_cull: bool,
    /// The traced reference submits its frame band by band and reports its progress to the
    /// band reporter (`render` shows it as a bar); off for benchmarks, which time one
    /// submission.
    pub traced_progress: bool,
    /// MSAA samples per pixel: 1 (off), 2, 4 or 8.
    pub msaa: u32,
    /// Exposure before tonemapping.
    pub exposure: f32,
    /// Compute the exposure from each frame's image (log-average luminance;
    /// `tiledlight_cull::exposure`) instead of using `exposure`.
    pub auto_exposure: bool,
    /// Shadow-casting point lights: the brightest point lights of the scene (0: no point
    /// light casts a shadow).
    pub shadow_point_lights: u32,
    /// Shadow-casting spot lights: the brightest spot lights of the scene.
    pub shadow_spot_lights: u32,
    /// How the casters of each kind are chosen (brightest, or by contribution to the frame).
    pub casters_by: CasterChoice,
    /// Virtual point lights from the shadow casters' reflective shadow maps (`--vpl` and
    /// its settings; tiledlight-vpl); None: none of their passes or buffers.
    pub vpl: Option<VplConfig>,
    /// A pinned camera; None: the scene's own camera, else one framing the scene.
    pub camera: Option<CameraBookmark>,
    /// The pass settings, one row each in `tiledlight_gpu::knobs` (early-outs, G-buffer
    /// targets, draw order, the visibility buffer's raster, the MSAA edge test): their
    /// flags, axes, script keys, checks and rebuilds come from the rows.
    pub knobs: Knobs,
    /// Every warning becomes an error: a glTF file that loads only with warnings (a
    /// missing texture, an extension it is drawn without) fails to load.
    pub strict: bool,
    /// Read the buffer and image files a glTF file names wherever they are; off, only
    /// files inside the model's folder are read.
    pub allow_any_path: bool,
}

impl Default for Settings {
    /// The default run (the default scene, 1024 lights, 1920x1080, Forward+).
    fn default() -> Self {
        Self {
            scene: SceneSource::Default,
            demo: None,
            lights: None,
            spot_lights: None,
            placement: LightPlacement::Bounds,
            seed: 1,
            threshold: DEFAULT_LIGHT_THRESHOLD,
            grid_objects: 0,
            materials: tiledlight_scene::materials::DEFAULT_MATERIALS,
            density: GridDensity::Medium,
            transparent_objects: 0,
            emissive: false,
            width: 1920,
            height: 1080,
            method: Method::ForwardPlus,
            tile_size: 16,
            capacity: None,
            grid_pairs: None,
            aabb: false,
            half_z: false,
            depth_mask: false,
            scatter: false,
            clusters: None,
            spot_cone: false,
            flat_cull: false,
            traced_progress: false,
            msaa: 1,
            exposure: 1.0,
            auto_exposure: false,
            shadow_point_lights: 0,
            shadow_spot_lights: 0,
            casters_by: CasterChoice::Brightness,
            vpl: None,
            camera: None,
            knobs: Knobs::default(),
            strict: false,
            allow_any_path: false,
        }
    }
}

/// Every method but the stochastic one reads the shadow casters: the shadow-mapped methods
/// draw them, the traced reference takes its VPLs' reflective shadow maps from them; the
/// stochastic method's rays are its shadows and it has no VPLs. (The run settings' table's
/// caster rows apply to it.)
pub fn reads_casters(m: tiledlight_gpu::method::MethodTraits) -> bool {
    !m.stochastic
}

impl Settings {
    /// Random (point, spot) lights asked for, with the per-scene defaults applied.
    pub fn random_light_counts(&self) -> (u64, u64) {
        match self.scene {
            SceneSource::Default | SceneSource::Materials => {
                (self.lights.unwrap_or(DEFAULT_POINT_LIGHTS), self.spot_lights.unwrap_or(0))
            }
            SceneSource::File(_) | SceneSource::Peer(_) => (self.lights.unwrap_or(0), self.spot_lights.unwrap_or(0)),
        }
    }

    /// The per-list capacity: [`Settings::capacity`], or the one `Prepared` chose for the
    /// scene's light count.
    pub fn capacity(&self) -> u32 {
        self.capacity.unwrap_or(DEFAULT_CAPACITY)
    }

    /// The culling options of these settings.
    pub fn cull_options(&self) -> CullOptions {
        CullOptions {
            tile_size: self.tile_size,
            capacity: self.capacity(),
            aabb: self.aabb,
            half_z: self.half_z,
            spot_cone: self.spot_cone,
            coarse: !self.flat_cull,
            samples: self.msaa,
            grid_pairs: self.grid_pairs,
            depth_mask: self.depth_mask,
            scatter: self.scatter,
            clusters: self.clusters,
        }
    }

    /// Workgroup memory the method's culling kernel needs besides its lists (bytes).
    pub fn reserved_workgroup_bytes(&self) -> u32 {
        match self.method {
            Method::TiledDeferred => workgroup_bytes_besides_lists(self.tile_size, self.msaa),
            _ => CULL_WORKGROUP_BYTES,
        }
    }

    /// The frame renderer's settings (`heatmap` only for a tiled method).
    pub fn frame_settings(&self, heatmap: bool) -> FrameSettings {
        FrameSettings {
            method: self.method,
            cull: self.cull_options(),
            knobs: self.knobs,
            exposure: self.exposure,
            auto_exposure: self.auto_exposure,
            heatmap,
            msaa: self.msaa,
            shadows: self.shadow_options(),
            vpl: self.vpl,
            traced_progress: self.traced_progress,
            ..FrameSettings::default()
        }
    }

    /// Shadow-casting (point, spot) lights: those asked for, none for a method that does
    /// not read casters (the stochastic method: its rays are its shadows; no atlas, no
    /// caster ranking is built for it).
    pub fn shadow_casters(&self) -> (u32, u32) {
        if !reads_casters(self.method.traits()) {
            return (0, 0);
        }
        (self.shadow_point_lights, self.shadow_spot_lights)
    }

    /// True when some light casts a shadow.
    pub fn has_shadows(&self) -> bool {
        self.shadow_casters() != (0, 0)
    }

    /// How shadows are drawn: the shadow rows of the pass settings' table.
    pub fn shadow_options(&self) -> ShadowOptions {
        ShadowOptions {
            tile_size: self.knobs.shadow_size,
            filter: self.knobs.shadow_filter,
            format: self.knobs.shadow_format,
        }
    }

    /// One line of the shadow settings, e.g. "8 point + 4 spot casters (the brightest of
    /// each kind), 256 px tiles, 5x5 PCF, d16"; None when no light casts a shadow.
    pub fn shadow_description(&self) -> Option<String> {
        let asked = (self.shadow_point_lights, self.shadow_spot_lights);
        if !reads_casters(self.method.traits()) && asked != (0, 0) {
            return Some(format!(
                "every light by a ray; the {} point + {} spot casters asked for are not read by the {} method",
                asked.0,
                asked.1,
                self.method.name()
            ));
        }
        self.has_shadows().then(|| {
            format!(
                "{} point + {} spot casters ({}), {}",
                self.shadow_point_lights,
                self.shadow_spot_lights,
                self.casters_by.describe(),
                shadow_options_description(&self.shadow_options())
            )
        })
    }

    /// True when the scene may have blended geometry, as far as the settings know:
    /// transparent grid objects, or a glTF file (whose `BLEND` materials are found when it
    /// loads). The blend mode matters only then.
    pub fn may_blend(&self) -> bool {
        self.transparent_objects > 0 || matches!(self.scene, SceneSource::File(_))
    }

    /// One line on the blended geometry, e.g. "20 transparent grid objects (glass), sorted
    /// back to front"; None when there is none (no transparent objects and
    /// `scene_has_blend` false: the loaded scene has no blended material).
    pub fn blend_description(&self, scene_has_blend: bool) -> Option<String> {
        if self.transparent_objects == 0 && !scene_has_blend {
            return None;
        }
        let what = if self.transparent_objects > 0 {
            let s = if self.transparent_objects == 1 { "" } else { "s" };
            format!("{} transparent grid object{s} (glass)", self.transparent_objects)
        } else {
            "the scene's blended materials".to_string()
        };
        Some(format!("{what}, {}", blend_mode_description(self.knobs.blend_mode)))
    }

    /// The options of the surface lights, None unless they are placed on surfaces (the
    /// count is the settings' random point lights, at most [`MAX_LIGHTS`](tiledlight_scene::MAX_LIGHTS)).
    pub fn surface_light_options(&self) -> Option<SurfaceLightOptions> {
        let LightPlacement::Surfaces { lights_per_point } = self.placement else {
            return None;
        };
        Some(SurfaceLightOptions {
            count: u32::try_from(self.random_light_counts().0).unwrap_or(u32::MAX),
            lights_per_point,
            seed: self.seed,
            threshold: self.threshold,
            offset: DEFAULT_SURFACE_OFFSET,
        })
    }

    /// One line of the culling options, e.g. "16 px tiles, capacity 512, tests: planes+aabb".
    pub fn culling_description(&self) -> String {
        let mut tests = String::from("planes");
        if self.aabb {
            tests.push_str("+aabb");
        }
        if self.spot_cone {
            tests.push_str("+spot-cone");
        }
        if self.half_z {
            tests.push_str(", half-z (2 lists per tile)");
        }
        if self.depth_mask {
            tests.push_str(", 2.5D (32 depth bins per tile)");
        }
        if let Some(c) = &self.clusters {
            let only = if c.geometry_only { ", only clusters holding geometry" } else { "" };
            return format!(
                "clusters: {} px tiles x {} depth slices (first to {} m, exponential to {} m{only}), \
                 assigned light-centrically, tests: sphere vs cluster planes and slices",
                c.tile_size, c.slices, c.first, c.last
            );
        }
        let levels = if self.scatter {
            "assigned light-centrically (each light scatters into its tiles)"
        } else if self.flat_cull {
            "one level"
        } else {
            "two levels (64 px cells, then tiles)"
        };
        format!("{} px tiles, capacity {}, {levels}, tests: {tests}", self.tile_size, self.capacity())
    }
}

/// "sorted back to front" or "weighted blended OIT (unsorted)", with the flag value.
pub fn blend_mode_description(mode: BlendMode) -> String {
    let how = match mode {
        BlendMode::Sorted => "sorted back to front",
        BlendMode::WeightedOit => "weighted blended OIT (unsorted, approximate)",
    };
    format!("{how}, --blend-mode {}", mode.name())
}

/// "256 px tiles, 5x5 PCF, d16" (1x1 is "1 tap").
pub fn shadow_options_description(o: &ShadowOptions) -> String {
    let filter = match o.filter.size() {
        1 => "1 tap".to_string(),
        n => format!("{n}x{n} PCF"),
    };
    format!("{} px tiles, {filter}, {}", o.tile_size, o.format.name())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat};

    fn small() -> Settings {
        Settings { width: 64, height: 36, ..Settings::default() }
    }

    fn err(s: Settings) -> String {
        format!("{:#}", s.validate().unwrap_err())
    }

    fn file(name: &str) -> SceneSource {
        SceneSource::File(name.into())
    }

    #[test]
    fn material_counts_are_checked_and_only_for_the_materials_scene() {
        let materials = |n| Settings { scene: SceneSource::Materials, materials: n, ..small() };
        assert!(materials(512).validate().is_ok());
        assert!(err(materials(0)).contains("--materials 0: must be between 1 and 4096"));
        assert!(err(materials(4097)).contains("--materials 4097"));
        let courtyard = Settings { materials: 16, ..small() };
        assert!(err(courtyard).contains("--materials 16: only the many-material scene has them"));
        assert!(err(Settings { grid_objects: 4, ..materials(16) }).contains("--scene materials has its boxes"));
        assert_eq!(SceneSource::parse("Materials"), SceneSource::Materials);
        assert_eq!(SceneSource::Materials.to_string(), "materials");
    }

    #[test]
    fn defaults_are_valid() {
        Settings::default().validate().unwrap();
        assert_eq!(Settings::default().random_light_counts(), (1024, 0));
    }

    #[test]
    fn vpls_need_casters_and_valid_settings() {
        let vpl = Some(VplConfig::default());
        assert!(err(Settings { vpl, ..small() }).contains("--shadow-spot-lights"));
        let casters = Settings { spot_lights: Some(4), shadow_spot_lights: 2, ..small() };
        Settings { vpl, ..casters.clone() }.validate().unwrap();
        let bad = Some(VplConfig { block: 3, ..VplConfig::default() });
        let e = err(Settings { vpl: bad, ..casters.clone() });
        assert!(e.contains("--vpl") && e.contains("block 3"), "{e}");
        assert_eq!(Settings { vpl, ..casters }.frame_settings(false).vpl, vpl);
    }

    #[test]
    fn bad_settings_name_the_flag() {
        assert!(err(Settings { width: 0, ..small() }).contains("--width 0"));
        assert!(err(Settings { height: 20000, ..small() }).contains("--height 20000"));
        assert!(err(Settings { tile_size: 7, ..small() }).contains("--tile-size 7"));
        assert!(err(Settings { capacity: Some(0), ..small() }).contains("--capacity 0"));
        assert!(err(Settings { lights: Some(99_999_999), ..small() }).contains("--lights 99999999"));
        let both = Settings { lights: Some(tiledlight_scene::MAX_LIGHTS), spot_lights: Some(1), ..small() };
        assert!(err(both).contains("in total"));
        assert!(err(Settings { threshold: f32::NAN, ..small() }).contains("--threshold"));
        assert!(err(Settings { threshold: 0.0, ..small() }).contains("--threshold"));
        assert!(err(Settings { exposure: -1.0, ..small() }).contains("--exposure"));
        assert!(err(Settings { grid_objects: 281, ..small() }).contains("--grid-objects 281"));
        assert_eq!(
            err(Settings { grid_objects: 10, transparent_objects: 11, ..small() }),
            "--transparent-objects 11: must be between 0 and the grid objects (--grid-objects 10)"
        );
        assert!(err(Settings { transparent_objects: 1, ..small() }).contains("(--grid-objects 0)"));
        let glass_on_file = Settings { scene: file("x.glb"), transparent_objects: 2, ..small() };
        assert!(err(glass_on_file)
            .starts_with("--transparent-objects 2: transparent grid objects exist only in the default scene"));
        Settings { grid_objects: 280, transparent_objects: 280, ..small() }.validate().unwrap();
        assert!(err(Settings { scene: file("x.obj"), ..small() }).contains("--scene x.obj"));
        let grid_on_file = Settings { scene: file("x.glb"), grid_objects: 3, ..small() };
        assert!(err(grid_on_file).contains("default scene"));
        assert!(err(Settings { msaa: 3, ..small() }).contains("--msaa 3"));
        // The stochastic method's one sample a pixel, refused from the settings alone.
        let stochastic = || Settings { method: Method::Stochastic, ..small() };
        stochastic().validate().unwrap();
        assert!(err(Settings { msaa: 4, ..stochastic() })
            .starts_with("--method stochastic shades one sample a pixel: --msaa 4"));
        Settings { msaa: 4, ..small() }.validate().unwrap();
        // Casters asked of the stochastic method are not read (no atlas, no ranking), and
        // its description says so; the same for a shadow-mapped method are.
        let casters = Settings { shadow_point_lights: 4, ..stochastic() };
        assert_eq!((casters.shadow_casters(), casters.has_shadows()), ((0, 0), false));
        assert_eq!(
            casters.shadow_description().unwrap(),
            "every light by a ray; the 4 point + 0 spot casters asked for are not read by the stochastic method"
        );
        assert_eq!(stochastic().shadow_description(), None);
        let mapped = Settings { shadow_point_lights: 4, ..small() };
        assert_eq!(mapped.shadow_casters(), (4, 0));
        assert!(mapped.shadow_description().unwrap().starts_with("4 point + 0 spot casters"));
        let with_vpls = Settings { vpl: Some(VplConfig::default()), ..stochastic() };
        assert!(err(with_vpls).starts_with("--method stochastic does not sample VPLs yet"));
        assert!(err(Settings { knobs: Knobs { gbuffer_rts: 6, ..Knobs::default() }, ..small() })
            .contains("--gbuffer-rts 6"));
        let tiny_tiles = Knobs { shadow_size: 100, ..Knobs::default() };
        assert!(err(Settings { knobs: tiny_tiles, ..small() }).contains("--shadow-size 100: must be between 128"));
        let casters = Settings { lights: Some(4), shadow_point_lights: 5, ..small() };
        assert_eq!(err(casters), "--shadow-point-lights 5: more than the scene's 4 point lights (--lights 4)");
        let spots = Settings { spot_lights: Some(2), shadow_spot_lights: 3, ..small() };
        assert!(err(spots).contains("--shadow-spot-lights 3: more than the scene's 2 spot lights"));
        // A glTF file's own lights are unknown here: the upload checks its casters.
        Settings { scene: file("a.glb"), shadow_point_lights: 5, ..small() }.validate().unwrap();
        Settings { spot_lights: Some(2), shadow_spot_lights: 2, shadow_point_lights: 1024, ..small() }
            .validate()
            .unwrap();
        // Refused for 8 GiB of "lists x capacity" before the light grid; fine now.
        let huge = Settings { width: 16384, height: 16384, tile_size: 8, capacity: Some(2048), ..small() };
        huge.validate().unwrap();
    }

    #[test]
    fn surface_placement_is_checked_and_exposed() {
        for k in [0.0, -2.0, f32::NAN] {
            let s = Settings { placement: LightPlacement::Surfaces { lights_per_point: k }, ..small() };
            assert!(err(s).starts_with("--lights-per-pixel"), "k {k}");
        }
        assert_eq!(small().surface_light_options(), None);
        let s = Settings { placement: LightPlacement::SURFACES, lights: Some(MILLION_LIGHTS), seed: 3, ..small() };
        s.validate().unwrap();
        let o = s.surface_light_options().unwrap();
        assert_eq!((o.count, o.lights_per_point, o.seed), (1_000_000, DEFAULT_LIGHTS_PER_POINT, 3));
        // The exposure falls as the expected irradiance (k * threshold) grows.
        let e = surface_exposure(DEFAULT_LIGHTS_PER_POINT, DEFAULT_LIGHT_THRESHOLD);
        assert!(e.is_finite() && e > 0.0);
        assert!((surface_exposure(2.0 * DEFAULT_LIGHTS_PER_POINT, DEFAULT_LIGHT_THRESHOLD) - e / 2.0).abs() < 1e-4 * e);
    }

    #[test]
    fn gltf_gets_random_lights_only_when_asked() {
        let s = Settings { scene: file("a.gltf"), ..small() };
        assert_eq!(s.random_light_counts(), (0, 0));
        let s = Settings { scene: file("a.gltf"), spot_lights: Some(5), ..small() };
        assert_eq!(s.random_light_counts(), (0, 5));
    }

    #[test]
    fn scene_source_round_trips_through_its_text() {
        assert_eq!(SceneSource::parse("Default"), SceneSource::Default);
        assert_eq!(SceneSource::parse("a/b.glb"), file("a/b.glb"));
        assert_eq!(SceneSource::parse("a/b.glb").to_string(), "a/b.glb");
        assert_eq!(SceneSource::Default.to_string(), "default");
    }

    #[test]
    fn renderer_settings_follow_the_settings() {
        let s = Settings {
            method: Method::BruteForce { cutoff: false },
            capacity: Some(99),
            half_z: true,
            flat_cull: true,
            msaa: 4,
            ..small()
        };
        let f = s.frame_settings(false);
        assert_eq!(f.method, Method::BruteForce { cutoff: false });
        assert_eq!((f.cull.capacity, f.cull.half_z, f.cull.coarse, f.cull.samples, f.msaa), (99, true, false, 4, 4));
        let knobs = Knobs { gbuffer_rts: 4, edge_distance: 0.5, ..Knobs::default() };
        let d = Settings { knobs, ..s.clone() }.frame_settings(true);
        assert_eq!((d.knobs, d.heatmap), (knobs, true));
        assert_eq!(
            Settings { aabb: true, ..s }.culling_description(),
            "16 px tiles, capacity 99, one level, tests: planes+aabb, half-z (2 lists per tile)"
        );
        assert_eq!((f.shadows, d.shadows), (ShadowOptions::default(), ShadowOptions::default()));
        let shadow_knobs = Knobs {
            shadow_size: 512,
            shadow_filter: ShadowFilter::Pcf3,
            shadow_format: ShadowFormat::Depth32,
            ..Knobs::default()
        };
        let sh = Settings { knobs: shadow_knobs, ..small() };
        let want = ShadowOptions { tile_size: 512, filter: ShadowFilter::Pcf3, format: ShadowFormat::Depth32 };
        assert_eq!((sh.frame_settings(false).shadows, sh.frame_settings(false).shadows), (want, want));
        // Shadows are mentioned only when some light casts one.
        assert_eq!(sh.shadow_description(), None);
        let one = Settings {
            shadow_spot_lights: 1,
            knobs: Knobs { shadow_filter: ShadowFilter::Tap1, ..shadow_knobs },
            ..sh
        };
        assert_eq!(
            one.shadow_description().unwrap(),
            "0 point + 1 spot casters (the brightest of each kind), 512 px tiles, 1 tap, d32"
        );
        // The blend mode reaches both renderers; blended geometry is mentioned only when used.
        assert_eq!((f.knobs.blend_mode, d.knobs.blend_mode), (BlendMode::Sorted, BlendMode::Sorted));
        let oit = Settings { knobs: Knobs { blend_mode: BlendMode::WeightedOit, ..Knobs::default() }, ..small() };
        assert_eq!(
            (oit.frame_settings(false).knobs.blend_mode, oit.frame_settings(true).knobs.blend_mode),
            (BlendMode::WeightedOit, BlendMode::WeightedOit)
        );
        assert_eq!(oit.blend_description(false), None);
        assert!(!oit.may_blend());
        let glass = Settings { grid_objects: 50, transparent_objects: 20, ..oit.clone() };
        assert!(glass.may_blend());
        assert_eq!(
            glass.blend_description(true).unwrap(),
            "20 transparent grid objects (glass), weighted blended OIT (unsorted, approximate), --blend-mode wboit"
        );
        let gltf = Settings { scene: file("a.glb"), ..small() };
        assert!(gltf.may_blend());
        assert_eq!(gltf.blend_description(false), None);
        assert_eq!(
            gltf.blend_description(true).unwrap(),
            "the scene's blended materials, sorted back to front, --blend-mode sorted"
        );
        let tiled: Vec<&str> = Method::ALL.iter().filter(|m| m.is_tiled()).map(|m| m.name()).collect();
        assert_eq!(tiled, ["forward-plus", "deferred", "visibility", "stochastic"]);
    }
}
