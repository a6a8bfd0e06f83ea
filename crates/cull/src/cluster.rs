//! Clustered shading (Olsson, Billeter, Assarsson 2012): screen tiles times depth slices,
//! one light list per cluster, with exponential slices and a special first slice
//! `[0, first)` (as Bevy and Filament do: exponential slicing from the near plane would
//! spend most slices in the first metres). Lists are built light-centrically: each light
//! visits the tiles of its [`light_tile_rect`] times the slices its depth span reaches.
//! The GPU side mirrors [`ClusterConfig::slice_of`] and the assignment in f32. The layout
//! itself ([`ClusterConfig`]) is in [`crate::lists`] with the other layouts. Depends on
//! [`crate::assign`] (the tile rectangle), [`crate::camera`], [`crate::tiles`],
//! [`crate::volumes`] (view-space lights, depth checks) and [`crate::lists`].
//!
//! 1. `scale = (slices - 1) / ln(last / first)` (0 with one slice).
//! 2. [`ClusterConfig::slice_of`]: distances below `first` (0, negative, NaN included) are
//!    slice 0; else `1 + min(ln(d / first) * scale, slices - 2)` truncated. Never a log of
//!    0 or a NaN; `d = inf` is the last slice.
//! 3. A light (view-space centre `c`, radius `r`, `dist = -c.z`) reaches slices
//!    `lo = slice_of(max(dist - r, 0)) ..= hi = slice_of(dist + r)`. `slice_of` is monotone
//!    and every point of the sphere lies at a view distance in `[dist - r, dist + r]`, so a
//!    surface the light reaches reads a slice in that range.
//! 4. It joins cluster (tile `t`, slice `s`) iff `r > 0`, `dist + r > 0`, the tile's four
//!    side planes pass (the tiles' own test: `dot(p.xyz, c) + p.w >= -r` for each plane of
//!    [`crate::tiles::TileFrustum::from_parts`]), `lo <= s <= hi`, and, with
//!    `geometry_only`, bit `s` of the tile's occupancy mask ([`cluster_occupancy`]: the
//!    slices holding a non-sky sample of the tile) is set. Only the tiles of the light's
//!    [`light_tile_rect`] are visited, and each is still plane-tested: the rectangle is
//!    the whole grid for a perspective sphere reaching the eye plane, where the planes
//!    still reject tiles, and within f32 rounding it may hold a tile that fails them.
//! 5. A pixel at view distance `d` of tile `t` reads list `t * slices + slice_of(d)`
//!    ([`TileLists::list_index`]).
//!
//! Unlike the tile layouts there are no AABB or spot-cone tests per cluster, and without
//! `geometry_only` no test against the tile's surfaces: clusters are built from the view
//! frustum alone, so empty clusters get lights too (spots are tested by their fitted sphere).

use glam::Vec4;

use crate::assign::light_tile_rect;
use crate::camera::{clip_edge_plane, Camera};
use crate::error::CullError;
use crate::light::PackedLights;
use crate::lists::{ClusterConfig, CullConfig, TileLists};
use crate::tiles::{tile_depth_bounds_samples, tile_sample_spans, TileGrid};
use crate::volumes::{check_depth_samples, view_lights};

/// Per tile (row-major), the slices holding a non-sky sample: bit `slice_of(view
/// distance)` of every sample with depth > 0; 0 for all-sky tiles. `depth` as the culler
/// reads it (reversed-Z, row-major, `samples` values per pixel, pixel-major).
///
/// # Panics
///
/// If `depth` holds fewer than `grid.width * grid.height * samples` values.
pub fn cluster_occupancy(
    depth: &[f32],
    grid: &TileGrid,
    samples: u32,
    camera: &Camera,
    cluster: &ClusterConfig,
) -> Vec<u32> {
    let dp = camera.depth_params();
    let mut occupancy = vec![0u32; grid.tile_count()];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            let mut m = 0u32;
            for span in tile_sample_spans(grid, samples, tx, ty) {
                for &d in &depth[span] {
                    if d > 0.0 {
                        m |= 1 << cluster.slice_of(dp.view_distance(d));
                    }
                }
            }
            occupancy[(ty * grid.tiles_x + tx) as usize] = m;
        }
    }
    occupancy
}

/// The slices `lo..=hi` a light of view-space depth `dist` (`-c.z`) and radius `r`
/// reaches (step 3 of the module docs).
pub fn light_slices(cluster: &ClusterConfig, dist: f32, r: f32) -> (u32, u32) {
    (cluster.slice_of((dist - r).max(0.0)), cluster.slice_of(dist + r))
}

/// Clustered light lists for a reversed-Z `depth` buffer (row-major, `samples` values per
/// pixel, pixel-major): list `t * slices + s` of tile `t`, slice `s`, ascending. `lights` as
/// uploaded (points first); `inflate` grows radii as [`CullConfig::inflate`] does.
///
/// The returned [`TileLists`] has `cluster: Some(*cluster)`, `ranges` the tiles' surface
/// ranges (None for all-sky tiles, whose clusters still get lights unless
/// `geometry_only`), and `config` the default one with `tile_size`, `samples` and
/// `inflate` set (its other switches do not apply; `capacity` is only what
/// [`TileLists::overflowing_lists`] counts against).
#[allow(clippy::too_many_arguments)]
pub fn cull_clusters(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
    cluster: &ClusterConfig,
    samples: u32,
    inflate: f32,
) -> Result<TileLists, CullError> {
    let config = CullConfig { tile_size: cluster.tile_size, samples, inflate, ..CullConfig::default() };
    config.validate()?;
    let grid = cluster.grid(width, height)?;
    check_depth_samples(&grid, depth, samples)?;
    let dp = camera.depth_params();
    let proj = camera.proj();
    let occupancy = cluster.geometry_only.then(|| cluster_occupancy(depth, &grid, samples, camera, cluster));
    let n = cluster.slices as usize;
    // The tile planes of `TileFrustum::from_parts`, per column (left, right) and row
    // (bottom, top): the same calls on the same `tile_ndc` edges, so the same values.
    let cols: Vec<[Vec4; 2]> = (0..grid.tiles_x)
        .map(|tx| {
            let (l, r, _, _) = grid.tile_ndc(tx, 0);
            [clip_edge_plane(&proj, 0, l, 1.0), clip_edge_plane(&proj, 0, r, -1.0)]
        })
        .collect();
    let rows: Vec<[Vec4; 2]> = (0..grid.tiles_y)
        .map(|ty| {
            let (_, _, b, t) = grid.tile_ndc(0, ty);
            [clip_edge_plane(&proj, 1, b, 1.0), clip_edge_plane(&proj, 1, t, -1.0)]
        })
        .collect();
    let mut lists = vec![Vec::new(); grid.tile_count() * n];
    for (i, l) in view_lights(&camera.view(), lights, inflate).iter().enumerate() {
        let (c, r) = (l.center, l.radius);
        let dist = -c.z;
        if !(r > 0.0 && dist + r > 0.0) {
            continue;
        }
        let Some(rect) = light_tile_rect(&grid, &proj, &dp, c, r) else { continue };
        let (lo, hi) = light_slices(cluster, dist, r);
        for ty in rect.y0..=rect.y1 {
            for tx in rect.x0..=rect.x1 {
                let t = (ty * grid.tiles_x + tx) as usize;
                let planes = cols[tx as usize].iter().chain(&rows[ty as usize]);
                if planes.into_iter().any(|p| p.truncate().dot(c) + p.w < -r) {
                    continue;
                }
                for s in lo..=hi {
                    if occupancy.as_ref().is_some_and(|o| o[t] & (1 << s) == 0) {
                        continue;
                    }
                    lists[t * n + s as usize].push(i as u32);
                }
            }
        }
    }
    let mut ranges = vec![None; grid.tile_count()];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            if let Some(b) = tile_depth_bounds_samples(&grid, depth, samples, tx, ty) {
                ranges[(ty * grid.tiles_x + tx) as usize] =
                    Some((dp.view_distance(b.max_depth), dp.view_distance(b.min_depth)));
            }
        }
    }
    Ok(TileLists { grid, config, lists, ranges, cluster: Some(*cluster) })
}
