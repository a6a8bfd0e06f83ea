//! The flags of the measurement lab's subcommands (`bench`, `sweep`, `accuracy`, `tune`,
//! `shadow-accuracy`, `peer-report`) and their conversion into tiledlight-lab's plain run
//! structs; the runs themselves are the lab's. The scene flags reach the lab as
//! [`SceneArgs`], which implements the lab's `Flags` (in [`crate::scene_setup`]).
//!
//! May depend on [`crate::scene_setup`] and tiledlight-lab.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};
use tiledlight_lab::accuracy::{self, ReferenceKind, VplReference};
use tiledlight_lab::{bench, peer_report, shadow_accuracy, sweep, tune};

use crate::scene_setup::SceneArgs;

/// Flags of `tiledlight bench`.
#[derive(Args, Clone, Debug)]
pub struct BenchArgs {
    /// Scene, lights, screen and renderer.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Measured frames.
    #[arg(long, default_value_t = 200, value_name = "N")]
    pub frames: u32,
    /// Frames rendered before measuring (pipeline warm-up, caches, clocks).
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub warmup: u32,
    /// Also write the results as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Move the lights before every frame (warm-up and measured), as the viewer's animation
    /// does: the shadow faces of every caster are drawn again each frame, so the shadow
    /// pass is measured with moving lights (without it, still lights' faces are drawn once,
    /// before the measured frames).
    #[arg(long)]
    pub move_lights: bool,
}

impl BenchArgs {
    /// Runs `tiledlight bench`.
    pub fn run(&self) -> Result<()> {
        let job = bench::Bench {
            frames: self.frames,
            warmup: self.warmup,
            json: self.json.clone(),
            move_lights: self.move_lights,
        };
        bench::run(&self.scene, &job)
    }
}

/// Named sweeps (`--preset`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// AMD's Figure 9: frame time vs light count (32 to 16,384, denser around the
    /// sample's 1,792-light crossover; down to 32 because on an H100 the crossover lies
    /// below 256), Forward+ and Tiled Deferred, the default scene plus 280 medium grid
    /// objects (748,980 triangles), 4 G-buffer targets.
    Figure9,
}

/// Flags of `tiledlight sweep`.
#[derive(Args, Clone, Debug)]
pub struct SweepArgs {
    /// Scene, lights, screen and renderer: the settings every point starts from.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// An axis to vary, NAME=VALUES (every name: `tiledlight_lab::axes::axis_help`).
    #[arg(long = "axis", value_name = "NAME=VALUES", help = tiledlight_lab::axes::axis_help())]
    pub axes: Vec<String>,
    /// A named sweep; --axis replaces its axes of the same name.
    #[arg(long, value_enum)]
    pub preset: Option<PresetArg>,
    /// Measured frames per point (the median of each pass is recorded).
    #[arg(long, default_value_t = 30, value_name = "N")]
    pub frames: u32,
    /// Frames rendered before measuring each point.
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub warmup: u32,
    /// CSV output; an existing file with the same columns is resumed (points already in it
    /// are skipped) [default: out/sweep.csv, or out/PRESET.csv].
    #[arg(long, value_name = "FILE.csv")]
    pub out: Option<PathBuf>,
    /// Chart output [default: the CSV path with .png].
    #[arg(long, value_name = "FILE.png")]
    pub chart: Option<PathBuf>,
    /// The axis on the chart's x [default: the first numeric axis with several values].
    #[arg(long, value_name = "AXIS")]
    pub x: Option<String>,
}

impl SweepArgs {
    /// Runs `tiledlight sweep`.
    pub fn run(&self) -> Result<()> {
        let job = sweep::Sweep {
            axes: self.axes.clone(),
            preset: self.preset.map(|p| match p {
                PresetArg::Figure9 => sweep::Preset::Figure9,
            }),
            frames: self.frames,
            warmup: self.warmup,
            out: self.out.clone(),
            chart: self.chart.clone(),
            x: self.x.clone(),
        };
        sweep::run(&self.scene, &job)
    }
}

/// Flags of `tiledlight accuracy`.
#[derive(Args, Clone, Debug)]
pub struct AccuracyArgs {
    /// Scene, lights, screen and renderer: the settings every point starts from.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A setting to vary, NAME=VALUES [default: threshold=0.4,0.2,...,0.0001 (13 values) and
    /// culling=planes,aabb,half-z]. Given axes replace default ones of the same name and add
    /// to the others.
    #[arg(long = "axis", value_name = "NAME=VALUES", help = format!(
        "A setting to vary, NAME=VALUES [default: threshold=0.4,0.2,...,0.0001 (13 values) and \
         culling=planes,aabb,half-z]. Given axes replace default ones of the same name and add to the others. Names: {}",
        tiledlight_lab::axes::axis_names()
    ))]
    pub axes: Vec<String>,
    /// Measured frames per setting.
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub frames: u32,
    /// Frames rendered before measuring each setting.
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub warmup: u32,
    /// Measured frames of the brute-force reference (slow: every light for every pixel).
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub reference_frames: u32,
    /// Degrees a frame the camera orbits the scene's vertical axis (through its centre)
    /// during the measured frames, ending at the view the reference shows; the warm-up
    /// stands still where the orbit starts. The error of a camera in motion: what the
    /// stochastic method's history does while the view changes (its frames' mean starts
    /// again each frame; `--temporal N` reuses reservoirs across the move). 0: still.
    #[arg(long, default_value_t = 0.0, value_name = "DEG", allow_negative_numbers = true)]
    pub camera_orbit: f32,
    /// Keep references on disk in DIR: a reference an earlier run rendered with the same
    /// scene, lights, screen and shaders is read from there instead of rendered again (the
    /// traced truth of a million lights takes minutes). Clear DIR after changing the code
    /// that places lights or builds the scene.
    #[arg(long, value_name = "DIR")]
    pub reference_cache: Option<PathBuf>,
    /// The reference: `no-cutoff` (brute force, plain inverse-square: what the radius
    /// cutoff costs is part of the error) or `cutoff` (brute force with the same radii:
    /// the error is only what the method's other approximations cost, e.g. the G-buffer's
    /// 8-bit albedo or the MSAA edge test, which the cutoff's error would swamp). The
    /// reference has the setting's MSAA.
    #[arg(long, value_enum, default_value_t = ReferenceArg::NoCutoff)]
    pub reference: ReferenceArg,
    /// With VPLs, the RSM size of the reference (every texel a VPL): `Nx` for N times the
    /// setting's own (1x, 2x, 4x, 8x; at most 512 texels a side), or a size for every
    /// setting (4..512), so that an RSM-size axis is measured against one reference and
    /// the RSM size's own error shows. 1x: the setting's own RSM, whose error is then only
    /// block, thresholds, cap, model and culling.
    #[arg(long, default_value = "1x", value_name = "Nx|SIZE", value_parser = accuracy::parse_vpl_reference)]
    pub vpl_reference_rsm: VplReference,
    /// The FLIP mean the recommendation must stay under.
    #[arg(long, default_value_t = 0.01, value_name = "E")]
    pub target_flip: f64,
    /// The error budget: change one axis at a time from the base (each axis's first value)
    /// instead of trying every combination, one chart curve per axis; with `--reference
    /// traced` each setting's error against the truth splits by cause. Only the given axes
    /// (no default threshold and culling axes: the flags' own values are the base's).
    #[arg(long)]
    pub budget: bool,
    /// CSV output, resumed when it exists with the same columns [default: out/accuracy.csv].
    #[arg(long, value_name = "FILE.csv")]
    pub out: Option<PathBuf>,
    /// Pareto chart [default: the CSV path with .png].
    #[arg(long, value_name = "FILE.png")]
    pub chart: Option<PathBuf>,
    /// Directory of the FLIP heat maps of the frontier's settings [default: the CSV path
    /// without extension, plus "-flip"].
    #[arg(long, value_name = "DIR")]
    pub diff_dir: Option<PathBuf>,
}

/// What the settings are compared with (`--reference`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReferenceArg {
    /// Brute force without the radius cutoff.
    NoCutoff,
    /// Brute force with the same radius cutoff as the setting.
    Cutoff,
    /// The traced reference: every light, no cutoff, each shadowed by a ray (the truth
    /// that unshadowed lights, shadow maps and the cutoff are measured against).
    Traced,
}

impl AccuracyArgs {
    /// Runs `tiledlight accuracy`.
    pub fn run(&self) -> Result<()> {
        let job = accuracy::Accuracy {
            axes: self.axes.clone(),
            frames: self.frames,
            warmup: self.warmup,
            reference_frames: self.reference_frames,
            camera_orbit: self.camera_orbit,
            reference_cache: self.reference_cache.clone(),
            reference: match self.reference {
                ReferenceArg::NoCutoff => ReferenceKind::NoCutoff,
                ReferenceArg::Cutoff => ReferenceKind::Cutoff,
                ReferenceArg::Traced => ReferenceKind::Traced,
            },
            vpl_reference_rsm: self.vpl_reference_rsm,
            target_flip: self.target_flip,
            budget: self.budget,
            out: self.out.clone(),
            chart: self.chart.clone(),
            diff_dir: self.diff_dir.clone(),
        };
        accuracy::run(&self.scene, &job)
    }
}

/// Flags of `tiledlight tune`.
#[derive(Args, Clone, Debug)]
pub struct TuneArgs {
    /// Scene, lights and screen: what is tuned for (the dials' values replace these flags'
    /// own).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The FLIP mean (against the traced truth) the setting must stay under.
    #[arg(long, value_name = "E")]
    pub target_flip: f64,
    /// Also keep FLIP's 99th percentile under this.
    #[arg(long, value_name = "P")]
    pub target_p99: Option<f64>,
    /// Also keep the worst pixel's HDR error (relative to the truth's 99.9th-percentile
    /// value, the accuracy CSV's `max_error`) under this.
    #[arg(long, value_name = "W")]
    pub max_worst: Option<f64>,
    /// A dial to search, NAME=VALUES (axis names as for `sweep`), the first value where the
    /// search starts [default: method=deferred,visibility,forward-plus;
    /// threshold=0.0015,...; shadow-point-lights=16,0,64,256; casters-by; shadow-size;
    /// shadow-filter; aabb; msaa].
    #[arg(long = "dial", value_name = "NAME=VALUES")]
    pub dials: Vec<String>,
    /// Measured frames per candidate (the time is their median).
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub frames: u32,
    /// Frames rendered before measuring each candidate.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub warmup: u32,
    /// Measured frames of the truth.
    #[arg(long, default_value_t = 2, value_name = "N")]
    pub reference_frames: u32,
    /// Most passes over the dials.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub passes: u32,
    /// CSV of every candidate, resumed when it exists with the same dials [default:
    /// out/tune.csv].
    #[arg(long, value_name = "FILE.csv")]
    pub out: Option<PathBuf>,
    /// Camera bookmarks (files the viewer's "save camera" writes) the budget must hold
    /// from: every candidate is measured from each and judged by its worst view (slowest
    /// time, largest error) [default: the scene flags' camera].
    #[arg(long, value_name = "A,B,...", value_delimiter = ',', conflicts_with = "camera")]
    pub bookmarks: Vec<PathBuf>,
}

/// `tune`'s own flags that take a value (left out of the reproducing command lines).
const TUNE_FLAGS: [&str; 10] = [
    "--bookmarks",
    "--target-flip",
    "--target-p99",
    "--max-worst",
    "--dial",
    "--frames",
    "--warmup",
    "--reference-frames",
    "--passes",
    "--out",
];

/// The scene flags of a `tune` command line (`args`, after the subcommand) without the
/// tuner's own flags and without the flags the dials set (`dials`: their names).
pub fn scene_flags(args: &[String], dials: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let a = &args[i];
        let name = a.split('=').next().unwrap_or(a);
        let dial = name.strip_prefix("--").is_some_and(|n| dials.iter().any(|d| d == n));
        if TUNE_FLAGS.contains(&name) || dial {
            // The value is the next argument unless given as --flag=value, or the flag is
            // a bare switch (a dial like --aabb: the next argument is another flag).
            let takes_next = !a.contains('=') && args.get(i + 1).is_some_and(|n| !n.starts_with("--"));
            i += if takes_next { 2 } else { 1 };
            continue;
        }
        out.push(a.clone());
        i += 1;
    }
    out
}

impl TuneArgs {
    /// Runs `tiledlight tune`; `cli` is the command line after `tune`, for the commands
    /// that reproduce the answer.
    pub fn run(&self, cli: &[String]) -> Result<()> {
        let job = tune::Tune {
            constraints: tune::Constraints { flip: self.target_flip, p99: self.target_p99, worst: self.max_worst },
            dials: self.dials.clone(),
            frames: self.frames,
            warmup: self.warmup,
            reference_frames: self.reference_frames,
            passes: self.passes,
            out: self.out.clone(),
            bookmarks: self.bookmarks.clone(),
        };
        let answer = tune::run(&self.scene, &job)?;
        println!("result:     {}", answer.summary());
        let names: Vec<String> = answer.dials.iter().map(|d| d.name.clone()).collect();
        let scene = scene_flags(cli, &names).join(" ");
        let sep = if scene.is_empty() { "" } else { " " };
        let render = tune::render_flags(&answer.dials, &answer.point).join(" ");
        let mut axes: Vec<String> =
            answer.dials.iter().zip(&answer.point).map(|(d, v)| format!("--axis {}={v}", d.name)).collect();
        // From each view: the first bookmark's render, every view measured.
        let camera = answer.views.first().map(|v| format!(" --camera {v}")).unwrap_or_default();
        if !answer.views.is_empty() {
            axes.push(format!("--axis camera={}", answer.views.join(",")));
        }
        println!("render it:  tiledlight render{sep}{scene} {render}{camera}");
        println!("measure it: tiledlight accuracy{sep}{scene} --reference traced {}", axes.join(" "));
        Ok(())
    }
}

/// Flags of `tiledlight shadow-accuracy`.
#[derive(Args, Clone, Debug)]
pub struct ShadowAccuracyArgs {
    /// Scene, lights and screen [default here: 960x540, 12 point + 12 spot casters, 128
    /// spot lights]. Only the casters are lit; the method is brute force and MSAA must be
    /// 1; --shadow-size/--shadow-filter/--shadow-format are replaced by --config.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A shadow configuration to measure, `TILExFILTER[:FORMAT]` (e.g. 512x3, 1024x5:d32;
    /// FORMAT d16 or d32, default d16); repeat for several [default: 128, 256, 512 and
    /// 1024 times 1, 3 and 5 with d16, and 1024x5:d32].
    #[arg(long = "config", value_name = "TILExFILTER[:FORMAT]")]
    pub configs: Vec<String>,
    /// Measured frames per configuration (the lights move before each, so every shadow
    /// face is drawn in each).
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub frames: u32,
    /// Frames rendered before measuring each configuration.
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub warmup: u32,
    /// The reference's ray offset: a ray from a surface point starts this fraction of its
    /// distance to the light off the surface, along the normal (and stops as far short of
    /// the light), so the surface does not shadow itself.
    #[arg(long, default_value_t = 1e-3, value_name = "F")]
    pub ray_offset: f32,
    /// JSON output [default: out/shadow-accuracy.json].
    #[arg(long, value_name = "FILE.json")]
    pub out: Option<PathBuf>,
    /// Pareto chart [default: the JSON path with .png].
    #[arg(long, value_name = "FILE.png")]
    pub chart: Option<PathBuf>,
    /// Directory of the reference image (tonemapped), and of the FLIP heat maps and the
    /// misplaced light (red: lost, green: leaked) of the frontier's configurations
    /// [default: the JSON path without extension, plus "-images"].
    #[arg(long, value_name = "DIR")]
    pub diff_dir: Option<PathBuf>,
}

impl ShadowAccuracyArgs {
    /// Runs `tiledlight shadow-accuracy`.
    pub fn run(&self) -> Result<()> {
        let job = shadow_accuracy::ShadowAccuracy {
            configs: self.configs.clone(),
            frames: self.frames,
            warmup: self.warmup,
            ray_offset: self.ray_offset,
            out: self.out.clone(),
            chart: self.chart.clone(),
            diff_dir: self.diff_dir.clone(),
        };
        shadow_accuracy::run(&self.scene, &job)
    }
}

/// Flags of `tiledlight peer-report`.
#[derive(Args, Clone, Debug)]
pub struct PeerReportArgs {
    /// The folder with the peer benchmark's JSON and PNG files (`SCENE.CONFIG.rK.json`,
    /// `SCENE.CONFIG.png`: `scripts/peer-bench.sh`'s archives unpacked).
    pub dir: PathBuf,
    /// Where the report, chart and heat maps go (default: DIR).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

impl PeerReportArgs {
    /// Runs `tiledlight peer-report`.
    pub fn run(&self) -> Result<()> {
        peer_report::run(&self.dir, self.out.as_deref())
    }
}
