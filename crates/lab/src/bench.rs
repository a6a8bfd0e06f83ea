//! `tiledlight bench`: renders warm-up frames, then N measured frames, collecting each
//! frame's per-pass GPU times (timestamp queries through `GpuTimer`) and its CPU wall
//! time, and prints (and optionally writes as JSON) median/min/max per pass.
//!
//! Frames are serialised: each frame is recorded, submitted and waited for before the
//! next, so the CPU frame time is the wall time of record + submit + wait of that frame
//! (latency, not pipelined throughput) and the profiler never has to drop a pending frame.
//! The frame loop ([`measure`]) and the table are shared with `render` and the default run.
//!
//! With shadow-casting lights, each measured frame's count of shadow faces drawn is
//! recorded: with still lights every face is drawn once, before the measured frames, so
//! the shadow pass costs nothing there; `--move-lights` moves the lights before every
//! frame (the viewer's animation, tiledlight-setup's `LightAnimator`, at a fixed step) and
//! tells the renderer (`Renderer::lights_moved`), so every caster's faces are drawn again
//! each frame and the shadow pass's cost with moving lights is measured.
//!
//! With alpha-blended geometry (transparent objects, glTF BLEND materials) the blended
//! instances and the blend mode are printed and written to the JSON (`blended_instances`,
//! `blend_mode`, null without blended geometry); the blended passes are timed like the
//! others (`blended.depth`, `blended.cull`, `blended.shade`, `blended.composite`).
//!
//! Frames that dropped lights (a light grid full: see [`crate::dropped`]) are counted from
//! the light-grid headers read back (the opaque grid's, the blended geometry's and the
//! VPLs'): the table marks the times as those of incomplete frames, the JSON has
//! `dropped_frames`, `dropped_lights`, `dropped_lists` (and `blended_dropped_*`,
//! `vpl_dropped_*`) and the scene's
//! `load_warnings`, a `warning:` line goes to
//! stderr, and `--strict` makes it an error once the JSON is written.
//!
//! A lost device or an out-of-memory error ends the frame loop with the named error
//! ([`tiledlight_gpu::GpuError::DeviceLost`], `OutOfMemory`), not with what failed after
//! it. `TILEDLIGHT_TEST_LOSE_DEVICE_AFTER=N` (tests only) destroys the device after the
//! N-th frame of the process, to check that path on any GPU.
//!
//! [`render_frame`] is the frame loop of one frame with its images read back (the GPU
//! tests compare those). The loops here are the lab's only callers of the renderer's
//! recording (`Renderer::prepare`, `record`, `render_once`) besides shadow-accuracy's
//! per-caster renderer.
//!
//! May depend on [`crate::axes`] (the flags), [`crate::dropped`], [`crate::output`],
//! tiledlight-setup and tiledlight-gpu.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use anyhow::{ensure, Context, Result};
use glam::Mat4;
use serde::Serialize;
use tiledlight_cull::Camera;
use tiledlight_frame::{Diagnostics as _, FrameRenderer, Renderer};
use tiledlight_gpu::knobs::{Kind, Knob, Knobs, KNOBS};
use tiledlight_gpu::light_grid::GridStatus;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::{GpuTimer, PassTime};
use tiledlight_gpu::{GpuContext, GpuError};

use tiledlight_setup::settings::blend_mode_description;
use tiledlight_setup::{shadow_atlas_description, LightAnimator, Prepared};

use crate::axes::Flags;
use crate::dropped::{self, Dropped};

/// How the CPU frame time is measured (printed and written to JSON).
pub const CPU_TIME_MEANING: &str = "wall time of record + submit + wait for the GPU, per frame (frames serialised)";

/// The most frames `--frames` and `--warmup` accept (a guard against typos that would run
/// for hours).
pub const MAX_FRAMES: u32 = 100_000;

/// The shortest warm-up (when any is asked for): long enough for an idle GPU to raise its
/// clocks. On the H100, 3 warm-up frames after a few seconds of CPU work left every pass
/// up to 5x slower (the 0.29 ms tonemap pass measured up to 1.69 ms).
pub const MIN_WARMUP: std::time::Duration = std::time::Duration::from_millis(500);

/// The time step of `--move-lights` per frame, seconds: the lights move as in the viewer at
/// 60 frames per second, whatever the frame rate (so runs move them alike).
pub const MOVE_STEP_S: f32 = 1.0 / 60.0;

/// A `bench` run: the frames and where the JSON goes (the app's `bench` flags).
#[derive(Clone, Debug)]
pub struct Bench {
    /// Measured frames.
    pub frames: u32,
    /// Frames rendered before measuring.
    pub warmup: u32,
    /// Also write the results as JSON here.
    pub json: Option<PathBuf>,
    /// Move the lights before every frame (`--move-lights`).
    pub move_lights: bool,
}

/// What a run of frames measured.
#[derive(Clone, Debug, Default)]
pub struct Measurement {
    /// Per measured frame whose timestamps came back, its pass times, in frame order.
    pub gpu_frames: Vec<Vec<PassTime>>,
    /// Per measured frame, its CPU wall time in milliseconds.
    pub cpu_ms: Vec<f64>,
    /// Per measured frame whose timestamps came back, the GPU milliseconds from its first
    /// timed pass's start to its last one's end (gaps and untimed work included).
    pub gpu_span_ms: Vec<f64>,
    /// Whether the device had timestamp queries.
    pub timestamps: bool,
    /// Light-grid headers of measured frames that came back (tiled methods; every other
    /// frame or so, as the readback never waits; the last frame's, read after the timing,
    /// when none came back).
    pub grid: Vec<GridStatus>,
    /// The same for the blended geometry's own light grid (tiled methods with blended
    /// geometry).
    pub blended_grid: Vec<GridStatus>,
    /// The same for the VPLs' own light grid (tiled methods with `--vpl`).
    pub vpl_grid: Vec<GridStatus>,
    /// Per measured frame, the shadow faces it drew (empty without shadow casters).
    pub shadow_faces: Vec<u32>,
}

impl Measurement {
    /// What the measured frames read back lost to a full light grid.
    pub fn dropped(&self) -> Dropped {
        Dropped::of(&self.grid, &self.blended_grid).with_vpl(&self.vpl_grid)
    }

    /// One line on the measured frames' light grid: pairs, grid size, and any lights
    /// dropped because the grid was full (None for a method without one).
    pub fn grid_line(&self) -> Option<String> {
        let last = self.grid.last()?;
        let dropped: Vec<&GridStatus> = self.grid.iter().filter(|g| !g.complete()).collect();
        Some(match dropped.first() {
            None => format!("{last}; no frame dropped lights"),
            Some(d) => format!(
                "{last}; {} of {} frames read back DROPPED lights (e.g. {} from {} lists): their times are of incomplete frames",
                dropped.len(),
                self.grid.len(),
                d.header.dropped_pairs,
                d.header.dropped_lists
            ),
        })
    }

    /// The smallest and largest count of shadow faces a measured frame drew (None without
    /// shadow casters).
    pub fn shadow_faces_range(&self) -> Option<(u32, u32)> {
        let min = self.shadow_faces.iter().copied().min()?;
        Some((min, self.shadow_faces.iter().copied().max().unwrap_or(min)))
    }

    /// One line on the shadow faces the measured frames drew (None without shadow casters).
    pub fn shadow_line(&self) -> Option<String> {
        let (min, max) = self.shadow_faces_range()?;
        let range = if min == max { format!("{min}") } else { format!("{min} to {max}") };
        Some(format!("{range} shadow faces drawn per measured frame"))
    }
}

/// Median, minimum and maximum of a set of samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Median (mean of the middle two for an even count).
    pub median_ms: f64,
    /// Smallest.
    pub min_ms: f64,
    /// Largest.
    pub max_ms: f64,
    /// Number of samples.
    pub frames: usize,
}

impl Summary {
    /// Summary of `samples` (None when empty).
    pub fn of(samples: &[f64]) -> Option<Self> {
        if samples.is_empty() {
            return None;
        }
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let median = if n % 2 == 1 { s[n / 2] } else { 0.5 * (s[n / 2 - 1] + s[n / 2]) };
        Some(Self { median_ms: median, min_ms: s[0], max_ms: s[n - 1], frames: n })
    }
}

/// One pass's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PassSummary {
    /// Pass label, e.g. "forward.cull".
    pub pass: String,
    /// Its times.
    #[serde(flatten)]
    pub summary: Summary,
}

impl Measurement {
    /// Per pass (in the order passes run), the summary of its times over the frames.
    pub fn passes(&self) -> Vec<PassSummary> {
        let mut labels: Vec<&str> = Vec::new();
        for f in &self.gpu_frames {
            for p in f {
                if !labels.contains(&p.label.as_str()) {
                    labels.push(&p.label);
                }
            }
        }
        labels
            .into_iter()
            .filter_map(|label| {
                let samples: Vec<f64> =
                    self.gpu_frames.iter().flat_map(|f| f.iter().filter(|p| p.label == label).map(|p| p.ms)).collect();
                Summary::of(&samples).map(|summary| PassSummary { pass: label.to_string(), summary })
            })
            .collect()
    }

    /// Summary of the CPU frame times.
    pub fn cpu(&self) -> Option<Summary> {
        Summary::of(&self.cpu_ms)
    }
}

/// Renders `warmup` frames (and more until [`MIN_WARMUP`] has passed), then `frames`
/// frames through `renderer`, each submitted and waited for, and collects the measured
/// frames' pass times and CPU wall times. The lights stay still.
pub fn measure(prep: &Prepared, renderer: &mut FrameRenderer, warmup: u32, frames: u32) -> Result<Measurement> {
    measure_moving(prep, renderer, warmup, frames, None)
}

/// [`measure`] with the camera orbiting `degrees` a frame about the vertical axis through
/// the scene's centre: the warm-up stands still where the orbit starts, each measured
/// frame moves on, and the last one is seen through the settings' camera (what a
/// reference of the settings' view is compared with: the error of a camera in motion).
pub fn measure_orbiting(
    prep: &Prepared,
    renderer: &mut FrameRenderer,
    (warmup, frames): (u32, u32),
    degrees: f32,
) -> Result<Measurement> {
    let pb = indicatif::ProgressBar::hidden();
    measure_along(prep, renderer, (warmup, frames), (None, degrees), &pb)
}

/// The camera `degrees` times `steps` back along the orbit of [`measure_orbiting`]
/// (`prep`'s own at 0 steps).
pub fn orbit_camera(prep: &Prepared, degrees: f32, steps: u32) -> Result<Camera> {
    let centre = (prep.bounds.min + prep.bounds.max) * 0.5;
    orbit(&prep.camera, centre, -degrees * steps as f32)
        .map_err(|e| anyhow::anyhow!("orbiting the camera {degrees} degrees a frame: {e}"))
}

/// `camera` moved `degrees` about the vertical axis through `centre` (its view turning
/// with it, its projection kept).
pub fn orbit(camera: &Camera, centre: glam::Vec3, degrees: f32) -> Result<Camera, tiledlight_cull::CullError> {
    let moved =
        Mat4::from_translation(centre) * Mat4::from_rotation_y(degrees.to_radians()) * Mat4::from_translation(-centre);
    Camera::from_view(camera.view() * moved.inverse(), camera.projection())
}

/// [`measure`] with a progress bar of its frames on stderr (`what` beside it), cleared
/// when done: for commands whose own frames take long (bench, render, the quick start).
pub fn measure_shown(
    prep: &Prepared,
    renderer: &mut FrameRenderer,
    (warmup, frames): (u32, u32),
    animator: Option<&mut LightAnimator>,
    what: &str,
) -> Result<Measurement> {
    let pb = crate::axes::frames_progress(warmup + frames, what);
    let m = measure_with(prep, renderer, (warmup, frames), animator, &pb);
    pb.finish_and_clear();
    m
}

/// [`measure`], with the lights moved by `animator` (made for `prep`'s lights), one
/// [`MOVE_STEP_S`] before every frame, when it is given.
pub fn measure_moving(
    prep: &Prepared,
    renderer: &mut FrameRenderer,
    warmup: u32,
    frames: u32,
    animator: Option<&mut LightAnimator>,
) -> Result<Measurement> {
    measure_with(prep, renderer, (warmup, frames), animator, &indicatif::ProgressBar::hidden())
}

/// [`measure_moving`], stepping `pb` once a frame (warm-up frames past `warmup`, run until
/// the clocks are up, lengthen it).
fn measure_with(
    prep: &Prepared,
    renderer: &mut FrameRenderer,
    (warmup, frames): (u32, u32),
    animator: Option<&mut LightAnimator>,
    pb: &indicatif::ProgressBar,
) -> Result<Measurement> {
    measure_along(prep, renderer, (warmup, frames), (animator, 0.0), pb)
}

/// [`measure_with`], the camera orbiting `orbit` degrees a frame ([`measure_orbiting`]; 0:
/// still).
fn measure_along(
    prep: &Prepared,
    renderer: &mut FrameRenderer,
    (warmup, frames): (u32, u32),
    (mut animator, orbit): (Option<&mut LightAnimator>, f32),
    pb: &indicatif::ProgressBar,
) -> Result<Measurement> {
    let ctx = &prep.ctx;
    let mut timer = GpuTimer::new(ctx).context("creating the GPU timer")?;
    let mut out = Measurement { timestamps: timer.enabled(), ..Default::default() };
    // `left`: measured frames still to come after this one (the orbit's steps back).
    let mut frame = |timer: &mut GpuTimer, renderer: &mut FrameRenderer, grids: Option<&mut Measurement>, left: u32| {
        // The last finished frame's light-grid headers: grow a grid that was too small.
        // (Never waits: it cannot fail on a read-back.) The VPL grid's header is copied
        // after its culling as the light grid's is; it never grows, so its status is only
        // reported.
        let between = renderer.between_frames(ctx, false).unwrap_or_default();
        let (status, blended, vpl) = (between.status, between.blended, between.vpl);
        if let Some(m) = grids {
            m.grid.extend(status);
            m.blended_grid.extend(blended);
            m.vpl_grid.extend(vpl);
        }
        let mut step = || -> Result<()> {
            if let Some(a) = animator.as_deref_mut() {
                a.advance(&ctx.queue, &prep.lights, MOVE_STEP_S);
                renderer.lights_moved(&ctx.queue, a.current()).context("moving the lights' shadows")?;
            }
            let mut encoder =
                ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bench.frame") });
            let moved = (orbit != 0.0).then(|| orbit_camera(prep, orbit, left)).transpose()?;
            renderer.record(&ctx.queue, &mut encoder, timer, &prep.scene_gpu, moved.as_ref().unwrap_or(&prep.camera));
            timer.resolve(&mut encoder);
            ctx.queue.submit([encoder.finish()]);
            timer.end_frame().context("ending a timed frame")?;
            lose_device_for_tests(ctx);
            ctx.device.poll(wgpu::PollType::wait_indefinitely()).context("waiting for the GPU")?;
            prep.check_gpu_errors_while("rendering a frame")
        };
        // After a device loss whatever failed next is a consequence: name the loss.
        step().map_err(|e| prep.device_lost().map_or(e, anyhow::Error::from))
    };
    // Warm-up: `warmup` frames, and at least MIN_WARMUP of them back to back, so a GPU
    // that idled (e.g. while the accuracy lab computed statistics on the CPU) has its
    // clocks up again before anything is measured. The profiler hands frames back in
    // submission order: the first `skip` are the warm-up's.
    let start = Instant::now();
    let mut skip = 0u32;
    let mut finished = 0u32;
    let drain = |timer: &mut GpuTimer, out: &mut Measurement, finished: &mut u32, skip: u32| {
        while let Some((f, span)) = timer.finished_frame_and_span() {
            if *finished >= skip {
                out.gpu_frames.push(f);
                out.gpu_span_ms.extend(span);
            }
            *finished += 1;
        }
    };
    while (skip < warmup || (warmup > 0 && start.elapsed() < MIN_WARMUP)) && skip < MAX_FRAMES {
        frame(&mut timer, renderer, None, frames)?;
        skip += 1;
        if skip > warmup {
            pb.inc_length(1);
        }
        pb.inc(1);
        ctx.device.poll(wgpu::PollType::Poll).context("polling the GPU")?;
        drain(&mut timer, &mut out, &mut finished, skip);
    }
    // The stochastic method's history holds the measured frames alone: the warm-up's length
    // depends on the GPU's speed (MIN_WARMUP), and a history of the warm-up's frames too
    // would make "after N frames" mean more frames on a faster GPU.
    renderer.restart_history();
    for k in 0..frames {
        let t0 = Instant::now();
        let mut grids = Measurement::default();
        frame(&mut timer, renderer, Some(&mut grids), frames - 1 - k)?;
        pb.inc(1);
        out.grid.append(&mut grids.grid);
        out.blended_grid.append(&mut grids.blended_grid);
        out.vpl_grid.append(&mut grids.vpl_grid);
        out.cpu_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        if let Some(a) = renderer.outputs().shadow_atlas {
            out.shadow_faces.push(a.faces_drawn_last_frame());
        }
        // The timestamp readback is mapped after the submit; the next poll delivers it.
        ctx.device.poll(wgpu::PollType::Poll).context("polling the GPU")?;
        drain(&mut timer, &mut out, &mut finished, skip);
    }
    // Frames still in flight: wait, then take what is left.
    for _ in 0..8 {
        if finished >= skip + frames || !out.timestamps {
            break;
        }
        ctx.device.poll(wgpu::PollType::wait_indefinitely()).context("waiting for the GPU")?;
        drain(&mut timer, &mut out, &mut finished, skip);
    }
    // Too few frames for a header to come back without waiting: the last frame's, read now
    // (after the timing), so whether the frames dropped lights is always known.
    let (device, queue) = (&ctx.device, &ctx.queue);
    if out.grid.is_empty() && frames > 0 {
        if let Some(g) = renderer.outputs().light_grid {
            out.grid.push(g.status(device, queue).context("reading the light grid's header back")?);
        }
    }
    if out.blended_grid.is_empty() && frames > 0 {
        if let Some(c) = renderer.outputs().blended.and_then(|b| b.culling.as_ref()) {
            out.blended_grid.push(c.grid.status(device, queue).context("reading the blended grid's header back")?);
        }
    }
    if out.vpl_grid.is_empty() && frames > 0 {
        if let Some(g) = renderer.outputs().vpl_light_grid {
            out.vpl_grid.push(g.status(device, queue).context("reading the VPL grid's header back")?);
        }
    }
    Ok(out)
}

/// The images of one frame: linear HDR and the tonemapped sRGB image (RGBA8), row-major.
#[derive(Clone, Debug)]
pub struct FrameImages {
    /// Linear HDR.
    pub hdr: Vec<[f32; 4]>,
    /// Tonemapped sRGB, RGBA8.
    pub ldr: Vec<u8>,
}

/// Records, submits and waits for one frame of `renderer` (growing a light grid that was
/// too small and rendering again, as `Diagnostics::render_once` does) and reads both its
/// images back: a single render, the GPU tests' frame and shadow-accuracy's.
pub fn render_frame(
    ctx: &GpuContext,
    renderer: &mut FrameRenderer,
    scene: &SceneGpu,
    camera: &Camera,
) -> Result<FrameImages, GpuError> {
    let mut timer = GpuTimer::new(ctx)?;
    renderer.render_once(ctx, &mut timer, scene, camera)?;
    Ok(FrameImages { hdr: renderer.read_hdr(ctx)?, ldr: renderer.read_ldr(ctx)? })
}

/// Frames rendered by this process (the test hook's count).
static FRAMES_RENDERED: AtomicU64 = AtomicU64::new(0);

/// Tests only: with `TILEDLIGHT_TEST_LOSE_DEVICE_AFTER=N`, destroys the device once the
/// process has submitted N frames, as a driver reset would lose it (wgpu then calls the
/// device-lost callback with the reason "destroyed"), so the message and the lab's resume
/// hint can be checked on any GPU. The frame loop here and the viewer's call it after each
/// submit.
pub fn lose_device_for_tests(ctx: &GpuContext) {
    let n = FRAMES_RENDERED.fetch_add(1, Ordering::Relaxed) + 1;
    let after = std::env::var("TILEDLIGHT_TEST_LOSE_DEVICE_AFTER").ok().and_then(|v| v.parse::<u64>().ok());
    if after == Some(n) {
        ctx.device.destroy();
    }
}

/// The mark of the times of a run that dropped lights (table rows, report lines).
pub const INCOMPLETE_MARK: &str = " *";

/// The table of pass times: pass | median | min | max | frames, a "total GPU" row (sum of
/// medians) and the CPU frame time. When a frame read back dropped lights, every time is
/// marked ([`INCOMPLETE_MARK`]) and a footnote says so.
pub fn table(m: &Measurement) -> String {
    let dropped = m.dropped();
    let mark = if dropped.any() { INCOMPLETE_MARK } else { "" };
    let mut s = String::new();
    if !m.timestamps {
        s.push_str("GPU pass times: not available (the adapter has no timestamp queries)\n");
    } else {
        let passes = m.passes();
        s.push_str(&format!("{:<22} {:>10} {:>10} {:>10} {:>7}\n", "pass", "median ms", "min", "max", "frames"));
        for p in &passes {
            let t = p.summary;
            s.push_str(&format!(
                "{:<22} {:>10.3} {:>10.3} {:>10.3} {:>7}{mark}\n",
                p.pass, t.median_ms, t.min_ms, t.max_ms, t.frames
            ));
        }
        let total: f64 = passes.iter().map(|p| p.summary.median_ms).sum();
        s.push_str(&format!("{:<22} {:>10.3}{mark}\n", "total GPU", total));
        if let Some(t) = Summary::of(&m.gpu_span_ms) {
            s.push_str(&format!(
                "{:<22} {:>10.3} {:>10.3} {:>10.3} {:>7}{mark}   (first pass's start to last pass's end: gaps included)\n",
                "GPU frame", t.median_ms, t.min_ms, t.max_ms, t.frames
            ));
        }
    }
    if let Some(c) = m.cpu() {
        s.push_str(&format!(
            "{:<22} {:>10.3} {:>10.3} {:>10.3} {:>7}{mark}   ({CPU_TIME_MEANING})\n",
            "CPU frame", c.median_ms, c.min_ms, c.max_ms, c.frames
        ));
    }
    if let Some(d) = dropped.mark() {
        s.push_str(&format!(
            "{}  times of INCOMPLETE frames: {d} (a light grid was full; see the warning)\n",
            INCOMPLETE_MARK.trim()
        ));
    }
    if let Some(g) = m.grid_line() {
        s.push_str(&format!("light grid: {g}\n"));
    }
    if let Some(l) = m.shadow_line() {
        s.push_str(&format!("shadows:    {l}\n"));
    }
    s
}

/// The JSON written by `--json`.
#[derive(Serialize)]
struct BenchJson {
    config: ConfigJson,
    frames: u32,
    warmup: u32,
    timestamps: bool,
    passes: Vec<PassSummary>,
    total_gpu_median_ms: Option<f64>,
    /// The frame's GPU time from its first timed pass's start to its last one's end: the
    /// passes plus the gaps and untimed work between them (null without timestamps).
    frame_gpu_first_to_last: Option<Summary>,
    cpu_frame: Option<Summary>,
    cpu_frame_measure: &'static str,
    /// GPU memory allocated, bytes per category.
    gpu_memory: Vec<(String, u64)>,
    gpu_memory_total: u64,
    /// Pixels of the last frame the MSAA edge test shaded per sample (Tiled Deferred, MSAA).
    edge_pixels: Option<u32>,
    /// (list, light) pairs of the last measured frame read back (tiled methods).
    light_pairs: Option<u32>,
    /// Screen tiles (16 px) the last frame listed for its large triangles (the visibility
    /// buffer's compute raster, large triangles by compute).
    large_tiles: Option<u32>,
    /// Lights dropped because the light grid was full, summed over the measured frames
    /// read back (0: every measured frame was complete; null without a light grid).
    dropped_lights: Option<u64>,
    /// Lists that lost lights, summed likewise.
    dropped_lists: Option<u64>,
    /// Measured frames read back that dropped lights (of any grid): their times are of
    /// incomplete frames.
    dropped_frames: Option<usize>,
    /// Measured frames whose light-grid header was read back.
    frames_read_back: Option<usize>,
    /// The blended geometry's own lists: lights dropped, summed over the measured frames
    /// read back (null without blended lists).
    blended_dropped_lights: Option<u64>,
    /// The blended geometry's lists that lost lights, summed likewise.
    blended_dropped_lists: Option<u64>,
    /// The VPLs' own lists (a fixed budget, `--vpl`): VPLs dropped, summed over the
    /// measured frames read back (null without VPL lists).
    vpl_dropped_lights: Option<u64>,
    /// The VPL lists that lost VPLs, summed likewise.
    vpl_dropped_lists: Option<u64>,
    /// What the scene was drawn despite (a missing texture, an unknown extension...), one
    /// sentence each naming the file, as the `warning:` lines say (empty: none).
    load_warnings: Vec<String>,
    /// VPLs the last frame made and those its cap refused (null without `--vpl`).
    vpls_kept: Option<u32>,
    vpls_refused: Option<u32>,
    /// Whether the lights moved before every frame (`--move-lights`).
    move_lights: bool,
    /// Shadow faces drawn per measured frame, smallest and largest (null without shadow
    /// casters; with still lights both are 0).
    shadow_faces_per_frame: Option<MinMax>,
    /// GPU memory of the shadow atlas and its face buffer (null without shadow casters).
    shadow_atlas_bytes: Option<u64>,
    /// The shadow atlas's layout, e.g. "atlas 1536x2304 x1 layer, 256 px tiles, 5x5 PCF,
    /// d16; 52 faces; 9.00 MiB" (null without shadow casters).
    shadow_atlas: Option<String>,
    /// Alpha-blended instances drawn each frame (null without blended geometry).
    blended_instances: Option<usize>,
    /// How they were composited: "sorted" or "wboit" (null without blended geometry).
    blend_mode: Option<&'static str>,
}

/// The smallest and largest of a count over the measured frames.
#[derive(Serialize)]
struct MinMax {
    min: u32,
    max: u32,
}

/// The `config` block of the lab's JSON reports (`bench --json`, shadow-accuracy's): what
/// was measured, where. Each report fills the parts it has; an absent part writes nothing,
/// so each report's JSON keeps its own fields in its own order.
#[derive(Clone, Debug, Serialize)]
pub struct ConfigJson {
    /// The adapter, as `GpuContext::describe` names it.
    pub adapter: String,
    /// "WxH".
    pub resolution: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The scene's name.
    pub scene: String,
    /// Triangles drawn.
    pub triangles: u64,
    /// Shadow-accuracy: the camera and the casters.
    #[serde(flatten)]
    pub casters: Option<CastersJson>,
    /// Bench: instances and lights.
    #[serde(flatten)]
    pub lights: Option<LightsJson>,
    /// Seed of the random lights.
    pub seed: u64,
    /// Light intensity threshold.
    pub threshold: f32,
    /// Shadow-accuracy: the one exposure of every configuration.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exposure: Option<f32>,
    /// The method's name.
    pub method: &'static str,
    /// Shadow-accuracy: the reference's and the timing's parameters.
    #[serde(flatten)]
    pub shadow_run: Option<ShadowRunJson>,
    /// Bench: the renderer's settings.
    #[serde(flatten)]
    pub renderer: Option<RendererJson>,
    /// The commit ([`commit_hash`]).
    pub commit: String,
}

impl ConfigJson {
    /// The parts every report has, of `prep`; the others absent.
    pub fn of(prep: &Prepared) -> Self {
        let a = &prep.settings;
        Self {
            adapter: prep.ctx.describe(),
            resolution: format!("{}x{}", a.width, a.height),
            width: a.width,
            height: a.height,
            scene: prep.scene_name.clone(),
            triangles: prep.scene_gpu.triangles,
            casters: None,
            lights: None,
            seed: a.seed,
            threshold: a.threshold,
            exposure: None,
            method: a.method.name(),
            shadow_run: None,
            renderer: None,
            commit: commit_hash(),
        }
    }
}

/// Bench's instances and lights ([`ConfigJson::lights`]).
#[derive(Clone, Debug, Serialize)]
#[allow(missing_docs)]
pub struct LightsJson {
    pub instances: usize,
    pub point_lights: usize,
    pub spot_lights: usize,
}

/// Shadow-accuracy's camera and casters ([`ConfigJson::casters`]).
#[derive(Clone, Debug, Serialize)]
#[allow(missing_docs)]
pub struct CastersJson {
    pub camera: String,
    pub point_casters: u32,
    pub spot_casters: u32,
    pub scene_point_lights: u64,
    pub scene_spot_lights: u64,
}

/// Shadow-accuracy's run parameters ([`ConfigJson::shadow_run`]).
#[derive(Clone, Debug, Serialize)]
#[allow(missing_docs)]
pub struct ShadowRunJson {
    pub ambient: f32,
    pub ray_offset: f32,
    pub frames: u32,
    pub warmup: u32,
}

/// Bench's renderer settings ([`ConfigJson::renderer`]).
#[derive(Clone, Debug, Serialize)]
#[allow(missing_docs)]
pub struct RendererJson {
    pub tile_size: u32,
    pub capacity: u32,
    pub aabb: bool,
    pub half_z: bool,
    pub spot_cone: bool,
    pub coarse: bool,
    pub msaa: u32,
    pub shadow_point_lights: u32,
    pub shadow_spot_lights: u32,
    /// How the casters were chosen: "brightness" or "contribution".
    pub casters_by: &'static str,
    pub transparent_objects: u32,
    /// The default scene's banners glow (`--emissive`: the emission target exists).
    pub emissive: bool,
    /// The pass settings, one key a row of `tiledlight_gpu::knobs` ([`knobs_json`]).
    #[serde(flatten)]
    pub knobs: KnobsJson,
}

/// The pass settings as JSON keys, in the table's order ([`knobs_json`]).
#[derive(Clone, Debug, PartialEq)]
pub struct KnobsJson(pub Vec<(&'static str, serde_json::Value)>);

impl Serialize for KnobsJson {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

/// The pass settings as JSON: one key a row ([`Knob::field`]), a switch as a boolean, a
/// count or number as a number, a choice as its name.
pub fn knobs_json(knobs: &Knobs) -> KnobsJson {
    use serde_json::Value;
    KnobsJson(
        KNOBS
            .iter()
            .map(|k: &Knob| {
                let text = (k.get)(knobs);
                let value = match k.kind {
                    Kind::Switch => Value::Bool(text == "on"),
                    Kind::Count | Kind::Number | Kind::Values(_) => {
                        serde_json::from_str::<serde_json::Number>(&text).map_or(Value::String(text), Value::Number)
                    }
                    Kind::Choice(_) | Kind::Text => Value::String(text),
                };
                (k.field, value)
            })
            .collect(),
    )
}

/// The commit the lab was built from (`TILEDLIGHT_COMMIT`, set by its build.rs), else
/// `git rev-parse HEAD` of the working directory, else "unknown".
pub fn commit_hash() -> String {
    if let Some(c) = option_env!("TILEDLIGHT_COMMIT").filter(|c| !c.is_empty()) {
        return c.to_string();
    }
    std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// Runs `tiledlight bench`.
pub fn run<F: Flags>(scene: &F, args: &Bench) -> Result<()> {
    ensure!((1..=MAX_FRAMES).contains(&args.frames), "--frames {}: must be between 1 and {MAX_FRAMES}", args.frames);
    ensure!(args.warmup <= MAX_FRAMES, "--warmup {}: must be at most {MAX_FRAMES}", args.warmup);
    if let Some(p) = &args.json {
        // Fail before minutes of rendering if the file cannot be written.
        crate::output::check_output("--json", p)?;
    }
    let prep = Prepared::new(&scene.settings()?)?;
    crate::output::print_load_warnings(&prep.scene_warnings);
    for (k, v) in prep.describe() {
        println!("{:<11} {v}", format!("{k}:"));
    }
    let mut renderer = prep.renderer(false)?;
    let motion = if args.move_lights { "lights moved before every frame (--move-lights)" } else { "lights still" };
    println!("frames:     {} warm-up + {} measured, {motion}", args.warmup, args.frames);
    let mut animator = args.move_lights.then(|| LightAnimator::new(&prep.lights.packed, prep.bounds.center()));
    let m = measure_shown(&prep, &mut renderer, (args.warmup, args.frames), animator.as_mut(), "bench")?;
    // The times of a traced frame the driver cut short are of work it did not do.
    renderer.check_traced_complete(&prep.ctx)?;
    print!("{}", table(&m));
    let atlas = renderer.outputs().shadow_atlas;
    if let Some(a) = atlas {
        println!("shadow map: {}", shadow_atlas_description(a));
    }
    let blended = renderer.outputs().blended;
    if let Some(b) = blended {
        let s = if b.instance_count() == 1 { "" } else { "s" };
        println!("blend path: {} instance{s}, {}", b.instance_count(), blend_mode_description(b.mode()));
    }
    let edge_pixels = renderer.edge_pixels(&prep.ctx).context("reading the MSAA edge count back")?;
    if let Some(e) = edge_pixels {
        let pixels = f64::from(prep.settings.width) * f64::from(prep.settings.height);
        println!("MSAA edges: {e} pixels ({:.2}%) shaded per sample", 100.0 * f64::from(e) / pixels);
    }
    let large_tiles = renderer.large_tiles(&prep.ctx).context("reading the large triangles' tile count back")?;
    if let Some(t) = large_tiles {
        println!("large triangles: {t} screen tiles of 16 px listed in the last frame");
    }
    let vpls = renderer.vpl_count(&prep.ctx).context("reading the VPL count back")?;
    if let Some((kept, refused)) = vpls {
        println!("VPLs: {kept} made in the last frame, {refused} refused by the cap (of {})", kept + refused);
    }
    println!("GPU memory:\n{}", renderer.memory());
    let dropped = m.dropped();
    if let Some(path) = &args.json {
        let a = &prep.settings;
        let passes = m.passes();
        let json = BenchJson {
            config: ConfigJson {
                lights: Some(LightsJson {
                    instances: prep.instances,
                    point_lights: prep.light_summary.point,
                    spot_lights: prep.light_summary.spot,
                }),
                renderer: Some(RendererJson {
                    tile_size: a.tile_size,
                    capacity: a.capacity(),
                    aabb: a.aabb,
                    half_z: a.half_z,
                    spot_cone: a.spot_cone,
                    coarse: !a.flat_cull,
                    msaa: a.msaa,
                    shadow_point_lights: a.shadow_point_lights,
                    shadow_spot_lights: a.shadow_spot_lights,
                    casters_by: a.casters_by.name(),
                    transparent_objects: a.transparent_objects,
                    emissive: a.emissive,
                    knobs: knobs_json(&a.knobs),
                }),
                ..ConfigJson::of(&prep)
            },
            frames: args.frames,
            warmup: args.warmup,
            timestamps: m.timestamps,
            total_gpu_median_ms: m.timestamps.then(|| passes.iter().map(|p| p.summary.median_ms).sum()),
            passes,
            frame_gpu_first_to_last: Summary::of(&m.gpu_span_ms),
            cpu_frame: m.cpu(),
            cpu_frame_measure: CPU_TIME_MEANING,
            gpu_memory: renderer.memory().entries.clone(),
            gpu_memory_total: renderer.memory().total(),
            edge_pixels,
            light_pairs: m.grid.last().map(|g| g.header.pairs),
            large_tiles,
            dropped_lights: dropped.opaque.map(|g| g.pairs),
            dropped_lists: dropped.opaque.map(|g| g.lists),
            dropped_frames: dropped.frames_read().map(|_| dropped.frames()),
            frames_read_back: dropped.frames_read(),
            blended_dropped_lights: dropped.blended.map(|g| g.pairs),
            blended_dropped_lists: dropped.blended.map(|g| g.lists),
            vpl_dropped_lights: dropped.vpl.map(|g| g.pairs),
            vpl_dropped_lists: dropped.vpl.map(|g| g.lists),
            load_warnings: prep.scene_warnings.clone(),
            vpls_kept: vpls.map(|v| v.0),
            vpls_refused: vpls.map(|v| v.1),
            move_lights: args.move_lights,
            shadow_faces_per_frame: m.shadow_faces_range().map(|(min, max)| MinMax { min, max }),
            shadow_atlas_bytes: atlas.map(|a| a.memory.total()),
            shadow_atlas: atlas.map(shadow_atlas_description),
            blended_instances: blended.map(|b| b.instance_count()),
            blend_mode: blended.map(|b| b.mode().name()),
        };
        let text = serde_json::to_string_pretty(&json).context("encoding the results as JSON")?;
        std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    let mut warnings = 0;
    let max_binding = prep.ctx.device.limits().max_storage_buffer_binding_size;
    if let Some(w) = dropped.warning("the measured frames", prep.settings.grid_pairs, max_binding) {
        dropped::warn(&mut warnings, &w);
    }
    if let Some(w) = vpls.and_then(|c| crate::dropped::refused_line("the measured frames", c)) {
        dropped::warn(&mut warnings, &w);
    }
    dropped::strict(prep.settings.strict, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_statistics() {
        assert_eq!(Summary::of(&[]), None);
        let s = Summary::of(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((s.median_ms, s.min_ms, s.max_ms, s.frames), (2.0, 1.0, 3.0, 3));
        assert_eq!(Summary::of(&[4.0, 1.0, 2.0, 3.0]).unwrap().median_ms, 2.5);
    }

    #[test]
    fn passes_keep_their_order() {
        let f = |a: f64, b: f64| vec![PassTime { label: "z".into(), ms: a }, PassTime { label: "a".into(), ms: b }];
        let m = Measurement {
            gpu_frames: vec![f(1.0, 2.0), f(3.0, 4.0)],
            cpu_ms: vec![5.0],
            gpu_span_ms: vec![3.5, 7.5],
            timestamps: true,
            grid: Vec::new(),
            blended_grid: Vec::new(),
            vpl_grid: Vec::new(),
            shadow_faces: Vec::new(),
        };
        let p = m.passes();
        assert_eq!(p[0].pass, "z");
        assert_eq!(p[0].summary.median_ms, 2.0);
        assert_eq!(p[1].pass, "a");
        let t = table(&m);
        assert!(t.contains("total GPU"), "{t}");
        assert!(t.contains("CPU frame"), "{t}");
        assert!(t.contains("GPU frame                   5.500      3.500      7.500       2"), "{t}");
        assert!(!t.contains("shadow"), "no shadow line without casters: {t}");
        assert_eq!(m.shadow_line(), None);
        let still = Measurement { shadow_faces: vec![0, 0, 0], ..m.clone() };
        assert_eq!(still.shadow_faces_range(), Some((0, 0)));
        assert!(table(&still).contains("shadows:    0 shadow faces drawn per measured frame"));
        let moving = Measurement { shadow_faces: vec![52, 48, 52], ..m };
        assert_eq!(moving.shadow_line().unwrap(), "48 to 52 shadow faces drawn per measured frame");
    }

    #[test]
    fn each_report_keeps_its_config_fields_in_their_order() {
        let common = ConfigJson {
            adapter: "a".into(),
            resolution: "2x1".into(),
            width: 2,
            height: 1,
            scene: "default".into(),
            triangles: 3,
            casters: None,
            lights: None,
            seed: 1,
            threshold: 0.5,
            exposure: None,
            method: "brute-force",
            shadow_run: None,
            renderer: None,
            commit: "c".into(),
        };
        let keys = |c: &ConfigJson| -> Vec<String> {
            let text = serde_json::to_string(c).unwrap();
            let v: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&text).unwrap();
            // serde_json's map is sorted unless preserve_order: read the order from the text.
            let mut k: Vec<(usize, String)> =
                v.keys().map(|k| (text.find(&format!("\"{k}\":")).unwrap(), k.clone())).collect();
            k.sort();
            k.into_iter().map(|(_, k)| k).collect()
        };
        let bench = ConfigJson {
            lights: Some(LightsJson { instances: 1, point_lights: 2, spot_lights: 0 }),
            renderer: Some(RendererJson {
                tile_size: 16,
                capacity: 8,
                aabb: false,
                half_z: false,
                spot_cone: false,
                coarse: true,
                msaa: 1,
                shadow_point_lights: 0,
                shadow_spot_lights: 0,
                casters_by: "brightness",
                transparent_objects: 0,
                emissive: false,
                knobs: knobs_json(&Knobs { edge_distance: 0.1, ..Knobs::default() }),
            }),
            ..common.clone()
        };
        // The fields and order of bench's `config`: those before the two schemas became one,
        // then one key a row of the pass settings' table.
        // The rows' keys come from the table itself: a new row needs no edit here.
        let before_rows = "adapter resolution width height scene triangles instances point_lights spot_lights seed \
             threshold method tile_size capacity aabb half_z spot_cone coarse msaa shadow_point_lights shadow_spot_lights \
             casters_by transparent_objects emissive";
        let mut bench_keys: Vec<&str> = before_rows.split_whitespace().collect();
        bench_keys.extend(tiledlight_gpu::knobs::KNOBS.iter().map(|k| k.field));
        bench_keys.push("commit");
        assert_eq!(keys(&bench), bench_keys);
        // The table's rows as they were when the schemas became one, first and in order.
        let first_rows = "early_outs gbuffer_rts draw_order raster raster_large_px raster_large surface_edges";
        assert!(keys(&bench).join(" ").contains(first_rows));
        // The rows' values by kind: a switch a boolean, a count or number a number, a choice
        // its name (scripts read `config.early_outs` as a boolean).
        let v = serde_json::to_value(&bench).unwrap();
        assert_eq!(v["early_outs"], serde_json::json!(true));
        assert_eq!(v["gbuffer_rts"], serde_json::json!(2));
        // A row of whole numbers is written as a number, as the flag was before it was a row.
        assert_eq!((&v["shadow_filter"], &v["shadow_format"]), (&serde_json::json!(5), &serde_json::json!("d16")));
        assert_eq!(v["edge_distance"], serde_json::json!(0.1));
        assert_eq!(v["draw_order"], serde_json::json!("front-to-back"));
        assert_eq!(v["raster"], serde_json::json!("auto"));
        let shadow = ConfigJson {
            casters: Some(CastersJson {
                camera: "x".into(),
                point_casters: 1,
                spot_casters: 1,
                scene_point_lights: 4,
                scene_spot_lights: 4,
            }),
            exposure: Some(1.0),
            shadow_run: Some(ShadowRunJson { ambient: 0.0, ray_offset: 1e-3, frames: 2, warmup: 1 }),
            ..common
        };
        // ...and shadow-accuracy's.
        let shadow_keys = "adapter resolution width height scene triangles camera point_casters spot_casters \
             scene_point_lights scene_spot_lights seed threshold exposure method ambient ray_offset frames warmup commit";
        assert_eq!(keys(&shadow).join(" "), shadow_keys.split_whitespace().collect::<Vec<_>>().join(" "));
    }
}
