//! The CPU reference culler, the twin every GPU culling kernel is compared with:
//! [`cull_tiles`] dispatches to the technique the configuration asks for (tile-centric
//! [`crate::gather`] or light-centric [`crate::assign`]; clusters: [`crate::cluster`], blended
//! geometry: [`crate::gather::cull_tiles_blended`]). Also the ground truth (which lights
//! really reach a pixel), culling statistics and the quality of a set of lists (from the
//! CPU or read back from a GPU). The top of the culling modules: it depends on them
//! ([`crate::lists`], [`crate::volumes`], [`crate::gather`], [`crate::assign`]), none on it.

use glam::{Mat4, Vec3};

use crate::bounds::to_view;
use crate::camera::Camera;
use crate::error::CullError;
use crate::light::PackedLights;
use crate::lists::{CullConfig, TileLists};
use crate::tiles::{pixel_to_ndc_x, pixel_to_ndc_y, tile_depth_bounds, TileFrustum, TileGrid};
use crate::volumes::check_depth;

/// Culls `lights` (packed points first, as uploaded) against every tile of a reversed-Z
/// `depth` buffer (row-major, `width * height`), as the GPU kernel does: tile by tile
/// ([`crate::gather::cull_tiles_gather`]), or light by light with `config.scatter`
/// ([`crate::assign::cull_tiles_scatter`]).
pub fn cull_tiles(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
    config: &CullConfig,
) -> Result<TileLists, CullError> {
    if config.scatter {
        crate::assign::cull_tiles_scatter(depth, width, height, camera, lights, config)
    } else {
        crate::gather::cull_tiles_gather(depth, width, height, camera, lights, config)
    }
}

/// View-space position of the centre of pixel (x, y) with reversed-Z depth `d`, or `None`
/// for sky. The position every renderer shades.
pub fn pixel_view_position(camera: &Camera, width: u32, height: u32, x: u32, y: u32, d: f32) -> Option<Vec3> {
    if d <= 0.0 {
        return None;
    }
    camera.unproject_view(pixel_to_ndc_x(x as f32 + 0.5, width), pixel_to_ndc_y(y as f32 + 0.5, height), d)
}

/// Lights in view space, ready for the ground-truth test of whether a light reaches a point.
struct ReachTest {
    lights: Vec<ReachLight>,
}

/// A light's centre, radius, and a spot's view-space axis and cos outer.
type ReachLight = (Vec3, f32, Option<(Vec3, f32)>);

impl ReachTest {
    fn new(view: &Mat4, lights: &PackedLights) -> Self {
        let rot = Mat4::from_mat3(glam::Mat3::from_mat4(*view));
        let lights = (0..lights.len())
            .map(|i| {
                let sh = lights.shading[i];
                let spot = (i >= lights.num_point as usize).then(|| {
                    let s = lights.spots[i - lights.num_point as usize];
                    (to_view(&rot, Vec3::from(s.direction)), s.cos_outer)
                });
                (to_view(view, Vec3::from(sh.position)), sh.radius, spot)
            })
            .collect();
        Self { lights }
    }

    /// Whether light `i` reaches view-space `p` with `margin` (a fraction of the radius,
    /// and of the cone's angular width) to spare.
    fn reaches(&self, i: u32, p: Vec3, margin: f32) -> bool {
        let (pos, radius, spot) = self.lights[i as usize];
        let d = p - pos;
        let len = d.length();
        if len >= radius * (1.0 - margin) {
            return false;
        }
        // Inside the cone by an angular margin too: cos of the angle to the axis above cos_outer.
        spot.is_none_or(|(axis, c)| len > 0.0 && d.dot(axis) / len > c + margin * (1.0 - c))
    }
}

/// Ground truth: the lights (indices into the packed order) whose light volume contains
/// view-space point `p` with at least `margin` (a fraction of the radius) to spare:
/// strictly inside the radius and, for spots, inside the outer cone.
pub fn lights_reaching(view: &Mat4, lights: &PackedLights, p: Vec3, margin: f32) -> Vec<u32> {
    let t = ReachTest::new(view, lights);
    (0..lights.len() as u32).filter(|&i| t.reaches(i, p, margin)).collect()
}

/// Culling statistics of a set of lists.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CullStats {
    /// Mean lights per list over lists of tiles with geometry (for clusters: over every
    /// slice of those tiles, empty slices included).
    pub mean_per_list: f64,
    /// Largest light count of a list.
    pub max_per_list: u32,
    /// Lists whose count exceeds the capacity.
    pub overflowing: u32,
    /// Tiles with geometry.
    pub tiles_with_geometry: u32,
}

/// Mean/max/overflow statistics of `lists`.
pub fn stats(lists: &TileLists) -> CullStats {
    let per = lists.lists_per_tile();
    let mut s = CullStats::default();
    let mut sum = 0u64;
    let mut n = 0u64;
    for (t, r) in lists.ranges.iter().enumerate() {
        if r.is_none() {
            continue;
        }
        s.tiles_with_geometry += 1;
        for k in 0..per {
            let c = lists.lists[t * per + k].len() as u32;
            sum += c as u64;
            n += 1;
            s.max_per_list = s.max_per_list.max(c);
        }
    }
    s.overflowing = lists.overflowing_lists() as u32;
    s.mean_per_list = if n > 0 { sum as f64 / n as f64 } else { 0.0 };
    s
}

/// How well a set of lists fits the pixels that use them, the cost side of culling.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ListQuality {
    /// Fraction of listed (list, light) pairs whose light reaches no pixel using the list:
    /// the culling test's false-positive rate.
    pub false_positive_rate: f64,
    /// Per pixel with geometry, lights in its list that do not reach it (the shader
    /// evaluates them for nothing), averaged over those pixels.
    pub wasted_per_pixel: f64,
    /// Per pixel with geometry, lights in its list, averaged: the evaluations shading does.
    pub evaluated_per_pixel: f64,
    /// Pixels with geometry.
    pub pixels: u64,
}

/// The view distance range of every tile's surfaces (None for all-sky tiles), as the
/// culler computes it: what half-z splits and [`TileLists::list_index`] needs.
pub fn tile_ranges(depth: &[f32], grid: &TileGrid, camera: &Camera) -> Result<Vec<Option<(f32, f32)>>, CullError> {
    check_depth(grid, depth)?;
    let mut ranges = vec![None; grid.tile_count()];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            if let Some(b) = tile_depth_bounds(grid, depth, tx, ty) {
                let f = TileFrustum::new(grid, camera, tx, ty, b);
                ranges[(ty * grid.tiles_x + tx) as usize] = Some((f.near, f.far));
            }
        }
    }
    Ok(ranges)
}

/// [`ListQuality`] of `lists` (from this culler or read back from a GPU) for a frame:
/// every pixel tests only the lights of its own list with [`lights_reaching`]'s test (margin
/// 0), so it costs pixels x mean list length and runs on full-HD frames in seconds. A light
/// that reaches a pixel but is missing from its list (a false negative) counts nowhere.
pub fn list_quality(depth: &[f32], camera: &Camera, lights: &PackedLights, lists: &TileLists) -> ListQuality {
    let g = lists.grid;
    let test = ReachTest::new(&camera.view(), lights);
    // Rows of tiles touch disjoint lists, so bands of them run on separate threads with no
    // shared state, and the integer sums are the same whatever the thread count.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(g.tiles_y as usize).max(1);
    let band = (g.tiles_y as usize).div_ceil(threads) as u32;
    let counts: Vec<[u64; 5]> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..g.tiles_y)
            .step_by(band as usize)
            .map(|ty0| {
                let test = &test;
                s.spawn(move || quality_of_rows(depth, camera, test, lists, ty0..(ty0 + band).min(g.tiles_y)))
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("a list-quality thread panicked")).collect()
    });
    let [evaluated, wasted, pixels, listed, unused] =
        counts.iter().fold([0u64; 5], |acc, c| std::array::from_fn(|i| acc[i] + c[i]));
    let per_pixel = |n: u64| if pixels > 0 { n as f64 / pixels as f64 } else { 0.0 };
    ListQuality {
        false_positive_rate: if listed > 0 { unused as f64 / listed as f64 } else { 0.0 },
        wasted_per_pixel: per_pixel(wasted),
        evaluated_per_pixel: per_pixel(evaluated),
        pixels,
    }
}

/// [`list_quality`]'s counts over the tile rows `rows`: evaluated, wasted, pixels, listed
/// pairs, listed pairs reaching no pixel.
fn quality_of_rows(
    depth: &[f32],
    camera: &Camera,
    test: &ReachTest,
    lists: &TileLists,
    rows: std::ops::Range<u32>,
) -> [u64; 5] {
    let g = lists.grid;
    let dp = camera.depth_params();
    let per = lists.lists_per_tile();
    let first = rows.start as usize * g.tiles_x as usize * per;
    let last = rows.end as usize * g.tiles_x as usize * per;
    let mut used: Vec<Vec<bool>> = lists.lists[first..last].iter().map(|l| vec![false; l.len()]).collect();
    let (mut evaluated, mut wasted, mut pixels) = (0u64, 0u64, 0u64);
    let y_end = (rows.end * g.tile_size).min(g.height);
    for y in rows.start * g.tile_size..y_end {
        for x in 0..g.width {
            let d = depth[(y * g.width + x) as usize];
            let Some(p) = pixel_view_position(camera, g.width, g.height, x, y, d) else { continue };
            let li = lists.list_index(g.tile_of_pixel(x, y), dp.view_distance(d));
            pixels += 1;
            for (k, &i) in lists.lists[li].iter().enumerate() {
                evaluated += 1;
                if test.reaches(i, p, 0.0) {
                    used[li - first][k] = true;
                } else {
                    wasted += 1;
                }
            }
        }
    }
    let listed = used.iter().map(|u| u.len() as u64).sum();
    let unused = used.iter().map(|u| u.iter().filter(|&&b| !b).count() as u64).sum();
    [evaluated, wasted, pixels, listed, unused]
}

/// Fraction of listed (tile, light) pairs whose light reaches no pixel of the tile (or of
/// the list's half, with half-z): the culling test's false-positive rate
/// ([`list_quality`]'s, which also gives the wasted evaluations per pixel).
pub fn false_positive_rate(depth: &[f32], camera: &Camera, lights: &PackedLights, lists: &TileLists) -> f64 {
    list_quality(depth, camera, lights, lists).false_positive_rate
}
