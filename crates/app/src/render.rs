//! `tiledlight render`: renders a few frames of one configuration, writes the image (or,
//! with `--heatmap`, the lights-per-tile heat map with its legend; `--heatmap blended`,
//! that of the alpha-blended geometry's own lists) as PNG, and prints the
//! adapter, scene, lights, tile grid, the last frame's pass times, the culling statistics
//! read back from the GPU, the shadow atlas (faces drawn by the last frame: 0 with still
//! lights, whose faces the first frame drew; layout; memory) when lights cast shadows, the
//! alpha-blended geometry (instances, blend mode, its own light lists, memory) when the
//! scene has some, and the GPU memory the configuration allocated.
//!
//! The culling and blended statistics are tiledlight-setup's (`Prepared::culling_stats`,
//! `Prepared::blended_stats`). When the image's frame dropped lights (a light grid full),
//! a `warning:` line on stderr says so and the frame's pass times are marked; `--strict`
//! then fails after the PNG is written (tiledlight-lab's `dropped`).
//!
//! May depend on [`crate::scene_setup`], tiledlight-lab (the frame loop, dropped work, the
//! legend, PNG output), tiledlight-setup and tiledlight-gpu.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use tiledlight_frame::Diagnostics as _;
use tiledlight_frame::FrameRenderer;
use tiledlight_gpu::heatmap::HeatmapOf;
use tiledlight_setup::{shadow_atlas_description, Prepared, Settings};

use crate::scene_setup::SceneArgs;
use tiledlight_lab::bench::{self, Measurement, INCOMPLETE_MARK};
use tiledlight_lab::dropped::{self, Dropped};
use tiledlight_lab::legend;
use tiledlight_lab::output::{check_png_path, rgb_image, save_png};

/// Frames rendered before the image is read back: the pass times reported are the last
/// finished one's, after the first frame's one-off costs.
pub const RENDER_FRAMES: u32 = 3;

/// Flags of `tiledlight render`.
#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    /// Scene, lights, screen and renderer.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Write the lights-per-tile heat map (with a legend) over the lit image: of the opaque
    /// geometry's lists (`--heatmap` alone), of the alpha-blended geometry's own lists
    /// (`--heatmap blended`; tiles without blended geometry keep the image), or of the
    /// virtual point lights' own lists (`--heatmap vpl`; needs --vpl).
    #[arg(help_heading = "Output", long, value_enum, num_args = 0..=1, default_missing_value = "opaque", value_name = "LISTS")]
    pub heatmap: Option<HeatmapArg>,
    /// Output PNG [default: out/render.png, or out/heatmap.png with --heatmap].
    #[arg(help_heading = "Output", long, value_name = "FILE.png")]
    pub out: Option<PathBuf>,
}

/// Whose light lists the heat map shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum HeatmapArg {
    /// The opaque geometry's (the method's culling).
    Opaque,
    /// The alpha-blended geometry's own (needs blended geometry).
    Blended,
    /// The virtual point lights' own (needs --vpl).
    Vpl,
}

impl From<HeatmapArg> for HeatmapOf {
    fn from(a: HeatmapArg) -> Self {
        match a {
            HeatmapArg::Opaque => HeatmapOf::Opaque,
            HeatmapArg::Blended => HeatmapOf::Blended,
            HeatmapArg::Vpl => HeatmapOf::Vpl,
        }
    }
}

/// The pass times of the last finished frame, one line each, plus their sum; marked as
/// times of an incomplete frame when `dropped` says the frame lost lights.
pub fn last_frame_times(m: &Measurement, dropped: &Dropped) -> String {
    if !m.timestamps {
        return "GPU times:  not available (the adapter has no timestamp queries)\n".into();
    }
    let Some(frame) = m.gpu_frames.last() else {
        return "GPU times:  no frame's timestamps came back\n".into();
    };
    let mark = if dropped.any() { INCOMPLETE_MARK } else { "" };
    let mut s = format!("GPU times (frame {} of {}):\n", m.gpu_frames.len(), m.cpu_ms.len());
    for p in frame {
        s.push_str(&format!("  {:<22} {:>9.3} ms{mark}\n", p.label, p.ms));
    }
    let total: f64 = frame.iter().map(|p| p.ms).sum();
    s.push_str(&format!("  {:<22} {:>9.3} ms{mark}\n", "total", total));
    if dropped.any() {
        s.push_str(&format!(
            "  {}  times of an INCOMPLETE frame: its light lists DROPPED lights (see the warning)\n",
            INCOMPLETE_MARK.trim()
        ));
    }
    s
}

/// Reads the renderer's image, adds the legend for a heat map, and writes the PNG.
/// Returns a note when the legend did not fit.
pub fn write_image(prep: &Prepared, renderer: &FrameRenderer, heatmap: bool, path: &Path) -> Result<Option<String>> {
    let (img, note) = frame_image(prep, renderer, heatmap)?;
    save_png(path, &img)?;
    Ok(note)
}

/// The renderer's image with the heat map's legend, and a note when the legend did not fit.
pub fn frame_image(
    prep: &Prepared,
    renderer: &FrameRenderer,
    heatmap: bool,
) -> Result<(image::RgbImage, Option<String>)> {
    let ldr = renderer.read_ldr(&prep.ctx).context("reading the image back")?;
    let mut img = rgb_image(prep.settings.width, prep.settings.height, &ldr)?;
    let mut note = None;
    if heatmap && !legend::draw_legend(&mut img, prep.settings.capacity()) {
        note = Some(format!("the image ({}x{}) is too small for the legend: not drawn", img.width(), img.height()));
    }
    Ok((img, note))
}

/// Runs `tiledlight render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    // The heatmap and clusters demos show the heat map unless asked for another.
    let demo = args.scene.demo.as_deref().and_then(|n| tiledlight_setup::demo::parse(n).ok());
    let heatmap_arg = args.heatmap.or(demo.filter(|d| d.shows_heatmap()).map(|_| HeatmapArg::Opaque));
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(if heatmap_arg.is_some() { "out/heatmap.png" } else { "out/render.png" }));
    check_png_path(&out)?;
    tiledlight_lab::output::check_output("--out", &out)?;
    let method = args.scene.rows().method;
    let heatmap = heatmap_arg.map(HeatmapOf::from);
    if heatmap.is_some() && !method.is_tiled() {
        bail!("--heatmap needs --method forward-plus ({} has no tiles)", method.name());
    }
    // A traced reference's frame takes seconds: its bands report their progress.
    let prep = Prepared::new(&Settings { traced_progress: true, ..args.scene.settings()? })?;
    tiledlight_lab::output::print_load_warnings(&prep.scene_warnings);
    let mut renderer = prep.renderer_with_heatmap(heatmap)?;
    // The traced reference's frame takes seconds: one is enough (nothing in it carries
    // over between frames).
    let traced = prep.settings.method.is_traced_reference();
    let start = std::time::Instant::now();
    let frames = if traced { 1 } else { RENDER_FRAMES };
    let m = if traced {
        // Its one frame's bands are the bar (two bars would draw over each other's line).
        let _bands = tiledlight_lab::axes::BandsProgress::start();
        bench::measure_moving(&prep, &mut renderer, 0, frames, None)?
    } else {
        bench::measure_shown(&prep, &mut renderer, (0, frames), None, "render")?
    };
    let seconds = start.elapsed().as_secs_f64();
    let stats = prep.culling_stats(&renderer)?;
    let blended = prep.blended_stats(&renderer)?;
    let edges = renderer.edge_pixels(&prep.ctx).context("reading the MSAA edge count back")?;
    // The image is the last frame: what it lost is its own headers' (read back, stalling).
    let dropped = Dropped::last_frame(&prep, &renderer)?;
    // The image is written after the report is printed: a failed write loses no report.
    let (img, note) = frame_image(&prep, &renderer, heatmap.is_some())?;
    let exposure = renderer.auto_exposure(&prep.ctx).context("reading the exposure back")?;
    prep.check_gpu_errors()?;
    // A traced frame the driver cut short is refused, not written (llvmpipe's loop limit).
    renderer.check_traced_complete(&prep.ctx)?;

    for (k, v) in prep.describe() {
        println!("{:<11} {v}", format!("{k}:"));
    }
    match exposure {
        Some(e) => println!(
            "exposure:   {e:.4}, automatic (the last frame's log-average luminance mapped to {}; --exposure fixes it)",
            tiledlight_cull::exposure::AUTO_EXPOSURE_KEY
        ),
        None => println!("exposure:   {:.4}, fixed", prep.settings.exposure),
    }
    print!("{}", last_frame_times(&m, &dropped));
    if let Some(s) = stats {
        println!("culling:    {s}");
    }
    if let Some(b) = blended {
        println!("blend path: {b}");
    }
    if let Some(e) = edges {
        let pixels = u64::from(prep.settings.width) * u64::from(prep.settings.height);
        println!(
            "MSAA edges: {e} pixels ({:.2}%) shaded per sample by the edge test, the rest once",
            100.0 * e as f64 / pixels as f64
        );
    }
    if let Some(a) = renderer.outputs().shadow_atlas {
        println!(
            "shadow map: {} faces drawn by the last frame (of {RENDER_FRAMES}; still lights' faces are drawn by the first); {}",
            a.faces_drawn_last_frame(),
            shadow_atlas_description(a)
        );
    }
    if let Some(v) = renderer.passes::<tiledlight_frame::VisibilityFrame>() {
        let rays = v.shading().read_traced_rays(&prep.ctx.device, &prep.ctx.queue)?;
        if let Some(rays) = rays.filter(|_| !traced) {
            // The stochastic method: at most one ray a pixel, counted for the last frame only.
            println!("rays:       {rays} shadow rays in the last frame (at most one a pixel; of {frames} frames)");
        } else if let Some(rays) = rays {
            println!(
                "rays:       {rays} shadow rays in {:.2} s wall ({:.1} M rays/s; {} bands)",
                seconds,
                rays as f64 / seconds / 1e6,
                v.shading().traced_bands().unwrap_or(1)
            );
        }
    }
    println!("GPU memory:\n{}", renderer.memory());
    if let Some(n) = note {
        println!("note:       {n}");
    }
    let what = match heatmap {
        Some(HeatmapOf::Opaque) => " (heat map with legend)",
        Some(HeatmapOf::Blended) => " (heat map of the blended lists, with legend)",
        Some(HeatmapOf::Vpl) => " (heat map of the VPL lists, with legend)",
        None => "",
    };
    save_png(&out, &img)?;
    println!("wrote {}{what}", out.display());
    let mut warnings = 0;
    let max_binding = prep.ctx.device.limits().max_storage_buffer_binding_size;
    if let Some(w) = dropped.warning(&format!("the image {}", out.display()), prep.settings.grid_pairs, max_binding) {
        dropped::warn(&mut warnings, &w);
    }
    let what = format!("the image {}", out.display());
    if let Some(w) = tiledlight_lab::dropped::refused_warning(&renderer, &prep.ctx, &what)? {
        dropped::warn(&mut warnings, &w);
    }
    dropped::strict(args.scene.rows().strict, warnings)
}
