//! `tiledlight render`: renders a few frames of one configuration, writes the image (or,
//! with `--heatmap`, the lights-per-tile heat map with its legend) as PNG, and prints the
//! adapter, scene, lights, tile grid, the last frame's pass times, the culling statistics
//! read back from the GPU, and the GPU memory the configuration allocated.
//!
//! May depend on [`crate::scene_setup`], [`crate::bench`] (the frame loop),
//! [`crate::legend`], tiledlight-forward, tiledlight-gpu and tiledlight-cull.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use tiledlight_cull::tiles::tile_depth_bounds_samples;
use tiledlight_gpu::targets::Renderer;

use crate::bench::{self, Measurement};
use crate::legend;
use crate::scene_setup::{check_png_path, group_digits, rgb_image, save_png, Prepared, SceneArgs};

/// Frames rendered before the image is read back: the pass times reported are the last
/// finished one's, after the first frame's one-off costs.
pub const RENDER_FRAMES: u32 = 3;

/// Flags of `tiledlight render`.
#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    /// Scene, lights, screen and renderer.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Write the lights-per-tile heat map (with a legend) instead of the lit image.
    #[arg(long)]
    pub heatmap: bool,
    /// Output PNG [default: out/render.png, or out/heatmap.png with --heatmap].
    #[arg(long, value_name = "FILE.png")]
    pub out: Option<PathBuf>,
}

/// Culling statistics of one frame, read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct CullingStats {
    /// Lists per tile (2 with half-z).
    pub lists_per_tile: u32,
    /// Tiles with at least one non-sky pixel.
    pub tiles_with_geometry: usize,
    /// All tiles.
    pub tiles: usize,
    /// Mean light count per list, over the lists of tiles with geometry (as
    /// `tiledlight_cull::reference::stats` defines it).
    pub mean_per_list: f64,
    /// Largest light count of a list.
    pub max_per_list: u32,
    /// Lists that lost lights because the light grid was full (counted on the GPU; 0
    /// unless the grid's budget was fixed or the device could not bind a larger one).
    pub overflowing: u32,
    /// Lights those lists lost.
    pub dropped: u32,
    /// Lists longer than the culling kernel's workgroup list, written by its second pass.
    pub spilled: u32,
    /// (tile, light) pairs found (summed from the GPU's per-list counts).
    pub pairs: u64,
    /// The workgroup list's capacity.
    pub capacity: u32,
    /// Indices the light grid holds.
    pub grid_capacity: u32,
}

impl std::fmt::Display for CullingStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let per = if self.lists_per_tile == 1 { "tile" } else { "list (half-z)" };
        write!(
            f,
            "mean {:.1}, max {} lights per {per} over {} of {} tiles with geometry; {} lists longer than the workgroup list ({}), culled twice; ",
            self.mean_per_list,
            self.max_per_list,
            self.tiles_with_geometry,
            self.tiles,
            self.spilled,
            self.capacity,
        )?;
        if self.overflowing > 0 {
            write!(
                f,
                "DROPPED {} lights from {} lists (light grid of {} indices full); ",
                group_digits(self.dropped.into()),
                self.overflowing,
                group_digits(self.grid_capacity.into())
            )?;
        } else {
            write!(f, "0 dropped (light grid of {} indices); ", group_digits(self.grid_capacity.into()))?;
        }
        write!(f, "{} tile-light pairs", group_digits(self.pairs))
    }
}

/// Reads the last frame's lists and depth back and computes the statistics (None for a
/// renderer without culling).
pub fn culling_stats(prep: &Prepared, renderer: &dyn Renderer) -> Result<Option<CullingStats>> {
    let Some(grid) = renderer.light_grid() else {
        return Ok(None);
    };
    let (device, queue) = (&prep.ctx.device, &prep.ctx.queue);
    let counts = grid.read_counts(device, queue).context("reading the tile counts back")?;
    let header = grid.status(device, queue).context("reading the light grid's header back")?.header;
    let depth = renderer.read_depth(&prep.ctx).context("reading the depth buffer back")?;
    let grid = renderer.grid();
    let options = prep.args.cull_options();
    let per = options.lists_per_tile() as usize;
    let counts = &counts[..grid.tile_count() * per];
    let (mut sum, mut n, mut tiles_with_geometry) = (0u64, 0u64, 0usize);
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            if tile_depth_bounds_samples(&grid, &depth, renderer.targets().samples, tx, ty).is_none() {
                continue;
            }
            tiles_with_geometry += 1;
            let t = (ty * grid.tiles_x + tx) as usize;
            for c in &counts[t * per..(t + 1) * per] {
                sum += u64::from(*c);
                n += 1;
            }
        }
    }
    Ok(Some(CullingStats {
        lists_per_tile: per as u32,
        tiles_with_geometry,
        tiles: grid.tile_count(),
        mean_per_list: if n > 0 { sum as f64 / n as f64 } else { 0.0 },
        max_per_list: counts.iter().copied().max().unwrap_or(0),
        overflowing: header.dropped_lists,
        dropped: header.dropped_pairs,
        spilled: header.spilled_lists,
        pairs: counts.iter().map(|&c| u64::from(c)).sum(),
        capacity: options.capacity,
        grid_capacity: header.capacity,
    }))
}

/// The pass times of the last finished frame, one line each, plus their sum.
pub fn last_frame_times(m: &Measurement) -> String {
    if !m.timestamps {
        return "GPU times:  not available (the adapter has no timestamp queries)\n".into();
    }
    let Some(frame) = m.gpu_frames.last() else {
        return "GPU times:  no frame's timestamps came back\n".into();
    };
    let mut s = format!("GPU times (frame {} of {}):\n", m.gpu_frames.len(), m.cpu_ms.len());
    for p in frame {
        s.push_str(&format!("  {:<22} {:>9.3} ms\n", p.label, p.ms));
    }
    let total: f64 = frame.iter().map(|p| p.ms).sum();
    s.push_str(&format!("  {:<22} {:>9.3} ms\n", "total", total));
    s
}

/// Reads the renderer's image, adds the legend for a heat map, and writes the PNG.
/// Returns a note when the legend did not fit.
pub fn write_image(prep: &Prepared, renderer: &dyn Renderer, heatmap: bool, path: &Path) -> Result<Option<String>> {
    let ldr = renderer.read_ldr(&prep.ctx).context("reading the image back")?;
    let mut img = rgb_image(prep.args.width, prep.args.height, &ldr)?;
    let mut note = None;
    if heatmap && !legend::draw_legend(&mut img, prep.args.capacity()) {
        note = Some(format!("the image ({}x{}) is too small for the legend: not drawn", img.width(), img.height()));
    }
    save_png(path, &img)?;
    Ok(note)
}

/// Runs `tiledlight render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(if args.heatmap { "out/heatmap.png" } else { "out/render.png" }));
    check_png_path(&out)?;
    if args.heatmap && !args.scene.method.is_tiled() {
        bail!("--heatmap needs --method forward-plus ({} has no tiles)", args.scene.method.name());
    }
    let prep = Prepared::new(&args.scene)?;
    let mut renderer = prep.renderer(args.heatmap)?;
    let m = bench::measure(&prep, renderer.as_mut(), 0, RENDER_FRAMES)?;
    let stats = culling_stats(&prep, renderer.as_ref())?;
    let edges = renderer.edge_pixels(&prep.ctx).context("reading the MSAA edge count back")?;
    let note = write_image(&prep, renderer.as_ref(), args.heatmap, &out)?;
    prep.check_gpu_errors()?;

    for (k, v) in prep.describe() {
        println!("{:<11} {v}", format!("{k}:"));
    }
    print!("{}", last_frame_times(&m));
    if let Some(s) = stats {
        println!("culling:    {s}");
    }
    if let Some(e) = edges {
        let pixels = u64::from(prep.args.width) * u64::from(prep.args.height);
        println!(
            "MSAA edges: {e} pixels ({:.2}%) shaded per sample by the edge test, the rest once",
            100.0 * e as f64 / pixels as f64
        );
    }
    println!("GPU memory:\n{}", renderer.memory());
    if let Some(n) = note {
        println!("note:       {n}");
    }
    println!("wrote {}{}", out.display(), if args.heatmap { " (heat map with legend)" } else { "" });
    Ok(())
}
