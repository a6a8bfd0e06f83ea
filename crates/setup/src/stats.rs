//! Culling statistics of one frame, read back from the GPU ([`culling_stats`]): lights
//! per list over the tiles with geometry, the largest list, lists that lost lights and
//! (tile, light) pairs, as `render`, the lab, the viewer and the GPU tests report them;
//! the same for the alpha-blended geometry's own light grid, with its instances, blend
//! mode and memory ([`blended_stats`]); the shadow atlas's line
//! ([`shadow_atlas_description`]); and [`group_digits`], the thousands separators of the
//! reports.
//!
//! Depends on tiledlight-gpu (readback, the `Renderer` trait, `CullOptions`, the shadow
//! atlas, the blended path), tiledlight-cull (tile depth bounds, the blended depth test,
//! atlas layout) and [`crate::settings`]'s descriptions.

use anyhow::{Context, Result};
use tiledlight_cull::shadow::{AtlasLayout, ShadowOptions};
use tiledlight_cull::tiles::tile_depth_bounds_samples;
use tiledlight_cull::volumes::depth_tested_blended;
use tiledlight_cull::TileGrid;
use tiledlight_frame::Diagnostics as _;
use tiledlight_frame::FrameRenderer;
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::features::BlendMode;
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::memory::format_bytes;
use tiledlight_gpu::readback::read_depth;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::GpuContext;

use crate::settings::{blend_mode_description, shadow_options_description};

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
        self.write(f, "geometry")
    }
}

impl CullingStats {
    /// The one-line report, the tiles counted being those with `geometry`.
    fn write(&self, f: &mut std::fmt::Formatter<'_>, geometry: &str) -> std::fmt::Result {
        let per = match self.lists_per_tile {
            1 => "tile".to_string(),
            2 => "list (half-z)".to_string(),
            n => format!("cluster ({n} slices a tile)"),
        };
        write!(
            f,
            "mean {:.1}, max {} lights per {per} over {} of {} tiles with {geometry}; {} lists longer than the workgroup list ({}), culled twice; ",
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
/// renderer without culling). `renderer` was built on `ctx` with the culling `options`
/// (tile size, capacity, half-z) given here.
pub fn culling_stats(
    ctx: &GpuContext,
    renderer: &FrameRenderer,
    options: &CullOptions,
) -> Result<Option<CullingStats>> {
    let Some(grid) = renderer.outputs().light_grid else {
        return Ok(None);
    };
    let depth = renderer.read_depth(ctx).context("reading the depth buffer back")?;
    let depth = (depth.as_slice(), renderer.outputs().targets.samples);
    // The grid's own tiles: a clustered grid's differ from the renderer's shading tiles.
    grid_stats(ctx, grid, grid.tiles, depth, options).map(Some)
}

/// The statistics of the lists in `light_grid` over the tiles of `grid`, counting the
/// tiles where `depth` (`samples` values per pixel) has some geometry (a value > 0).
fn grid_stats(
    ctx: &GpuContext,
    light_grid: &LightGrid,
    grid: TileGrid,
    (depth, samples): (&[f32], u32),
    options: &CullOptions,
) -> Result<CullingStats> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let counts = light_grid.read_counts(device, queue).context("reading the tile counts back")?;
    let header = light_grid.status(device, queue).context("reading the light grid's header back")?.header;
    let per = options.lists_per_tile() as usize;
    let counts = &counts[..grid.tile_count() * per];
    let (mut sum, mut n, mut tiles_with_geometry) = (0u64, 0u64, 0usize);
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            if tile_depth_bounds_samples(&grid, depth, samples, tx, ty).is_none() {
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
    Ok(CullingStats {
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
    })
}

/// The alpha-blended geometry of one frame: its instances, how it was composited, its
/// light lists (tiled methods) and its memory.
#[derive(Clone, Debug, PartialEq)]
pub struct BlendedStats {
    /// Blended instances drawn.
    pub instances: usize,
    /// How the layer was composited.
    pub mode: BlendMode,
    /// The blended light grid's statistics, over the tiles with blended geometry in front of
    /// the opaque surfaces (one list per tile; None for brute force, which has no lists).
    pub culling: Option<CullingStats>,
    /// GPU memory of the blended path (its depth buffer, layer targets and light grid), bytes.
    pub memory: u64,
}

impl std::fmt::Display for BlendedStats {
    /// "20 instances, sorted back to front, --blend-mode sorted; lists: mean 2.1, max 9
    /// lights per tile over 40 of 510 tiles with blended geometry; ...; 1.50 MiB".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = if self.instances == 1 { "" } else { "s" };
        write!(f, "{} instance{s}, {}; ", self.instances, blend_mode_description(self.mode))?;
        match &self.culling {
            Some(c) => {
                f.write_str("lists: ")?;
                c.write(f, "blended geometry")?;
                f.write_str("; ")?;
            }
            None => f.write_str("no lists (every light for every pixel); ")?,
        }
        write!(f, "{}", format_bytes(self.memory))
    }
}

/// The blended geometry of the last frame `renderer` (built on `ctx`) drew: None when its
/// scene has none. Its light lists are read back with the opaque and the blended depth;
/// the tiles counted are those with a blended sample in front of the opaque depth (the
/// blended culling's own test, `tiledlight_cull::reference::depth_tested_blended`).
pub fn blended_stats(ctx: &GpuContext, renderer: &FrameRenderer) -> Result<Option<BlendedStats>> {
    let Some(b) = renderer.outputs().blended else {
        return Ok(None);
    };
    // Without lists of its own (brute force, or frustum clusters serving it) the blended
    // geometry has no statistics of its own.
    let culling = match (&b.culling, &b.depth) {
        (None, _) | (_, None) => None,
        (Some(c), Some(d)) => {
            let opaque = renderer.read_depth(ctx).context("reading the depth buffer back")?;
            let blended =
                read_depth(&ctx.device, &ctx.queue, &d.texture).context("reading the blended depth buffer back")?;
            let tested = depth_tested_blended(&opaque, &blended);
            let depth = (tested.as_slice(), renderer.outputs().targets.samples);
            Some(grid_stats(ctx, &c.grid, renderer.outputs().grid, depth, &c.options)?)
        }
    };
    Ok(Some(BlendedStats { instances: b.instance_count(), mode: b.mode(), culling, memory: b.memory.total() }))
}

/// "atlas 1536x3584 x1 layer, 256 px tiles, 5x5 PCF, d16; 52 faces": where the shadow
/// faces of `layout` lie and how they are drawn.
pub fn atlas_layout_description(layout: &AtlasLayout, options: &ShadowOptions) -> String {
    let layers = if layout.layers == 1 { "layer" } else { "layers" };
    format!(
        "atlas {}x{} x{} {layers}, {}; {} faces",
        layout.width(),
        layout.height(),
        layout.layers,
        shadow_options_description(options),
        layout.faces()
    )
}

/// The shadow atlas's layout ([`atlas_layout_description`]) and its GPU memory (atlas and
/// face buffer), e.g. "atlas 1536x3584 x1 layer, 256 px tiles, 5x5 PCF, d16; 52 faces;
/// 10.50 MiB".
pub fn shadow_atlas_description(atlas: &ShadowAtlas) -> String {
    format!("{}; {}", atlas_layout_description(&atlas.layout, &atlas.options), format_bytes(atlas.memory.total()))
}

/// 1234567 -> "1,234,567".
pub fn group_digits(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_are_grouped() {
        assert_eq!(group_digits(0), "0");
        assert_eq!(group_digits(999), "999");
        assert_eq!(group_digits(1000), "1,000");
        assert_eq!(group_digits(1234567), "1,234,567");
    }

    #[test]
    fn the_atlas_reads_as_one_line() {
        let layout = AtlasLayout::new(256, 8, 4, 8192, 256).unwrap();
        assert_eq!(
            atlas_layout_description(&layout, &ShadowOptions::default()),
            "atlas 1536x2304 x1 layer, 256 px tiles, 5x5 PCF, d16; 52 faces"
        );
        let tall = AtlasLayout::new(1024, 9, 0, 8192, 256).unwrap();
        assert!(atlas_layout_description(&tall, &ShadowOptions::default()).starts_with("atlas 6144x8192 x2 layers"));
    }

    #[test]
    fn stats_read_as_one_line() {
        let s = CullingStats {
            lists_per_tile: 2,
            tiles_with_geometry: 3,
            tiles: 4,
            mean_per_list: 1.26,
            max_per_list: 9,
            overflowing: 0,
            dropped: 0,
            spilled: 2,
            pairs: 12345,
            capacity: 64,
            grid_capacity: 20000,
        };
        assert_eq!(
            s.to_string(),
            "mean 1.3, max 9 lights per list (half-z) over 3 of 4 tiles with geometry; 2 lists longer than the \
             workgroup list (64), culled twice; 0 dropped (light grid of 20,000 indices); 12,345 tile-light pairs"
        );
        let dropped = CullingStats { overflowing: 3, dropped: 1500, ..s.clone() };
        assert!(dropped.to_string().contains("DROPPED 1,500 lights from 3 lists (light grid of 20,000 indices full)"));
        let one = CullingStats { lists_per_tile: 1, ..s };
        let b = BlendedStats { instances: 20, mode: BlendMode::Sorted, culling: Some(one), memory: 3 << 20 };
        assert_eq!(
            b.to_string(),
            "20 instances, sorted back to front, --blend-mode sorted; lists: mean 1.3, max 9 lights per tile over 3 of \
             4 tiles with blended geometry; 2 lists longer than the workgroup list (64), culled twice; 0 dropped \
             (light grid of 20,000 indices); 12,345 tile-light pairs; 3.00 MiB"
        );
        let brute = BlendedStats { instances: 1, mode: BlendMode::WeightedOit, culling: None, memory: 1024 };
        assert_eq!(
            brute.to_string(),
            "1 instance, weighted blended OIT (unsorted, approximate), --blend-mode wboit; no lists (every light for \
             every pixel); 1.00 KiB"
        );
    }
}
