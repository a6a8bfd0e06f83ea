//! Culling statistics of one frame, read back from the GPU ([`culling_stats`]): lights
//! per list over the tiles with geometry, the largest list, overflowing lists and
//! (tile, light) pairs, as `render`, the lab, the viewer and the GPU tests report them;
//! and [`group_digits`], the thousands separators of the reports.
//!
//! Depends on tiledlight-gpu (readback, the `Renderer` trait, `CullOptions`) and
//! tiledlight-cull (tile depth bounds); nothing else of the crate.

use anyhow::{Context, Result};
use tiledlight_cull::tiles::tile_depth_bounds_samples;
use tiledlight_gpu::light_cull::CullOptions;
use tiledlight_gpu::readback::read_buffer;
use tiledlight_gpu::targets::Renderer;
use tiledlight_gpu::GpuContext;

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
    /// Lists whose count exceeded the capacity (counted on the GPU).
    pub overflowing: u32,
    /// (tile, light) pairs found (summed from the GPU's per-list counts).
    pub pairs: u64,
    /// The list capacity.
    pub capacity: u32,
}

impl std::fmt::Display for CullingStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let per = if self.lists_per_tile == 1 { "tile" } else { "list (half-z)" };
        write!(
            f,
            "mean {:.1}, max {} lights per {per} over {} of {} tiles with geometry; {} overflowing lists (capacity {}); {} tile-light pairs",
            self.mean_per_list,
            self.max_per_list,
            self.tiles_with_geometry,
            self.tiles,
            self.overflowing,
            self.capacity,
            group_digits(self.pairs)
        )
    }
}

/// Reads the last frame's lists and depth back and computes the statistics (None for a
/// renderer without culling). `renderer` was built on `ctx` with the culling `options`
/// (tile size, capacity, half-z) given here.
pub fn culling_stats(ctx: &GpuContext, renderer: &dyn Renderer, options: &CullOptions) -> Result<Option<CullingStats>> {
    let Some(counts_buffer) = renderer.tile_counts() else {
        return Ok(None);
    };
    let counts: Vec<u32> =
        read_buffer(&ctx.device, &ctx.queue, counts_buffer).context("reading the tile counts back")?;
    let depth = renderer.read_depth(ctx).context("reading the depth buffer back")?;
    let grid = renderer.grid();
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
        overflowing: counts.iter().filter(|&&c| c > options.capacity).count() as u32,
        pairs: counts.iter().map(|&c| u64::from(c)).sum(),
        capacity: options.capacity,
    }))
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
    fn stats_read_as_one_line() {
        let s = CullingStats {
            lists_per_tile: 2,
            tiles_with_geometry: 3,
            tiles: 4,
            mean_per_list: 1.26,
            max_per_list: 9,
            overflowing: 0,
            pairs: 12345,
            capacity: 64,
        };
        assert_eq!(
            s.to_string(),
            "mean 1.3, max 9 lights per list (half-z) over 3 of 4 tiles with geometry; 0 overflowing lists (capacity 64); 12,345 tile-light pairs"
        );
    }
}
