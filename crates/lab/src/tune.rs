//! `tiledlight tune`: the fastest setting within an error budget, measured against the
//! traced truth (issue 44). The question a user brings: "which method and which dials give
//! me FLIP under E on my scene, fastest?"
//!
//! 1. **Dials**: `--dial NAME=VALUES` (axes of [`crate::axes::axes`]), or
//!    [`DEFAULT_DIALS`]. The first value of each dial is where the search starts.
//! 2. **Constraints** ([`Constraints`]): FLIP mean under the target, and optionally its
//!    99th percentile and the worst pixel's HDR error (`max_error`) under theirs; frames that
//!    dropped lights never qualify (their time is of less work), nor does a setting slower
//!    than the truth (the truth is exact: the answer is then the truth itself).
//! 3. **Coordinate descent**: for each dial the current method reads, in turn, every value
//!    the settings accept with the other dials at the current setting is measured
//!    (accuracy's session: one truth per scene, camera and light set, reused by every
//!    candidate; candidates already in the CSV are not measured again, so a rerun
//!    resumes). The current setting moves to the fastest candidate that
//!    meets every constraint (of those within [`TIME_TIE`] of it, the most accurate);
//!    while none does, to the most accurate (of those within [`FLIP_TIE`] of it, the
//!    fastest) ([`pick`]). Passes over the dials repeat until one changes nothing (at
//!    most `passes`).
//! 4. **Views** (`--bookmarks a,b,c`): every candidate is measured from each camera
//!    bookmark (a `camera` column; one truth per view) and judged by its worst view: the
//!    slowest time, the largest errors; it meets the budget only where it meets it from
//!    every view and is faster than the truth in each ([`Candidate::worst_of`]).
//! 5. **Answer**: the fastest setting meeting the budget among every candidate in the CSV
//!    (so a tighter budget over the same CSV never answers with a faster setting the CSV
//!    already held, beyond the [`TIME_TIE`] within which the more accurate wins; its own
//!    descent may measure a faster one the first run's path never reached), else where the descent
//!    ended; its time (the median of the measured frames, with the fastest and slowest
//!    frame), its errors, and two command lines: one that renders it and one that measures
//!    it again. One CSV per scene, camera and light set: its rows are compared as one.
//!
//! Coordinate descent finds a local optimum: dials that only pay together (more casters
//! *and* a tighter threshold) can be missed; list such a pair's values on one dial's
//! neighbour by running again from that start. Depends on [`crate::accuracy`] and
//! [`crate::axes`].

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{ensure, Context, Result};
use tiledlight_setup::Settings;

use crate::accuracy::{self, Accuracy, ReferenceKind, Session, VplReference};
use crate::axes::{self, Axis, Flags, Point};

/// The dials searched when none is given: the method, the radius cutoff, the casters and
/// their choice, the shadow atlas, the culling test, MSAA, and the stochastic method's near
/// candidates (4096: every light of a pixel's list) and rays a pixel (a dial is searched
/// only while the current method reads it). The first value of each is the
/// start (the defaults of a user who has not tuned anything yet, at a threshold where the
/// cutoff's lost light and the unshadowed lights' added light roughly balance).
pub const DEFAULT_DIALS: [&str; 10] = [
    "method=deferred,visibility,forward-plus,stochastic",
    "threshold=0.0015,0.003,0.00625,0.025,0.1,0.0006",
    "shadow-point-lights=16,0,64,256",
    "casters-by=contribution,brightness",
    "shadow-size=512,256,1024",
    "shadow-filter=3,1,5",
    "aabb=on,off",
    "msaa=1,4",
    "candidates=4,16,4096",
    "rays=1,2,4",
];

/// What a setting must meet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constraints {
    /// FLIP mean below this.
    pub flip: f64,
    /// FLIP's 99th percentile below this.
    pub p99: Option<f64>,
    /// The worst pixel's HDR error (`max_error`, relative to the reference's peak) below this.
    pub worst: Option<f64>,
}

/// A tuning run (the app's `tune` flags besides the scene's).
#[derive(Clone, Debug)]
pub struct Tune {
    /// What the answer must meet.
    pub constraints: Constraints,
    /// Dials, `NAME=VALUES` each (empty: [`DEFAULT_DIALS`]).
    pub dials: Vec<String>,
    /// Measured frames per candidate.
    pub frames: u32,
    /// Frames rendered before measuring each candidate.
    pub warmup: u32,
    /// Measured frames of the truth.
    pub reference_frames: u32,
    /// Most passes over the dials.
    pub passes: u32,
    /// CSV of every candidate measured [default: out/tune.csv]; a rerun resumes from it.
    pub out: Option<PathBuf>,
    /// Camera bookmarks the budget must hold from (empty: the scene flags' camera).
    pub bookmarks: Vec<PathBuf>,
}

/// One measured candidate, as [`pick`] judges it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Median GPU frame time (sum of the passes' medians), ms.
    pub time: f64,
    /// The truth's time, ms.
    pub reference_time: f64,
    /// FLIP mean, p99 and the worst pixel's HDR error against the truth.
    pub flip: f64,
    /// FLIP's 99th percentile.
    pub p99: f64,
    /// `max_error`.
    pub worst: f64,
    /// Its frames dropped lights.
    pub incomplete: bool,
}

impl Candidate {
    /// One setting seen from several views, judged by its worst: the slowest time, the
    /// largest errors, incomplete if any view dropped lights. Its truth time is scaled so
    /// that it is faster than it exactly when it is faster than the truth in every view
    /// (`time * min(truth_i / time_i)`). None for no views.
    pub fn worst_of(views: &[Candidate]) -> Option<Candidate> {
        // NaN (an unmeasured number) in any view makes the whole NaN: it never qualifies.
        let fold = |f: &dyn Fn(&Candidate) -> f64, pick: fn(f64, f64) -> f64| {
            views.iter().map(f).reduce(|a, b| if a.is_nan() || b.is_nan() { f64::NAN } else { pick(a, b) })
        };
        // One view is its own verdict (no rescaled truth time to round).
        if let [one] = views {
            return Some(*one);
        }
        let max = |f: fn(&Candidate) -> f64| fold(&f, f64::max).unwrap_or(f64::NAN);
        let time = max(|c| c.time);
        let margin = fold(&|c: &Candidate| c.reference_time / c.time, f64::min).unwrap_or(f64::NAN);
        (!views.is_empty()).then(|| Candidate {
            time,
            reference_time: time * margin,
            flip: max(|c| c.flip),
            p99: max(|c| c.p99),
            worst: max(|c| c.worst),
            incomplete: views.iter().any(|c| c.incomplete),
        })
    }

    /// Whether it meets `c` (and is complete and faster than the truth).
    pub fn meets(&self, c: &Constraints) -> bool {
        !self.incomplete
            && self.time < self.reference_time
            && self.flip < c.flip
            && c.p99.is_none_or(|p| self.p99 < p)
            && c.worst.is_none_or(|w| self.worst < w)
    }
}

/// Times within this share of the fastest feasible candidate's count as equally fast: the
/// more accurate of them wins. Measured on the H200: 256 casters chosen by contribution
/// took 16.988 ms (FLIP 0.131), by brightness 16.936 ms (FLIP 0.150): a 0.3% difference,
/// within what another run moves, for 14% more error.
pub const TIME_TIE: f64 = 0.01;

/// FLIP means within this of the most accurate infeasible candidate count as equally
/// accurate: the faster of them wins, so the search does not move to a 35x slower method
/// for 0.0005 of FLIP (Forward+ against Tiled Deferred on the H200) while no candidate
/// meets the budget yet.
pub const FLIP_TIE: f64 = 0.002;

/// The candidate to move to: among those that meet `c`, the most accurate of those within
/// [`TIME_TIE`] of the fastest; while none meets it, the fastest of those within
/// [`FLIP_TIE`] of the lowest FLIP mean. None for no candidates. NaN never wins.
pub fn pick(candidates: &[Candidate], c: &Constraints) -> Option<usize> {
    let by_flip = |a: &usize, b: &usize| {
        let (x, y) = (&candidates[*a], &candidates[*b]);
        x.flip.total_cmp(&y.flip).then(x.time.total_cmp(&y.time))
    };
    let by_time = |a: &usize, b: &usize| {
        let (x, y) = (&candidates[*a], &candidates[*b]);
        x.time.total_cmp(&y.time).then(x.flip.total_cmp(&y.flip))
    };
    let feasible: Vec<usize> = (0..candidates.len()).filter(|&i| candidates[i].meets(c)).collect();
    if let Some(fastest) = feasible.iter().copied().min_by(by_time) {
        let limit = candidates[fastest].time * (1.0 + TIME_TIE);
        return feasible.into_iter().filter(|&i| candidates[i].time <= limit).min_by(by_flip);
    }
    let finite: Vec<usize> =
        (0..candidates.len()).filter(|&i| candidates[i].flip.is_finite() && candidates[i].time.is_finite()).collect();
    let best = finite.iter().copied().min_by(by_flip)?;
    let limit = candidates[best].flip + FLIP_TIE;
    finite.into_iter().filter(|&i| candidates[i].flip <= limit).min_by(by_time)
}

/// The flags that render `point` of `dials` (`--method deferred --threshold 0.003 ...`;
/// on/off dials as a bare flag when on, nothing when off).
pub fn render_flags(dials: &[Axis], point: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for (a, v) in dials.iter().zip(point) {
        match v.as_str() {
            "on" => out.push(format!("--{}", a.name)),
            "off" => {}
            _ => out.extend([format!("--{}", a.name), v.clone()]),
        }
    }
    out
}

/// What [`run`] found.
#[derive(Clone, Debug)]
pub struct Answer {
    /// The dials.
    pub dials: Vec<Axis>,
    /// The chosen setting (one value per dial).
    pub point: Point,
    /// It meets the constraints (else it is the closest found, and the truth is the answer).
    pub meets: bool,
    /// The views (bookmark paths; empty: the scene flags' camera).
    pub views: Vec<String>,
    /// Its CSV rows by column, one per view (one without views).
    pub rows: Vec<HashMap<String, String>>,
    /// Its verdict over the views (their worst).
    pub judged: Candidate,
    /// Candidates measured in all (settings, each from every view).
    pub measured: usize,
}

/// A row's number (NaN when empty).
fn num(row: &HashMap<String, String>, col: &str) -> f64 {
    row.get(col).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
}

fn candidate(row: &HashMap<String, String>) -> Candidate {
    Candidate {
        time: num(row, "total_ms"),
        reference_time: num(row, "reference_ms"),
        flip: num(row, "flip_mean"),
        p99: num(row, "flip_p99"),
        worst: num(row, "max_error"),
        incomplete: num(row, "dropped_frames") > 0.0,
    }
}

/// Runs the search (module doc) and prints its progress and answer.
pub fn run<F: Flags>(scene: &F, t: &Tune) -> Result<Answer> {
    let c = &t.constraints;
    ensure!(c.flip.is_finite() && c.flip > 0.0 && c.flip <= 1.0, "--target-flip {}: must be in (0, 1]", c.flip);
    if let Some(p) = c.p99 {
        ensure!(p.is_finite() && p > 0.0 && p <= 1.0, "--target-p99 {p}: must be in (0, 1]");
    }
    if let Some(w) = c.worst {
        ensure!(w.is_finite() && w > 0.0, "--max-worst {w}: must be a positive number");
    }
    ensure!((1..=20).contains(&t.passes), "--passes {}: must be between 1 and 20", t.passes);
    let specs: Vec<String> =
        if t.dials.is_empty() { DEFAULT_DIALS.iter().map(|s| s.to_string()).collect() } else { t.dials.clone() };
    let dials: Vec<Axis> = specs.iter().map(|s| axes::parse_axis::<F>(s)).collect::<Result<_>>()?;
    let mut names = std::collections::HashSet::new();
    for d in &dials {
        ensure!(names.insert(d.name.as_str()), "dial '{}' is given twice", d.name);
    }
    let out = t.out.clone().unwrap_or_else(|| PathBuf::from("out/tune.csv"));
    crate::output::check_output("--out", &out)?;
    let args = Accuracy {
        axes: specs.clone(),
        frames: t.frames,
        warmup: t.warmup,
        reference_frames: t.reference_frames,
        camera_orbit: 0.0,
        reference_cache: None,
        reference: ReferenceKind::Traced,
        vpl_reference_rsm: VplReference::Scale(1),
        target_flip: c.flip,
        budget: false,
        out: Some(out.clone()),
        chart: None,
        diff_dir: None,
    };
    accuracy::check_frames(&args)?;
    // The views: a camera axis after the dials (each candidate measured from every one).
    let views: Vec<String> = t.bookmarks.iter().map(|b| b.display().to_string()).collect();
    ensure!(!names.contains("camera"), "the camera is not a dial: give the views with --bookmarks");
    let mut seen = std::collections::HashSet::new();
    if let Some(v) = views.iter().find(|v| !seen.insert(v.as_str())) {
        anyhow::bail!("--bookmarks: {v} is given twice");
    }
    let mut axes_measured = dials.clone();
    if !views.is_empty() {
        let spec = format!("camera={}", views.join(","));
        axes_measured.push(axes::parse_axis::<F>(&spec).context("--bookmarks")?);
    }
    let in_views = |p: &Point| -> Vec<Point> {
        if views.is_empty() {
            return vec![p.clone()];
        }
        views.iter().map(|v| p.iter().cloned().chain([v.clone()]).collect()).collect()
    };
    let mut session = Session::open(&out, &axes_measured, false, &args)?;
    let head = accuracy::header(&axes_measured);
    let by_point = |session: &Session| -> Result<HashMap<Point, HashMap<String, String>>> {
        let rows = session.csv.read_all()?;
        let first = accuracy::HEAD.len();
        Ok(rows
            .into_iter()
            .map(|r| {
                let key = r[first..first + axes_measured.len()].to_vec();
                (key, head.iter().cloned().zip(r).collect())
            })
            .collect())
    };
    // A candidate's rows (one per view) and its verdict; None while a view is missing.
    let judged = |rows: &HashMap<Point, HashMap<String, String>>, p: &Point| {
        let rows: Option<Vec<HashMap<String, String>>> = in_views(p).iter().map(|q| rows.get(q).cloned()).collect();
        let rows = rows?;
        let views: Vec<Candidate> = rows.iter().map(candidate).collect();
        Some((Candidate::worst_of(&views)?, rows))
    };
    println!(
        "tune:       {} dials ({}), FLIP mean < {}{}{}; against the traced truth{}; {} already in {}",
        dials.len(),
        dials.iter().map(|a| format!("{} x{}", a.name, a.values.len())).collect::<Vec<_>>().join(", "),
        c.flip,
        c.p99.map(|p| format!(", p99 < {p}")).unwrap_or_default(),
        c.worst.map(|w| format!(", worst pixel < {w}")).unwrap_or_default(),
        if views.is_empty() { String::new() } else { format!(" from each of {} views", views.len()) },
        session.csv.existing.len(),
        out.display()
    );
    let mut current: Point = dials.iter().map(|d| d.values[0].clone()).collect();
    let base_method = scene.plain().method;
    for pass in 1..=t.passes {
        let mut changed = false;
        for (k, dial) in dials.iter().enumerate() {
            // A dial the current method does not read would measure its setting again under
            // each value (the stochastic method has no shadow atlas, the tiled ones no rays).
            if !axes::reads(&dial.name, axes::method_at(&dials, &current, base_method)) {
                continue;
            }
            // Values the settings refuse with the others as they are (the stochastic
            // method's one sample a pixel at 4x MSAA) are no candidates; the current
            // setting itself must be valid.
            let mut points = Vec::new();
            let mut settings: Vec<Settings> = Vec::new();
            for v in &dial.values {
                let mut p = current.clone();
                p[k] = v.clone();
                let of_views: Result<Vec<Settings>> = in_views(&p)
                    .iter()
                    .map(|q| axes::args_at(scene, &axes_measured, q).and_then(|a| a.settings()))
                    .collect();
                match of_views {
                    Ok(s) => {
                        settings.extend(s);
                        points.push(p);
                    }
                    // (The error names the point: `args_at` says which values it was at.)
                    Err(e) if p != current => println!("skipped:    {e:#}"),
                    Err(e) => return Err(e),
                }
            }
            let measured: Vec<Point> = points.iter().flat_map(&in_views).collect();
            session.measure(&axes_measured, (&measured, &settings), &args, &out)?;
            let rows = by_point(&session)?;
            let cands: Vec<Candidate> = points
                .iter()
                .map(|p| judged(&rows, p).map(|j| j.0).context("a measured candidate is missing from the CSV"))
                .collect::<Result<_>>()?;
            let Some(best) = pick(&cands, c) else { continue };
            if points[best] != current {
                let b = &cands[best];
                println!(
                    "pass {pass}, {}: {} -> {} ({:.3} ms, FLIP mean {:.4}{}{})",
                    dial.name,
                    current[k],
                    points[best][k],
                    b.time,
                    b.flip,
                    if views.is_empty() { "" } else { " in the worst view" },
                    if b.meets(c) { ", meets the budget" } else { ", closest so far" }
                );
                current = points[best].clone();
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    // The answer: the fastest feasible setting among every candidate in the CSV (the
    // descent's path and earlier runs' alike, measured from every view), else where the
    // descent ended. So a run with a tighter budget over the same CSV never answers with a
    // faster setting.
    let rows = by_point(&session)?;
    let mut points: Vec<Point> = rows.keys().map(|p| p[..dials.len()].to_vec()).collect();
    points.sort();
    points.dedup();
    let all: Vec<(Point, Candidate)> =
        points.into_iter().filter_map(|p| judged(&rows, &p).map(|(c, _)| (p, c))).collect();
    let measured: Vec<Candidate> = all.iter().map(|(_, c)| *c).collect();
    let chosen = match pick(&measured, c).filter(|&i| measured[i].meets(c)) {
        Some(i) => all[i].0.clone(),
        None => current,
    };
    let (cand, rows_of) = judged(&rows, &chosen).context("the chosen setting is missing from the CSV")?;
    Ok(Answer { meets: cand.meets(c), dials, point: chosen, views, rows: rows_of, judged: cand, measured: all.len() })
}

impl Answer {
    /// The answer in words: the setting, its time and spread, its errors (the worst view's,
    /// then each view's), or why the truth itself is the answer.
    pub fn summary(&self) -> String {
        let what = axes::describe(&self.dials, &self.point);
        let numbers = |r: &HashMap<String, String>| {
            let n = |c: &str| num(r, c);
            format!(
                "{:.3} ms (frames {:.3}-{:.3} ms), FLIP mean {:.4} p99 {:.4}, worst pixel {:.3}; the truth {:.3} ms",
                n("total_ms"),
                n("frame_min_ms"),
                n("frame_max_ms"),
                n("flip_mean"),
                n("flip_p99"),
                n("max_error"),
                n("reference_ms")
            )
        };
        let j = &self.judged;
        let overall = match self.rows.as_slice() {
            [one] => numbers(one),
            _ => format!(
                "{:.3} ms, FLIP mean {:.4} p99 {:.4}, worst pixel {:.3} in the worst of {} views",
                j.time,
                j.flip,
                j.p99,
                j.worst,
                self.rows.len()
            ),
        };
        let mut out = if self.meets {
            format!("fastest within the budget: {what}: {overall} ({} candidates measured)", self.measured)
        } else {
            format!(
                "no setting faster than the truth meets the budget; the closest found: {what}: {overall} ({} candidates measured): render the truth itself (--method traced-reference)",
                self.measured
            )
        };
        if self.rows.len() > 1 {
            for (v, r) in self.views.iter().zip(&self.rows) {
                out.push_str(&format!("\n  from {v}: {}", numbers(r)));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(time: f64, flip: f64) -> Candidate {
        Candidate { time, reference_time: 100.0, flip, p99: flip * 3.0, worst: flip * 10.0, incomplete: false }
    }

    /// The fastest feasible candidate wins; while none is feasible, the most accurate; a
    /// candidate that dropped lights, one slower than the truth and one past the p99 or
    /// worst-pixel limit never count as feasible.
    #[test]
    fn pick_takes_the_fastest_within_the_budget() {
        let c = Constraints { flip: 0.05, p99: None, worst: None };
        let cands = [cand(30.0, 0.04), cand(10.0, 0.06), cand(20.0, 0.03), cand(5.0, 0.2)];
        assert_eq!(pick(&cands, &c), Some(2));
        // A tighter budget never picks a faster setting: here, the most accurate one.
        let tight = Constraints { flip: 0.02, ..c };
        assert_eq!(pick(&cands, &tight), Some(2));
        assert!(!cands[2].meets(&tight));
        let dropped = [Candidate { incomplete: true, ..cand(1.0, 0.01) }, cand(30.0, 0.04)];
        assert_eq!(pick(&dropped, &c), Some(1));
        let slower = [Candidate { time: 150.0, ..cand(0.0, 0.001) }, cand(30.0, 0.049)];
        assert_eq!(pick(&slower, &c), Some(1));
        let p99 = Constraints { p99: Some(0.1), ..c };
        assert_eq!(pick(&cands, &p99), Some(2), "p99 0.09 < 0.1");
        let worst = Constraints { worst: Some(0.35), ..c };
        assert!(!cands[0].meets(&worst) && cands[2].meets(&worst));
        assert_eq!(pick(&[], &c), None);
        assert_eq!(pick(&[cand(1.0, f64::NAN), cand(9.0, 0.5)], &c), Some(1));
    }

    /// Ties: feasible candidates within 1% of the fastest are as fast (the more accurate
    /// wins: the H200's casters by contribution against by brightness); infeasible ones
    /// within 0.002 of FLIP of the most accurate are as accurate (the faster wins: Tiled
    /// Deferred against Forward+); beyond the tie the plain rule holds.
    #[test]
    fn near_ties_go_to_the_other_measure() {
        let c = Constraints { flip: 0.15, p99: None, worst: None };
        let casters = [cand(16.936, 0.1495), cand(16.988, 0.1309)];
        assert_eq!(pick(&casters, &c), Some(1));
        let apart = [cand(16.0, 0.1495), cand(16.988, 0.1309)];
        assert_eq!(pick(&apart, &c), Some(0), "6% faster is faster");
        let methods = [cand(15.2, 0.1750), cand(629.0, 0.1745)];
        let tight = Constraints { flip: 0.1, ..c };
        assert_eq!(pick(&methods, &tight), Some(0));
        let methods_apart = [cand(15.2, 0.1780), cand(629.0, 0.1745)];
        assert_eq!(pick(&methods_apart, &tight), Some(1), "0.0035 more accurate is more accurate");
    }

    /// Several views judge a setting by its worst: the slowest time and largest errors; it
    /// is faster than the truth only when faster in every view (a view where the truth is
    /// quicker than the setting rejects it even though the other view's truth is slower
    /// than the setting's worst time); a view that dropped lights or lacks a number
    /// rejects it too.
    #[test]
    fn views_are_judged_by_their_worst() {
        let c = Constraints { flip: 0.05, p99: None, worst: None };
        let a = Candidate { reference_time: 100.0, ..cand(10.0, 0.01) };
        let b = Candidate { reference_time: 400.0, ..cand(150.0, 0.04) };
        let both = Candidate::worst_of(&[a, b]).unwrap();
        assert_eq!((both.time, both.flip, both.p99, both.worst), (150.0, 0.04, 0.12, 0.4));
        assert!(both.meets(&c), "faster than the truth in each view: {both:?}");
        let slow = Candidate { time: 120.0, ..a };
        assert!(!Candidate::worst_of(&[slow, b]).unwrap().meets(&c), "slower than the truth in one view");
        assert!(!Candidate::worst_of(&[a, Candidate { flip: 0.06, ..b }]).unwrap().meets(&c));
        assert!(!Candidate::worst_of(&[a, Candidate { incomplete: true, ..b }]).unwrap().meets(&c));
        assert!(!Candidate::worst_of(&[Candidate { flip: f64::NAN, ..a }, b]).unwrap().meets(&c));
        assert_eq!(Candidate::worst_of(&[a]), Some(a));
        assert_eq!(Candidate::worst_of(&[]), None);
    }

    #[test]
    fn render_flags_spell_each_dial() {
        let dials = vec![
            Axis { name: "method".into(), values: vec!["deferred".into()] },
            Axis { name: "aabb".into(), values: vec!["on".into(), "off".into()] },
            Axis { name: "threshold".into(), values: vec!["0.003".into()] },
        ];
        let on = render_flags(&dials, &["deferred".into(), "on".into(), "0.003".into()]);
        assert_eq!(on, ["--method", "deferred", "--aabb", "--threshold", "0.003"]);
        let off = render_flags(&dials, &["deferred".into(), "off".into(), "0.003".into()]);
        assert_eq!(off, ["--method", "deferred", "--threshold", "0.003"]);
    }
}
