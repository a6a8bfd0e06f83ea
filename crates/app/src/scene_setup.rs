//! The flags `render`, `bench`, `sweep`, `accuracy` and `view` share ([`SceneArgs`]: scene,
//! lights, screen and renderer) and their conversion into the library's plain settings
//! ([`SceneArgs::settings`]); what is built from them is tiledlight-setup's. Also the small
//! PNG output helpers the subcommands use.
//!
//! May depend on tiledlight-setup, tiledlight-scene, tiledlight-deferred (flag defaults),
//! tiledlight-gpu (the pass settings' table) and tiledlight-setup (its `bookmark` file format); the subcommand modules depend on it.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use tiledlight_gpu::culling::ClusterOptions;
use tiledlight_gpu::knobs::KnobArgs;
use tiledlight_lab::axes::{on_off, Flags};
use tiledlight_scene::{GridDensity, DEFAULT_LIGHT_THRESHOLD};
use tiledlight_setup::bookmark;
use tiledlight_setup::{
    surface_exposure, CameraBookmark, CasterChoice, LightPlacement, Method, SceneSource, Settings,
    DEFAULT_LIGHTS_PER_POINT, MILLION_LIGHTS,
};

/// Tessellation of the default scene's grid objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DensityArg {
    /// 484 triangles per object.
    Low,
    /// 1764 triangles per object.
    Medium,
    /// 3600 triangles per object.
    High,
}

impl From<DensityArg> for GridDensity {
    fn from(d: DensityArg) -> Self {
        match d {
            DensityArg::Low => GridDensity::Low,
            DensityArg::Medium => GridDensity::Medium,
            DensityArg::High => GridDensity::High,
        }
    }
}

impl From<GridDensity> for DensityArg {
    fn from(d: GridDensity) -> Self {
        match d {
            GridDensity::Low => DensityArg::Low,
            GridDensity::Medium => DensityArg::Medium,
            GridDensity::High => DensityArg::High,
        }
    }
}

/// How the shadow casters of each kind are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CastersByArg {
    /// The brightest (intensity times the largest colour channel).
    Brightness,
    /// The largest contributions to the frame: each light's arrival at the surfaces it
    /// reaches on screen, estimated on the GPU from one frame's depth and light grid.
    Contribution,
}

impl From<CastersByArg> for CasterChoice {
    fn from(c: CastersByArg) -> Self {
        match c {
            CastersByArg::Brightness => CasterChoice::Brightness,
            CastersByArg::Contribution => CasterChoice::Contribution,
        }
    }
}

impl From<CasterChoice> for CastersByArg {
    fn from(c: CasterChoice) -> Self {
        match c {
            CasterChoice::Brightness => CastersByArg::Brightness,
            CasterChoice::Contribution => CastersByArg::Contribution,
        }
    }
}

/// The light grid's layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GridArg {
    /// One list per screen tile (TiledLighting11).
    Tiled,
    /// Two lists per tile, split at the middle of its depth range (TiledLighting11's half-z).
    HalfZ,
    /// One list per tile, lights tested against 32 depth bins of the tile that hold a
    /// surface (Harada 2012).
    #[value(name = "2.5d")]
    DepthMask,
    /// 3D clusters: tiles x exponential depth slices (Olsson 2012), assigned light-centrically.
    Clustered,
}

impl GridArg {
    /// Every layout with the label the viewer shows.
    pub const ALL: [(GridArg, &'static str); 4] = [
        (GridArg::Tiled, "tiles"),
        (GridArg::HalfZ, "half-z (two lists per tile)"),
        (GridArg::DepthMask, "2.5D (32 depth bins per tile)"),
        (GridArg::Clustered, "clusters (exponential depth slices)"),
    ];

    /// Sets `settings` to this layout (clusters keep their options, or get the defaults).
    pub fn apply(self, settings: &mut Settings) {
        settings.half_z = self == Self::HalfZ;
        settings.depth_mask = self == Self::DepthMask;
        settings.clusters = (self == Self::Clustered).then(|| settings.clusters.unwrap_or_default());
    }

    /// The layout `settings` name.
    pub fn of(settings: &Settings) -> Self {
        match (settings.clusters.is_some(), settings.depth_mask, settings.half_z) {
            (true, ..) => Self::Clustered,
            (_, true, _) => Self::DepthMask,
            (_, _, true) => Self::HalfZ,
            _ => Self::Tiled,
        }
    }
}

/// How lights get into the grid's lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AssignArg {
    /// Tile-centric: a workgroup per tile tests the lights (TiledLighting11; cost ~ lights
    /// x tiles, two-level by default).
    Gather,
    /// Light-centric: each light scatters itself into the tiles it covers (cost ~ lights +
    /// pairs). Same lists.
    Scatter,
}

/// A named configuration of the lights (`--light-preset`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// 1,000,000 point lights on the scene's surfaces (`--lights-on-surfaces --lights
    /// 1000000`), k = 8 lights per pixel, the exposure chosen for them: about 100 lights per
    /// 16 px tile at 1080p in the courtyard. Flags given with it override its values.
    Million,
}

/// `args` with the flags of its `--demo NAME` (if any) put right after the subcommand,
/// leaving out each flag the command line gives itself, so the user's own win. Only for
/// a subcommand that `takes_demo` (the app asks its own clap command which have the
/// flag); anything else is returned as it is (clap then reports an unknown demo or a
/// misplaced flag).
pub fn expand_demo(args: Vec<std::ffi::OsString>, takes_demo: impl Fn(&str) -> bool) -> Vec<std::ffi::OsString> {
    let text: Vec<String> = args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
    if !text.get(1).is_some_and(|c| takes_demo(c)) {
        return args;
    }
    let name = text.iter().enumerate().find_map(|(i, a)| match a.strip_prefix("--demo=") {
        Some(v) => Some(v.to_string()),
        None if a == "--demo" => text.get(i + 1).cloned(),
        None => None,
    });
    let Some(demo) = name.and_then(|n| tiledlight_setup::demo::parse(&n).ok()) else { return args };
    let given = |flag: &str| text.iter().any(|a| a == flag || a.starts_with(&format!("{flag}=")));
    let mut out: Vec<std::ffi::OsString> = args[..2].to_vec();
    for pair in demo.flags().chunks(2) {
        if !given(pair[0]) {
            out.extend(pair.iter().map(std::ffi::OsString::from));
        }
    }
    out.extend_from_slice(&args[2..]);
    out
}

/// Scene, lights, screen and renderer flags shared by `render` and `bench`.
///
/// Numbers are parsed wide (u64 light counts) and range-checked in [`SceneArgs::validate`],
/// so an absurd value gets a message naming the flag and its limit.
#[derive(Args, Clone, Debug, PartialEq)]
pub struct SceneArgs {
    /// `default` (the procedural courtyard), `materials` (576 boxes with --materials
    /// distinct textured materials), `bevy-many-lights` (Bevy's many_lights stress test
    /// rebuilt: 100,000 lights of 0.3 m on a sphere) or a glTF file (.gltf or .glb).
    #[arg(
        help_heading = "Scene",
        long,
        default_value = "default",
        value_name = "default|materials|bevy-many-lights|FILE"
    )]
    pub scene: String,
    /// A demo setup of the courtyard that makes one feature obvious: shadows, vpl (add
    /// --vpl for the bounce), glass, million, heatmap, clusters. It stands for a few flags
    /// (any given on the command line wins) and places its own lights, camera and props
    /// (docs/USAGE.md, "Demos").
    #[arg(help_heading = "Scene", long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(tiledlight_setup::Demo::ALL.map(|d| d.name())))]
    pub demo: Option<String>,
    /// Random point lights [default: 1024 for the default scene; for a glTF file, random
    /// lights are added to its own lights only when this or --spot-lights is given].
    #[arg(help_heading = "Lights", long, value_name = "N")]
    pub lights: Option<u64>,
    /// Random spot lights [default: 0]. A glTF scene's go near its surfaces, aimed at them
    /// (never past the first geometry above), their radius following its area and the
    /// count; the default scene's (and with --lights-in-bounds) go in the bounds.
    #[arg(help_heading = "Lights", long, value_name = "N")]
    pub spot_lights: Option<u64>,
    /// A named configuration: `million` is 1,000,000 point lights on the surfaces (see
    /// --lights-on-surfaces) with the exposure chosen for them. --lights, --lights-per-pixel
    /// and --exposure given with it override its values.
    #[arg(help_heading = "Lights", hide_short_help = true, long, value_enum, value_name = "NAME")]
    pub light_preset: Option<PresetArg>,
    /// Place the random point lights on the scene's surfaces (area-weighted, lifted off
    /// them along the normal by a quarter of their radius), all with one radius that
    /// follows the count so that --lights-per-pixel lights reach a surface point on average
    /// (the threshold then sets their intensity: threshold * radius^2). Spot lights stay in
    /// the scene's bounds.
    /// The default for a glTF scene (random lights then fit its size: their radius follows
    /// its surface area and the count).
    #[arg(help_heading = "Lights", hide_short_help = true, long)]
    pub lights_on_surfaces: bool,
    /// Place a glTF scene's random point and spot lights uniformly in its bounds instead,
    /// with radii fitted to the bounds and the count (8 lights reaching a surface point on
    /// average; the built-in courtyard's keep TiledLighting11's 1.5-4 m).
    #[arg(help_heading = "Lights", hide_short_help = true, long, conflicts_with_all = ["lights_on_surfaces", "lights_per_pixel", "light_preset"])]
    pub lights_in_bounds: bool,
    /// Mean number of surface lights reaching a pixel's surface point, the radius dial of
    /// surface lights (implies --lights-on-surfaces) [default: 8].
    #[arg(help_heading = "Lights", hide_short_help = true, long, value_name = "K")]
    pub lights_per_pixel: Option<f32>,
    /// Seed of the random lights (the same seed gives the same lights).
    #[arg(help_heading = "Lights", hide_short_help = true, long, default_value_t = 1, value_name = "S")]
    pub seed: u64,
    /// Intensity threshold that sets each light's radius: r = sqrt(intensity / T).
    #[arg(help_heading = "Lights", hide_short_help = true, long, default_value_t = DEFAULT_LIGHT_THRESHOLD, value_name = "T")]
    pub threshold: f32,
    /// Grid objects (instanced spheres) added to the default scene, 0 to 280.
    #[arg(help_heading = "Scene", long, default_value_t = 0, value_name = "N")]
    pub grid_objects: u32,
    /// Distinct textured materials of `--scene materials`, 1 to 4096 (box i takes material
    /// i mod N: the boxes, and so the coverage, stay the same).
    #[arg(help_heading = "Scene", hide_short_help = true, long, default_value_t = tiledlight_scene::materials::DEFAULT_MATERIALS, value_name = "N")]
    pub materials: u32,
    /// Tessellation of the grid objects.
    #[arg(help_heading = "Scene", hide_short_help = true, long, value_enum, default_value_t = DensityArg::Medium)]
    pub density: DensityArg,
    /// Grid objects drawn as alpha-blended glass spheres, 0 to the grid count (spread evenly
    /// over the grid; the default scene only: a glTF file's BLEND materials are drawn
    /// blended on their own).
    #[arg(help_heading = "Blended geometry", long, default_value_t = 0, value_name = "N")]
    pub transparent_objects: u32,
    /// The default scene's banners glow in their colour (emissive materials: Tiled
    /// Deferred's G-buffer gets its emission target; for measuring its cost).
    #[arg(help_heading = "Scene", hide_short_help = true, long)]
    pub emissive: bool,
    /// Image width in pixels.
    #[arg(help_heading = "Method and image", long, default_value_t = 1920, value_name = "W")]
    pub width: u32,
    /// Image height in pixels.
    #[arg(help_heading = "Method and image", long, default_value_t = 1080, value_name = "H")]
    pub height: u32,
    /// Renderer.
    #[arg(help_heading = "Method and image", long, value_enum, default_value_t = Method::ForwardPlus)]
    pub method: Method,
    /// Tile side in pixels: 8, 16 or 32.
    #[arg(help_heading = "Culling", hide_short_help = true, long, default_value_t = 16, value_name = "8|16|32")]
    pub tile_size: u32,
    /// Light indices stored per tile list (more are counted as overflow), 1 to 2048.
    /// Default: the light count, up to what the GPU's workgroup memory holds (2048), so
    /// lists overflow only when a tile really sees more lights than that.
    #[arg(help_heading = "Culling", hide_short_help = true, long, value_name = "N")]
    pub capacity: Option<u32>,
    /// Also test light spheres against each tile's view-space AABB.
    #[arg(help_heading = "Culling", hide_short_help = true, long)]
    pub aabb: bool,
    /// Two lists per tile, split at the middle of its depth range (the same as --grid half-z).
    #[arg(help_heading = "Culling", hide_short_help = true, long)]
    pub half_z: bool,
    /// The light grid's layout: screen tiles, half-z, 2.5D depth masks or clusters.
    #[arg(help_heading = "Culling", hide_short_help = true, long, value_enum, default_value_t = GridArg::Tiled)]
    pub grid: GridArg,
    /// How lights are assigned to the grid's lists (clusters are always scattered).
    #[arg(help_heading = "Culling", hide_short_help = true, long, value_enum, default_value_t = AssignArg::Gather)]
    pub assign: AssignArg,
    /// Clusters: tile side in pixels, 8, 16, 32 or 64.
    #[arg(help_heading = "Culling", hide_short_help = true, long, default_value_t = ClusterOptions::default().tile_size, value_name = "PX")]
    pub cluster_tile: u32,
    /// Clusters: depth slices, 1 to 32.
    #[arg(help_heading = "Culling", hide_short_help = true, long, default_value_t = ClusterOptions::default().slices, value_name = "N")]
    pub cluster_slices: u32,
    /// Clusters: far end of the first depth slice, metres (exponential slicing starts here).
    #[arg(help_heading = "Culling", hide_short_help = true, long, default_value_t = ClusterOptions::default().first, value_name = "M")]
    pub cluster_first: f32,
    /// Clusters: far end of the exponential slices, metres (the last slice reaches past it).
    #[arg(help_heading = "Culling", hide_short_help = true, long, default_value_t = ClusterOptions::default().last, value_name = "M")]
    pub cluster_last: f32,
    /// Clusters: only clusters holding a surface of the depth buffer get lights (off: every
    /// cluster of the frustum, which also serves transparent geometry).
    #[arg(help_heading = "Culling", hide_short_help = true, long)]
    pub cluster_geometry_only: bool,
    /// Also test spot cones against each tile (needs spot lights to matter).
    #[arg(help_heading = "Culling", hide_short_help = true, long)]
    pub spot_cone: bool,
    /// One-level culling: every tile tests every light (the default first culls per
    /// 64x64-pixel cell, and tiles test only their cell's lights).
    #[arg(help_heading = "Culling", hide_short_help = true, long)]
    pub flat_cull: bool,
    /// MSAA samples per pixel: 1 (off), 2, 4 or 8 (2 and 8 where the GPU has them). Forward+
    /// and brute force use hardware MSAA; Tiled Deferred shades edge pixels per sample.
    #[arg(help_heading = "Method and image", long, default_value_t = 1, value_name = "1|2|4|8")]
    pub msaa: u32,
    /// A fixed exposure before tonemapping [default: automatic, from each frame's
    /// log-average luminance, mapped to middle grey; `accuracy` and `shadow-accuracy` fix
    /// the one their reference image gets, so every setting is tonemapped alike].
    #[arg(help_heading = "Method and image", hide_short_help = true, long, value_name = "E")]
    pub exposure: Option<f32>,
    /// Shadow-casting point lights: the N brightest point lights cast shadows (six cube
    /// faces each, in the shadow atlas).
    #[arg(help_heading = "Shadows", long, default_value_t = 0, value_name = "N")]
    pub shadow_point_lights: u32,
    /// Shadow-casting spot lights: the N brightest spot lights cast shadows (one face each).
    #[arg(help_heading = "Shadows", hide_short_help = true, long, default_value_t = 0, value_name = "N")]
    pub shadow_spot_lights: u32,
    /// How the shadow casters of each kind are chosen: the brightest, or the largest
    /// contributions to the frame (estimated on the GPU from one frame's depth and light
    /// grid, for the camera the lights are made with).
    #[arg(help_heading = "Shadows", hide_short_help = true, long, value_enum, default_value_t = CastersByArg::Brightness)]
    pub casters_by: CastersByArg,
    /// Camera bookmark to render from (a small text file; the viewer writes them with its
    /// "save camera" button): eye, target, up, field of view, near and far plane.
    #[arg(help_heading = "Scene", hide_short_help = true, long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
    /// Turn every warning (missing textures, unknown extensions, dropped lights...) into an error with a non-zero exit
    #[arg(help_heading = "Input checks", hide_short_help = true, long)]
    pub strict: bool,
    /// Test only: a fixed light-grid budget of N (list, light) indices for the opaque and
    /// the blended grid (the grid never grows; pairs beyond it are dropped, with a warning).
    #[arg(long, value_name = "N", hide = true)]
    pub grid_budget: Option<u32>,
    /// Read the buffer and image files a glTF file names wherever they point (absolute
    /// paths, `../`, links leading out); without it only files inside the model's folder
    /// are read, since a downloaded model may name any file on the machine.
    #[arg(help_heading = "Input checks", hide_short_help = true, long)]
    pub allow_any_path: bool,
    /// Virtual point lights (`--vpl` and its settings).
    #[command(flatten)]
    pub vpl: crate::vpl_args::VplArgs,
    /// The pass settings, one flag a row of `tiledlight_gpu::knobs` (`--gbuffer-rts`,
    /// `--draw-order`, `--no-early-outs`, `--raster`, `--edge-distance`, ...).
    #[command(flatten)]
    pub knobs: KnobArgs,
}

impl Default for SceneArgs {
    /// The defaults clap gives, which are tiledlight-setup's `Settings::default()` (a unit
    /// test checks the flags parse to this).
    fn default() -> Self {
        let d = Settings::default();
        let c = d.clusters.unwrap_or_default();
        Self {
            scene: d.scene.to_string(),
            demo: d.demo.map(|x| x.name().to_string()),
            lights: d.lights,
            spot_lights: d.spot_lights,
            light_preset: None,
            lights_on_surfaces: d.placement.on_surfaces(),
            lights_in_bounds: false,
            lights_per_pixel: None,
            seed: d.seed,
            threshold: d.threshold,
            grid_objects: d.grid_objects,
            materials: d.materials,
            density: d.density.into(),
            transparent_objects: d.transparent_objects,
            emissive: d.emissive,
            width: d.width,
            height: d.height,
            method: d.method,
            tile_size: d.tile_size,
            capacity: d.capacity,
            aabb: d.aabb,
            half_z: d.half_z,
            grid: GridArg::of(&d),
            assign: if d.scatter { AssignArg::Scatter } else { AssignArg::Gather },
            cluster_tile: c.tile_size,
            cluster_slices: c.slices,
            cluster_first: c.first,
            cluster_last: c.last,
            cluster_geometry_only: c.geometry_only,
            spot_cone: d.spot_cone,
            flat_cull: d.flat_cull,
            msaa: d.msaa,
            exposure: None,
            shadow_point_lights: d.shadow_point_lights,
            shadow_spot_lights: d.shadow_spot_lights,
            casters_by: d.casters_by.into(),
            camera: None,
            strict: d.strict,
            grid_budget: d.grid_pairs,
            allow_any_path: d.allow_any_path,
            vpl: crate::vpl_args::VplArgs::of(d.vpl),
            knobs: KnobArgs(d.knobs),
        }
    }
}

impl SceneArgs {
    /// The settings of these flags, unchecked (`Flags::validate` checks them), the
    /// camera bookmark not read (`camera: None`).
    pub fn plain_settings(&self) -> Settings {
        let million = self.light_preset == Some(PresetArg::Million);
        // A loaded scene may be 2 m or 200 m across: its random lights go on its surfaces,
        // sized from its area, unless asked otherwise. The built-in courtyard keeps the
        // sample's uniform lights (every benchmark here is measured with them).
        let file = matches!(SceneSource::parse(&self.scene), SceneSource::File(_));
        let placement = if self.lights_on_surfaces
            || million
            || self.lights_per_pixel.is_some()
            || (file && !self.lights_in_bounds)
        {
            LightPlacement::Surfaces { lights_per_point: self.lights_per_pixel.unwrap_or(DEFAULT_LIGHTS_PER_POINT) }
        } else {
            LightPlacement::Bounds
        };
        let exposure = self.exposure.unwrap_or(match placement {
            LightPlacement::Surfaces { lights_per_point } => surface_exposure(lights_per_point, self.threshold),
            LightPlacement::Bounds => Settings::default().exposure,
        });
        Settings {
            scene: SceneSource::parse(&self.scene),
            // Clap accepts only the names of Demo::ALL.
            demo: self.demo.as_deref().and_then(|n| tiledlight_setup::demo::parse(n).ok()),
            lights: self.lights.or(million.then_some(MILLION_LIGHTS)),
            spot_lights: self.spot_lights,
            placement,
            seed: self.seed,
            threshold: self.threshold,
            auto_exposure: self.exposure.is_none(),
            grid_objects: self.grid_objects,
            materials: self.materials,
            density: self.density.into(),
            transparent_objects: self.transparent_objects,
            emissive: self.emissive,
            width: self.width,
            height: self.height,
            method: self.method,
            tile_size: self.tile_size,
            capacity: self.capacity,
            grid_pairs: self.grid_budget,
            aabb: self.aabb,
            half_z: self.half_z || self.grid == GridArg::HalfZ,
            depth_mask: self.grid == GridArg::DepthMask,
            scatter: self.assign == AssignArg::Scatter,
            clusters: (self.grid == GridArg::Clustered).then_some(ClusterOptions {
                tile_size: self.cluster_tile,
                slices: self.cluster_slices,
                first: self.cluster_first,
                last: self.cluster_last,
                geometry_only: self.cluster_geometry_only,
            }),
            spot_cone: self.spot_cone,
            flat_cull: self.flat_cull,
            msaa: self.msaa,
            exposure,
            shadow_point_lights: self.shadow_point_lights,
            shadow_spot_lights: self.shadow_spot_lights,
            casters_by: self.casters_by.into(),
            camera: None,
            strict: self.strict,
            allow_any_path: self.allow_any_path,
            vpl: self.vpl.config(),
            knobs: self.knobs.0,
            traced_progress: false,
        }
    }

    /// The library settings of these flags: checked first, then the `--camera` bookmark
    /// read, so a typo in a flag is reported before a file problem.
    pub fn settings(&self) -> Result<Settings> {
        let mut settings = self.plain_settings();
        settings.validate()?;
        if let Some(path) = &self.camera {
            settings.camera = Some(CameraBookmark { path: path.clone(), camera: bookmark::load(path)? });
        }
        Ok(settings)
    }
}

/// The lab's axes set these flags (`sweep`/`accuracy --axis NAME=VALUES`): an axis's name
/// is its flag's.
impl Flags for SceneArgs {
    fn set_axis(&mut self, name: &str, value: &str) -> Result<()> {
        let args = self;
        let int = || -> Result<u64> {
            value.parse::<u64>().with_context(|| format!("{name} '{value}': expected an integer"))
        };
        let small = || -> Result<u32> {
            let n = int()?;
            u32::try_from(n).with_context(|| format!("{name} {n}: too large"))
        };
        // A row of the pass settings' table parses its own value.
        if let Some(set) = args.knobs.0.set(name, value) {
            return set.map_err(anyhow::Error::msg);
        }
        match name {
            "lights" => args.lights = Some(int()?),
            "spot-lights" => args.spot_lights = Some(int()?),
            "seed" => args.seed = int()?,
            // Read (and checked) with the other files the settings name.
            "camera" => args.camera = Some(PathBuf::from(value)),
            "grid-objects" => args.grid_objects = small()?,
            "materials" => args.materials = small()?,
            "tile-size" => args.tile_size = small()?,
            "msaa" => args.msaa = small()?,
            "threshold" => {
                args.threshold = value.parse().with_context(|| format!("threshold '{value}': expected a number"))?
            }
            "method" => {
                args.method = Method::from_str(value, true).map_err(|e| anyhow::anyhow!("method '{value}': {e}"))?
            }
            "density" => {
                args.density =
                    DensityArg::from_str(value, true).map_err(|e| anyhow::anyhow!("density '{value}': {e}"))?
            }
            "shadow-point-lights" => args.shadow_point_lights = small()?,
            "shadow-spot-lights" => args.shadow_spot_lights = small()?,
            "casters-by" => {
                args.casters_by =
                    CastersByArg::from_str(value, true).map_err(|e| anyhow::anyhow!("casters-by '{value}': {e}"))?
            }
            "transparent-objects" => args.transparent_objects = small()?,
            "grid" => {
                args.grid = GridArg::from_str(value, true).map_err(|e| anyhow::anyhow!("grid '{value}': {e}"))?;
                // The layout is the axis's alone: --half-z on the command line would fight it.
                args.half_z = false;
            }
            "assign" => {
                args.assign = AssignArg::from_str(value, true).map_err(|e| anyhow::anyhow!("assign '{value}': {e}"))?
            }
            "cluster-tile" => args.cluster_tile = small()?,
            "cluster-slices" => args.cluster_slices = small()?,
            "cluster-first" => {
                args.cluster_first =
                    value.parse().with_context(|| format!("cluster-first '{value}': expected a number"))?
            }
            "lights-per-pixel" => {
                args.lights_per_pixel =
                    Some(value.parse().with_context(|| format!("lights-per-pixel '{value}': expected a number"))?)
            }
            "aabb" => args.aabb = on_off(value)?,
            "half-z" => args.half_z = on_off(value)?,
            // The VPL settings' axes apply with --vpl (or the vpl axis) on.
            "vpl" => args.vpl.vpl = on_off(value)?,
            "vpl-rsm-size" => args.vpl.vpl_rsm_size = small()?,
            "vpl-block" => args.vpl.vpl_block = small()?,
            "vpl-cap" => args.vpl.vpl_cap = small()?,
            "vpl-colour-threshold" => {
                args.vpl.vpl_colour_threshold =
                    value.parse().with_context(|| format!("vpl-colour-threshold '{value}': expected a number"))?
            }
            "vpl-brightness-threshold" => {
                args.vpl.vpl_brightness_threshold =
                    value.parse().with_context(|| format!("vpl-brightness-threshold '{value}': expected a number"))?
            }
            "vpl-shading" => {
                args.vpl.vpl_shading = crate::vpl_args::VplShadingArg::from_str(value, true)
                    .map_err(|e| anyhow::anyhow!("vpl-shading '{value}': {e}"))?
            }
            "culling" => {
                (args.aabb, args.half_z) = match value {
                    "planes" => (false, false),
                    "aabb" => (true, false),
                    "half-z" => (false, true),
                    "aabb+half-z" => (true, true),
                    _ => bail!("culling '{value}': expected planes, aabb, half-z or aabb+half-z"),
                }
            }
            _ => bail!("unknown axis '{name}'"),
        }
        Ok(())
    }

    fn plain(&self) -> Settings {
        self.plain_settings()
    }

    fn settings(&self) -> Result<Settings> {
        SceneArgs::settings(self)
    }

    fn scene_label(&self) -> String {
        tiledlight_lab::axes::scene_phrase(&self.scene, self.grid_objects)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat};
    use tiledlight_gpu::features::BlendMode;
    use tiledlight_lab::axes;
    use tiledlight_setup::{DrawOrderMode, Knobs, LargeRaster, Raster};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        scene: SceneArgs,
    }

    /// `--demo` puts its flags after the subcommand, leaving out those the user gives, so
    /// the user's win; other subcommands and unknown demos are left to clap.
    #[test]
    fn a_demo_expands_into_its_flags_and_the_users_win() {
        let os = |v: &[&str]| v.iter().map(std::ffi::OsString::from).collect::<Vec<_>>();
        let scene_cmd = |c: &str| c == "render" || c == "bench";
        let got = expand_demo(os(&["tiledlight", "render", "--demo", "shadows", "--grid-objects", "8"]), scene_cmd);
        let mut want = vec!["tiledlight", "render", "--lights", "0"];
        want.extend(["--shadow-point-lights", "6", "--shadow-size", "1024", "--shadow-filter", "5"]);
        want.extend(["--demo", "shadows", "--grid-objects", "8"]);
        assert_eq!(got, os(&want));
        let got = expand_demo(os(&["tiledlight", "bench", "--demo=million", "--width", "64"]), scene_cmd);
        assert_eq!(got, os(&["tiledlight", "bench", "--light-preset", "million", "--demo=million", "--width", "64"]));
        for unchanged in [
            &["tiledlight", "peer-report", "--demo", "shadows"][..],
            &["tiledlight", "render", "--demo", "sparkles"],
            &["tiledlight", "render", "--lights", "3"],
            &["tiledlight"],
        ] {
            assert_eq!(expand_demo(os(unchanged), scene_cmd), os(unchanged));
        }
        // Parsed: the demo's settings, the user's flag, the courtyard dressed by the loader.
        let s = parse(&["--lights", "0", "--grid-objects", "60", "--demo", "shadows"]).plain_settings();
        assert_eq!((s.demo, s.lights, s.grid_objects), (Some(tiledlight_setup::Demo::Shadows), Some(0), 60));
        let s = Settings { scene: SceneSource::File("a.gltf".into()), ..s };
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("--demo shadows dresses the built-in courtyard"), "{e}");
    }

    fn parse(flags: &[&str]) -> SceneArgs {
        Cli::try_parse_from(std::iter::once("x").chain(flags.iter().copied())).unwrap().scene
    }

    #[test]
    fn defaults_are_the_library_defaults() {
        assert_eq!(parse(&[]), SceneArgs::default());
        // But the exposure: automatic on the command line unless given, fixed in the library
        // (images compared across renderers need one exposure).
        assert_eq!(SceneArgs::default().settings().unwrap(), Settings { auto_exposure: true, ..Settings::default() });
    }

    #[test]
    fn every_flag_reaches_the_settings() {
        let a = parse(&[
            "--scene",
            "a.glb",
            "--lights",
            "3",
            "--spot-lights",
            "4",
            "--seed",
            "5",
            "--threshold",
            "0.5",
            "--density",
            "high",
            "--width",
            "64",
            "--height",
            "36",
            "--method",
            "deferred",
            "--tile-size",
            "8",
            "--capacity",
            "9",
            "--aabb",
            "--half-z",
            "--spot-cone",
            "--flat-cull",
            "--gbuffer-rts",
            "3",
            "--draw-order",
            "submission",
            "--no-early-outs",
            "--raster",
            "hardware",
            "--raster-large-px",
            "48",
            "--raster-large",
            "hardware",
            "--msaa",
            "4",
            "--no-surface-edges",
            "--edge-distance",
            "0.25",
            "--edge-normal-deg",
            "30",
            "--exposure",
            "2",
            "--lights-per-pixel",
            "3",
            "--shadow-point-lights",
            "2",
            "--shadow-spot-lights",
            "1",
            "--casters-by",
            "contribution",
            "--shadow-size",
            "512",
            "--shadow-filter",
            "3",
            "--shadow-format",
            "d32",
            "--blend-mode",
            "wboit",
            "--assign",
            "scatter",
            "--grid-budget",
            "77",
        ]);
        let s = a.settings().unwrap();
        let expected = Settings {
            demo: None,
            scene: SceneSource::File("a.glb".into()),
            lights: Some(3),
            spot_lights: Some(4),
            placement: LightPlacement::Surfaces { lights_per_point: 3.0 },
            seed: 5,
            threshold: 0.5,
            grid_objects: 0,
            materials: tiledlight_scene::materials::DEFAULT_MATERIALS,
            density: GridDensity::High,
            transparent_objects: 0,
            emissive: false,
            width: 64,
            height: 36,
            method: Method::TiledDeferred,
            tile_size: 8,
            capacity: Some(9),
            grid_pairs: Some(77),
            aabb: true,
            half_z: true,
            depth_mask: false,
            scatter: true,
            clusters: None,
            spot_cone: true,
            flat_cull: true,
            msaa: 4,
            exposure: 2.0,
            auto_exposure: false,
            shadow_point_lights: 2,
            shadow_spot_lights: 1,
            casters_by: CasterChoice::Contribution,
            vpl: None,
            traced_progress: false,
            knobs: Knobs {
                gbuffer_rts: 3,
                draw_order: DrawOrderMode::Submission,
                early_outs: false,
                raster: Raster::Hardware,
                raster_large_px: 48,
                raster_large: LargeRaster::Hardware,
                surface_edges: false,
                edge_distance: 0.25,
                edge_normal_deg: 30.0,
                shadow_size: 512,
                shadow_filter: ShadowFilter::Pcf3,
                shadow_format: ShadowFormat::Depth32,
                blend_mode: BlendMode::WeightedOit,
                // Rows this command line leaves at their default (each row's own flag is
                // parsed by the table's tests, tiledlight_gpu::knobs): a new row needs no edit here.
                ..Knobs::default()
            },
            camera: None,
            strict: false,
            allow_any_path: false,
        };
        assert_eq!(s, expected);
        assert_eq!(parse(&["--grid-objects", "7"]).settings().unwrap().grid_objects, 7);
        let glass = parse(&["--grid-objects", "50", "--transparent-objects", "20"]).settings().unwrap();
        assert_eq!(
            (glass.grid_objects, glass.transparent_objects, glass.knobs.blend_mode),
            (50, 20, BlendMode::Sorted)
        );
        assert_eq!(parse(&["--scene", "DEFAULT"]).settings().unwrap().scene, SceneSource::Default);
    }

    #[test]
    fn grid_layouts_reach_the_settings() {
        let s = |flags: &[&str]| parse(flags).settings().unwrap();
        assert!(s(&["--grid", "half-z"]).half_z);
        let mask = s(&["--grid", "2.5d"]);
        assert!(mask.depth_mask && !mask.half_z && mask.clusters.is_none() && !mask.scatter);
        let c = s(&[
            "--grid",
            "clustered",
            "--cluster-tile",
            "32",
            "--cluster-slices",
            "16",
            "--cluster-first",
            "2",
            "--cluster-last",
            "100",
            "--cluster-geometry-only",
        ]);
        let want = ClusterOptions { tile_size: 32, slices: 16, first: 2.0, last: 100.0, geometry_only: true };
        assert_eq!(c.clusters, Some(want));
        for g in [GridArg::Tiled, GridArg::HalfZ, GridArg::DepthMask, GridArg::Clustered] {
            let name = g.to_possible_value().unwrap().get_name().to_string();
            assert_eq!(GridArg::of(&s(&["--grid", &name])), g);
            let mut settings = c.clone();
            g.apply(&mut settings);
            assert_eq!(GridArg::of(&settings), g);
        }
        // Switching away and back keeps the clusters' options only while clustered.
        let mut settings = c.clone();
        GridArg::Tiled.apply(&mut settings);
        assert_eq!(settings.clusters, None);
        let e = |flags: &[&str]| format!("{:#}", parse(flags).settings().unwrap_err());
        assert!(e(&["--grid", "2.5d", "--half-z"]).contains("--grid 2.5d"), "{}", e(&["--grid", "2.5d", "--half-z"]));
        assert!(e(&["--grid", "clustered", "--cluster-slices", "33"]).starts_with("--cluster-slices 33"));
        assert!(e(&["--grid", "clustered", "--cluster-tile", "12"]).starts_with("--cluster-tile 12"));
        assert!(e(&["--grid", "clustered", "--cluster-last", "1"]).starts_with("--cluster-last 1"));
    }

    #[test]
    fn the_million_preset_places_a_million_lights_on_the_surfaces() {
        let s = parse(&["--light-preset", "million"]).settings().unwrap();
        assert_eq!((s.lights, s.placement), (Some(MILLION_LIGHTS), LightPlacement::SURFACES));
        assert_eq!(s.exposure, surface_exposure(DEFAULT_LIGHTS_PER_POINT, DEFAULT_LIGHT_THRESHOLD));
        // Flags given with it win.
        let s = parse(&["--light-preset", "million", "--lights", "1000", "--lights-per-pixel", "4", "--exposure", "3"])
            .settings()
            .unwrap();
        let placement = LightPlacement::Surfaces { lights_per_point: 4.0 };
        assert_eq!((s.lights, s.placement, s.exposure), (Some(1000), placement, 3.0));
        // On surfaces without the preset: the usual count, the surface exposure for k.
        let s = parse(&["--lights-on-surfaces", "--threshold", "0.2"]).settings().unwrap();
        assert_eq!((s.lights, s.placement), (None, LightPlacement::SURFACES));
        assert_eq!(s.exposure, surface_exposure(DEFAULT_LIGHTS_PER_POINT, 0.2));
        assert!(Cli::try_parse_from(["x", "--light-preset", "billion"]).is_err());
        let e = format!("{:#}", parse(&["--lights-per-pixel", "0"]).settings().unwrap_err());
        assert!(e.starts_with("--lights-per-pixel 0:"), "{e}");
    }

    #[test]
    fn bad_flags_are_named_before_the_bookmark_is_read() {
        let e = |a: SceneArgs| format!("{:#}", a.settings().unwrap_err());
        let missing = Some(PathBuf::from("/nonexistent/cam.txt"));
        assert!(e(SceneArgs { width: 0, camera: missing.clone(), ..SceneArgs::default() }).contains("--width 0"));
        let line = e(SceneArgs { camera: missing, ..SceneArgs::default() });
        assert!(line.contains("--camera /nonexistent/cam.txt: cannot read the file"), "{line}");
        assert!(SceneArgs { tile_size: 7, ..SceneArgs::default() }.validate().is_err());
        let e = |flags: &[&str]| format!("{:#}", parse(flags).settings().unwrap_err());
        assert_eq!(e(&["--shadow-size", "100"]), "--shadow-size 100: must be between 128 and 1024 texels");
        let bad_filter = Cli::try_parse_from(["x", "--shadow-filter", "4"]).err().expect("refused").to_string();
        assert!(bad_filter.contains("'4'") && bad_filter.contains("--shadow-filter") && bad_filter.contains("1, 3, 5"));
        assert!(e(&["--lights", "3", "--shadow-point-lights", "4"]).starts_with("--shadow-point-lights 4:"));
        let bad_format = Cli::try_parse_from(["x", "--shadow-format", "d24"]);
        assert!(bad_format.is_err());
        assert_eq!(
            e(&["--grid-objects", "10", "--transparent-objects", "11"]),
            "--transparent-objects 11: must be between 0 and the grid objects (--grid-objects 10)"
        );
        assert!(e(&["--scene", "a.glb", "--transparent-objects", "1"]).starts_with("--transparent-objects 1:"));
        assert!(Cli::try_parse_from(["x", "--blend-mode", "additive"]).is_err());
    }

    // The lab's axes on these flags (tiledlight-lab's `axes` with `Flags for SceneArgs`).
    #[test]
    fn ranges_and_lists() {
        assert_eq!(
            axes::parse_axis::<SceneArgs>("lights=64..1000").unwrap().values,
            ["64", "128", "256", "512", "1000"]
        );
        assert_eq!(axes::parse_axis::<SceneArgs>("lights=64..65536:4").unwrap().values, ["64", "645", "6502", "65536"]);
        assert_eq!(axes::parse_axis::<SceneArgs>("threshold=0.4..0.05").unwrap().values, ["0.4", "0.2", "0.1", "0.05"]);
        assert_eq!(
            axes::parse_axis::<SceneArgs>("method=forward-plus, deferred").unwrap().values,
            ["forward-plus", "deferred"]
        );
        assert_eq!(axes::parse_axis::<SceneArgs>("culling=planes,aabb+half-z").unwrap().values.len(), 2);
    }

    #[test]
    fn bad_axes_are_clear_errors() {
        let e = |s: &str| format!("{:#}", axes::parse_axis::<SceneArgs>(s).unwrap_err());
        assert!(e("colour=1,2").contains("unknown axis 'colour'"), "{}", e("colour=1,2"));
        assert!(e("lights=").contains("empty sweep"));
        assert!(e("lights").contains("NAME=VALUES"));
        assert!(e("method=forward").contains("method 'forward'"));
        assert!(e("method=a..b").contains("numeric"));
        assert!(e("lights=0..8").contains("positive"));
        assert!(e("lights=99999999999").contains("--lights"), "{}", e("lights=99999999999"));
        assert!(e("tile-size=12").contains("--tile-size 12"));
        assert!(e("threshold=-1").contains("--threshold"));
        assert!(e("lights=1,1").contains("twice"));
        assert!(e("lights=1..1e9:100000").contains("step count"));
        assert!(e("shadow-size=100").contains("--shadow-size 100"), "{}", e("shadow-size=100"));
        assert!(
            e("shadow-filter=2").contains("shadow-filter '2': expected one of 1, 3, 5"),
            "{}",
            e("shadow-filter=2")
        );
        assert!(e("shadow-format=d24").contains("shadow-format 'd24'"));
        assert!(axes::points(&[]).is_err());
    }

    #[test]
    fn points_are_the_product() {
        let axes = vec![
            axes::parse_axis::<SceneArgs>("lights=1,2").unwrap(),
            axes::parse_axis::<SceneArgs>("method=forward-plus,deferred").unwrap(),
        ];
        let p = axes::points(&axes).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(p[1], ["1", "deferred"]);
        let a = axes::args_at(&SceneArgs::default(), &axes, &p[3]).unwrap();
        assert_eq!((a.lights, a.method), (Some(2), Method::TiledDeferred));
        let merged = axes::merge_axes(
            axes.clone(),
            vec![axes::parse_axis::<SceneArgs>("lights=8").unwrap(), axes::parse_axis::<SceneArgs>("seed=3").unwrap()],
        );
        assert_eq!(merged.iter().map(|a| a.values.len()).collect::<Vec<_>>(), [1, 2, 1]);
        assert!(axes::points(&[axes[0].clone(), axes[0].clone()]).is_err());
    }

    #[test]
    fn shadows_are_axes() {
        // Spot casters parse before the spot lights they need are known...
        let axes = vec![
            axes::parse_axis::<SceneArgs>("shadow-spot-lights=1..8").unwrap(),
            axes::parse_axis::<SceneArgs>("shadow-size=128,1024").unwrap(),
            axes::parse_axis::<SceneArgs>("shadow-filter=1,5").unwrap(),
            axes::parse_axis::<SceneArgs>("shadow-format=d16,d32").unwrap(),
            axes::parse_axis::<SceneArgs>("shadow-point-lights=2").unwrap(),
        ];
        assert_eq!(axes[0].values, ["1", "2", "4", "8"]);
        let p = axes::points(&axes).unwrap();
        assert_eq!(p.len(), 4 * 2 * 2 * 2);
        let base = SceneArgs { spot_lights: Some(8), ..SceneArgs::default() };
        let a = axes::args_at(&base, &axes, &p[p.len() - 1]).unwrap();
        assert_eq!(
            (
                a.shadow_spot_lights,
                a.knobs.0.shadow_size,
                a.knobs.0.shadow_filter,
                a.knobs.0.shadow_format,
                a.shadow_point_lights
            ),
            (8, 1024, ShadowFilter::Pcf5, ShadowFormat::Depth32, 2)
        );
        // ...and are checked against them with the point's settings.
        let e = format!("{:#}", axes::args_at(&SceneArgs::default(), &axes, &p[0]).unwrap_err());
        assert!(e.contains("--shadow-spot-lights 1: more than the scene's 0 spot lights"), "{e}");
    }

    #[test]
    fn layouts_and_assignment_are_axes() {
        let a = axes::parse_axis::<SceneArgs>("grid=tiled,half-z,2.5d,clustered").unwrap();
        assert_eq!(a.values.len(), 4);
        assert!(axes::parse_axis::<SceneArgs>("assign=gather,scatter").is_ok());
        assert!(
            axes::parse_axis::<SceneArgs>("cluster-slices=8..32").is_ok() && axes::is_numeric_axis("cluster-first")
        );
        let mut args = SceneArgs { half_z: true, ..SceneArgs::default() };
        axes::apply(&mut args, "grid", "2.5d").unwrap();
        assert_eq!((args.grid, args.half_z), (GridArg::DepthMask, false));
        axes::apply(&mut args, "assign", "scatter").unwrap();
        assert_eq!(args.assign, AssignArg::Scatter);
        let e = format!("{:#}", axes::parse_axis::<SceneArgs>("grid=hexagonal").unwrap_err());
        assert!(e.contains("grid 'hexagonal'"), "{e}");
    }

    #[test]
    fn vpl_settings_are_axes() {
        let mut args = SceneArgs::default();
        for (name, value) in [
            ("vpl", "on"),
            ("vpl-block", "4"),
            ("vpl-rsm-size", "64"),
            ("vpl-cap", "1000"),
            ("vpl-colour-threshold", "0.5"),
            ("vpl-brightness-threshold", "0.25"),
            ("vpl-shading", "physical"),
        ] {
            axes::apply(&mut args, name, value).unwrap();
        }
        let c = args.vpl.config().expect("--vpl on");
        assert_eq!((c.block, c.rsm_size, c.cap), (4, 64, 1000));
        assert_eq!((c.colour_threshold, c.brightness_threshold), (0.5, 0.25));
        assert_eq!(c.shading, tiledlight_cull::vpl::VplShading::Physical);
        assert_eq!(axes::parse_axis::<SceneArgs>("vpl-block=1..8").unwrap().values, ["1", "2", "4", "8"]);
        assert!(axes::is_numeric_axis("vpl-brightness-threshold") && !axes::is_numeric_axis("vpl-shading"));
        let e = format!("{:#}", axes::apply(&mut args, "vpl-shading", "fancy").unwrap_err());
        assert!(e.contains("vpl-shading 'fancy'"), "{e}");
    }

    #[test]
    fn blended_geometry_is_an_axis() {
        let axes = vec![
            axes::parse_axis::<SceneArgs>("transparent-objects=0,10,50,280").unwrap(),
            axes::parse_axis::<SceneArgs>("blend-mode=sorted,wboit").unwrap(),
        ];
        assert!(axes::is_numeric_axis("transparent-objects") && !axes::is_numeric_axis("blend-mode"));
        assert_eq!(axes::parse_axis::<SceneArgs>("transparent-objects=10..40").unwrap().values, ["10", "20", "40"]);
        // The material count needs `--scene materials`, which the command's flags give: the
        // axis parses without it (USAGE's `sweep --scene materials --axis materials=2..512`
        // was refused), and a point of it without that scene is refused by name.
        let materials = axes::parse_axis::<SceneArgs>("materials=2..512").unwrap();
        assert_eq!(materials.values.len(), 9);
        let on = SceneArgs { scene: "materials".into(), ..SceneArgs::default() };
        assert!(axes::args_at(&on, std::slice::from_ref(&materials), &vec!["2".to_string()]).is_ok());
        let off = format!(
            "{:#}",
            axes::args_at(&SceneArgs::default(), &[materials], &vec!["2".to_string()]).map(|_| ()).unwrap_err()
        );
        assert!(off.contains("only the many-material scene"), "{off}");
        let p = axes::points(&axes).unwrap();
        assert_eq!(p.len(), 8);
        // The count parses before the grid objects it needs are known...
        let base = SceneArgs { grid_objects: 280, ..SceneArgs::default() };
        let a = axes::args_at(&base, &axes, &p[p.len() - 1]).unwrap();
        assert_eq!((a.transparent_objects, a.knobs.0.blend_mode), (280, BlendMode::WeightedOit));
        // ...and is checked against them with the point's settings.
        let e = format!("{:#}", axes::args_at(&SceneArgs { grid_objects: 50, ..base }, &axes, &p[6]).unwrap_err());
        assert!(
            e.contains("--transparent-objects 280: must be between 0 and the grid objects (--grid-objects 50)"),
            "{e}"
        );
        let e = format!("{:#}", axes::parse_axis::<SceneArgs>("blend-mode=additive").unwrap_err());
        assert!(e.contains("blend-mode 'additive'"), "{e}");
    }

    #[test]
    fn the_early_outs_are_an_axis() {
        let axes = vec![axes::parse_axis::<SceneArgs>("early-outs=on,off").unwrap()];
        let p = axes::points(&axes).unwrap();
        let settings = |i: usize| axes::args_at(&SceneArgs::default(), &axes, &p[i]).unwrap().settings().unwrap();
        assert!(settings(0).knobs.early_outs);
        assert!(!settings(1).knobs.early_outs);
        assert!(!settings(1).frame_settings(false).knobs.early_outs, "the ablation reaches the frame");
        let e = format!("{:#}", axes::parse_axis::<SceneArgs>("early-outs=sometimes").unwrap_err());
        assert!(e.contains("early-outs"), "{e}");
    }

    #[test]
    fn preset_axes_are_valid() {
        let axes = tiledlight_lab::sweep::Preset::Figure9.axes::<SceneArgs>();
        assert_eq!(axes::points(&axes).unwrap().len(), 26);
        assert!(axes[0].values.contains(&"1792".to_string()));
        assert_eq!(tiledlight_lab::sweep::chart_x_axis(&axes, None).unwrap(), "lights");
        assert!(tiledlight_lab::sweep::chart_x_axis(&axes, Some("colour")).is_err());
    }
}
