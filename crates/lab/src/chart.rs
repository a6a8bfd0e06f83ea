//! The measurement lab's charts, drawn with plotters into an RGB buffer and saved as PNG:
//! [`line_chart`] (a measure against a swept value, one line per series, with an optional
//! marked x such as a crossover; on a category axis, such as `grid=tiled,clustered`, each
//! series is a row of separate points, one per category, with no line between them) and
//! [`pareto_chart`] (time against error, one point per setting, the Pareto frontier drawn,
//! a target error line) and [`bar_panels`] (several measures side by side, one horizontal
//! bar per setting in each panel: the culling statistics of each light-grid layout).
//!
//! Every chart draws at any size (the `_sized` variants; the plain ones at [`SIZE`]): fonts,
//! margins and label areas scale with the image, down to a readable minimum font. Text is
//! measured before it is drawn: titles, subtitles and notes wrap onto a second line at a
//! word boundary, then shrink, then are cut short with "…"; labels in the plot move to the
//! other side of their anchor rather than leave it, and avoid the legend and each other
//! where they can; tick labels are thinned (nicer values kept first) until neighbours keep
//! a gap. The legend goes in the plot's emptiest corner. Each chart returns its [`Layout`]:
//! the box of every text drawn (tick labels and axis descriptions where plotters places
//! them), the legend's box and the plotted points, which [`Layout::problems`] checks.
//!
//! Text uses DejaVu Sans embedded in the binary (`assets/fonts`, through plotters'
//! ab_glyph backend), so charts render identically without system fonts. Log axes are
//! drawn as linear axes over log10 of the values, with ticks at chosen values, which keeps
//! one coordinate type for every chart.
//!
//! A point measured over frames that dropped lights (a light grid full: the time of an
//! incomplete frame) is ringed in red, with a legend entry saying so, on both charts. May
//! depend on plotters, image and [`crate::output`] (PNG output) only.

use std::fmt;
use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, ensure, Context, Result};
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

// `crates/lab/assets/fonts` links to the workspace's `assets/fonts`, so the published crate
// holds the font too; build.rs finds it (through the link, or at the workspace root).
static FONT: &[u8] = include_bytes!(env!("TILEDLIGHT_CHART_FONT"));
const FAMILY: &str = "sans-serif";

/// Chart size in pixels of [`line_chart`], [`pareto_chart`] and [`bar_panels`], and the
/// size the `_sized` variants scale their fonts and margins from.
pub const SIZE: (u32, u32) = (1280, 800);

/// The smallest chart the `_sized` variants draw, and the largest side.
pub const MIN_SIZE: (u32, u32) = (320, 180);
const MAX_SIDE: u32 = 8192;

/// The smallest font size in pixels: smaller DejaVu Sans is hard to read on a screen.
const MIN_FONT: f64 = 11.0;

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

/// The colour of series `i`: the ten, then each again darker (a chart of the methods and
/// the stochastic method's dials has more than ten series; a repeated colour would merge
/// two of them).
fn color(i: usize) -> RGBColor {
    let RGBColor(r, g, b) = COLORS[i % COLORS.len()];
    let round = (i / COLORS.len()).min(2) as u32;
    let shade = |c: u8| (u32::from(c) * (10 - 3 * round) / 10) as u8;
    RGBColor(shade(r), shade(g), shade(b))
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

/// Nice ticks in [lo, hi] (data units), about `n` of them: 1-2-5 steps on linear axes,
/// 1-2-5 per decade on log axes spanning at most two decades (decades only when `n` < 5).
fn nice_ticks(lo: f64, hi: f64, scale: Scale, n: usize) -> Vec<f64> {
    match scale {
        Scale::Log => {
            let mut out = Vec::new();
            if !(lo > 0.0 && hi >= lo && hi.is_finite()) {
                return out;
            }
            let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
            let span = d1 - d0;
            let mults: &[f64] = if span <= 2 && n >= 5 { &[1.0, 2.0, 5.0] } else { &[1.0] };
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
            let raw = (hi - lo) / n.max(1) as f64;
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

/// How plain a tick value is, smaller first: fewer significant digits, then a leading 1,
/// 5, 2, other. Thinning keeps the plainest labels (100 and 1,000 before 300).
fn plainness(v: f64) -> (u32, u32) {
    let v = v.abs();
    if v == 0.0 || !v.is_finite() {
        return (0, 0);
    }
    let m = v / 10f64.powf(v.log10().floor());
    let digits = (1..=6u32).find(|&d| {
        let s = m * 10f64.powi(d as i32 - 1);
        (s - s.round()).abs() < 1e-6 * s.max(1.0)
    });
    let lead = match m.floor() as u32 {
        1 => 0,
        5 => 1,
        2 => 2,
        _ => 3,
    };
    (digits.unwrap_or(7), lead)
}

/// A pixel rectangle: `x0..x1` by `y0..y1` (ends exclusive), y down.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    /// Left.
    pub x0: i32,
    /// Top.
    pub y0: i32,
    /// Right (exclusive).
    pub x1: i32,
    /// Bottom (exclusive).
    pub y1: i32,
}

impl Rect {
    /// A `w` x `h` rectangle with its top left at (x, y).
    pub fn at((x, y): (i32, i32), (w, h): (i32, i32)) -> Self {
        Rect { x0: x, y0: y, x1: x + w, y1: y + h }
    }

    /// Width.
    pub fn w(&self) -> i32 {
        self.x1 - self.x0
    }

    /// Height.
    pub fn h(&self) -> i32 {
        self.y1 - self.y0
    }

    /// Whether the two share a pixel.
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// Whether `o` lies wholly inside.
    pub fn contains(&self, o: &Rect) -> bool {
        o.x0 >= self.x0 && o.y0 >= self.y0 && o.x1 <= self.x1 && o.y1 <= self.y1
    }

    /// The smallest rectangle holding both.
    fn union(&self, o: &Rect) -> Rect {
        Rect { x0: self.x0.min(o.x0), y0: self.y0.min(o.y0), x1: self.x1.max(o.x1), y1: self.y1.max(o.y1) }
    }

    /// Whether the two are at least `gap` apart along x (`vertical` false) or y.
    fn apart(&self, o: &Rect, gap: i32, vertical: bool) -> bool {
        if vertical {
            self.y1 + gap <= o.y0 || o.y1 + gap <= self.y0
        } else {
            self.x1 + gap <= o.x0 || o.x1 + gap <= self.x0
        }
    }
}

impl fmt::Display for Rect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}, {})..({}, {})", self.x0, self.y0, self.x1, self.y1)
    }
}

/// What a text on a chart is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextKind {
    /// A line of the title.
    Title,
    /// A line of the subtitle.
    Subtitle,
    /// A line of the note under the subtitle.
    Note,
    /// A panel's name (bar panels).
    Caption,
    /// A label of the x axis (a value, or a category's name).
    XTick,
    /// A label of the y axis.
    YTick,
    /// The x axis description.
    XDesc,
    /// The y axis description (drawn turned, reading upwards).
    YDesc,
    /// A line of a legend entry.
    Legend,
    /// The label of a line chart's marker (e.g. the crossover).
    Marker,
    /// The target line's label (Pareto chart).
    Target,
    /// A reference's label (Pareto chart).
    Reference,
    /// A point's label (the Pareto frontier's settings).
    PointLabel,
    /// A bar's value.
    BarValue,
}

/// One text as drawn: what it is, its panel (0 but on bar panels), the text, its box.
#[derive(Clone, Debug, PartialEq)]
pub struct TextBox {
    /// What it is.
    pub kind: TextKind,
    /// The panel it belongs to (bar panels; 0 elsewhere).
    pub panel: usize,
    /// The text as drawn (a category name wrapped onto two lines reads as one).
    pub text: String,
    /// Its box: the advance width by the font's whole line height (ascent to descent).
    pub rect: Rect,
}

/// Where a chart put things, in pixels, for [`Layout::problems`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layout {
    /// The image size.
    pub size: (u32, u32),
    /// Every text drawn.
    pub texts: Vec<TextBox>,
    /// The legend's box, if any (drawn by the chart, so exact).
    pub legend: Option<Rect>,
    /// The box of every plotted point's marker.
    pub points: Vec<Rect>,
}

impl Layout {
    /// The texts of `kind`, in drawing order.
    pub fn texts_of(&self, kind: TextKind) -> impl Iterator<Item = &TextBox> + '_ {
        self.texts.iter().filter(move |t| t.kind == kind)
    }

    /// What is wrong with the layout, one line each: a text or the legend not wholly inside
    /// the image, two texts overlapping (two tick labels of one axis, title lines, a label
    /// on an axis description, ...), a plotted point or a label in the plot under the legend.
    pub fn problems(&self) -> Vec<String> {
        let image = Rect::at((0, 0), (self.size.0 as i32, self.size.1 as i32));
        let mut out = Vec::new();
        for t in &self.texts {
            if !image.contains(&t.rect) {
                out.push(format!("{:?} '{}' at {} leaves the {}x{} image", t.kind, t.text, t.rect, image.x1, image.y1));
            }
        }
        for (i, a) in self.texts.iter().enumerate() {
            for b in &self.texts[i + 1..] {
                if !a.rect.overlaps(&b.rect) {
                    continue;
                }
                if a.kind == b.kind && a.panel == b.panel && matches!(a.kind, TextKind::XTick | TextKind::YTick) {
                    out.push(format!("{:?} labels '{}' and '{}' overlap", a.kind, a.text, b.text));
                } else {
                    out.push(format!("{:?} '{}' overlaps {:?} '{}'", a.kind, a.text, b.kind, b.text));
                }
            }
        }
        if let Some(legend) = self.legend {
            if !image.contains(&legend) {
                out.push(format!("the legend at {legend} leaves the {}x{} image", image.x1, image.y1));
            }
            for p in self.points.iter().filter(|p| p.overlaps(&legend)) {
                out.push(format!("the point at {p} is under the legend at {legend}"));
            }
            for t in self.texts.iter().filter(|t| t.kind != TextKind::Legend && t.rect.overlaps(&legend)) {
                out.push(format!("{:?} '{}' is under the legend at {legend}", t.kind, t.text));
            }
        }
        out
    }
}

/// Sizes at one image size: `k` scales lengths given for [`SIZE`].
#[derive(Clone, Copy, Debug)]
struct Metrics {
    w: i32,
    k: f64,
}

impl Metrics {
    fn new((w, h): (u32, u32)) -> Self {
        let k = (f64::from(w) / f64::from(SIZE.0)).min(f64::from(h) / f64::from(SIZE.1));
        Metrics { w: w as i32, k }
    }

    /// A font size in whole pixels: `base` at [`SIZE`], scaled, at least [`MIN_FONT`].
    fn font(&self, base: f64) -> f64 {
        (base * self.k).max(MIN_FONT).round()
    }

    /// A length: `base` pixels at [`SIZE`], scaled, at least 1.
    fn px(&self, base: f64) -> i32 {
        (base * self.k).round().max(1.0) as i32
    }
}

/// The share of a line above the top of plotters' layout box: the ab_glyph backend puts
/// the baseline half the font size below the text's position, and DejaVu Sans's ascent is
/// 1901 of its 2384 units of ascent plus descent (the font size): 0.797 - 0.5 of it.
const ABOVE: f64 = 0.2974;

/// How far a line's ink may reach above plotters' layout box, in pixels.
fn above(px: f64) -> i32 {
    (ABOVE * px).ceil() as i32
}

/// A line's height: ascent to descent is the font size, plus two pixels: antialiasing,
/// and the backend's rounding of each glyph's place down a pixel at small sizes.
fn line_h(px: f64) -> i32 {
    px.ceil() as i32 + 2
}

/// The advance width and layout height of `text` (what plotters anchors text by).
fn layout_size(text: &str, px: f64) -> (i32, i32) {
    match (FAMILY, px).into_font().layout_box(text) {
        Ok(((x0, y0), (x1, y1))) => (x1 - x0, y1 - y0),
        // Only without the font, which every chart registers first: an estimate.
        Err(_) => ((text.chars().count() as f64 * px * 0.6) as i32, (px / 1.24) as i32),
    }
}

fn width(text: &str, px: f64) -> i32 {
    layout_size(text, px).0
}

/// The box of `text` as plotters draws it at `pos` with anchor `(h, v)`: the way its
/// bitmap backend offsets the layout box, then the line's height from [`above`].
fn anchored(text: &str, px: f64, pos: (i32, i32), h: HPos, v: VPos) -> Rect {
    let (w, lh) = layout_size(text, px);
    let dx = match h {
        HPos::Left => 0,
        HPos::Center => -w / 2,
        HPos::Right => -w,
    };
    let dy = match v {
        VPos::Top => 0,
        VPos::Center => -lh / 2,
        VPos::Bottom => -lh,
    };
    Rect::at((pos.0 + dx, pos.1 + dy - above(px)), (w, line_h(px)))
}

/// The box of `text` as plotters draws it turned 270 degrees (reading upwards) at `pos`,
/// anchored at its top centre: the line's height runs along x from `pos`, its width along
/// y, centred (the glyph at the text's start lands a pixel past the half width).
fn turned(text: &str, px: f64, (x, y): (i32, i32)) -> Rect {
    let (w, _) = layout_size(text, px);
    Rect { x0: x - above(px), y0: y - (w - w / 2), x1: x - above(px) + line_h(px), y1: y + w / 2 + 1 }
}

/// Where `s` may break: (end of this line, start of the next), at spaces and after
/// hyphens, underscores and slashes (setting names like `clustered-aabb` have no spaces).
fn breaks(s: &str) -> Vec<(usize, usize)> {
    s.char_indices()
        .filter_map(|(i, c)| match c {
            ' ' => Some((i, i + 1)),
            '-' | '_' | '/' => Some((i + 1, i + 1)),
            _ => None,
        })
        .filter(|&(end, _)| end > 0 && end < s.len())
        .collect()
}

/// `text` broken greedily at [`breaks`] into at most `max_lines` lines, each but the last
/// no wider than `max_w` (the last holds the rest).
fn break_lines(text: &str, px: f64, max_w: i32, max_lines: usize) -> Vec<String> {
    let mut rest = text.trim();
    let mut out = Vec::new();
    while out.len() + 1 < max_lines && width(rest, px) > max_w {
        let cut = breaks(rest).into_iter().rev().find(|&(end, _)| width(rest[..end].trim_end(), px) <= max_w);
        let Some((end, next)) = cut else { break };
        out.push(rest[..end].trim_end().to_string());
        rest = rest[next..].trim_start();
    }
    out.push(rest.to_string());
    out
}

/// `text` cut short with "…" to at most `max_w` (empty when not even "…" fits).
fn elide(text: &str, px: f64, max_w: i32) -> String {
    cut(text, px, max_w, (1, 1))
}

/// `text` cut in the middle with "…" to at most `max_w`: two fifths of the kept characters
/// from its start, the rest from its end (where settings named alike differ: the last
/// value of `grid=clustered, bounds=aabb`).
fn elide_middle(text: &str, px: f64, max_w: i32) -> String {
    cut(text, px, max_w, (2, 5))
}

/// `text` whole if it fits `max_w`, else the most characters that fit with "…" in their
/// place, `head.0 / head.1` of them from the start and the rest from the end.
fn cut(text: &str, px: f64, max_w: i32, head: (usize, usize)) -> String {
    if width(text, px) <= max_w {
        return text.to_string();
    }
    let chars: Vec<char> = text.chars().collect();
    (0..chars.len())
        .rev()
        .map(|n| {
            let h = n * head.0 / head.1;
            let (a, b): (String, String) =
                (chars[..h].iter().collect(), chars[chars.len() - (n - h)..].iter().collect());
            format!("{}…{}", a.trim_end(), b.trim_start())
        })
        .find(|s| width(s, px) <= max_w)
        .unwrap_or_default()
}

/// `names` each cut to `max_w` at size `px`, told apart: cut at the end where that leaves
/// them distinct, else in the middle (their ends differ), else numbered.
fn elide_distinct(names: &[String], px: f64, max_w: i32) -> Vec<String> {
    let distinct = |v: &[String]| {
        let mut seen = std::collections::HashSet::new();
        v.iter().all(|s| seen.insert(s.as_str()))
    };
    let end: Vec<String> = names.iter().map(|s| elide(s, px, max_w)).collect();
    if distinct(&end) || !distinct(names) {
        return end;
    }
    let middle: Vec<String> = names.iter().map(|s| elide_middle(s, px, max_w)).collect();
    if distinct(&middle) {
        return middle;
    }
    names.iter().enumerate().map(|(i, s)| elide(&format!("{}: {s}", i + 1), px, max_w)).collect()
}

/// `text` in at most `max_lines` lines no wider than `max_w`: broken at word boundaries
/// at size `px`, else at smaller sizes down to `min_px`, else cut short with "…" there.
/// Returns the lines and the size.
fn fit(text: &str, px: f64, min_px: f64, max_w: i32, max_lines: usize) -> (Vec<String>, f64) {
    let mut size = px;
    loop {
        let lines = break_lines(text, size, max_w, max_lines);
        if lines.iter().all(|l| width(l, size) <= max_w) {
            return (lines, size);
        }
        if size <= min_px {
            let lines = lines.iter().map(|l| elide(l, size, max_w)).collect();
            return (lines, size);
        }
        size = (size - 1.0).max(min_px);
    }
}

/// Lines of one text read as one (a break at a space becomes the space again).
fn join_lines(lines: &[String]) -> String {
    let mut out = String::new();
    for l in lines {
        if !out.is_empty() && !out.ends_with(['-', '_', '/']) {
            out.push(' ');
        }
        out.push_str(l);
    }
    out
}

type Root<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<Keyed, Keyed>>;

fn err<E: fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing the chart: {e}")
}

/// Draws `text` on the image with its box's top left at `(x, y)` and records the box.
#[allow(clippy::too_many_arguments)]
fn put(
    root: &Root<'_>,
    lay: &mut Layout,
    kind: TextKind,
    panel: usize,
    text: &str,
    px: f64,
    col: RGBColor,
    (x, y): (i32, i32),
) -> Result<Rect> {
    let rect = Rect::at((x, y), (width(text, px), line_h(px)));
    if !text.is_empty() {
        root.draw(&Text::new(text.to_string(), (x, y + above(px)), (FAMILY, px).into_font().color(&col)))
            .map_err(err)?;
        lay.texts.push(TextBox { kind, panel, text: text.to_string(), rect });
    }
    Ok(rect)
}

/// Draws an RGB image of `size`, saves it as a PNG at `path` (which must end in .png) and
/// returns what `draw` recorded.
fn draw_png(path: &Path, size: (u32, u32), draw: impl FnOnce(&Root<'_>, &mut Layout) -> Result<()>) -> Result<Layout> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "chart {}: only .png charts are supported", path.display());
    let (w, h) = size;
    ensure!(
        (MIN_SIZE.0..=MAX_SIDE).contains(&w) && (MIN_SIZE.1..=MAX_SIDE).contains(&h),
        "chart {}: size {w}x{h} is outside {}x{} to {MAX_SIDE}x{MAX_SIDE}",
        path.display(),
        MIN_SIZE.0,
        MIN_SIZE.1
    );
    register_font()?;
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    let mut layout = Layout { size, ..Layout::default() };
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root, &mut layout)?;
        root.present().map_err(err)?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).context("building the chart image")?;
    crate::output::save_png(path, &img)?;
    Ok(layout)
}

/// Draws the title, subtitle and note at the top, each wrapped, shrunk or cut to the
/// width, and returns the height they took.
fn title_block(
    root: &Root<'_>,
    lay: &mut Layout,
    m: &Metrics,
    title: &str,
    subtitle: &str,
    note: Option<&str>,
) -> Result<i32> {
    let x = m.px(24.0);
    let max_w = m.w - 2 * x;
    let mut y = m.px(10.0);
    let blocks = [
        (TextKind::Title, title, m.font(28.0), RGBColor(0, 0, 0)),
        (TextKind::Subtitle, subtitle, m.font(18.0), RGBColor(70, 70, 70)),
        (TextKind::Note, note.unwrap_or(""), m.font(20.0), RGBColor(160, 20, 20)),
    ];
    for (kind, text, px, col) in blocks {
        if text.trim().is_empty() {
            continue;
        }
        let (lines, size) = fit(text, px, MIN_FONT.min(px), max_w, 2);
        for l in &lines {
            put(root, lay, kind, 0, l, size, col, (x, y))?;
            y += line_h(size) + (size * 0.1).round() as i32;
        }
        y += m.px(6.0);
    }
    Ok(y + m.px(4.0))
}

/// The plot's corners, for the legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Corner {
    UpperRight,
    LowerRight,
    UpperLeft,
    LowerLeft,
}

/// The corner of the plot (`x` and `y` spans, in plotted units) whose quarter holds the
/// fewest of `points`, for the legend: a legend over the points fades them (the error
/// budget's points all sit near the top of a log axis that reaches down to the target).
/// Ties keep the upper right, then the lower right.
fn emptiest_corner(points: &[(f64, f64)], (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Corner {
    let (xm, ym) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let count =
        |right: bool, upper: bool| points.iter().filter(|(x, y)| (*x >= xm) == right && (*y >= ym) == upper).count();
    [
        (Corner::UpperRight, count(true, true)),
        (Corner::LowerRight, count(true, false)),
        (Corner::UpperLeft, count(false, true)),
        (Corner::LowerLeft, count(false, false)),
    ]
    .into_iter()
    .min_by_key(|(_, n)| *n)
    .map(|(c, _)| c)
    .unwrap_or(Corner::UpperRight)
}

/// A legend entry's symbol (sizes in pixels).
#[derive(Clone, Copy, Debug)]
enum Mark {
    Line(RGBColor, u32),
    Dot(RGBColor, i32),
    Ring(RGBColor, i32, u32),
    Diamond(RGBColor, i32),
}

/// A legend laid out, not yet drawn: its box and each entry's symbol and lines.
struct Legend {
    rect: Rect,
    px: f64,
    pad: i32,
    mark_w: i32,
    entries: Vec<(Mark, Vec<String>, i32)>,
}

/// Lays out a legend of `entries` in the corner of `plot` that covers none of the points
/// already recorded in `lay`, trying `prefer` first (the emptiest quarter), then the upper
/// right, lower right, upper left and lower left; failing all, the one covering fewest.
fn plan_legend(
    lay: &Layout,
    m: &Metrics,
    plot: Rect,
    entries: &[(Mark, String)],
    base_px: f64,
    prefer: Corner,
) -> Option<Legend> {
    if entries.is_empty() {
        return None;
    }
    let px0 = m.font(base_px);
    let mark_w = (px0 * 1.6).round() as i32;
    let pad = (px0 * 0.45).round() as i32;
    let max_text = ((f64::from(plot.w()) * 0.5) as i32 - mark_w - 3 * pad).max((px0 * 6.0) as i32);
    // One size for every entry: the smallest any needs.
    let px = entries.iter().map(|(_, t)| fit(t, px0, MIN_FONT.min(px0), max_text, 2).1).fold(px0, f64::min);
    let gap = (px * 0.3).round() as i32;
    let lgap = (px * 0.1).round() as i32;
    let mut rows = Vec::new();
    let (mut w, mut h) = (0, 0);
    for (mark, text) in entries {
        let (lines, _) = fit(text, px, px, max_text, 2);
        w = w.max(lines.iter().map(|l| width(l, px)).max().unwrap_or(0));
        let eh = lines.len() as i32 * line_h(px) + (lines.len() as i32 - 1) * lgap;
        h += eh + gap;
        rows.push((*mark, lines, eh));
    }
    let size = (pad + mark_w + pad + w + pad, 2 * pad + h - gap);
    let inset = m.px(10.0);
    let at = |c: Corner| {
        let x = match c {
            Corner::UpperLeft | Corner::LowerLeft => plot.x0 + inset,
            _ => plot.x1 - inset - size.0,
        };
        let y = match c {
            Corner::UpperLeft | Corner::UpperRight => plot.y0 + inset,
            _ => plot.y1 - inset - size.1,
        };
        Rect::at((x, y), size)
    };
    // The corners, the preferred first; then places along the top and bottom edges and
    // down the sides (a small plot has points in every corner).
    let mut places = vec![at(prefer)];
    for c in [Corner::UpperRight, Corner::LowerRight, Corner::UpperLeft, Corner::LowerLeft] {
        if c != prefer {
            places.push(at(c));
        }
    }
    let (ul, lr) = (at(Corner::UpperLeft), at(Corner::LowerRight));
    for k in 1..12 {
        let x = ul.x0 + (lr.x0 - ul.x0) * k / 12;
        let y = ul.y0 + (lr.y0 - ul.y0) * k / 12;
        places.extend([Rect::at((x, ul.y0), size), Rect::at((x, lr.y0), size)]);
        places.extend([Rect::at((ul.x0, y), size), Rect::at((lr.x0, y), size)]);
    }
    let covered = |r: &Rect| lay.points.iter().filter(|p| p.overlaps(r)).count();
    let rect = places.iter().copied().min_by_key(covered).unwrap_or_else(|| at(prefer));
    Some(Legend { rect, px, pad, mark_w, entries: rows })
}

/// Draws a planned legend and records it.
fn draw_legend(root: &Root<'_>, lay: &mut Layout, legend: &Legend) -> Result<()> {
    let r = legend.rect;
    root.draw(&Rectangle::new([(r.x0, r.y0), (r.x1, r.y1)], WHITE.mix(0.9).filled())).map_err(err)?;
    root.draw(&Rectangle::new([(r.x0, r.y0), (r.x1, r.y1)], RGBColor(160, 160, 160))).map_err(err)?;
    let gap = (legend.px * 0.3).round() as i32;
    let lgap = (legend.px * 0.1).round() as i32;
    let mut y = r.y0 + legend.pad;
    for (mark, lines, eh) in &legend.entries {
        let (cx, cy) = (r.x0 + legend.pad + legend.mark_w / 2, y + line_h(legend.px) / 2);
        let half = legend.mark_w / 2;
        match *mark {
            Mark::Line(col, w) => {
                root.draw(&PathElement::new(vec![(cx - half, cy), (cx + half, cy)], col.stroke_width(w)))
            }
            Mark::Dot(col, rad) => root.draw(&Circle::new((cx, cy), rad, col.filled())),
            Mark::Ring(col, rad, w) => root.draw(&Circle::new((cx, cy), rad.min(half), col.stroke_width(w))),
            Mark::Diamond(col, s) => {
                root.draw(&Polygon::new(vec![(cx, cy - s), (cx + s, cy), (cx, cy + s), (cx - s, cy)], col.filled()))
            }
        }
        .map_err(err)?;
        let mut ly = y;
        for l in lines {
            let x = r.x0 + legend.pad + legend.mark_w + legend.pad;
            put(root, lay, TextKind::Legend, 0, l, legend.px, RGBColor(0, 0, 0), (x, ly))?;
            ly += line_h(legend.px) + lgap;
        }
        y += eh + gap;
    }
    lay.legend = Some(r);
    Ok(())
}

/// The first of the boxes `candidates` inside `within` that overlaps no text drawn yet,
/// nor the legend (`avoid`), nor (first try) a plotted point; else the first inside;
/// else the first.
fn place(lay: &Layout, candidates: &[Rect], within: Rect, avoid: Option<Rect>) -> Rect {
    let free = |r: &Rect, points: bool| {
        let blocked = lay.texts.iter().any(|t| t.rect.overlaps(r))
            || avoid.is_some_and(|a| a.overlaps(r))
            || (points && lay.points.iter().any(|p| p.overlaps(r)));
        within.contains(r) && !blocked
    };
    candidates
        .iter()
        .find(|r| free(r, true))
        .or_else(|| candidates.iter().find(|r| free(r, false)))
        .or_else(|| candidates.iter().find(|r| within.contains(r)))
        .or(candidates.first())
        .copied()
        .unwrap_or(Rect::at((within.x0, within.y0), (0, 0)))
}

/// The plot area's pixels.
fn plot_rect(chart: &Chart<'_, '_>) -> Rect {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    Rect { x0: xr.start, y0: yr.start, x1: xr.end, y1: yr.end }
}

/// An axis before layout.
struct AxisIn<'s> {
    /// The plotted span (plotted units).
    lo: f64,
    hi: f64,
    scale: Scale,
    /// Candidate ticks (plotted units), thinned to fit; None: nice ones, fewer if crowded.
    ticks: Option<Vec<f64>>,
    /// Names of the keys 0, 1, 2, ...: a category axis (ticks at every key).
    names: Option<Vec<String>>,
    /// The widest a name may be (y axis), in pixels.
    names_w: i32,
    /// The description (label with unit), or empty.
    desc: &'s str,
}

impl AxisIn<'_> {
    /// The candidate ticks (plotted units) with about `n` nice ones when automatic.
    fn candidates(&self, n: usize) -> Vec<f64> {
        let inside = |u: &f64| u.is_finite() && *u >= self.lo - 1e-9 && *u <= self.hi + 1e-9;
        match (&self.names, &self.ticks) {
            (Some(names), _) => (0..names.len()).map(|i| i as f64).filter(inside).collect(),
            (None, Some(t)) => t.iter().copied().filter(inside).collect(),
            (None, None) => nice_ticks(self.scale.unmap(self.lo), self.scale.unmap(self.hi), self.scale, n)
                .into_iter()
                .map(|v| self.scale.map(v))
                .filter(inside)
                .collect(),
        }
    }

    fn label(&self, u: f64) -> String {
        match &self.names {
            Some(names) => {
                let i = u.round();
                if (u - i).abs() < 1e-6 && i >= 0.0 {
                    names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            }
            None => tick_label(self.scale.unmap(u)),
        }
    }

    /// How plain a key's label is, for thinning: the value's plainness, or a category's
    /// place.
    fn plainness(&self, u: f64) -> (u32, u32) {
        match self.names {
            Some(_) => (0, 0),
            None => plainness(self.scale.unmap(u)),
        }
    }
}

/// Sizes of one plot's frame.
struct FrameStyle {
    tick_px: f64,
    desc_px: f64,
    /// Margins around the plot and its label areas: top, bottom, left, right.
    margin: (i32, i32, i32, i32),
    /// Horizontal grid lines.
    y_grid: bool,
}

impl FrameStyle {
    /// The style of a whole-chart plot (the line and Pareto charts): 18 px ticks, 22 px axis
    /// descriptions, horizontal grid lines, a top margin that clears the top tick label.
    fn plot(m: &Metrics) -> Self {
        let tick_px = m.font(18.0);
        FrameStyle {
            tick_px,
            desc_px: m.font(22.0),
            margin: (m.px(12.0).max((tick_px * 0.8) as i32), m.px(12.0), m.px(16.0), m.px(28.0)),
            y_grid: true,
        }
    }
}

/// The keys (indices into `boxes`) whose labels keep `gap` apart along the axis and stay
/// inside `within`, clear of `avoid`: the ends of the range first, then the plainest
/// values, then in order.
fn thin(boxes: &[Rect], plain: &[(u32, u32)], gap: i32, vertical: bool, within: Rect, avoid: &[Rect]) -> Vec<usize> {
    let n = boxes.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| (i != 0 && i + 1 != n, plain[i], i));
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        let b = &boxes[i];
        if within.contains(b)
            && avoid.iter().all(|a| !a.overlaps(b))
            && kept.iter().all(|&j| b.apart(&boxes[j], gap, vertical))
        {
            kept.push(i);
        }
    }
    kept.sort_unstable();
    kept
}

/// Builds the plot on `area`, with its label areas sized to the labels and descriptions,
/// the tick keys thinned so that their labels keep apart, the axes, grid, labels and
/// descriptions drawn (category names of the x axis wrapped under their category), and
/// every label's box recorded.
fn frame<'a, 'b>(
    area: &'a Root<'b>,
    lay: &mut Layout,
    m: &Metrics,
    panel: usize,
    (x, y): (&AxisIn<'_>, &AxisIn<'_>),
    style: &FrameStyle,
) -> Result<Chart<'a, 'b>> {
    let (tpx, dpx) = (style.tick_px, style.desc_px);
    let tick = m.px(5.0).max(3);
    let dist = 2 * tick;
    let gap = m.px(8.0).max(6);
    let lgap = (tpx * 0.1).round() as i32;
    let (ar_x, ar_y) = area.get_pixel_range();
    let area_rect = Rect { x0: ar_x.start, y0: ar_y.start, x1: ar_x.end, y1: ar_y.end };
    let desc_h = |d: &str| if d.is_empty() { 0 } else { line_h(dpx) + gap };
    let y_cands = y.candidates(6);
    let widest = match &y.names {
        Some(all) => all.iter().map(|n| width(n, tpx)).max().unwrap_or(0).min(y.names_w),
        None => y_cands.iter().map(|&u| width(&y.label(u), tpx)).max().unwrap_or(0),
    };
    let y_area = dist + widest + gap / 2 + desc_h(y.desc) + m.px(2.0);
    let x_area = |lines: i32| dist - above(tpx) + lines * line_h(tpx) + (lines - 1) * lgap + desc_h(x.desc) + m.px(2.0);
    let build = |xa: i32, xk: Vec<f64>, yk: Vec<f64>| {
        ChartBuilder::on(area)
            .margin_top(style.margin.0)
            .margin_bottom(style.margin.1)
            .margin_left(style.margin.2)
            .margin_right(style.margin.3)
            .x_label_area_size(xa)
            .y_label_area_size(y_area)
            .build_cartesian_2d(Keyed { lo: x.lo, hi: x.hi, keys: xk }, Keyed { lo: y.lo, hi: y.hi, keys: yk })
            .map_err(err)
    };
    // Category names: one size for all, wrapped onto two lines, cut short if they must,
    // each within its category's width.
    let mut names: Vec<Vec<String>> = Vec::new();
    let mut name_px = tpx;
    let mut lines = 1;
    if let Some(all) = &x.names {
        let probe = build(x_area(1), Vec::new(), Vec::new())?;
        let slot = (plot_rect(&probe).w() / all.len().max(1) as i32 - gap).max(1);
        name_px = all.iter().map(|n| fit(n, tpx, MIN_FONT.min(tpx), slot, 2).1).fold(tpx, f64::min);
        names = all.iter().map(|n| fit(n, name_px, name_px, slot, 2).0).collect();
        lines = names.iter().map(|l| l.len() as i32).max().unwrap_or(1);
    }
    let line_px = if x.names.is_some() { name_px } else { tpx };
    let xa = x_area(lines) + (line_h(line_px) - line_h(tpx)) * lines;
    // The plot's pixels do not depend on the keys: thin them on a first build.
    let probe = build(xa, Vec::new(), Vec::new())?;
    let plot = plot_rect(&probe);
    // Names of the y axis: one size for all, on two lines where a key's share of the
    // height holds two, cut short if they must.
    let mut y_names: Vec<Vec<String>> = Vec::new();
    let mut y_name_px = tpx;
    if let Some(all) = &y.names {
        let slot = plot.h() / all.len().max(1) as i32;
        let max_lines = if slot >= 2 * line_h(tpx) + lgap + gap / 2 { 2 } else { 1 };
        y_name_px = all.iter().map(|n| fit(n, tpx, MIN_FONT.min(tpx), widest, max_lines).1).fold(tpx, f64::min);
        y_names = all.iter().map(|n| fit(n, y_name_px, y_name_px, widest, max_lines).0).collect();
    }
    let named_box = |lines: &[String], px: f64| {
        let w = lines.iter().map(|l| width(l, px)).max().unwrap_or(0);
        (w, lines.len() as i32 * line_h(px) + (lines.len() as i32 - 1).max(0) * lgap)
    };
    let y_box = |u: f64| {
        let p = probe.backend_coord(&(x.lo, u)).1;
        match y_names.get(u.round().max(0.0) as usize).filter(|_| y.names.is_some()) {
            Some(lines) => {
                let (w, h) = named_box(lines, y_name_px);
                Rect::at((plot.x0 - dist - w, p - h / 2), (w, h))
            }
            None => anchored(&y.label(u), tpx, (plot.x0 - dist, p), HPos::Right, VPos::Center),
        }
    };
    let keep = |cands: &[f64], boxes: &dyn Fn(f64) -> Rect, axis: &AxisIn<'_>, vertical: bool, avoid: &[Rect]| {
        let b: Vec<Rect> = cands.iter().map(|&u| boxes(u)).collect();
        let plain: Vec<(u32, u32)> = cands.iter().map(|&u| axis.plainness(u)).collect();
        thin(&b, &plain, gap, vertical, area_rect, avoid).into_iter().map(|i| cands[i]).collect::<Vec<f64>>()
    };
    // Automatic ticks: fewer nice ones rather than uneven survivors, where that fits.
    let choose = |axis: &AxisIn<'_>, boxes: &dyn Fn(f64) -> Rect, vertical: bool, avoid: &[Rect]| {
        let first = axis.candidates(6);
        if axis.names.is_none() && axis.ticks.is_none() {
            for n in [6, 4, 3, 2] {
                let c = axis.candidates(n);
                let kept = keep(&c, boxes, axis, vertical, avoid);
                if kept.len() == c.len() {
                    return kept;
                }
            }
        }
        keep(&first, boxes, axis, vertical, avoid)
    };
    let y_keys = choose(y, &y_box, true, &[]);
    let y_boxes: Vec<Rect> = y_keys.iter().map(|&u| y_box(u)).collect();
    let x_box = |u: f64| {
        let p = probe.backend_coord(&(u, y.lo)).0;
        anchored(&x.label(u), tpx, (p, plot.y1 + dist), HPos::Center, VPos::Top)
    };
    let x_keys = if x.names.is_some() { x.candidates(6) } else { choose(x, &x_box, false, &y_boxes) };
    let mut chart = build(xa, x_keys.clone(), y_keys.clone())?;
    // The descriptions: one size for both (plotters styles them together), cut to the plot.
    let d_px = [(x.desc, plot.w()), (y.desc, plot.h())]
        .iter()
        .filter(|(d, _)| !d.is_empty())
        .map(|(d, w)| fit(d, dpx, MIN_FONT.min(dpx), *w, 1).1)
        .fold(dpx, f64::min);
    let x_desc = elide(x.desc, d_px, plot.w());
    let y_desc = elide(y.desc, d_px, plot.h());
    // Names are drawn below, wrapped: plotters draws one line.
    let (x_named, y_named) = (x.names.is_some(), y.names.is_some());
    let fx = |u: &f64| if x_named { String::new() } else { x.label(*u) };
    let fy = |u: &f64| if y_named { String::new() } else { y.label(*u) };
    {
        let mut mesh = chart.configure_mesh();
        mesh.axis_desc_style((FAMILY, d_px))
            .label_style((FAMILY, tpx))
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .set_all_tick_mark_size(tick)
            .light_line_style(WHITE)
            .bold_line_style(RGBColor(225, 225, 225));
        if !x_desc.is_empty() {
            mesh.x_desc(x_desc.clone());
        }
        if !y_desc.is_empty() {
            mesh.y_desc(y_desc.clone());
        }
        if !style.y_grid {
            mesh.disable_y_mesh();
        }
        mesh.draw().map_err(err)?;
    }
    // Record the labels where plotters put them (see `draw_axis_and_labels` in plotters'
    // chart/context/cartesian2d/draw_impl.rs): y labels right-aligned `dist` left of the
    // plot, centred on their key; x labels centred under their key, `dist` below; the x
    // description centred at the bottom of its area, the y one turned at the left edge of
    // its area, centred on the plot's height.
    // Lines drawn here go on `area`, whose origin is its top left.
    let draw_lines = |lines: &[String], px: f64, (x, y): (i32, i32), right: bool| -> Result<Rect> {
        let mut out: Option<Rect> = None;
        let mut yy = y;
        for l in lines {
            let w = width(l, px);
            let r = Rect::at((if right { x - w } else { x - w / 2 }, yy), (w, line_h(px)));
            let at = (r.x0 - area_rect.x0, yy + above(px) - area_rect.y0);
            area.draw(&Text::new(l.clone(), at, (FAMILY, px).into_font())).map_err(err)?;
            out = Some(out.map_or(r, |a| a.union(&r)));
            yy += line_h(px) + lgap;
        }
        Ok(out.unwrap_or(Rect::at((x, y), (0, 0))))
    };
    for &u in &y_keys {
        let (text, rect) = match y_names.get(u.round().max(0.0) as usize).filter(|_| y_named) {
            Some(lines) => {
                let b = y_box(u);
                (join_lines(lines), draw_lines(lines, y_name_px, (b.x1, b.y0), true)?)
            }
            None => (y.label(u), y_box(u)),
        };
        if !text.is_empty() {
            lay.texts.push(TextBox { kind: TextKind::YTick, panel, text, rect });
        }
    }
    if x_named {
        for (i, lines) in names.iter().enumerate() {
            let p = chart.backend_coord(&(i as f64, y.lo)).0;
            let rect = draw_lines(lines, name_px, (p, plot.y1 + dist - above(name_px)), false)?;
            if !lines.is_empty() {
                lay.texts.push(TextBox { kind: TextKind::XTick, panel, text: join_lines(lines), rect });
            }
        }
    } else {
        for &u in &x_keys {
            let text = x.label(u);
            if !text.is_empty() {
                let p = chart.backend_coord(&(u, y.lo)).0;
                let rect = anchored(&text, tpx, (p, plot.y1 + dist), HPos::Center, VPos::Top);
                lay.texts.push(TextBox { kind: TextKind::XTick, panel, text, rect });
            }
        }
    }
    if !x_desc.is_empty() {
        let pos = (plot.x0 + plot.w() / 2, plot.y1 + xa);
        let rect = anchored(&x_desc, d_px, pos, HPos::Center, VPos::Bottom);
        lay.texts.push(TextBox { kind: TextKind::XDesc, panel, text: x_desc, rect });
    }
    if !y_desc.is_empty() {
        let rect = turned(&y_desc, d_px, (plot.x0 - y_area, plot.y0 + plot.h() / 2));
        lay.texts.push(TextBox { kind: TextKind::YDesc, panel, text: y_desc, rect });
    }
    Ok(chart)
}

/// The box of a point's marker of radius `r` at pixel `p`.
fn dot_box((x, y): (i32, i32), r: i32) -> Rect {
    Rect { x0: x - r, y0: y - r, x1: x + r + 1, y1: y + r + 1 }
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

/// A line chart.
#[derive(Clone, Debug)]
pub struct LineChart {
    /// Title (what, where: GPU, resolution, scene).
    pub title: String,
    /// Second title line (settings held fixed).
    pub subtitle: String,
    /// The x axis (its scale and ticks unused on a category axis).
    pub x: AxisSpec,
    /// The y axis.
    pub y: AxisSpec,
    /// The lines.
    pub series: Vec<Series>,
    /// A vertical marker at x with its label (e.g. the crossover).
    pub marker: Option<(f64, String)>,
    /// A note printed under the subtitle (e.g. where the lines cross).
    pub note: Option<String>,
    /// For a categorical x axis: the label of x = 0, 1, 2, ... Points are drawn without
    /// lines (no order between categories), side by side within a category.
    pub categories: Option<Vec<String>>,
}

/// Draws `c` at [`SIZE`] to the PNG `path`.
pub fn line_chart(path: &Path, c: &LineChart) -> Result<Layout> {
    line_chart_sized(path, c, SIZE)
}

/// The x offset (in categories) of series `i` of `n` on a category axis: side by side,
/// like grouped bars, so that equal values stay apart.
fn category_offset(i: usize, n: usize) -> f64 {
    let step = (0.6 / n.max(1) as f64).min(0.2);
    (i as f64 - (n as f64 - 1.0) / 2.0) * step
}

/// Draws `c` at `size` (width, height) to the PNG `path` and returns where it put things.
pub fn line_chart_sized(path: &Path, c: &LineChart, size: (u32, u32)) -> Result<Layout> {
    let cats = c.categories.as_ref().filter(|v| !v.is_empty());
    let n_series = c.series.len();
    // Plotted units: log10 on a log axis; a category's index plus the series' offset.
    let map = |i: usize, (x, y): (f64, f64)| -> Option<(f64, f64)> {
        let u = match cats {
            Some(names) => {
                let k = x.round();
                if (x - k).abs() > 1e-9 || k < 0.0 || k as usize >= names.len() {
                    return None;
                }
                k + category_offset(i, n_series)
            }
            None => c.x.scale.map(x),
        };
        let v = c.y.scale.map(y);
        (u.is_finite() && v.is_finite()).then_some((u, v))
    };
    let pts: Vec<Vec<(f64, f64)>> =
        c.series.iter().enumerate().map(|(i, s)| s.points.iter().filter_map(|&p| map(i, p)).collect()).collect();
    let rings: Vec<(f64, f64)> =
        c.series.iter().enumerate().flat_map(|(i, s)| s.incomplete.iter().filter_map(move |&p| map(i, p))).collect();
    let all: Vec<(f64, f64)> = pts.iter().flatten().copied().collect();
    ensure!(!all.is_empty(), "chart {}: no points to draw", path.display());
    draw_png(path, size, |root, lay| {
        let m = Metrics::new(size);
        let ys: Vec<f64> = all.iter().map(|p| c.y.scale.unmap(p.1)).collect();
        let (x0, x1) = match cats {
            Some(names) => (-0.5, names.len() as f64 - 0.5),
            None => span(&all.iter().map(|p| c.x.scale.unmap(p.0)).collect::<Vec<_>>(), c.x.scale, false),
        };
        let (y0, y1) = span(&ys, c.y.scale, true);
        let top = title_block(root, lay, &m, &c.title, &c.subtitle, c.note.as_deref())?;
        let (_, rest) = root.split_vertically(top);
        let mapped = |t: &Option<Vec<f64>>, s: Scale| t.as_ref().map(|v| v.iter().map(|&x| s.map(x)).collect());
        let x_axis = AxisIn {
            lo: x0,
            hi: x1,
            scale: if cats.is_some() { Scale::Linear } else { c.x.scale },
            ticks: if cats.is_some() { None } else { mapped(&c.x.ticks, c.x.scale) },
            names: cats.cloned(),
            names_w: 0,
            desc: &c.x.label,
        };
        let y_axis = AxisIn {
            lo: y0,
            hi: y1,
            scale: c.y.scale,
            ticks: mapped(&c.y.ticks, c.y.scale),
            names: None,
            names_w: 0,
            desc: &c.y.label,
        };
        let style = FrameStyle::plot(&m);
        let mut chart = frame(&rest, lay, &m, 0, (&x_axis, &y_axis), &style)?;
        let plot = plot_rect(&chart);
        let dot = m.px(5.0).max(3);
        let mut entries = Vec::new();
        for (i, s) in pts.iter().enumerate() {
            let col = color(i);
            if cats.is_none() {
                let w = m.px(3.0).max(2) as u32;
                chart.draw_series(LineSeries::new(s.clone(), col.stroke_width(w))).map_err(err)?;
                entries.push((Mark::Line(col, w), c.series[i].name.clone()));
            } else {
                // Categories have no order: points only, no line between them.
                entries.push((Mark::Dot(col, dot + 1), c.series[i].name.clone()));
            }
            let r = if cats.is_some() { dot + 1 } else { dot };
            chart.draw_series(s.iter().map(|&p| Circle::new(p, r, col.filled()))).map_err(err)?;
            lay.points.extend(s.iter().map(|p| dot_box(chart.backend_coord(p), r)));
        }
        let ring = m.px(11.0).max(6);
        if !rings.is_empty() {
            let w = m.px(3.0).max(2) as u32;
            chart
                .draw_series(rings.iter().map(|&p| Circle::new(p, ring, INCOMPLETE_RED.stroke_width(w))))
                .map_err(err)?;
            entries.push((Mark::Ring(INCOMPLETE_RED, ring * 3 / 4, w), INCOMPLETE_LABEL.to_string()));
        }
        let marker = c.marker.as_ref().map(|(x, label)| (c.x.scale.map(*x), label)).filter(|(u, _)| u.is_finite());
        if let Some((u, _)) = marker {
            let grey = RGBColor(80, 80, 80);
            chart
                .draw_series(DashedLineSeries::new(vec![(u, y0), (u, y1)], m.px(10.0), m.px(6.0), grey.stroke_width(2)))
                .map_err(err)?;
        }
        let corner = emptiest_corner(&all, (x0, x1), (y0, y1));
        let legend = plan_legend(lay, &m, plot, &entries, 20.0, corner);
        if let Some((u, label)) = marker {
            // Beside the marker's line at the top, on the side with room; at the bottom
            // if the legend is in the way.
            let px = m.font(20.0);
            let label = elide(label, px, plot.w() / 2);
            let (w, h) = (width(&label, px), line_h(px));
            let lx = chart.backend_coord(&(u, y0)).0;
            let (pad, inset) = (m.px(8.0), m.px(10.0));
            let cands: Vec<Rect> = [plot.y0 + inset, plot.y1 - inset - h]
                .iter()
                .flat_map(|&y| [Rect::at((lx + pad, y), (w, h)), Rect::at((lx - pad - w, y), (w, h))])
                .collect();
            let r = place(lay, &cands, plot, legend.as_ref().map(|l| l.rect));
            put(root, lay, TextKind::Marker, 0, &label, px, RGBColor(80, 80, 80), (r.x0, r.y0))?;
        }
        if let Some(legend) = &legend {
            draw_legend(root, lay, legend)?;
        }
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

/// Draws `c` at [`SIZE`] to the PNG `path`: two panels a row, the settings' labels on
/// each panel's left, each bar's value at its end.
pub fn bar_panels(path: &Path, c: &BarPanels) -> Result<Layout> {
    bar_panels_sized(path, c, SIZE)
}

/// Draws `c` at `size` to the PNG `path` (see [`bar_panels`]) and returns where it put
/// things. Setting names too long for a panel's left 40% are cut short with "…", in the
/// middle where cutting their ends would make two read the same.
pub fn bar_panels_sized(path: &Path, c: &BarPanels, size: (u32, u32)) -> Result<Layout> {
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
    draw_png(path, size, |root, lay| {
        let m = Metrics::new(size);
        let top = title_block(root, lay, &m, &c.title, &c.subtitle, c.note.as_deref())?;
        let (_, rest) = root.split_vertically(top);
        let cols = if c.panels.len() == 1 { 1 } else { 2 };
        let rows = c.panels.len().div_ceil(cols);
        let areas = rest.split_evenly((rows, cols));
        let n = c.settings.len();
        for (k, (area, (name, values))) in areas.iter().zip(&c.panels).enumerate() {
            let (ax, ay) = area.get_pixel_range();
            let panel = Rect { x0: ax.start, y0: ay.start, x1: ax.end, y1: ay.end };
            let pad = m.px(14.0);
            let (lines, cpx) = fit(name, m.font(22.0), MIN_FONT, panel.w() - 2 * pad, 1);
            let caption = lines.concat();
            let cw = width(&caption, cpx);
            put(
                root,
                lay,
                TextKind::Caption,
                k,
                &caption,
                cpx,
                RGBColor(0, 0, 0),
                (panel.x0 + (panel.w() - cw) / 2, panel.y0 + m.px(6.0)),
            )?;
            let (_, body) = area.split_vertically(m.px(6.0) + line_h(cpx) + m.px(4.0));
            // The settings' names, one size for all, within 40% of the panel.
            let tick_px = m.font(16.0);
            let max_name = (f64::from(panel.w()) * 0.4) as i32;
            let npx = c
                .settings
                .iter()
                .map(|s| fit(s, tick_px, MIN_FONT.min(tick_px), max_name, 1).1)
                .fold(tick_px, f64::min);
            // Bar i is drawn at y = n - 1 - i: the first setting on top.
            let names: Vec<String> = elide_distinct(&c.settings, npx, max_name).into_iter().rev().collect();
            let hi = values.iter().copied().filter(|v| v.is_finite()).fold(0.0f64, f64::max);
            let hi = if hi > 0.0 { hi * 1.25 } else { 1.0 };
            let x_axis = AxisIn { lo: 0.0, hi, scale: Scale::Linear, ticks: None, names: None, names_w: 0, desc: "" };
            let y_axis = AxisIn {
                lo: -0.6,
                hi: n as f64 - 0.4,
                scale: Scale::Linear,
                ticks: None,
                names: Some(names),
                names_w: max_name,
                desc: "",
            };
            let style = FrameStyle {
                tick_px,
                desc_px: tick_px,
                margin: (m.px(4.0), m.px(8.0), m.px(10.0), m.px(20.0)),
                y_grid: false,
            };
            let mut chart = frame(&body, lay, &m, k, (&x_axis, &y_axis), &style)?;
            let plot = plot_rect(&chart);
            let col = color(k);
            let vpx = m.font(15.0);
            for (i, &v) in values.iter().enumerate() {
                let y = (n - 1 - i) as f64;
                let yc = chart.backend_coord(&(0.0, y)).1;
                let h = line_h(vpx);
                if !v.is_finite() {
                    let t = "not measured";
                    let r = place(lay, &[Rect::at((plot.x0 + m.px(6.0), yc - h / 2), (width(t, vpx), h))], plot, None);
                    put(root, lay, TextKind::BarValue, k, t, vpx, RGBColor(120, 120, 120), (r.x0, r.y0))?;
                    continue;
                }
                chart
                    .draw_series(std::iter::once(Rectangle::new([(0.0, y - 0.35), (v, y + 0.35)], col.filled())))
                    .map_err(err)?;
                // At the bar's end, or inside it (in white) where the plot ends first.
                let text = tick_label(v);
                let (w, gap) = (width(&text, vpx), m.px(5.0));
                let end = chart.backend_coord(&(v, y)).0;
                let outside = Rect::at((end + gap, yc - h / 2), (w, h));
                if plot.contains(&outside) || end - gap - w < plot.x0 {
                    put(root, lay, TextKind::BarValue, k, &text, vpx, RGBColor(0, 0, 0), (outside.x0, outside.y0))?;
                } else {
                    put(
                        root,
                        lay,
                        TextKind::BarValue,
                        k,
                        &text,
                        vpx,
                        RGBColor(255, 255, 255),
                        (end - gap - w, yc - h / 2),
                    )?;
                }
            }
        }
        Ok(())
    })
}

/// The red of the incomplete-frame rings.
const INCOMPLETE_RED: RGBColor = RGBColor(220, 0, 0);
/// Their legend text.
const INCOMPLETE_LABEL: &str = "ringed red: frames DROPPED lights (time of an incomplete frame)";

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

/// Draws `c` at [`SIZE`] to the PNG `path`: points coloured by series, the frontier's
/// labelled, the frontier as a staircase, the target line, the chosen point ringed. Log
/// scales where values span 10x.
pub fn pareto_chart(path: &Path, c: &ParetoChart) -> Result<Layout> {
    pareto_chart_sized(path, c, SIZE)
}

/// Draws `c` at `size` to the PNG `path` (see [`pareto_chart`]) and returns where it put
/// things.
pub fn pareto_chart_sized(path: &Path, c: &ParetoChart, size: (u32, u32)) -> Result<Layout> {
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
    draw_png(path, size, |root, lay| {
        let m = Metrics::new(size);
        let (x0, x1) = span(&xs, xsc, false);
        let (y0, y1) = span(&ys, ysc, ysc == Scale::Linear);
        let top = title_block(root, lay, &m, &c.title, &c.subtitle, c.note.as_deref())?;
        let (_, rest) = root.split_vertically(top);
        let x_axis = AxisIn { lo: x0, hi: x1, scale: xsc, ticks: None, names: None, names_w: 0, desc: &c.x_label };
        let y_axis = AxisIn { lo: y0, hi: y1, scale: ysc, ticks: None, names: None, names_w: 0, desc: &c.y_label };
        let style = FrameStyle::plot(&m);
        let mut chart = frame(&rest, lay, &m, 0, (&x_axis, &y_axis), &style)?;
        let plot = plot_rect(&chart);
        let map = |p: &ParetoPoint| (xsc.map(p.time), ysc.map(p.error));
        let (dot, diamond) = (m.px(7.0).max(4), m.px(9.0).max(5));
        // Every marker's place first: the legend and the labels keep off them.
        for p in &pts {
            lay.points.push(dot_box(chart.backend_coord(&map(p)), dot));
        }
        for r in &refs {
            lay.points.push(dot_box(chart.backend_coord(&(xsc.map(r.0), y0)), diamond));
        }
        let mut entries = Vec::new();
        if !refs.is_empty() {
            entries.push((Mark::Diamond(RGBColor(0, 0, 0), diamond), "reference (error 0)".to_string()));
        }
        let dark = RGBColor(40, 40, 40);
        let line_w = m.px(2.0).max(1) as u32;
        entries.push((Mark::Line(dark, line_w), "Pareto frontier".to_string()));
        for (si, name) in names.iter().enumerate() {
            entries.push((Mark::Dot(color(si), dot), name.to_string()));
        }
        let rings: Vec<(f64, f64)> = pts.iter().filter(|p| p.incomplete).map(|p| map(p)).collect();
        let (ring, ring_w) = (m.px(11.0).max(6), m.px(3.0).max(2) as u32);
        if !rings.is_empty() {
            entries.push((Mark::Ring(INCOMPLETE_RED, ring * 3 / 4, ring_w), INCOMPLETE_LABEL.to_string()));
        }
        // The references' diamonds sit on the bottom edge: counted with the points.
        let mapped: Vec<(f64, f64)> =
            pts.iter().map(|p| map(p)).chain(refs.iter().map(|r| (xsc.map(r.0), y0))).collect();
        let legend = plan_legend(lay, &m, plot, &entries, 18.0, emptiest_corner(&mapped, (x0, x1), (y0, y1)));
        let avoid = legend.as_ref().map(|l| l.rect);
        let (pad, inset) = (m.px(6.0), m.px(10.0));
        if let Some((t, label)) = &c.target {
            let u = ysc.map(*t);
            let red = RGBColor(200, 30, 30);
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(x0, u), (x1, u)],
                    m.px(10.0),
                    m.px(6.0),
                    red.stroke_width(line_w),
                ))
                .map_err(err)?;
            // Above the line at its right end, else its left end, else below.
            let px = m.font(18.0);
            let label = elide(label, px, plot.w() - 2 * inset);
            let (w, h) = (width(&label, px), line_h(px));
            let ty = chart.backend_coord(&(x0, u)).1;
            let cands: Vec<Rect> = [ty - pad / 2 - h, ty + pad / 2]
                .iter()
                .flat_map(|&y| [Rect::at((plot.x1 - inset - w, y), (w, h)), Rect::at((plot.x0 + inset, y), (w, h))])
                .collect();
            let r = place(lay, &cands, plot, avoid);
            put(root, lay, TextKind::Target, 0, &label, px, red, (r.x0, r.y0))?;
        }
        // The references: error 0 sits below any log axis, so on the bottom edge, with a
        // line up through the chart at their time; labels just above, beside the line.
        let black = RGBColor(0, 0, 0);
        for (t, label) in &refs {
            let u = xsc.map(*t);
            chart
                .draw_series(DashedLineSeries::new(vec![(u, y0), (u, y1)], m.px(6.0), m.px(6.0), black.stroke_width(1)))
                .map_err(err)?;
            let (cx, cy) = chart.backend_coord(&(u, y0));
            let s = diamond;
            root.draw(&Polygon::new(vec![(cx, cy - s), (cx + s, cy), (cx, cy + s), (cx - s, cy)], black.filled()))
                .map_err(err)?;
            let px = m.font(16.0);
            let label = elide(label, px, plot.w() / 2);
            let (w, h) = (width(&label, px), line_h(px));
            let cands: Vec<Rect> = (0..4)
                .flat_map(|j| {
                    let y = cy - s - pad - h - j * (h + pad);
                    [Rect::at((cx + pad, y), (w, h)), Rect::at((cx - pad - w, y), (w, h))]
                })
                .collect();
            let r = place(lay, &cands, plot, avoid);
            put(root, lay, TextKind::Reference, 0, &label, px, black, (r.x0, r.y0))?;
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
        chart.draw_series(LineSeries::new(stair, dark.stroke_width(line_w))).map_err(err)?;
        for (si, name) in names.iter().enumerate() {
            let col = color(si);
            let mine = pts.iter().filter(|p| p.series == *name);
            chart.draw_series(mine.map(|p| Circle::new(map(p), dot, col.filled()))).map_err(err)?;
        }
        // Labels on the frontier only: settings of one threshold share a height, and
        // labelling every point would print them on top of each other. Each goes beside
        // its point where it covers no other label, point or the legend.
        let px = m.font(15.0);
        for &i in &frontier {
            let p = &c.points[i];
            if p.label.is_empty() {
                continue;
            }
            let label = elide(&p.label, px, plot.w() / 3);
            let (w, h) = (width(&label, px), line_h(px));
            let (x, y) = chart.backend_coord(&map(p));
            let d = dot + m.px(3.0);
            let cands = [
                Rect::at((x + d, y - d - h / 2), (w, h)),
                Rect::at((x + d, y + d - h / 2), (w, h)),
                Rect::at((x - d - w, y - d - h / 2), (w, h)),
                Rect::at((x - d - w, y + d - h / 2), (w, h)),
                Rect::at((x - w / 2, y - d - h), (w, h)),
                Rect::at((x - w / 2, y + d), (w, h)),
            ];
            let r = place(lay, &cands, plot, avoid);
            put(root, lay, TextKind::PointLabel, 0, &label, px, black, (r.x0, r.y0))?;
        }
        if !rings.is_empty() {
            chart
                .draw_series(rings.iter().map(|&p| Circle::new(p, ring, INCOMPLETE_RED.stroke_width(ring_w))))
                .map_err(err)?;
        }
        if let Some(i) = c.chosen.filter(|&i| i < c.points.len()) {
            let p = map(&c.points[i]);
            if p.0.is_finite() && p.1.is_finite() {
                let ring = m.px(14.0).max(8);
                chart
                    .draw_series(std::iter::once(Circle::new(p, ring, RGBColor(200, 30, 30).stroke_width(ring_w))))
                    .map_err(err)?;
            }
        }
        if let Some(legend) = &legend {
            draw_legend(root, lay, legend)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    /// Series past the first ten get darker colours, never one already used (the error-
    /// against-time chart across methods has eleven series and more).
    #[test]
    fn more_than_ten_series_keep_distinct_colours() {
        let colours: std::collections::HashSet<_> = (0..30)
            .map(|i| {
                let super::RGBColor(r, g, b) = super::color(i);
                (r, g, b)
            })
            .collect();
        assert_eq!(colours.len(), 30);
        assert_eq!(super::color(3).0, super::COLORS[3].0);
    }

    use super::*;
    use plotters::style::text_anchor::Pos;

    /// A directory for the test's charts: `TILEDLIGHT_CHART_DIR` keeps them (to look at),
    /// else a temporary one removed by the test.
    fn chart_dir(name: &str) -> (std::path::PathBuf, bool) {
        match std::env::var_os("TILEDLIGHT_CHART_DIR") {
            Some(d) => (Path::new(&d).join(name), true),
            None => (std::env::temp_dir().join(format!("tiledlight-chart-{name}-{}", std::process::id())), false),
        }
    }

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
        assert_eq!(nice_ticks(0.0, 10.0, Scale::Linear, 6), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(nice_ticks(0.0, 10.0, Scale::Linear, 2), [0.0, 5.0, 10.0]);
        assert_eq!(nice_ticks(3.0, 90.0, Scale::Log, 6), [5.0, 10.0, 20.0, 50.0]);
        assert_eq!(nice_ticks(3.0, 90.0, Scale::Log, 3), [10.0]);
        assert_eq!(nice_ticks(3.0, 300.0, Scale::Log, 6), [10.0, 100.0]);
        assert_eq!(nice_ticks(0.5, 5000.0, Scale::Log, 6), [1.0, 10.0, 100.0, 1000.0]);
        assert_eq!(tick_label(16384.0), "16,384");
        assert_eq!(tick_label(0.0125), "0.0125");
        assert_eq!(tick_label(2.5), "2.5");
        assert_eq!(Scale::auto([1.0, 5.0], 10.0), Scale::Linear);
        assert_eq!(Scale::auto([1.0, 50.0], 10.0), Scale::Log);
        assert_eq!(Scale::auto([0.0, 50.0], 10.0), Scale::Linear);
        // Thinning keeps the plainest values first.
        assert!(plainness(1000.0) < plainness(500.0));
        assert!(plainness(500.0) < plainness(200.0));
        assert!(plainness(200.0) < plainness(300.0));
        assert!(plainness(300.0) < plainness(250.0));
        let boxes: Vec<Rect> = (0..5).map(|i| Rect::at((i * 20, 0), (30, 10))).collect();
        let plain = [(1, 0), (1, 3), (1, 1), (1, 3), (1, 0)];
        let all = Rect::at((0, 0), (200, 20));
        assert_eq!(thin(&boxes, &plain, 6, false, all, &[]), [0, 2, 4]);
        // A label that would leave the image goes.
        assert_eq!(thin(&boxes, &plain, 6, false, Rect::at((0, 0), (100, 20)), &[]), [0, 2]);
    }

    #[test]
    fn text_is_wrapped_then_shrunk_then_cut() {
        register_font().unwrap();
        let text = "courtyard, 4,096 lights, visibility buffer";
        let w = width(text, 20.0);
        assert_eq!(fit(text, 20.0, 11.0, w, 2), (vec![text.to_string()], 20.0));
        // Too wide for one line: two, broken at a space, at the same size.
        let (lines, px) = fit(text, 20.0, 11.0, w * 2 / 3, 2);
        assert_eq!((lines.len(), px), (2, 20.0));
        assert_eq!(join_lines(&lines), text);
        assert!(lines.iter().all(|l| width(l, 20.0) <= w * 2 / 3));
        // Too wide for two lines at 20 px: smaller.
        let (lines, px) = fit(text, 20.0, 11.0, w / 3, 2);
        assert!(px < 20.0 && lines.len() == 2 && lines.iter().all(|l| width(l, px) <= w / 3), "{lines:?} {px}");
        // Too wide at the smallest size: cut short.
        let (lines, px) = fit(text, 20.0, 11.0, w / 6, 2);
        assert_eq!(px, 11.0);
        assert!(lines.last().unwrap().ends_with('…') && lines.iter().all(|l| width(l, px) <= w / 6), "{lines:?}");
        assert_eq!(join_lines(&break_lines("grid=clustered-aabb", 20.0, 90, 2)), "grid=clustered-aabb");
        assert_eq!(elide("abc", 20.0, 0), "");
    }

    /// The boxes of `put` and `anchored` hold every pixel of ink plotters draws, turned
    /// text included: what `Layout::problems` checks is what is on the image.
    #[test]
    fn text_boxes_hold_their_ink() {
        register_font().unwrap();
        let text = "ÅHgjpqy|[]";
        for px in [11.0, 18.0, 28.0, 40.0] {
            let (w, h) = (400u32, 300u32);
            let mut buf = vec![255u8; (w * h * 3) as usize];
            let mut lay = Layout::default();
            let mut boxes = Vec::new();
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                boxes.push(put(&root, &mut lay, TextKind::Title, 0, text, px, RGBColor(0, 0, 0), (20, 20)).unwrap());
                let font = (FAMILY, px).into_font();
                let right = TextStyle::from(font.clone()).pos(Pos::new(HPos::Right, VPos::Center));
                root.draw_text(text, &right, (380, 150)).unwrap();
                boxes.push(anchored(text, px, (380, 150), HPos::Right, VPos::Center));
                let bottom = TextStyle::from(font.clone()).pos(Pos::new(HPos::Center, VPos::Bottom));
                root.draw_text(text, &bottom, (200, 290)).unwrap();
                boxes.push(anchored(text, px, (200, 290), HPos::Center, VPos::Bottom));
                let upward =
                    TextStyle::from(font.transform(FontTransform::Rotate270)).pos(Pos::new(HPos::Center, VPos::Top));
                root.draw_text(text, &upward, (20, 150)).unwrap();
                boxes.push(turned(text, px, (20, 150)));
                root.present().unwrap();
            }
            let img = image::RgbImage::from_raw(w, h, buf).unwrap();
            for (x, y, p) in img.enumerate_pixels() {
                if p.0 != [255, 255, 255] {
                    let inside = boxes.iter().any(|b| b.contains(&Rect::at((x as i32, y as i32), (1, 1))));
                    assert!(inside, "{px} px: ink at ({x}, {y}) outside {boxes:?}");
                }
            }
        }
    }

    #[test]
    fn the_checker_reports_what_is_wrong() {
        let tb = |kind, text: &str, rect| TextBox { kind, panel: 0, text: text.into(), rect };
        let good = Layout {
            size: (640, 360),
            texts: vec![
                tb(TextKind::Title, "t", Rect::at((10, 5), (200, 20))),
                tb(TextKind::XTick, "100", Rect::at((100, 300), (30, 12))),
                tb(TextKind::XTick, "200", Rect::at((140, 300), (30, 12))),
            ],
            legend: Some(Rect::at((500, 50), (100, 40))),
            points: vec![Rect::at((300, 200), (9, 9))],
        };
        assert!(good.problems().is_empty(), "{:?}", good.problems());
        let mut past_edge = good.clone();
        past_edge.texts[0].rect = Rect::at((500, 5), (200, 20));
        let p = past_edge.problems();
        assert!(p.len() == 1 && p[0].contains("leaves the 640x360 image"), "{p:?}");
        let mut ticks = good.clone();
        ticks.texts[2].rect = Rect::at((120, 300), (30, 12));
        let p = ticks.problems();
        assert!(p.len() == 1 && p[0].contains("XTick labels '100' and '200' overlap"), "{p:?}");
        let mut titles = good.clone();
        titles.texts.push(tb(TextKind::Title, "second line", Rect::at((10, 15), (200, 20))));
        assert_eq!(titles.problems().len(), 1);
        let mut covered = good.clone();
        covered.points.push(Rect::at((510, 60), (9, 9)));
        let p = covered.problems();
        assert!(p.len() == 1 && p[0].contains("under the legend"), "{p:?}");
        let mut label = good;
        label.texts.push(tb(TextKind::PointLabel, "T=0.1", Rect::at((590, 80), (40, 12))));
        assert_eq!(label.problems().len(), 1);
    }

    const SIZES: [(u32, u32); 3] = [(640, 360), (1280, 800), (1920, 1080)];

    fn lights_chart() -> LineChart {
        let xs: Vec<f64> = (1..=10).map(|i| f64::from(i) * 100.0).collect();
        let series = |name: &str, f: &dyn Fn(f64) -> f64| Series {
            name: name.into(),
            points: xs.iter().map(|&x| (x, f(x))).collect(),
            incomplete: Vec::new(),
        };
        let mut a = series("Tiled Deferred", &|x| 0.4 + x * 0.002);
        a.incomplete.push(*a.points.last().unwrap());
        LineChart {
            title: "Frame time vs lights: NVIDIA GeForce RTX 4090 Laptop GPU, 1920x1080".into(),
            subtitle: "sponza-with-a-long-name, 262,267 triangles, grid=clustered, tile=16, depth-slices=24, \
                       bounds=aabb, stage-lights=on, shadows=off; per pass the median of 120 frames after 30 warm-up \
                       frames, lights moving, uniform random point lights"
                .into(),
            x: AxisSpec { label: "lights".into(), scale: Scale::Log, ticks: Some(xs.clone()) },
            y: AxisSpec { label: "GPU frame time, ms (sum of pass medians)".into(), scale: Scale::Linear, ticks: None },
            series: vec![a, series("Visibility Buffer", &|x| 0.9 + x * 0.0008)],
            marker: Some((417.0, "crossover ~417".into())),
            note: Some(
                "crossover ~417 lights: Tiled Deferred faster below, Visibility Buffer above; 1 point ringed red: \
                 frames DROPPED lights"
                    .into(),
            ),
            categories: None,
        }
    }

    const CATEGORIES: [&str; 3] = ["tiled", "clustered", "clustered with bounding boxes per froxel"];

    fn grid_chart() -> LineChart {
        LineChart {
            title: "Frame time vs grid: NVIDIA H100 80GB HBM3, 1920x1080".into(),
            subtitle: "courtyard, 1,024 lights".into(),
            x: AxisSpec { label: "grid".into(), scale: Scale::Linear, ticks: None },
            y: AxisSpec { label: "GPU frame time, ms (sum of pass medians)".into(), scale: Scale::Linear, ticks: None },
            series: vec![
                Series { name: "tile=16".into(), points: vec![(0.0, 2.0), (1.0, 2.0), (2.0, 2.0)], incomplete: vec![] },
                Series { name: "tile=32".into(), points: vec![(0.0, 1.0), (1.0, 3.0), (2.0, 2.5)], incomplete: vec![] },
            ],
            marker: None,
            note: None,
            categories: Some(CATEGORIES.iter().map(|s| s.to_string()).collect()),
        }
    }

    fn accuracy_chart() -> ParetoChart {
        let mut points = Vec::new();
        for (s, scale) in [("aabb, 16 px tiles", 1.0), ("sphere, 32 px tiles", 1.3)] {
            for (k, t) in [0.2, 0.1, 0.05, 0.02, 0.01, 0.005].iter().enumerate() {
                points.push(ParetoPoint {
                    series: s.into(),
                    label: format!("T={t}"),
                    time: (1.0 + k as f64 * 0.35) * scale,
                    error: t * 0.4 / scale,
                    incomplete: k == 5 && scale > 1.0,
                });
            }
        }
        ParetoChart {
            title: "Speed vs accuracy: NVIDIA GeForce RTX 4090 Laptop GPU, 1920x1080".into(),
            subtitle: "courtyard, 4,096 lights, visibility buffer, grid=clustered, depth-slices=24, stage-lights=on; \
                       error vs the reference (brute force, same frame); labels: threshold T (the light's cutoff as a \
                       share of its peak)"
                .into(),
            x_label: "GPU frame time, ms (sum of pass medians)".into(),
            y_label: "FLIP mean (tonemapped, vs reference)".into(),
            points,
            target: Some((0.01, "target: FLIP mean 0.01".into())),
            chosen: Some(3),
            note: Some(
                "recommended: aabb, 16 px tiles, T=0.02 (1.7 ms, FLIP 0.008): the fastest under the target; 1 setting \
                 ringed red: frames DROPPED lights"
                    .into(),
            ),
            references: vec![(3.1, "reference: 3.1 ms".into())],
        }
    }

    fn culling_chart() -> BarPanels {
        BarPanels {
            title: "Culling statistics per setting: NVIDIA GeForce RTX 4090 Laptop GPU, 1920x1080".into(),
            subtitle: "courtyard, 4,096 lights, visibility buffer".into(),
            note: Some(
                "fewest false positives: grid=clustered, bounds=aabb; fastest: grid=tiled, bounds=sphere".into(),
            ),
            settings: vec![
                "grid=tiled, bounds=sphere, tile=16".into(),
                "grid=clustered, bounds=aabb, tile=16, depth-slices=24".into(),
                "grid=clustered, bounds=sphere, tile=32, depth-slices=32".into(),
            ],
            panels: vec![
                ("false positives per pixel".into(), vec![3.2, 0.9, 1.4]),
                ("wasted evaluations, share".into(), vec![0.61, 0.22, f64::NAN]),
                ("longest light list".into(), vec![412.0, 96.0, 180.0]),
                ("GPU frame time, ms".into(), vec![1.92, 2.05, 1.88]),
            ],
        }
    }

    /// Names cut short at their end where that tells them apart, in the middle where their
    /// ends differ, numbered where neither does; equal names stay equal.
    #[test]
    fn cut_names_stay_apart() {
        register_font().unwrap();
        let px = 16.0;
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let w = width("grid=clustered, bo…", px);
        let tail = elide_distinct(&names(&["grid=clustered, bounds=aabb", "grid=clustered, bounds=sphere"]), px, w);
        // Cut in the middle: their differing ends are kept (not numbered).
        assert!(tail[0].ends_with("aabb") && tail[1].ends_with("sphere"), "{tail:?}");
        assert!(tail.iter().all(|s| s.starts_with("grid=") && s.contains('…') && width(s, px) <= w), "{tail:?}");
        let plain = elide_distinct(&names(&["alpha=1, rest", "beta=2, rest"]), px, w);
        assert!(plain[0].starts_with("alpha") && plain[1].starts_with("beta"), "{plain:?}");
        let same_ends =
            elide_distinct(&names(&["a, x, middle-one, z", "a, x, middle-two, z"]), px, width("a, x…z", px));
        assert_ne!(same_ends[0], same_ends[1], "{same_ends:?}");
        assert_eq!(elide_distinct(&names(&["same", "same"]), px, 1000), ["same", "same"]);
    }

    /// Every kind of chart at every size: the image has the size, and no text leaves it or
    /// overlaps another, no tick labels run together, the legend covers no point.
    #[test]
    fn every_chart_fits_at_every_size() {
        let (dir, keep) = chart_dir("sizes");
        for size in SIZES {
            let name = |kind: &str| dir.join(format!("{kind}-{}x{}.png", size.0, size.1));
            let charts: Vec<(&str, Layout)> = vec![
                ("lights", line_chart_sized(&name("lights"), &lights_chart(), size).unwrap()),
                ("grid", line_chart_sized(&name("grid"), &grid_chart(), size).unwrap()),
                ("accuracy", pareto_chart_sized(&name("accuracy"), &accuracy_chart(), size).unwrap()),
                ("culling", bar_panels_sized(&name("culling"), &culling_chart(), size).unwrap()),
            ];
            for (kind, layout) in charts {
                let img = image::open(name(kind)).unwrap();
                assert_eq!((img.width(), img.height()), size, "{kind}");
                assert_eq!(layout.size, size);
                assert!(layout.problems().is_empty(), "{kind} at {size:?}: {:#?}", layout.problems());
                assert!(layout.texts_of(TextKind::XTick).count() >= 2, "{kind} at {size:?}: x labels");
                if kind != "culling" {
                    assert!(layout.legend.is_some(), "{kind}: no legend");
                } else {
                    // Cut to fit, the settings' names still tell the bars apart.
                    for panel in 0..4 {
                        let names: Vec<&str> = layout
                            .texts_of(TextKind::YTick)
                            .filter(|t| t.panel == panel)
                            .map(|t| t.text.as_str())
                            .collect();
                        let mut unique = names.clone();
                        unique.sort_unstable();
                        unique.dedup();
                        assert_eq!(unique.len(), 3, "culling at {size:?}, panel {panel}: names {names:?}");
                    }
                }
            }
        }
        // The smallest size draws too (crowded: not checked).
        let name = |kind: &str| dir.join(format!("{kind}-min.png"));
        line_chart_sized(&name("lights"), &lights_chart(), MIN_SIZE).unwrap();
        line_chart_sized(&name("grid"), &grid_chart(), MIN_SIZE).unwrap();
        pareto_chart_sized(&name("accuracy"), &accuracy_chart(), MIN_SIZE).unwrap();
        bar_panels_sized(&name("culling"), &culling_chart(), MIN_SIZE).unwrap();
        if !keep {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    /// The sweep over lights 100..1,000 whose every value was a tick printed "9001,000":
    /// thinned, the ends and the plainest values stay.
    #[test]
    fn dense_ticks_are_thinned() {
        let (dir, keep) = chart_dir("dense");
        let layout = line_chart_sized(&dir.join("lights.png"), &lights_chart(), (640, 360)).unwrap();
        let labels: Vec<&str> = layout.texts_of(TextKind::XTick).map(|t| t.text.as_str()).collect();
        assert!(labels.len() >= 3 && labels.len() < 10, "{labels:?}");
        assert_eq!((labels[0], *labels.last().unwrap()), ("100", "1,000"));
        assert!(labels.contains(&"500") || labels.contains(&"200"), "{labels:?}");
        let big = line_chart_sized(&dir.join("lights-big.png"), &lights_chart(), (1920, 1080)).unwrap();
        assert!(big.texts_of(TextKind::XTick).count() > labels.len());
        if !keep {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    /// A category axis is labelled with the names, once each, and its points are not
    /// joined: no pixel of the series' colour between two categories at one height.
    #[test]
    fn a_category_axis_has_its_names_and_no_lines() {
        let (dir, keep) = chart_dir("categories");
        let c = grid_chart();
        let path = dir.join("grid.png");
        let layout = line_chart_sized(&path, &c, (1280, 800)).unwrap();
        let labels: Vec<&str> = layout.texts_of(TextKind::XTick).map(|t| t.text.as_str()).collect();
        assert_eq!(labels, CATEGORIES);
        // Series 0 is flat: its first two points share a height.
        let between = |path: &Path, layout: &Layout| {
            let img = image::open(path).unwrap().to_rgb8();
            let (a, b) = (layout.points[0], layout.points[1]);
            let y = (a.y0 + a.y1) / 2;
            assert_eq!(y, (b.y0 + b.y1) / 2);
            let col = color(0);
            (a.x1 + 2..b.x0 - 2).filter(|&x| img.get_pixel(x as u32, y as u32).0 == [col.0, col.1, col.2]).count()
        };
        assert_eq!(between(&path, &layout), 0, "a line joins the categories");
        // The same points on a numeric axis are joined: the count sees a line.
        let numeric = LineChart { categories: None, ..c };
        let joined = line_chart_sized(&dir.join("numeric.png"), &numeric, (1280, 800)).unwrap();
        assert!(between(&dir.join("numeric.png"), &joined) > 50);
        if !keep {
            let _ = std::fs::remove_dir_all(&dir);
        }
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
        assert!(line_chart_sized(&path, &c, (100, 50)).is_err());
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
