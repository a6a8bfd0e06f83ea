//! Clustered lists (`cluster::cull_clusters`): the light-centric lists equal a brute-force
//! loop over every cluster and light with the definition's test; `slice_of` is monotone,
//! never NaN (near 1e-4, infinite far plane, sky, subnormal depths) and matches
//! `slice_range`; occupancy masks; `list_index`, `stats` and `list_quality` on clusters;
//! validation. The no-false-negative property is in `no_false_negatives.rs`.

mod common;

use common::{log_uniform, rng, CamKind, CamSpec, DEPTH_MODES};
use glam::Vec3;
use proptest::prelude::*;
use rand::Rng;
use tiledlight_cull::assign::near_cap_rect;
use tiledlight_cull::bounds::{sphere_vs_frustum, to_view};
use tiledlight_cull::cluster::{cluster_occupancy, light_slices};
use tiledlight_cull::light::{order_points_first, pack_lights, PackedLights};
use tiledlight_cull::lists::MAX_SLICES;
use tiledlight_cull::reference::{list_quality, stats};
use tiledlight_cull::tiles::TileFrustum;
use tiledlight_cull::{cull_clusters, Camera, ClusterConfig, CullError, TileLists};

/// `cases` cases from the workspace's fixed seed (`common::proptest_config`);
/// `PROPTEST_CASES=n` runs more, `PROPTEST_RNG_SEED=s` others.
fn cases(cases: u32) -> ProptestConfig {
    common::proptest_config(cases)
}

/// A random cluster layout over the ranges the GPU accepts.
fn random_cluster(r: &mut impl Rng) -> ClusterConfig {
    let first = log_uniform(r, 1e-3, 1e3);
    ClusterConfig {
        tile_size: r.random_range(8..=256),
        slices: r.random_range(1..=MAX_SLICES),
        first,
        last: first * log_uniform(r, 1.01, 1e6),
        geometry_only: r.random_bool(0.5),
    }
}

struct Frame {
    camera: Camera,
    depth: Vec<f32>,
    packed: PackedLights,
    w: u32,
    h: u32,
    samples: u32,
    cluster: ClusterConfig,
}

fn frame(seed: u64) -> Frame {
    let mut r = rng(seed);
    let spec = CamSpec::random(&mut r);
    let camera = spec.camera();
    let (w, h) = (r.random_range(1..300), r.random_range(1..300));
    let samples = [1, 2, 4, 8][r.random_range(0..4)];
    let mode = DEPTH_MODES[r.random_range(0..DEPTH_MODES.len())];
    let depth = common::random_depth_samples(&mut r, mode, &camera, w, h, samples, None, 0.1);
    let targets = common::surface_targets(&mut r, &camera, &depth, (w, h, samples), 16);
    let lights = common::random_lights(&mut r, &spec, &targets, 24);
    let cluster = random_cluster(&mut r);
    Frame { camera, depth, packed: pack_lights(&order_points_first(&lights)), w, h, samples, cluster }
}

fn cull(f: &Frame) -> TileLists {
    cull_clusters(&f.depth, f.w, f.h, &f.camera, &f.packed, &f.cluster, f.samples, 0.0).expect("valid frame")
}

/// The definition, cluster by cluster: `r > 0`, `dist + r > 0`, the tile's four side
/// planes pass (as `sphere_vs_frustum` tests them, depth range open), a perspective light
/// reaching the eye plane covers the tile beyond the near plane (`near_cap_rect`), slice
/// in the light's range, and with `geometry_only` the tile's occupancy bit.
fn brute_force(f: &Frame) -> Vec<Vec<u32>> {
    let cc = &f.cluster;
    let grid = cc.grid(f.w, f.h).unwrap();
    let (proj, dp, view) = (f.camera.proj(), f.camera.depth_params(), f.camera.view());
    let occupancy = cluster_occupancy(&f.depth, &grid, f.samples, &f.camera, cc);
    let n = cc.slices as usize;
    let mut lists = vec![Vec::new(); grid.tile_count() * n];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            let t = (ty * grid.tiles_x + tx) as usize;
            let fr = TileFrustum::from_parts(&proj, &dp, grid.tile_ndc(tx, ty), f32::NEG_INFINITY, f32::INFINITY);
            for s in 0..cc.slices {
                if cc.geometry_only && occupancy[t] & (1 << s) == 0 {
                    continue;
                }
                for i in 0..f.packed.len() {
                    let cl = f.packed.cull[i];
                    let (c, r) = (to_view(&view, Vec3::from(cl.center)), cl.radius);
                    let dist = -c.z;
                    let (lo, hi) = light_slices(cc, dist, r);
                    let cap = !dp.orthographic && c.z + r >= 0.0;
                    let in_cap = || near_cap_rect(&grid, &proj, dp.near, c, r).is_some_and(|q| q.contains(tx, ty));
                    if r > 0.0
                        && dist + r > 0.0
                        && sphere_vs_frustum(&fr, c, r)
                        && (!cap || in_cap())
                        && (lo..=hi).contains(&s)
                    {
                        lists[t * n + s as usize].push(i as u32);
                    }
                }
            }
        }
    }
    lists
}

proptest! {
    #![proptest_config(cases(128))]

    /// Light-centric (tile rectangle x slice range, each tile plane-tested) = brute force.
    /// A light reaching the eye plane gets its near-plane rectangle (`near_cap_rect`), whose
    /// no-false-negative guarantee tests/assign.rs samples.
    /// They could differ only where a tile outside the rectangle passes its planes by f32
    /// rounding against the monotone trend; no case has shown it.
    #[test]
    fn light_centric_equals_brute_force(seed in any::<u64>()) {
        let f = frame(seed);
        let lists = cull(&f);
        prop_assert_eq!(&lists.lists, &brute_force(&f), "{:?}", f.cluster);
    }

    /// `slice_of` is monotone non-decreasing: what makes the slice-range test conservative.
    #[test]
    fn slice_of_is_monotone(
        first in common::exp10(-3.0, 3.0),
        ratio in common::exp10(0.0044, 6.0),
        slices in 1u32..=MAX_SLICES,
        d1 in prop_oneof![common::exp10(-6.0, 12.0), Just(0.0), Just(f32::INFINITY), -1e3f32..1e3],
        step in prop_oneof![Just(0.0), common::exp10(-8.0, 10.0), Just(f32::MIN_POSITIVE)],
    ) {
        let cc = ClusterConfig { slices, first, last: first * ratio, ..ClusterConfig::default() };
        prop_assume!(cc.validate().is_ok());
        let d2 = d1 + step.max(d1.abs() * step);
        prop_assert!(d1 <= d2);
        let (s1, s2) = (cc.slice_of(d1), cc.slice_of(d2));
        prop_assert!(s1 <= s2, "slice_of({}) = {} > slice_of({}) = {}", d1, s1, d2, s2);
        prop_assert!(s2 < slices);
    }
}

/// Near 1e-4 and an infinite far plane: every sample's distance (down to subnormal depths,
/// whose distance overflows to infinity, and sky) gets a slice without NaN, and so does
/// every light's range.
#[test]
fn no_nan_at_near_1e_4_and_infinite_far() {
    let mut r = rng(21);
    for i in 0..200 {
        let spec = CamSpec { kind: CamKind::Infinite, near: 1e-4, ..CamSpec::random(&mut r) };
        let dp = spec.camera().depth_params();
        let cc = random_cluster(&mut r);
        let scale = cc.scale();
        assert!(scale.is_finite() && scale >= 0.0, "{cc:?}: scale {scale}");
        let depths = [0.0, f32::from_bits(1), f32::MIN_POSITIVE, 1e-30, 1e-7, 0.5, 1.0 - 1e-7, 1.0];
        let randoms: Vec<f32> = (0..100).map(|_| r.random::<f32>()).collect();
        for d in depths.into_iter().chain(randoms) {
            let dist = dp.view_distance(d);
            assert!(!dist.is_nan(), "depth {d}");
            // The same operations as `slice_of`, checked for NaN step by step.
            if dist >= cc.first && cc.slices > 1 {
                let x = (dist / cc.first).ln() * scale;
                assert!(!x.is_nan() && x >= 0.0, "{cc:?}: x {x} at distance {dist}");
            }
            assert!(cc.slice_of(dist) < cc.slices);
            let radius = log_uniform(&mut r, 1e-4, 1e6);
            let (lo, hi) = light_slices(&cc, dist, radius);
            assert!(lo <= hi && hi < cc.slices, "{i}: {lo}..{hi}");
        }
        assert_eq!(cc.slice_of(f32::INFINITY), cc.slices - 1);
        assert_eq!(cc.slice_of(f32::NAN), 0);
        assert_eq!(cc.slice_of(-1.0), 0);
    }
}

#[test]
fn slice_ranges_match_slice_of() {
    let mut r = rng(22);
    for _ in 0..500 {
        let cc = random_cluster(&mut r);
        let n = cc.slices;
        assert_eq!(cc.slice_range(0).0, 0.0);
        assert_eq!(cc.slice_range(n - 1).1, f32::INFINITY);
        for s in 0..n {
            let (a, b) = cc.slice_range(s);
            assert!(a < b, "{cc:?} slice {s}: {a}..{b}");
            if s + 1 < n {
                assert_eq!(b, cc.slice_range(s + 1).0);
            }
            // Points well inside the slice (away from its ends by a relative 1e-4, beyond
            // the log's and powf's f32 error) land in it.
            let inside = if b.is_finite() { a + (b - a) * 0.5 } else { a * 2.0 + 1.0 };
            assert_eq!(cc.slice_of(inside), s, "{cc:?}: {inside} in [{a}, {b})");
        }
    }
    let cc = ClusterConfig { slices: 3, first: 1.0, last: 100.0, ..ClusterConfig::default() };
    assert_eq!(cc.slice_range(1), (1.0, 10.0));
    assert_eq!([0.5, 1.0, 9.9, 10.5, 99.0, 1e9].map(|d| cc.slice_of(d)), [0, 1, 1, 2, 2, 2]);
    let one = ClusterConfig { slices: 1, ..cc };
    assert_eq!(one.slice_range(0), (0.0, f32::INFINITY));
    assert_eq!(one.slice_of(1e9), 0);
}

#[test]
fn cluster_lists_and_statistics() {
    let (mut pairs, mut geometry_only_smaller) = (0, 0);
    for seed in 0..40 {
        let mut f = frame(seed);
        f.cluster.geometry_only = false;
        let all = cull(&f);
        f.cluster.geometry_only = true;
        let occupied = cull(&f);
        let grid = all.grid;
        assert_eq!(all.cluster, Some(ClusterConfig { geometry_only: false, ..f.cluster }));
        assert_eq!(all.lists_per_tile(), f.cluster.slices as usize);
        assert_eq!(all.lists.len(), grid.tile_count() * f.cluster.slices as usize);
        let occupancy = cluster_occupancy(&f.depth, &grid, f.samples, &f.camera, &f.cluster);
        for (k, (a, b)) in all.lists.iter().zip(&occupied.lists).enumerate() {
            let (t, s) = (k / f.cluster.slices as usize, k % f.cluster.slices as usize);
            let expected: &[u32] = if occupancy[t] & (1 << s) != 0 { a } else { &[] };
            assert_eq!(b, expected, "cluster {t}/{s}");
            geometry_only_smaller += a.len() - b.len();
            pairs += b.len();
        }
        // Occupancy: sky tiles have none, tiles with geometry some.
        for (t, range) in all.ranges.iter().enumerate() {
            assert_eq!(range.is_some(), occupancy[t] != 0, "tile {t}");
        }
        let st = stats(&occupied);
        assert_eq!(st.tiles_with_geometry as usize, all.ranges.iter().filter(|r| r.is_some()).count());
        let q = list_quality(&f.depth, &f.camera, &f.packed, &occupied);
        assert!((0.0..=1.0).contains(&q.false_positive_rate));
    }
    assert!(pairs > 1000 && geometry_only_smaller > 1000, "{pairs} pairs, {geometry_only_smaller} dropped");
}

#[test]
fn cluster_validation() {
    let ok = ClusterConfig::default();
    assert_eq!(ok, ClusterConfig { tile_size: 64, slices: 16, first: 5.0, last: 500.0, geometry_only: false });
    ok.validate().unwrap();
    let bad = [
        ClusterConfig { tile_size: 7, ..ok },
        ClusterConfig { tile_size: 513, ..ok },
        ClusterConfig { slices: 0, ..ok },
        ClusterConfig { slices: 33, ..ok },
        ClusterConfig { first: 0.0, ..ok },
        ClusterConfig { first: -1.0, ..ok },
        ClusterConfig { first: f32::NAN, ..ok },
        ClusterConfig { first: f32::INFINITY, ..ok },
        ClusterConfig { last: 5.0, ..ok },
        ClusterConfig { last: f32::INFINITY, ..ok },
        ClusterConfig { last: f32::NAN, ..ok },
    ];
    for c in bad {
        match c.validate() {
            Err(CullError::InvalidSize(m)) => assert!(!m.is_empty()),
            other => panic!("{c:?} accepted: {other:?}"),
        }
    }
    ClusterConfig { slices: 1, ..ok }.validate().unwrap();
    ClusterConfig { tile_size: 512, slices: 32, ..ok }.validate().unwrap();
    let cam = common::axis_camera(1.0);
    let packed = pack_lights(&[]);
    let run = |c: &ClusterConfig, samples, inflate| cull_clusters(&[0.5; 4], 2, 2, &cam, &packed, c, samples, inflate);
    assert!(run(&ok, 1, 0.0).is_ok());
    assert!(matches!(run(&ok, 3, 0.0), Err(CullError::InvalidSize(_))));
    assert!(matches!(run(&ok, 1, f32::NAN), Err(CullError::InvalidSize(_))));
    assert!(matches!(run(&ClusterConfig { slices: 0, ..ok }, 1, 0.0), Err(CullError::InvalidSize(_))));
    assert!(matches!(run(&ok, 2, 0.0), Err(CullError::InvalidDepth(_))));
}
