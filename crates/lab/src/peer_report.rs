//! `tiledlight peer-report DIR`: the report of a peer benchmark (`scripts/peer-bench.sh`,
//! tiledlight and Bevy on one exported scene; `peers/bevy/README.md`). Reads the folder the
//! script's per-count archives unpack to and writes, into `--out` (default: DIR):
//!
//! 1. `peer-report.md` (also printed): GPU frame time per light count and run, the ratios of
//!    Bevy's best run to tiledlight's best Forward+ and best Tiled Deferred, per-pass
//!    medians, the adapter and versions; a run that dropped lights (tiledlight) or measured
//!    fewer frames than asked (Bevy) is starred with a footnote;
//! 2. `peer-frame-time.png`: frame time against light count, one line per run (log axes);
//! 3. FLIP of Bevy's frames against tiledlight's (`flip-*.png` heat maps at half size): the
//!    two BRDFs differ, so this shows both light the same places, not that they are equal;
//!    Bevy against Bevy (matched vs. with a prepass) is the baseline of the same renderer.
//!
//! No GPU. May depend on [`crate::chart`], [`crate::output`], tiledlight-metrics,
//! image and serde_json.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};
use serde_json::Value;

use crate::chart::{self, AxisSpec, LineChart, Scale, Series};

/// Which renderer a run is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Who {
    Bevy,
    ForwardPlus,
    Deferred,
}

/// The runs `scripts/peer-bench.sh` makes, by file prefix, in table order.
const RUNS: [(&str, &str, Who); 8] = [
    ("bevy", "Bevy default (4x MSAA, TonyMcMapface)", Who::Bevy),
    ("bevy-matched", "Bevy matched (no MSAA, ACES)", Who::Bevy),
    ("bevy-prepass", "Bevy matched + depth prepass", Who::Bevy),
    ("bevy-clusters", "Bevy + prepass, 65,536 fixed clusters", Who::Bevy),
    ("tl-fp", "tiledlight Forward+", Who::ForwardPlus),
    ("tl-fp-2.5d", "tiledlight Forward+ 2.5D", Who::ForwardPlus),
    ("tl-td", "tiledlight Tiled Deferred", Who::Deferred),
    ("tl-td-2.5d", "tiledlight Tiled Deferred 2.5D", Who::Deferred),
];

/// Image pairs compared by FLIP: (reference run, test run, what it shows).
const FLIP_PAIRS: [(&str, &str, &str); 4] = [
    ("bevy-prepass", "tl-fp", "Bevy (+ prepass) vs tiledlight Forward+"),
    ("bevy-prepass", "tl-td", "Bevy (+ prepass) vs tiledlight Tiled Deferred"),
    ("tl-fp", "tl-td", "tiledlight Forward+ vs Tiled Deferred"),
    ("bevy-matched", "bevy-prepass", "Bevy matched vs Bevy + prepass (same renderer)"),
];

/// One run at one light count.
#[derive(Clone, Debug)]
struct Run {
    /// GPU frame time, ms.
    ms: f64,
    /// Per pass (name, median ms).
    passes: Vec<(String, f64)>,
    /// Why this run's time is suspect (dropped lights, frames missing), if it is.
    flag: Option<String>,
    json: Value,
}

fn number(v: &Value, key: &str, file: &Path) -> Result<f64> {
    v[key].as_f64().with_context(|| format!("{}: no number \"{key}\"", file.display()))
}

fn read_run(file: &Path, who: Who) -> Result<Run> {
    let text = std::fs::read_to_string(file).with_context(|| format!("reading {}", file.display()))?;
    let json: Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", file.display()))?;
    let (ms, passes, flag) = if who == Who::Bevy {
        let ms = number(&json, "gpu_frame_ms_median", file)?;
        let passes = json["passes"].as_object().with_context(|| format!("{}: no \"passes\" object", file.display()))?;
        let passes =
            passes.iter().map(|(k, v)| Ok((k.clone(), number(v, "median_ms", file)?))).collect::<Result<_>>()?;
        let (got, asked) = (json["gpu_frames_measured"].as_u64(), json["frames"].as_u64());
        let flag = match (got, asked) {
            (Some(g), Some(a)) if g < a => Some(format!("GPU times of {g} of {a} frames")),
            _ => None,
        };
        (ms, passes, flag)
    } else {
        let ms = number(&json, "total_gpu_median_ms", file)?;
        let passes = json["passes"].as_array().with_context(|| format!("{}: no \"passes\" list", file.display()))?;
        let passes = passes
            .iter()
            .map(|p| {
                let name = p["pass"].as_str().with_context(|| format!("{}: a pass without a name", file.display()))?;
                Ok((name.to_string(), number(p, "median_ms", file)?))
            })
            .collect::<Result<_>>()?;
        let dropped = json["dropped_frames"].as_u64().unwrap_or(0);
        let flag = (dropped > 0).then(|| format!("{dropped} frames dropped lights"));
        (ms, passes, flag)
    };
    ensure!(ms.is_finite() && ms > 0.0, "{}: frame time {ms} ms is not a positive number", file.display());
    Ok(Run { ms, passes, flag, json })
}

/// The light counts present: N of every `PREFIX-N.json` of a known run.
fn light_counts(dir: &Path) -> Result<Vec<u64>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("reading the folder {}", dir.display()))?;
    let mut counts = BTreeSet::new();
    for e in entries {
        let name = e.with_context(|| format!("reading the folder {}", dir.display()))?.file_name();
        let Some(stem) = name.to_str().and_then(|n| n.strip_suffix(".json")) else { continue };
        let Some((prefix, n)) = stem.rsplit_once('-') else { continue };
        if RUNS.iter().any(|r| r.0 == prefix) {
            if let Ok(n) = n.parse::<u64>() {
                counts.insert(n);
            }
        }
    }
    ensure!(
        !counts.is_empty(),
        "{}: no peer benchmark results (bevy-N.json, tl-fp-N.json, ...): unpack scripts/peer-bench.sh's peer-N.tar.gz here",
        dir.display()
    );
    Ok(counts.into_iter().collect())
}

/// Every run at every count: `table[count][run]`.
struct Results {
    counts: Vec<u64>,
    table: Vec<Vec<Option<Run>>>,
}

impl Results {
    fn read(dir: &Path) -> Result<Self> {
        let counts = light_counts(dir)?;
        let mut table = Vec::new();
        for &n in &counts {
            let mut row = Vec::new();
            for (prefix, _, who) in RUNS {
                let file = dir.join(format!("{prefix}-{n}.json"));
                row.push(if file.exists() { Some(read_run(&file, who)?) } else { None });
            }
            table.push(row);
        }
        let mut res = Self { counts, table };
        res.flag_from_summary(dir)?;
        Ok(res)
    }

    /// Marks the runs `scripts/peer-bench.sh`'s summary.txt (in DIR or the folder above it,
    /// where the script leaves it) warns about ("  warning: bevy-prepass-1000: Bevy resized
    /// its cluster lists inside the measured frames") or names as failed ("FAILED
    /// (tl-fp-1000-png): exit 124"): their JSON alone does not show it.
    fn flag_from_summary(&mut self, dir: &Path) -> Result<()> {
        let Some(file) = [dir.join("summary.txt"), dir.join("../summary.txt")].into_iter().find(|f| f.is_file()) else {
            return Ok(());
        };
        let text = std::fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?;
        for line in text.lines().map(str::trim) {
            let (label, why) = if let Some(rest) = line.strip_prefix("warning: ") {
                match rest.split_once(": ") {
                    Some((label, why)) => (label, why.to_string()),
                    None => continue,
                }
            } else if let Some(rest) = line.strip_prefix("FAILED (") {
                match rest.split_once(')') {
                    Some((label, why)) => (label, format!("failed{why}")),
                    None => continue,
                }
            } else {
                continue;
            };
            let label = label.strip_suffix("-png").unwrap_or(label);
            let Some((prefix, n)) = label.rsplit_once('-') else { continue };
            let (Some(r), Ok(n)) = (RUNS.iter().position(|r| r.0 == prefix), n.parse::<u64>()) else { continue };
            let Some(i) = self.counts.iter().position(|&c| c == n) else { continue };
            if let Some(run) = self.table[i][r].as_mut() {
                let why = format!("{why} (summary.txt)");
                run.flag = Some(match run.flag.take() {
                    Some(before) => format!("{before}; {why}"),
                    None => why,
                });
            }
        }
        Ok(())
    }

    /// The fastest run of `who` at count index `i`: (run index, ms).
    fn best(&self, i: usize, who: Who) -> Option<(usize, f64)> {
        (0..RUNS.len())
            .filter(|&r| RUNS[r].2 == who)
            .filter_map(|r| self.table[i][r].as_ref().map(|x| (r, x.ms)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The first present run's JSON field, as text.
    fn field(&self, who: Who, path: &[&str]) -> Option<String> {
        self.table.iter().flatten().enumerate().find_map(|(k, r)| {
            let r = r.as_ref()?;
            (RUNS[k % RUNS.len()].2 == who).then_some(())?;
            let mut v = &r.json;
            for p in path {
                v = &v[*p];
            }
            match v {
                Value::String(s) => Some(s.clone()),
                Value::Null => None,
                other => Some(other.to_string()),
            }
        })
    }
}

fn ms(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.1}")
    } else if v >= 10.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// The markdown report (without the FLIP table) and the footnotes' count.
fn tables(res: &Results) -> String {
    let mut md = String::new();
    let present: Vec<usize> = (0..RUNS.len()).filter(|&r| res.table.iter().any(|row| row[r].is_some())).collect();
    let _ = writeln!(md, "## GPU frame time, ms (median)\n");
    let head: Vec<&str> = present.iter().map(|&r| RUNS[r].1).collect();
    let _ =
        writeln!(md, "| lights | {} | Bevy best / Forward+ best | Bevy best / Tiled Deferred best |", head.join(" | "));
    let _ = writeln!(md, "| ---: |{} ---: | ---: |", " ---: |".repeat(present.len()));
    let mut notes = Vec::new();
    for (i, &n) in res.counts.iter().enumerate() {
        let mut cells = Vec::new();
        for &r in &present {
            cells.push(match &res.table[i][r] {
                None => "-".to_string(),
                Some(run) => match &run.flag {
                    None => ms(run.ms),
                    Some(why) => {
                        notes.push(format!("{} at {n} lights: {why}", RUNS[r].1));
                        format!("{}*{}", ms(run.ms), notes.len())
                    }
                },
            });
        }
        let bevy = res.best(i, Who::Bevy);
        let ratio = |who| match (bevy, res.best(i, who)) {
            (Some((_, b)), Some((_, t))) => format!("{:.2}x", b / t),
            _ => "-".to_string(),
        };
        let _ =
            writeln!(md, "| {n} | {} | {} | {} |", cells.join(" | "), ratio(Who::ForwardPlus), ratio(Who::Deferred));
    }
    for (k, note) in notes.iter().enumerate() {
        let _ = writeln!(md, "\n*{}: {note}", k + 1);
    }
    let _ = writeln!(md, "\n## Per pass, ms (median)\n");
    let _ = writeln!(md, "| lights | run | passes |");
    let _ = writeln!(md, "| ---: | --- | --- |");
    for (i, &n) in res.counts.iter().enumerate() {
        for &r in &present {
            if let Some(run) = &res.table[i][r] {
                let p: Vec<String> = run.passes.iter().map(|(k, v)| format!("{k} {}", ms(*v))).collect();
                let _ = writeln!(md, "| {n} | {} | {} |", RUNS[r].1, p.join(", "));
            }
        }
    }
    md
}

/// Decodes a PNG as RGBA8.
fn load_rgba(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let img = image::open(path).with_context(|| format!("reading the image {}", path.display()))?.to_rgba8();
    Ok((img.width(), img.height(), img.into_raw()))
}

/// Mean Rec. 709 luma of an RGBA8 sRGB image's encoded values, 0..1.
fn mean_luma(rgba: &[u8]) -> f64 {
    let n = (rgba.len() / 4).max(1) as f64;
    rgba.chunks_exact(4).map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64).sum::<f64>()
        / (255.0 * n)
}

/// Mean luma of every run's frame at one light count (None: no frame).
type LumaRow = (u64, [Option<f64>; RUNS.len()]);

/// The mean luma table: one row per count, one column per run with a frame.
fn luma_table(rows: &[LumaRow]) -> String {
    let mut md = String::new();
    let present: Vec<usize> = (0..RUNS.len()).filter(|&r| rows.iter().any(|row| row.1[r].is_some())).collect();
    if present.is_empty() {
        return md;
    }
    let _ = writeln!(
        md,
        "\nMean luma of the frames (Rec. 709 weights on the encoded sRGB values, 0..1): a difference in overall \
         brightness raises FLIP on every pixel, even where the light falls alike.\n"
    );
    let head: Vec<&str> = present.iter().map(|&r| RUNS[r].1).collect();
    let _ = writeln!(md, "| lights | {} |", head.join(" | "));
    let _ = writeln!(md, "| ---: |{}", " ---: |".repeat(present.len()));
    for (n, row) in rows {
        let cells: Vec<String> = present.iter().map(|&r| row[r].map_or("-".into(), |v| format!("{v:.3}"))).collect();
        let _ = writeln!(md, "| {n} | {} |", cells.join(" | "));
    }
    md
}

/// One FLIP comparison: mean and 99th percentile as rendered, and mean after matching
/// the test image's tone curve to the reference's.
struct FlipRow {
    count: u64,
    what: &'static str,
    mean: f32,
    p99: f32,
    matched_mean: f32,
    heat: PathBuf,
}

/// Per light count, every run's frame decoded once: its mean luma, and FLIP of the pairs
/// in [`FLIP_PAIRS`] (heat maps written to `out`).
fn compare_frames(res: &Results, dir: &Path, out: &Path) -> Result<(Vec<FlipRow>, Vec<LumaRow>)> {
    let (mut rows, mut lumas) = (Vec::new(), Vec::new());
    for &n in &res.counts {
        let path = |prefix: &str| dir.join(format!("{prefix}-{n}.png"));
        let frames: Vec<Option<(u32, u32, Vec<u8>)>> = RUNS
            .iter()
            .map(|(prefix, _, _)| path(prefix).exists().then(|| load_rgba(&path(prefix))).transpose())
            .collect::<Result<_>>()?;
        lumas.push((n, std::array::from_fn(|r| frames[r].as_ref().map(|f| mean_luma(&f.2)))));
        let frame = |prefix: &str| RUNS.iter().position(|r| r.0 == prefix).and_then(|r| frames[r].as_ref());
        for (a, b, what) in FLIP_PAIRS {
            let (Some((wa, ha, ra)), Some((wb, hb, rb))) = (frame(a), frame(b)) else { continue };
            let (wa, ha) = (*wa, *ha);
            ensure!(
                (wa, ha) == (*wb, *hb),
                "{} is {wa}x{ha} but {} is {wb}x{hb}: FLIP compares images of one size",
                path(a).display(),
                path(b).display()
            );
            let map = tiledlight_metrics::flip(wa, ha, ra, rb);
            let s = map.summary(0.99);
            let matched =
                tiledlight_metrics::flip(wa, ha, ra, &tiledlight_metrics::histogram::match_histograms(ra, rb))
                    .summary(0.99);
            let heat = image::RgbImage::from_raw(wa, ha, map.heat_rgb()).context("building the FLIP heat map")?;
            let half = image::imageops::resize(&heat, (wa / 2).max(1), (ha / 2).max(1), image::imageops::Triangle);
            let heat_path = out.join(format!("flip-{a}-vs-{b}-{n}.png"));
            crate::output::save_png(&heat_path, &half)?;
            rows.push(FlipRow {
                count: n,
                what,
                mean: s.mean,
                p99: s.percentile,
                matched_mean: matched.mean,
                heat: heat_path,
            });
        }
    }
    Ok((rows, lumas))
}

/// 1, 2 and 5 times each power of ten from below the smallest value to above the largest.
fn ticks_125(values: &[f64]) -> Vec<f64> {
    let (lo, hi) = values.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if !(lo.is_finite() && lo > 0.0) {
        return vec![1.0];
    }
    let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let ticks: Vec<f64> = (d0..=d1)
        .flat_map(|d| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(d)))
        .filter(|&t| t >= lo / 2.0 && t <= hi * 2.0)
        .collect();
    if ticks.is_empty() {
        vec![lo]
    } else {
        ticks
    }
}

fn chart(res: &Results, path: &Path, adapter: &str) -> Result<()> {
    let times: Vec<f64> = res.table.iter().flatten().flatten().map(|r| r.ms).collect();
    let mut series = Vec::new();
    for (r, (_, label, _)) in RUNS.iter().enumerate() {
        let mut points = Vec::new();
        let mut incomplete = Vec::new();
        for (i, &n) in res.counts.iter().enumerate() {
            if let Some(run) = &res.table[i][r] {
                points.push((n as f64, run.ms));
                if run.flag.is_some() {
                    incomplete.push((n as f64, run.ms));
                }
            }
        }
        if !points.is_empty() {
            series.push(Series { name: label.to_string(), points, incomplete });
        }
    }
    let c = LineChart {
        // The adapter's name without the backend and driver, which the report lists.
        title: format!(
            "tiledlight and Bevy, one scene: GPU frame time, {}",
            adapter.split(" (").next().unwrap_or(adapter)
        ),
        subtitle: "courtyard, uniform random point lights, one exported glTF; median of the measured frames".into(),
        x: AxisSpec {
            label: "point lights".into(),
            scale: Scale::Log,
            ticks: Some(res.counts.iter().map(|&n| n as f64).collect()),
        },
        // 1-2-5 ticks in every decade the times span: the automatic ones label decades only
        // when the times span more than two, and Tiled Deferred's 2-3 ms would have none.
        y: AxisSpec { label: "GPU frame time, ms".into(), scale: Scale::Log, ticks: Some(ticks_125(&times)) },
        series,
        marker: None,
        note: None,
        categories: None,
    };
    chart::line_chart(path, &c)
}

/// Runs `tiledlight peer-report DIR [--out OUT]`: reads `dir`, writes the report, chart
/// and heat maps to `out` (default: `dir`).
pub fn run(dir: &Path, out: Option<&Path>) -> Result<()> {
    if !dir.is_dir() {
        bail!("{}: no such folder (unpack scripts/peer-bench.sh's peer-N.tar.gz archives into one)", dir.display());
    }
    let out = out.unwrap_or(dir).to_path_buf();
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let res = Results::read(dir)?;
    let adapter = res.field(Who::Bevy, &["adapter"]).or_else(|| res.field(Who::ForwardPlus, &["config", "adapter"]));
    let adapter = adapter.unwrap_or_else(|| "adapter not recorded".into());
    let mut md = String::from("# Peer benchmark: tiledlight and Bevy on one scene\n\n");
    let size = res.field(Who::ForwardPlus, &["config", "resolution"]).unwrap_or_else(|| "?".into());
    let _ = writeln!(md, "- adapter: {adapter}");
    let _ = writeln!(md, "- resolution: {size}");
    let _ = writeln!(
        md,
        "- tiledlight commit: {}",
        res.field(Who::ForwardPlus, &["config", "commit"]).unwrap_or_else(|| "not recorded".into())
    );
    let _ =
        writeln!(md, "- Bevy: {}", res.field(Who::Bevy, &["bevy_version"]).unwrap_or_else(|| "not recorded".into()));
    let _ = writeln!(md, "- light counts: {:?}\n", res.counts);
    md.push_str(&tables(&res));
    let (rows, lumas) = compare_frames(&res, dir, &out)?;
    if !rows.is_empty() {
        let _ = writeln!(md, "\n## FLIP between the frames (0 = the same, 1 = as different as can be)\n");
        let _ = writeln!(md, "| lights | images | mean | 99th percentile | mean, tone curves matched | heat map |");
        let _ = writeln!(md, "| ---: | --- | ---: | ---: | ---: | --- |");
        for r in &rows {
            let heat = r.heat.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            let _ = writeln!(
                md,
                "| {} | {} | {:.4} | {:.4} | {:.4} | {heat} |",
                r.count, r.what, r.mean, r.p99, r.matched_mean
            );
        }
        let _ = writeln!(
            md,
            "\nThe renderers' BRDFs, spot falloffs and tonemappers differ (Bevy's Filament BRDF and ACES fit against \
             tiledlight's), so FLIP between them shows whether both light the same places, not equality. \
             \"Tone curves matched\" remaps the second image's channels to the first's histograms (a monotone \
             per-channel curve: exposure, tonemapper, gain) before FLIP, so what remains is where the light falls. \
             Forward+ against Tiled Deferred is the floor of one renderer's two methods, Bevy against itself \
             (matched vs. with a prepass) the floor of the same frame."
        );
        md.push_str(&luma_table(&lumas));
    }
    let chart_path = out.join("peer-frame-time.png");
    chart(&res, &chart_path, &adapter)?;
    let report = out.join("peer-report.md");
    std::fs::write(&report, &md).with_context(|| format!("writing {}", report.display()))?;
    print!("{md}");
    println!("\nwrote {}, {} and {} FLIP heat maps", report.display(), chart_path.display(), rows.len());
    Ok(())
}
