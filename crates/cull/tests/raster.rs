//! The compute rasteriser's rules (`tiledlight_cull::raster`, issue 29) at the extremes,
//! against an exact reference: the pixel centre's ray meets the triangle's plane in f64
//! (`visibility::barycentrics_f64`, homogeneous, so triangles crossing the eye plane need
//! no clipping there). Random cameras (reversed-Z, infinite far; near 1e-3..1 m, field of
//! view 10-150 degrees), targets from 1x1 to 96x96 pixels and 16384x16384 for small
//! triangles, and six kinds of triangle: ordinary, slivers, sub-pixel, huge ones 1e6 m
//! away, ones crossing the near plane or the eye plane, and ones reaching past the guard
//! band.
//!
//! What must hold:
//! - **Sound**: a covered pixel's centre lies on the triangle in front of the near plane,
//!   up to what snapping the vertices to 1/256 px may move an edge (each weight's change
//!   over 1/128 px, from its exact screen gradient), and its depth is the exact depth up to
//!   the same snapping plus f32 rounding.
//! - **Complete**: a pixel whose centre lies on the triangle by more than that margin, in
//!   front of the near plane, is covered.
//! - **Watertight**: two triangles sharing an edge never both cover a pixel (the top-left
//!   rule), and a pixel inside the quad they make is covered (completeness of both).
//! - **Large triangles' tiles** (`large_tiles`, what the GPU's `cs_large` lists): every
//!   covered pixel lies in a listed tile, for every shape (clipped fans included).

mod common;

use common::{log_uniform, proptest_config, rng, unit};
use glam::{DVec2, DVec4, Mat4, Vec3, Vec4};
use proptest::prelude::*;
use rand::Rng;
use tiledlight_cull::raster::{large_tiles, rasterize, Cull, Fragment, LARGE_TILE};
use tiledlight_cull::visibility::{barycentrics_f64, pixel_ndc};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Ordinary,
    Sliver,
    SubPixel,
    Far,
    CrossingNear,
    PastGuardBand,
}

const SHAPES: [Shape; 6] =
    [Shape::Ordinary, Shape::Sliver, Shape::SubPixel, Shape::Far, Shape::CrossingNear, Shape::PastGuardBand];

/// A case: the projection, the triangle in view space, the target (shape and near plane
/// are printed with a failure).
#[derive(Clone, Debug)]
#[allow(dead_code)]
struct Case {
    shape: Shape,
    proj: Mat4,
    near: f32,
    view: [Vec3; 3],
    size: (u32, u32),
}

fn case(seed: u64, shape: Shape) -> Case {
    let mut r = rng(seed);
    let near = log_uniform(&mut r, 1e-3, 1.0);
    let fov = r.random_range(10f32..150.0).to_radians();
    let big = shape == Shape::SubPixel && r.random_bool(0.3);
    let size = if big { (16384, 16384) } else { (r.random_range(1..=96), r.random_range(1..=96)) };
    let aspect = size.0 as f32 / size.1 as f32;
    let proj = Mat4::perspective_infinite_reverse_rh(fov, aspect, near);
    // A point seen at NDC (x, y) at view distance d.
    let half = (fov * 0.5).tan();
    let at = |x: f32, y: f32, d: f32| Vec3::new(x * half * aspect * d, y * half * d, -d);
    let ndc = |r: &mut rand_pcg::Pcg64, s: f32| (r.random_range(-s..s), r.random_range(-s..s));
    let view = match shape {
        Shape::Ordinary => {
            let d = log_uniform(&mut r, near * 2.0, 100.0);
            [0, 1, 2].map(|_| {
                let (x, y) = ndc(&mut r, 1.3);
                at(x, y, d * r.random_range(0.5f32..2.0))
            })
        }
        Shape::Sliver => {
            let d = log_uniform(&mut r, near * 2.0, 100.0);
            let (x, y) = ndc(&mut r, 1.0);
            let a = at(x, y, d);
            let b = at(x + r.random_range(-1.0..1.0), y + r.random_range(-1.0..1.0), d * r.random_range(0.8f32..1.2));
            let t = r.random_range(0.0f32..1.0);
            let c = a.lerp(b, t) + unit(&mut r) * (a - b).length() * log_uniform(&mut r, 1e-6, 1e-2);
            [a, b, c]
        }
        Shape::SubPixel => {
            let d = log_uniform(&mut r, near * 2.0, 1e4);
            let (x, y) = ndc(&mut r, 1.0);
            let c = at(x, y, d);
            let pixel = 2.0 * half * d / size.1 as f32;
            let s = pixel * log_uniform(&mut r, 1e-3, 1.5);
            [c, c + unit(&mut r) * s, c + unit(&mut r) * s]
        }
        Shape::Far => {
            let d = log_uniform(&mut r, 1e5, 1e6);
            [0, 1, 2].map(|_| {
                let (x, y) = ndc(&mut r, 1.2);
                at(x, y, d * r.random_range(0.98f32..1.02))
            })
        }
        Shape::CrossingNear => {
            // One or two vertices nearer than the near plane or behind the eye.
            let d = log_uniform(&mut r, near * 2.0, 50.0);
            let behind = r.random_range(1..=2);
            let mut v = [0, 1, 2].map(|_| {
                let (x, y) = ndc(&mut r, 1.2);
                at(x, y, d * r.random_range(0.5f32..2.0))
            });
            for p in v.iter_mut().take(behind) {
                p.z =
                    if r.random_bool(0.5) { -near * r.random_range(0.01f32..0.99) } else { r.random_range(0.0f32..d) };
            }
            v
        }
        Shape::PastGuardBand => {
            let d = log_uniform(&mut r, near * 2.0, 100.0);
            let (x, y) = ndc(&mut r, 1.0);
            [at(x, y, d), at(x + r.random_range(-200.0..200.0), y, d), at(x, y + r.random_range(-200.0..200.0), d)]
        }
    };
    Case { shape, proj, near, view, size }
}

impl Case {
    fn clip(&self) -> [Vec4; 3] {
        self.view.map(|p| self.proj * p.extend(1.0))
    }

    fn fragments(&self, clip: [Vec4; 3]) -> Vec<Fragment> {
        let mut v = Vec::new();
        rasterize(clip, self.size, Cull::None, |f| v.push(f));
        v
    }
}

/// The exact surface at pixel `p`: weights, their per-pixel change, the hit's clip w and
/// its depth; None where the ray is parallel to the plane.
struct Exact {
    lambda: [f64; 3],
    margin: [f64; 3],
    w: f64,
    depth: f64,
    depth_margin: f64,
}

fn exact(clip: [Vec4; 3], p: (u32, u32), size: (u32, u32)) -> Option<Exact> {
    let c = clip.map(|v| DVec4::new(v.x.into(), v.y.into(), v.z.into(), v.w.into()));
    let ndc = pixel_ndc(p, size).as_dvec2();
    let (l, dx, dy) = barycentrics_f64(c, ndc, size)?;
    let interp = |l: glam::DVec3, f: fn(DVec4) -> f64| l.x * f(c[0]) + l.y * f(c[1]) + l.z * f(c[2]);
    let w = interp(l, |v| v.w);
    let z = interp(l, |v| v.z);
    let depth = z / w;
    // Snapping moves each vertex by up to 1/512 px a coordinate: an edge by at most 1/256
    // px; allow twice that through each weight's screen gradient.
    let margin = [dx.x.abs() + dy.x.abs(), dx.y.abs() + dy.y.abs(), dx.z.abs() + dy.z.abs()].map(|g| g / 128.0 + 1e-6);
    let depth_at = |q: DVec2| -> Option<f64> {
        let (l, _, _) = barycentrics_f64(c, q, size)?;
        Some(interp(l, |v| v.z) / interp(l, |v| v.w))
    };
    let step = DVec2::new(2.0 / size.0 as f64, -2.0 / size.1 as f64);
    let gx = depth_at(ndc + DVec2::new(step.x, 0.0)).map_or(0.0, |d| (d - depth).abs());
    let gy = depth_at(ndc + DVec2::new(0.0, step.y)).map_or(0.0, |d| (d - depth).abs());
    let zmax = c.iter().map(|v| (v.z / v.w).abs()).fold(0.0, f64::max).min(1e3);
    Some(Exact { lambda: [l.x, l.y, l.z], margin, w, depth, depth_margin: (gx + gy) / 128.0 + 4e-6 * zmax.max(depth) })
}

/// The pixels checked for completeness: the whole target when small, else the covered
/// pixels' neighbourhood (a 16384x16384 target holds only small triangles).
fn region(c: &Case, frags: &[Fragment]) -> Vec<(u32, u32)> {
    if c.size.0 as u64 * c.size.1 as u64 <= 96 * 96 {
        return (0..c.size.1).flat_map(|y| (0..c.size.0).map(move |x| (x, y))).collect();
    }
    let clip = c.clip();
    // The projected vertices' box (all in front: sub-pixel triangles), two pixels wider.
    let px: Vec<(f32, f32)> = clip
        .iter()
        .map(|v| ((v.x / v.w + 1.0) * 0.5 * c.size.0 as f32, (1.0 - v.y / v.w) * 0.5 * c.size.1 as f32))
        .collect();
    let lo = |a: f32| (a.floor() as i64 - 2).max(0) as u32;
    let (x0, x1) = (lo(px.iter().map(|p| p.0).fold(f32::MAX, f32::min)), px.iter().map(|p| p.0).fold(0.0, f32::max));
    let (y0, y1) = (lo(px.iter().map(|p| p.1).fold(f32::MAX, f32::min)), px.iter().map(|p| p.1).fold(0.0, f32::max));
    let (x1, y1) = ((x1 as u32 + 2).min(c.size.0 - 1), (y1 as u32 + 2).min(c.size.1 - 1));
    let mut out: Vec<(u32, u32)> = (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| (x, y))).collect();
    out.extend(frags.iter().map(|f| (f.x, f.y)));
    out
}

fn check(c: &Case) -> Result<(usize, usize), String> {
    let clip = c.clip();
    let frags = c.fragments(clip);
    let mut covered = std::collections::HashSet::new();
    for f in &frags {
        if !covered.insert((f.x, f.y)) {
            return Err(format!("pixel ({}, {}) emitted twice", f.x, f.y));
        }
        let Some(e) = exact(clip, (f.x, f.y), c.size) else { continue };
        for k in 0..3 {
            if e.lambda[k] < -e.margin[k] {
                return Err(format!(
                    "pixel ({}, {}) covered outside the triangle: weight {k} {} (margin {})",
                    f.x, f.y, e.lambda[k], e.margin[k]
                ));
            }
        }
        if e.w.is_nan() || e.w <= 0.0 {
            return Err(format!("pixel ({}, {}) covered where the ray meets the plane behind the eye", f.x, f.y));
        }
        if e.depth > 1.0 + e.depth_margin || e.depth < -e.depth_margin {
            return Err(format!("pixel ({}, {}) covered at depth {} outside [0, 1]", f.x, f.y, e.depth));
        }
        let err = (f64::from(f.depth) - e.depth.clamp(0.0, 1.0)).abs();
        if err > e.depth_margin {
            return Err(format!(
                "pixel ({}, {}) depth {} exact {} (margin {})",
                f.x, f.y, f.depth, e.depth, e.depth_margin
            ));
        }
    }
    let mut inside = 0;
    for p in region(c, &frags) {
        let Some(e) = exact(clip, p, c.size) else { continue };
        let deep = (0..3).all(|k| e.lambda[k] > e.margin[k])
            && e.w > 0.0
            && e.depth < 1.0 - e.depth_margin
            && e.depth > e.depth_margin;
        if deep {
            inside += 1;
            if !covered.contains(&p) {
                return Err(format!(
                    "pixel {p:?} inside the triangle (weights {:?}, depth {}) not covered",
                    e.lambda, e.depth
                ));
            }
        }
    }
    Ok((frags.len(), inside))
}

proptest! {
    #![proptest_config(proptest_config(256))]

    /// Sound and complete for every shape (module doc).
    #[test]
    fn covers_what_the_exact_triangle_covers(seed in any::<u64>(), s in 0usize..6) {
        let c = case(seed, SHAPES[s]);
        check(&c).map_err(|e| TestCaseError::fail(format!("{e}\n{c:?}")))?;
    }

    /// Every covered pixel of every shape lies in one of the tiles `large_tiles` lists.
    #[test]
    fn the_large_tiles_hold_every_covered_pixel(seed in any::<u64>(), s in 0usize..6) {
        let c = case(seed, SHAPES[s]);
        let clip = c.clip();
        tiles_hold(&large_tiles(clip, c.size, Cull::None), &c.fragments(clip))
            .map_err(|e| TestCaseError::fail(format!("{e}\n{c:?}")))?;
    }

    /// Two triangles sharing an edge (a quad split along its diagonal, either way) never
    /// both cover a pixel.
    #[test]
    fn a_shared_edge_is_drawn_once(seed in any::<u64>()) {
        let mut r = rng(seed);
        let c = case(seed, if r.random_bool(0.5) { Shape::Ordinary } else { Shape::CrossingNear });
        let d = c.view[0].lerp(c.view[1], 0.5) + (c.view[2] - c.view[0]) * r.random_range(-1.0f32..-0.1);
        let quad = [c.view[0], c.view[1], c.view[2], d];
        let clip = |p: Vec3| c.proj * p.extend(1.0);
        let (t1, t2) = ([clip(quad[0]), clip(quad[1]), clip(quad[2])], [clip(quad[0]), clip(quad[3]), clip(quad[1])]);
        let a: std::collections::HashSet<(u32, u32)> = c.fragments(t1).iter().map(|f| (f.x, f.y)).collect();
        for f in c.fragments(t2) {
            prop_assert!(!a.contains(&(f.x, f.y)), "pixel ({}, {}) drawn by both triangles of {:?}", f.x, f.y, c);
        }
    }
}

/// The property's teeth: each shape produces covered pixels and checked interior pixels
/// over the first seeds (a generator that only made empty or off-screen triangles would
/// prove nothing), and the soundness check rejects a triangle shifted by one pixel.
#[test]
fn the_property_sees_pixels_and_rejects_a_shifted_triangle() {
    for shape in SHAPES {
        let (mut frags, mut inside) = (0, 0);
        for seed in 0..200 {
            let (f, i) = check(&case(seed, shape)).unwrap_or_else(|e| panic!("{shape:?} seed {seed}: {e}"));
            frags += f;
            inside += i;
        }
        eprintln!("{shape:?}: {frags} covered pixels, {inside} interior pixels checked");
        assert!(frags > 0, "{shape:?} covers nothing");
        if shape != Shape::SubPixel && shape != Shape::Sliver {
            assert!(inside > 0, "{shape:?} checks no interior pixel");
        }
    }
    // A rasteriser off by one pixel: its fragments against the unshifted triangle.
    let c = (0..)
        .map(|s| case(s, Shape::Ordinary))
        .find(|c| c.size.0 > 16 && c.size.1 > 16 && c.fragments(c.clip()).len() > 20)
        .unwrap();
    let clip = c.clip();
    let shifted = clip.map(|v| v + Vec4::new(2.0 / c.size.0 as f32 * v.w, 0.0, 0.0, 0.0));
    let bad = c.fragments(shifted);
    let outside = bad
        .iter()
        .filter(|f| exact(clip, (f.x, f.y), c.size).is_some_and(|e| (0..3).any(|k| e.lambda[k] < -e.margin[k])))
        .count();
    assert!(outside > 0, "a one-pixel shift must put some fragment outside the triangle");
}

/// Whether every fragment's pixel lies in one of `tiles` (`[piece, x, y]`, the piece not
/// checked: `rasterize` does not say which piece covered a pixel).
fn tiles_hold(tiles: &[[u32; 3]], frags: &[Fragment]) -> Result<(), String> {
    let set: std::collections::HashSet<(u32, u32)> = tiles.iter().map(|t| (t[1], t[2])).collect();
    match frags.iter().find(|f| !set.contains(&(f.x / LARGE_TILE, f.y / LARGE_TILE))) {
        Some(f) => Err(format!("pixel ({}, {}) is in no listed tile ({} listed)", f.x, f.y, tiles.len())),
        None => Ok(()),
    }
}

/// The tiles of a triangle filling the lower-left half of a 64 x 64 target: the ten tiles
/// on and below the diagonal, not the six above it that no pixel centre of the triangle
/// reaches; and `tiles_hold` rejects the list with any one of them left out. A triangle
/// clipped by the near plane lists its tiles per piece of its fan.
#[test]
fn a_half_screen_triangle_lists_the_tiles_on_its_side() {
    let size = (64, 64);
    // Counter-clockwise in NDC: (-1, -1), (1, -1), (-1, 1); window y down.
    let tri = [Vec4::new(-1.0, -1.0, 0.5, 1.0), Vec4::new(1.0, -1.0, 0.5, 1.0), Vec4::new(-1.0, 1.0, 0.5, 1.0)];
    let tiles = large_tiles(tri, size, Cull::Back);
    let mut got: Vec<(u32, u32)> = tiles.iter().map(|t| (t[1], t[2])).collect();
    got.sort_unstable();
    let mut want: Vec<(u32, u32)> = (0..4).flat_map(|y| (0..4).map(move |x| (x, y))).filter(|&(x, y)| x <= y).collect();
    want.sort_unstable();
    assert_eq!(got, want);
    assert!(tiles.iter().all(|t| t[0] == 0));
    let mut frags = Vec::new();
    rasterize(tri, size, Cull::Back, |f| frags.push(f));
    tiles_hold(&tiles, &frags).unwrap();
    for k in 0..tiles.len() {
        let mut fewer = tiles.clone();
        fewer.remove(k);
        assert!(tiles_hold(&fewer, &frags).is_err(), "tile {:?} left out must be caught", tiles[k]);
    }
    // Back faces are culled as rasterize culls them; nothing off screen is listed.
    assert!(large_tiles([tri[0], tri[2], tri[1]], size, Cull::Back).is_empty());
    assert!(large_tiles(tri.map(|v| v + Vec4::new(3.0, 0.0, 0.0, 0.0)), size, Cull::None).is_empty());
    // Crossing the near plane (z > w at one vertex): a fan of two pieces, each listing tiles.
    let near = [Vec4::new(-1.0, -1.0, 0.5, 1.0), Vec4::new(1.0, -1.0, 0.5, 1.0), Vec4::new(-1.0, 1.0, 2.0, 1.0)];
    let pieces: std::collections::BTreeSet<u32> = large_tiles(near, size, Cull::None).iter().map(|t| t[0]).collect();
    assert_eq!(pieces.into_iter().collect::<Vec<_>>(), vec![0, 1]);
}
