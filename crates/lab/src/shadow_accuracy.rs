//! `tiledlight shadow-accuracy`: the shadow maps' own error, against a CPU ray-cast
//! reference, per shadow configuration (atlas tile size x filter x depth format), with
//! the time of the shadow atlas pass and of shading, on a Pareto chart.
//!
//! `tiledlight accuracy` compares each setting with a brute-force image that draws the
//! same shadow maps, so it cannot see their error. Here only the shadow casters are lit
//! (every other light removed), ambient is 0 and the renderer is brute force with the
//! radius cutoff, so the image is exactly the casters' light with their shadows:
//!
//! - **Reference** (once): each caster k rendered alone without shadows (a light buffer
//!   holding that light only) gives its unshadowed contribution `U_k` (linear HDR); the
//!   depth buffer gives each pixel's surface point and normal
//!   ([`tiledlight_cull::raycast::surface_points`]); a ray cast from the point, offset
//!   along the normal by `--ray-offset` times its distance to the light, to caster k gives
//!   its visibility `V_k` in {0, 1} ([`tiledlight_cull::raycast::Triangles::occluded`],
//!   the same offset cut off both ends), on every core (`std::thread::scope`). The
//!   reference is `R = sum_k V_k U_k`. Pixels without a surface point (sky, silhouettes
//!   whose normal the depth buffer cannot give) are not scored: `R` takes the shadowed
//!   image's value there.
//! - **Per configuration**: one renderer with every caster casting shadows; its first
//!   frame (which draws every face) is the image `S`, compared with `R`: the visibility
//!   error `sum |L(S) - L(R)| / sum L(R)` over the scored pixels (L = Rec. 709 luminance:
//!   the share of the casters' light that is misplaced), split into light lost (`S` darker)
//!   and leaked (`S` brighter); PSNR on linear HDR and FLIP on the images tonemapped on the
//!   CPU with the GPU's curve (tiledlight-metrics' `tonemap`), as the accuracy lab measures. Then the lights
//!   move before every frame (`bench --move-lights`' animation), so every face is drawn
//!   every frame, and the median GPU time of the atlas pass (`shadow.atlas*`) and of the
//!   shading pass over `--frames` frames is recorded.
//!
//! Output: a table on stdout, JSON (`--out`), a Pareto chart (time vs visibility error,
//! `--chart`), the reference image, and for the frontier's configurations the FLIP heat
//! maps and pictures of the misplaced light (tiledlight-metrics' `visibility::misplaced_rgb`)
//! (`--diff-dir`). May depend on [`crate::accuracy`], [`crate::bench`],
//! [`crate::chart`], [`crate::axes`], [`crate::output`], tiledlight-setup,
//! tiledlight-gpu, tiledlight-forward, tiledlight-cull and tiledlight-metrics.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, ensure, Context, Result};
use glam::Vec3;
use serde::Serialize;
use tiledlight_cull::light::shadow_casters;
use tiledlight_cull::raycast::{surface_points, SurfacePoint, Triangles};
use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat, ShadowOptions, TILE_SIZES};
use tiledlight_cull::Light;
use tiledlight_frame::Diagnostics as _;
use tiledlight_frame::{FrameRenderer, FrameSettings};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::{ContextOptions, GpuContext};
use tiledlight_metrics::tonemap::tonemap;
use tiledlight_metrics::visibility::{misplaced_rgb, visibility_error};
use tiledlight_metrics::{flip, luminance, HdrError};
use tiledlight_setup::settings::shadow_options_description;
use tiledlight_setup::{group_digits, LightAnimator, Method, Prepared, SceneCpu, Settings};

use crate::accuracy::PERCENTILE;
use crate::axes::{self, Flags};
use crate::bench::{self, CastersJson, ConfigJson, PassSummary, ShadowRunJson, MAX_FRAMES};
use crate::chart::{self, ParetoChart, ParetoPoint};

/// The configurations measured when no `--config` is given: every tile size times every
/// filter with 16-bit depth, and 32-bit depth at the largest tile and filter.
pub const DEFAULT_CONFIGS: [&str; 13] = [
    "128x1",
    "128x3",
    "128x5",
    "256x1",
    "256x3",
    "256x5",
    "512x1",
    "512x3",
    "512x5",
    "1024x1",
    "1024x3",
    "1024x5",
    "1024x5:d32",
];

/// Shadow-casting (point, spot) lights when neither `--shadow-point-lights` nor
/// `--shadow-spot-lights` is given.
pub const DEFAULT_CASTERS: (u32, u32) = (12, 12);

/// Random spot lights when `--spot-lights` is not given and spot lights cast shadows:
/// the spot casters are the brightest of these.
pub const DEFAULT_SPOT_LIGHTS: u64 = 128;

/// The default resolution, as clap's default values of `--width` and `--height`
/// (`main.rs`): the CPU ray cast (one ray per pixel and caster that the caster lights)
/// must stay affordable.
pub const DEFAULT_SIZE: (&str, &str) = ("960", "540");

/// A shadow-accuracy run (the app's `shadow-accuracy` flags besides the scene's).
#[derive(Clone, Debug)]
pub struct ShadowAccuracy {
    /// Shadow configurations, `TILExFILTER[:FORMAT]` each [default: [`DEFAULT_CONFIGS`]].
    pub configs: Vec<String>,
    /// Measured frames per configuration.
    pub frames: u32,
    /// Frames rendered before measuring each configuration.
    pub warmup: u32,
    /// The reference's ray offset (a fraction of the distance to the light).
    pub ray_offset: f32,
    /// JSON output [default: out/shadow-accuracy.json].
    pub out: Option<PathBuf>,
    /// Pareto chart [default: the JSON path with .png].
    pub chart: Option<PathBuf>,
    /// Directory of the reference image and the frontier's pictures [default: the JSON
    /// path without extension, plus "-images"].
    pub diff_dir: Option<PathBuf>,
}

/// Parses one `--config` value, `TILExFILTER[:FORMAT]`.
pub fn parse_config(spec: &str) -> Result<ShadowOptions> {
    let (size, format) = match spec.split_once(':') {
        Some((s, f)) => (s, f.trim()),
        None => (spec, "d16"),
    };
    let (tile, filter) =
        size.split_once('x').with_context(|| format!("--config {spec}: expected TILExFILTER[:FORMAT], e.g. 512x3"))?;
    let tile: u32 = tile.trim().parse().with_context(|| format!("--config {spec}: tile '{tile}' is not an integer"))?;
    ensure!(
        TILE_SIZES.contains(&tile),
        "--config {spec}: tile {tile} must be between {} and {} texels",
        TILE_SIZES.start(),
        TILE_SIZES.end()
    );
    let taps: u32 =
        filter.trim().parse().with_context(|| format!("--config {spec}: filter '{filter}' is not an integer"))?;
    let filter = ShadowFilter::from_size(taps)
        .map_err(|_| anyhow::anyhow!("--config {spec}: filter {taps} must be 1, 3 or 5"))?;
    let format = ShadowFormat::from_name(format)
        .map_err(|_| anyhow::anyhow!("--config {spec}: format '{format}' must be d16 or d32"))?;
    Ok(ShadowOptions { tile_size: tile, filter, format })
}

/// The settings of a run: `scene` with this command's defaults (casters, spot lights; the
/// resolution's is the app's) and brute force.
pub fn settings_of<F: Flags>(scene: &F) -> Result<Settings> {
    let mut scene = scene.clone();
    let plain = scene.plain();
    if (plain.shadow_point_lights, plain.shadow_spot_lights) == (0, 0) {
        scene.set_axis("shadow-point-lights", &DEFAULT_CASTERS.0.to_string())?;
        scene.set_axis("shadow-spot-lights", &DEFAULT_CASTERS.1.to_string())?;
    }
    let plain = scene.plain();
    if plain.spot_lights.is_none() && plain.shadow_spot_lights > 0 {
        scene.set_axis("spot-lights", &DEFAULT_SPOT_LIGHTS.to_string())?;
    }
    ensure!(plain.msaa == 1, "--msaa {}: shadow-accuracy scores pixel centres, MSAA must be 1", plain.msaa);
    let mut settings = scene.settings()?;
    settings.method = Method::BruteForce { cutoff: true };
    Ok(settings)
}

/// Visibility of `light` from each surface point marked in `todo` (true = the light is
/// seen), cast on `threads` threads; unmarked pixels are reported visible.
pub fn ray_cast_visibility(
    tris: &Triangles,
    points: &[Option<SurfacePoint>],
    todo: &[bool],
    light: Vec3,
    offset: f32,
    threads: usize,
) -> Vec<bool> {
    let jobs: Vec<usize> = (0..points.len()).filter(|&i| todo[i] && points[i].is_some()).collect();
    let mut seen = vec![true; points.len()];
    if jobs.is_empty() {
        return seen;
    }
    let chunk = jobs.len().div_ceil(threads.max(1));
    let results: Vec<Vec<bool>> = std::thread::scope(|s| {
        let handles: Vec<_> = jobs
            .chunks(chunk)
            .map(|part| {
                s.spawn(move || {
                    part.iter()
                        .map(|&i| {
                            let Some(p) = points[i] else { return true };
                            let eps = offset * (light - p.position).length();
                            !tris.occluded(p.position + p.normal * eps, light, eps)
                        })
                        .collect::<Vec<bool>>()
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("a ray-cast thread panicked")).collect()
    });
    for (&i, v) in jobs.iter().zip(results.into_iter().flatten()) {
        seen[i] = v;
    }
    seen
}

/// The ray-cast reference of one scene, caster set and camera.
struct Reference {
    hdr: Vec<[f32; 4]>,
    /// Pixels with a surface point (the others take the shadowed image's value).
    scored: Vec<bool>,
    /// Summed luminance of the casters' unshadowed light over the scored pixels.
    unshadowed: f64,
    /// Summed luminance of the reference over the scored pixels.
    lit: f64,
    /// Scored pixels the reference lights.
    lit_pixels: usize,
    rays: u64,
    ray_cast_s: f64,
    render_s: f64,
}

/// Renders each caster alone without shadows, ray-casts its visibility and sums.
fn reference(
    prep: &Prepared,
    casters: &[Light],
    tris: &Triangles,
    base: &FrameSettings,
    offset: f32,
    threads: usize,
) -> Result<Reference> {
    let ctx = &prep.ctx;
    let (w, h) = (prep.settings.width, prep.settings.height);
    let n = (w * h) as usize;
    let mut timer = GpuTimer::new(ctx).context("creating the GPU timer")?;
    let mut out = Reference {
        hdr: vec![[0.0, 0.0, 0.0, 1.0]; n],
        scored: Vec::new(),
        unshadowed: 0.0,
        lit: 0.0,
        lit_pixels: 0,
        rays: 0,
        ray_cast_s: 0.0,
        render_s: 0.0,
    };
    let mut points: Vec<Option<SurfacePoint>> = Vec::new();
    let settings = FrameSettings { shadows: ShadowOptions::default(), ..*base };
    for (k, light) in casters.iter().enumerate() {
        let t0 = Instant::now();
        let lights = LightBuffers::new(&ctx.device, std::slice::from_ref(light))
            .with_context(|| format!("uploading caster {k} alone"))?;
        let mut r = FrameRenderer::new(ctx, &prep.scene_gpu, &lights, w, h, settings)
            .with_context(|| format!("building the renderer of caster {k} alone"))?;
        r.render_once(ctx, &mut timer, &prep.scene_gpu, &prep.camera)
            .with_context(|| format!("rendering caster {k} alone"))?;
        let u = r.read_hdr(ctx).context("reading a caster's image back")?;
        if k == 0 {
            let depth = r.read_depth(ctx).context("reading the depth buffer back")?;
            points = surface_points(&prep.camera, w, h, &depth);
            out.scored = points.iter().map(Option::is_some).collect();
        }
        prep.check_gpu_errors()?;
        out.render_s += t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let todo: Vec<bool> = u.iter().map(|p| luminance(p) > 0.0).collect();
        out.rays += todo.iter().zip(&out.scored).filter(|(a, b)| **a && **b).count() as u64;
        let seen = ray_cast_visibility(tris, &points, &todo, light.position, offset, threads);
        out.ray_cast_s += t0.elapsed().as_secs_f64();
        for (i, ((r, uk), seen)) in out.hdr.iter_mut().zip(&u).zip(&seen).enumerate() {
            if !out.scored[i] {
                continue;
            }
            out.unshadowed += luminance(uk);
            if *seen {
                for (rc, uc) in r.iter_mut().zip(uk).take(3) {
                    *rc += uc;
                }
            }
        }
    }
    for i in (0..n).filter(|&i| out.scored[i]) {
        let l = luminance(&out.hdr[i]);
        out.lit += l;
        out.lit_pixels += usize::from(l > 0.0);
    }
    Ok(out)
}

/// One measured configuration, as written to JSON.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Atlas tile size in texels.
    pub tile_size: u32,
    /// Filter taps per side.
    pub filter: u32,
    /// Depth format, "d16" or "d32".
    pub format: &'static str,
    /// GPU memory of the shadow atlas and its face buffer.
    pub atlas_bytes: u64,
    /// The same in MiB.
    pub atlas_mib: f64,
    /// The atlas's layout line.
    pub atlas: String,
    /// Faces drawn per measured frame (every caster's, as the lights move).
    pub faces_per_frame: u32,
    /// Median GPU time of the shadow atlas passes (`shadow.atlas*`), every face drawn.
    pub atlas_ms: f64,
    /// Median GPU time of the shading pass.
    pub shade_ms: f64,
    /// `atlas_ms + shade_ms`: the chart's time.
    pub shadow_frame_ms: f64,
    /// Every pass's median (and min, max).
    pub passes: Vec<PassSummary>,
    /// `sum |L(S) - L(R)| / sum L(R)` over the scored pixels.
    pub visibility_error: f64,
    /// The part of it where the shadow map is darker than the ray cast.
    pub light_lost: f64,
    /// The part of it where the shadow map is brighter (light leaks).
    pub light_leaked: f64,
    /// PSNR on linear HDR (peak: the reference's 99.9th percentile).
    pub psnr_db: f64,
    /// FLIP mean of the tonemapped images.
    pub flip_mean: f64,
    /// FLIP 99th percentile.
    pub flip_p99: f64,
    /// FLIP maximum.
    pub flip_max: f64,
    /// Largest difference, in 8-bit steps, between the GPU's tonemapped image and the CPU's
    /// tonemap of its HDR image (the FLIP inputs are the CPU's).
    pub tonemap_max_step: u8,
}

#[derive(Serialize)]
struct ReferenceJson {
    /// Pixels with a surface point (scored).
    scored_pixels: usize,
    /// Pixels without one (sky, silhouettes): R = S there.
    unscored_pixels: usize,
    /// Scored pixels the reference lights.
    lit_pixels: usize,
    /// Summed luminance of the reference over the scored pixels.
    luminance: f64,
    /// Share of the casters' unshadowed light the ray cast finds hidden.
    shadowed_share: f64,
    rays: u64,
    threads: usize,
    ray_cast_s: f64,
    render_s: f64,
}

#[derive(Serialize)]
struct Json<'a> {
    config: ConfigJson,
    reference: ReferenceJson,
    visibility_error_meaning: &'static str,
    configurations: &'a [Row],
}

const VISIBILITY_MEANING: &str = "sum over scored pixels of |L(S) - L(R)| / sum of L(R), L = Rec. 709 luminance of \
     linear HDR, S = shadow-mapped image, R = ray-cast reference: the share of the casters' light misplaced";

fn median(m: &bench::Measurement, pred: impl Fn(&str) -> bool) -> f64 {
    m.passes().iter().filter(|p| pred(&p.pass)).map(|p| p.summary.median_ms).sum()
}

/// Runs `tiledlight shadow-accuracy`.
pub fn run<F: Flags>(scene: &F, args: &ShadowAccuracy) -> Result<()> {
    ensure!((1..=MAX_FRAMES).contains(&args.frames), "--frames {}: must be between 1 and {MAX_FRAMES}", args.frames);
    ensure!(args.warmup <= MAX_FRAMES, "--warmup {}: must be at most {MAX_FRAMES}", args.warmup);
    ensure!(
        args.ray_offset.is_finite() && args.ray_offset > 0.0 && args.ray_offset < 0.1,
        "--ray-offset {}: must be in (0, 0.1)",
        args.ray_offset
    );
    let specs: Vec<String> = if args.configs.is_empty() {
        DEFAULT_CONFIGS.iter().map(|s| s.to_string()).collect()
    } else {
        args.configs.clone()
    };
    let configs: Vec<ShadowOptions> = specs.iter().map(|s| parse_config(s)).collect::<Result<_>>()?;
    for (i, c) in configs.iter().enumerate() {
        if configs[..i].contains(c) {
            bail!("--config {}: given twice", specs[i]);
        }
    }
    let settings = settings_of(scene)?;
    // Only the casters are lit here, so a ranking by contribution among all the lights
    // would need a frame of them all first: not done; the shadow maps' error does not
    // depend on which lights cast.
    ensure!(
        settings.casters_by == tiledlight_setup::CasterChoice::Brightness,
        "shadow-accuracy lights only the brightest casters: --casters-by {} is for render, bench and accuracy",
        settings.casters_by.name()
    );
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from("out/shadow-accuracy.json"));
    let chart_path = args.chart.clone().unwrap_or_else(|| axes::sibling(&out, "png"));
    let ext = chart_path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "--chart {}: only .png charts are supported", chart_path.display());
    let image_dir = args.diff_dir.clone().unwrap_or_else(|| {
        let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("shadow-accuracy");
        out.with_file_name(format!("{stem}-images"))
    });
    // Every output before the first frame: a bad path costs no rendering.
    crate::output::check_output("--out", &out)?;
    crate::output::check_output("--chart", &chart_path)?;
    crate::output::check_output_dir("--diff-dir", &image_dir)?;

    // The scene and its lights on the CPU; then only the casters are kept.
    let mut cpu = SceneCpu::load(&settings)?;
    crate::output::print_load_warnings(&cpu.warnings);
    let counts = settings.shadow_casters();
    let casters = shadow_casters(&cpu.lights, counts).context("choosing the shadow casters")?;
    let t0 = Instant::now();
    let tris = Triangles::new(cpu.scene.world_triangles());
    let bvh_s = t0.elapsed().as_secs_f64();
    cpu.lights = casters.clone();
    cpu.file_lights = 0;
    let ctx = GpuContext::headless(ContextOptions::default())
        .context("creating the GPU device (set WGPU_ADAPTER_NAME to pick an adapter)")?;
    let prep = Prepared::with_context(&settings, cpu, ctx)?;
    ensure!(prep.ctx.timestamps, "the adapter has no timestamp queries: shadow-accuracy needs GPU pass times");
    let a = &prep.settings;
    let (w, h) = (a.width, a.height);
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    println!("adapter:    {}", prep.ctx.describe());
    println!(
        "scene:      {}: {} triangles ({} in the ray cast's BVH, built in {bvh_s:.1} s), camera: {}",
        prep.scene_name,
        group_digits(prep.scene_gpu.triangles),
        group_digits(tris.len() as u64),
        prep.camera_source
    );
    let (scene_points, scene_spots) = a.random_light_counts();
    println!(
        "casters:    {} point + {} spot, the brightest of {scene_points} point and {scene_spots} spot lights (seed {}, threshold {}); only they are lit, ambient 0",
        counts.0, counts.1, a.seed, a.threshold
    );
    println!("resolution: {w}x{h}, brute force with the radius cutoff");

    // One fixed exposure for every configuration (the CPU tonemap below checks the GPU's):
    // with automatic exposure, the one the reference image gets.
    let mut base = FrameSettings { ambient: Vec3::ZERO, auto_exposure: false, ..a.frame_settings(false) };
    let reference = reference(&prep, &casters, &tris, &base, args.ray_offset, threads)?;
    let exposure = if a.auto_exposure {
        tiledlight_cull::exposure::auto_exposure(reference.hdr.as_flattened())
    } else {
        a.exposure
    };
    base.exposure = exposure;
    let n = (w * h) as usize;
    let scored_pixels = reference.scored.iter().filter(|s| **s).count();
    let shadowed_share = if reference.unshadowed > 0.0 { 1.0 - reference.lit / reference.unshadowed } else { f64::NAN };
    println!(
        "reference:  {} rays on {threads} threads in {:.1} s (renders {:.1} s); {} of {} pixels scored, {} lit; the ray cast hides {:.1}% of the casters' light",
        group_digits(reference.rays),
        reference.ray_cast_s,
        reference.render_s,
        group_digits(scored_pixels as u64),
        group_digits(n as u64),
        group_digits(reference.lit_pixels as u64),
        100.0 * shadowed_share
    );
    ensure!(reference.lit > 0.0, "the casters light no pixel of the view: nothing to measure");

    let mut rows: Vec<Row> = Vec::new();
    let mut heat: Vec<Vec<u8>> = Vec::new();
    let mut misplaced: Vec<Vec<u8>> = Vec::new();
    let mut ref_ldr = Vec::new();
    let pb = axes::progress(configs.len());
    for (ci, opts) in configs.iter().enumerate() {
        let what = format!("{} ({})", specs[ci], shadow_options_description(opts));
        pb.set_message(what.clone());
        let settings = FrameSettings { shadows: *opts, ..base };
        let mut r = FrameRenderer::new(&prep.ctx, &prep.scene_gpu, &prep.lights, w, h, settings)
            .with_context(|| format!("{what}: building the renderer"))?;
        // The first frame draws every face, with the lights where the reference has them.
        let frame =
            bench::render_frame(&prep.ctx, &mut r, &prep.scene_gpu, &prep.camera).with_context(|| what.clone())?;
        let (s, gpu_ldr) = (frame.hdr, frame.ldr);
        prep.check_gpu_errors()?;
        let atlas = r.outputs().shadow_atlas.context("internal: a renderer with casters has no shadow atlas")?;
        let faces = atlas.layout.faces();
        let (atlas_bytes, atlas_line) = (atlas.memory.total(), tiledlight_setup::shadow_atlas_description(atlas));
        // Unscored pixels: the reference is the image itself.
        let mut rhdr = reference.hdr.clone();
        for i in (0..n).filter(|&i| !reference.scored[i]) {
            rhdr[i] = s[i];
        }
        let (vis, lost, leaked) = visibility_error(&rhdr, &s, &reference.scored);
        let e = HdrError::of(&rhdr, &s);
        let (rl, sl) = (tonemap(&rhdr, exposure), tonemap(&s, exposure));
        let step = sl.iter().zip(&gpu_ldr).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0);
        let map = flip(w, h, &rl, &sl);
        let fl = map.summary(PERCENTILE);
        heat.push(map.heat_rgb());
        misplaced.push(misplaced_rgb(&rhdr, &s, exposure));
        if ci == 0 {
            ref_ldr = rl;
        }
        // Timing: the lights move before every frame, so every face is drawn each frame.
        let mut animator = LightAnimator::new(&prep.lights.packed, prep.bounds.center());
        let m = bench::measure_moving(&prep, &mut r, args.warmup, args.frames, Some(&mut animator))
            .with_context(|| what.clone())?;
        restore_lights(&prep);
        ensure!(m.timestamps && !m.passes().is_empty(), "{what}: no frame's timestamps came back");
        if let Some((lo, hi)) = m.shadow_faces_range() {
            ensure!(lo == faces && hi == faces, "{what}: measured frames drew {lo} to {hi} faces, not all {faces}");
        }
        let atlas_ms = median(&m, |p| p.starts_with("shadow.atlas"));
        let shade_ms = median(&m, |p| p.ends_with(".shade"));
        let row = Row {
            tile_size: opts.tile_size,
            filter: opts.filter.size(),
            format: opts.format.name(),
            atlas_bytes,
            atlas_mib: atlas_bytes as f64 / (1024.0 * 1024.0),
            atlas: atlas_line,
            faces_per_frame: faces,
            atlas_ms,
            shade_ms,
            shadow_frame_ms: atlas_ms + shade_ms,
            passes: m.passes(),
            visibility_error: vis,
            light_lost: lost,
            light_leaked: leaked,
            psnr_db: e.psnr_db,
            flip_mean: f64::from(fl.mean),
            flip_p99: f64::from(fl.percentile),
            flip_max: f64::from(fl.max),
            tonemap_max_step: step,
        };
        axes::say(
            &pb,
            format!(
                "{what}: atlas {atlas_ms:.3} ms + shade {shade_ms:.3} ms; visibility error {:.5} (lost {:.5}, leaked {:.5}), FLIP mean {:.5}, PSNR {:.2} dB",
                vis, lost, leaked, fl.mean, e.psnr_db
            ),
        );
        rows.push(row);
        pb.inc(1);
    }
    pb.finish_and_clear();
    print!("{}", table(&rows));

    let json = Json {
        config: ConfigJson {
            casters: Some(CastersJson {
                camera: prep.camera_source.clone(),
                point_casters: counts.0,
                spot_casters: counts.1,
                scene_point_lights: scene_points,
                scene_spot_lights: scene_spots,
            }),
            exposure: Some(exposure),
            shadow_run: Some(ShadowRunJson {
                ambient: 0.0,
                ray_offset: args.ray_offset,
                frames: args.frames,
                warmup: args.warmup,
            }),
            ..ConfigJson::of(&prep)
        },
        reference: ReferenceJson {
            scored_pixels,
            unscored_pixels: n - scored_pixels,
            lit_pixels: reference.lit_pixels,
            luminance: reference.lit,
            shadowed_share,
            rays: reference.rays,
            threads,
            ray_cast_s: reference.ray_cast_s,
            render_s: reference.render_s,
        },
        visibility_error_meaning: VISIBILITY_MEANING,
        configurations: &rows,
    };
    let text = serde_json::to_string_pretty(&json).context("encoding the results as JSON")?;
    std::fs::write(&out, text + "\n").with_context(|| format!("writing {}", out.display()))?;

    let frontier = draw_chart(&chart_path, &rows, &prep, counts, (&scene.scene_label(), args))?;
    let rgb: Vec<u8> = ref_ldr.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    let img = image::RgbImage::from_raw(w, h, rgb).context("building the reference image")?;
    crate::output::save_png(&image_dir.join("reference.png"), &img)?;
    for &i in &frontier {
        let name = format!("{}x{}-{}.png", rows[i].tile_size, rows[i].filter, rows[i].format);
        for (kind, rgb) in [("flip", &heat[i]), ("misplaced", &misplaced[i])] {
            let img = image::RgbImage::from_raw(w, h, rgb.clone()).context("building a heat map image")?;
            crate::output::save_png(&image_dir.join(format!("{kind}-{name}")), &img)?;
        }
    }
    let describe = |r: &Row| format!("{}x{}:{}", r.tile_size, r.filter, r.format);
    println!(
        "frontier:   {} of {} configurations: {}",
        frontier.len(),
        rows.len(),
        frontier.iter().map(|&i| describe(&rows[i])).collect::<Vec<_>>().join("; ")
    );
    println!("wrote {}, {} and {}", out.display(), chart_path.display(), image_dir.display());
    Ok(())
}

/// Writes the lights as uploaded back over the buffers the animator moved.
fn restore_lights(prep: &Prepared) {
    let (l, q) = (&prep.lights, &prep.ctx.queue);
    if l.packed.is_empty() {
        return;
    }
    q.write_buffer(&l.cull, 0, bytemuck::cast_slice(&l.packed.cull));
    q.write_buffer(&l.shading, 0, bytemuck::cast_slice(&l.packed.shading));
    if let Some(spots) = &l.spots {
        q.write_buffer(spots, 0, bytemuck::cast_slice(&l.packed.spots));
    }
}

/// The table printed at the end.
pub fn table(rows: &[Row]) -> String {
    let mut s = format!(
        "{:>5} {:>6} {:>6} {:>9} {:>9} {:>9} {:>10} {:>9} {:>9} {:>9} {:>8}\n",
        "tile",
        "filter",
        "format",
        "atlas MiB",
        "atlas ms",
        "shade ms",
        "vis error",
        "lost",
        "leaked",
        "FLIP mean",
        "PSNR dB"
    );
    for r in rows {
        s.push_str(&format!(
            "{:>5} {:>6} {:>6} {:>9.2} {:>9.3} {:>9.3} {:>10.5} {:>9.5} {:>9.5} {:>9.5} {:>8.2}\n",
            r.tile_size,
            format!("{0}x{0}", r.filter),
            r.format,
            r.atlas_mib,
            r.atlas_ms,
            r.shade_ms,
            r.visibility_error,
            r.light_lost,
            r.light_leaked,
            r.flip_mean,
            r.psnr_db
        ));
    }
    s
}

/// The Pareto chart: x = atlas + shading ms, y = visibility error, colour = filter,
/// label = tile size and format. Returns the frontier.
fn draw_chart(
    path: &Path,
    rows: &[Row],
    prep: &Prepared,
    counts: (u32, u32),
    (scene, args): (&str, &ShadowAccuracy),
) -> Result<Vec<usize>> {
    let points: Vec<ParetoPoint> = rows
        .iter()
        .map(|r| ParetoPoint {
            series: if r.filter == 1 { "1 tap".into() } else { format!("{0}x{0} PCF", r.filter) },
            label: format!("{} {}", r.tile_size, r.format),
            time: r.shadow_frame_ms,
            error: r.visibility_error,
            // Brute force: no light grid, nothing dropped.
            incomplete: false,
        })
        .collect();
    let frontier = chart::pareto_frontier(&points);
    let best = (0..rows.len()).filter(|&i| rows[i].visibility_error.is_finite()).min_by(|&i, &j| {
        rows[i]
            .visibility_error
            .total_cmp(&rows[j].visibility_error)
            .then(rows[i].shadow_frame_ms.total_cmp(&rows[j].shadow_frame_ms))
    });
    let note = best.map(|i| {
        let r = &rows[i];
        format!(
            "smallest error: {} px, {}x{} filter, {}: {:.4} of the light misplaced, {:.3} ms",
            r.tile_size, r.filter, r.filter, r.format, r.visibility_error, r.shadow_frame_ms
        )
    });
    let a = &prep.settings;
    let c = ParetoChart {
        title: format!("Shadow maps vs ray cast: {}, {}x{}", prep.ctx.info.name, a.width, a.height),
        subtitle: format!(
            "{}, {} point + {} spot casters lit alone, brute force, lights moving (every face drawn); ray offset {}; labels: tile px, format",
            scene, counts.0, counts.1, args.ray_offset
        ),
        x_label: "GPU ms: shadow atlas + shading (medians)".into(),
        y_label: "visibility error (share of the casters' light misplaced)".into(),
        points,
        target: None,
        chosen: best,
        note,
        // The ray cast runs on the CPU: no GPU time to compare with.
        references: Vec::new(),
    };
    chart::pareto_chart(path, &c)?;
    Ok(frontier)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configs_parse() {
        let c = parse_config("512x3").unwrap();
        assert_eq!((c.tile_size, c.filter.size(), c.format), (512, 3, ShadowFormat::Depth16));
        let c = parse_config("1024x5:d32").unwrap();
        assert_eq!((c.tile_size, c.filter.size(), c.format), (1024, 5, ShadowFormat::Depth32));
        let e = |s: &str| format!("{:#}", parse_config(s).unwrap_err());
        assert!(e("512").contains("TILExFILTER"), "{}", e("512"));
        assert!(e("100x3").contains("tile 100"), "{}", e("100x3"));
        assert!(e("512x2").contains("filter 2 must be 1, 3 or 5"), "{}", e("512x2"));
        assert!(e("512x3:d24").contains("format 'd24'"), "{}", e("512x3:d24"));
        assert!(e("ax3").contains("not an integer"));
        for s in DEFAULT_CONFIGS {
            parse_config(s).unwrap();
        }
    }

    #[test]
    fn ray_cast_sees_the_blocker() {
        // A quad at y = 1 between the floor points x < 0 and a light above them.
        let quad = vec![
            [Vec3::new(-2.0, 1.0, -1.0), Vec3::new(0.0, 1.0, -1.0), Vec3::new(0.0, 1.0, 1.0)],
            [Vec3::new(-2.0, 1.0, -1.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(-2.0, 1.0, 1.0)],
        ];
        let tris = Triangles::new(quad);
        let floor = |x: f32| Some(SurfacePoint { position: Vec3::new(x, 0.0, 0.0), normal: Vec3::Y });
        let points = vec![floor(-1.0), floor(1.0), None, floor(-0.5)];
        let light = Vec3::new(0.0, 3.0, 0.0);
        for threads in [1, 3, 8] {
            let v = ray_cast_visibility(&tris, &points, &[true, true, true, false], light, 1e-3, threads);
            assert_eq!(v, [false, true, true, true], "{threads} threads");
        }
    }
}
