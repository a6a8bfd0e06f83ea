//! Lights per tile estimated on the CPU without a GPU frame, for light counts (a million)
//! where the brute-force reference ([`crate::reference::cull_tiles`], every light
//! against every tile) is too slow: a sample of tiles is ray cast pixel by pixel
//! ([`Triangles::first_hit`]) for its depth range, and only the lights near the tile's
//! volume (a hash grid of light centres, walked slice by slice along the volume) are
//! tested, with the GPU kernel's test (side planes + depth range, [`sphere_vs_frustum`]).
//! So the count of a sampled tile is the GPU's (default tests, one list per tile) for
//! the same depth buffer. Depends on this crate's camera, tiles, bounds, light and
//! raycast modules.

use std::collections::HashMap;

use glam::{IVec3, Vec3};

use crate::bounds::{sphere_vs_frustum, to_view};
use crate::camera::Camera;
use crate::error::CullError;
use crate::light::Light;
use crate::raycast::Triangles;
use crate::tiles::{pixel_to_ndc_x, pixel_to_ndc_y, DepthBounds, TileFrustum, TileGrid};

/// What [`estimate_lights_per_tile`] found over its sampled tiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileEstimate {
    /// Tiles sampled that show some surface (all-sky tiles cull nothing and are left out).
    pub tiles: usize,
    /// Tiles sampled that show only sky.
    pub sky_tiles: usize,
    /// Mean over `tiles` of the lights the tile's volume test keeps.
    pub mean_culled: f64,
    /// Largest such count.
    pub max_culled: usize,
    /// Mean over `tiles` of the lights whose sphere holds some pixel's surface point (the
    /// lights that really light the tile; an exact culler's count).
    pub mean_reaching: f64,
}

/// The reversed-Z depth of every pixel of tile (tx, ty), row-major within the tile, from
/// rays cast through the pixel centres (0 where the ray hits nothing before the far
/// plane), and the world positions hit.
fn tile_depths(tris: &Triangles, camera: &Camera, grid: &TileGrid, tx: u32, ty: u32) -> (Vec<f32>, Vec<Vec3>) {
    let (x0, x1, y0, y1) = grid.tile_pixels(tx, ty);
    let to_world = camera.view().inverse();
    let dp = camera.depth_params();
    let mut depths = Vec::new();
    let mut hits = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let nx = pixel_to_ndc_x(x as f32 + 0.5, grid.width);
            let ny = pixel_to_ndc_y(y as f32 + 0.5, grid.height);
            // A ray from the near plane (the eye plane for an orthographic camera would
            // also do) along the pixel's line of sight; works for both projections.
            let a = camera.view_point_at(nx, ny, dp.near);
            let b = camera.view_point_at(nx, ny, dp.near + 1.0);
            let (origin, dir) = (to_world.transform_point3(a), to_world.transform_vector3(b - a));
            let hit = tris.first_hit(origin, dir, f32::INFINITY).map(|t| origin + dir.normalize() * t);
            let depth = hit.map_or(0.0, |p| {
                let dist = -to_view(&camera.view(), p).z;
                dp.depth(dist).clamp(0.0, 1.0)
            });
            if let Some(p) = hit.filter(|_| depth > 0.0) {
                hits.push(p);
            }
            depths.push(depth);
        }
    }
    (depths, hits)
}

/// A hash grid of light bounding spheres' centres, cells of the largest radius.
struct LightGrid {
    cell: f32,
    cells: HashMap<IVec3, Vec<u32>>,
}

impl LightGrid {
    fn new(spheres: &[(Vec3, f32)]) -> Self {
        let cell = spheres.iter().map(|s| s.1).fold(0.0f32, f32::max).max(1e-3);
        let mut cells: HashMap<IVec3, Vec<u32>> = HashMap::new();
        for (i, (c, _)) in spheres.iter().enumerate() {
            cells.entry((*c / cell).floor().as_ivec3()).or_default().push(i as u32);
        }
        Self { cell, cells }
    }

    /// Appends the lights whose centre lies in a cell overlapping the box grown by two
    /// cells: the plane test keeps spheres off a corner of the volume, up to about
    /// `sqrt(3) * radius` away from it (the planes meet nearly at right angles there).
    fn gather(&self, lo: Vec3, hi: Vec3, out: &mut Vec<u32>) {
        let a = ((lo - 2.0 * self.cell) / self.cell).floor().as_ivec3();
        let b = ((hi + 2.0 * self.cell) / self.cell).floor().as_ivec3();
        for z in a.z..=b.z {
            for y in a.y..=b.y {
                for x in a.x..=b.x {
                    if let Some(v) = self.cells.get(&IVec3::new(x, y, z)) {
                        out.extend_from_slice(v);
                    }
                }
            }
        }
    }
}

/// Estimates the lights per `tile_size` tile of a `width` x `height` frame that `camera`
/// sees of `tris`, lit by `lights`: every `stride`-th tile in x and y is ray cast and
/// culled (planes + depth range, the GPU's default test, one list per tile; spot lights by
/// their bounding sphere, without the optional cone test).
///
/// Errors: a bad screen or tile size ([`TileGrid::new`]), `stride` 0.
pub fn estimate_lights_per_tile(
    tris: &Triangles,
    camera: &Camera,
    (width, height): (u32, u32),
    tile_size: u32,
    lights: &[Light],
    stride: u32,
) -> Result<TileEstimate, CullError> {
    let grid = TileGrid::new(width, height, tile_size)?;
    if stride == 0 {
        return Err(CullError::InvalidSize(
            "estimate stride 0: must be at least 1 (every stride-th tile is sampled)".into(),
        ));
    }
    let spheres: Vec<(Vec3, f32)> = lights.iter().map(Light::bounding_sphere).collect();
    let light_grid = LightGrid::new(&spheres);
    let view = camera.view();
    let to_world = view.inverse();
    let (mut tiles, mut sky_tiles, mut sum_culled, mut max_culled, mut sum_reaching) = (0, 0, 0usize, 0, 0usize);
    let mut candidates = Vec::new();
    for ty in (0..grid.tiles_y).step_by(stride as usize) {
        for tx in (0..grid.tiles_x).step_by(stride as usize) {
            let (depths, hits) = tile_depths(tris, camera, &grid, tx, ty);
            let lo = depths.iter().copied().filter(|&d| d > 0.0).fold(f32::INFINITY, f32::min);
            let hi = depths.iter().copied().fold(0.0f32, f32::max);
            if hi <= 0.0 {
                sky_tiles += 1;
                continue;
            }
            let f = TileFrustum::new(&grid, camera, tx, ty, DepthBounds { min_depth: lo, max_depth: hi });
            // Walk the volume in slices about as deep as they are wide (and at least a
            // grid cell), so each slice's box stays close to the volume.
            candidates.clear();
            let (l, r, b, t) = f.ndc;
            let mut d0 = f.near;
            while d0 < f.far {
                let width_at = |d: f32| {
                    (camera.view_point_at(r, t, d) - camera.view_point_at(l, b, d)).length().max(light_grid.cell)
                };
                let d1 = (d0 + width_at(d0)).min(f.far);
                let (mut blo, mut bhi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                for d in [d0, d1] {
                    for (x, y) in [(l, b), (r, b), (l, t), (r, t)] {
                        let p = to_world.transform_point3(camera.view_point_at(x, y, d));
                        (blo, bhi) = (blo.min(p), bhi.max(p));
                    }
                }
                light_grid.gather(blo, bhi, &mut candidates);
                d0 = d1;
            }
            candidates.sort_unstable();
            candidates.dedup();
            let (mut culled, mut reaching) = (0, 0);
            for &i in &candidates {
                let (c, radius) = spheres[i as usize];
                if radius > 0.0 && sphere_vs_frustum(&f, to_view(&view, c), radius) {
                    culled += 1;
                    reaching += usize::from(hits.iter().any(|p| (*p - c).length_squared() < radius * radius));
                }
            }
            tiles += 1;
            sum_culled += culled;
            sum_reaching += reaching;
            max_culled = max_culled.max(culled);
        }
    }
    let mean = |s: usize| if tiles == 0 { 0.0 } else { s as f64 / tiles as f64 };
    Ok(TileEstimate { tiles, sky_tiles, mean_culled: mean(sum_culled), max_culled, mean_reaching: mean(sum_reaching) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::try_pack_lights;
    use crate::lists::CullConfig;
    use crate::reference::cull_tiles;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// A floor, a wall behind it and a box on the floor, as triangles.
    fn scene() -> Vec<[Vec3; 3]> {
        let quad = |o: Vec3, u: Vec3, v: Vec3| [[o, o + u, o + u + v], [o, o + u + v, o + v]];
        let mut t = Vec::new();
        t.extend(quad(Vec3::new(-10.0, 0.0, 10.0), Vec3::X * 20.0, Vec3::NEG_Z * 20.0));
        t.extend(quad(Vec3::new(-10.0, 0.0, -10.0), Vec3::X * 20.0, Vec3::Y * 8.0));
        t.extend(quad(Vec3::new(-1.0, 0.0, 1.0), Vec3::X * 2.0, Vec3::Y * 2.0));
        t.extend(quad(Vec3::new(-1.0, 2.0, 1.0), Vec3::X * 2.0, Vec3::NEG_Z * 2.0));
        t
    }

    #[test]
    fn sampled_tiles_count_what_the_reference_culler_counts() {
        let tris = Triangles::new(scene());
        let (w, h) = (96, 64);
        let cam =
            Camera::perspective(Vec3::new(0.0, 4.0, 12.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 1.0, 1.5, 0.1, None)
                .unwrap();
        let mut rng = Pcg64::seed_from_u64(5);
        let lights: Vec<Light> = (0..3000)
            .map(|_| {
                let p =
                    Vec3::new(rng.random_range(-10.0..10.0), rng.random_range(0.0..8.0), rng.random_range(-10.0..10.0));
                Light::point(p, Vec3::ONE, rng.random_range(0.01..0.2), 0.1).unwrap()
            })
            .collect();
        // The full depth buffer, ray cast the same way, culled by the reference.
        let grid = TileGrid::new(w, h, 16).unwrap();
        let mut depth = vec![0.0; (w * h) as usize];
        for ty in 0..grid.tiles_y {
            for tx in 0..grid.tiles_x {
                let (d, _) = tile_depths(&tris, &cam, &grid, tx, ty);
                let (x0, x1, y0, y1) = grid.tile_pixels(tx, ty);
                let tw = (x1 - x0) as usize;
                for y in y0..y1 {
                    let row = (y - y0) as usize * tw;
                    depth[(y * w + x0) as usize..(y * w + x1) as usize].copy_from_slice(&d[row..row + tw]);
                }
            }
        }
        let packed = try_pack_lights(&lights).unwrap();
        let cfg = CullConfig { capacity: 2048, ..CullConfig::default() };
        let reference = cull_tiles(&depth, w, h, &cam, &packed, &cfg).unwrap();
        let counts: Vec<usize> = reference.lists.iter().map(Vec::len).collect();
        let est = estimate_lights_per_tile(&tris, &cam, (w, h), 16, &lights, 1).unwrap();
        let lit: Vec<usize> = (0..grid.tile_count()).filter(|&i| reference.ranges[i].is_some()).collect();
        assert_eq!(est.tiles + est.sky_tiles, grid.tile_count());
        assert_eq!(est.tiles, lit.len());
        let mean = lit.iter().map(|&i| counts[i]).sum::<usize>() as f64 / lit.len() as f64;
        assert!((est.mean_culled - mean).abs() < 1e-9, "estimate {} vs reference {mean}", est.mean_culled);
        assert_eq!(est.max_culled, lit.iter().map(|&i| counts[i]).max().unwrap());
        assert!(est.mean_reaching > 0.0 && est.mean_reaching <= est.mean_culled, "{est:?}");
        // A stride samples fewer tiles; a zero stride is refused.
        let sparse = estimate_lights_per_tile(&tris, &cam, (w, h), 16, &lights, 2).unwrap();
        assert_eq!(sparse.tiles + sparse.sky_tiles, 3 * 2);
        assert!(estimate_lights_per_tile(&tris, &cam, (w, h), 16, &lights, 0).is_err());
    }
}
