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
use tiledlight_setup::bookmark;
use tiledlight_setup::table::SettingArgs;
use tiledlight_setup::{
    surface_exposure, CameraBookmark, LightPlacement, SceneSource, Settings, DEFAULT_LIGHTS_PER_POINT, MILLION_LIGHTS,
};

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

/// Scene, lights, screen and renderer flags shared by `render`, `bench`, the lab and the
/// viewer: one flag a row of the run settings' table (`tiledlight_setup::table`) and of
/// the pass settings' table (`tiledlight_gpu::knobs`), and the flags that stand for several
/// settings at once or are derived from several (the light placement and its preset, the
/// exposure, the cluster options, VPLs, the camera bookmark, the demo).
///
/// Numbers are parsed wide (u64 light counts) and range-checked by the settings'
/// validation, so an absurd value gets a message naming the flag and its limit.
#[derive(Args, Clone, Debug, PartialEq)]
pub struct SceneArgs {
    /// The run settings, one flag a row of `tiledlight_setup::table` (`--scene`, `--lights`,
    /// `--method`, `--width`, `--tile-size`, `--grid`, `--aabb`, `--shadow-point-lights`, ...).
    #[command(flatten)]
    pub settings: SettingArgs,
    /// A demo setup of the courtyard that makes one feature obvious: shadows, vpl (add
    /// --vpl for the bounce), glass, million, heatmap, clusters. It stands for a few flags
    /// (any given on the command line wins) and places its own lights, camera and props
    /// (docs/USAGE.md, "Demos").
    #[arg(help_heading = "Scene", long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(tiledlight_setup::Demo::ALL.map(|d| d.name())))]
    pub demo: Option<String>,
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
    /// Two lists per tile, split at the middle of its depth range (the same as --grid half-z).
    #[arg(help_heading = "Culling", hide_short_help = true, long)]
    pub half_z: bool,
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
    /// A fixed exposure before tonemapping [default: automatic, from each frame's
    /// log-average luminance, mapped to middle grey; `accuracy` and `shadow-accuracy` fix
    /// the one their reference image gets, so every setting is tonemapped alike].
    #[arg(help_heading = "Method and image", hide_short_help = true, long, value_name = "E")]
    pub exposure: Option<f32>,
    /// Camera bookmark to render from (a small text file; the viewer writes them with its
    /// "save camera" button): eye, target, up, field of view, near and far plane.
    #[arg(help_heading = "Scene", hide_short_help = true, long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
    /// Test only: a fixed light-grid budget of N (list, light) indices for the opaque and
    /// the blended grid (the grid never grows; pairs beyond it are dropped, with a warning).
    #[arg(long, value_name = "N", hide = true)]
    pub grid_budget: Option<u32>,
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
            demo: d.demo.map(|x| x.name().to_string()),
            light_preset: None,
            lights_on_surfaces: d.placement.on_surfaces(),
            lights_in_bounds: false,
            lights_per_pixel: None,
            half_z: d.half_z,
            cluster_tile: c.tile_size,
            cluster_slices: c.slices,
            cluster_first: c.first,
            cluster_last: c.last,
            cluster_geometry_only: c.geometry_only,
            exposure: None,
            camera: None,
            grid_budget: d.grid_pairs,
            vpl: crate::vpl_args::VplArgs::of(d.vpl),
            knobs: KnobArgs(d.knobs),
            settings: SettingArgs(d),
        }
    }
}

impl SceneArgs {
    /// The run settings' rows as given (the table's values, before the flags that stand
    /// for several settings are applied).
    pub fn rows(&self) -> &Settings {
        &self.settings.0
    }

    /// The settings of these flags, unchecked (`Flags::validate` checks them), the
    /// camera bookmark not read (`camera: None`).
    pub fn plain_settings(&self) -> Settings {
        let mut s = self.settings.0.clone();
        let million = self.light_preset == Some(PresetArg::Million);
        // A loaded scene may be 2 m or 200 m across: its random lights go on its surfaces,
        // sized from its area, unless asked otherwise. The built-in courtyard keeps the
        // sample's uniform lights (every benchmark here is measured with them).
        let file = matches!(s.scene, SceneSource::File(_));
        s.placement = if self.lights_on_surfaces
            || million
            || self.lights_per_pixel.is_some()
            || (file && !self.lights_in_bounds)
        {
            LightPlacement::Surfaces { lights_per_point: self.lights_per_pixel.unwrap_or(DEFAULT_LIGHTS_PER_POINT) }
        } else {
            LightPlacement::Bounds
        };
        s.exposure = self.exposure.unwrap_or(match s.placement {
            LightPlacement::Surfaces { lights_per_point } => surface_exposure(lights_per_point, s.threshold),
            LightPlacement::Bounds => Settings::default().exposure,
        });
        s.auto_exposure = self.exposure.is_none();
        // Clap accepts only the names of Demo::ALL.
        s.demo = self.demo.as_deref().and_then(|n| tiledlight_setup::demo::parse(n).ok());
        s.lights = s.lights.or(million.then_some(MILLION_LIGHTS));
        s.grid_pairs = self.grid_budget;
        s.half_z |= self.half_z;
        if s.clusters.is_some() {
            s.clusters = Some(ClusterOptions {
                tile_size: self.cluster_tile,
                slices: self.cluster_slices,
                first: self.cluster_first,
                last: self.cluster_last,
                geometry_only: self.cluster_geometry_only,
            });
        }
        s.camera = None;
        s.vpl = self.vpl.config();
        s.knobs = self.knobs.0;
        s.traced_progress = false;
        s
    }

    /// The `--cluster-*` flags given a value other than their default.
    fn cluster_flags_given(&self) -> Vec<String> {
        let d = ClusterOptions::default();
        let mut given = Vec::new();
        if self.cluster_tile != d.tile_size {
            given.push(format!("--cluster-tile {}", self.cluster_tile));
        }
        if self.cluster_slices != d.slices {
            given.push(format!("--cluster-slices {}", self.cluster_slices));
        }
        if self.cluster_first != d.first {
            given.push(format!("--cluster-first {}", self.cluster_first));
        }
        if self.cluster_last != d.last {
            given.push(format!("--cluster-last {}", self.cluster_last));
        }
        if self.cluster_geometry_only != d.geometry_only {
            given.push("--cluster-geometry-only".into());
        }
        given
    }

    /// The library settings of these flags: checked first, then the `--camera` bookmark
    /// read, so a typo in a flag is reported before a file problem. A `--cluster-*` flag
    /// without clusters is refused by name (it would change nothing).
    pub fn settings(&self) -> Result<Settings> {
        let settings = self.point_settings()?;
        if settings.clusters.is_none() {
            if let Some(flag) = self.cluster_flags_given().first() {
                let grid = tiledlight_setup::table::GridLayout::of(&settings).name();
                bail!("{flag}: the clusters' settings are read only with --grid clustered (this run's grid is {grid})");
            }
        }
        Ok(settings)
    }

    /// [`Self::settings`] without the clusters' check: a lab point of a sweep over grids
    /// keeps the run's `--cluster-*` flags for its clustered points.
    fn point_settings(&self) -> Result<Settings> {
        let mut settings = self.plain_settings();
        settings.validate()?;
        if let Some(path) = &self.camera {
            settings.camera = Some(CameraBookmark { path: path.clone(), camera: bookmark::load(path)? });
        }
        Ok(settings)
    }
}

/// The lab's axes set these flags (`sweep`/`accuracy --axis NAME=VALUES`): an axis's name
/// is its flag's. A row of either settings table parses its own value.
impl Flags for SceneArgs {
    fn set_axis(&mut self, name: &str, value: &str) -> Result<()> {
        let args = self;
        if let Some(set) = args.knobs.0.set(name, value) {
            return set.map_err(anyhow::Error::msg);
        }
        if let Some(row) = tiledlight_setup::table::row(name) {
            (row.set)(&mut args.settings.0, value).map_err(anyhow::Error::msg)?;
            if name == "grid" {
                // The layout is the axis's alone: --half-z on the command line would fight it.
                args.half_z = false;
            }
            return Ok(());
        }
        let small = || -> Result<u32> {
            let n: u64 = value.parse().with_context(|| format!("{name} '{value}': expected an integer"))?;
            u32::try_from(n).with_context(|| format!("{name} {n}: too large"))
        };
        match name {
            // Read (and checked) with the other files the settings name.
            "camera" => args.camera = Some(PathBuf::from(value)),
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
                (args.settings.0.aabb, args.half_z) = match value {
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
        self.point_settings()
    }

    fn scene_label(&self) -> String {
        tiledlight_lab::axes::scene_phrase(&self.rows().scene.to_string(), self.rows().grid_objects)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat};
    use tiledlight_gpu::features::BlendMode;
    use tiledlight_lab::axes;
    use tiledlight_scene::{GridDensity, DEFAULT_LIGHT_THRESHOLD};
    use tiledlight_setup::{CasterChoice, DrawOrderMode, GridLayout, Knobs, LargeRaster, Method, Raster};

    /// The default flags with the run settings' rows changed by `f`.
    fn with(f: impl FnOnce(&mut Settings)) -> SceneArgs {
        let mut a = SceneArgs::default();
        f(&mut a.settings.0);
        a
    }

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
        for g in GridLayout::ALL {
            assert_eq!(GridLayout::of(&s(&["--grid", g.name()])), g);
            let mut settings = c.clone();
            g.apply(&mut settings);
            assert_eq!(GridLayout::of(&settings), g);
        }
        // Switching away and back keeps the clusters' options only while clustered.
        let mut settings = c.clone();
        GridLayout::Tiled.apply(&mut settings);
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
        assert!(e(SceneArgs { camera: missing.clone(), ..with(|s| s.width = 0) }).contains("--width 0"));
        let line = e(SceneArgs { camera: missing, ..SceneArgs::default() });
        assert!(line.contains("--camera /nonexistent/cam.txt: cannot read the file"), "{line}");
        assert!(with(|s| s.tile_size = 7).validate().is_err());
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
        assert!(e("tile-size=12").contains("--tile-size 12: must be 8, 16 or 32"), "{}", e("tile-size=12"));
        assert!(e("msaa=3").contains("--msaa 3: must be 1, 2, 4 or 8"), "{}", e("msaa=3"));
        assert!(e("grid=hex").contains("grid 'hex': expected one of tiled, half-z, 2.5d, clustered"));
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
        assert_eq!((a.rows().lights, a.rows().method), (Some(2), Method::TiledDeferred));
        let merged = axes::merge_axes(
            axes.clone(),
            vec![axes::parse_axis::<SceneArgs>("lights=8").unwrap(), axes::parse_axis::<SceneArgs>("seed=3").unwrap()],
        );
        assert_eq!(merged.iter().map(|a| a.values.len()).collect::<Vec<_>>(), [1, 2, 1]);
        assert!(axes::points(&[axes[0].clone(), axes[0].clone()]).is_err());
    }

    /// An axis a point's method does not read keeps its first value there: Forward+ is
    /// measured once whatever the denoiser's values, the stochastic method at each; an axis
    /// every method reads (lights) multiplies every method.
    #[test]
    fn axes_a_method_does_not_read_do_not_multiply_it() {
        let axes = vec![
            axes::parse_axis::<SceneArgs>("method=forward-plus,stochastic").unwrap(),
            axes::parse_axis::<SceneArgs>("denoise=0,2,4").unwrap(),
            axes::parse_axis::<SceneArgs>("lights=8,16").unwrap(),
        ];
        let all = axes::points(&axes).unwrap();
        let (kept, left_out) = axes::without_unread(&SceneArgs::default(), &axes, all).unwrap();
        assert_eq!((kept.len(), left_out), (2 + 6, 4));
        assert!(kept.iter().all(|p| p[0] == "stochastic" || p[1] == "0"), "{kept:?}");
        assert!(axes::unread_line(left_out).unwrap().contains("4 settings"));
        assert!(axes::unread_line(0).is_none());
        // The chart names a point by the values its method reads; the base method stands
        // where no axis names one.
        let p = |m: &str, d: &str| vec![m.to_string(), d.to_string(), "8".to_string()];
        assert_eq!(axes::series_name(&axes, &[0, 1], &p("forward-plus", "0"), Method::Stochastic), "forward-plus");
        assert_eq!(
            axes::series_name(&axes, &[0, 1], &p("stochastic", "4"), Method::ForwardPlus),
            "stochastic, denoise=4"
        );
        assert_eq!(axes::method_at(&axes[1..], &["4".into()], Method::Stochastic), Method::Stochastic);
        assert_eq!(axes::series_name(&axes[1..], &[0], &["4".into()], Method::ForwardPlus), "");
        // Every method reads the culling test's tile size: nothing is left out.
        let tiles = vec![axes[0].clone(), axes::parse_axis::<SceneArgs>("tile-size=8,16").unwrap()];
        let (kept, left_out) =
            axes::without_unread(&SceneArgs::default(), &tiles, axes::points(&tiles).unwrap()).unwrap();
        assert_eq!((kept.len(), left_out), (4, 0));
    }

    /// A `--cluster-*` flag without clusters is refused by name (it would change nothing);
    /// with `--grid clustered` it is taken.
    #[test]
    fn cluster_flags_need_the_clustered_grid() {
        let mut a = SceneArgs { cluster_tile: 32, ..SceneArgs::default() };
        let e = a.settings().unwrap_err().to_string();
        assert!(e.contains("--cluster-tile 32") && e.contains("--grid clustered"), "{e}");
        a.set_axis("grid", "half-z").unwrap();
        assert!(a.settings().unwrap_err().to_string().contains("grid is half-z"));
        let only = SceneArgs { cluster_geometry_only: true, ..SceneArgs::default() };
        assert!(only.settings().unwrap_err().to_string().starts_with("--cluster-geometry-only"));
        a.set_axis("grid", "clustered").unwrap();
        assert_eq!(a.settings().unwrap().clusters.unwrap().tile_size, 32);
        assert!(SceneArgs::default().settings().is_ok());
        // A lab point of a sweep over grids keeps the flags for its clustered points.
        let tiled = SceneArgs { cluster_tile: 32, ..SceneArgs::default() };
        assert!(Flags::settings(&tiled).is_ok());
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
        let base = with(|s| s.spot_lights = Some(8));
        let a = axes::args_at(&base, &axes, &p[p.len() - 1]).unwrap();
        assert_eq!(
            (
                a.rows().shadow_spot_lights,
                a.knobs.0.shadow_size,
                a.knobs.0.shadow_filter,
                a.knobs.0.shadow_format,
                a.rows().shadow_point_lights
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
        assert_eq!((GridLayout::of(args.rows()), args.half_z), (GridLayout::DepthMask, false));
        axes::apply(&mut args, "assign", "scatter").unwrap();
        assert!(args.rows().scatter);
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
        let on = with(|s| s.scene = SceneSource::Materials);
        assert!(axes::args_at(&on, std::slice::from_ref(&materials), &vec!["2".to_string()]).is_ok());
        let off = format!(
            "{:#}",
            axes::args_at(&SceneArgs::default(), &[materials], &vec!["2".to_string()]).map(|_| ()).unwrap_err()
        );
        assert!(off.contains("only the many-material scene"), "{off}");
        let p = axes::points(&axes).unwrap();
        assert_eq!(p.len(), 8);
        // The count parses before the grid objects it needs are known...
        let base = with(|s| s.grid_objects = 280);
        let a = axes::args_at(&base, &axes, &p[p.len() - 1]).unwrap();
        assert_eq!((a.rows().transparent_objects, a.knobs.0.blend_mode), (280, BlendMode::WeightedOit));
        // ...and is checked against them with the point's settings.
        let mut fifty = base.clone();
        fifty.settings.0.grid_objects = 50;
        let e = format!("{:#}", axes::args_at(&fifty, &axes, &p[6]).unwrap_err());
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
