//! What the measurement lab's two subcommands (`sweep`, `accuracy`) share: the axes a
//! run varies (`--axis NAME=VALUES`), parsed and applied to [`SceneArgs`]; the points of a
//! run (the product of its axes); the resumable CSV file that records them; and the
//! progress bar.
//!
//! An axis is one entry of [`AXES`]: adding a setting to the lab (as MSAA and its edge
//! thresholds were) is one more entry there and one more arm in [`apply`].
//!
//! A run cut short by a fault of the GPU (a lost device, out of GPU memory) ends with the
//! fault named, how many points the CSV already holds and that the same command resumes
//! after them ([`interrupted`]): every point is appended and flushed as soon as it is
//! measured, so nothing measured is lost. May depend on [`crate::scene_setup`],
//! [`crate::dropped`], tiledlight-setup and tiledlight-gpu (the fault's error type).

use std::collections::HashSet;
use std::fs::OpenOptions;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};

use crate::scene_setup::{AssignArg, BlendModeArg, DensityArg, GridArg, MethodArg, SceneArgs, ShadowFormatArg};

/// The most points one run may have (a guard against a typo that would run for days).
pub const MAX_POINTS: usize = 10_000;

/// The axes a sweep can vary: name and what its values are.
pub const AXES: &[(&str, &str)] = &[
    ("lights", "random point lights (integer; ranges allowed)"),
    ("spot-lights", "random spot lights (integer; ranges allowed)"),
    ("method", "forward-plus | deferred | brute-force | brute-force-no-cutoff"),
    ("grid-objects", "grid objects of the default scene, 0..280 (integer; ranges allowed)"),
    ("density", "grid object tessellation: low | medium | high"),
    ("gbuffer-rts", "Tiled Deferred G-buffer targets, 2..5"),
    ("tile-size", "8 | 16 | 32"),
    ("threshold", "light intensity threshold, the radius dial (number; ranges allowed)"),
    ("culling", "culling tests: planes | aabb | half-z | aabb+half-z"),
    ("aabb", "sphere-vs-AABB test: on | off"),
    ("half-z", "two lists per tile: on | off"),
    ("seed", "seed of the random lights (integer)"),
    ("msaa", "MSAA samples per pixel: 1 | 2 | 4 | 8"),
    ("edge-distance", "Tiled Deferred MSAA edge test: off-plane distance / view distance (number; ranges allowed)"),
    ("edge-normal-deg", "Tiled Deferred MSAA edge test: normal angle in degrees (number; ranges allowed)"),
    ("shadow-point-lights", "shadow-casting point lights, the brightest (integer; ranges allowed)"),
    ("shadow-spot-lights", "shadow-casting spot lights, the brightest (integer; ranges allowed)"),
    ("shadow-size", "shadow tile size in texels: 128 | 256 | 512 | 1024 (integer)"),
    ("shadow-filter", "shadow filter taps per side: 1 | 3 | 5"),
    ("shadow-format", "shadow atlas depth format: d16 | d32"),
    ("transparent-objects", "grid objects drawn as blended glass, 0 to the grid objects (integer; ranges allowed)"),
    ("blend-mode", "compositing of blended geometry: sorted | wboit"),
    ("grid", "light grid layout: tiled | half-z | 2.5d | clustered"),
    ("assign", "light assignment: gather (tile-centric) | scatter (light-centric)"),
    ("cluster-tile", "cluster tile side in pixels: 8 | 16 | 32 | 64 | 128 | 256 (integer)"),
    ("cluster-slices", "cluster depth slices, 1 to 32 (integer; ranges allowed)"),
    ("cluster-first", "far end of the first cluster slice, metres (number; ranges allowed)"),
    ("lights-per-pixel", "lights placed on surfaces, mean lights per surface point (number; ranges allowed)"),
    ("vpl", "virtual point lights from the shadow casters: on | off"),
    ("vpl-rsm-size", "VPLs: reflective shadow map texels per face side, 4..512 (integer; ranges allowed)"),
    ("vpl-block", "VPLs: texels per side of one VPL's block, divides the RSM size (integer; ranges allowed)"),
    ("vpl-colour-threshold", "VPLs: colour threshold, 0..1 (number; ranges allowed)"),
    ("vpl-brightness-threshold", "VPLs: brightness threshold (number; ranges allowed)"),
    ("vpl-cap", "VPLs: most VPLs (integer; ranges allowed)"),
    ("vpl-shading", "VPLs: sample | physical"),
];

/// One swept axis: its name (a key of [`AXES`]) and its values, in sweep order.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Name, e.g. "lights".
    pub name: String,
    /// Values as the CSV records them, e.g. "256".
    pub values: Vec<String>,
}

fn known(name: &str) -> Result<()> {
    if AXES.iter().any(|(n, _)| *n == name) {
        return Ok(());
    }
    let names: Vec<&str> = AXES.iter().map(|(n, _)| *n).collect();
    bail!("unknown axis '{name}': expected one of {}", names.join(", "))
}

fn is_integer_axis(name: &str) -> bool {
    matches!(
        name,
        "lights"
            | "spot-lights"
            | "grid-objects"
            | "gbuffer-rts"
            | "tile-size"
            | "seed"
            | "msaa"
            | "shadow-point-lights"
            | "shadow-spot-lights"
            | "shadow-size"
            | "shadow-filter"
            | "transparent-objects"
            | "cluster-tile"
            | "cluster-slices"
            | "vpl-rsm-size"
            | "vpl-block"
            | "vpl-cap"
    )
}

/// Whether the axis's values are numbers (plotted on a numeric x axis).
pub fn is_numeric_axis(name: &str) -> bool {
    is_integer_axis(name)
        || matches!(
            name,
            "threshold"
                | "edge-distance"
                | "edge-normal-deg"
                | "cluster-first"
                | "lights-per-pixel"
                | "vpl-colour-threshold"
                | "vpl-brightness-threshold"
        )
}

/// Parses `NAME=VALUES`. VALUES is a comma-separated list, or for numeric axes a range
/// `A..B` (A, 2A, 4A, ... up to B, B included; halving when B < A) or `A..B:N` (N values
/// evenly spaced on a log scale, integers rounded).
pub fn parse_axis(spec: &str) -> Result<Axis> {
    let (name, values) = spec.split_once('=').with_context(|| format!("--axis {spec}: expected NAME=VALUES"))?;
    let name = name.trim();
    known(name).with_context(|| format!("--axis {spec}"))?;
    let values = values.trim();
    ensure!(!values.is_empty(), "--axis {spec}: no values (an empty sweep)");
    let list: Vec<String> = if let Some((a, b)) = values.split_once("..") {
        ensure!(is_numeric_axis(name), "--axis {spec}: ranges need a numeric axis, '{name}' is not");
        range(name, a, b).with_context(|| format!("--axis {spec}"))?
    } else {
        values.split(',').map(|v| v.trim().to_string()).collect()
    };
    for v in &list {
        // Check every value now, not after an hour of measuring the ones before it.
        apply(&mut SceneArgs::default(), name, v).with_context(|| format!("--axis {spec}"))?;
    }
    let mut seen = HashSet::new();
    if let Some(d) = list.iter().find(|v| !seen.insert(v.as_str())) {
        bail!("--axis {spec}: value {d} appears twice");
    }
    Ok(Axis { name: name.to_string(), values: list })
}

fn number(name: &str, v: &str) -> Result<f64> {
    let x: f64 = v.trim().parse().with_context(|| format!("'{v}' is not a number"))?;
    ensure!(x.is_finite() && x > 0.0, "range bound {v} of '{name}' must be a positive number");
    Ok(x)
}

/// The values of `A..B` or `A..B:N` (see [`parse_axis`]).
fn range(name: &str, a: &str, b: &str) -> Result<Vec<String>> {
    let (b, steps) = match b.split_once(':') {
        Some((b, n)) => (b, Some(n.trim().parse::<usize>().with_context(|| format!("step count '{n}'"))?)),
        None => (b, None),
    };
    let (a, b) = (number(name, a)?, number(name, b)?);
    let mut xs = Vec::new();
    match steps {
        Some(n) => {
            ensure!((2..=MAX_POINTS).contains(&n), "step count {n}: must be between 2 and {MAX_POINTS}");
            let r = (b / a).ln() / (n - 1) as f64;
            xs.extend((0..n).map(|i| a * (r * i as f64).exp()));
            xs[n - 1] = b;
        }
        None => {
            let f = if b >= a { 2.0 } else { 0.5 };
            let mut x = a;
            while (f > 1.0 && x < b * (1.0 - 1e-9)) || (f < 1.0 && x > b * (1.0 + 1e-9)) {
                xs.push(x);
                x *= f;
                ensure!(xs.len() < MAX_POINTS, "the range has more than {MAX_POINTS} values");
            }
            xs.push(b);
        }
    }
    let mut out: Vec<String> = Vec::new();
    for x in xs {
        let s = if is_integer_axis(name) { format!("{}", x.round() as u64) } else { format_number(x) };
        if !out.contains(&s) {
            out.push(s);
        }
    }
    Ok(out)
}

/// A number with at most 6 significant digits and no trailing zeros: 0.0125, 400, 1e-5.
pub fn format_number(x: f64) -> String {
    let s = format!("{x:.6e}");
    let v: f64 = s.parse().unwrap_or(x);
    format!("{v}")
}

fn on_off(v: &str) -> Result<bool> {
    match v {
        "on" | "true" | "yes" | "1" => Ok(true),
        "off" | "false" | "no" | "0" => Ok(false),
        _ => bail!("'{v}': expected on or off"),
    }
}

/// Sets axis `name` of `args` to `value`. The ranges are checked by
/// [`SceneArgs::validate`] when the point runs; here only the syntax.
pub fn apply(args: &mut SceneArgs, name: &str, value: &str) -> Result<()> {
    let int =
        || -> Result<u64> { value.parse::<u64>().with_context(|| format!("{name} '{value}': expected an integer")) };
    let small = || -> Result<u32> {
        let n = int()?;
        u32::try_from(n).with_context(|| format!("{name} {n}: too large"))
    };
    match name {
        "lights" => args.lights = Some(int()?),
        "spot-lights" => args.spot_lights = Some(int()?),
        "seed" => args.seed = int()?,
        "grid-objects" => args.grid_objects = small()?,
        "gbuffer-rts" => args.gbuffer_rts = small()?,
        "tile-size" => args.tile_size = small()?,
        "msaa" => args.msaa = small()?,
        "edge-distance" => {
            args.edge_distance = value.parse().with_context(|| format!("edge-distance '{value}': expected a number"))?
        }
        "edge-normal-deg" => {
            args.edge_normal_deg =
                value.parse().with_context(|| format!("edge-normal-deg '{value}': expected a number"))?
        }
        "threshold" => {
            args.threshold = value.parse().with_context(|| format!("threshold '{value}': expected a number"))?
        }
        "method" => {
            args.method = MethodArg::from_str(value, true).map_err(|e| anyhow::anyhow!("method '{value}': {e}"))?
        }
        "density" => {
            args.density = DensityArg::from_str(value, true).map_err(|e| anyhow::anyhow!("density '{value}': {e}"))?
        }
        "shadow-point-lights" => args.shadow_point_lights = small()?,
        "shadow-spot-lights" => args.shadow_spot_lights = small()?,
        "shadow-size" => args.shadow_size = small()?,
        "shadow-filter" => args.shadow_filter = small()?,
        "shadow-format" => {
            args.shadow_format =
                ShadowFormatArg::from_str(value, true).map_err(|e| anyhow::anyhow!("shadow-format '{value}': {e}"))?
        }
        "transparent-objects" => args.transparent_objects = small()?,
        "blend-mode" => {
            args.blend_mode =
                BlendModeArg::from_str(value, true).map_err(|e| anyhow::anyhow!("blend-mode '{value}': {e}"))?
        }
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
            args.cluster_first = value.parse().with_context(|| format!("cluster-first '{value}': expected a number"))?
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
        _ => known(name)?,
    }
    if matches!(name, "shadow-point-lights" | "shadow-spot-lights" | "transparent-objects") {
        // Their only limit is the scene's lights of that kind (the grid objects), which
        // other axes and flags set: checked with the point's whole settings ([`args_at`]).
        return Ok(());
    }
    let probe = args.validate();
    // Only this axis's own range matters here; other flags are checked when the point runs.
    if let Err(e) = probe {
        let msg = e.to_string();
        let flag = format!("--{name} ");
        if msg.starts_with(&flag) {
            return Err(e);
        }
    }
    Ok(())
}

/// One point of a run: per axis, its value (in axis order).
pub type Point = Vec<String>;

/// Every point of `axes` (their product, the first axis varying slowest).
pub fn points(axes: &[Axis]) -> Result<Vec<Point>> {
    ensure!(!axes.is_empty(), "nothing to sweep: give at least one --axis NAME=VALUES");
    let mut names = HashSet::new();
    for a in axes {
        ensure!(names.insert(a.name.as_str()), "axis '{}' is given twice", a.name);
    }
    let total = axes.iter().try_fold(1usize, |n, a| n.checked_mul(a.values.len())).unwrap_or(usize::MAX);
    ensure!(total <= MAX_POINTS, "{total} points: at most {MAX_POINTS} per run (fewer values per axis)");
    let mut out: Vec<Point> = vec![vec![]];
    for a in axes {
        out = out.iter().flat_map(|p| a.values.iter().map(move |v| [p.clone(), vec![v.clone()]].concat())).collect();
    }
    Ok(out)
}

/// `base` with the point's values applied.
pub fn args_at(base: &SceneArgs, axes: &[Axis], point: &Point) -> Result<SceneArgs> {
    let mut args = base.clone();
    for (a, v) in axes.iter().zip(point) {
        apply(&mut args, &a.name, v)?;
    }
    args.validate().with_context(|| describe(axes, point))?;
    Ok(args)
}

/// "lights=256 method=deferred".
pub fn describe(axes: &[Axis], point: &Point) -> String {
    axes.iter().zip(point).map(|(a, v)| format!("{}={v}", a.name)).collect::<Vec<_>>().join(" ")
}

/// Replaces axes of `base` by those of `over` with the same name and appends the others.
pub fn merge_axes(base: Vec<Axis>, over: Vec<Axis>) -> Vec<Axis> {
    let mut out = base;
    for a in over {
        match out.iter_mut().find(|b| b.name == a.name) {
            Some(b) => *b = a,
            None => out.push(a),
        }
    }
    out
}

/// A CSV file that a run appends to point by point and that a later run with the same
/// header resumes: points already complete are skipped, rows of an incomplete point (a
/// run cut off while writing) are dropped.
pub struct ResumableCsv {
    path: PathBuf,
    header: Vec<String>,
    key: Vec<usize>,
    done: HashSet<Vec<String>>,
    writer: csv::Writer<std::fs::File>,
    /// The rows found in the file when it was opened.
    pub existing: Vec<Vec<String>>,
}

impl ResumableCsv {
    /// Opens (or creates) `path` with `header`. A point is keyed by the columns `key`; it
    /// is complete once a row has `marker.1` in column `marker.0` (or any row, without a
    /// marker). An existing file with another header is an error, never overwritten.
    pub fn open(path: &Path, header: &[String], key: &[usize], marker: Option<(usize, &str)>) -> Result<Self> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating directory {}", dir.display()))?;
        }
        let key_of = |r: &[String]| key.iter().map(|&i| r[i].clone()).collect::<Vec<_>>();
        let mut existing = Vec::new();
        let mut done = HashSet::new();
        let fresh = !path.exists() || std::fs::metadata(path).map(|m| m.len() == 0).unwrap_or(true);
        if !fresh {
            let mut r = csv::ReaderBuilder::new()
                .flexible(true)
                .from_path(path)
                .with_context(|| format!("reading {}", path.display()))?;
            let found: Vec<String> = r.headers()?.iter().map(str::to_string).collect();
            ensure!(
                found == header,
                "{} exists with other columns ({}), not this run's ({}): choose another output file or remove it",
                path.display(),
                found.join(","),
                header.join(",")
            );
            for rec in r.records() {
                // A line cut short by an interrupted run is dropped with its point.
                let Ok(rec) = rec else { continue };
                if rec.len() != header.len() {
                    continue;
                }
                existing.push(rec.iter().map(str::to_string).collect::<Vec<_>>());
            }
            for row in &existing {
                if marker.is_none_or(|(c, v)| row[c] == v) {
                    done.insert(key_of(row));
                }
            }
            let before = existing.len();
            existing.retain(|row| done.contains(&key_of(row)));
            if existing.len() != before {
                // Rewrite without the incomplete point's rows so it can be measured again.
                let mut w = csv::Writer::from_path(path).with_context(|| format!("rewriting {}", path.display()))?;
                w.write_record(header)?;
                for row in &existing {
                    w.write_record(row)?;
                }
                w.flush()?;
            }
        }
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("opening {} for writing", path.display()))?;
        let mut writer = csv::WriterBuilder::new().has_headers(false).from_writer(file);
        if fresh {
            writer.write_record(header)?;
            writer.flush()?;
        }
        Ok(Self { path: path.to_path_buf(), header: header.to_vec(), key: key.to_vec(), done, writer, existing })
    }

    /// Whether the point with these key values is already in the file.
    pub fn is_done(&self, key: &[String]) -> bool {
        self.done.contains(key)
    }

    /// Appends one point's rows and flushes them to disk.
    pub fn append(&mut self, rows: &[Vec<String>]) -> Result<()> {
        for r in rows {
            ensure!(r.len() == self.header.len(), "internal: a row of {} columns for {}", r.len(), self.header.len());
            self.writer.write_record(r)?;
        }
        self.writer.flush().with_context(|| format!("writing {}", self.path.display()))?;
        if let Some(r) = rows.first() {
            self.done.insert(self.key.iter().map(|&i| r[i].clone()).collect());
        }
        Ok(())
    }

    /// Every row now in the file (after a run: the old ones and the new ones).
    pub fn read_all(&self) -> Result<Vec<Vec<String>>> {
        let mut r = csv::Reader::from_path(&self.path).with_context(|| format!("reading {}", self.path.display()))?;
        let rows: Result<Vec<Vec<String>>, csv::Error> =
            r.records().map(|rec| rec.map(|rec| rec.iter().map(str::to_string).collect())).collect();
        rows.with_context(|| format!("reading {}", self.path.display()))
    }
}

/// Fails when rows of an existing file were measured on another adapter or screen (the
/// columns `adapter`, `width`, `height` at `cols`): mixing them would compare GPUs.
pub fn check_same_setup(rows: &[Vec<String>], cols: [usize; 3], now: [&str; 3], path: &Path) -> Result<()> {
    if let Some(r) = rows.iter().find(|r| cols.iter().zip(now).any(|(&c, v)| r[c] != v)) {
        bail!(
            "{} holds points measured on {} at {}x{}, this run is {} at {}x{}: choose another output file",
            path.display(),
            r[cols[0]],
            r[cols[1]],
            r[cols[2]],
            now[0],
            now[1],
            now[2]
        );
    }
    Ok(())
}

/// A progress bar of `n` points on stderr (hidden when stderr is not a terminal).
pub fn progress(n: usize) -> ProgressBar {
    let pb = ProgressBar::new(n as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{bar:30} {pos}/{len} points, {elapsed} elapsed, ~{eta} left  {msg}")
    {
        pb.set_style(style);
    }
    pb
}

/// Prints a line above the progress bar, or plainly when the bar is hidden (output to a
/// file or pipe, where a log of every point is wanted).
pub fn say(pb: &ProgressBar, line: String) {
    if pb.is_hidden() {
        println!("{line}");
    } else {
        pb.println(line);
    }
}

/// Prints a `warning:` line on stderr above the progress bar and counts it.
pub fn warn(pb: &ProgressBar, count: &mut usize, line: &str) {
    pb.suspend(|| crate::dropped::warn(count, line));
}

/// Where a run stood when it stopped.
pub struct Progress<'a> {
    /// The point being measured ("lights=256 method=deferred").
    pub point: &'a str,
    /// Points in the CSV for this run (measured before, or by this run).
    pub done: usize,
    /// Points of the run.
    pub total: usize,
    /// The CSV.
    pub csv: &'a Path,
}

/// The error that ends a run at `progress`: for a fault of the GPU (a lost device, out of
/// GPU memory; `prep`'s device is asked too, as a lost device fails later calls with other
/// errors), the fault named, the points kept and how to resume; other errors unchanged.
pub fn interrupted(
    e: anyhow::Error,
    prep: Option<&tiledlight_setup::Prepared>,
    progress: &Progress<'_>,
) -> anyhow::Error {
    use tiledlight_gpu::GpuError;
    let fault = prep.and_then(|p| p.device_lost()).map(|lost| lost.to_string()).or_else(|| {
        e.chain()
            .filter_map(|c| c.downcast_ref::<GpuError>())
            .find(|g| matches!(g, GpuError::DeviceLost { .. } | GpuError::OutOfMemory { .. }))
            .map(|g| g.to_string())
    });
    match fault {
        Some(fault) => anyhow::anyhow!(
            "{fault} at point {}: {} of {} points are in {}; run the same command again to resume after them",
            progress.point,
            progress.done,
            progress.total,
            progress.csv.display()
        ),
        None => e,
    }
}

/// `path` with its extension replaced by `ext`.
pub fn sibling(path: &Path, ext: &str) -> PathBuf {
    path.with_extension(ext)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_lists() {
        assert_eq!(parse_axis("lights=64..1000").unwrap().values, ["64", "128", "256", "512", "1000"]);
        assert_eq!(parse_axis("lights=64..65536:4").unwrap().values, ["64", "645", "6502", "65536"]);
        assert_eq!(parse_axis("threshold=0.4..0.05").unwrap().values, ["0.4", "0.2", "0.1", "0.05"]);
        assert_eq!(parse_axis("method=forward-plus, deferred").unwrap().values, ["forward-plus", "deferred"]);
        assert_eq!(parse_axis("culling=planes,aabb+half-z").unwrap().values.len(), 2);
    }

    #[test]
    fn bad_axes_are_clear_errors() {
        let e = |s: &str| format!("{:#}", parse_axis(s).unwrap_err());
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
        assert!(e("shadow-filter=2").contains("--shadow-filter 2"));
        assert!(e("shadow-format=d24").contains("shadow-format 'd24'"));
        assert!(points(&[]).is_err());
    }

    #[test]
    fn points_are_the_product() {
        let axes = vec![parse_axis("lights=1,2").unwrap(), parse_axis("method=forward-plus,deferred").unwrap()];
        let p = points(&axes).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(p[1], ["1", "deferred"]);
        let a = args_at(&SceneArgs::default(), &axes, &p[3]).unwrap();
        assert_eq!((a.lights, a.method), (Some(2), MethodArg::Deferred));
        let merged = merge_axes(axes.clone(), vec![parse_axis("lights=8").unwrap(), parse_axis("seed=3").unwrap()]);
        assert_eq!(merged.iter().map(|a| a.values.len()).collect::<Vec<_>>(), [1, 2, 1]);
        assert!(points(&[axes[0].clone(), axes[0].clone()]).is_err());
    }

    #[test]
    fn shadows_are_axes() {
        // Spot casters parse before the spot lights they need are known...
        let axes = vec![
            parse_axis("shadow-spot-lights=1..8").unwrap(),
            parse_axis("shadow-size=128,1024").unwrap(),
            parse_axis("shadow-filter=1,5").unwrap(),
            parse_axis("shadow-format=d16,d32").unwrap(),
            parse_axis("shadow-point-lights=2").unwrap(),
        ];
        assert_eq!(axes[0].values, ["1", "2", "4", "8"]);
        let p = points(&axes).unwrap();
        assert_eq!(p.len(), 4 * 2 * 2 * 2);
        let base = SceneArgs { spot_lights: Some(8), ..SceneArgs::default() };
        let a = args_at(&base, &axes, &p[p.len() - 1]).unwrap();
        assert_eq!(
            (a.shadow_spot_lights, a.shadow_size, a.shadow_filter, a.shadow_format, a.shadow_point_lights),
            (8, 1024, 5, ShadowFormatArg::D32, 2)
        );
        // ...and are checked against them with the point's settings.
        let e = format!("{:#}", args_at(&SceneArgs::default(), &axes, &p[0]).unwrap_err());
        assert!(e.contains("--shadow-spot-lights 1: more than the scene's 0 spot lights"), "{e}");
    }

    #[test]
    fn layouts_and_assignment_are_axes() {
        let a = parse_axis("grid=tiled,half-z,2.5d,clustered").unwrap();
        assert_eq!(a.values.len(), 4);
        assert!(parse_axis("assign=gather,scatter").is_ok());
        assert!(parse_axis("cluster-slices=8..32").is_ok() && is_numeric_axis("cluster-first"));
        let mut args = SceneArgs { half_z: true, ..SceneArgs::default() };
        apply(&mut args, "grid", "2.5d").unwrap();
        assert_eq!((args.grid, args.half_z), (GridArg::DepthMask, false));
        apply(&mut args, "assign", "scatter").unwrap();
        assert_eq!(args.assign, AssignArg::Scatter);
        let e = format!("{:#}", parse_axis("grid=hexagonal").unwrap_err());
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
            apply(&mut args, name, value).unwrap();
        }
        let c = args.vpl.config().expect("--vpl on");
        assert_eq!((c.block, c.rsm_size, c.cap), (4, 64, 1000));
        assert_eq!((c.colour_threshold, c.brightness_threshold), (0.5, 0.25));
        assert_eq!(c.shading, tiledlight_cull::vpl::VplShading::Physical);
        assert_eq!(parse_axis("vpl-block=1..8").unwrap().values, ["1", "2", "4", "8"]);
        assert!(is_numeric_axis("vpl-brightness-threshold") && !is_numeric_axis("vpl-shading"));
        let e = format!("{:#}", apply(&mut args, "vpl-shading", "fancy").unwrap_err());
        assert!(e.contains("vpl-shading 'fancy'"), "{e}");
    }

    #[test]
    fn blended_geometry_is_an_axis() {
        let axes = vec![
            parse_axis("transparent-objects=0,10,50,280").unwrap(),
            parse_axis("blend-mode=sorted,wboit").unwrap(),
        ];
        assert!(is_numeric_axis("transparent-objects") && !is_numeric_axis("blend-mode"));
        assert_eq!(parse_axis("transparent-objects=10..40").unwrap().values, ["10", "20", "40"]);
        let p = points(&axes).unwrap();
        assert_eq!(p.len(), 8);
        // The count parses before the grid objects it needs are known...
        let base = SceneArgs { grid_objects: 280, ..SceneArgs::default() };
        let a = args_at(&base, &axes, &p[p.len() - 1]).unwrap();
        assert_eq!((a.transparent_objects, a.blend_mode), (280, BlendModeArg::Wboit));
        // ...and is checked against them with the point's settings.
        let e = format!("{:#}", args_at(&SceneArgs { grid_objects: 50, ..base }, &axes, &p[6]).unwrap_err());
        assert!(
            e.contains("--transparent-objects 280: must be between 0 and the grid objects (--grid-objects 50)"),
            "{e}"
        );
        let e = format!("{:#}", parse_axis("blend-mode=additive").unwrap_err());
        assert!(e.contains("blend-mode 'additive'"), "{e}");
    }

    #[test]
    fn csv_resumes_and_drops_incomplete_points() {
        let dir = std::env::temp_dir().join(format!("tiledlight-lab-{}", std::process::id()));
        let path = dir.join("r.csv");
        let _ = std::fs::remove_file(&path);
        let header: Vec<String> = ["k", "pass", "ms"].map(String::from).to_vec();
        let row = |k: &str, p: &str| vec![k.to_string(), p.to_string(), "1".to_string()];
        {
            let mut c = ResumableCsv::open(&path, &header, &[0], Some((1, "total"))).unwrap();
            c.append(&[row("a", "x"), row("a", "total")]).unwrap();
            c.append(&[row("b", "x")]).unwrap(); // cut off before its total
        }
        let c = ResumableCsv::open(&path, &header, &[0], Some((1, "total"))).unwrap();
        assert!(c.is_done(&["a".into()]) && !c.is_done(&["b".into()]));
        assert_eq!(c.read_all().unwrap().len(), 2, "b's partial row dropped");
        let other: Vec<String> = ["k", "ms"].map(String::from).to_vec();
        let e = ResumableCsv::open(&path, &other, &[0], None).err().unwrap();
        assert!(e.to_string().contains("other columns"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(format_number(0.1 * 0.5 * 0.5), "0.025");
        assert_eq!(format_number(400.0), "400");
    }
}
