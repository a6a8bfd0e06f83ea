//! What the measurement lab's two sweeping runs ([`crate::sweep`], [`crate::accuracy`])
//! share: the axes a run varies (`--axis NAME=VALUES`), parsed and applied to the run's
//! [`Flags`] (the app's scene flags, or a program's own settings type); the points of a
//! run (the product of its axes); the resumable CSV file that records them; and the
//! progress bars (points, frames, the traced reference's bands).
//!
//! An axis is a row of the run settings' table (`tiledlight_setup::table`) or of the pass
//! settings' table (`tiledlight_gpu::knobs`): nothing to add here; or one entry of [`AXES`]
//! and one more arm in the app's [`Flags::set_axis`] (`crates/app/src/scene_setup.rs`)
//! for the flags that are rows of neither; [`axes`] lists all.
//!
//! A run cut short by a fault of the GPU (a lost device, out of GPU memory) ends with the
//! fault named, how many points the CSV already holds and that the same command resumes
//! after them ([`interrupted`]): every point is appended and flushed as soon as it is
//! measured, so nothing measured is lost. May depend on [`crate::dropped`],
//! tiledlight-setup, tiledlight-gpu (the fault's error type) and tiledlight-frame (the
//! band reporter).

use std::collections::HashSet;
use std::fs::OpenOptions;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use tiledlight_gpu::knobs::{Kind, Knobs, KNOBS};
use tiledlight_setup::table::{self, SETTINGS};
use tiledlight_setup::{Method, Settings};

/// The settings a lab run starts from and varies, as the command line states them: the
/// app's scene flags, or a program's own type. An axis sets one value by name; the
/// settings are built from the whole once every axis of a point is applied (so an axis
/// that depends on another, e.g. the spot casters on the spot lights, is checked then).
pub trait Flags: Clone + Default {
    /// Sets axis `name` (a name of [`axes`]) to `value`, checking only its syntax (an
    /// error names the axis and the value, e.g. "method 'forward': ..."). A name this type
    /// does not handle is an error.
    fn set_axis(&mut self, name: &str, value: &str) -> Result<()>;
    /// The settings these flags state, unchecked, reading no file.
    fn plain(&self) -> Settings;
    /// Checks every value's range, reading no file; an error names the flag first
    /// (`--tile-size 12: ...`), as [`Settings::validate`] does.
    fn validate(&self) -> Result<()> {
        self.plain().validate()
    }
    /// The library settings: checked, then any file they name read.
    fn settings(&self) -> Result<Settings> {
        let settings = self.plain();
        settings.validate()?;
        Ok(settings)
    }
    /// The scene as the user named it, for charts' subtitles: "default scene", "default
    /// scene + 280 grid objects" (the Figure 9 scene), or the file's path and " scene".
    fn scene_label(&self) -> String {
        let s = self.plain();
        scene_phrase(&s.scene.to_string(), s.grid_objects)
    }
}

/// "default scene", or with grid objects "default scene + 280 grid objects" (the Figure 9
/// scene): a chart subtitle's scene, from the scene's name as the user gave it.
pub fn scene_phrase(name: &str, grid_objects: u32) -> String {
    match grid_objects {
        0 => format!("{name} scene"),
        n => format!("{name} scene + {n} grid objects"),
    }
}

/// The most points one run may have (a guard against a typo that would run for days).
pub const MAX_POINTS: usize = 10_000;

/// The axes of the settings that are rows of neither table (the run settings' in
/// tiledlight-setup, the pass settings' in tiledlight-gpu): name and what its values are
/// ([`axes`] adds the rows).
pub const AXES: &[(&str, &str)] = &[
    ("culling", "culling tests: planes | aabb | half-z | aabb+half-z"),
    ("half-z", "two lists per tile: on | off"),
    ("camera", "camera bookmark file (the viewer's \"save camera\"; a path without commas)"),
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

/// What a row's values are, from its kind.
fn values_of(kind: Kind) -> String {
    match kind {
        Kind::Switch => "on | off".to_string(),
        Kind::Count => "integer; ranges allowed".to_string(),
        Kind::Number => "number; ranges allowed".to_string(),
        Kind::Choice(names) | Kind::Values(names) => names.join(" | "),
        Kind::Text => "a name or a file".to_string(),
    }
}

/// The kind of the row of either table named `name`, if it is one.
fn row_kind(name: &str) -> Option<Kind> {
    table::row(name).map(|r| r.kind).or_else(|| Knobs::row(name).map(|r| r.kind))
}

/// Every axis a sweep can vary, name and what its values are: one a row of the run
/// settings' table (`tiledlight_setup::table`), then [`AXES`], then one a row of the pass
/// settings' table (`tiledlight_gpu::knobs`), each row described from itself.
pub fn axes() -> Vec<(&'static str, String)> {
    let settings = SETTINGS.iter().map(|r| (r.name, format!("{} ({})", r.label, values_of(r.kind))));
    let knobs = KNOBS.iter().map(|k| (k.name, format!("{} ({})", k.label, values_of(k.kind))));
    settings.chain(AXES.iter().map(|&(n, d)| (n, d.to_string()))).chain(knobs).collect()
}

/// Every axis name, comma-separated: the one list `sweep --help`, `accuracy --help`, the
/// error for an unknown axis and docs/USAGE.md's table (checked by a test) all show.
pub fn axis_names() -> String {
    axes().iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// `--axis`'s help: the syntax and every name ([`axis_names`]).
pub fn axis_help() -> String {
    format!(
        "An axis to vary, NAME=VALUES: a list (method=forward-plus,deferred), a doubling range (lights=64..65536) \
         or N log-spaced values (lights=64..65536:9). Repeat for more axes; every combination is measured. Names: {}",
        axis_names()
    )
}

/// One swept axis: its name (a key of [`axes`]) and its values, in sweep order.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Name, e.g. "lights".
    pub name: String,
    /// Values as the CSV records them, e.g. "256".
    pub values: Vec<String>,
}

fn known(name: &str) -> Result<()> {
    let all = axes();
    if all.iter().any(|(n, _)| *n == name) {
        return Ok(());
    }
    bail!("unknown axis '{name}': expected one of {}", axis_names())
}

/// Whether the axis's values are integers.
pub fn is_integer_axis(name: &str) -> bool {
    if let Some(kind) = row_kind(name) {
        return matches!(kind, Kind::Count | Kind::Values(_));
    }
    matches!(name, "cluster-tile" | "cluster-slices" | "vpl-rsm-size" | "vpl-block" | "vpl-cap")
}

/// Whether the axis's values are numbers (plotted on a numeric x axis).
pub fn is_numeric_axis(name: &str) -> bool {
    if let Some(kind) = row_kind(name) {
        return matches!(kind, Kind::Count | Kind::Number | Kind::Values(_));
    }
    is_integer_axis(name)
        || matches!(name, "cluster-first" | "lights-per-pixel" | "vpl-colour-threshold" | "vpl-brightness-threshold")
}

/// Parses `NAME=VALUES`. VALUES is a comma-separated list, or for numeric axes a range
/// `A..B` (A, 2A, 4A, ... up to B, B included; halving when B < A) or `A..B:N` (N values
/// evenly spaced on a log scale, integers rounded).
pub fn parse_axis<F: Flags>(spec: &str) -> Result<Axis> {
    let (name, values) = spec.split_once('=').with_context(|| format!("--axis {spec}: expected NAME=VALUES"))?;
    let name = name.trim();
    known(name).with_context(|| format!("--axis {spec}"))?;
    let values = values.trim();
    ensure!(!values.is_empty(), "--axis {spec}: no values (an empty sweep)");
    // A camera bookmark's path may hold "..": never a range.
    let list: Vec<String> = if let Some((a, b)) = values.split_once("..").filter(|_| name != "camera") {
        ensure!(is_numeric_axis(name), "--axis {spec}: ranges need a numeric axis, '{name}' is not");
        range(name, a, b).with_context(|| format!("--axis {spec}"))?
    } else {
        values.split(',').map(|v| v.trim().to_string()).collect()
    };
    for v in &list {
        // Check every value now, not after an hour of measuring the ones before it.
        apply(&mut F::default(), name, v).with_context(|| format!("--axis {spec}"))?;
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

/// An on/off value: on, true, yes, 1 or off, false, no, 0.
pub fn on_off(v: &str) -> Result<bool> {
    match v {
        "on" | "true" | "yes" | "1" => Ok(true),
        "off" | "false" | "no" | "0" => Ok(false),
        _ => bail!("'{v}': expected on or off"),
    }
}

/// Sets axis `name` of `args` to `value` ([`Flags::set_axis`]) and checks the value's
/// own range; the other values are checked by [`Flags::validate`] when the point runs.
pub fn apply<F: Flags>(args: &mut F, name: &str, value: &str) -> Result<()> {
    known(name)?;
    args.set_axis(name, value)?;
    if matches!(name, "shadow-point-lights" | "shadow-spot-lights" | "transparent-objects" | "materials") {
        // Their limits depend on other flags (the scene's lights of that kind, the grid
        // objects, `--scene materials`), which other axes and flags set: checked with the
        // point's whole settings ([`args_at`]) before anything is measured.
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

/// Whether `method` reads axis `name`: a pass setting's or a run setting's row says
/// which methods read it (its `applies`, as `--help`'s `[methods: ...]`); every other axis
/// is read by every method.
pub fn reads(name: &str, method: Method) -> bool {
    let traits = method.traits();
    if let Some(k) = KNOBS.iter().find(|k| k.name == name) {
        return (k.applies)(traits);
    }
    SETTINGS.iter().find(|r| r.name == name).is_none_or(|r| (r.applies)(traits))
}

/// `points` less those that give an axis their method does not read another value than
/// its first (`--axis method=deferred,stochastic --axis denoise=0,4` would measure Tiled
/// Deferred twice: the same image and time), and how many were left out.
pub fn without_unread<F: Flags>(base: &F, axes: &[Axis], points: Vec<Point>) -> Result<(Vec<Point>, usize)> {
    let given = points.len();
    let mut kept = Vec::with_capacity(given);
    for p in points {
        let s = args_at(base, axes, &p)?.plain();
        // (Only the method is asked: a point's flags are checked in full before it runs.)
        if !axes.iter().zip(&p).any(|(a, v)| *v != a.values[0] && !reads(&a.name, s.method)) {
            kept.push(p);
        }
    }
    let left_out = given - kept.len();
    Ok((kept, left_out))
}

/// The method of a point: its `method` axis's value, else `base`.
pub fn method_at(axes: &[Axis], point: &[String], base: Method) -> Method {
    axes.iter()
        .zip(point)
        .find(|(a, _)| a.name == "method")
        .and_then(|(_, v)| Method::ALL.into_iter().find(|m| m.name() == v.as_str()))
        .unwrap_or(base)
}

/// A chart series' name for `point`: the method's name and `NAME=VALUE` of its other
/// `series` axes (a legend of bare numbers does not say which dial is which), less those
/// the point's method does not read (Tiled Deferred is "deferred", not "deferred,
/// denoise=0" for a denoiser it has not).
pub fn series_name(axes: &[Axis], series: &[usize], point: &[String], base: Method) -> String {
    let m = method_at(axes, point, base);
    let named = |i: usize| match axes[i].name.as_str() {
        "method" => point[i].clone(),
        name => format!("{name}={}", point[i]),
    };
    series.iter().filter(|&&i| reads(&axes[i].name, m)).map(|&i| named(i)).collect::<Vec<_>>().join(", ")
}

/// One line for a run that left points out ([`without_unread`]), or None.
pub fn unread_line(left_out: usize) -> Option<String> {
    (left_out > 0).then(|| {
        format!(
            "skipped:    {left_out} settings that give an axis their method does not read a value other than its first (each would repeat one measured)"
        )
    })
}

/// Axes of the error budget swept again under each other value of [`CHOICE_AXIS`]: the
/// caster counts, whose curve is the point of choosing casters one way or another.
const CHOSEN_COUNTS: [&str; 2] = ["shadow-point-lights", "shadow-spot-lights"];

/// The axis that says how the casters of [`CHOSEN_COUNTS`] are chosen.
const CHOICE_AXIS: &str = "casters-by";

/// The error budget's points: the base (every axis at its first value), then each axis's
/// other values with every other axis at its first (one dial changed at a time), so each
/// setting's error differs from the base's by one cause. The caster counts are also swept
/// under each other value of `casters-by` (two dials: how many casters, chosen how), so the
/// chart has a caster curve per choice. Same checks as [`points`].
pub fn points_one_at_a_time(axes: &[Axis]) -> Result<Vec<Point>> {
    ensure!(!axes.is_empty(), "nothing to sweep: give at least one --axis NAME=VALUES");
    let mut names = HashSet::new();
    for a in axes {
        ensure!(names.insert(a.name.as_str()), "axis '{}' is given twice", a.name);
    }
    let base: Point = axes.iter().map(|a| a.values[0].clone()).collect();
    let mut out = vec![base.clone()];
    for (k, a) in axes.iter().enumerate() {
        for v in &a.values[1..] {
            let mut p = base.clone();
            p[k] = v.clone();
            out.push(p);
        }
    }
    if let Some(c) = axes.iter().position(|a| a.name == CHOICE_AXIS) {
        for choice in &axes[c].values[1..] {
            for (k, a) in axes.iter().enumerate().filter(|(_, a)| CHOSEN_COUNTS.contains(&a.name.as_str())) {
                for v in &a.values[1..] {
                    let mut p = base.clone();
                    (p[k], p[c]) = (v.clone(), choice.clone());
                    out.push(p);
                }
            }
        }
    }
    ensure!(out.len() <= MAX_POINTS, "{} points: at most {MAX_POINTS} per run (fewer values per axis)", out.len());
    Ok(out)
}

/// The curve of the error budget's chart that `point` of [`points_one_at_a_time`] belongs
/// to: "base", the axis it changed ("threshold"), or a caster count with its choice
/// ("shadow-point-lights, casters-by=contribution"); a changed `casters-by` is named with
/// its value.
pub fn budget_series(axes: &[Axis], point: &[String]) -> String {
    let changed: Vec<String> = axes
        .iter()
        .zip(point)
        .filter(|(a, v)| **v != a.values[0])
        .map(|(a, v)| if a.name == CHOICE_AXIS { format!("{}={v}", a.name) } else { a.name.clone() })
        .collect();
    if changed.is_empty() {
        "base".into()
    } else {
        changed.join(", ")
    }
}

/// The label of an error budget's point on its chart: the values it changed from the base
/// ("deferred", "64"; "base" for the base), so points of one dial can be told apart.
pub fn budget_label(axes: &[Axis], point: &[String]) -> String {
    let changed: Vec<&str> =
        axes.iter().zip(point).filter(|(a, v)| **v != a.values[0]).map(|(_, v)| v.as_str()).collect();
    if changed.is_empty() {
        "base".into()
    } else {
        changed.join(", ")
    }
}

/// `base` with the point's values applied.
pub fn args_at<F: Flags>(base: &F, axes: &[Axis], point: &Point) -> Result<F> {
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

/// `--quiet`: no progress bar anywhere (they are hidden anyway when stderr is not a
/// terminal).
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Switches every progress bar of this process off (`--quiet`) or back on.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// A bar of `n` steps on stderr: hidden with `--quiet`, and by indicatif when stderr is
/// not a terminal (a pipe or a file gets no bar).
fn bar(n: u64) -> ProgressBar {
    if QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(n)
    }
}

/// A progress bar of `n` frames on stderr for a command's own frames (bench, render, the
/// quick start), `what` beside it; hidden as [`progress`]'s.
pub fn frames_progress(n: u32, what: &str) -> ProgressBar {
    let pb = bar(u64::from(n));
    if let Ok(style) = ProgressStyle::with_template("{bar:30} {pos}/{len} frames, {elapsed} elapsed  {msg}") {
        pb.set_style(style);
    }
    pb.set_message(what.to_string());
    pb
}

/// A progress bar of `n` points on stderr (hidden with `--quiet` or when stderr is not a
/// terminal).
pub fn progress(n: usize) -> ProgressBar {
    let pb = bar(n as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{bar:30} {pos}/{len} points, {elapsed} elapsed, ~{eta} left  {msg}")
    {
        pb.set_style(style);
    }
    pb
}

/// The traced reference's bands as a progress bar on stderr while this lives: it installs
/// the frame crate's band reporter (`tiledlight_frame::visibility::set_band_reporter`) and
/// removes it when dropped. Hidden as [`progress`]'s (with `--quiet`, or when stderr is
/// not a terminal: a pipe gets no carriage-return lines).
pub struct BandsProgress {
    pb: ProgressBar,
}

impl BandsProgress {
    /// Starts the bar (its length is the frame's band count, known at the first band).
    pub fn start() -> Self {
        let pb = bar(0);
        if let Ok(style) =
            ProgressStyle::with_template("{bar:30} {pos}/{len} bands, {elapsed} elapsed, ~{eta} left  {msg}")
        {
            pb.set_style(style);
        }
        pb.set_message("traced reference");
        let shown = pb.clone();
        tiledlight_frame::visibility::set_band_reporter(Some(std::sync::Arc::new(move |band, bands, _| {
            shown.set_length(u64::from(bands));
            shown.set_position(u64::from(band));
        })));
        BandsProgress { pb }
    }
}

impl Drop for BandsProgress {
    fn drop(&mut self) {
        tiledlight_frame::visibility::set_band_reporter(None);
        self.pb.finish_and_clear();
    }
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

    /// The axes as docs/USAGE.md lists them: a markdown table, one row an axis.
    fn usage_table() -> String {
        let mut t = String::from("| axis | values |\n| --- | --- |\n");
        for (name, what) in axes() {
            t.push_str(&format!("| `{name}` | {} |\n", what.replace('|', "\\|")));
        }
        t
    }

    /// One list of axes everywhere (issue 47): docs/USAGE.md's table between its markers is
    /// [`axes`]' (the help and the unknown-axis error print [`axis_names`]); the failure
    /// prints the table to paste.
    #[test]
    fn usage_lists_every_axis() {
        let usage = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/USAGE.md")).unwrap();
        let start = usage.find("<!-- axes: generated").expect("USAGE's axes marker");
        let body = &usage[start..];
        let (first, end) = (body.find('\n').unwrap() + 1, body.find("<!-- /axes -->").expect("end marker"));
        let table = usage_table();
        assert!(body[first..end] == table, "docs/USAGE.md's axes table is stale; it should read:\n{table}");
        let e = known("bogus").unwrap_err().to_string();
        assert!(e.ends_with(&axis_names()), "{e}");
        assert!(axis_help().ends_with(&axis_names()));
    }

    /// A program's own flags: a light count and a tile size, as the lab's example has.
    #[derive(Clone, Debug, Default, PartialEq)]
    struct Two {
        lights: u64,
        tile: u32,
    }

    impl Flags for Two {
        fn set_axis(&mut self, name: &str, value: &str) -> Result<()> {
            match name {
                "lights" => self.lights = value.parse().with_context(|| format!("lights '{value}'"))?,
                "tile-size" => self.tile = value.parse().with_context(|| format!("tile-size '{value}'"))?,
                _ => bail!("axis '{name}' is not one of this program's"),
            }
            Ok(())
        }
        fn plain(&self) -> Settings {
            let d = Settings::default();
            Settings { lights: Some(self.lights), tile_size: if self.tile == 0 { d.tile_size } else { self.tile }, ..d }
        }
    }

    /// Every row of the pass settings' table is an axis, described from the row, numeric
    /// exactly when the row holds a number; the hand-written axes stay.
    #[test]
    fn every_pass_setting_row_is_an_axis() {
        let all = axes();
        for row in KNOBS {
            let (_, d) = all.iter().find(|(n, _)| *n == row.name).unwrap_or_else(|| panic!("{} no axis", row.name));
            assert!(d.starts_with(row.label), "{d}");
            let numbers = matches!(row.kind, Kind::Count | Kind::Values(_));
            assert_eq!(is_numeric_axis(row.name), numbers || row.kind == Kind::Number, "{}", row.name);
            assert_eq!(is_integer_axis(row.name), numbers, "{}", row.name);
        }
        assert!(all.iter().any(|(n, _)| *n == "lights") && all.len() == SETTINGS.len() + AXES.len() + KNOBS.len());
        // So is every row of the run settings' table.
        for row in SETTINGS {
            let (_, d) = all.iter().find(|(n, _)| *n == row.name).unwrap_or_else(|| panic!("{} no axis", row.name));
            assert!(d.starts_with(row.label), "{d}");
        }
        assert!(format!("{:#}", parse_axis::<Two>("gbuffer-rts=2..4").unwrap_err()).contains("not one of this"));
        assert!(is_numeric_axis("threshold") && !is_numeric_axis("method"));
    }

    #[test]
    fn any_flags_type_takes_axes() {
        assert_eq!(parse_axis::<Two>("lights=64..1000").unwrap().values, ["64", "128", "256", "512", "1000"]);
        assert_eq!(parse_axis::<Two>("lights=64..65536:4").unwrap().values, ["64", "645", "6502", "65536"]);
        let e = |s: &str| format!("{:#}", parse_axis::<Two>(s).unwrap_err());
        // The range is the library settings' check.
        assert!(e("tile-size=12").contains("--tile-size 12"), "{}", e("tile-size=12"));
        assert!(e("seed=3").contains("not one of this program's"), "{}", e("seed=3"));
        assert!(e("colour=1").contains("unknown axis 'colour'"));
        let axes = vec![parse_axis::<Two>("lights=1,2").unwrap(), parse_axis::<Two>("tile-size=8,32").unwrap()];
        let p = points(&axes).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(args_at(&Two::default(), &axes, &p[3]).unwrap(), Two { lights: 2, tile: 32 });
        assert_eq!(describe(&axes, &p[1]), "lights=1 tile-size=32");
        assert_eq!(args_at(&Two::default(), &axes, &p[2]).unwrap().settings().unwrap().tile_size, 8);
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
    fn the_budget_sweeps_caster_counts_once_per_choice() {
        let axis =
            |name: &str, v: &[&str]| Axis { name: name.into(), values: v.iter().map(|s| s.to_string()).collect() };
        let axes = vec![
            axis("threshold", &["0.01", "0.1"]),
            axis("shadow-point-lights", &["4", "0", "16"]),
            axis("casters-by", &["brightness", "contribution"]),
        ];
        let p = points_one_at_a_time(&axes).unwrap();
        let series: Vec<String> = p.iter().map(|p| budget_series(&axes, p)).collect();
        let labels: Vec<String> = p.iter().map(|p| budget_label(&axes, p)).collect();
        assert_eq!(labels[0], "base");
        assert!(labels[1..].iter().all(|l| l != "base" && !l.is_empty()), "{labels:?}");
        assert_eq!(
            series,
            [
                "base",
                "threshold",
                "shadow-point-lights",
                "shadow-point-lights",
                "casters-by=contribution",
                "shadow-point-lights, casters-by=contribution",
                "shadow-point-lights, casters-by=contribution",
            ]
        );
        assert_eq!(p[5], ["0.01", "0", "contribution"]);
        // Without a choice axis: one dial at a time only.
        assert_eq!(points_one_at_a_time(&axes[..2]).unwrap().len(), 4);
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(format_number(0.1 * 0.5 * 0.5), "0.025");
        assert_eq!(format_number(400.0), "400");
    }
}
