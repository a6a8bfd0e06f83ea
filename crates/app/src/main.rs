//! `tiledlight`: the command-line front end of the tiledlight renderers.
//!
//! - `tiledlight render ...`: one image (or heat map) of a configuration, with a report
//!   ([`render`]);
//! - `tiledlight bench ...`: per-pass GPU times over many frames, optionally as JSON;
//! - `tiledlight sweep ...`: per-pass GPU times over a grid of settings, CSV + chart;
//! - `tiledlight accuracy ...`: time and image error against the brute-force reference per
//!   setting, CSV + Pareto chart + FLIP heat maps;
//! - `tiledlight shadow-accuracy ...`: the shadow maps' error against a CPU ray-cast
//!   reference per atlas tile size, filter and format, with the atlas and shading times;
//!   JSON + Pareto chart;
//! - `tiledlight export ...`: the scene, lights and camera as one glTF file for another
//!   engine ([`export`]; the peer benchmark, `peers/bevy/`);
//! - `tiledlight peer-report DIR`: the peer benchmark's table, chart and FLIP comparison
//!   (`scripts/peer-bench.sh`);
//! - `tiledlight view ...`: the interactive viewer ([`viewer`]);
//! - `tiledlight` alone: the viewer when a display is available, else the default scene at
//!   1080p headless, image + heat map + short benchmark ([`quickstart`]).
//!
//! The measurement lab's subcommands (bench, sweep, accuracy, shadow-accuracy,
//! peer-report) are tiledlight-lab's runs; this crate has their flags
//! ([`lab_commands`]), converted into the lab's plain run structs.
//!
//! Every subcommand builds its scene, lights, camera and renderer from the same flags
//! ([`scene_setup`]), converted into tiledlight-setup's settings; that library crate
//! builds them. Every failure ends with one `error: ...` line on stderr and a
//! non-zero exit code (1 for run-time errors, 2 for unparsable flags); a result that is
//! wrong in part (a frame that dropped lights: tiledlight-lab's `dropped`) gets one `warning: ...` line,
//! an error with `--strict` once the output files are written; a successful run prints
//! no `error` line. Logging goes through env_logger (`RUST_LOG`). This module may depend
//! on all the others.

mod export;
mod lab_commands;
mod messages;
mod quickstart;
mod render;
mod scene_setup;
mod viewer;
mod vpl_args;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use lab_commands::{AccuracyArgs, BenchArgs, PeerReportArgs, ShadowAccuracyArgs, SweepArgs, TuneArgs};
use tiledlight_lab::shadow_accuracy;

use messages::{error_line, one_line};

/// Forward+ and Tiled Deferred lighting with thousands of lights: an interactive viewer,
/// headless renders and benchmarks. With no subcommand: opens the viewer when a display is
/// available; otherwise renders the default scene at 1920x1080 with 1024 lights to
/// out/render.png and out/heatmap.png and prints the pass timings.
#[derive(Parser, Debug)]
#[command(name = "tiledlight", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// No progress bars (they show only when stderr is a terminal anyway).
    #[arg(long, global = true)]
    quiet: bool,
    /// Every detail of grouped warnings (each missing image of a model, not only the count
    /// and two examples).
    #[arg(long, global = true)]
    verbose: bool,
}

/// Under `-h` of every command with the scene flags: `-h` lists the main flags of each
/// group, `--help` every flag.
const GROUPS_NOTE: &str = "-h shows the main flags of each group; --help shows every flag, grouped: scene, lights, \
     method and image, culling, shadows, VPLs, blended geometry, pass settings, input checks, output. docs/USAGE.md has \
     the commands, the demos and the lab.";

#[derive(Subcommand, Debug)]
enum Command {
    /// Render one image (or the lights-per-tile heat map) to a PNG and report on it.
    // Negative numbers are values, so `--threshold -1` gets a range error, not "unknown flag".
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    Render(render::RenderArgs),
    /// Time every pass over many frames; print a table and optionally write JSON.
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    Bench(BenchArgs),
    /// Measure per-pass GPU time over a grid of settings (--axis NAME=VALUES, or --preset
    /// figure9); write a resumable CSV and a chart.
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    Sweep(SweepArgs),
    /// Measure the speed/accuracy trade: per setting, GPU time, image error against the
    /// brute-force reference without cutoff, and culling statistics; CSV, Pareto chart and
    /// FLIP heat maps.
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    Accuracy(AccuracyArgs),
    /// Find the fastest setting within an error budget: coordinate descent over dials
    /// (method, threshold, casters, shadow atlas, culling, MSAA), each candidate measured
    /// against the traced truth; prints the setting, its time and errors, and the command
    /// lines that render it and measure it again.
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    Tune(TuneArgs),
    /// Measure the shadow maps' own error: only the shadow casters lit, brute force, each
    /// shadow configuration (atlas tile size x filter x format) against a CPU ray-cast
    /// reference, with the atlas and shading pass times; table, JSON and Pareto chart.
    // Its own default resolution: the CPU ray cast must stay affordable.
    #[command(
        allow_negative_numbers = true,
        after_help = GROUPS_NOTE,
        mut_arg("width", |a| a.default_value(shadow_accuracy::DEFAULT_SIZE.0)),
        mut_arg("height", |a| a.default_value(shadow_accuracy::DEFAULT_SIZE.1))
    )]
    ShadowAccuracy(ShadowAccuracyArgs),
    /// Write the scene, its lights (KHR_lights_punctual) and the camera that `render` with
    /// the same flags draws as one glTF file (.gltf + .bin, or .glb) for another engine.
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    Export(export::ExportArgs),
    /// Report a peer benchmark (scripts/peer-bench.sh: tiledlight and Bevy on one exported
    /// scene): frame-time table and chart, ratios, per-pass times, FLIP between the frames.
    PeerReport(PeerReportArgs),
    /// Open the interactive viewer: a window with the controls, camera and pass timings.
    #[command(allow_negative_numbers = true, after_help = GROUPS_NOTE)]
    View(viewer::ViewArgs),
}

/// A window without `XDG_RUNTIME_DIR` (a plain `ssh -X` or Xvfb session): libwayland, probed
/// by winit and Mesa, printed "error: XDG_RUNTIME_DIR is invalid or not set" on every start
/// (twice on lavapipe under Xvfb). Then a private folder of this user's (0700, in the temp
/// folder) stands in for it: nothing listens there, so the probes fail quietly and the
/// window opens on X11 as before. Called before any thread starts.
fn runtime_dir_fallback() {
    #[cfg(unix)]
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
        let Ok(uid) = std::fs::metadata("/proc/self").map(|m| m.uid()) else { return };
        let dir = std::env::temp_dir().join(format!("tiledlight-runtime-{uid}"));
        let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
        // Only a folder this user owns with no one else's access stands in.
        let ours =
            std::fs::metadata(&dir).is_ok_and(|m| m.is_dir() && m.uid() == uid && m.permissions().mode() & 0o077 == 0);
        if ours {
            std::env::set_var("XDG_RUNTIME_DIR", &dir);
        }
    }
}

/// Whether subcommand `name` has the `--demo` flag (the scene flags).
fn takes_demo(name: &str) -> bool {
    use clap::CommandFactory;
    Cli::command().find_subcommand(name).is_some_and(|c| c.get_arguments().any(|a| a.get_id() == "demo"))
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    // `--demo NAME` stands for flags of its own, put in before the user's.
    let cli = match Cli::try_parse_from(scene_setup::expand_demo(std::env::args_os().collect(), takes_demo)) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version: clap prints them as it always does.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            let text = e.render().to_string();
            // Keep the problem and clap's tips; the usage line and the pointer to --help
            // are replaced by the short hint below.
            let kept: Vec<&str> =
                text.lines().filter(|l| !l.starts_with("For more information") && !l.starts_with("Usage:")).collect();
            let msg = one_line(&kept.join("\n"));
            let msg = msg.strip_prefix("error: ").unwrap_or(&msg);
            eprintln!("error: {msg} (see --help)");
            return ExitCode::from(2);
        }
    };
    tiledlight_lab::axes::set_quiet(cli.quiet);
    tiledlight_lab::output::set_verbose(cli.verbose);
    // Headless commands: no window-system probe by Mesa's device-select layer (it prints
    // "error: XDG_RUNTIME_DIR ..." lines on machines without one). Here, before any thread.
    let headless = match &cli.command {
        Some(Command::View(_)) => false,
        Some(_) => true,
        None => !viewer::display_available(),
    };
    if headless {
        tiledlight_gpu::skip_display_gpu_probe();
    } else {
        runtime_dir_fallback();
    }
    let result = match &cli.command {
        Some(Command::Render(args)) => render::run(args),
        Some(Command::Bench(args)) => args.run(),
        Some(Command::Sweep(args)) => args.run(),
        Some(Command::Accuracy(args)) => args.run(),
        Some(Command::Tune(args)) => {
            // The command line after the subcommand, for the commands that reproduce the answer.
            let all: Vec<String> = std::env::args().collect();
            let after = all.iter().position(|a| a == "tune").map_or(all.len(), |i| i + 1);
            args.run(&all[after..])
        }
        Some(Command::ShadowAccuracy(args)) => args.run(),
        Some(Command::Export(args)) => export::run(args),
        Some(Command::PeerReport(args)) => args.run(),
        Some(Command::View(args)) => viewer::run(args),
        None => viewer::run_default(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_line(&e));
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_is_consistent() {
        Cli::command().debug_assert();
    }

    /// The manual (`docs/USAGE.md`) names every flag of every subcommand (hidden test hooks
    /// aside).
    #[test]
    fn usage_documents_every_flag() {
        let usage = include_str!("../../../docs/USAGE.md");
        let mut missing = Vec::new();
        for sub in Cli::command().get_subcommands() {
            for a in sub.get_arguments() {
                // Hidden flags are test hooks, not the manual's business.
                let Some(long) = a.get_long().filter(|_| !a.is_hide_set()) else { continue };
                if !matches!(long, "help" | "version") && !usage.contains(&format!("--{long}")) {
                    missing.push(format!("{} --{long}", sub.get_name()));
                }
            }
        }
        assert!(missing.is_empty(), "docs/USAGE.md never mentions {missing:?}");
    }

    /// `--demo` works through the real parser: its flags, then the user's.
    #[test]
    fn a_demo_parses_with_the_users_flags_winning() {
        let argv = ["tiledlight", "render", "--demo", "shadows", "--grid-objects", "8"].map(std::ffi::OsString::from);
        let cli = Cli::try_parse_from(scene_setup::expand_demo(argv.to_vec(), takes_demo)).unwrap();
        assert!(takes_demo("render") && takes_demo("view") && !takes_demo("peer-report") && !takes_demo("x"));
        let Some(Command::Render(r)) = cli.command else { panic!("not render") };
        assert_eq!(
            (r.scene.rows().lights, r.scene.rows().grid_objects, r.scene.rows().shadow_point_lights),
            (Some(0), 8, 6)
        );
        assert_eq!(r.scene.demo.as_deref(), Some("shadows"));
        let e = Cli::try_parse_from(["tiledlight", "render", "--demo", "sparkles"]).unwrap_err().to_string();
        assert!(e.contains("sparkles") && e.contains("shadows"), "{e}");
    }

    #[test]
    fn messages_become_one_line() {
        assert_eq!(one_line("a\n\n  b  \nc"), "a b c");
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        let e = anyhow::Error::new(io).context("x: cannot read: gone").context("loading");
        assert_eq!(error_line(&e), "loading: x: cannot read: gone");
    }

    #[test]
    fn flags_parse() {
        let cli = Cli::try_parse_from([
            "tiledlight",
            "render",
            "--lights",
            "5",
            "--method",
            "brute-force-no-cutoff",
            "--tile-size",
            "32",
            "--heatmap",
            "--out",
            "x.png",
            "--density",
            "high",
        ])
        .unwrap();
        let Some(Command::Render(r)) = cli.command else { panic!("not render") };
        assert_eq!(r.scene.rows().lights, Some(5));
        assert_eq!(r.scene.rows().method, tiledlight_setup::Method::BruteForce { cutoff: false });
        assert_eq!(r.scene.rows().tile_size, 32);
        assert_eq!(r.heatmap, Some(render::HeatmapArg::Opaque));
        let cli = Cli::try_parse_from(["tiledlight", "render", "--heatmap", "blended", "--out", "x.png"]).unwrap();
        let Some(Command::Render(r)) = cli.command else { panic!("not render") };
        assert_eq!(
            (r.heatmap, r.out.as_deref()),
            (Some(render::HeatmapArg::Blended), Some(std::path::Path::new("x.png")))
        );
        let cli = Cli::try_parse_from(["tiledlight", "render", "--heatmap", "vpl"]).unwrap();
        let Some(Command::Render(r)) = cli.command else { panic!("not render") };
        assert_eq!(r.heatmap, Some(render::HeatmapArg::Vpl));
        assert!(Cli::try_parse_from(["tiledlight", "render", "--heatmap", "transparent"]).is_err());
        let cli = Cli::try_parse_from(["tiledlight", "bench", "--frames", "3", "--json", "a.json"]).unwrap();
        let Some(Command::Bench(b)) = cli.command else { panic!("not bench") };
        assert_eq!((b.frames, b.warmup), (3, 20));
        assert_eq!(b.scene.rows().width, 1920);
        assert!(Cli::try_parse_from(["tiledlight"]).unwrap().command.is_none());
        // shadow-accuracy's own resolution default; the other subcommands keep 1920x1080.
        let cli =
            Cli::try_parse_from(["tiledlight", "shadow-accuracy", "--config", "512x3", "--config", "128x1"]).unwrap();
        let Some(Command::ShadowAccuracy(s)) = cli.command else { panic!("not shadow-accuracy") };
        assert_eq!((s.scene.rows().width, s.scene.rows().height, s.configs.len()), (960, 540, 2));
        let cli = Cli::try_parse_from(["tiledlight", "shadow-accuracy", "--width", "320"]).unwrap();
        let Some(Command::ShadowAccuracy(s)) = cli.command else { panic!("not shadow-accuracy") };
        assert_eq!((s.scene.rows().width, s.scene.rows().height), (320, 540));
        let cli = Cli::try_parse_from(["tiledlight", "render"]).unwrap();
        let Some(Command::Render(r)) = cli.command else { panic!("not render") };
        assert_eq!(r.scene.rows().width, 1920);
        let cli = Cli::try_parse_from(["tiledlight", "export", "--lights", "7", "--out", "a.glb"]).unwrap();
        let Some(Command::Export(x)) = cli.command else { panic!("not export") };
        assert_eq!((x.scene.rows().lights, x.out.as_path()), (Some(7), std::path::Path::new("a.glb")));
        assert!(Cli::try_parse_from(["tiledlight", "export"]).is_err(), "--out is required");
    }
}
