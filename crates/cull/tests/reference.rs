//! The CPU reference culler (`cull_tiles`) and its statistics: sky tiles get empty lists; a
//! light around the eye is kept exactly by the tiles whose surfaces it reaches; capacity
//! and overflow counting (lists are never truncated); half-z lists are subsets of the
//! full list and every pixel finds its lights through `list_index`; AABB, cone and
//! negative-inflate lists are subsets, positive inflate a superset; two-level (coarse)
//! culling keeps subsets too, and falls back to every light when a cell overflows; `stats` and
//! `false_positive_rate` on a hand-checked 2x1-tile frame; invalid depth buffers and
//! options are rejected with typed errors.

mod common;

use common::{axis_camera, point_light as point, rng, CamKind, CamSpec, DepthMode, DEPTH_MODES, EPS};
use glam::Vec3;
use rand::Rng;
use tiledlight_cull::gather::coarse_cells;
use tiledlight_cull::light::{order_points_first, pack_lights, PackedLights};
use tiledlight_cull::lists::{half_z_split, COARSE_CAPACITY, COARSE_SIZE, MAX_CAPACITY};
use tiledlight_cull::reference::{
    false_positive_rate, lights_reaching, list_quality, pixel_view_position, stats, tile_ranges, CullStats,
};
use tiledlight_cull::{cull_tiles, Camera, CullConfig, CullError, Light, TileLists};

/// A random small frame: camera, depth buffer, packed lights, size.
struct Frame {
    camera: Camera,
    depth: Vec<f32>,
    packed: PackedLights,
    w: u32,
    h: u32,
}

fn frame(seed: u64, mode: DepthMode) -> Frame {
    let mut r = rng(seed);
    let spec = CamSpec::random(&mut r);
    let camera = spec.camera();
    let (w, h) = (r.random_range(1..40), r.random_range(1..40));
    let depth = common::random_depth(&mut r, mode, &camera, w, h, None);
    let targets = common::surface_targets(&mut r, &camera, &depth, (w, h, 1), 16);
    let lights = common::random_lights(&mut r, &spec, &targets, 24);
    Frame { camera, depth, packed: pack_lights(&order_points_first(&lights)), w, h }
}

fn cull(f: &Frame, config: CullConfig) -> TileLists {
    cull_tiles(&f.depth, f.w, f.h, &f.camera, &f.packed, &config).expect("valid frame")
}

fn is_subset(a: &[u32], b: &[u32]) -> bool {
    a.iter().all(|x| b.binary_search(x).is_ok())
}

#[test]
fn lists_are_sorted_and_index_points_first() {
    let f = frame(1, DepthMode::Plane);
    for l in &cull(&f, CullConfig { spot_cone: true, ..CullConfig::default() }).lists {
        assert!(l.windows(2).all(|w| w[0] < w[1]), "{l:?}");
        assert!(l.iter().all(|&i| (i as usize) < f.packed.len()));
    }
}

#[test]
fn sky_tiles_have_empty_lists() {
    // 64x32 px, 16 px tiles: the left two columns of tiles see a wall 10 m away, the rest
    // is sky. One light around the eye reaches everything that exists.
    let (w, h) = (64, 32);
    let cam = axis_camera(2.0);
    let d = cam.depth_params().depth(10.0);
    let depth: Vec<f32> = (0..w * h).map(|i| if i % w < 32 { d } else { 0.0 }).collect();
    let packed = pack_lights(&[point(Vec3::ZERO, 1e3)]);
    for half_z in [false, true] {
        for aabb in [false, true] {
            let config = CullConfig { half_z, aabb, ..CullConfig::default() };
            let lists = cull_tiles(&depth, w, h, &cam, &packed, &config).unwrap();
            let per = config.lists_per_tile();
            for t in 0..lists.grid.tile_count() {
                let sky = t % 4 >= 2;
                assert_eq!(lists.ranges[t].is_none(), sky, "tile {t}");
                for k in 0..per {
                    let expected: &[u32] = if sky { &[] } else { &[0] };
                    assert_eq!(lists.lists[t * per + k], expected, "tile {t} list {k} ({config:?})");
                }
            }
            assert_eq!(stats(&lists).tiles_with_geometry, 4);
        }
    }
}

#[test]
fn light_around_the_eye_is_kept_by_the_tiles_it_reaches() {
    let mut checked = [0, 0];
    for seed in 0..48 {
        let mut r = rng(1000 + seed);
        let mut spec = CamSpec::random(&mut r);
        if spec.kind == CamKind::Ortho {
            // The side planes pass through the eye only in perspective.
            spec.kind = CamKind::Finite;
            spec.near = spec.near.max(1e-3);
        }
        let cam = spec.camera();
        let (w, h) = (r.random_range(1..40), r.random_range(1..40));
        let depth = common::random_depth(&mut r, DepthMode::PerPixel, &cam, w, h, None);
        let dp = cam.depth_params();
        // Its sphere holds the eye (centred a bit off it) and reaches about as far as a
        // random surface point, so that some tiles are reached and some are not.
        let some_dist =
            depth.iter().filter(|&&d| d > 0.0).map(|&d| dp.view_distance(d)).nth(r.random_range(0..8)).unwrap_or(1.0);
        let radius = some_dist * r.random_range(0.5..2.0);
        let centre = spec.eye + common::unit(&mut r) * radius * 0.3 * r.random::<f32>();
        let packed = pack_lights(&[point(centre, radius)]);
        let view_c = common::to_view(&cam.view(), centre);
        let config = CullConfig { tile_size: [1, 2, 4][seed as usize % 3], ..CullConfig::default() };
        let lists = cull_tiles(&depth, w, h, &cam, &packed, &config).unwrap();
        // Planes only: the four side planes pass through the eye, inside the sphere, so
        // only the depth range decides: kept iff dist(centre) + r >= the tile's nearest
        // surface. Decided with a band of 1e-5 relative (the view transform of the centre
        // and the depth decode, a few eps each) plus 8 eps * |eye| for the translation.
        let band = 1e-5 * (radius + view_c.length()) + 8.0 * EPS * spec.eye.length();
        for (t, range) in lists.ranges.iter().enumerate() {
            let Some((near, _)) = *range else { continue };
            let reach = -view_c.z + radius;
            if reach > near + band {
                assert_eq!(lists.lists[t], [0], "seed {seed} tile {t}: reach {reach} beyond nearest surface {near}");
                checked[0] += 1;
            } else if reach < near - band {
                assert!(
                    lists.lists[t].is_empty(),
                    "seed {seed} tile {t}: reach {reach} short of nearest surface {near}"
                );
                checked[1] += 1;
            }
        }
        // A light whose sphere holds every surface point too is in every list of every
        // tile with geometry, whatever the tests.
        let far_pixel = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter_map(|(x, y)| pixel_view_position(&cam, w, h, x, y, depth[(y * w + x) as usize]))
            .map(|p| p.length())
            .fold(0.0f32, f32::max);
        let big = pack_lights(&[point(spec.eye, far_pixel * 1.01 + 1.0)]);
        let config = CullConfig { aabb: true, half_z: true, spot_cone: true, ..CullConfig::default() };
        let lists = cull_tiles(&depth, w, h, &cam, &big, &config).unwrap();
        for (t, range) in lists.ranges.iter().enumerate() {
            if range.is_some() {
                assert_eq!(
                    (&lists.lists[2 * t], &lists.lists[2 * t + 1]),
                    (&vec![0], &vec![0]),
                    "seed {seed} tile {t}"
                );
            }
        }
    }
    assert!(checked[0] > 100 && checked[1] > 100, "kept/culled tiles checked: {checked:?}");
}

#[test]
fn capacity_overflow_is_counted_not_truncated() {
    let (w, h) = (32, 32);
    let cam = axis_camera(1.0);
    let mut depth = vec![cam.depth_params().depth(5.0); (w * h) as usize];
    depth[..(16 * w) as usize].fill(0.0); // the top row of tiles is sky
    let lights: Vec<Light> = (0..10).map(|i| point(Vec3::new(0.0, 0.0, -0.01 * i as f32), 100.0)).collect();
    let packed = pack_lights(&lights);
    for (capacity, half_z, overflowing) in [(9, false, 2), (10, false, 0), (1, true, 4), (10, true, 0)] {
        let config = CullConfig { capacity, half_z, ..CullConfig::default() };
        let lists = cull_tiles(&depth, w, h, &cam, &packed, &config).unwrap();
        assert_eq!(lists.overflowing_lists(), overflowing, "capacity {capacity} half_z {half_z}");
        let s = stats(&lists);
        assert_eq!(s.overflowing as usize, overflowing);
        assert_eq!(s.max_per_list, 10, "counts are never truncated");
        assert_eq!(s.tiles_with_geometry, 2);
        assert_eq!(s.mean_per_list, 10.0, "sky tiles do not enter the mean");
    }
}

#[test]
fn half_z_lists_split_the_full_list_and_serve_every_pixel() {
    let mut far_half_only = 0;
    for seed in 0..60 {
        let f = frame(seed, DEPTH_MODES[seed as usize % DEPTH_MODES.len()]);
        for (aabb, spot_cone) in [(false, false), (true, true)] {
            let base =
                CullConfig { tile_size: [1, 4, 8, 16][seed as usize % 4], aabb, spot_cone, ..CullConfig::default() };
            let full = cull(&f, base);
            let halves = cull(&f, CullConfig { half_z: true, ..base });
            assert_eq!(full.ranges, halves.ranges);
            for t in 0..full.grid.tile_count() {
                let (near, far) = (&halves.lists[2 * t], &halves.lists[2 * t + 1]);
                assert!(is_subset(near, &full.lists[t]) && is_subset(far, &full.lists[t]), "seed {seed} tile {t}");
                far_half_only += far.iter().filter(|l| near.binary_search(l).is_err()).count();
            }
            // Every pixel's lights (margin 0: see no_false_negatives.rs) are in its list.
            let dp = f.camera.depth_params();
            for y in 0..f.h {
                for x in 0..f.w {
                    let d = f.depth[(y * f.w + x) as usize];
                    let Some(p) = pixel_view_position(&f.camera, f.w, f.h, x, y, d) else { continue };
                    let li = halves.list_index(halves.grid.tile_of_pixel(x, y), dp.view_distance(d));
                    for l in lights_reaching(&f.camera.view(), &f.packed, p, 0.0) {
                        // Skipped as in no_false_negatives.rs (f32 cannot decide these).
                        let unresolvable = common::spot_pair_unresolvable(&f.camera, &f.packed, l, p);
                        assert!(
                            unresolvable || halves.lists[li].contains(&l),
                            "seed {seed}: pixel ({x}, {y}) light {l}"
                        );
                    }
                }
            }
        }
    }
    assert!(far_half_only > 50, "half-z never separated anything: {far_half_only}");
}

#[test]
fn half_z_separates_two_surfaces() {
    // One 16x16 tile: left half of the pixels at 5 m, right half at 50 m.
    let cam = axis_camera(1.0);
    let dp = cam.depth_params();
    let depth: Vec<f32> = (0..256).map(|i| if i % 16 < 8 { dp.depth(5.0) } else { dp.depth(50.0) }).collect();
    // A light at the near surface and one at the far surface, both small.
    let near_l = point(Vec3::new(-2.0, 0.0, -5.0), 1.0);
    let far_l = point(Vec3::new(20.0, 0.0, -50.0), 1.0);
    let packed = pack_lights(&[near_l, far_l]);
    let config = CullConfig { half_z: true, ..CullConfig::default() };
    let lists = cull_tiles(&depth, 16, 16, &cam, &packed, &config).unwrap();
    let (n, f) = lists.ranges[0].unwrap();
    assert!((n - 5.0).abs() < 1e-4 && (f - 50.0).abs() < 1e-3, "range {n}..{f}");
    assert_eq!(lists.lists, [vec![0], vec![1]]);
    let split = half_z_split(n, f);
    assert_eq!(lists.list_index(0, 5.0), 0);
    assert_eq!(lists.list_index(0, 50.0), 1);
    assert_eq!(lists.list_index(0, split), 0, "the split distance itself belongs to the near half");
    assert_eq!(lists.list_index(0, split.next_up()), 1);
    // Without half-z there is one list, and every distance maps to it.
    let one = cull_tiles(&depth, 16, 16, &cam, &packed, &CullConfig::default()).unwrap();
    assert_eq!(one.lists, [vec![0, 1]]);
    assert_eq!(one.list_index(0, 50.0), 0);
}

#[test]
fn tighter_tests_give_subsets_and_inflate_is_monotonic() {
    let mut removed = [0usize; 4];
    for seed in 0..60 {
        let f = frame(500 + seed, DEPTH_MODES[seed as usize % DEPTH_MODES.len()]);
        let base =
            CullConfig { tile_size: [2, 8, 16][seed as usize % 3], half_z: seed % 2 == 0, ..CullConfig::default() };
        let planes = cull(&f, base);
        let variants = [
            CullConfig { aabb: true, ..base },
            CullConfig { spot_cone: true, ..base },
            CullConfig { inflate: -1e-3, ..base },
            // The 64 px cell's volume holds the tile's, so its test keeps at least what the
            // tile needs; it also drops some of the tile's false positives (balls by or
            // behind the eye, where the planes through the eye no longer nest).
            CullConfig { coarse: true, ..base },
        ];
        for (k, config) in variants.into_iter().enumerate() {
            let tight = cull(&f, config);
            for (a, b) in tight.lists.iter().zip(&planes.lists) {
                assert!(is_subset(a, b), "seed {seed} {config:?}: {a:?} not within {b:?}");
                removed[k] += b.len() - a.len();
            }
        }
        let grown = cull(&f, CullConfig { inflate: 1e-3, ..base });
        for (a, b) in planes.lists.iter().zip(&grown.lists) {
            assert!(is_subset(a, b), "seed {seed}: inflate 1e-3 lost a light");
        }
    }
    // Each tighter test must actually remove lights somewhere, or the subset check is idle.
    assert!(removed.iter().all(|&n| n > 0), "lights removed by aabb / cone / shrink / coarse: {removed:?}");
}

#[test]
fn coarse_cells_keep_what_their_pixels_need_and_fall_back_when_full() {
    // 130x70 px: 3x2 cells of 64 px (partial ones on the right and bottom). The right
    // column of cells is sky.
    let (w, h) = (130, 70);
    let cam = axis_camera(w as f32 / h as f32);
    let d = cam.depth_params().depth(10.0);
    let depth: Vec<f32> = (0..w * h).map(|i| if i % w < 128 { d } else { 0.0 }).collect();
    // Light 0 lights the wall's centre; light 1 is behind the camera, out of every cell
    // (its 1 m ball stays 5 m behind the eye).
    let packed = pack_lights(&[point(Vec3::new(0.0, 0.0, -10.0), 1.0), point(Vec3::new(0.0, 0.0, 5.0), 1.0)]);
    let (cgrid, cells) = coarse_cells(&depth, w, h, &cam, &packed).unwrap();
    assert_eq!((cgrid.tiles_x, cgrid.tiles_y, cgrid.tile_size), (3, 2, COARSE_SIZE));
    for (i, cell) in cells.iter().enumerate() {
        let cell = cell.as_ref().expect("2 lights never overflow a cell");
        assert!(!cell.contains(&1), "cell {i}: the light behind the camera");
        if i % 3 == 2 {
            assert!(cell.is_empty(), "cell {i} is sky");
        }
    }
    // The centre pixel's cell keeps light 0.
    let centre_cell = cgrid.tile_of_pixel(w / 2, h / 2);
    assert_eq!(cells[centre_cell], Some(vec![0]));

    // Past COARSE_CAPACITY lights a cell stores nothing (None) and its tiles test every
    // light: the lists are exactly the flat ones.
    let many: Vec<Light> =
        (0..COARSE_CAPACITY + 1).map(|i| point(Vec3::new(0.0, 0.0, -9.0 - 1e-4 * i as f32), 2.0)).collect();
    let many = pack_lights(&many);
    let (_, cells) = coarse_cells(&depth, w, h, &cam, &many).unwrap();
    assert_eq!(cells[centre_cell], None, "an overflowing cell falls back");
    let config = CullConfig { tile_size: 16, capacity: MAX_CAPACITY, ..CullConfig::default() };
    let flat = cull_tiles(&depth, w, h, &cam, &many, &config).unwrap();
    let two_level = cull_tiles(&depth, w, h, &cam, &many, &CullConfig { coarse: true, ..config }).unwrap();
    assert_eq!(flat.lists, two_level.lists);
    assert!(flat.lists.iter().any(|l| l.len() == many.len()), "the centre tiles see every light");
}

/// The 2x1-tile frame of `stats_and_false_positives_by_hand`: a wall 10 m in front of
/// a camera with a 90 degree vertical FOV, aspect 2, 32x16 px.
///
/// With p00 = 0.5, p11 = 1 the left tile (NDC x in [-1, 0]) sees x in [-20, 0],
/// y in [-10, 10] at z = -10. Light 0 at (-5, 0, -10), r 2, lights pixels of the left
/// tile. Light 1 at (-22, 12, -10), r 2, is 0.89 outside the left plane and 1.41 above
/// the top plane (both less than r, so the plane test keeps it), but its nearest pixel
/// centre (-19.375, 9.375) is 3.7 away and the tile's box corner (-20, 10) 2.83 away:
/// it lights nothing, and the AABB test removes it. The right tile (x >= 0) rejects
/// both by its left plane (x = -5 and -22, beyond r).
fn hand_frame() -> (Camera, Vec<f32>, PackedLights) {
    let cam = axis_camera(2.0);
    let depth = vec![cam.depth_params().depth(10.0); 32 * 16];
    let packed = pack_lights(&[point(Vec3::new(-5.0, 0.0, -10.0), 2.0), point(Vec3::new(-22.0, 12.0, -10.0), 2.0)]);
    (cam, depth, packed)
}

#[test]
fn stats_and_false_positives_by_hand() {
    let (cam, depth, packed) = hand_frame();
    assert_eq!(cam.view(), glam::Mat4::IDENTITY, "world space is view space here");
    let run = |config: CullConfig| {
        let lists = cull_tiles(&depth, 32, 16, &cam, &packed, &config).unwrap();
        let fp = false_positive_rate(&depth, &cam, &packed, &lists);
        (lists, fp)
    };
    let (planes, fp_planes) = run(CullConfig::default());
    assert_eq!(planes.lists, [vec![0, 1], vec![]]);
    assert_eq!(
        stats(&planes),
        CullStats { mean_per_list: 1.0, max_per_list: 2, overflowing: 0, tiles_with_geometry: 2 }
    );
    assert_eq!(fp_planes, 0.5, "light 1 is listed and lights nothing");

    let (aabb, fp_aabb) = run(CullConfig { aabb: true, ..CullConfig::default() });
    assert_eq!(aabb.lists, [vec![0], vec![]]);
    assert_eq!(stats(&aabb), CullStats { mean_per_list: 0.5, max_per_list: 1, overflowing: 0, tiles_with_geometry: 2 });
    assert_eq!(fp_aabb, 0.0);

    // Half-z over a flat wall: both halves span [10, 10], every pixel reads the near
    // list, so the far list's two entries are wasted too: 3 of 4.
    let (halves, fp_halves) = run(CullConfig { half_z: true, ..CullConfig::default() });
    assert_eq!(halves.lists, [vec![0, 1], vec![0, 1], vec![], vec![]]);
    assert_eq!(fp_halves, 0.75);

    // Capacity 1: the left tile's list overflows.
    let (small, _) = run(CullConfig { capacity: 1, ..CullConfig::default() });
    assert_eq!(stats(&small).overflowing, 1);

    // Nothing listed: the rate is 0, not NaN.
    let sky = vec![0.0; 32 * 16];
    let empty = cull_tiles(&sky, 32, 16, &cam, &packed, &CullConfig::default()).unwrap();
    assert_eq!(false_positive_rate(&sky, &cam, &packed, &empty), 0.0);
    assert_eq!(stats(&empty), CullStats::default());
}

#[test]
fn false_positive_rate_is_a_fraction_and_aabb_lowers_it() {
    let mut lower = 0;
    for seed in 0..40 {
        let f = frame(900 + seed, DEPTH_MODES[seed as usize % 3]);
        let base = CullConfig { tile_size: 4, ..CullConfig::default() };
        let p = false_positive_rate(&f.depth, &f.camera, &f.packed, &cull(&f, base));
        let a = false_positive_rate(&f.depth, &f.camera, &f.packed, &cull(&f, CullConfig { aabb: true, ..base }));
        assert!((0.0..=1.0).contains(&p) && (0.0..=1.0).contains(&a), "seed {seed}: {p} {a}");
        // Removing only wasted pairs (AABB never removes a pair that lights a pixel) can
        // only lower the wasted fraction: (w - k) / (n - k) <= w / n.
        assert!(a <= p, "seed {seed}: aabb {a} > planes {p}");
        lower += usize::from(a < p);
    }
    assert!(lower > 5, "the AABB test lowered the rate in only {lower} frames");
}

/// `list_quality` against a direct count: every pixel's list member tested with
/// `lights_reaching` over all lights, and a list's light wasted when no pixel of it is reached.
#[test]
fn list_quality_matches_a_direct_count() {
    for seed in 0..30 {
        let f = frame(1300 + seed, DEPTH_MODES[seed as usize % 3]);
        let config = CullConfig { tile_size: 4, half_z: seed % 2 == 0, ..CullConfig::default() };
        let lists = cull(&f, config);
        let q = list_quality(&f.depth, &f.camera, &f.packed, &lists);
        let dp = f.camera.depth_params();
        let (mut pixels, mut evaluated, mut wasted) = (0u64, 0u64, 0u64);
        let mut reached = vec![std::collections::BTreeSet::new(); lists.lists.len()];
        for y in 0..f.h {
            for x in 0..f.w {
                let d = f.depth[(y * f.w + x) as usize];
                let Some(p) = pixel_view_position(&f.camera, f.w, f.h, x, y, d) else { continue };
                let li = lists.list_index(lists.grid.tile_of_pixel(x, y), dp.view_distance(d));
                let truth = lights_reaching(&f.camera.view(), &f.packed, p, 0.0);
                pixels += 1;
                evaluated += lists.lists[li].len() as u64;
                wasted += lists.lists[li].iter().filter(|i| !truth.contains(i)).count() as u64;
                reached[li].extend(truth);
            }
        }
        let listed: usize = lists.lists.iter().map(Vec::len).sum();
        let unused: usize =
            lists.lists.iter().zip(&reached).map(|(l, r)| l.iter().filter(|i| !r.contains(i)).count()).sum();
        assert_eq!(q.pixels, pixels, "seed {seed}");
        let per = |n: u64| if pixels > 0 { n as f64 / pixels as f64 } else { 0.0 };
        assert_eq!(q.evaluated_per_pixel, per(evaluated), "seed {seed}");
        assert_eq!(q.wasted_per_pixel, per(wasted), "seed {seed}");
        let fp = if listed > 0 { unused as f64 / listed as f64 } else { 0.0 };
        assert_eq!(q.false_positive_rate, fp, "seed {seed}");
        assert!(q.wasted_per_pixel <= q.evaluated_per_pixel);
        assert_eq!(tile_ranges(&f.depth, &lists.grid, &f.camera).unwrap(), lists.ranges, "seed {seed}");
    }
}

#[test]
fn wasted_evaluations_by_hand() {
    let (cam, depth, packed) = hand_frame();
    // Left tile (256 of 512 pixels) lists lights 0 and 1 with plane tests, only 0 with the
    // AABB test; light 1 reaches no pixel, so it is wasted at each of the 256 pixels.
    let planes = cull_tiles(&depth, 32, 16, &cam, &packed, &CullConfig::default()).unwrap();
    let aabb = cull_tiles(&depth, 32, 16, &cam, &packed, &CullConfig { aabb: true, ..CullConfig::default() }).unwrap();
    let qp = list_quality(&depth, &cam, &packed, &planes);
    let qa = list_quality(&depth, &cam, &packed, &aabb);
    assert_eq!((qp.pixels, qp.evaluated_per_pixel, qa.evaluated_per_pixel), (512, 1.0, 0.5));
    assert!((qp.wasted_per_pixel - qa.wasted_per_pixel - 0.5).abs() < 1e-12, "{qp:?} {qa:?}");
}

#[test]
fn lights_reaching_is_strict_and_honours_margin_and_cone() {
    let view = glam::Mat4::IDENTITY;
    let packed = pack_lights(&order_points_first(&[
        Light::with_radius(
            Vec3::ZERO,
            Vec3::ONE,
            1.0,
            2.0,
            Light::spot_kind(Vec3::X, 0.0, 30f32.to_radians()).unwrap(),
        )
        .unwrap(),
        point(Vec3::ZERO, 2.0),
    ]));
    // Index 0 is the point light (points first), 1 the spot.
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(1.0, 0.0, 0.0), 0.0), [0, 1]);
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(2.0, 0.0, 0.0), 0.0), [] as [u32; 0], "at r: out");
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(1.9, 0.0, 0.0), 0.1), [] as [u32; 0], "margin 0.1 of r");
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(-1.0, 0.0, 0.0), 0.0), [0], "behind the spot");
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(1.0, 0.6, 0.0), 0.0), [0], "31 degrees off the axis: outside");
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(1.0, 0.5, 0.0), 0.0), [0, 1], "26.6 degrees: inside");
    // Margin 0.3 asks cos > cos30 + 0.3 (1 - cos30) = 0.906; cos 26.6 = 0.894.
    assert_eq!(lights_reaching(&view, &packed, Vec3::new(1.0, 0.5, 0.0), 0.3), [0], "not with an angular margin");
    assert_eq!(lights_reaching(&view, &packed, Vec3::ZERO, 0.0), [0], "the apex itself is not in the cone");
}

#[test]
fn rejects_bad_depth_and_options() {
    let cam = axis_camera(1.0);
    let packed = pack_lights(&[point(Vec3::ZERO, 1.0)]);
    let cfg = CullConfig::default();
    let bad_depth = |d: &[f32], w: u32, h: u32| {
        assert!(
            matches!(cull_tiles(d, w, h, &cam, &packed, &cfg), Err(CullError::InvalidDepth(_))),
            "{w}x{h} with {} values accepted",
            d.len()
        );
    };
    bad_depth(&[0.5; 15], 4, 4);
    bad_depth(&[0.5; 17], 4, 4);
    bad_depth(&[], 1, 1);
    for v in [f32::NAN, 1.5, -0.1, f32::INFINITY, f32::NEG_INFINITY, 1.0f32.next_up()] {
        let mut d = vec![0.5; 16];
        d[7] = v;
        bad_depth(&d, 4, 4);
    }
    // The valid extremes.
    cull_tiles(&[0.0, 1.0, -0.0, f32::from_bits(1)], 2, 2, &cam, &packed, &cfg).unwrap();
    for capacity in [0, MAX_CAPACITY + 1] {
        let r = cull_tiles(&[0.5; 4], 2, 2, &cam, &packed, &CullConfig { capacity, ..cfg });
        assert!(matches!(r, Err(CullError::InvalidSize(_))), "capacity {capacity}: {r:?}");
    }
    cull_tiles(&[0.5; 4], 2, 2, &cam, &packed, &CullConfig { capacity: MAX_CAPACITY, ..cfg }).unwrap();
    for inflate in [f32::NAN, f32::INFINITY] {
        let r = cull_tiles(&[0.5; 4], 2, 2, &cam, &packed, &CullConfig { inflate, ..cfg });
        assert!(matches!(r, Err(CullError::InvalidSize(_))), "inflate {inflate}: {r:?}");
    }
    for tile_size in [0, 65] {
        let r = cull_tiles(&[0.5; 4], 2, 2, &cam, &packed, &CullConfig { tile_size, ..cfg });
        assert!(matches!(r, Err(CullError::InvalidSize(_))), "tile {tile_size}: {r:?}");
    }
    // Two-level culling needs tiles that divide the 64 px cells.
    for (tile_size, ok) in [(13, false), (48, false), (1, true), (32, true), (64, true)] {
        let r = cull_tiles(&[0.5; 4], 2, 2, &cam, &packed, &CullConfig { tile_size, coarse: true, ..cfg });
        assert_eq!(r.is_ok(), ok, "coarse with tile {tile_size}: {r:?}");
        assert!(ok || matches!(r, Err(CullError::InvalidSize(_))));
    }
    assert!(matches!(cull_tiles(&[], 0, 0, &cam, &packed, &cfg), Err(CullError::InvalidSize(_))));
}

#[test]
fn light_far_beyond_squaring_range_is_kept() {
    // A surface 1e25 m away (reversed-Z 1e-26 with near 0.1) and a light on it: every
    // length() on that scale overflows. Regression test: the CPU-only inflate term used
    // to turn the radius into 0 * inf = NaN, which culled the light everywhere.
    let cam = axis_camera(1.0);
    let dist = 1e25f32;
    let depth = vec![cam.depth_params().depth(dist); 16];
    let p = pixel_view_position(&cam, 4, 4, 1, 2, depth[0]).unwrap();
    let packed = pack_lights(&[point(p, 1e3)]);
    assert_eq!(lights_reaching(&cam.view(), &packed, p, 0.0), [0]);
    for aabb in [false, true] {
        let lists =
            cull_tiles(&depth, 4, 4, &cam, &packed, &CullConfig { tile_size: 1, aabb, ..CullConfig::default() })
                .unwrap();
        assert_eq!(lists.lists[lists.grid.tile_of_pixel(1, 2)], [0], "aabb {aabb}");
    }
}
