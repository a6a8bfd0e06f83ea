//! `tiledlight accuracy`: the speed/accuracy trade, measured. For every setting (the
//! product of the `--axis` values; by default the intensity threshold, i.e. the light
//! radius dial, times the culling test) it records the GPU time of each pass and the error
//! of the image against the brute-force reference (every light for every pixel, plain
//! inverse-square with no radius cutoff, the same frame): PSNR on linear HDR, FLIP mean,
//! 99th percentile and maximum after tonemapping, the largest HDR error and the energy
//! lost; and the culling statistics: mean/max lights per tile (the GPU's counts), the
//! false-positive rate and wasted light evaluations per pixel (the CPU reference culler's
//! lists for the GPU's depth buffer, `tiledlight_cull::reference::list_quality`).
//!
//! Alpha-blended geometry (`--transparent-objects`, glTF BLEND materials) is drawn by the
//! reference too, always sorted back to front: the error of `blend-mode=wboit` is the
//! weighted blended OIT's approximation plus the method's, measured against exact "over".
//! The error that dropping the sort alone costs is measured too: every setting with
//! blended geometry and `blend-mode=wboit` is also compared with the sorted frame of the
//! same settings (same method, cutoff, lights, screen), side by side with its time
//! (columns `sorted_ms`, `vs_sorted_flip_mean`, `vs_sorted_flip_p99`; empty otherwise).
//! That frame is the run's own `blend-mode=sorted` point when the run has it, else it is
//! rendered and timed alike.
//!
//! Output: a resumable CSV (one row per setting), a Pareto chart (time vs FLIP mean, the
//! frontier drawn, the fastest setting under the target error ringed) and FLIP heat maps
//! of the frontier's settings.
//!
//! The error split by cause (`--budget --reference traced`): every setting is also
//! compared through two more images of the same frame, each rendered once per key and
//! compared with the truth: *the truth with the cutoff* (`traced-reference-cutoff` at the
//! setting's threshold: every light shadowed by its ray, the windowed falloff) measures the
//! cutoff's share (`cutoff_flip_mean`), and *the truth without shadow rays* (brute force,
//! no cutoff, no casters) the error of leaving every light unshadowed
//! (`unshadowed_flip_mean`; not measured with VPLs, whose RSMs need the casters). The
//! setting against the truth with its cutoff (`beyond_cutoff_flip_mean`) is what its
//! shadows (unshadowed lights, shadow maps) and its method add to the cutoff. FLIP is not
//! additive: each number is its own comparison. `--diff-dir` gets each one's heat map
//! beside the setting's.
//!
//! A setting whose frames dropped lights (a light grid full, [`crate::dropped`]) gets a
//! `warning:` line, the columns `dropped_frames`, `dropped_lights`, `dropped_lists` (over
//! its measured frames read back; `overflowing_lists` is the compared frame's) and a red
//! ring on the chart; `--strict` fails once the CSV and the chart are written. The column
//! `load_warnings` holds the scene's load warnings (a missing texture...), `vpls_refused`
//! the VPLs the cap refused (with a `warning:` line). A lost device
//! (or out of GPU memory) ends the run naming it; the settings measured so far stay in the
//! CSV and the same command resumes after them.
//!
//! May depend on [`crate::axes`], [`crate::bench`], [`crate::chart`], [`crate::dropped`],
//! [`crate::output`], tiledlight-setup, tiledlight-cull and tiledlight-metrics.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use tiledlight_frame::Diagnostics as _;
use tiledlight_gpu::features::BlendMode;
use tiledlight_gpu::knobs::Knobs;

use anyhow::{bail, ensure, Context, Result};
use tiledlight_cull::reference::{cull_tiles, list_quality, ListQuality};
use tiledlight_metrics::{flip, HdrError};
use tiledlight_scene::trace::TraceGeometry;
use tiledlight_setup::{group_digits, rebuild_plan, Method, Prepared, Reload, Settings};

use crate::axes::{self, Axis, Flags, ResumableCsv};
use crate::bench::{self, MAX_FRAMES};
use crate::chart::{self, ParetoChart, ParetoPoint};
use crate::dropped;
use crate::reference_cache::{hash_parts, shader_fingerprint, CachedReference, ReferenceCache};
use crate::worst;

/// The settings measured when no `--axis` is given: thirteen thresholds, about halving
/// (radii from 0.5x to 32x the default 0.1's; at 1e-4 every light of the default scene
/// reaches every pixel), times three culling tests.
pub const DEFAULT_AXES: [&str; 2] = [
    "threshold=0.4,0.2,0.1,0.05,0.025,0.0125,0.00625,0.003,0.0015,0.0008,0.0004,0.0002,0.0001",
    "culling=planes,aabb,half-z",
];

/// The FLIP means whose cheapest setting every run prints (issue 30: an error budget).
pub const CHEAPEST_WITHIN: [f64; 3] = [0.01, 0.02, 0.05];

/// The FLIP percentile recorded besides the mean.
pub const PERCENTILE: f32 = 0.99;

/// An accuracy run (the app's `accuracy` flags besides the scene's).
#[derive(Clone, Debug)]
pub struct Accuracy {
    /// Axes, `NAME=VALUES` each; they replace [`DEFAULT_AXES`] of the same name.
    pub axes: Vec<String>,
    /// Measured frames per setting.
    pub frames: u32,
    /// Frames rendered before measuring each setting.
    pub warmup: u32,
    /// Measured frames of the brute-force reference.
    pub reference_frames: u32,
    /// Degrees a frame the camera orbits the scene's vertical axis through the measured
    /// frames, ending at the view the reference shows (0: a still camera).
    pub camera_orbit: f32,
    /// A directory of references kept on disk ([`crate::reference_cache`]): each one is
    /// read from there if an earlier run rendered it, else rendered and stored.
    pub reference_cache: Option<PathBuf>,
    /// The reference's radius cutoff.
    pub reference: ReferenceKind,
    /// With VPLs, the RSM size of the reference.
    pub vpl_reference_rsm: VplReference,
    /// The FLIP mean the recommendation must stay under.
    pub target_flip: f64,
    /// The error budget: change one axis at a time from the base (every axis's first
    /// value) instead of the cross product, and chart one curve per axis (dial). Only the
    /// given axes: the defaults ([`DEFAULT_AXES`]) are not added, so the flags' own
    /// threshold and culling are the base's unless an axis says otherwise.
    pub budget: bool,
    /// CSV output [default: out/accuracy.csv].
    pub out: Option<PathBuf>,
    /// Pareto chart [default: the CSV path with .png].
    pub chart: Option<PathBuf>,
    /// Directory of the FLIP heat maps [default: the CSV path without extension + "-flip"].
    pub diff_dir: Option<PathBuf>,
}

/// The RSM size of the VPL reference (`--vpl-reference-rsm`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VplReference {
    /// N times the setting's RSM size, at most the largest.
    Scale(u32),
    /// This size for every setting.
    Size(u32),
}

impl VplReference {
    /// The reference's RSM size for a setting's `rsm_size`.
    fn rsm_size(self, rsm_size: u32) -> u32 {
        let largest = *tiledlight_cull::vpl::RSM_SIZES.end();
        match self {
            VplReference::Scale(k) => rsm_size.saturating_mul(k).min(largest),
            VplReference::Size(n) => n,
        }
    }
}

/// Parses `--vpl-reference-rsm`: "4x" or "128".
pub fn parse_vpl_reference(v: &str) -> Result<VplReference, String> {
    let sizes = tiledlight_cull::vpl::RSM_SIZES;
    match v.strip_suffix('x') {
        Some(k) => match k.parse() {
            Ok(k @ (1 | 2 | 4 | 8)) => Ok(VplReference::Scale(k)),
            _ => Err(format!("{v}: use 1x, 2x, 4x or 8x, or an RSM size")),
        },
        None => match v.parse() {
            Ok(n) if sizes.contains(&n) => Ok(VplReference::Size(n)),
            _ => Err(format!("{v}: use an RSM size {}..={}, or 1x, 2x, 4x or 8x", sizes.start(), sizes.end())),
        },
    }
}

/// What the settings are compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceKind {
    /// Brute force without the radius cutoff.
    NoCutoff,
    /// Brute force with the same radius cutoff as the setting.
    Cutoff,
    /// The traced reference (`--method traced-reference`): every light, no cutoff, a
    /// shadow ray each, so unshadowed lights and shadow maps are measured against the light
    /// that really arrives.
    Traced,
}

/// The CSV columns before the axes'.
pub(crate) const HEAD: [&str; 4] = ["adapter", "width", "height", "measured"];

/// The `measured` column: how every point of the run was measured (frames, camera
/// motion, reference), which a resumed CSV must share.
fn measured(args: &Accuracy) -> String {
    let motion = match args.camera_orbit {
        0.0 => "a still camera".to_string(),
        d => format!("the camera orbiting {d} degrees a frame"),
    };
    format!(
        "{} frames after {} warm-up, {motion}, against {}",
        args.frames,
        args.warmup,
        reference_kind(args.reference)
    )
}
const TAIL: [&str; 37] = [
    "total_ms",
    "passes",
    "frame_min_ms",
    "frame_max_ms",
    "psnr_db",
    "flip_mean",
    "flip_p99",
    "flip_max",
    "max_error",
    "energy_lost",
    "mean_lights_per_tile",
    "max_lights_per_tile",
    "overflowing_lists",
    "dropped_frames",
    "dropped_lights",
    "dropped_lists",
    dropped::LOAD_WARNINGS_COLUMN,
    dropped::VPLS_REFUSED_COLUMN,
    "false_positive_rate",
    "wasted_per_pixel",
    "evaluated_per_pixel",
    "reference_ms",
    "reference_passes",
    "lights",
    "edge_pixels",
    "sorted_ms",
    "vs_sorted_flip_mean",
    "vs_sorted_flip_p99",
    worst::COLUMNS[0],
    worst::COLUMNS[1],
    worst::COLUMNS[2],
    worst::COLUMNS[3],
    worst::COLUMNS[4],
    "cutoff_flip_mean",
    "unshadowed_flip_mean",
    "beyond_cutoff_flip_mean",
    "flicker_flip_mean",
];

/// The CSV header of a run over `axes`.
pub fn header(axes: &[Axis]) -> Vec<String> {
    HEAD.iter()
        .map(|s| s.to_string())
        .chain(axes.iter().map(|a| a.name.clone()))
        .chain(TAIL.iter().map(|s| s.to_string()))
        .collect()
}

/// The reference image of one scene, light set and screen, as the cache keeps it: every
/// setting compared with it is tonemapped with its exposure.
type Reference = CachedReference;

/// What identifies a reference image: everything but the settings it is compared over
/// (threshold, tests, tile size, method), which do not change it. The reference draws
/// the setting's shadows (casters, tile size, filter, format): the error is the method's,
/// not the shadow map's, which the shadow axes' times are measured against. It draws the
/// setting's transparent objects, always sorted (so the blend mode is not part of the key).
fn reference_key(a: &Settings, reference: ReferenceKind, vpl_ref: VplReference) -> String {
    // With the cutoff the radii, so the threshold, shape the reference too; lights on
    // surfaces take their radius from k and their intensity from the threshold, so both
    // always shape it.
    // A loaded scene's random lights have radii fitted to it and intensities from the
    // threshold, wherever they are placed.
    let fitted = matches!(a.scene, tiledlight_setup::SceneSource::File(_));
    let threshold = if reference == ReferenceKind::Cutoff || a.placement.on_surfaces() || fitted {
        format!("{}|{:?}|", a.threshold, a.placement)
    } else {
        String::new()
    };
    // The traced reference draws no shadow map (its rays are the shadows) unless VPLs need
    // the casters' reflective shadow maps: then the casters and how they are chosen shape
    // it; the brute-force references draw the setting's shadows.
    let casters_shape_it = a.has_shadows() && (reference != ReferenceKind::Traced || a.vpl.is_some());
    let shadows = if casters_shape_it {
        format!("{:?}|{:?}|{:?}", a.shadow_casters(), a.casters_by, a.shadow_options())
    } else {
        String::new()
    };
    let shadows = shadows + &reference_vpl(a, vpl_ref).map(|v| format!("|vpl {v:?}")).unwrap_or_default();
    // The camera: a bookmark axis (the tuner's --bookmarks) changes the truth.
    let shadows = shadows + &a.camera.as_ref().map(|c| format!("|camera {:?}", c.camera)).unwrap_or_default();
    threshold
        + &format!(
            "{}|{}|{}|{}|{:?}|{:?}|{:?}|{}|{}x{}|{}|{}|{shadows}",
            a.scene,
            a.grid_objects,
            a.transparent_objects,
            a.emissive,
            a.density,
            a.lights,
            a.spot_lights,
            a.seed,
            a.width,
            a.height,
            a.exposure,
            a.msaa
        )
}

/// The sorted frame a weighted-blended-OIT setting is compared with.
struct SortedFrame {
    ldr: Vec<u8>,
    total_ms: f64,
}

/// The setting `a` with its blended layer sorted.
fn sorted(a: &Settings) -> Settings {
    Settings { knobs: Knobs { blend_mode: BlendMode::Sorted, ..a.knobs }, ..a.clone() }
}

/// What identifies the sorted frame of a setting: every setting, the blend mode sorted
/// (the frame differs from the setting's own by the sort alone).
fn sorted_key(a: &Settings) -> String {
    format!("{:?}", sorted(a))
}

/// Renders and times the setting `a` with the blended layer sorted, as the setting itself
/// was measured (`warmup`, `frames`).
fn render_sorted(prep: &mut Prepared, a: &Settings, warmup: u32, frames: u32) -> Result<SortedFrame> {
    prep.reconfigure(&sorted(a))?;
    let mut r = prep.renderer(false)?;
    let m = bench::measure(prep, &mut r, warmup, frames).context("rendering the sorted frame")?;
    let (total_ms, _) = pass_times(&m)?;
    let ldr = r.read_ldr(&prep.ctx).context("reading the sorted frame back")?;
    prep.check_gpu_errors()?;
    Ok(SortedFrame { ldr, total_ms })
}

/// One image of the error split, rendered once per key ([`split_images`]) and compared with
/// the truth.
struct SplitFrame {
    ldr: Vec<u8>,
    /// FLIP mean against the truth.
    flip_mean: f64,
    /// Its FLIP heat map against the truth (RGB).
    heat: Vec<u8>,
}

/// Something per measured point (its axis values).
type ByPoint<T> = HashMap<Vec<String>, T>;

/// A setting's error split by cause (see the module doc).
pub(crate) struct ErrorSplit {
    /// The truth with the setting's cutoff.
    cutoff: Rc<SplitFrame>,
    /// The truth without shadow rays (None with VPLs).
    unshadowed: Option<Rc<SplitFrame>>,
    /// The setting against the truth with its cutoff: FLIP mean and heat map.
    beyond: (f64, Vec<u8>),
}

impl ErrorSplit {
    /// The split's CSV cells, in [`TAIL`]'s order.
    fn csv(&self) -> [String; 3] {
        [
            f(self.cutoff.flip_mean, 6),
            self.unshadowed.as_ref().map_or(String::new(), |u| f(u.flip_mean, 6)),
            f(self.beyond.0, 6),
        ]
    }

    /// The report's line under the setting.
    fn line(&self) -> String {
        let unshadowed =
            self.unshadowed.as_ref().map_or("not measured (VPLs)".to_string(), |u| format!("{:.5}", u.flip_mean));
        format!(
            "error by cause (FLIP mean vs the truth): the cutoff alone {:.5}; every light unshadowed {unshadowed}; \
             this setting vs the truth with its cutoff {:.5}",
            self.cutoff.flip_mean, self.beyond.0
        )
    }
}

/// The split's two images of setting `a` (already at the truth's exposure), each with what
/// identifies it: the traced reference with the cutoff (the truth's key, with the threshold
/// and the lights' placement), and brute force without cutoff or casters (its own key;
/// None with VPLs: their RSMs need the casters). Blended geometry sorted as in the truth.
fn split_images(a: &Settings, vpl_ref: VplReference) -> ((String, Settings), Option<(String, Settings)>) {
    let cutoff =
        Settings { method: Method::TracedReference { cutoff: true }, vpl: reference_vpl(a, vpl_ref), ..sorted(a) };
    let truth = reference_key(a, ReferenceKind::Traced, vpl_ref);
    let unshadowed = a.vpl.is_none().then(|| {
        let u = Settings {
            method: Method::BruteForce { cutoff: false },
            shadow_point_lights: 0,
            shadow_spot_lights: 0,
            ..sorted(a)
        };
        (format!("unshadowed|{}", reference_key(&u, ReferenceKind::NoCutoff, vpl_ref)), u)
    });
    ((format!("cutoff|{}|{:?}|{truth}", a.threshold, a.placement), cutoff), unshadowed)
}

/// Renders one frame of `settings` and compares it with the truth's `truth_ldr`.
fn render_split(prep: &mut Prepared, settings: &Settings, truth_ldr: &[u8]) -> Result<SplitFrame> {
    prep.reconfigure(settings)?;
    let mut r = prep.renderer(false)?;
    bench::measure(prep, &mut r, 0, 1)?;
    let ldr = r.read_ldr(&prep.ctx).context("reading the image back")?;
    prep.check_gpu_errors()?;
    let map = flip(settings.width, settings.height, truth_ldr, &ldr);
    Ok(SplitFrame { flip_mean: f64::from(map.summary(PERCENTILE).mean), heat: map.heat_rgb(), ldr })
}

/// The error split of setting `a` whose image is `ldr` ([`ErrorSplit`]): its two images
/// from `cache` or rendered (once per key).
fn error_split(
    prep: &mut Prepared,
    (a, ldr, truth_ldr): (&Settings, &[u8], &[u8]),
    vpl_ref: VplReference,
    cache: &mut HashMap<String, Rc<SplitFrame>>,
) -> Result<ErrorSplit> {
    let ((cutoff_key, cutoff_settings), unshadowed) = split_images(a, vpl_ref);
    let mut get = |key: String, s: &Settings, what: &str| -> Result<Rc<SplitFrame>> {
        if let Some(f) = cache.get(&key) {
            return Ok(f.clone());
        }
        let f = Rc::new(render_split(prep, s, truth_ldr).with_context(|| format!("rendering {what}"))?);
        cache.insert(key, f.clone());
        Ok(f)
    };
    let cutoff = get(cutoff_key, &cutoff_settings, "the truth with the cutoff")?;
    let unshadowed = match unshadowed {
        Some((k, s)) => Some(get(k, &s, "the truth without shadow rays")?),
        None => None,
    };
    let map = flip(a.width, a.height, &cutoff.ldr, ldr);
    Ok(ErrorSplit { beyond: (f64::from(map.summary(PERCENTILE).mean), map.heat_rgb()), cutoff, unshadowed })
}

/// The fastest and slowest measured frame (the sum of its timed passes): the spread of the
/// median `total_ms` sums.
fn frame_spread(m: &bench::Measurement) -> (f64, f64) {
    let totals = m.gpu_frames.iter().map(|f| f.iter().map(|p| p.ms).sum::<f64>());
    totals.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)))
}

/// "depth_prepass=0.592;forward.cull=0.043" and their sum.
fn pass_times(m: &bench::Measurement) -> Result<(f64, String)> {
    ensure!(m.timestamps, "the adapter has no timestamp queries: the accuracy lab needs GPU pass times");
    let passes = m.passes();
    ensure!(!passes.is_empty(), "no frame's timestamps came back");
    let total = passes.iter().map(|p| p.summary.median_ms).sum();
    let text = passes.iter().map(|p| format!("{}={:.4}", p.pass, p.summary.median_ms)).collect::<Vec<_>>().join(";");
    Ok((total, text))
}

/// The VPLs of the reference of a setting with VPLs: one bounce from every texel of the
/// The chart subtitle's setting: the scene, the lights, the base method unless an axis
/// names the method (its values are the points', or its one value is among the fixed
/// axes), then every axis of one value as `name=value`.
fn setting_phrase(scene: &str, lights: &str, method: Method, axes: &[Axis]) -> String {
    let mut parts = vec![scene.to_string(), format!("{lights} lights")];
    if !axes.iter().any(|a| a.name == "method") {
        parts.push(method.name().to_string());
    }
    parts.extend(axes.iter().filter(|a| a.values.len() == 1).map(|a| format!("{}={}", a.name, a.values[0])));
    parts.join(", ")
}

/// The Pareto chart's subtitle's end when its points are labelled by threshold.
const THRESHOLD_LABELS: &str = "; labels: intensity threshold T";

/// How the reference treats the lights' radii, as the output and the chart say it.
fn reference_kind(r: ReferenceKind) -> &'static str {
    match r {
        ReferenceKind::NoCutoff => "brute force, no cutoff",
        ReferenceKind::Cutoff => "brute force, same cutoff",
        ReferenceKind::Traced => "traced (no cutoff, a shadow ray per light)",
    }
}

/// The VPLs of the reference of a setting with VPLs: one bounce from every texel of the
/// setting's reflective shadow maps, or of ones of another size (`vpl_ref`,
/// `--vpl-reference-rsm`: N times the setting's, at most 512, or one size), block 1, no
/// thresholds, a cap above the texels, shaded by the physical model, which the brute-force
/// reference sums with no cutoff. The setting's own block, thresholds, cap, model and
/// (tiled methods) culling are what its error measures, and with a finer reference its RSM size
/// too (a texel's flux is its solid angle's share, so finer RSMs converge to the same
/// light). None without VPLs.
fn reference_vpl(a: &Settings, vpl_ref: VplReference) -> Option<tiledlight_cull::vpl::VplConfig> {
    a.vpl.map(|v| {
        let (points, spots) = a.shadow_casters();
        let rsm_size = vpl_ref.rsm_size(v.rsm_size);
        let texels = (6 * u64::from(points) + u64::from(spots)) * u64::from(rsm_size).pow(2);
        tiledlight_cull::vpl::VplConfig {
            rsm_size,
            block: 1,
            colour_threshold: 0.0,
            brightness_threshold: 0.0,
            cap: texels.clamp(1, u64::from(tiledlight_cull::vpl::MAX_CAP)) as u32,
            shading: tiledlight_cull::vpl::VplShading::Physical,
            ..v
        }
    })
}

/// Renders the reference of `point_args`, or reads it from `cache` (then the second value
/// is the file it came from); a rendered one is stored there.
fn render_reference(
    prep: &mut Prepared,
    point_args: &Settings,
    (reference, vpl_ref): (ReferenceKind, VplReference),
    frames: u32,
    cache: Option<&ReferenceCache>,
) -> Result<(Reference, Option<PathBuf>)> {
    let method = match reference {
        ReferenceKind::NoCutoff => Method::BruteForce { cutoff: false },
        ReferenceKind::Cutoff => Method::BruteForce { cutoff: true },
        ReferenceKind::Traced => Method::TRUTH,
    };
    // Blended geometry in the reference is exact "over" (sorted back to front), whatever
    // the setting's blend mode.
    let settings = Settings { method, vpl: reference_vpl(point_args, vpl_ref), ..sorted(point_args) };
    prep.reconfigure(&settings)?;
    let disk_key = cache.map(|_| cache_key(prep, &reference_key(point_args, reference, vpl_ref), reference));
    if let (Some(c), Some(key)) = (cache, &disk_key) {
        if let Some(r) = c.load(key)? {
            return Ok((r, Some(c.path(key))));
        }
    }
    let mut r = prep.renderer(false)?;
    // No warm-up frame for the traced truth: a frame of seconds (minutes with a million
    // lights) needs no clocks brought up, and rendering it twice would double the wait.
    let warmup = u32::from(reference != ReferenceKind::Traced);
    let m = bench::measure(prep, &mut r, warmup, frames).context("rendering the brute-force reference")?;
    r.check_traced_complete(&prep.ctx).context("the reference")?;
    let (total_ms, passes) = pass_times(&m)?;
    let hdr = r.read_hdr(&prep.ctx).context("reading the reference back")?;
    let ldr = r.read_ldr(&prep.ctx).context("reading the reference back")?;
    let exposure = r.auto_exposure(&prep.ctx).context("reading the reference's exposure back")?;
    let (width, height) = (settings.width, settings.height);
    let reference = Reference { width, height, exposure, hdr, ldr, total_ms, passes };
    if let (Some(c), Some(key)) = (cache, &disk_key) {
        c.store(key, &reference)?;
    }
    Ok((reference, None))
}

/// The key a reference is kept on disk by ([`crate::reference_cache`], step 1), with the
/// reference's settings in `prep`: its in-memory key, its kind, the prepared scene's and
/// lights' description, the packed lights' hash and the shaders' fingerprint.
fn cache_key(prep: &Prepared, rkey: &str, kind: ReferenceKind) -> String {
    let described = prep.describe().into_iter().filter(|(k, _)| k == "scene" || k == "lights");
    let described: Vec<String> = described.map(|(k, v)| format!("{k}: {v}")).collect();
    let p = &prep.lights.packed;
    let lights = hash_parts([
        bytemuck::cast_slice::<_, u8>(&p.cull),
        bytemuck::cast_slice(&p.shading),
        bytemuck::cast_slice(&p.spots),
    ]);
    format!("{kind:?}|{rkey}|{}|lights {lights:016x}|shaders {:016x}", described.join("; "), shader_fingerprint())
}

/// What the reference of a setting with VPLs sums, for the lab's output: "VPLs: every
/// texel of 128x128 RSMs (4x the setting's 32), physical shading" (None without VPLs).
fn reference_vpl_line(a: &Settings, vpl_ref: VplReference) -> Option<String> {
    let (setting, reference) = (a.vpl?, reference_vpl(a, vpl_ref)?);
    let (n, own) = (reference.rsm_size, setting.rsm_size);
    let how = match vpl_ref {
        _ if n == own => "the setting's own".to_string(),
        VplReference::Scale(k) if n < own * k => format!("{k}x the setting's {own}, capped at {n}"),
        VplReference::Scale(k) => format!("{k}x the setting's {own}"),
        VplReference::Size(_) => format!("--vpl-reference-rsm {n}, for every setting"),
    };
    Some(format!("VPLs: every texel of {n}x{n} RSMs ({how}), physical shading"))
}

/// Culling quality of the frame just rendered: the CPU reference culler's lists for the
/// GPU's depth buffer (the GPU test suite checks they are the GPU's lists), scored pixel
/// by pixel. None for the untiled methods.
fn quality(prep: &Prepared, depth: &[f32]) -> Result<Option<ListQuality>> {
    if !prep.settings.method.is_tiled() {
        return Ok(None);
    }
    let a = &prep.settings;
    let config = a.cull_options().to_config(prep.lights.has_spots());
    let (cam, lights) = (&prep.camera, &prep.lights.packed);
    let lists = match &a.clusters {
        Some(c) => tiledlight_cull::cull_clusters(depth, a.width, a.height, cam, lights, c, a.msaa, 0.0),
        None => cull_tiles(depth, a.width, a.height, cam, lights, &config),
    }
    .context("culling on the CPU for the statistics")?;
    // With MSAA the lists bound every sample; pixels are scored at their sample 0.
    let pixels: Vec<f32> = depth.iter().step_by(a.msaa.max(1) as usize).copied().collect();
    Ok(Some(list_quality(&pixels, &prep.camera, &prep.lights.packed, &lists)))
}

fn f(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else if v > 0.0 {
        "inf".into()
    } else {
        "nan".into()
    }
}

/// Runs `tiledlight accuracy`.
pub fn run<F: Flags>(scene: &F, args: &Accuracy) -> Result<()> {
    check_frames(args)?;
    ensure!(
        args.target_flip.is_finite() && args.target_flip > 0.0 && args.target_flip <= 1.0,
        "--target-flip {}: must be in (0, 1]",
        args.target_flip
    );
    // The budget changes one dial at a time from the flags' own setting: the default
    // threshold and culling axes would replace the flags' --threshold with their first
    // value, so only the given axes count there.
    let defaults: Vec<Axis> = if args.budget {
        Vec::new()
    } else {
        DEFAULT_AXES.iter().map(|s| axes::parse_axis::<F>(s)).collect::<Result<_>>()?
    };
    let given: Vec<Axis> = args.axes.iter().map(|s| axes::parse_axis::<F>(s)).collect::<Result<_>>()?;
    let axes = axes::merge_axes(defaults, given);
    let points = if args.budget { axes::points_one_at_a_time(&axes)? } else { axes::points(&axes)? };
    let (points, unread) = axes::without_unread(scene, &axes, points)?;
    let all_args: Vec<Settings> =
        points.iter().map(|p| axes::args_at(scene, &axes, p).and_then(|a| a.settings())).collect::<Result<_>>()?;
    ensure!(
        all_args.iter().all(|a| a.method != Method::BruteForce { cutoff: false }),
        "method brute-force-no-cutoff is the reference itself: leave it out of the settings"
    );
    ensure!(
        args.reference != ReferenceKind::Traced || all_args.iter().all(|a| a.method != Method::TRUTH),
        "method traced-reference is the reference itself: leave it out of the settings"
    );
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from("out/accuracy.csv"));
    let chart_path = args.chart.clone().unwrap_or_else(|| axes::sibling(&out, "png"));
    let ext = chart_path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "--chart {}: only .png charts are supported", chart_path.display());
    let diff_dir = args.diff_dir.clone().unwrap_or_else(|| {
        let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("accuracy");
        out.with_file_name(format!("{stem}-flip"))
    });
    // Every output before the first frame: a bad path costs no rendering.
    crate::output::check_output("--out", &out)?;
    crate::output::check_output("--chart", &chart_path)?;
    crate::output::check_output_dir("--diff-dir", &diff_dir)?;

    let keep_sorted = all_args.iter().any(|a| a.knobs.blend_mode == BlendMode::WeightedOit);
    let mut session = Session::open(&out, &axes, keep_sorted, args)?;
    let pending = points.iter().filter(|p| !session.csv.is_done(p)).count();
    println!(
        "accuracy:   {} settings ({}), {} already in {}",
        points.len(),
        axes.iter().map(|a| format!("{} x{}", a.name, a.values.len())).collect::<Vec<_>>().join(", "),
        points.len() - pending,
        out.display()
    );
    if let Some(line) = axes::unread_line(unread) {
        println!("{line}");
    }
    if args.camera_orbit != 0.0 {
        println!(
            "camera:     orbiting {} degrees a frame through the {} measured frames, the last at the compared view",
            args.camera_orbit, args.frames
        );
    }
    session.measure(&axes, (&points, &all_args), args, &out)?;
    let csv = &session.csv;
    let heat = (&session.heat, &session.split);
    let warnings = session.warnings;
    let rows = csv.read_all()?;
    let base = (scene.scene_label(), scene.plain().method);
    let summary = report(&chart_path, &diff_dir, &axes, &rows, heat, (args, base))?;
    println!("{summary}");
    println!("wrote {} and {}", out.display(), chart_path.display());
    dropped::strict(all_args.iter().any(|a| a.strict), warnings)
}

/// The largest orbit a frame (`--camera-orbit`): beyond it consecutive frames share
/// little of their view.
pub const MAX_ORBIT_DEG: f32 = 45.0;

/// Checks the frame counts and the orbit of `args` (an error names the flag).
pub(crate) fn check_frames(args: &Accuracy) -> Result<()> {
    ensure!((1..=MAX_FRAMES).contains(&args.frames), "--frames {}: must be between 1 and {MAX_FRAMES}", args.frames);
    ensure!(args.warmup <= MAX_FRAMES, "--warmup {}: must be at most {MAX_FRAMES}", args.warmup);
    ensure!(
        args.camera_orbit.is_finite() && args.camera_orbit.abs() <= MAX_ORBIT_DEG,
        "--camera-orbit {}: must be a number of degrees between -{MAX_ORBIT_DEG} and {MAX_ORBIT_DEG}",
        args.camera_orbit
    );
    ensure!(
        (1..=MAX_FRAMES).contains(&args.reference_frames),
        "--reference-frames {}: must be between 1 and {MAX_FRAMES}",
        args.reference_frames
    );
    Ok(())
}

/// An accuracy run's state across the settings it measures: the GPU, the CSV, the
/// references and sorted frames rendered so far (each rendered once: the truth is reused
/// by every setting that shares its key), the FLIP heat maps, the warnings given. The
/// tuner ([`crate::tune`]) keeps one across its rounds.
pub(crate) struct Session {
    prep: Option<Prepared>,
    adapter: String,
    /// The resumable CSV of every setting measured.
    pub(crate) csv: ResumableCsv,
    references: HashMap<String, Reference>,
    sorted: HashMap<String, SortedFrame>,
    /// FLIP heat maps (RGB) by point.
    pub(crate) heat: ByPoint<Vec<u8>>,
    /// The error split's images by key, and each point's split (`--budget` against the truth).
    splits: HashMap<String, Rc<SplitFrame>>,
    split: ByPoint<ErrorSplit>,
    keep_sorted: bool,
    warned_scene: Option<tiledlight_setup::SceneSource>,
    geometry: Option<(Settings, TraceGeometry)>,
    /// Settings whose frames dropped work (`warning:` lines given).
    pub(crate) warnings: usize,
}

impl Session {
    /// Opens the CSV at `out` for `axes` (resuming what it holds). `keep_sorted`: keep the
    /// sorted frames of sorted points for WBOIT points to compare with.
    /// Rows measured another way than `args` says ([`measured`]) are refused here, before
    /// anything is measured or skipped.
    pub(crate) fn open(out: &Path, axes: &[Axis], keep_sorted: bool, args: &Accuracy) -> Result<Self> {
        let head = header(axes);
        let key: Vec<usize> = (HEAD.len()..HEAD.len() + axes.len()).collect();
        let csv = ResumableCsv::open(out, &head, &key, None)?;
        if let Some(r) = csv.existing.iter().find(|r| r[3] != measured(args)) {
            bail!(
                "{} holds points measured with {}, this run measures {}: choose another output file",
                out.display(),
                r[3],
                measured(args)
            );
        }
        Ok(Self {
            prep: None,
            adapter: String::new(),
            csv,
            references: HashMap::new(),
            sorted: HashMap::new(),
            heat: HashMap::new(),
            splits: HashMap::new(),
            split: HashMap::new(),
            keep_sorted,
            warned_scene: None,
            geometry: None,
            warnings: 0,
        })
    }

    /// Measures the `points` (with their settings) not yet in the CSV, with a progress bar;
    /// an error names the point and how far the run got (the CSV keeps what was measured).
    pub(crate) fn measure(
        &mut self,
        axes: &[Axis],
        (points, all_args): (&[axes::Point], &[Settings]),
        args: &Accuracy,
        out: &Path,
    ) -> Result<()> {
        let pending: Vec<usize> = (0..points.len()).filter(|&i| !self.csv.is_done(&points[i])).collect();
        let pb = axes::progress(pending.len());
        for (done, &i) in pending.iter().enumerate() {
            let (point, pargs) = (&points[i], &all_args[i]);
            let what = axes::describe(axes, point);
            pb.set_message(what.clone());
            match measure_setting(self, (point, pargs, &what), args, out, &pb) {
                Ok(Some(w)) => axes::warn(&pb, &mut self.warnings, &format!("{what}: {w}")),
                Ok(None) => {}
                Err(e) => {
                    pb.finish_and_clear();
                    let done = points.len() - pending.len() + done;
                    let progress = axes::Progress { point: &what, done, total: points.len(), csv: out };
                    return Err(axes::interrupted(e, self.prep.as_ref(), &progress));
                }
            }
            pb.inc(1);
        }
        pb.finish_and_clear();
        Ok(())
    }
}

/// Measures one setting and appends its row; returns the warning about its frames, if they
/// dropped lights.
fn measure_setting(
    st: &mut Session,
    (point, pargs, what): (&axes::Point, &Settings, &String),
    args: &Accuracy,
    out: &Path,
    pb: &indicatif::ProgressBar,
) -> Result<Option<String>> {
    let what = what.clone();
    let Session {
        prep,
        adapter,
        csv,
        references,
        sorted,
        heat,
        keep_sorted,
        warned_scene,
        geometry,
        splits,
        split,
        ..
    } = st;
    let keep_sorted = *keep_sorted;
    {
        let p = match prep.as_mut() {
            Some(p) => p,
            None => {
                let p = Prepared::new(pargs).with_context(|| what.clone())?;
                *adapter = p.ctx.info.name.clone();
                let size = [adapter.as_str(), &pargs.width.to_string(), &pargs.height.to_string()];
                axes::check_same_setup(&csv.existing, [0, 1, 2], size, out)?;
                axes::say(pb, format!("adapter:    {}", p.ctx.describe()));
                prep.insert(p)
            }
        };
        let rkey = reference_key(pargs, args.reference, args.vpl_reference_rsm);
        if !references.contains_key(&rkey) {
            let cache = args.reference_cache.as_deref().map(ReferenceCache::new);
            let refs = (args.reference, args.vpl_reference_rsm);
            let (r, from) = render_reference(p, pargs, refs, args.reference_frames, cache.as_ref())
                .with_context(|| format!("{what}: reference"))?;
            let kind = reference_kind(args.reference);
            let vpls = reference_vpl_line(pargs, args.vpl_reference_rsm).map(|l| format!("; {l}")).unwrap_or_default();
            let from = from.map(|f| format!(" when it was rendered; read from {}", f.display())).unwrap_or_default();
            axes::say(pb, format!("reference ({kind}{vpls}): {:.3} ms{from}", r.total_ms));
            references.insert(rkey.clone(), r);
        }
        let reference = &references[&rkey];
        // Every setting is tonemapped with the reference's exposure, so FLIP compares images,
        // not exposures.
        let fixed;
        let pargs = match reference.exposure {
            Some(exposure) => {
                fixed = Settings { auto_exposure: false, exposure, ..pargs.clone() };
                &fixed
            }
            None => pargs,
        };
        p.reconfigure(pargs).with_context(|| what.clone())?;
        // The scene may have been loaded here, at the start or for the reference: show its
        // warnings once per scene.
        if warned_scene.as_ref() != Some(&pargs.scene) {
            pb.suspend(|| crate::output::print_load_warnings(&p.scene_warnings));
            *warned_scene = Some(pargs.scene.clone());
        }
        let mut renderer = p.renderer(false).with_context(|| what.clone())?;
        let m = if args.camera_orbit == 0.0 {
            bench::measure(p, &mut renderer, args.warmup, args.frames)
        } else {
            bench::measure_orbiting(p, &mut renderer, (args.warmup, args.frames), args.camera_orbit)
        }
        .with_context(|| what.clone())?;
        renderer.check_traced_complete(&p.ctx).with_context(|| what.clone())?;
        let (total, passes) = pass_times(&m).with_context(|| what.clone())?;
        let spread = frame_spread(&m);
        let dropped = m.dropped();
        let stats = p.culling_stats(&renderer)?;
        let edges = renderer.edge_pixels(&p.ctx).context("reading the MSAA edge count back")?;
        let depth = renderer.read_depth(&p.ctx).context("reading the depth buffer back")?;
        let hdr = renderer.read_hdr(&p.ctx).context("reading the image back")?;
        let ldr = renderer.read_ldr(&p.ctx).context("reading the image back")?;
        p.check_gpu_errors()?;
        let q = quality(p, &depth)?;
        let e = HdrError::of(&reference.hdr, &hdr);
        let worst = explain_worst(p, pargs, geometry, (&depth, e.worst_pixel), (&reference.hdr, &hdr))
            .with_context(|| format!("{what}: explaining the worst pixel"))?;
        let map = flip(pargs.width, pargs.height, &reference.ldr, &ldr);
        let fl = map.summary(PERCENTILE);
        heat.insert(point.clone(), map.heat_rgb());
        // WBOIT against the sorted frame of the same settings: the sort's share alone.
        let glass = p.has_blended_geometry();
        let vpls = renderer.vpl_count(&p.ctx).context("reading the VPL count back")?;
        // Flicker (the stochastic method only: every other method draws a still view's
        // frames alike): FLIP between the compared frame and the next one of the same view.
        let flicker = if pargs.method.traits().stochastic {
            let next = bench::render_frame(&p.ctx, &mut renderer, &p.scene_gpu, &p.camera)
                .with_context(|| format!("{what}: the next frame (flicker)"))?;
            Some(flip(pargs.width, pargs.height, &ldr, &next.ldr).summary(PERCENTILE).mean)
        } else {
            None
        };
        drop(renderer);
        let vs_sorted = match pargs.knobs.blend_mode {
            BlendMode::Sorted => {
                if glass && keep_sorted {
                    sorted.insert(sorted_key(pargs), SortedFrame { ldr: ldr.clone(), total_ms: total });
                }
                None
            }
            BlendMode::WeightedOit if glass => {
                let key = sorted_key(pargs);
                if !sorted.contains_key(&key) {
                    let s = render_sorted(p, pargs, args.warmup, args.frames)
                        .with_context(|| format!("{what}: the sorted frame"))?;
                    sorted.insert(key.clone(), s);
                }
                let s = &sorted[&key];
                Some((s.total_ms, flip(pargs.width, pargs.height, &s.ldr, &ldr).summary(PERCENTILE)))
            }
            BlendMode::WeightedOit => None,
        };
        // The error split by cause: the budget against the truth.
        let by_cause = if args.budget && args.reference == ReferenceKind::Traced {
            let e = error_split(p, (pargs, &ldr, &reference.ldr), args.vpl_reference_rsm, splits)
                .with_context(|| format!("{what}: the error split"))?;
            Some(e)
        } else {
            None
        };
        let mut row = vec![adapter.clone(), pargs.width.to_string(), pargs.height.to_string(), measured(args)];
        row.extend(point.iter().cloned());
        let opt = |v: Option<String>| v.unwrap_or_default();
        row.extend([
            f(total, 4),
            passes,
            f(spread.0, 4),
            f(spread.1, 4),
            f(e.psnr_db, 3),
            f(f64::from(fl.mean), 6),
            f(f64::from(fl.percentile), 6),
            f(f64::from(fl.max), 6),
            f(e.max_error, 6),
            f(e.energy_lost, 6),
            opt(stats.as_ref().map(|s| f(s.mean_per_list, 3))),
            opt(stats.as_ref().map(|s| s.max_per_list.to_string())),
            opt(stats.as_ref().map(|s| s.overflowing.to_string())),
        ]);
        row.extend(dropped.csv());
        row.push(dropped::load_warnings_cell(&p.scene_warnings));
        row.push(dropped::vpls_refused_cell(vpls));
        row.extend([
            opt(q.map(|q| f(q.false_positive_rate, 6))),
            opt(q.map(|q| f(q.wasted_per_pixel, 4))),
            opt(q.map(|q| f(q.evaluated_per_pixel, 4))),
            f(reference.total_ms, 4),
            reference.passes.clone(),
            p.lights.len().to_string(),
            opt(edges.map(|e| e.to_string())),
            opt(vs_sorted.as_ref().map(|v| f(v.0, 4))),
            opt(vs_sorted.as_ref().map(|v| f(f64::from(v.1.mean), 6))),
            opt(vs_sorted.as_ref().map(|v| f(f64::from(v.1.percentile), 6))),
        ]);
        row.extend(worst.as_ref().map_or_else(|| std::array::from_fn(|_| String::new()), worst::WorstPixel::csv));
        row.extend(by_cause.as_ref().map_or_else(|| std::array::from_fn(|_| String::new()), ErrorSplit::csv));
        row.push(opt(flicker.map(|v| f(f64::from(v), 6))));
        csv.append(&[row])?;
        let vs = vs_sorted.map_or(String::new(), |(ms, v)| {
            format!("; vs sorted ({ms:.3} ms): FLIP mean {:.5} p99 {:.4}", v.mean, v.percentile)
        });
        let mark = dropped.mark().map(|d| format!(" ({d}: incomplete frames)")).unwrap_or_default();
        let vs = match flicker {
            Some(v) => format!("{vs}; flicker (FLIP to the next frame) {v:.5}"),
            None => vs,
        };
        axes::say(
            pb,
            format!(
                "{what}: {total:.3} ms{mark}, FLIP mean {:.5} p99 {:.4}, PSNR {:.2} dB, energy lost {:.3}%{vs}",
                fl.mean,
                fl.percentile,
                e.psnr_db,
                100.0 * e.energy_lost
            ),
        );
        if let Some(w) = &worst {
            axes::say(pb, format!("  {}", w.line()));
        }
        if let Some(e) = by_cause {
            axes::say(pb, format!("  {}", e.line()));
            split.insert(point.clone(), e);
        }
        let max_binding = p.ctx.device.limits().max_storage_buffer_binding_size;
        let refused = vpls.and_then(|c| crate::dropped::refused_line("the measured frames", c));
        Ok(crate::dropped::join_warnings(
            dropped.warning("the measured frames", p.settings.grid_pairs, max_binding),
            refused,
        ))
    }
}

/// The worst pixel of a setting explained ([`worst::attribute`]): the first depth sample of
/// each pixel (MSAA), the setting's camera and lights, the scene's shadow geometry (built
/// again only when the scene changes). None when the images are identical.
fn explain_worst(
    p: &Prepared,
    pargs: &Settings,
    geometry: &mut Option<(Settings, TraceGeometry)>,
    (depth, pixel): (&[f32], Option<usize>),
    (reference, setting): (&[[f32; 4]], &[[f32; 4]]),
) -> Result<Option<worst::WorstPixel>> {
    let Some(pixel) = pixel else { return Ok(None) };
    let stale = geometry.as_ref().is_none_or(|(built, _)| rebuild_plan(built, pargs).reload == Reload::Scene);
    if stale {
        let scene = tiledlight_setup::load::scene_of(pargs).context("loading the scene for its shadow geometry")?;
        *geometry = Some((pargs.clone(), TraceGeometry::of(&scene)));
    }
    let pixels = pargs.width as usize * pargs.height as usize;
    let samples = (depth.len() / pixels.max(1)).max(1);
    let first: Vec<f32> = depth.iter().step_by(samples).copied().collect();
    ensure!(first.len() == pixels, "a depth buffer of {} values for {pixels} pixels", depth.len());
    let frame = worst::Frame {
        camera: &p.camera,
        size: (pargs.width, pargs.height),
        depth: &first,
        lights: &p.lights.packed,
        geometry: geometry.as_ref().map(|(_, g)| g),
    };
    Ok(worst::attribute(&frame, pixel, reference, setting))
}

/// The CSV's rows as numbers by column name (NaN where empty or not a number).
fn parse_rows(rows: &[Vec<String>], head: &[String]) -> Vec<HashMap<String, f64>> {
    rows.iter()
        .map(|r| head.iter().zip(r).map(|(h, v)| (h.clone(), v.parse::<f64>().unwrap_or(f64::NAN))).collect())
        .collect()
}

/// The culling statistics of every setting side by side (false-positive rate, wasted
/// evaluations per pixel, longest list, frame time) in `<chart>-culling.png`, when the
/// run has them for two settings or more (methods without light lists have none); returns
/// the line naming which setting wins each.
fn culling_chart(
    chart_path: &Path,
    title: &str,
    subtitle: &str,
    rows: &[Vec<String>],
    numbers: &[HashMap<String, f64>],
    describe: &dyn Fn(usize) -> String,
) -> Result<Option<String>> {
    let with: Vec<usize> = (0..rows.len()).filter(|&i| numbers[i]["false_positive_rate"].is_finite()).collect();
    if with.len() < 2 {
        return Ok(None);
    }
    let measures = [
        ("false_positive_rate", "False-positive rate (listed lights reaching no pixel's surface)"),
        ("wasted_per_pixel", "Wasted light evaluations per pixel"),
        ("max_lights_per_tile", "Longest light list (a tile's or a cluster's)"),
        ("total_ms", "GPU frame time, ms"),
    ];
    let settings: Vec<String> = with.iter().map(|&i| describe(i)).collect();
    let panels: Vec<(String, Vec<f64>)> = measures
        .iter()
        .map(|(col, name)| (name.to_string(), with.iter().map(|&i| numbers[i][*col]).collect()))
        .collect();
    let best = |k: usize| {
        let v = &panels[k].1;
        (0..v.len()).filter(|&j| v[j].is_finite()).min_by(|&a, &b| v[a].total_cmp(&v[b])).map(|j| settings[j].clone())
    };
    let line = format!(
        "culling:    fewest false positives: {}; fewest wasted evaluations: {}; shortest longest list: {}; fastest: {}",
        best(0).unwrap_or_default(),
        best(1).unwrap_or_default(),
        best(2).unwrap_or_default(),
        best(3).unwrap_or_default()
    );
    let path = chart_path.with_file_name(format!(
        "{}-culling.png",
        chart_path.file_stem().map_or_else(|| "accuracy".into(), |s| s.to_string_lossy().into_owned())
    ));
    chart::bar_panels(
        &path,
        &chart::BarPanels {
            title: title.replace("Speed vs accuracy", "Culling statistics per setting"),
            subtitle: subtitle.replace(THRESHOLD_LABELS, ""),
            note: Some(line.trim_start_matches("culling:").trim().to_string()),
            settings,
            panels,
        },
    )?;
    Ok(Some(format!("{line} ({})", path.display())))
}

/// Draws the Pareto chart, writes the heat maps of the frontier's settings measured in
/// this run, and returns the recommendation line.
fn report(
    chart_path: &Path,
    diff_dir: &Path,
    axes: &[Axis],
    rows: &[Vec<String>],
    (heat, split): (&ByPoint<Vec<u8>>, &ByPoint<ErrorSplit>),
    (args, (scene, method)): (&Accuracy, (String, Method)),
) -> Result<String> {
    let head = header(axes);
    let col = |name: &str| head.iter().position(|h| h == name).expect("known column");
    let n = HEAD.len();
    let threshold = axes.iter().position(|a| a.name == "threshold");
    // Colour by the axes with several values other than the threshold; label by threshold.
    let series_axes: Vec<usize> =
        (0..axes.len()).filter(|&i| Some(i) != threshold && axes[i].values.len() > 1).collect();
    let parse = |r: &Vec<String>, c: &str| r[col(c)].parse::<f64>().unwrap_or(f64::NAN);
    let points: Vec<ParetoPoint> = rows
        .iter()
        .map(|r| ParetoPoint {
            series: if args.budget {
                // One curve per dial: the axis this setting changed from the base (the
                // caster counts once per way of choosing them).
                axes::budget_series(axes, &r[n..n + axes.len()])
            } else {
                let s = axes::series_name(axes, &series_axes, &r[n..n + axes.len()], method);
                if s.is_empty() {
                    "settings".into()
                } else {
                    s
                }
            },
            // A budget's point by the value its dial changed, others by their threshold.
            label: match threshold {
                _ if args.budget => axes::budget_label(axes, &r[n..n + axes.len()]),
                Some(t) => format!("T={}", r[n + t]),
                None => String::new(),
            },
            time: parse(r, "total_ms"),
            error: parse(r, "flip_mean"),
            incomplete: parse(r, "dropped_frames") > 0.0,
        })
        .collect();
    let frontier = chart::pareto_frontier(&points);
    // The reference is a setting too: exact (error 0) at its own time. A setting slower
    // than its reference is dominated by it and never recommended (at the lowest
    // thresholds Forward+ was measured slower than the traced truth).
    let reference_ms: Vec<f64> = rows.iter().map(|r| parse(r, "reference_ms")).collect();
    let slower: Vec<bool> = points.iter().zip(&reference_ms).map(|(p, &r)| r.is_finite() && p.time >= r).collect();
    let candidates: Vec<usize> = frontier.iter().copied().filter(|&i| !slower[i]).collect();
    let chosen = candidates.iter().copied().find(|&i| points[i].error < args.target_flip);
    let describe = |i: usize| axes::describe(axes, &rows[i][n..n + axes.len()].to_vec());
    let fastest_reference = reference_ms.iter().copied().filter(|t| t.is_finite()).min_by(f64::total_cmp);
    let kind = reference_kind(args.reference);
    let note = match (chosen, fastest_reference) {
        (Some(i), _) => format!(
            "fastest under FLIP mean {}: {} at {:.3} ms (FLIP mean {:.4})",
            args.target_flip,
            describe(i),
            points[i].time,
            points[i].error
        ),
        (None, Some(t)) => {
            format!("no faster setting reaches FLIP mean < {}: the reference itself ({t:.1} ms)", args.target_flip)
        }
        (None, None) => format!("no setting reaches FLIP mean < {}", args.target_flip),
    };
    // The cheapest setting within each of the usual error budgets (on the frontier: the
    // fastest below each), or the reference where no faster setting is within it.
    let budgets: Vec<String> = CHEAPEST_WITHIN
        .iter()
        .map(|&eps| match (candidates.iter().copied().find(|&i| points[i].error < eps), fastest_reference) {
            (Some(i), _) => format!(
                "cheapest within FLIP {eps}: {} at {:.3} ms (FLIP mean {:.4})",
                describe(i),
                points[i].time,
                points[i].error
            ),
            (None, Some(t)) => {
                format!("cheapest within FLIP {eps}: the reference itself ({kind}, {t:.3} ms); no faster setting")
            }
            (None, None) => format!("cheapest within FLIP {eps}: none"),
        })
        .collect();
    let dominated = slower.iter().filter(|&&s| s).count();
    let note = if dominated > 0 {
        let s = if dominated == 1 { "" } else { "s" };
        format!("{note}; {dominated} setting{s} slower than it")
    } else {
        note
    };
    // One diamond per distinct reference time (a run can hold several references: MSAA,
    // VPLs, blended geometry each get their own).
    let mut references: Vec<(f64, String)> = Vec::new();
    for &t in reference_ms.iter().filter(|t| t.is_finite()) {
        if !references.iter().any(|(u, _)| (u - t).abs() <= 1e-6 * t.abs().max(1.0)) {
            references.push((t, format!("reference: {t:.1} ms")));
        }
    }
    let incomplete = points.iter().filter(|p| p.incomplete).count();
    let note = if incomplete > 0 {
        let s = if incomplete == 1 { "" } else { "s" };
        format!("{note}; {incomplete} setting{s} ringed red: frames DROPPED lights")
    } else {
        note
    };
    let first = rows.first();
    let adapter = first.map(|r| r[0].clone()).unwrap_or_default();
    let res = first.map(|r| format!("{}x{}", r[1], r[2])).unwrap_or_default();
    let lights = first.map(|r| group_digits(r[col("lights")].parse().unwrap_or(0))).unwrap_or_default();
    let c = ParetoChart {
        title: format!("Speed vs accuracy: {adapter}, {res}"),
        subtitle: format!(
            "{}; error vs the reference ({}){}",
            setting_phrase(&scene, &lights, method, axes),
            reference_kind(args.reference),
            // The points are labelled by threshold only outside a budget, with a threshold axis.
            if threshold.is_some() && !args.budget { THRESHOLD_LABELS } else { "" }
        ),
        x_label: "GPU frame time, ms (sum of pass medians)".into(),
        y_label: "FLIP mean (tonemapped, vs reference)".into(),
        points,
        target: Some((args.target_flip, format!("target: FLIP mean {}", args.target_flip))),
        chosen,
        note: Some(note.clone()),
        references,
    };
    chart::pareto_chart(chart_path, &c)?;
    // Bars are labelled by the axes that vary (the fixed ones are in the subtitle).
    let varying = |i: usize| {
        let v: Vec<String> = (0..axes.len())
            .filter(|&a| axes[a].values.len() > 1)
            .map(|a| format!("{}={}", axes[a].name, rows[i][n + a]))
            .collect();
        if v.is_empty() {
            describe(i)
        } else {
            v.join(" ")
        }
    };
    let culling = culling_chart(chart_path, &c.title, &c.subtitle, rows, &parse_rows(rows, &head), &varying)?;
    let (w, h) = first.map(|r| (r[1].parse().unwrap_or(0), r[2].parse().unwrap_or(0))).unwrap_or((0, 0));
    let mut wrote = 0;
    let mut split_maps = 0;
    let save = |name: String, rgb: &[u8]| -> Result<()> {
        let img = image::RgbImage::from_raw(w, h, rgb.to_vec()).context("building a heat map image")?;
        crate::output::save_png(&diff_dir.join(name), &img)
    };
    for &i in &frontier {
        let key = rows[i][n..n + axes.len()].to_vec();
        let Some(rgb) = heat.get(&key) else { continue };
        let stem = format!("flip-{}", describe(i).replace(' ', "_").replace(['=', '+'], "-"));
        save(format!("{stem}.png"), rgb)?;
        wrote += 1;
        // Beside it, the error by cause (module doc).
        if let Some(e) = split.get(&key) {
            save(format!("{stem}.cutoff.png"), &e.cutoff.heat)?;
            save(format!("{stem}.beyond-cutoff.png"), &e.beyond.1)?;
            split_maps += 2;
            if let Some(u) = &e.unshadowed {
                save(format!("{stem}.unshadowed.png"), &u.heat)?;
                split_maps += 1;
            }
        }
    }
    let mut out = culling.map_or(String::new(), |line| format!("{line}\n"));
    // The frontier without the settings the reference beats (slower than it, and exact).
    out += &format!(
        "frontier:   {} of {} settings: {}\n",
        candidates.len(),
        rows.len(),
        candidates.iter().map(|&i| describe(i)).collect::<Vec<_>>().join("; ")
    );
    if wrote > 0 {
        let by_cause = if split_maps > 0 {
            format!(
                ", with {split_maps} of the error by cause beside them (.cutoff: the truth with the cutoff, \
                 .unshadowed: the truth without shadow rays, each against the truth; .beyond-cutoff: the setting \
                 against the truth with its cutoff)"
            )
        } else {
            String::new()
        };
        out.push_str(&format!("heat maps:  {wrote} in {}{by_cause}\n", diff_dir.display()));
    }
    out.push_str(&format!("result:     {note}"));
    for b in &budgets {
        out.push_str(&format!("\n{b}"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The subtitle names the base method only when no axis names the method, and every
    /// axis of one value.
    #[test]
    fn the_subtitle_names_the_method_once() {
        let axis = |name: &str, values: &[&str]| Axis {
            name: name.into(),
            values: values.iter().map(|v| v.to_string()).collect(),
        };
        let base = Method::ForwardPlus;
        assert_eq!(
            setting_phrase("default scene", "1,024", base, &[axis("threshold", &["0.1"]), axis("lights", &["1", "2"])]),
            "default scene, 1,024 lights, forward-plus, threshold=0.1"
        );
        let methods = [axis("method", &["stochastic", "visibility"]), axis("accumulate", &["64"])];
        assert_eq!(setting_phrase("f9", "4,096", base, &methods), "f9, 4,096 lights, accumulate=64");
        let one = [axis("method", &["deferred"])];
        assert_eq!(setting_phrase("f9", "4,096", base, &one), "f9, 4,096 lights, method=deferred");
    }

    #[test]
    fn the_reference_follows_the_transparent_objects_not_the_blend_mode() {
        let s = Settings { grid_objects: 50, transparent_objects: 10, ..Settings::default() };
        let key = |s: &Settings| reference_key(s, ReferenceKind::NoCutoff, VplReference::Scale(1));
        let oit = Settings { knobs: Knobs { blend_mode: BlendMode::WeightedOit, ..s.knobs }, ..s.clone() };
        assert_eq!(key(&s), key(&oit), "the reference is always sorted");
        assert_ne!(key(&s), key(&Settings { transparent_objects: 20, ..s.clone() }));
        assert_eq!(key(&s), key(&Settings { threshold: 0.5, method: Method::TiledDeferred, ..s.clone() }));
    }

    #[test]
    fn the_vpl_reference_is_every_texel_of_the_settings_rsm() {
        use tiledlight_cull::vpl::{VplConfig, VplShading};
        let s = Settings { spot_lights: Some(8), shadow_spot_lights: 4, shadow_point_lights: 0, ..Settings::default() };
        assert_eq!(reference_vpl(&s, VplReference::Scale(1)), None);
        let with = |v: VplConfig| Settings { vpl: Some(v), ..s.clone() };
        let r = reference_vpl(
            &with(VplConfig { block: 4, brightness_threshold: 0.3, cap: 10, ..VplConfig::default() }),
            VplReference::Scale(1),
        )
        .expect("a VPL reference");
        assert_eq!((r.block, r.colour_threshold, r.brightness_threshold), (1, 0.0, 0.0));
        assert_eq!((r.cap, r.shading), (4 * 32 * 32, VplShading::Physical));
        let key = |s: &Settings| reference_key(s, ReferenceKind::NoCutoff, VplReference::Scale(1));
        // Block, thresholds, cap and model are what the setting's error measures; the RSM
        // size makes another reference.
        let a = with(VplConfig { block: 2, ..VplConfig::default() });
        let b = with(VplConfig { block: 8, shading: VplShading::Physical, cap: 5, ..VplConfig::default() });
        assert_eq!(key(&a), key(&b));
        assert_ne!(key(&a), key(&with(VplConfig { rsm_size: 64, ..VplConfig::default() })));
        assert_ne!(key(&a), key(&s), "VPLs change the reference");
        assert_eq!(
            reference_vpl_line(&a, VplReference::Scale(1)).unwrap(),
            "VPLs: every texel of 32x32 RSMs (the setting's own), physical shading"
        );
    }

    #[test]
    fn a_finer_vpl_reference_scales_the_rsm_or_fixes_its_size() {
        use tiledlight_cull::vpl::{VplConfig, RSM_SIZES};
        let s = Settings { spot_lights: Some(8), shadow_spot_lights: 4, shadow_point_lights: 1, ..Settings::default() };
        let with = |v: VplConfig| Settings { vpl: Some(v), ..s.clone() };
        let a = with(VplConfig { block: 4, ..VplConfig::default() });
        let x4 = VplReference::Scale(4);
        let r = reference_vpl(&a, x4).expect("a VPL reference");
        // 4x the default 32 texels, every texel of the 4 spot faces and 6 point faces a VPL.
        assert_eq!((r.rsm_size, r.block, r.cap), (128, 1, 10 * 128 * 128));
        r.validate().expect("a valid reference");
        let line = reference_vpl_line(&a, x4).unwrap();
        assert_eq!(line, "VPLs: every texel of 128x128 RSMs (4x the setting's 32), physical shading");
        // Capped at the largest RSM size, and said so.
        let big = with(VplConfig { rsm_size: 256, ..VplConfig::default() });
        assert_eq!(reference_vpl(&big, VplReference::Scale(8)).unwrap().rsm_size, *RSM_SIZES.end());
        assert_eq!(
            reference_vpl_line(&big, VplReference::Scale(8)).unwrap(),
            "VPLs: every texel of 512x512 RSMs (8x the setting's 256, capped at 512), physical shading"
        );
        let key = |s: &Settings, r| reference_key(s, ReferenceKind::NoCutoff, r);
        assert_ne!(key(&a, VplReference::Scale(1)), key(&a, x4), "another scale, another reference");
        // One size for every setting: an RSM-size axis shares one reference.
        let a16 = with(VplConfig { rsm_size: 16, ..VplConfig::default() });
        let a64 = with(VplConfig { rsm_size: 64, block: 8, ..VplConfig::default() });
        let fixed = VplReference::Size(128);
        assert_eq!(key(&a16, fixed), key(&a64, fixed));
        assert_ne!(key(&a16, x4), key(&a64, x4), "scaled references follow the setting's size");
        assert_eq!(
            reference_vpl_line(&a16, fixed).unwrap(),
            "VPLs: every texel of 128x128 RSMs (--vpl-reference-rsm 128, for every setting), physical shading"
        );
        // The flag's values.
        assert_eq!(parse_vpl_reference("4x"), Ok(x4));
        assert_eq!(parse_vpl_reference("256"), Ok(VplReference::Size(256)));
        for bad in ["3x", "0x", "1024", "3", "fine"] {
            assert!(parse_vpl_reference(bad).unwrap_err().starts_with(bad), "{bad}");
        }
    }

    #[test]
    fn the_sorted_frame_differs_from_the_setting_by_the_blend_mode_only() {
        let s = Settings { grid_objects: 50, transparent_objects: 10, ..Settings::default() };
        let oit = Settings { knobs: Knobs { blend_mode: BlendMode::WeightedOit, ..s.knobs }, ..s.clone() };
        assert_eq!(sorted_key(&s), sorted_key(&oit), "a WBOIT point finds the sorted point of its settings");
        // Unlike the reference, the cutoff, method and culling are the setting's own.
        for other in [
            Settings { threshold: 0.5, ..oit.clone() },
            Settings { method: Method::TiledDeferred, ..oit.clone() },
            Settings { half_z: true, ..oit.clone() },
            Settings { transparent_objects: 20, ..oit.clone() },
        ] {
            assert_ne!(sorted_key(&oit), sorted_key(&other));
        }
    }

    #[test]
    fn the_vs_sorted_columns_follow_the_reference_ones() {
        let axes = [Axis { name: "blend-mode".into(), values: vec!["sorted".into(), "wboit".into()] }];
        let h = header(&axes);
        let at = |c: &str| h.iter().position(|x| x == c).unwrap_or_else(|| panic!("no column {c}"));
        assert_eq!(h[HEAD.len()], "blend-mode");
        assert!(at("total_ms") < at("sorted_ms") && at("sorted_ms") + 1 == at("vs_sorted_flip_mean"));
        // The worst pixel's columns follow, then the error split's.
        assert_eq!(at("vs_sorted_flip_p99") + 1, at(worst::COLUMNS[0]));
        let split = ["cutoff_flip_mean", "unshadowed_flip_mean", "beyond_cutoff_flip_mean"];
        assert_eq!(at(worst::COLUMNS[4]) + 1, at(split[0]));
        // Then the flicker column closes the row.
        assert_eq!(&h[h.len() - split.len() - 1..h.len() - 1], split);
        assert_eq!(h.last().map(String::as_str), Some("flicker_flip_mean"));
    }
}
