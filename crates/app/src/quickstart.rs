//! `tiledlight` with no subcommand: the one-command tour. Renders the default scene with
//! 1024 point lights at 1920x1080 with Forward+, writes `out/render.png` and
//! `out/heatmap.png` (with its legend), and prints the median pass times of a short
//! benchmark. Two renderers, one after the other: the heat map is drawn over the lit
//! image, so the plain image needs a renderer without it.
//!
//! A frame that dropped lights (a light grid full) gets a `warning:` line, as in `render`.
//!
//! May depend on tiledlight-setup, tiledlight-lab and [`crate::render`].

use std::path::Path;

use anyhow::Result;
use tiledlight_setup::{Prepared, Settings};

use crate::render::write_image;
use tiledlight_lab::bench;
use tiledlight_lab::dropped::{self, Dropped};

/// Frames of the short benchmark (after a few warm-up frames).
const FRAMES: u32 = 30;
const WARMUP: u32 = 5;

/// Runs the default tour.
pub fn run() -> Result<()> {
    let settings = Settings::default();
    let render_path = Path::new("out/render.png");
    let heatmap_path = Path::new("out/heatmap.png");
    let prep = Prepared::new(&settings)?;
    for (k, v) in prep.describe() {
        println!("{:<11} {v}", format!("{k}:"));
    }

    {
        let mut renderer = prep.renderer(false)?;
        println!("benchmark:  {WARMUP} warm-up + {FRAMES} measured frames");
        let m = bench::measure_shown(&prep, &mut renderer, (WARMUP, FRAMES), None, "quick start")?;
        print!("{}", bench::table(&m));
        if let Some(s) = prep.culling_stats(&renderer)? {
            println!("culling:    {s}");
        }
        write_image(&prep, &renderer, false, render_path)?;
        println!("GPU memory:\n{}", renderer.memory());
        let max_binding = prep.ctx.device.limits().max_storage_buffer_binding_size;
        let lost = Dropped::last_frame(&prep, &renderer)?;
        if let Some(w) = lost.warning(&format!("the image {}", render_path.display()), None, max_binding) {
            dropped::warn(&mut 0, &w);
        }
    }
    // The first renderer is dropped: only one set of targets is alive at a time.
    let mut heat = prep.renderer(true)?;
    bench::measure(&prep, &mut heat, 0, 1)?;
    let note = write_image(&prep, &heat, true, heatmap_path)?;
    prep.check_gpu_errors()?;
    if let Some(n) = note {
        println!("note:       {n}");
    }
    println!("wrote {} and {} (heat map with legend)", render_path.display(), heatmap_path.display());
    println!("more: `tiledlight render --help`, `tiledlight bench --help`");
    Ok(())
}
