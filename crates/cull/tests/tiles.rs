//! Screen tiling and tile volumes: the grid of 1x1, 17x9 and 1921x1081 screens with 1, 8,
//! 16 and 32 px tiles covers every pixel exactly once (partial edge tiles included); the
//! NDC edges of adjacent tiles are bit-for-bit equal and the outer ones are exactly +-1;
//! the four side planes of a tile keep every point that projects inside the tile's NDC
//! rectangle and reject every pixel centre of the neighbouring tiles, at the extremes
//! (1 px tiles, FOV 1 and 170 degrees, aspect 0.1 and 10, orthographic); the tile's
//! view-space AABB holds every pixel of it; tile depth bounds skip sky.

mod common;

use common::{rng, EPS};
use glam::{Vec3, Vec4};
use rand::Rng;
use tiledlight_cull::tiles::{
    pixel_to_ndc_x, pixel_to_ndc_y, tile_depth_bounds, DepthBounds, TileFrustum, MAX_SCREEN_SIDE,
};
use tiledlight_cull::{Camera, CullError, TileGrid};

const SCREENS: [(u32, u32); 3] = [(1, 1), (17, 9), (1921, 1081)];
const TILES: [u32; 4] = [1, 8, 16, 32];

#[test]
fn grid_covers_every_pixel_exactly_once() {
    for (w, h) in SCREENS {
        for ts in TILES {
            let g = TileGrid::new(w, h, ts).unwrap();
            assert_eq!((g.tiles_x, g.tiles_y), (w.div_ceil(ts), h.div_ceil(ts)));
            assert_eq!(g.tile_count(), (g.tiles_x * g.tiles_y) as usize);
            let mut hits = vec![0u8; (w * h) as usize];
            for ty in 0..g.tiles_y {
                for tx in 0..g.tiles_x {
                    let (x0, x1, y0, y1) = g.tile_pixels(tx, ty);
                    assert!(x0 < x1 && y0 < y1, "{w}x{h}/{ts}: tile ({tx}, {ty}) is empty");
                    assert!(x1 - x0 <= ts && y1 - y0 <= ts);
                    for y in y0..y1 {
                        for x in x0..x1 {
                            hits[(y * w + x) as usize] += 1;
                            assert_eq!(
                                g.tile_of_pixel(x, y),
                                (ty * g.tiles_x + tx) as usize,
                                "{w}x{h}/{ts}: pixel ({x}, {y})"
                            );
                        }
                    }
                }
            }
            assert!(
                hits.iter().all(|&n| n == 1),
                "{w}x{h}/{ts}: a pixel is covered {} times",
                hits.iter().find(|&&n| n != 1).unwrap()
            );
            // The last column and row are partial exactly when the size is not a multiple.
            let (x0, x1, y0, y1) = g.tile_pixels(g.tiles_x - 1, g.tiles_y - 1);
            assert_eq!((x1 - x0, y1 - y0), (w - (g.tiles_x - 1) * ts, h - (g.tiles_y - 1) * ts));
        }
    }
}

#[test]
fn grid_rejects_bad_sizes() {
    for (w, h, ts) in [
        (0, 10, 16),
        (10, 0, 16),
        (MAX_SCREEN_SIDE + 1, 10, 16),
        (10, MAX_SCREEN_SIDE + 1, 16),
        (10, 10, 0),
        (10, 10, 65),
    ] {
        assert!(matches!(TileGrid::new(w, h, ts), Err(CullError::InvalidSize(_))), "{w}x{h}/{ts} accepted");
    }
    TileGrid::new(MAX_SCREEN_SIDE, MAX_SCREEN_SIDE, 64).unwrap();
}

#[test]
fn adjacent_tile_edges_coincide_bit_for_bit() {
    for (w, h) in SCREENS.into_iter().chain([(1920, 1080), (7, 3000)]) {
        for ts in TILES.into_iter().chain([3, 13, 64]) {
            let g = TileGrid::new(w, h, ts).unwrap();
            for ty in 0..g.tiles_y {
                for tx in 0..g.tiles_x {
                    let (l, r, b, t) = g.tile_ndc(tx, ty);
                    assert!(l < r && b < t, "{w}x{h}/{ts} ({tx}, {ty}): {:?}", (l, r, b, t));
                    if tx + 1 < g.tiles_x {
                        assert_eq!(
                            r.to_bits(),
                            g.tile_ndc(tx + 1, ty).0.to_bits(),
                            "{w}x{h}/{ts} ({tx}, {ty}) right edge"
                        );
                    } else {
                        assert_eq!(r, 1.0, "{w}x{h}/{ts}: the last column ends at the screen edge");
                    }
                    if ty + 1 < g.tiles_y {
                        // Row 0 is at the top: the next row's top is this row's bottom.
                        assert_eq!(
                            b.to_bits(),
                            g.tile_ndc(tx, ty + 1).3.to_bits(),
                            "{w}x{h}/{ts} ({tx}, {ty}) bottom edge"
                        );
                    } else {
                        assert_eq!(b, -1.0, "{w}x{h}/{ts}: the last row ends at the screen edge");
                    }
                    if tx == 0 {
                        assert_eq!(l, -1.0);
                    }
                    if ty == 0 {
                        assert_eq!(t, 1.0);
                    }
                }
            }
        }
    }
}

/// The cameras at the extremes the design names: FOV 1 and 170 degrees, aspect 0.1 and 10,
/// finite and infinite far, and orthographic.
fn extreme_cameras() -> Vec<Camera> {
    let eye = Vec3::new(3.0, -2.0, 7.0);
    let target = eye + Vec3::new(0.3, 0.2, -1.0);
    let mut v = Vec::new();
    for fov in [1.0f32, 60.0, 170.0] {
        for aspect in [0.1, 1.0, 10.0] {
            v.push(Camera::perspective(eye, target, Vec3::Y, fov.to_radians(), aspect, 1e-3, Some(1e5)).unwrap());
            v.push(Camera::perspective(eye, target, Vec3::Y, fov.to_radians(), aspect, 0.1, None).unwrap());
        }
    }
    for aspect in [0.1, 1.0, 10.0] {
        v.push(Camera::orthographic(eye, target, Vec3::Y, 50.0, aspect, 0.0, 1e3).unwrap());
    }
    v
}

/// Signed distances of `p` to the four side planes.
fn signed(f: &TileFrustum, p: Vec3) -> [f32; 4] {
    f.planes.map(|pl: Vec4| pl.truncate().dot(p) + pl.w)
}

/// Tiles to test in a grid: all of a small one, else the corners, the centre and random ones.
fn some_tiles(g: &TileGrid, rng: &mut impl Rng) -> Vec<(u32, u32)> {
    if g.tile_count() <= 256 {
        return (0..g.tiles_y).flat_map(|y| (0..g.tiles_x).map(move |x| (x, y))).collect();
    }
    let (mx, my) = (g.tiles_x - 1, g.tiles_y - 1);
    let mut v = vec![(0, 0), (mx, 0), (0, my), (mx, my), (mx / 2, my / 2)];
    v.extend((0..150).map(|_| (rng.random_range(0..=mx), rng.random_range(0..=my))));
    v
}

#[test]
fn side_planes_keep_inside_points_and_reject_neighbouring_pixels() {
    let mut r = rng(9);
    let mut rejected = 0;
    for cam in extreme_cameras() {
        let proj = cam.proj();
        let dp = cam.depth_params();
        let ortho = dp.orthographic;
        let far = dp.far.min(1e5);
        for (w, h, ts) in [(1921, 1081, 1), (17, 9, 8), (1921, 1081, 16)] {
            let g = TileGrid::new(w, h, ts).unwrap();
            for (tx, ty) in some_tiles(&g, &mut r) {
                let f = TileFrustum::from_parts(&proj, &dp, g.tile_ndc(tx, ty), dp.near, far);
                for pl in f.planes {
                    assert!((pl.truncate().length() - 1.0).abs() <= 2.0 * EPS, "plane {pl} is not normalised");
                }
                let (l, rt, b, t) = f.ndc;
                let mut dr = rng(r.random());
                let (lo_d, hi_d) = (dp.near.max(1e-3), far);
                let mut dist = move || common::log_uniform(&mut dr, lo_d, hi_d);
                // Continuous points of the rectangle, edges included: the exact signed
                // distance is >= 0; the computed one has the error of view_point_at (4 eps
                // of |p|, see camera.rs) plus that of a 4-term dot product and of the plane
                // (~2 eps each of |p| and |w|): 8 eps * (|p| + |w|).
                for _ in 0..20 {
                    let nx = if r.random_bool(0.2) { l } else { r.random_range(l..=rt) };
                    let ny = if r.random_bool(0.2) { t } else { r.random_range(b..=t) };
                    let p = cam.view_point_at(nx, ny, dist());
                    for (k, s) in signed(&f, p).into_iter().enumerate() {
                        let tol = 8.0 * EPS * (p.length() + f.planes[k].w.abs());
                        assert!(s >= -tol, "{cam:?} {w}x{h}/{ts} tile ({tx}, {ty}): {p} at NDC ({nx}, {ny}) is {s} outside plane {k} (tol {tol})");
                    }
                }
                // Pixel centres: half a pixel inside, which is far above the float error
                // at every FOV/aspect here, so the sign must be strict both ways.
                let (x0, x1, y0, y1) = g.tile_pixels(tx, ty);
                let centre = |x: i64, y: i64, d: f32| {
                    cam.view_point_at(pixel_to_ndc_x(x as f32 + 0.5, w), pixel_to_ndc_y(y as f32 + 0.5, h), d)
                };
                for (x, y) in [(x0, y0), (x1 - 1, y0), (x0, y1 - 1), (x1 - 1, y1 - 1)] {
                    let p = centre(x as i64, y as i64, dist());
                    assert!(
                        signed(&f, p).iter().all(|&s| s > 0.0),
                        "{cam:?} {w}x{h}/{ts} pixel ({x}, {y}) of its own tile: {:?}",
                        signed(&f, p)
                    );
                }
                // The nearest pixel centres of the four neighbours (left, right, below,
                // above; row y grows downwards), off-screen ones included.
                let (x0, x1, y0, y1) = (x0 as i64, x1 as i64, y0 as i64, y1 as i64);
                let ym = (y0 + y1) / 2;
                let xm = (x0 + x1) / 2;
                for (k, (x, y)) in [(x0 - 1, ym), (x1, ym), (xm, y1), (xm, y0 - 1)].into_iter().enumerate() {
                    let p = centre(x, y, dist());
                    let s = signed(&f, p)[k];
                    assert!(
                        s < 0.0,
                        "{cam:?} {w}x{h}/{ts} tile ({tx}, {ty}): neighbour pixel ({x}, {y}) is {s} inside plane {k}"
                    );
                    rejected += 1;
                }
                // The same-depth-range AABB holds the pixels: view_point_at is monotonic
                // in NDC and distance, so this holds exactly, no tolerance.
                let (lo, hi) = f.aabb(&proj, ortho);
                for _ in 0..8 {
                    let (x, y) = (r.random_range(x0..x1), r.random_range(y0..y1));
                    let p = centre(x, y, dist());
                    assert!(
                        p.cmpge(lo).all() && p.cmple(hi).all(),
                        "{cam:?} pixel ({x}, {y}) {p} outside AABB {lo}..{hi}"
                    );
                }
            }
        }
    }
    assert!(rejected > 10_000);
}

#[test]
fn depth_bounds_skip_sky_and_order_near_far() {
    let g = TileGrid::new(5, 3, 2).unwrap();
    #[rustfmt::skip]
    let depth = [
        0.0, 0.0,   0.5, 0.25,  0.0,
        0.0, 0.0,   0.0, 1.0,   0.0,
        0.1, 0.0,   0.0, 0.0,   0.7,
    ];
    assert_eq!(tile_depth_bounds(&g, &depth, 0, 0), None, "all sky");
    assert_eq!(tile_depth_bounds(&g, &depth, 1, 0), Some(DepthBounds { min_depth: 0.25, max_depth: 1.0 }));
    assert_eq!(tile_depth_bounds(&g, &depth, 2, 0), None);
    assert_eq!(
        tile_depth_bounds(&g, &depth, 0, 1),
        Some(DepthBounds { min_depth: 0.1, max_depth: 0.1 }),
        "partial row"
    );
    assert_eq!(
        tile_depth_bounds(&g, &depth, 2, 1),
        Some(DepthBounds { min_depth: 0.7, max_depth: 0.7 }),
        "partial corner"
    );
    // Reversed-Z: the largest depth is the nearest surface.
    let cam = Camera::perspective(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 5.0 / 3.0, 0.5, None).unwrap();
    let b = tile_depth_bounds(&g, &depth, 1, 0).unwrap();
    let f = TileFrustum::new(&g, &cam, 1, 0, b);
    assert_eq!((f.near, f.far), (0.5, 2.0), "near/depth: 0.5/1 and 0.5/0.25");
    // A subnormal depth is geometry, not sky (only exact 0 is sky).
    let tiny = [f32::from_bits(1); 4];
    let g = TileGrid::new(2, 2, 2).unwrap();
    assert!(tile_depth_bounds(&g, &tiny, 0, 0).is_some());
}
