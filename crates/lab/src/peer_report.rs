//! `tiledlight peer-report DIR`: the report of a peer benchmark (`scripts/peer-bench.sh`
//! with `PHASE=final`: tiledlight and Bevy on the same exported scenes;
//! `peers/bevy/README.md`). Reads the folder its archives unpack to: one JSON per run,
//! `SCENE.CONFIG.rK.json` (configuration CONFIG of scene SCENE, repeat K), one frame per
//! scene and configuration, `SCENE.CONFIG.png` (the first repeat's), and the script's
//! `clocks.csv` and `summary.txt` from DIR or the folder above. Writes into `--out`
//! (default: DIR):
//!
//! 1. `peer-report.md` (also printed):
//!    1. per scene and configuration, the GPU frame time from the frame's first command to
//!       its last: each run's median, then the median over the repeats with their spread.
//!       Both sides' timers hold the untimed passes (Bevy's deferred lighting pass has no
//!       diagnostics span of its own), so this, not the sum of the pass times, is compared;
//!    2. the ratios: Bevy's forward renderer against tiledlight's Forward+ (both shade in
//!       fragment shaders: like for like), Bevy's deferred against Tiled Deferred (a
//!       fragment lighting pass against a compute one, with the breakdown beside it), the
//!       early-outs' ablation (tiledlight without them against with them, and Bevy against
//!       tiledlight without them), and what tuning Bevy's cluster grid gained;
//!    3. Bevy's prepare phase on the CPU (its per-frame uploads) and CPU frame time;
//!    4. per-pass medians of each configuration's first repeat;
//!    5. the GPU's clocks, temperature and power around the runs (`clocks.csv`);
//!    6. a run that dropped lights (tiledlight), measured fewer frames than asked or
//!       resized its cluster lists while measured (Bevy), or failed (`summary.txt`) is
//!       starred with a footnote;
//! 2. `peer-frame-time.png`: frame time against light count over the `court-N` scenes, one
//!    line per configuration (log axes);
//! 3. FLIP of every Bevy frame against tiledlight's Forward+ frame of its scene
//!    (`flip-*.png` heat maps at half size), and tiledlight's Forward+ against its Tiled
//!    Deferred (the floor of one renderer's two methods): the BRDFs differ, so this shows
//!    that both light the same places, not that they are equal.
//!
//! No GPU. May depend on [`crate::chart`], [`crate::output`], tiledlight-metrics,
//! image and serde_json.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};
use serde_json::Value;

use crate::bench::Summary;
use crate::chart::{self, AxisSpec, LineChart, Scale, Series};

/// What a configuration is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Who {
    BevyForward,
    BevyDeferred,
    ForwardPlus,
    Deferred,
    ForwardPlusAblation,
    DeferredAblation,
}

impl Who {
    fn is_bevy(self) -> bool {
        matches!(self, Who::BevyForward | Who::BevyDeferred)
    }
}

impl Who {
    /// What a run's JSON says it is: bevy-peer's `renderer` and `method`, or tiledlight
    /// bench's `config.method` and `config.early_outs`.
    fn of_json(json: &Value, file: &Path) -> Result<Self> {
        if json["renderer"] == "bevy" {
            return Ok(if json["method"] == "deferred" { Who::BevyDeferred } else { Who::BevyForward });
        }
        let early_outs = json["config"]["early_outs"].as_bool().unwrap_or(true);
        match (json["config"]["method"].as_str(), early_outs) {
            (Some("forward-plus"), true) => Ok(Who::ForwardPlus),
            (Some("forward-plus"), false) => Ok(Who::ForwardPlusAblation),
            (Some("deferred"), true) => Ok(Who::Deferred),
            (Some("deferred"), false) => Ok(Who::DeferredAblation),
            (m, _) => bail!(
                "{}: neither a bevy-peer run nor a tiledlight Forward+ or Tiled Deferred bench (config.method {m:?})",
                file.display()
            ),
        }
    }
}

/// The configurations `scripts/peer-bench.sh` runs, in table order: (name, label).
/// Others found in the folder are reported after these, by their names.
const KNOWN: [(&str, &str); 8] = [
    ("bevy-fwd-default", "Bevy forward, default grid"),
    ("bevy-fwd-tuned", "Bevy forward, tuned grid"),
    ("bevy-def-tuned", "Bevy deferred, tuned grid"),
    ("tl-fp", "tiledlight Forward+"),
    ("tl-fp-2.5d", "tiledlight Forward+ 2.5D"),
    ("tl-td", "tiledlight Tiled Deferred"),
    ("tl-fp-noeo", "tiledlight Forward+, no early-outs"),
    ("tl-td-noeo", "tiledlight Tiled Deferred, no early-outs"),
];

/// A configuration: its name, its label ([`KNOWN`]'s, else its name) and its kind (from
/// its runs' JSON).
#[derive(Clone, Debug, PartialEq)]
struct Config {
    name: String,
    label: String,
    who: Who,
}

impl Config {
    fn new(name: &str, who: Who) -> Self {
        let label = KNOWN.iter().find(|k| k.0 == name).map_or(name, |k| k.1);
        Self { name: name.into(), label: label.into(), who }
    }

    fn order(&self) -> usize {
        KNOWN.iter().position(|k| k.0 == self.name).unwrap_or(KNOWN.len())
    }
}

/// One run (one repeat of a configuration on a scene).
#[derive(Clone, Debug)]
struct Run {
    /// GPU ms from the frame's first command to its last (median over the run's frames).
    frame_ms: f64,
    /// The sum of the pass times (Bevy: median over frames of the frame's timed spans;
    /// tiledlight: the sum of the passes' medians).
    passes_ms: f64,
    /// Per pass (name, median ms).
    passes: Vec<(String, f64)>,
    /// Bevy: CPU ms of the render world's prepare phase (median).
    prepare_cpu_ms: Option<f64>,
    /// CPU ms a frame (median).
    cpu_frame_ms: Option<f64>,
    /// Why this run's time is suspect, if it is.
    flag: Option<String>,
    json: Value,
}

fn number(v: &Value, key: &str, file: &Path) -> Result<f64> {
    v[key].as_f64().with_context(|| format!("{}: no number \"{key}\"", file.display()))
}

/// One run's JSON: what it is and what it measured.
fn read_run(file: &Path) -> Result<(Who, Run)> {
    let text = std::fs::read_to_string(file).with_context(|| format!("reading {}", file.display()))?;
    let json: Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", file.display()))?;
    let who = Who::of_json(&json, file)?;
    let frame_ms = json["frame_gpu_first_to_last"]["median_ms"].as_f64().with_context(|| {
        format!(
            "{}: no \"frame_gpu_first_to_last\" median: run it again with today's {}",
            file.display(),
            if who.is_bevy() { "bevy-peer" } else { "tiledlight bench" }
        )
    })?;
    let (passes_ms, passes, flag, prepare_cpu_ms, cpu_frame_ms) = if who.is_bevy() {
        let ms = number(&json, "gpu_frame_ms_median", file)?;
        let passes = json["passes"].as_object().with_context(|| format!("{}: no \"passes\" object", file.display()))?;
        let passes =
            passes.iter().map(|(k, v)| Ok((k.clone(), number(v, "median_ms", file)?))).collect::<Result<_>>()?;
        let (got, asked) = (json["gpu_frames_measured"].as_u64(), json["frames"].as_u64());
        let flag = match (got, asked) {
            (Some(g), Some(a)) if g < a => Some(format!("GPU times of {g} of {a} frames")),
            _ => None,
        };
        (ms, passes, flag, json["prepare_cpu"]["median_ms"].as_f64(), json["cpu_frame_ms_median"].as_f64())
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
        (ms, passes, flag, None, json["cpu_frame"]["median_ms"].as_f64())
    };
    ensure!(
        frame_ms.is_finite() && frame_ms > 0.0 && passes_ms.is_finite() && passes_ms > 0.0,
        "{}: frame time {frame_ms} ms (passes {passes_ms} ms) is not a positive number",
        file.display()
    );
    Ok((who, Run { frame_ms, passes_ms, passes, prepare_cpu_ms, cpu_frame_ms, flag, json }))
}

/// Every repeat of one configuration on one scene, in repeat order.
#[derive(Clone, Debug, Default)]
struct Cell {
    runs: Vec<(u32, Run)>,
}

impl Cell {
    /// Median, smallest and largest over the repeats of `f` (None: no repeat has it).
    fn summary_of(&self, f: impl Fn(&Run) -> Option<f64>) -> Option<Summary> {
        Summary::of(&self.runs.iter().filter_map(|(_, r)| f(r)).collect::<Vec<_>>())
    }
    /// Median over the repeats of `f`.
    fn median_of(&self, f: impl Fn(&Run) -> Option<f64>) -> Option<f64> {
        self.summary_of(f).map(|s| s.median_ms)
    }
    /// The frame time over the repeats.
    fn frame(&self) -> Summary {
        self.summary_of(|r| Some(r.frame_ms)).expect("a cell has a run")
    }
    fn frame_ms(&self) -> f64 {
        self.frame().median_ms
    }
    fn flags(&self) -> Vec<String> {
        self.runs.iter().filter_map(|(k, r)| r.flag.as_ref().map(|f| format!("repeat {k}: {f}"))).collect()
    }
    fn first(&self) -> &Run {
        &self.runs[0].1
    }
}

/// Every run found: `cells[(scene, config)]`.
struct Results {
    scenes: Vec<String>,
    configs: Vec<Config>,
    cells: BTreeMap<(String, String), Cell>,
}

/// Scenes in report order: `court-N` by N, then the others by name.
fn scene_key(s: &str) -> (u8, u64, String) {
    match s.strip_prefix("court-").and_then(|n| n.parse::<u64>().ok()) {
        Some(n) => (0, n, String::new()),
        None => (1, 0, s.to_string()),
    }
}

impl Results {
    fn read(dir: &Path) -> Result<Self> {
        let entries = std::fs::read_dir(dir).with_context(|| format!("reading the folder {}", dir.display()))?;
        let mut found = Vec::new();
        for e in entries {
            let name = e.with_context(|| format!("reading the folder {}", dir.display()))?.file_name();
            let Some(stem) = name.to_str().and_then(|n| n.strip_suffix(".json")) else { continue };
            // SCENE.CONFIG.rK: the scene has no dot; the configuration may ("tl-fp-2.5d").
            let Some((rest, rep)) = stem.rsplit_once(".r") else { continue };
            let Ok(rep) = rep.parse::<u32>() else { continue };
            let Some((scene, config)) = rest.split_once('.') else { continue };
            found.push((scene.to_string(), config.to_string(), rep, dir.join(&name)));
        }
        ensure!(
            !found.is_empty(),
            "{}: no peer benchmark results (SCENE.CONFIG.rK.json): unpack scripts/peer-bench.sh's peer-SCENE.tar.gz \
             archives here",
            dir.display()
        );
        found.sort_by(|a, b| (scene_key(&a.0), &a.1, a.2).cmp(&(scene_key(&b.0), &b.1, b.2)));
        let mut res = Self { scenes: Vec::new(), configs: Vec::new(), cells: BTreeMap::new() };
        for (scene, config, rep, file) in found {
            let (who, run) = read_run(&file)?;
            if !res.scenes.contains(&scene) {
                res.scenes.push(scene.clone());
            }
            match res.configs.iter().find(|c| c.name == config) {
                None => res.configs.push(Config::new(&config, who)),
                Some(c) => ensure!(
                    c.who == who,
                    "{}: a {who:?} run, but the other runs of {config} are {:?}",
                    file.display(),
                    c.who
                ),
            }
            res.cells.entry((scene, config)).or_default().runs.push((rep, run));
        }
        res.configs.sort_by_key(|c| (c.order(), c.name.clone()));
        res.flag_from_summary(dir)?;
        Ok(res)
    }

    fn cell(&self, scene: &str, config: &str) -> Option<&Cell> {
        self.cells.get(&(scene.to_string(), config.to_string()))
    }

    /// Marks the runs `scripts/peer-bench.sh`'s summary.txt (in DIR or the folder above it)
    /// warns about ("  warning: court-1000.bevy-fwd-default.r1: Bevy resized its cluster
    /// lists inside the measured frames") or names as failed ("FAILED
    /// (court-1000.tl-fp.r1-png): exit 124"): their JSON alone does not show it.
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
            let Some((rest, rep)) = label.rsplit_once(".r") else { continue };
            let (Ok(rep), Some((scene, config))) = (rep.parse::<u32>(), rest.split_once('.')) else { continue };
            let Some(cell) = self.cells.get_mut(&(scene.to_string(), config.to_string())) else { continue };
            if let Some((_, run)) = cell.runs.iter_mut().find(|(k, _)| *k == rep) {
                let why = format!("{why} (summary.txt)");
                run.flag = Some(match run.flag.take() {
                    Some(before) => format!("{before}; {why}"),
                    None => why,
                });
            }
        }
        Ok(())
    }

    /// The fastest configuration of `who` on `scene`: (config, median frame ms).
    fn best(&self, scene: &str, who: Who) -> Option<(&Config, f64)> {
        self.configs
            .iter()
            .filter(|c| c.who == who)
            .filter_map(|c| self.cell(scene, &c.name).map(|cell| (c, cell.frame_ms())))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The first run's JSON field of a configuration of `bevy` (or not), as text.
    fn field(&self, bevy: bool, path: &[&str]) -> Option<String> {
        self.cells.iter().find_map(|((_, config), cell)| {
            self.configs.iter().find(|c| c.name == *config).filter(|c| c.who.is_bevy() == bevy)?;
            let mut v = &cell.first().json;
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

fn ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) => format!("{:.2}x", a / b),
        _ => "-".into(),
    }
}

/// The frame-time table, the ratios, the deferred breakdown, Bevy's CPU side and the
/// per-pass table.
fn tables(res: &Results) -> String {
    let mut md = String::new();
    let mut notes = Vec::new();
    let _ = writeln!(
        md,
        "## GPU frame time, ms: first command to last, median over the repeats [fastest - slowest repeat]\n"
    );
    let head: Vec<&str> = res.configs.iter().map(|c| c.label.as_str()).collect();
    let _ = writeln!(md, "| scene | {} |", head.join(" | "));
    let _ = writeln!(md, "| --- |{}", " ---: |".repeat(res.configs.len()));
    for s in &res.scenes {
        let mut cells = Vec::new();
        for c in &res.configs {
            cells.push(match res.cell(s, &c.name) {
                None => "-".to_string(),
                Some(cell) => {
                    let f = cell.frame();
                    let mut text = format!("{} [{} - {}]", ms(f.median_ms), ms(f.min_ms), ms(f.max_ms));
                    let flags = cell.flags();
                    if !flags.is_empty() {
                        notes.push(format!("{} on {s}: {}", c.label, flags.join("; ")));
                        text.push_str(&format!(" *{}", notes.len()));
                    }
                    if cell.runs.len() < 3 {
                        text.push_str(&format!(
                            " ({} repeat{})",
                            cell.runs.len(),
                            if cell.runs.len() == 1 { "" } else { "s" }
                        ));
                    }
                    text
                }
            });
        }
        let _ = writeln!(md, "| {s} | {} |", cells.join(" | "));
    }
    for (k, note) in notes.iter().enumerate() {
        let _ = writeln!(md, "\n*{}: {note}", k + 1);
    }

    let _ = writeln!(md, "\n## Ratios (frame times above)\n");
    let _ = writeln!(
        md,
        "| scene | Bevy forward best / Forward+ best (both fragment-shaded) | Bevy deferred best / Tiled Deferred \
         best (fragment vs compute lighting) | Forward+ without / with early-outs | Bevy forward best / Forward+ \
         without early-outs | Tiled Deferred without / with early-outs | Bevy forward: default / tuned grid |"
    );
    let _ = writeln!(md, "| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for s in &res.scenes {
        let best = |w| res.best(s, w).map(|b| b.1);
        let of = |name: &str| res.cell(s, name).map(Cell::frame_ms);
        let _ = writeln!(
            md,
            "| {s} | {} | {} | {} | {} | {} | {} |",
            ratio(best(Who::BevyForward), best(Who::ForwardPlus)),
            ratio(best(Who::BevyDeferred), best(Who::Deferred)),
            ratio(of("tl-fp-noeo"), of("tl-fp")),
            ratio(best(Who::BevyForward), of("tl-fp-noeo")),
            ratio(of("tl-td-noeo"), of("tl-td")),
            ratio(of("bevy-fwd-default"), of("bevy-fwd-tuned")),
        );
    }

    // Bevy's deferred lighting is a fullscreen fragment pass without a diagnostics span:
    // the frame timer minus the timed spans is it and the gaps.
    let deferred: Vec<&Config> = res.configs.iter().filter(|c| c.who == Who::BevyDeferred).collect();
    if !deferred.is_empty() {
        let _ = writeln!(md, "\n## Deferred lighting: a fragment pass (Bevy) against a compute pass (tiledlight)\n");
        let _ = writeln!(
            md,
            "| scene | run | frame | timed passes | untimed (Bevy: its lighting pass and the gaps) | tiledlight \
             `deferred.shade` |"
        );
        let _ = writeln!(md, "| --- | --- | ---: | ---: | ---: | ---: |");
        for s in &res.scenes {
            let td = res.cell(s, "tl-td");
            let shade =
                td.and_then(|c| c.median_of(|r| r.passes.iter().find(|(n, _)| n == "deferred.shade").map(|p| p.1)));
            for c in &deferred {
                let Some(cell) = res.cell(s, &c.name) else { continue };
                let timed = cell.median_of(|r| Some(r.passes_ms)).unwrap_or(0.0);
                let _ = writeln!(
                    md,
                    "| {s} | {} | {} | {} | {} | {} |",
                    c.label,
                    ms(cell.frame_ms()),
                    ms(timed),
                    ms(cell.frame_ms() - timed),
                    shade.map_or("-".into(), ms)
                );
            }
        }
    }

    let bevy: Vec<&Config> = res.configs.iter().filter(|c| c.who.is_bevy()).collect();
    if !bevy.is_empty() {
        let _ = writeln!(md, "\n## Bevy on the CPU: the prepare phase (its per-frame uploads) and the frame\n");
        let _ = writeln!(md, "| scene | run | GPU frame | prepare phase, CPU | CPU frame |");
        let _ = writeln!(md, "| --- | --- | ---: | ---: | ---: |");
        for s in &res.scenes {
            for c in &bevy {
                let Some(cell) = res.cell(s, &c.name) else { continue };
                let opt = |v: Option<f64>| v.map_or("-".into(), ms);
                let _ = writeln!(
                    md,
                    "| {s} | {} | {} | {} | {} |",
                    c.label,
                    ms(cell.frame_ms()),
                    opt(cell.median_of(|r| r.prepare_cpu_ms)),
                    opt(cell.median_of(|r| r.cpu_frame_ms)),
                );
            }
        }
    }

    let _ = writeln!(md, "\n## Per pass, ms (median; the first repeat)\n");
    let _ = writeln!(md, "| scene | run | passes |");
    let _ = writeln!(md, "| --- | --- | --- |");
    for s in &res.scenes {
        for c in &res.configs {
            if let Some(cell) = res.cell(s, &c.name) {
                let p: Vec<String> = cell.first().passes.iter().map(|(k, v)| format!("{k} {}", ms(*v))).collect();
                let _ = writeln!(md, "| {s} | {} | {} |", c.label, p.join(", "));
            }
        }
    }
    md
}

/// The GPU's clocks around the runs (`clocks.csv` in DIR or the folder above): the range
/// of each column over every reading. None without the file.
fn clocks(dir: &Path) -> Result<Option<String>> {
    let Some(file) = [dir.join("clocks.csv"), dir.join("../clocks.csv")].into_iter().find(|f| f.is_file()) else {
        return Ok(None);
    };
    let text = std::fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?;
    // run,when,sm_mhz,mem_mhz,temp_c,power_w
    let mut cols: [Vec<f64>; 4] = Default::default();
    let mut after_sm = Vec::new();
    let mut readings = 0;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 {
            continue;
        }
        let v: Vec<Option<f64>> = f[2..].iter().map(|x| x.trim().parse().ok()).collect();
        for (c, x) in cols.iter_mut().zip(&v) {
            c.extend(*x);
        }
        readings += 1;
        if f[1] == "after" {
            after_sm.extend(v[0]);
        }
    }
    if readings == 0 {
        return Ok(None);
    }
    // Readings after a run below the highest SM clock seen: the GPU idling down, or a
    // run that did not hold the boost clock.
    let top = cols[0].iter().copied().fold(0.0, f64::max);
    let below = after_sm.iter().filter(|&&sm| sm < top).count();
    let range = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if v.is_empty() {
            "-".to_string()
        } else {
            format!("{lo} - {hi}")
        }
    };
    Ok(Some(format!(
        "- GPU around the runs ({readings} readings of nvidia-smi, before and after each run): SM clock {} MHz \
         ({below} of {} readings after a run below the highest), memory clock {} MHz, {} C, {} W\n",
        range(&cols[0]),
        after_sm.len(),
        range(&cols[1]),
        range(&cols[2]),
        range(&cols[3])
    )))
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

/// One FLIP comparison: mean and 99th percentile as rendered, and mean after matching
/// the test image's tone curve to the reference's.
struct FlipRow {
    scene: String,
    what: String,
    mean: f32,
    p99: f32,
    matched_mean: f32,
    heat: PathBuf,
}

/// Per scene, the mean luma of each configuration's frame (None: no frame).
type LumaRow = (String, Vec<Option<f64>>);

/// Per scene, every configuration's frame decoded once: its mean luma, and FLIP of every
/// Bevy frame and of Tiled Deferred's against Forward+'s (heat maps written to `out`).
fn compare_frames(res: &Results, dir: &Path, out: &Path) -> Result<(Vec<FlipRow>, Vec<LumaRow>)> {
    let (mut rows, mut lumas) = (Vec::new(), Vec::new());
    for s in &res.scenes {
        let path = |c: &str| dir.join(format!("{s}.{c}.png"));
        let frames: Vec<Option<(u32, u32, Vec<u8>)>> = res
            .configs
            .iter()
            .map(|c| path(&c.name).exists().then(|| load_rgba(&path(&c.name))).transpose())
            .collect::<Result<_>>()?;
        lumas.push((s.clone(), frames.iter().map(|f| f.as_ref().map(|f| mean_luma(&f.2))).collect()));
        let frame = |name: &str| res.configs.iter().position(|c| c.name == name).and_then(|i| frames[i].as_ref());
        let Some(reference) = frame("tl-fp") else { continue };
        let tests = res.configs.iter().filter(|c| c.who.is_bevy() || c.name == "tl-td");
        for c in tests {
            let Some((wb, hb, rb)) = frame(&c.name) else { continue };
            let (wa, ha, ra) = reference;
            ensure!(
                (*wa, *ha) == (*wb, *hb),
                "{} is {wa}x{ha} but {} is {wb}x{hb}: FLIP compares images of one size",
                path("tl-fp").display(),
                path(&c.name).display()
            );
            let map = tiledlight_metrics::flip(*wa, *ha, ra, rb);
            let stats = map.summary(0.99);
            let matched =
                tiledlight_metrics::flip(*wa, *ha, ra, &tiledlight_metrics::histogram::match_histograms(ra, rb))
                    .summary(0.99);
            let heat = image::RgbImage::from_raw(*wa, *ha, map.heat_rgb()).context("building the FLIP heat map")?;
            let half = image::imageops::resize(&heat, (wa / 2).max(1), (ha / 2).max(1), image::imageops::Triangle);
            let heat_path = out.join(format!("flip-{s}-tl-fp-vs-{}.png", c.name));
            crate::output::save_png(&heat_path, &half)?;
            rows.push(FlipRow {
                scene: s.clone(),
                what: format!("tiledlight Forward+ vs {}", c.label),
                mean: stats.mean,
                p99: stats.percentile,
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

/// Frame time against light count over the `court-N` scenes, written to `path`; false
/// (nothing written) with fewer than two of them.
fn chart(res: &Results, path: &Path, adapter: &str) -> Result<bool> {
    let courts: Vec<(&String, u64)> = res
        .scenes
        .iter()
        .filter_map(|s| s.strip_prefix("court-").and_then(|n| n.parse().ok()).map(|n| (s, n)))
        .collect();
    if courts.len() < 2 {
        return Ok(false);
    }
    let mut series = Vec::new();
    let mut times = Vec::new();
    for c in &res.configs {
        let mut points = Vec::new();
        let mut incomplete = Vec::new();
        for &(s, n) in &courts {
            if let Some(cell) = res.cell(s, &c.name) {
                points.push((n as f64, cell.frame_ms()));
                times.push(cell.frame_ms());
                if !cell.flags().is_empty() {
                    incomplete.push((n as f64, cell.frame_ms()));
                }
            }
        }
        if !points.is_empty() {
            series.push(Series { name: c.label.clone(), points, incomplete });
        }
    }
    let c = LineChart {
        // The adapter's name without the backend and driver, which the report lists.
        title: format!(
            "tiledlight and Bevy, one scene: GPU frame time, {}",
            adapter.split(" (").next().unwrap_or(adapter)
        ),
        subtitle: "courtyard, uniform random point lights, one exported glTF; first command to last, median of the \
                   repeats"
            .into(),
        x: AxisSpec {
            label: "point lights".into(),
            scale: Scale::Log,
            ticks: Some(courts.iter().map(|&(_, n)| n as f64).collect()),
        },
        // 1-2-5 ticks in every decade the times span: the automatic ones label decades only
        // when the times span more than two, and Tiled Deferred's 2-3 ms would have none.
        y: AxisSpec { label: "GPU frame time, ms".into(), scale: Scale::Log, ticks: Some(ticks_125(&times)) },
        series,
        marker: None,
        note: None,
        categories: None,
    };
    chart::line_chart(path, &c)?;
    Ok(true)
}

/// Runs `tiledlight peer-report DIR [--out OUT]`: reads `dir`, writes the report, chart
/// and heat maps to `out` (default: `dir`).
pub fn run(dir: &Path, out: Option<&Path>) -> Result<()> {
    if !dir.is_dir() {
        bail!("{}: no such folder (unpack scripts/peer-bench.sh's peer-SCENE.tar.gz archives into one)", dir.display());
    }
    let out = out.unwrap_or(dir).to_path_buf();
    crate::output::check_output_dir("--out", &out)?;
    let res = Results::read(dir)?;
    let adapter = res.field(true, &["adapter"]).or_else(|| res.field(false, &["config", "adapter"]));
    let adapter = adapter.unwrap_or_else(|| "adapter not recorded".into());
    let mut md = String::from("# Peer benchmark: tiledlight and Bevy on the same scenes\n\n");
    let size = res.field(false, &["config", "resolution"]).unwrap_or_else(|| "?".into());
    let _ = writeln!(md, "- adapter: {adapter}");
    let _ = writeln!(md, "- resolution: {size}");
    let _ = writeln!(
        md,
        "- tiledlight commit: {}",
        res.field(false, &["config", "commit"]).unwrap_or_else(|| "not recorded".into())
    );
    let _ = writeln!(md, "- Bevy: {}", res.field(true, &["bevy_version"]).unwrap_or_else(|| "not recorded".into()));
    let repeats = res.cells.values().map(|c| c.runs.len()).max().unwrap_or(0);
    let _ = writeln!(md, "- scenes: {}; up to {repeats} repeats of each configuration", res.scenes.join(", "));
    if let Some(line) = clocks(dir)? {
        md.push_str(&line);
    }
    md.push('\n');
    md.push_str(&tables(&res));
    let (rows, lumas) = compare_frames(&res, dir, &out)?;
    if !rows.is_empty() {
        let _ = writeln!(md, "\n## FLIP between the frames (0 = the same, 1 = as different as can be)\n");
        let _ = writeln!(md, "| scene | images | mean | 99th percentile | mean, tone curves matched | heat map |");
        let _ = writeln!(md, "| --- | --- | ---: | ---: | ---: | --- |");
        for r in &rows {
            let heat = r.heat.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            let _ = writeln!(
                md,
                "| {} | {} | {:.4} | {:.4} | {:.4} | {heat} |",
                r.scene, r.what, r.mean, r.p99, r.matched_mean
            );
        }
        let _ = writeln!(
            md,
            "\nThe renderers' BRDFs and tonemappers differ (Bevy's Filament BRDF and ACES fit against tiledlight's), \
             so FLIP between them shows whether both light the same places, not equality. \"Tone curves matched\" \
             remaps the second image's channels to the first's histograms (a monotone per-channel curve: exposure, \
             tonemapper, gain) before FLIP, so what remains is where the light falls. Forward+ against Tiled \
             Deferred is the floor of one renderer's two methods."
        );
        let present: Vec<usize> = (0..res.configs.len()).filter(|&i| lumas.iter().any(|l| l.1[i].is_some())).collect();
        let _ = writeln!(
            md,
            "\nMean luma of the frames (Rec. 709 weights on the encoded sRGB values, 0..1): a difference in overall \
             brightness raises FLIP on every pixel, even where the light falls alike.\n"
        );
        let head: Vec<&str> = present.iter().map(|&i| res.configs[i].label.as_str()).collect();
        let _ = writeln!(md, "| scene | {} |", head.join(" | "));
        let _ = writeln!(md, "| --- |{}", " ---: |".repeat(present.len()));
        for (s, row) in &lumas {
            let cells: Vec<String> =
                present.iter().map(|&i| row[i].map_or("-".into(), |v| format!("{v:.3}"))).collect();
            let _ = writeln!(md, "| {s} | {} |", cells.join(" | "));
        }
    }
    let chart_path = out.join("peer-frame-time.png");
    let charted = chart(&res, &chart_path, &adapter)?;
    let report = out.join("peer-report.md");
    std::fs::write(&report, &md).with_context(|| format!("writing {}", report.display()))?;
    print!("{md}");
    let chart_note = if charted { format!(", {}", chart_path.display()) } else { String::new() };
    println!("\nwrote {}{chart_note} and {} FLIP heat maps", report.display(), rows.len());
    Ok(())
}
