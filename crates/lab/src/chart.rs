//! The measurement lab's charts, drawn with plotters into an RGB buffer and saved as PNG:
//! [`line_chart`] (a measure against a swept value, one line per series, with an optional
//! marked x such as a crossover) and [`pareto_chart`] (time against error, one point per
//! setting, the Pareto frontier drawn, a target error line) and [`bar_panels`] (several
//! measures side by side, one horizontal bar per setting in each panel: the culling
//! statistics of each light-grid layout).
//!
//! Text uses DejaVu Sans embedded in the binary (`assets/fonts`, through plotters'
//! ab_glyph backend), so charts render identically without system fonts. Log axes are
//! drawn as linear axes over log10 of the values, with ticks at chosen values, which keeps
//! one coordinate type for every chart.
//!
//! A point measured over frames that dropped lights (a light grid full: the time of an
//! incomplete frame) is ringed in red, with a legend entry saying so, on both charts. May
//! depend on plotters, image and [`crate::output`] (PNG output) only.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, ensure, Context, Result};
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::prelude::*;

// `crates/lab/assets/fonts` links to the workspace's `assets/fonts`, so the published crate
// holds the font too; build.rs finds it (through the link, or at the workspace root).
static FONT: &[u8] = include_bytes!(env!("TILEDLIGHT_CHART_FONT"));
const FAMILY: &str = "sans-serif";

/// Chart size in pixels.
pub const SIZE: (u32, u32) = (1280, 800);

/// Series colours (colour-blind-friendly order of the usual ten).
const COLORS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// The colour of series `i`.
fn color(i: usize) -> RGBColor {
    COLORS[i % COLORS.len()]
}

fn register_font() -> Result<()> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    ensure!(ok, "the embedded chart font could not be loaded");
    Ok(())
}

/// One line of a chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// (x, y) points in x order.
    pub points: Vec<(f64, f64)>,
    /// Points (also in `points`) whose frames dropped lights: ringed in red.
    pub incomplete: Vec<(f64, f64)>,
}

/// The red of the incomplete-frame rings.
const INCOMPLETE_RED: RGBColor = RGBColor(220, 0, 0);
/// Their legend text.
const INCOMPLETE_LABEL: &str = "ringed red: frames DROPPED lights (time of an incomplete frame)";

/// How an axis maps values: linear, or log10 (values must be positive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Logarithmic.
    Log,
}

impl Scale {
    /// Log when the positive values span at least `ratio` (e.g. 10x), else linear.
    pub fn auto(values: impl IntoIterator<Item = f64>, ratio: f64) -> Self {
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for v in values {
            if v <= 0.0 || !v.is_finite() {
                return Scale::Linear;
            }
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if hi / lo >= ratio {
            Scale::Log
        } else {
            Scale::Linear
        }
    }

    /// The value in plotted units (log10 on a log axis).
    pub fn map(self, v: f64) -> f64 {
        match self {
            Scale::Linear => v,
            Scale::Log => v.log10(),
        }
    }

    /// Inverse of [`Scale::map`].
    pub fn unmap(self, u: f64) -> f64 {
        match self {
            Scale::Linear => u,
            Scale::Log => 10f64.powf(u),
        }
    }
}

/// An axis: label, scale, and optionally the ticks to show (values; default: nice ones).
#[derive(Clone, Debug)]
pub struct AxisSpec {
    /// Label with unit, e.g. "frame time, ms (sum of pass medians)".
    pub label: String,
    /// Scale.
    pub scale: Scale,
    /// Tick values (in data units); None for automatic ones.
    pub ticks: Option<Vec<f64>>,
}

/// A linear axis over `lo..hi` (plotted units) whose ticks and grid lines are exactly
/// `keys`: plotters' own ticks are evenly spaced, which on a log10 axis would land on
/// values like 1,318.
#[derive(Clone, Debug)]
struct Keyed {
    lo: f64,
    hi: f64,
    keys: Vec<f64>,
}

impl Ranged for Keyed {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let t = (v - self.lo) / (self.hi - self.lo);
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        // Only as bold points: the light grid would repeat them.
        if hint.weight().allow_light_points() {
            return Vec::new();
        }
        self.keys.iter().copied().filter(|k| (self.lo..=self.hi).contains(k)).collect()
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

/// "1,024" for integers, else up to 3 significant digits.
pub fn tick_label(v: f64) -> String {
    if v.abs() >= 1.0 && (v - v.round()).abs() < 1e-6 * v.abs() {
        tiledlight_setup::group_digits(v.round() as u64)
    } else if v == 0.0 {
        "0".into()
    } else {
        let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

/// Nice ticks in [lo, hi] (data units): 1-2-5 steps on linear axes, 1-2-5 per decade on
/// log axes.
fn nice_ticks(lo: f64, hi: f64, scale: Scale) -> Vec<f64> {
    match scale {
        Scale::Log => {
            let mut out = Vec::new();
            let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
            let span = d1 - d0;
            let mults: &[f64] = if span <= 2 { &[1.0, 2.0, 5.0] } else { &[1.0] };
            for d in d0..=d1 {
                for m in mults {
                    let v = m * 10f64.powi(d);
                    if v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9) {
                        out.push(v);
                    }
                }
            }
            out
        }
        Scale::Linear => {
            let raw = (hi - lo) / 6.0;
            if raw <= 0.0 || !raw.is_finite() {
                return vec![lo];
            }
            let mag = 10f64.powf(raw.log10().floor());
            let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
            let first = (lo / step).ceil() as i64;
            let last = (hi / step).floor() as i64;
            (first..=last).map(|k| k as f64 * step).collect()
        }
    }
}

/// The plotted range (in mapped units) around `values`, with a margin.
fn span(values: &[f64], scale: Scale, include_zero: bool) -> (f64, f64) {
    let mapped: Vec<f64> = values.iter().map(|&v| scale.map(v)).filter(|v| v.is_finite()).collect();
    let mut lo = mapped.iter().copied().fold(f64::INFINITY, f64::min);
    let mut hi = mapped.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        (lo, hi) = (0.0, 1.0);
    }
    if include_zero && scale == Scale::Linear {
        lo = lo.min(0.0);
    }
    if hi - lo < 1e-9 {
        let pad = if scale == Scale::Log { 0.3 } else { lo.abs().max(1.0) * 0.1 };
        return (lo - pad, hi + pad);
    }
    let m = (hi - lo) * 0.06;
    (if include_zero && scale == Scale::Linear && lo == 0.0 { 0.0 } else { lo - m }, hi + m)
}

/// Draws into an RGB buffer and saves it as a PNG at `path` (which must end in .png).
fn save(
    path: &Path,
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()>,
) -> Result<()> {
    register_font()?;
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "chart {}: only .png charts are supported", path.display());
    let mut buf = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("drawing the chart: {e}"))?;
        draw(&root)?;
        root.present().map_err(|e| anyhow!("drawing the chart: {e}"))?;
    }
    let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf).context("building the chart image")?;
    crate::output::save_png(path, &img)
}

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing the chart: {e}")
}

/// A line chart.
#[derive(Clone, Debug)]
pub struct LineChart {
    /// Title (what, where: GPU, resolution, scene).
    pub title: String,
    /// Second title line (settings held fixed).
    pub subtitle: String,
    /// The x axis.
    pub x: AxisSpec,
    /// The y axis.
    pub y: AxisSpec,
    /// The lines.
    pub series: Vec<Series>,
    /// A vertical marker at x with its label (e.g. the crossover).
    pub marker: Option<(f64, String)>,
    /// A note printed under the subtitle (e.g. where the lines cross).
    pub note: Option<String>,
    /// For a categorical x axis: the label of x = 0, 1, 2, ...
    pub categories: Option<Vec<String>>,
}

/// Draws `c` to the PNG `path`.
pub fn line_chart(path: &Path, c: &LineChart) -> Result<()> {
    let xs: Vec<f64> = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
    let ys: Vec<f64> = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).collect();
    ensure!(!xs.is_empty(), "chart {}: no points to draw", path.display());
    save(path, |root| {
        let (x0, x1) = span(&xs, c.x.scale, false);
        let (y0, y1) = span(&ys, c.y.scale, true);
        let x_ticks =
            c.x.ticks.clone().unwrap_or_else(|| nice_ticks(c.x.scale.unmap(x0), c.x.scale.unmap(x1), c.x.scale));
        let y_ticks =
            c.y.ticks.clone().unwrap_or_else(|| nice_ticks(c.y.scale.unmap(y0), c.y.scale.unmap(y1), c.y.scale));
        let root = titled(root, &c.title, &c.subtitle, c.note.as_deref())?;
        let xk: Vec<f64> = x_ticks.iter().map(|&v| c.x.scale.map(v)).collect();
        let yk: Vec<f64> = y_ticks.iter().map(|&v| c.y.scale.map(v)).collect();
        let mut chart = ChartBuilder::on(&root)
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(90)
            .build_cartesian_2d(Keyed { lo: x0, hi: x1, keys: xk }, Keyed { lo: y0, hi: y1, keys: yk })
            .map_err(err)?;
        let (xs_, ys_) = (c.x.scale, c.y.scale);
        let cats = c.categories.clone();
        let fx = move |u: &f64| match &cats {
            Some(cats) => cats.get(u.round() as usize).cloned().unwrap_or_default(),
            None => tick_label(xs_.unmap(*u)),
        };
        let fy = move |u: &f64| tick_label(ys_.unmap(*u));
        chart
            .configure_mesh()
            .x_desc(&c.x.label)
            .y_desc(&c.y.label)
            .axis_desc_style((FAMILY, 22))
            .label_style((FAMILY, 18))
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .light_line_style(WHITE)
            .bold_line_style(RGBColor(225, 225, 225))
            .draw()
            .map_err(err)?;
        for (i, s) in c.series.iter().enumerate() {
            let col = color(i);
            let pts: Vec<(f64, f64)> = s.points.iter().map(|&(x, y)| (c.x.scale.map(x), c.y.scale.map(y))).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), col.stroke_width(3)))
                .map_err(err)?
                .label(&s.name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], col.stroke_width(3)));
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 5, col.filled()))).map_err(err)?;
        }
        let rings: Vec<(f64, f64)> = c
            .series
            .iter()
            .flat_map(|s| s.incomplete.iter().map(|&(x, y)| (c.x.scale.map(x), c.y.scale.map(y))))
            .collect();
        incomplete_rings(&mut chart, rings)?;
        if let Some((x, label)) = &c.marker {
            let u = c.x.scale.map(*x);
            let grey = RGBColor(80, 80, 80);
            chart
                .draw_series(DashedLineSeries::new(vec![(u, y0), (u, y1)], 10, 6, grey.stroke_width(2)))
                .map_err(err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (u, y1 - (y1 - y0) * 0.04),
                    (FAMILY, 20).into_font().color(&grey),
                )))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font((FAMILY, 20))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(err)?;
        Ok(())
    })
}

/// Panels of horizontal bars: each panel one measure, one bar per setting (the same
/// settings, in the same order, in every panel).
#[derive(Clone, Debug)]
pub struct BarPanels {
    /// Title (what, where: GPU, resolution, scene).
    pub title: String,
    /// Second title line (settings held fixed).
    pub subtitle: String,
    /// A note under the subtitle (e.g. which setting wins).
    pub note: Option<String>,
    /// The settings' labels, top to bottom.
    pub settings: Vec<String>,
    /// Each panel: its measure's name and one value per setting (NaN: not measured).
    pub panels: Vec<(String, Vec<f64>)>,
}

/// Draws `c` to the PNG `path`: two panels a row, the settings' labels on each panel's
/// left, each bar's value at its end.
pub fn bar_panels(path: &Path, c: &BarPanels) -> Result<()> {
    ensure!(!c.settings.is_empty() && !c.panels.is_empty(), "chart {}: no bars to draw", path.display());
    for (name, values) in &c.panels {
        ensure!(
            values.len() == c.settings.len(),
            "chart {}: panel {name} has {} bars for {} settings",
            path.display(),
            values.len(),
            c.settings.len()
        );
    }
    save(path, |root| {
        let root = titled(root, &c.title, &c.subtitle, c.note.as_deref())?;
        let rows = c.panels.len().div_ceil(2);
        let areas = root.split_evenly((rows, 2));
        let n = c.settings.len();
        let longest = c.settings.iter().map(|s| s.chars().count()).max().unwrap_or(0);
        for (k, (area, (name, values))) in areas.iter().zip(&c.panels).enumerate() {
            let hi = values.iter().copied().filter(|v| v.is_finite()).fold(0.0f64, f64::max);
            let hi = if hi > 0.0 { hi * 1.25 } else { 1.0 };
            let labels = c.settings.clone();
            let fy = move |u: &f64| {
                let i = u.round();
                if (u - i).abs() < 1e-6 && i >= 0.0 {
                    labels.get(n - 1 - i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            };
            let mut chart = ChartBuilder::on(area)
                .margin(14)
                .caption(name, (FAMILY, 22))
                .x_label_area_size(36)
                .y_label_area_size((longest as u32 * 9 + 16).min(360))
                .build_cartesian_2d(0.0..hi, -0.6..(n as f64 - 0.4))
                .map_err(err)?;
            chart
                .configure_mesh()
                .label_style((FAMILY, 16))
                .y_labels(n)
                .y_label_formatter(&fy)
                .x_label_formatter(&|v: &f64| tick_label(*v))
                .disable_y_mesh()
                .light_line_style(WHITE)
                .bold_line_style(RGBColor(225, 225, 225))
                .draw()
                .map_err(err)?;
            let col = color(k);
            for (i, &v) in values.iter().enumerate() {
                let y = (n - 1 - i) as f64;
                if !v.is_finite() {
                    let t =
                        Text::new("not measured", (0.0, y), (FAMILY, 15).into_font().color(&RGBColor(120, 120, 120)));
                    chart.draw_series(std::iter::once(t)).map_err(err)?;
                    continue;
                }
                chart
                    .draw_series(std::iter::once(Rectangle::new([(0.0, y - 0.35), (v, y + 0.35)], col.filled())))
                    .map_err(err)?;
                let t = Text::new(format!(" {}", tick_label(v)), (v, y - 0.15), (FAMILY, 15).into_font());
                chart.draw_series(std::iter::once(t)).map_err(err)?;
            }
        }
        Ok(())
    })
}

/// Red rings around the points of frames that dropped lights, with their legend entry
/// (nothing when there are none).
fn incomplete_rings(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<Keyed, Keyed>>,
    rings: Vec<(f64, f64)>,
) -> Result<()> {
    if !rings.is_empty() {
        chart
            .draw_series(rings.into_iter().map(|p| Circle::new(p, 11, INCOMPLETE_RED.stroke_width(3))))
            .map_err(err)?
            .label(INCOMPLETE_LABEL)
            .legend(|(x, y)| Circle::new((x + 12, y), 8, INCOMPLETE_RED.stroke_width(3)));
    }
    Ok(())
}

/// Draws the title and subtitle at the top and returns the area below them.
fn titled<'a>(
    root: &DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>,
    title: &str,
    subtitle: &str,
    note: Option<&str>,
) -> Result<DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>> {
    let (top, rest) = root.split_vertically(if note.is_some() { 112 } else { 80 });
    top.draw(&Text::new(title.to_string(), (24, 12), (FAMILY, 28).into_font())).map_err(err)?;
    top.draw(&Text::new(subtitle.to_string(), (24, 50), (FAMILY, 18).into_font().color(&RGBColor(70, 70, 70))))
        .map_err(err)?;
    if let Some(n) = note {
        top.draw(&Text::new(n.to_string(), (24, 80), (FAMILY, 20).into_font().color(&RGBColor(160, 20, 20))))
            .map_err(err)?;
    }
    Ok(rest)
}

/// One setting on a Pareto chart.
#[derive(Clone, Debug, PartialEq)]
pub struct ParetoPoint {
    /// Which series (colour) it belongs to, e.g. "aabb, 16 px tiles".
    pub series: String,
    /// Its label next to the point, e.g. "T=0.05".
    pub label: String,
    /// Time (x).
    pub time: f64,
    /// Error (y).
    pub error: f64,
    /// Its frames dropped lights (a light grid full): ringed in red.
    pub incomplete: bool,
}

/// Indices of the points on the Pareto frontier of (time, error), both to be minimised,
/// in time order: each is faster than every point with at most its error. Points with a
/// non-finite coordinate are never on it, nor are incomplete ones (frames that dropped
/// lights: their time is of less work and their error of a partial image, so they are
/// never recommended).
pub fn pareto_frontier(points: &[ParetoPoint]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].time.is_finite() && points[i].error.is_finite() && !points[i].incomplete)
        .collect();
    idx.sort_by(|&a, &b| points[a].time.total_cmp(&points[b].time).then(points[a].error.total_cmp(&points[b].error)));
    let mut out = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].error < best {
            best = points[i].error;
            out.push(i);
        }
    }
    out
}

/// A Pareto chart.
#[derive(Clone, Debug)]
pub struct ParetoChart {
    /// Title.
    pub title: String,
    /// Second title line.
    pub subtitle: String,
    /// The time (x) axis label.
    pub x_label: String,
    /// The error (y) axis label.
    pub y_label: String,
    /// The settings.
    pub points: Vec<ParetoPoint>,
    /// A horizontal target error line and its label.
    pub target: Option<(f64, String)>,
    /// A point to ring (the recommended setting).
    pub chosen: Option<usize>,
    /// A note printed under the subtitle (e.g. the recommendation).
    pub note: Option<String>,
    /// The references the errors are measured against, as points of their own: (time,
    /// label). Their error is 0, which a log axis cannot show, so each is drawn as a
    /// black diamond on the bottom edge with a dashed vertical line at its time: a setting
    /// right of the line is slower than the reference it approximates.
    pub references: Vec<(f64, String)>,
}

/// Draws `c` to the PNG `path`: points coloured by series, the frontier's labelled, the frontier as a
/// staircase, the target line, the chosen point ringed. Log scales where values span 10x.
pub fn pareto_chart(path: &Path, c: &ParetoChart) -> Result<()> {
    let pts: Vec<&ParetoPoint> = c.points.iter().filter(|p| p.time.is_finite() && p.error.is_finite()).collect();
    ensure!(!pts.is_empty(), "chart {}: no finite points to draw", path.display());
    let refs: Vec<&(f64, String)> = c.references.iter().filter(|r| r.0.is_finite() && r.0 > 0.0).collect();
    let xsc = Scale::auto(pts.iter().map(|p| p.time).chain(refs.iter().map(|r| r.0)), 10.0);
    let xs: Vec<f64> = pts.iter().map(|p| p.time).chain(refs.iter().map(|r| r.0)).collect();
    let mut ys: Vec<f64> = pts.iter().map(|p| p.error).collect();
    if let Some((t, _)) = c.target {
        ys.push(t);
    }
    // A zero error (an image identical to the reference) cannot go on a log axis: auto
    // falls back to linear then.
    let ysc = Scale::auto(ys.iter().copied(), 10.0);
    // A setting slower than a reference (exact at its time) is dominated by it.
    let fastest_reference = refs.iter().map(|r| r.0).min_by(f64::total_cmp).unwrap_or(f64::INFINITY);
    let frontier: Vec<usize> =
        pareto_frontier(&c.points).into_iter().filter(|&i| c.points[i].time < fastest_reference).collect();
    let mut names: Vec<&str> = Vec::new();
    for p in &c.points {
        if !names.contains(&p.series.as_str()) {
            names.push(&p.series);
        }
    }
    save(path, |root| {
        let (x0, x1) = span(&xs, xsc, false);
        let (y0, y1) = span(&ys, ysc, ysc == Scale::Linear);
        let xk: Vec<f64> = nice_ticks(xsc.unmap(x0), xsc.unmap(x1), xsc).iter().map(|&v| xsc.map(v)).collect();
        let yk: Vec<f64> = nice_ticks(ysc.unmap(y0), ysc.unmap(y1), ysc).iter().map(|&v| ysc.map(v)).collect();
        let root = titled(root, &c.title, &c.subtitle, c.note.as_deref())?;
        let mut chart = ChartBuilder::on(&root)
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(90)
            .build_cartesian_2d(Keyed { lo: x0, hi: x1, keys: xk }, Keyed { lo: y0, hi: y1, keys: yk })
            .map_err(err)?;
        let fx = move |u: &f64| tick_label(xsc.unmap(*u));
        let fy = move |u: &f64| tick_label(ysc.unmap(*u));
        chart
            .configure_mesh()
            .x_desc(&c.x_label)
            .y_desc(&c.y_label)
            .axis_desc_style((FAMILY, 22))
            .label_style((FAMILY, 18))
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .light_line_style(WHITE)
            .bold_line_style(RGBColor(225, 225, 225))
            .draw()
            .map_err(err)?;
        let map = |p: &ParetoPoint| (xsc.map(p.time), ysc.map(p.error));
        // The references' diamonds and labels sit on the bottom edge: the legend avoids them.
        let mapped: Vec<(f64, f64)> =
            pts.iter().map(|p| map(p)).chain(refs.iter().map(|r| (xsc.map(r.0), y0))).collect();
        let legend_at = emptiest_corner(&mapped, (x0, x1), (y0, y1));
        if let Some((t, label)) = &c.target {
            let u = ysc.map(*t);
            let red = RGBColor(200, 30, 30);
            chart
                .draw_series(DashedLineSeries::new(vec![(x0, u), (x1, u)], 10, 6, red.stroke_width(2)))
                .map_err(err)?;
            // On the right, unless the legend sits in the lower right (over the line).
            let label_x = if matches!(legend_at, SeriesLabelPosition::LowerRight) {
                x0 + (x1 - x0) * 0.02
            } else {
                x1 - (x1 - x0) * 0.3
            };
            chart
                .draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (label_x, u + (y1 - y0) * 0.03),
                    (FAMILY, 18).into_font().color(&red),
                )))
                .map_err(err)?;
        }
        // The references: error 0 sits below any log axis, so on the bottom edge, with a
        // line up through the chart at their time.
        let black = RGBColor(0, 0, 0);
        for (k, (t, label)) in refs.iter().enumerate() {
            let u = xsc.map(*t);
            chart
                .draw_series(DashedLineSeries::new(vec![(u, y0), (u, y1)], 6, 6, black.stroke_width(1)))
                .map_err(err)?;
            let size = 9;
            let diamond = move |(x, y): (i32, i32)| {
                Polygon::new(vec![(x, y - size), (x + size, y), (x, y + size), (x - size, y)], black.filled())
            };
            let series =
                chart.draw_series(std::iter::once(EmptyElement::at((u, y0)) + diamond((0, 0)))).map_err(err)?;
            if k == 0 {
                series.label("reference (error 0)").legend(move |(x, y)| diamond((x + 12, y)));
            }
            // Right of the line, or left of it in the plot's right quarter (the label is
            // about a fifth of the plot wide).
            let lx = if u > x0 + (x1 - x0) * 0.75 { u - (x1 - x0) * 0.2 } else { u + (x1 - x0) * 0.008 };
            chart
                .draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (lx, y0 + (y1 - y0) * (0.04 + 0.05 * k as f64)),
                    (FAMILY, 16).into_font().color(&black),
                )))
                .map_err(err)?;
        }
        // The frontier as a staircase: from each frontier point right to the next one's time.
        let mut stair = Vec::new();
        for w in frontier.windows(2) {
            let (a, b) = (map(&c.points[w[0]]), map(&c.points[w[1]]));
            stair.extend([a, (b.0, a.1), b]);
        }
        if let [only] = frontier[..] {
            stair.push(map(&c.points[only]));
        }
        let dark = RGBColor(40, 40, 40);
        chart
            .draw_series(LineSeries::new(stair, dark.stroke_width(2)))
            .map_err(err)?
            .label("Pareto frontier")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], dark.stroke_width(2)));
        for (si, name) in names.iter().enumerate() {
            let col = color(si);
            let mine: Vec<&ParetoPoint> =
                c.points.iter().filter(|p| p.series == *name && p.time.is_finite() && p.error.is_finite()).collect();
            chart
                .draw_series(mine.iter().map(|p| Circle::new(map(p), 7, col.filled())))
                .map_err(err)?
                .label(name.to_string())
                .legend(move |(x, y)| Circle::new((x + 12, y), 7, col.filled()));
            // Labels on the frontier only: settings of one threshold share a height, and
            // labelling every point would print them on top of each other.
            let on_frontier: Vec<&&ParetoPoint> =
                mine.iter().filter(|p| frontier.iter().any(|&i| std::ptr::eq(&c.points[i], **p))).collect();
            // Alternate heights along the frontier: neighbours of one error overlap otherwise.
            chart
                .draw_series(on_frontier.iter().map(|p| {
                    let (u, v) = map(p);
                    let k = frontier.iter().position(|&i| std::ptr::eq(&c.points[i], **p)).unwrap_or(0);
                    let up = if k % 2 == 0 { 0.025 } else { -0.04 };
                    Text::new(p.label.clone(), (u + (x1 - x0) * 0.008, v + (y1 - y0) * up), (FAMILY, 15).into_font())
                }))
                .map_err(err)?;
        }
        let rings: Vec<(f64, f64)> = pts.iter().filter(|p| p.incomplete).map(|p| map(p)).collect();
        incomplete_rings(&mut chart, rings)?;
        if let Some(i) = c.chosen.filter(|&i| i < c.points.len()) {
            let p = map(&c.points[i]);
            chart
                .draw_series(std::iter::once(Circle::new(p, 14, RGBColor(200, 30, 30).stroke_width(3))))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(legend_at)
            .label_font((FAMILY, 18))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(err)?;
        Ok(())
    })
}

/// The corner of the plot (`x` and `y` spans, in plotted units) whose quarter holds the
/// fewest of `points`, for the legend: a legend over the points fades them (the error
/// budget's points all sit near the top of a log axis that reaches down to the target).
/// Ties keep the upper right, then the lower right.
fn emptiest_corner(points: &[(f64, f64)], (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> SeriesLabelPosition {
    let (xm, ym) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let count =
        |right: bool, upper: bool| points.iter().filter(|(x, y)| (*x >= xm) == right && (*y >= ym) == upper).count();
    [
        (SeriesLabelPosition::UpperRight, count(true, true)),
        (SeriesLabelPosition::LowerRight, count(true, false)),
        (SeriesLabelPosition::UpperLeft, count(false, true)),
        (SeriesLabelPosition::LowerLeft, count(false, false)),
    ]
    .into_iter()
    .min_by_key(|(_, n)| *n)
    .map(|(c, _)| c)
    .unwrap_or(SeriesLabelPosition::UpperRight)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_goes_where_the_points_are_not() {
        let corner = |pts: &[(f64, f64)]| format!("{:?}", emptiest_corner(pts, (0.0, 10.0), (0.0, 10.0)));
        assert_eq!(corner(&[]), "UpperRight");
        assert_eq!(corner(&[(9.0, 9.0), (8.0, 7.0), (1.0, 1.0)]), "LowerRight");
        assert_eq!(corner(&[(9.0, 9.0), (8.0, 2.0), (1.0, 9.0), (2.0, 1.0), (7.0, 8.0), (6.0, 1.0)]), "UpperLeft");
    }

    fn p(t: f64, e: f64) -> ParetoPoint {
        ParetoPoint { series: "s".into(), label: String::new(), time: t, error: e, incomplete: false }
    }

    #[test]
    fn frontier_keeps_only_undominated_points() {
        let pts = [p(3.0, 0.1), p(1.0, 0.5), p(2.0, 0.6), p(2.0, 0.2), p(4.0, 0.1), p(f64::NAN, 0.0)];
        assert_eq!(pareto_frontier(&pts), [1, 3, 0]);
        assert!(pareto_frontier(&[]).is_empty());
        // A faster, better setting whose frames dropped lights is never on it (nor
        // recommended): the frontier is what it was without it.
        let mut with_dropped = pts.to_vec();
        with_dropped.push(ParetoPoint { incomplete: true, ..p(0.5, 0.01) });
        assert_eq!(pareto_frontier(&with_dropped), [1, 3, 0]);
    }

    #[test]
    fn ticks_and_labels() {
        assert_eq!(nice_ticks(0.0, 10.0, Scale::Linear), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(nice_ticks(3.0, 90.0, Scale::Log), [5.0, 10.0, 20.0, 50.0]);
        assert_eq!(nice_ticks(3.0, 300.0, Scale::Log), [10.0, 100.0]);
        assert_eq!(nice_ticks(0.5, 5000.0, Scale::Log), [1.0, 10.0, 100.0, 1000.0]);
        assert_eq!(tick_label(16384.0), "16,384");
        assert_eq!(tick_label(0.0125), "0.0125");
        assert_eq!(tick_label(2.5), "2.5");
        assert_eq!(Scale::auto([1.0, 5.0], 10.0), Scale::Linear);
        assert_eq!(Scale::auto([1.0, 50.0], 10.0), Scale::Log);
        assert_eq!(Scale::auto([0.0, 50.0], 10.0), Scale::Linear);
    }

    #[test]
    fn charts_are_written_and_bad_paths_refused() {
        let dir = std::env::temp_dir().join(format!("tiledlight-chart-{}", std::process::id()));
        let path = dir.join("c.png");
        let c = LineChart {
            title: "t".into(),
            subtitle: "s".into(),
            x: AxisSpec { label: "x".into(), scale: Scale::Log, ticks: Some(vec![10.0, 100.0]) },
            y: AxisSpec { label: "y".into(), scale: Scale::Linear, ticks: None },
            series: vec![Series {
                name: "a".into(),
                points: vec![(10.0, 1.0), (100.0, 3.0)],
                incomplete: vec![(100.0, 3.0)],
            }],
            marker: Some((30.0, "here".into())),
            note: Some("note".into()),
            categories: None,
        };
        line_chart(&path, &c).unwrap();
        let img = image::open(&path).unwrap();
        assert_eq!((img.width(), img.height()), SIZE);
        // The incomplete point is ringed in the ring's red; without it, no such red.
        let reds = |path: &Path| {
            let img = image::open(path).unwrap().to_rgb8();
            img.pixels().filter(|p| p.0 == [INCOMPLETE_RED.0, INCOMPLETE_RED.1, INCOMPLETE_RED.2]).count()
        };
        assert!(reds(&path) > 50, "no red ring");
        let complete = LineChart { series: vec![Series { incomplete: vec![], ..c.series[0].clone() }], ..c.clone() };
        line_chart(&dir.join("complete.png"), &complete).unwrap();
        assert_eq!(reds(&dir.join("complete.png")), 0);
        assert!(line_chart(&dir.join("c.svg"), &c).is_err());
        let empty = LineChart { series: vec![], ..c };
        assert!(line_chart(&path, &empty).is_err());
        let pc = ParetoChart {
            title: "t".into(),
            subtitle: "s".into(),
            x_label: "ms".into(),
            y_label: "FLIP".into(),
            points: vec![p(1.0, 0.5), p(2.0, 0.01), ParetoPoint { incomplete: true, ..p(3.0, 0.02) }],
            target: Some((0.01, "1%".into())),
            chosen: Some(1),
            note: Some("n".into()),
            references: vec![(2.5, "truth: 2.5 ms".into())],
        };
        pareto_chart(&dir.join("p.png"), &pc).unwrap();
        assert!(image::open(dir.join("p.png")).is_ok());
        // The reference's diamond is black; the chart without it has no black blob that big.
        let black = |path: &Path| {
            let img = image::open(path).unwrap().to_rgb8();
            img.pixels().filter(|p| p.0 == [0, 0, 0]).count()
        };
        let without = ParetoChart { references: vec![], ..pc.clone() };
        pareto_chart(&dir.join("p0.png"), &without).unwrap();
        assert!(black(&dir.join("p.png")) > black(&dir.join("p0.png")) + 100, "no reference marker");
        let bars = BarPanels {
            title: "t".into(),
            subtitle: "s".into(),
            note: None,
            settings: vec!["grid=tiled".into(), "grid=clustered".into()],
            panels: vec![("a".into(), vec![0.5, 0.9]), ("b".into(), vec![3.0, f64::NAN]), ("c".into(), vec![1.0, 2.0])],
        };
        bar_panels(&dir.join("b.png"), &bars).unwrap();
        let img = image::open(dir.join("b.png")).unwrap().to_rgb8();
        // The first panel's bars are drawn in the first series colour.
        assert!(img.pixels().any(|p| *p == image::Rgb([31, 119, 180])));
        let short = BarPanels { panels: vec![("a".into(), vec![1.0])], ..bars };
        assert!(bar_panels(&dir.join("b.png"), &short).is_err());
        assert!(reds(&dir.join("p.png")) > 50, "no red ring on the Pareto chart");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
