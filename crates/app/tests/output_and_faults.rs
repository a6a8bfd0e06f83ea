//! Honest output and faults, end to end on the adapter `WGPU_ADAPTER_NAME` names (lavapipe
//! in CI), at 64x36 with a few lights:
//!
//! - a frame that drops lights (the light grid forced too small with the hidden
//!   `--grid-budget`) gives a `warning:` line in `render`, `bench`, `sweep` and `accuracy`,
//!   the JSON fields and CSV columns, the marks of the tables; `--strict` then fails with a
//!   non-zero exit after the output files are written;
//! - a successful headless run prints no `error` line, also without `XDG_RUNTIME_DIR`;
//! - a lost device (destroyed through the test hook `TILEDLIGHT_TEST_LOSE_DEVICE_AFTER`)
//!   is named, and a lab run keeps its CSV and resumes when run again;
//! - a request beyond an adapter limit names the limit, its value and what was asked.
//!
//! The viewer's side (the panel's warning, `--strict`) is in `viewer.rs`, which has the
//! window.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use common::{fails, gpu_lock, gpu_run, scratch, stdout, tiledlight};
use serde_json::Value;

/// 64x36 is 4x3 tiles of 16 px: 16 lights find far more than 8 (tile, light) pairs, so a
/// budget of 8 indices drops lights in every frame.
const TINY: [&str; 6] = ["--width", "64", "--height", "36", "--lights", "16"];
const SMALL_BUDGET: [&str; 2] = ["--grid-budget", "8"];

fn args<'a>(cmd: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![cmd];
    v.extend_from_slice(&TINY);
    v.extend_from_slice(&SMALL_BUDGET);
    v.extend_from_slice(rest);
    v
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The `warning:` lines of a run's stderr.
fn warnings(o: &Output) -> Vec<String> {
    stderr(o).lines().filter(|l| l.starts_with("warning: ")).map(str::to_string).collect()
}

/// Runs a command expected to fail under `--strict`; returns its output.
fn strict_fails(args: &[&str]) -> Output {
    let _guard = gpu_lock();
    let out = tiledlight(args);
    assert!(!out.status.success(), "tiledlight {args:?} succeeded with --strict:\n{}", stderr(&out));
    let err = stderr(&out);
    let last = err.lines().last().unwrap_or_default();
    assert!(last.starts_with("error: --strict: 1 warning above (the output files were written)"), "{err}");
    out
}

#[test]
fn bench_warns_of_dropped_lights_writes_them_to_json_and_strict_fails() {
    let dir = scratch("honest-bench");
    let json = dir.join("b.json");
    // Blended glass too: its own grid gets the same budget and drops too.
    let glass = ["--grid-objects", "24", "--transparent-objects", "6"];
    let mut a = args("bench", &["--frames", "6", "--warmup", "1", "--json", json.to_str().unwrap()]);
    a.extend(glass);
    let out = gpu_run(&a);
    let w = warnings(&out);
    assert_eq!(w.len(), 1, "one warning line: {}", stderr(&out));
    assert!(w[0].contains("the measured frames: light lists overflowed") && w[0].contains("DROPPED"), "{}", w[0]);
    assert!(w[0].contains("fixed budget of 8 indices (--grid-budget 8)"), "{}", w[0]);
    assert!(!stderr(&out).contains("error"), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("times of INCOMPLETE frames: DROPPED lights in"), "{text}");
    assert!(text.lines().any(|l| l.starts_with("total GPU") && l.ends_with(" *")), "{text}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("valid JSON");
    let n = |k: &str| v[k].as_u64().unwrap_or_else(|| panic!("{k} is not a count in {v}"));
    assert!(n("frames_read_back") >= 1 && n("dropped_frames") >= 1, "{v}");
    assert!(n("dropped_lights") > 0 && n("dropped_lists") > 0, "{v}");
    assert!(n("blended_dropped_lights") > 0 && n("blended_dropped_lists") > 0, "{v}");
    assert!(w[0].contains("the blended geometry's lists"), "{}", w[0]);

    // --strict: the same run fails, after writing the JSON.
    std::fs::remove_file(&json).unwrap();
    let mut a = args("bench", &["--frames", "3", "--warmup", "1", "--strict", "--json", json.to_str().unwrap()]);
    a.extend(glass);
    let out = strict_fails(&a);
    assert_eq!(warnings(&out).len(), 1, "{}", stderr(&out));
    assert!(json.exists(), "--strict fails after the JSON is written");
}

#[test]
fn bench_of_complete_frames_has_zero_drops_and_no_warning() {
    let dir = scratch("honest-bench-complete");
    let json = dir.join("b.json");
    let mut a = vec!["bench", "--frames", "4", "--warmup", "1", "--strict", "--json", json.to_str().unwrap()];
    a.extend(TINY);
    let out = gpu_run(&a);
    assert!(warnings(&out).is_empty() && !stderr(&out).contains("error"), "{}", stderr(&out));
    assert!(!stdout(&out).contains("INCOMPLETE"), "{}", stdout(&out));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!((v["dropped_lights"].as_u64(), v["dropped_frames"].as_u64()), (Some(0), Some(0)), "{v}");
    // Brute force has no light grid: null, not 0.
    let json = dir.join("bf.json");
    let mut a = vec!["bench", "--frames", "2", "--warmup", "0", "--method", "brute-force"];
    a.extend(TINY);
    a.extend(["--json", json.to_str().unwrap()]);
    gpu_run(&a);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(v["dropped_lights"].is_null() && v["dropped_frames"].is_null(), "{v}");
}

#[test]
fn render_warns_of_its_image_and_strict_fails_after_writing_it() {
    let dir = scratch("honest-render");
    let png = dir.join("r.png");
    for method in ["forward-plus", "deferred"] {
        let out = gpu_run(&args("render", &["--method", method, "--out", png.to_str().unwrap()]));
        let w = warnings(&out);
        assert_eq!(w.len(), 1, "{method}: {}", stderr(&out));
        assert!(w[0].contains(&format!("the image {}: light lists overflowed, DROPPED", png.display())), "{}", w[0]);
        let text = stdout(&out);
        assert!(text.contains("times of an INCOMPLETE frame"), "{method}: {text}");
        assert!(text.contains("DROPPED"), "the statistics line says it too: {text}");
        std::fs::remove_file(&png).unwrap();
    }
    let out = strict_fails(&args("render", &["--strict", "--out", png.to_str().unwrap()]));
    assert!(warnings(&out)[0].contains("DROPPED"), "{}", stderr(&out));
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36), "the PNG is written before --strict fails");
}

fn read_csv(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    r.records().map(|rec| header.iter().cloned().zip(rec.unwrap().iter().map(str::to_string)).collect()).collect()
}

#[test]
fn sweep_and_accuracy_mark_points_that_dropped_lights() {
    let dir = scratch("honest-lab");
    let csv = dir.join("s.csv");
    let sweep =
        args("sweep", &["--axis", "lights=8,16", "--frames", "4", "--warmup", "1", "--out", csv.to_str().unwrap()]);
    let out = gpu_run(&sweep);
    let w = warnings(&out);
    assert_eq!(w.len(), 2, "one warning per point: {}", stderr(&out));
    assert!(w[0].starts_with("warning: lights=8: the measured frames: light lists overflowed"), "{}", w[0]);
    assert!(stdout(&out).contains("ringed red"), "the chart's note: {}", stdout(&out));
    let rows = read_csv(&csv);
    for r in rows.iter().filter(|r| r["pass"] == "total") {
        let n = |k: &str| r[k].parse::<u64>().unwrap_or_else(|_| panic!("{k} = {:?}", r[k]));
        assert!(n("dropped_frames") >= 1 && n("dropped_lights") > 0 && n("dropped_lists") > 0, "{r:?}");
    }
    // --strict on a resumed run: nothing new is measured, so nothing new is warned of.
    gpu_run(&[sweep.clone(), vec!["--strict"]].concat());
    let csv2 = dir.join("s2.csv");
    let mut strict = args("sweep", &["--axis", "lights=16", "--frames", "3", "--warmup", "1", "--strict"]);
    strict.extend(["--out", csv2.to_str().unwrap()]);
    strict_fails(&strict);
    assert!(csv2.exists() && csv2.with_extension("png").exists(), "CSV and chart written before --strict fails");

    let acsv = dir.join("a.csv");
    let accuracy = args(
        "accuracy",
        &[
            "--axis",
            "threshold=0.1",
            "--axis",
            "culling=planes",
            "--frames",
            "3",
            "--warmup",
            "1",
            "--reference-frames",
            "1",
            "--out",
            acsv.to_str().unwrap(),
        ],
    );
    let out = gpu_run(&accuracy);
    let w = warnings(&out);
    assert_eq!(w.len(), 1, "{}", stderr(&out));
    assert!(w[0].contains("threshold=0.1 culling=planes: the measured frames: light lists overflowed"), "{}", w[0]);
    let rows = read_csv(&acsv);
    assert_eq!(rows.len(), 1);
    let n = |k: &str| rows[0][k].parse::<u64>().unwrap_or_else(|_| panic!("{k} = {:?}", rows[0][k]));
    assert!(n("dropped_frames") >= 1 && n("dropped_lights") > 0 && n("overflowing_lists") > 0, "{:?}", rows[0]);
}

/// Runs the binary without `XDG_RUNTIME_DIR` (the common helper sets it), one GPU run at a
/// time.
fn without_xdg(args: &[&str]) -> Output {
    let _guard = gpu_lock();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tiledlight"));
    cmd.args(args).env_remove("XDG_RUNTIME_DIR");
    cmd.output().expect("run the tiledlight binary")
}

#[test]
fn a_successful_headless_run_prints_no_error_line_without_xdg_runtime_dir() {
    // Before: lavapipe's device-select layer probed Wayland for the display's GPU, because
    // the instance enabled VK_KHR_wayland_surface, and libwayland printed four
    // "error: XDG_RUNTIME_DIR is invalid or not set in the environment." lines.
    let dir = scratch("quiet");
    let png = dir.join("q.png");
    let mut render = vec!["render", "--out", png.to_str().unwrap()];
    render.extend(TINY);
    let mut bench = vec!["bench", "--frames", "2", "--warmup", "0"];
    bench.extend(TINY);
    for a in [render, bench] {
        let out = without_xdg(&a);
        let err = stderr(&out);
        assert!(out.status.success(), "tiledlight {a:?}: {err}");
        let noisy: Vec<&str> = err.lines().filter(|l| l.to_ascii_lowercase().contains("error")).collect();
        assert!(noisy.is_empty(), "tiledlight {a:?} printed error lines on success:\n{err}");
    }
}

#[test]
fn a_lost_device_is_named_and_the_lab_resumes_after_it() {
    // The test hook destroys the device after the Nth frame of the process, as a driver
    // reset would lose it; wgpu reports the loss with the reason "destroyed".
    let dir = scratch("lost");
    let lose_after = |n: &str, a: &[&str]| {
        let _guard = gpu_lock();
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_tiledlight"));
        cmd.args(a).env("TILEDLIGHT_TEST_LOSE_DEVICE_AFTER", n).env("XDG_RUNTIME_DIR", std::env::temp_dir());
        cmd.output().expect("run the tiledlight binary")
    };
    let mut bench = vec!["bench", "--frames", "4", "--warmup", "0"];
    bench.extend(TINY);
    let out = lose_after("2", &bench);
    assert!(!out.status.success(), "bench survived a lost device: {}", stdout(&out));
    let err = stderr(&out);
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error: ")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    assert!(errors[0].contains("the GPU device was lost (destroyed by the program)"), "{err}");

    // A sweep of two points, 2 frames each, no warm-up: the device is lost at the second
    // point's first frame; the first point stays in the CSV and a rerun resumes after it.
    let csv = dir.join("l.csv");
    let mut sweep = vec!["sweep", "--axis", "lights=4,16", "--frames", "2", "--warmup", "0", "--width", "64"];
    sweep.extend(["--height", "36", "--out", csv.to_str().unwrap()]);
    let out = lose_after("3", &sweep);
    assert!(!out.status.success(), "sweep survived a lost device: {}", stdout(&out));
    let err = stderr(&out);
    let line = err.lines().find(|l| l.starts_with("error: ")).unwrap_or_default();
    assert!(
        line.contains("the GPU device was lost (destroyed by the program) at point lights=16: 1 of 2 points are in")
            && line.contains("run the same command again to resume after them"),
        "{err}"
    );
    assert_eq!(read_csv(&csv).iter().filter(|r| r["pass"] == "total").count(), 1, "the first point is kept");
    let again = stdout(&gpu_run(&sweep));
    assert!(again.contains("2 points") && again.contains("1 already in"), "{again}");
    assert_eq!(read_csv(&csv).iter().filter(|r| r["pass"] == "total").count(), 2);
}

#[test]
fn requests_beyond_an_adapter_limit_name_the_limit_and_the_value() {
    // A light-grid budget of u32::MAX indices is 16 GiB: more than any device binds.
    let _guard = gpu_lock();
    let line = fails(&["render", "--width", "64", "--height", "36", "--grid-budget", "4294967295"]);
    assert!(
        line.contains("a light-grid budget of 4294967295 indices: limit max_storage_buffer_binding_size = ")
            && line.contains(", asked for 17179869180 bytes"),
        "{line}"
    );
    // 5,000 point casters with 1024-texel faces: 16 rows of six faces a layer, 313 layers;
    // the device is given WebGPU's 256 array layers (the renderer asks no more).
    let line = fails(&[
        "render",
        "--width",
        "64",
        "--height",
        "36",
        "--lights",
        "5000",
        "--shadow-point-lights",
        "5000",
        "--shadow-size",
        "1024",
    ]);
    assert!(line.contains("limit max_texture_array_layers = ") && line.contains("asked for 313 layers"), "{line}");
}
