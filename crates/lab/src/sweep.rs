//! `tiledlight sweep`: per-pass GPU time over a grid of settings (`--axis NAME=VALUES`,
//! any number of axes, every combination), one GPU context for the whole run, written
//! point by point to a resumable CSV and drawn as a chart of frame time (the sum of the
//! per-pass medians) against the x axis, one line per combination of the other axes. With
//! two lines over a numeric x, the chart marks where they cross.
//!
//! `--preset figure9` is the comparison of AMD's sample (reference 000, Figure 9): Forward+
//! vs Tiled Deferred over the light count, ~750k triangles, 4 G-buffer targets.
//!
//! A point whose measured frames dropped lights (a light grid full, [`crate::dropped`]) gets
//! a `warning:` line, its CSV rows say how many (`dropped_frames`, `dropped_lights`,
//! `dropped_lists`; the scene's load warnings in `load_warnings`; VPLs the cap refused in
//! `vpls_refused`, with their own `warning:` line), and the chart rings it in red as the
//! time of incomplete frames;
//! `--strict` fails once the CSV and the chart are written. A lost device (or out of GPU
//! memory) ends the run naming it; the points measured so far stay in the CSV and the same
//! command resumes after them.
//!
//! May depend on [`crate::axes`], [`crate::bench`] (the frame loop), [`crate::chart`],
//! [`crate::dropped`], [`crate::output`] and tiledlight-setup (the run, its culling
//! statistics).

use std::path::PathBuf;

use anyhow::{ensure, Context, Result};
use tiledlight_setup::{group_digits, Prepared, Reload, Settings};

use crate::axes::{self, Axis, Flags, ResumableCsv};
use crate::bench::{self, MAX_FRAMES};
use crate::chart::{self, AxisSpec, LineChart, Scale, Series};
use crate::dropped;

/// Named sweeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// AMD's Figure 9: frame time vs light count (32 to 16,384, denser around the
    /// sample's 1,792-light crossover; down to 32 because on an H100 the crossover lies
    /// below 256), Forward+ and Tiled Deferred, the default scene plus 280 medium grid
    /// objects (748,980 triangles), 4 G-buffer targets.
    Figure9,
}

impl Preset {
    /// The preset's axes (the light count first: lights are rebuilt per light count, the
    /// renderer per method).
    pub fn axes<F: Flags>(self) -> Vec<Axis> {
        let a = |spec: &str| axes::parse_axis::<F>(spec).expect("preset axes are valid");
        match self {
            Preset::Figure9 => vec![
                a("lights=32,64,128,256,512,1024,1536,1792,2048,3072,4096,8192,16384"),
                a("method=forward-plus,deferred"),
                a("grid-objects=280"),
                a("density=medium"),
                a("gbuffer-rts=4"),
            ],
        }
    }

    /// The flag value.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Figure9 => "figure9",
        }
    }
}

/// A sweep (the app's `sweep` flags besides the scene's).
#[derive(Clone, Debug)]
pub struct Sweep {
    /// Axes, `NAME=VALUES` each ([`axes::parse_axis`]).
    pub axes: Vec<String>,
    /// A named sweep; `axes` replace its axes of the same name.
    pub preset: Option<Preset>,
    /// Measured frames per point.
    pub frames: u32,
    /// Frames rendered before measuring each point.
    pub warmup: u32,
    /// CSV output [default: out/sweep.csv, or out/PRESET.csv].
    pub out: Option<PathBuf>,
    /// Chart output [default: the CSV path with .png].
    pub chart: Option<PathBuf>,
    /// The axis on the chart's x [default: the first numeric axis with several values].
    pub x: Option<String>,
}

/// The columns before the axes and after them (per pass).
const HEAD: [&str; 3] = ["adapter", "width", "height"];
/// `dropped_*`: over the point's measured frames whose light-grid headers were read back
/// (opaque and blended grids together; empty for a method without a grid);
/// `load_warnings`: the scene's ([`dropped::load_warnings_cell`]).
const TAIL: [&str; 13] = [
    "triangles",
    "mean_lights_per_tile",
    "max_lights_per_tile",
    "pass",
    "median_ms",
    "min_ms",
    "max_ms",
    "frames",
    "dropped_frames",
    "dropped_lights",
    "dropped_lists",
    dropped::LOAD_WARNINGS_COLUMN,
    dropped::VPLS_REFUSED_COLUMN,
];
/// The pseudo-pass holding the sum of the pass medians.
pub const TOTAL: &str = "total";

/// The CSV header of a sweep over `axes`.
pub fn header(axes: &[Axis]) -> Vec<String> {
    HEAD.iter()
        .map(|s| s.to_string())
        .chain(axes.iter().map(|a| a.name.clone()))
        .chain(TAIL.iter().map(|s| s.to_string()))
        .collect()
}

/// Where two lines cross.
#[derive(Clone, Debug, PartialEq)]
pub enum Crossing {
    /// The first crossing, interpolated (linearly in the chart's x scale), and how many
    /// times the lines cross in all.
    At {
        /// The x where they cross.
        x: f64,
        /// The series that is lower (faster) before the crossing.
        lower_before: usize,
        /// Sign changes in all.
        count: usize,
    },
    /// One series is lower at every common x.
    None {
        /// Which.
        lower: usize,
    },
    /// Fewer than two common x values.
    Unknown,
}

/// The crossing of series `a` (index 0) and `b` (index 1) over their common x values.
pub fn crossing(a: &Series, b: &Series, scale: Scale) -> Crossing {
    let common: Vec<(f64, f64)> = a
        .points
        .iter()
        .filter_map(|&(x, ya)| b.points.iter().find(|p| p.0 == x).map(|&(_, yb)| (x, ya - yb)))
        .collect();
    if common.len() < 2 {
        return Crossing::Unknown;
    }
    let mut first = None;
    let mut count = 0;
    for w in common.windows(2) {
        let ((x0, d0), (x1, d1)) = (w[0], w[1]);
        if d0 != 0.0 && d1 != 0.0 && (d0 < 0.0) != (d1 < 0.0) {
            count += 1;
            if first.is_none() {
                let t = d0 / (d0 - d1);
                let u = scale.map(x0) + t * (scale.map(x1) - scale.map(x0));
                first = Some((scale.unmap(u), if d0 < 0.0 { 0 } else { 1 }));
            }
        }
    }
    match first {
        Some((x, lower_before)) => Crossing::At { x, lower_before, count },
        None => Crossing::None { lower: if common.iter().map(|c| c.1).sum::<f64>() < 0.0 { 0 } else { 1 } },
    }
}

/// Runs `tiledlight sweep`.
pub fn run<F: Flags>(scene: &F, args: &Sweep) -> Result<()> {
    ensure!((1..=MAX_FRAMES).contains(&args.frames), "--frames {}: must be between 1 and {MAX_FRAMES}", args.frames);
    ensure!(args.warmup <= MAX_FRAMES, "--warmup {}: must be at most {MAX_FRAMES}", args.warmup);
    let given: Vec<Axis> = args.axes.iter().map(|s| axes::parse_axis::<F>(s)).collect::<Result<_>>()?;
    let axes = match args.preset {
        Some(p) => axes::merge_axes(p.axes::<F>(), given),
        None => given,
    };
    let (points, unread) = axes::without_unread(scene, &axes, axes::points(&axes)?)?;
    if let Some(line) = axes::unread_line(unread) {
        println!("{line}");
    }
    let x_axis = chart_x_axis(&axes, args.x.as_deref())?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/{}.csv", args.preset.map(Preset::name).unwrap_or("sweep"))));
    let chart_path = args.chart.clone().unwrap_or_else(|| axes::sibling(&out, "png"));
    let ext = chart_path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "--chart {}: only .png charts are supported", chart_path.display());
    crate::output::check_output("--out", &out)?;
    crate::output::check_output("--chart", &chart_path)?;
    // Every point's flags are checked before the first is measured.
    let all_args: Vec<Settings> =
        points.iter().map(|p| axes::args_at(scene, &axes, p).and_then(|a| a.settings())).collect::<Result<_>>()?;

    let head = header(&axes);
    let n_axes = axes.len();
    let key: Vec<usize> = (HEAD.len()..HEAD.len() + n_axes).collect();
    let pass_col = HEAD.len() + n_axes + 3;
    let mut csv = ResumableCsv::open(&out, &head, &key, Some((pass_col, TOTAL)))?;
    let pending: Vec<usize> = (0..points.len()).filter(|&i| !csv.is_done(&points[i])).collect();
    println!(
        "sweep:      {} points ({}), {} already in {}",
        points.len(),
        axes.iter().map(|a| format!("{} x{}", a.name, a.values.len())).collect::<Vec<_>>().join(", "),
        points.len() - pending.len(),
        out.display()
    );
    let mut adapter = None;
    let mut prep: Option<Prepared> = None;
    let mut warnings = 0;
    let pb = axes::progress(pending.len());
    for (done, &i) in pending.iter().enumerate() {
        let (point, pargs) = (&points[i], &all_args[i]);
        let what = axes::describe(&axes, point);
        pb.set_message(what.clone());
        let measured = measure_point(&mut prep, &mut adapter, &mut csv, (point, pargs, &what), args, &out, &pb);
        match measured {
            Ok(Some(w)) => axes::warn(&pb, &mut warnings, &format!("{what}: {w}")),
            Ok(None) => {}
            Err(e) => {
                pb.finish_and_clear();
                let progress = axes::Progress {
                    point: &what,
                    done: points.len() - pending.len() + done,
                    total: points.len(),
                    csv: &out,
                };
                return Err(axes::interrupted(e, prep.as_ref(), &progress));
            }
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    let rows = csv.read_all()?;
    let note = draw(&chart_path, &axes, &x_axis, &rows, (&scene.scene_label(), args))?;
    println!("wrote {} and {}", out.display(), chart_path.display());
    if let Some(n) = note {
        println!("chart:      {n}");
    }
    dropped::strict(all_args.iter().any(|a| a.strict), warnings)
}

/// Measures one point and appends its rows to the CSV; returns the warning about its
/// frames, if they dropped lights.
fn measure_point(
    prep: &mut Option<Prepared>,
    adapter: &mut Option<String>,
    csv: &mut ResumableCsv,
    (point, pargs, what): (&axes::Point, &Settings, &String),
    args: &Sweep,
    out: &std::path::Path,
    pb: &indicatif::ProgressBar,
) -> Result<Option<String>> {
    let what = what.clone();
    let p = match prep.as_mut() {
        Some(p) => {
            let plan = p.reconfigure(pargs).with_context(|| what.clone())?;
            if plan.reload == Reload::Scene {
                pb.suspend(|| crate::output::print_load_warnings(&p.scene_warnings));
            }
            p
        }
        None => {
            let p = Prepared::new(pargs).with_context(|| what.clone())?;
            pb.suspend(|| crate::output::print_load_warnings(&p.scene_warnings));
            let name = p.ctx.info.name.clone();
            axes::check_same_setup(
                &csv.existing,
                [0, 1, 2],
                [&name, &pargs.width.to_string(), &pargs.height.to_string()],
                out,
            )?;
            axes::say(pb, format!("adapter:    {}", p.ctx.describe()));
            *adapter = Some(name);
            prep.insert(p)
        }
    };
    let mut renderer = p.renderer(false).with_context(|| what.clone())?;
    let m = bench::measure(p, &mut renderer, args.warmup, args.frames).with_context(|| what.clone())?;
    ensure!(m.timestamps, "the adapter has no timestamp queries: a sweep needs GPU pass times");
    let stats = p.culling_stats(&renderer)?;
    let passes = m.passes();
    ensure!(!passes.is_empty(), "{what}: no frame's timestamps came back");
    let total: f64 = passes.iter().map(|ps| ps.summary.median_ms).sum();
    let mut lead = vec![adapter.clone().unwrap_or_default(), pargs.width.to_string(), pargs.height.to_string()];
    lead.extend(point.iter().cloned());
    lead.push(p.scene_gpu.triangles.to_string());
    lead.push(stats.as_ref().map(|s| format!("{:.2}", s.mean_per_list)).unwrap_or_default());
    lead.push(stats.as_ref().map(|s| s.max_per_list.to_string()).unwrap_or_default());
    let mut rows: Vec<Vec<String>> = passes
        .iter()
        .map(|ps| {
            let s = ps.summary;
            let mut r = lead.clone();
            r.extend([ps.pass.clone(), ms(s.median_ms), ms(s.min_ms), ms(s.max_ms), s.frames.to_string()]);
            r
        })
        .collect();
    let frames = passes.iter().map(|ps| ps.summary.frames).min().unwrap_or(0);
    let mut r = lead.clone();
    r.extend([TOTAL.to_string(), ms(total), String::new(), String::new(), frames.to_string()]);
    rows.push(r);
    let dropped = m.dropped();
    let vpls = renderer.vpl_count(&p.ctx).context("reading the VPL count back")?;
    for r in &mut rows {
        r.extend(dropped.csv());
        r.push(dropped::load_warnings_cell(&p.scene_warnings));
        r.push(dropped::vpls_refused_cell(vpls));
    }
    csv.append(&rows)?;
    let mark = dropped.mark().map(|d| format!(" ({d}: incomplete frames)")).unwrap_or_default();
    axes::say(pb, format!("{what}: {total:.3} ms{mark}"));
    let max_binding = p.ctx.device.limits().max_storage_buffer_binding_size;
    let refused = vpls.and_then(|c| crate::dropped::refused_line("the measured frames", c));
    Ok(dropped::join_warnings(dropped.warning("the measured frames", p.settings.grid_pairs, max_binding), refused))
}

fn ms(v: f64) -> String {
    format!("{v:.4}")
}

/// The axis on the chart's x: `--x`, else the first numeric axis with several values,
/// else the first with several values, else the first.
pub fn chart_x_axis(axes: &[Axis], x: Option<&str>) -> Result<String> {
    if let Some(x) = x {
        ensure!(axes.iter().any(|a| a.name == x), "--x {x}: not one of the swept axes");
        return Ok(x.to_string());
    }
    let multi = |a: &&Axis| a.values.len() > 1;
    let pick = axes
        .iter()
        .filter(multi)
        .find(|a| axes::is_numeric_axis(&a.name))
        .or_else(|| axes.iter().find(multi))
        .or(axes.first());
    Ok(pick.map(|a| a.name.clone()).unwrap_or_default())
}

/// Draws the chart of the `total` rows; returns the crossover sentence, if any.
fn draw(
    path: &std::path::Path,
    axes: &[Axis],
    x_axis: &str,
    rows: &[Vec<String>],
    (scene, args): (&str, &Sweep),
) -> Result<Option<String>> {
    let col = |name: &str| header(axes).iter().position(|h| h == name).expect("known column");
    let (xc, pass, total, dropped) = (col(x_axis), col("pass"), col("median_ms"), col("dropped_frames"));
    let xi = axes.iter().position(|a| a.name == x_axis).expect("x is an axis");
    let numeric = axes::is_numeric_axis(x_axis);
    // Lines: one per combination of the other axes that have several values.
    let others: Vec<usize> = (0..axes.len()).filter(|&i| i != xi && axes[i].values.len() > 1).collect();
    let fixed: Vec<String> = axes
        .iter()
        .enumerate()
        .filter(|(i, a)| *i != xi && a.values.len() == 1)
        .map(|(_, a)| format!("{}={}", a.name, a.values[0]))
        .collect();
    let mut series: Vec<Series> = Vec::new();
    let totals: Vec<&Vec<String>> = rows.iter().filter(|r| r[pass] == TOTAL).collect();
    for r in &totals {
        let name = others.iter().map(|&i| r[col(&axes[i].name)].clone()).collect::<Vec<_>>().join(", ");
        let name = if name.is_empty() { "frame time".to_string() } else { name };
        let x = if numeric {
            r[xc].parse::<f64>().with_context(|| format!("CSV value '{}' of {x_axis}", r[xc]))?
        } else {
            axes[xi].values.iter().position(|v| *v == r[xc]).map(|p| p as f64).unwrap_or(f64::NAN)
        };
        let y: f64 = r[total].parse().with_context(|| format!("CSV total '{}'", r[total]))?;
        if !x.is_finite() {
            continue; // a value of an older run's axis not swept now
        }
        let incomplete = r[dropped].parse::<u64>().is_ok_and(|n| n > 0);
        let s = match series.iter().position(|s| s.name == name) {
            Some(i) => &mut series[i],
            None => {
                series.push(Series { name, points: Vec::new(), incomplete: Vec::new() });
                series.last_mut().expect("just pushed")
            }
        };
        s.points.push((x, y));
        if incomplete {
            s.incomplete.push((x, y));
        }
    }
    for s in &mut series {
        s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let incomplete = series.iter().map(|s| s.incomplete.len()).sum::<usize>();
    let xscale = if numeric {
        Scale::auto(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)), 8.0)
    } else {
        Scale::Linear
    };
    let yscale = Scale::auto(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)), 20.0);
    let (mut marker, mut note) = (None, None);
    if numeric && series.len() == 2 {
        let unit = x_axis.replace('-', " ");
        match crossing(&series[0], &series[1], xscale) {
            Crossing::At { x, lower_before, count } => {
                let (lo, hi) = (&series[lower_before].name, &series[1 - lower_before].name);
                let more = if count > 1 { format!(" ({count} crossings)") } else { String::new() };
                let text =
                    format!("crossover ~{} {unit}: {lo} faster below, {hi} above{more}", chart::tick_label(x.round()));
                marker = Some((x, format!("crossover ~{}", chart::tick_label(x.round()))));
                note = Some(text);
            }
            Crossing::None { lower } => {
                note = Some(format!("no crossover in range: {} faster at every {unit} value", series[lower].name));
            }
            Crossing::Unknown => {}
        }
    }
    if incomplete > 0 {
        let s = if incomplete == 1 { "" } else { "s" };
        let text = format!("{incomplete} point{s} ringed red: frames DROPPED lights");
        note = Some(match note {
            Some(n) => format!("{n}; {text}"),
            None => text,
        });
    }
    let first = totals.first();
    let adapter = first.map(|r| r[0].clone()).unwrap_or_default();
    let res = first.map(|r| format!("{}x{}", r[1], r[2])).unwrap_or_default();
    let tris =
        first.map(|r| r[col("triangles")].parse::<u64>().map(group_digits).unwrap_or_default()).unwrap_or_default();
    let chart = LineChart {
        title: format!("Frame time vs {x_axis}: {adapter}, {res}"),
        subtitle: format!(
            "{}, {tris} triangles{}{}; per pass the median of {} frames after {} warm-up",
            scene,
            if fixed.is_empty() { "" } else { ", " },
            fixed.join(", "),
            args.frames,
            args.warmup
        ),
        x: AxisSpec {
            label: x_axis.replace('-', " "),
            scale: xscale,
            ticks: numeric.then(|| {
                let mut v: Vec<f64> = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
                v.sort_by(f64::total_cmp);
                v.dedup();
                v
            }),
        },
        y: AxisSpec { label: "GPU frame time, ms (sum of pass medians)".into(), scale: yscale, ticks: None },
        series,
        marker,
        note: note.clone(),
        categories: (!numeric).then(|| axes[xi].values.clone()),
    };
    chart::line_chart(path, &chart)?;
    Ok(note)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(pts: &[(f64, f64)]) -> Series {
        Series { name: String::new(), points: pts.to_vec(), incomplete: Vec::new() }
    }

    #[test]
    fn crossing_is_interpolated() {
        let a = s(&[(1.0, 1.0), (2.0, 3.0), (4.0, 5.0)]);
        let b = s(&[(1.0, 2.0), (2.0, 2.0), (4.0, 3.0)]);
        assert_eq!(crossing(&a, &b, Scale::Linear), Crossing::At { x: 1.5, lower_before: 0, count: 1 });
        match crossing(&a, &b, Scale::Log) {
            Crossing::At { x, .. } => assert!((x - 2f64.sqrt()).abs() < 1e-12),
            c => panic!("{c:?}"),
        }
        let c = s(&[(1.0, 0.5), (2.0, 0.5), (4.0, 0.5)]);
        assert_eq!(crossing(&a, &c, Scale::Linear), Crossing::None { lower: 1 });
        assert_eq!(crossing(&a, &s(&[(9.0, 1.0)]), Scale::Linear), Crossing::Unknown);
    }
}
