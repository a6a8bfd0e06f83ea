//! End-to-end tests of the measurement lab (`tiledlight sweep`, `tiledlight accuracy`) on
//! the adapter `WGPU_ADAPTER_NAME` names (lavapipe in CI), at 160x96 with 2-3 values per
//! axis: the CSV parses with the expected columns and finite numbers, a resumed run skips
//! the points already measured, the charts are valid PNGs, and error does not rise as the
//! intensity threshold falls. Bad lab input fails before any GPU work.

mod common;

use std::collections::HashMap;
use std::path::Path;

use common::{fails, gpu_run, scratch, stdout};

const SMALL: [&str; 8] = ["--width", "160", "--height", "96", "--frames", "2", "--warmup", "1"];

/// The CSV as (header, rows of column name -> value).
fn read_csv(path: &Path) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r
        .records()
        .map(|rec| {
            let rec = rec.expect("well-formed CSV record");
            assert_eq!(rec.len(), header.len(), "a row of another width");
            header.iter().cloned().zip(rec.iter().map(str::to_string)).collect()
        })
        .collect();
    (header, rows)
}

fn num(row: &HashMap<String, String>, col: &str) -> f64 {
    let v = &row[col];
    v.parse().unwrap_or_else(|_| panic!("{col} = '{v}' is not a number"))
}

/// A PNG that decodes, of the chart size.
fn assert_png(path: &Path) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: not a readable PNG: {e}", path.display()));
    assert!(img.width() >= 160 && img.height() >= 96, "{}: {}x{}", path.display(), img.width(), img.height());
}

#[test]
fn sweep_figure9_preset_end_to_end_and_resume() {
    let dir = scratch("sweep");
    let csv = dir.join("f9.csv");
    let out_arg = csv.to_str().unwrap();
    // The preset's scene with only 2 grid objects and 2 light counts, to stay fast on a CPU.
    let mut args = vec!["sweep", "--preset", "figure9", "--axis", "lights=16,64", "--axis", "grid-objects=2"];
    args.extend(SMALL);
    args.extend(["--out", out_arg]);
    let first = stdout(&gpu_run(&args));
    assert!(first.contains("4 points") && first.contains("0 already"), "{first}");
    assert!(first.contains("crossover") || first.contains("no crossover in range"), "{first}");
    let (header, rows) = read_csv(&csv);
    for col in ["adapter", "lights", "method", "grid-objects", "gbuffer-rts", "pass", "median_ms", "frames"] {
        assert!(header.iter().any(|h| h == col), "column {col} missing from {header:?}");
    }
    let totals: Vec<_> = rows.iter().filter(|r| r["pass"] == "total").collect();
    assert_eq!(totals.len(), 4, "one total per point");
    for t in &totals {
        let passes: Vec<_> = rows
            .iter()
            .filter(|r| r["pass"] != "total" && r["lights"] == t["lights"] && r["method"] == t["method"])
            .collect();
        let expect: &[&str] = if t["method"] == "deferred" {
            &["deferred.gbuffer", "deferred.shade", "tonemap"]
        } else {
            &["depth_prepass", "forward.cull", "forward.shade", "tonemap"]
        };
        for p in expect {
            assert!(passes.iter().any(|r| r["pass"] == *p), "{}: no {p} row", t["method"]);
        }
        let sum: f64 = passes.iter().map(|r| num(r, "median_ms")).sum();
        let total = num(t, "median_ms");
        assert!(total.is_finite() && total > 0.0, "total {total}");
        assert!((sum - total).abs() < 1e-3 * passes.len() as f64, "total {total} vs sum of passes {sum}");
        assert_eq!(t["grid-objects"], "2");
        assert!(num(t, "triangles") > 0.0);
        assert!(passes.iter().all(|r| num(r, "frames") == 2.0 && num(r, "min_ms") <= num(r, "max_ms")));
    }
    assert_png(&dir.join("f9.png"));

    // A second run with one more light count measures only the two new points.
    let mut args = vec!["sweep", "--preset", "figure9", "--axis", "lights=16,64,128", "--axis", "grid-objects=2"];
    args.extend(SMALL);
    args.extend(["--out", out_arg]);
    let second = stdout(&gpu_run(&args));
    assert!(second.contains("6 points") && second.contains("4 already"), "{second}");
    let (_, rows) = read_csv(&csv);
    let totals: Vec<_> = rows.iter().filter(|r| r["pass"] == "total").map(|r| (&r["lights"], &r["method"])).collect();
    assert_eq!(totals.len(), 6, "{totals:?}");
    let unique: std::collections::HashSet<_> = totals.iter().collect();
    assert_eq!(unique.len(), 6, "a point measured twice: {totals:?}");
}

#[test]
fn accuracy_end_to_end_error_falls_with_the_threshold() {
    let dir = scratch("accuracy");
    let csv = dir.join("acc.csv");
    let mut args = vec![
        "accuracy",
        "--lights",
        "64",
        "--axis",
        "threshold=0.4,0.1,0.025",
        "--axis",
        "culling=planes,aabb",
        "--reference-frames",
        "1",
        "--out",
        csv.to_str().unwrap(),
    ];
    args.extend(SMALL);
    let out = stdout(&gpu_run(&args));
    assert!(out.contains("6 settings") && out.contains("frontier:"), "{out}");
    let (_, rows) = read_csv(&csv);
    assert_eq!(rows.len(), 6);
    let numeric = [
        "total_ms",
        "psnr_db",
        "flip_mean",
        "flip_p99",
        "flip_max",
        "max_error",
        "energy_lost",
        "mean_lights_per_tile",
        "false_positive_rate",
        "wasted_per_pixel",
        "evaluated_per_pixel",
        "reference_ms",
    ];
    for r in &rows {
        for c in numeric {
            assert!(num(r, c).is_finite(), "{c} = {} not finite", r[c]);
        }
        assert!((0.0..=1.0).contains(&num(r, "flip_mean")) && num(r, "flip_mean") <= num(r, "flip_p99") + 1e-6);
        assert!((0.0..=1.0).contains(&num(r, "false_positive_rate")));
        assert!(num(r, "wasted_per_pixel") <= num(r, "evaluated_per_pixel"));
        assert!(num(r, "energy_lost") > -1e-4 && num(r, "energy_lost") < 1.0, "energy lost {}", r["energy_lost"]);
    }
    let at = |t: &str, c: &str| rows.iter().find(|r| r["threshold"] == t && r["culling"] == c).expect("row");
    for culling in ["planes", "aabb"] {
        // Thresholds in falling order: radii grow, so every pixel gets closer to the
        // reference: error must not rise, evaluations must not fall.
        let series: Vec<_> = ["0.4", "0.1", "0.025"].iter().map(|t| at(t, culling)).collect();
        for w in series.windows(2) {
            let (a, b) = (w[0], w[1]);
            let ctx = format!("{culling}: T {} -> {}", a["threshold"], b["threshold"]);
            assert!(num(b, "flip_mean") <= num(a, "flip_mean") + 1e-6, "{ctx}: FLIP mean rose");
            assert!(num(b, "psnr_db") >= num(a, "psnr_db") - 1e-6, "{ctx}: PSNR fell");
            assert!(num(b, "energy_lost") <= num(a, "energy_lost") + 1e-6, "{ctx}: energy lost rose");
            assert!(num(b, "max_error") <= num(a, "max_error") + 1e-6, "{ctx}: max error rose");
            assert!(num(b, "evaluated_per_pixel") >= num(a, "evaluated_per_pixel"), "{ctx}: fewer evaluations");
        }
        assert!(num(series[2], "flip_mean") < num(series[0], "flip_mean"), "{culling}: the threshold changed nothing");
    }
    for t in ["0.4", "0.1", "0.025"] {
        let (p, a) = (at(t, "planes"), at(t, "aabb"));
        // Both tests are conservative: the same image up to summation order.
        assert!((num(p, "flip_mean") - num(a, "flip_mean")).abs() < 1e-3, "T {t}: culling changed the image");
        assert!(
            num(a, "false_positive_rate") <= num(p, "false_positive_rate") + 1e-9,
            "T {t}: AABB added false positives"
        );
        assert!(num(a, "mean_lights_per_tile") <= num(p, "mean_lights_per_tile") + 1e-9);
    }
    assert_png(&dir.join("acc.png"));
    let maps: Vec<_> = std::fs::read_dir(dir.join("acc-flip")).expect("heat map directory").collect();
    assert!(!maps.is_empty(), "no FLIP heat map written");
    for m in maps {
        assert_png(&m.unwrap().path());
    }
}

/// The MSAA edge test's dial, measured against brute force 4x with the same cutoff (so only
/// the edge test and the G-buffer's precision are left in the error): Forward+ 4x equals
/// that reference (FLIP mean < 1e-3: culling is exact); for Tiled Deferred 4x the edge
/// pixels can only fall as the off-plane tolerance grows, and the error stays within the
/// no-MSAA deferred bound (FLIP mean 0.015, tests/tests/deferred.rs).
#[test]
fn accuracy_msaa_edge_threshold_against_the_same_cutoff() {
    let dir = scratch("accuracy-msaa");
    let csv = dir.join("acc.csv");
    let mut args = vec![
        "accuracy",
        "--lights",
        "64",
        "--msaa",
        "4",
        "--reference",
        "cutoff",
        "--axis",
        "threshold=0.1",
        "--axis",
        "culling=aabb",
        "--axis",
        "method=forward-plus,deferred",
        "--axis",
        "edge-distance=0.0005,0.05",
        "--reference-frames",
        "1",
        "--out",
        csv.to_str().unwrap(),
    ];
    args.extend(SMALL);
    stdout(&gpu_run(&args));
    let (_, rows) = read_csv(&csv);
    assert_eq!(rows.len(), 4);
    let at = |m: &str, e: &str| rows.iter().find(|r| r["method"] == m && r["edge-distance"] == e).expect("row");
    for e in ["0.0005", "0.05"] {
        let f = num(at("forward-plus", e), "flip_mean");
        assert!(f < 1e-3, "Forward+ 4x vs brute force 4x with the same cutoff: FLIP mean {f}");
        let d = num(at("deferred", e), "flip_mean");
        assert!(d < 0.015, "Tiled Deferred 4x, edge distance {e}: FLIP mean {d}");
        assert!(at("forward-plus", e)["edge_pixels"].is_empty(), "Forward+ has no edge test");
    }
    let (tight, loose) = (num(at("deferred", "0.0005"), "edge_pixels"), num(at("deferred", "0.05"), "edge_pixels"));
    assert!(tight >= loose && tight > 0.0, "edge pixels {tight} (0.0005) vs {loose} (0.05)");
}

#[test]
fn bad_lab_input_is_one_clear_error() {
    assert!(fails(&["sweep", "--axis", "colour=1,2"]).contains("unknown axis 'colour'"));
    assert!(fails(&["sweep"]).contains("nothing to sweep"));
    assert!(fails(&["sweep", "--axis", "lights="]).contains("empty sweep"));
    assert!(fails(&["sweep", "--axis", "tile-size=12"]).contains("--tile-size 12"));
    assert!(fails(&["sweep", "--axis", "lights=1..1e9:99999"]).contains("step count"));
    assert!(fails(&["sweep", "--axis", "lights=4", "--frames", "0"]).contains("--frames 0"));
    assert!(fails(&["sweep", "--axis", "lights=4", "--chart", "x.svg"]).contains("only .png"));
    assert!(fails(&["sweep", "--axis", "lights=4", "--x", "method"]).contains("--x method"));
    assert!(fails(&["accuracy", "--axis", "method=brute-force-no-cutoff"]).contains("reference itself"));
    assert!(fails(&["accuracy", "--target-flip", "2"]).contains("--target-flip"));
}
