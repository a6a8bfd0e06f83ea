//! A soak run (issue 43): 2,000 frames on one GPU context at 64x36, the lights moving every
//! frame (`LightAnimator`, with `Renderer::lights_moved` so shadows follow) and the camera
//! orbiting every frame, the settings changing every 100 frames through
//! `Prepared::reconfigure` (method: Forward+, Tiled Deferred, visibility buffer; MSAA 1 and
//! 4; grid layouts: tiles, half-z, 2.5D, clusters, light-centric assignment; shadows on
//! and off). Ten configurations, each run twice (frames 0-999, then again 1,000-1,999),
//! each time by a renderer built after the reconfigure, as the viewer does.
//!
//! What must hold, frame by frame:
//! - **Memory as reported stays flat** (`MemoryReport`, what `render`, `bench` and the
//!   viewer print). The rule: a renderer's report changes only in a frame whose
//!   `between_frames` says a grid grew, and then only its light grid's index buffer
//!   (`*.indices`), upwards; it grows at most `ceil(log_1.25(lists x lights / first
//!   capacity))` times (each growth takes a quarter more than the frame needed, and no
//!   frame needs more than every list holding every light). A configuration run the second
//!   time starts from exactly the report of its first run (renderer, scene and lights),
//!   so nothing accumulates across reconfigures.
//! - **Nothing is dropped unannounced**: every frame's grid header counts every pair the
//!   grid could not hold as dropped (`dropped_pairs == pairs - capacity` when it
//!   overflows, 0 otherwise), and a frame that dropped pairs is announced by
//!   `between_frames` growing the grid (`grew`); no wgpu error is raised at any point.
//!
//! Timing on lavapipe (2 cores, alone): 126 s for 1,000 frames (the configurations with
//! MSAA 4x or shadows take 10-20 s a turn, the others 6-8 s), about 250 s for the run.

use std::time::Instant;

use glam::{Mat4, Quat, Vec3};
use tiledlight_cull::{Camera, ClusterConfig};
use tiledlight_frame::{FrameRenderer, Renderer};
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_setup::{LightAnimator, Method, Prepared, Settings};

/// Frames of the run, and of each configuration's turn.
const FRAMES: usize = 2_000;
const SEGMENT: usize = 100;

/// The ten configurations (each a change of method, MSAA, grid layout or shadows from
/// the one before, so every reconfigure rebuilds the renderer).
fn configurations(base: &Settings) -> Vec<Settings> {
    let clusters = Some(ClusterConfig { tile_size: 16, slices: 16, first: 1.0, last: 60.0, geometry_only: true });
    // The smallest shadow tile: every frame moves the lights, so every face is drawn again.
    let shadows = |s: Settings| Settings {
        shadow_point_lights: 1,
        shadow_spot_lights: 1,
        knobs: tiledlight_gpu::knobs::Knobs { shadow_size: 128, ..s.knobs },
        ..s
    };
    let b = || base.clone();
    vec![
        b(),
        Settings { method: Method::TiledDeferred, half_z: true, ..b() },
        Settings { method: Method::Visibility, depth_mask: true, ..b() },
        Settings { msaa: 4, clusters, ..b() },
        shadows(Settings { method: Method::TiledDeferred, msaa: 4, scatter: true, ..b() }),
        shadows(Settings { method: Method::Visibility, ..b() }),
        shadows(Settings { half_z: true, ..b() }),
        Settings { method: Method::TiledDeferred, clusters, ..b() },
        Settings { method: Method::Visibility, msaa: 4, scatter: true, ..b() },
        shadows(Settings { msaa: 4, depth_mask: true, ..b() }),
    ]
}

/// The camera of frame `i`: the scene's camera orbiting its target, a degree a frame, and
/// bobbing up and down by half a metre.
fn camera_at(start: &Camera, target: Vec3, i: usize) -> Camera {
    let eye = start.eye();
    let rot = Quat::from_rotation_y((i as f32).to_radians());
    let eye = target + rot * (eye - target) + Vec3::Y * 0.5 * (i as f32 * 0.05).sin();
    Camera::from_view(Mat4::look_at_rh(eye, target, Vec3::Y), start.projection()).expect("orbit camera")
}

/// Checks one frame's grid header: every pair the grid could not hold is counted as
/// dropped (none lost uncounted), and a frame that dropped pairs grew its grid.
fn check_grid(status: &tiledlight_gpu::light_grid::GridStatus, grew: bool, what: &str) {
    let h = &status.header;
    assert_eq!(h.dropped_pairs, h.pairs.saturating_sub(h.capacity), "{what}: pairs lost uncounted: {status}");
    assert!(h.dropped_pairs == 0 || grew, "{what}: a frame dropped pairs and the grid did not grow: {status}");
}

/// The report entries that differ between `a` and `b` (by category; either side missing
/// one counts as 0).
fn changed(a: &MemoryReport, b: &MemoryReport) -> Vec<(String, u64, u64)> {
    let mut names: Vec<&String> = a.entries.iter().chain(&b.entries).map(|(c, _)| c).collect();
    names.sort();
    names.dedup();
    names.into_iter().filter(|c| a.get(c) != b.get(c)).map(|c| (c.clone(), a.get(c), b.get(c))).collect()
}

#[test]
fn two_thousand_frames_of_moving_lights_and_changing_settings_keep_memory_flat() {
    let start = Instant::now();
    let base = Settings { width: 64, height: 36, lights: Some(64), spot_lights: Some(16), ..Settings::default() };
    let configs = configurations(&base);
    let mut prep = Prepared::new(&configs[0]).unwrap();
    let target = prep.bounds.center();
    let first_camera = prep.camera;
    let mut timer = GpuTimer::new(&prep.ctx).unwrap();
    // Per configuration: (renderer's report at build, scene + lights reports) of its first turn.
    let mut first_turn: Vec<Option<(MemoryReport, MemoryReport)>> = vec![None; configs.len()];
    let mut grows_total = 0;
    let mut frame = 0;
    while frame < FRAMES {
        let turn = frame / SEGMENT;
        let c = turn % configs.len();
        let settings = &configs[c];
        if frame > 0 {
            let plan = prep.reconfigure(settings).unwrap();
            assert!(plan.renderer, "turn {turn}: configuration {c} must rebuild the renderer");
        }
        let mut r: FrameRenderer = prep.renderer(false).unwrap();
        let mut animator = LightAnimator::new(&prep.lights.packed, target);
        let mut prepared = MemoryReport::default();
        prepared.extend(&prep.scene_gpu.memory);
        prepared.extend(&prep.lights.memory);
        let built = r.memory().clone();
        match &first_turn[c] {
            None => first_turn[c] = Some((built.clone(), prepared)),
            Some((r0, p0)) => {
                assert_eq!(changed(r0, &built), vec![], "turn {turn}: configuration {c}'s renderer reports otherwise");
                assert_eq!(changed(p0, &prepared), vec![], "turn {turn}: the scene and lights report otherwise");
            }
        }
        let grid = r.outputs().light_grid.expect("every configuration is tiled");
        let (lists, first_capacity) = (grid.list_count() as f64, grid.capacity() as f64);
        let most_pairs = lists * prep.lights.len() as f64;
        let max_grows = (most_pairs / first_capacity).ln().max(0.0) / 1.25f64.ln();
        let max_grows = max_grows.ceil() as u32;
        let mut grows = 0;
        let mut memory = built;
        for _ in 0..SEGMENT {
            let what = format!("frame {frame} (configuration {c}: {})", settings.method.name());
            animator.advance(&prep.ctx.queue, &prep.lights, 1.0 / 30.0);
            r.lights_moved(&prep.ctx.queue, animator.current()).unwrap();
            let camera = camera_at(&first_camera, target, frame);
            let mut encoder =
                prep.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("soak") });
            r.record(&prep.ctx.queue, &mut encoder, &timer, &prep.scene_gpu, &camera);
            timer.resolve(&mut encoder);
            prep.ctx.queue.submit([encoder.finish()]);
            timer.end_frame().unwrap();
            while timer.finished_frame().is_some() {}
            // Reads the headers of this frame (waits for it), as single renders do.
            let between = r.between_frames(&prep.ctx, true).unwrap();
            let status = between.status.expect("a tiled method reads its grid's header");
            check_grid(&status, between.grew, &what);
            let now = r.memory().clone();
            let diff = changed(&memory, &now);
            if !diff.is_empty() {
                assert!(between.grew, "{what}: memory changed without a grid growing: {diff:?}");
                for (category, before, after) in &diff {
                    assert!(
                        category.ends_with(".indices") && after > before,
                        "{what}: a growth changed {category} from {before} to {after}"
                    );
                }
            }
            if between.grew {
                grows += 1;
            }
            memory = now;
            frame += 1;
        }
        assert!(grows <= max_grows, "turn {turn}: the grid grew {grows} times, at most {max_grows} can be needed");
        grows_total += grows;
        prep.check_gpu_errors().unwrap();
        eprintln!("turn {turn} (configuration {c}) done at {:.1} s", start.elapsed().as_secs_f64());
    }
    eprintln!("{FRAMES} frames, {grows_total} grid growths, {:.1} s", start.elapsed().as_secs_f64());
}
