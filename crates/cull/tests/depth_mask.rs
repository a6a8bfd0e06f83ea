//! 2.5D culling (`depth_mask`): the bin formula at its edges (NaN, infinite and empty
//! ranges) against the plain formula the GPU mirrors; light masks; a light in the gap
//! between a near pane and a far wall of one tile is dropped that the plain depth range
//! keeps; masks of real frames have their nearest and farthest bins set; 2.5D lists are
//! subsets of the plain ones; the options are validated. The no-false-negative property
//! of 2.5D lists is part of `no_false_negatives.rs`.

mod common;

use common::{axis_camera, point_light, rng, CamSpec, DEPTH_MODES};
use glam::Vec3;
use rand::Rng;
use tiledlight_cull::depth_mask::{depth_bin, light_depth_mask, tile_depth_masks, DEPTH_MASK_BINS};
use tiledlight_cull::light::{order_points_first, pack_lights};
use tiledlight_cull::tiles::{tile_depth_bounds_samples, TileGrid};
use tiledlight_cull::{cull_tiles, cull_tiles_blended, CullConfig, CullError};

/// The formula as the brief writes it, with no guard for `inv == 0`.
fn plain_bin(d: f32, near: f32, far: f32) -> u32 {
    let mut inv = if far > near { 32.0 / (far - near) } else { 0.0 };
    if !inv.is_finite() {
        inv = 0.0;
    }
    let x = (d - near) * inv;
    // Not `clamp`: that keeps NaN, where `max` drops it as the brief's formula relies on.
    #[allow(clippy::manual_clamp)]
    let bin = x.max(0.0).min(31.0) as u32;
    bin
}

#[test]
fn depth_bin_at_its_edges() {
    assert_eq!(DEPTH_MASK_BINS, 32);
    let cases = [
        (0.0, 0.0, 32.0, 0),
        (0.99, 0.0, 32.0, 0),
        (1.0, 0.0, 32.0, 1),
        (31.5, 0.0, 32.0, 31),
        (32.0, 0.0, 32.0, 31),
        (1e30, 0.0, 32.0, 31),
        (-5.0, 0.0, 32.0, 0),
        (f32::NAN, 0.0, 32.0, 0),
        (f32::INFINITY, 0.0, 32.0, 31),
        (f32::NEG_INFINITY, 0.0, 32.0, 0),
        // Infinite far plane behind some sample: every value in bin 0, no NaN.
        (5.0, 1.0, f32::INFINITY, 0),
        (f32::INFINITY, 1.0, f32::INFINITY, 0),
        (f32::INFINITY, f32::INFINITY, f32::INFINITY, 0),
        // Empty and reversed ranges.
        (3.0, 3.0, 3.0, 0),
        (3.0, 4.0, 3.0, 0),
        // A range so thin that 32 / (far - near) overflows.
        (1.0, 1.0, 1.0 + f32::from_bits(1), 0),
    ];
    for (d, near, far, bin) in cases {
        assert_eq!(depth_bin(d, near, far), bin, "depth_bin({d}, {near}, {far})");
        assert_eq!(plain_bin(d, near, far), bin, "the plain formula at ({d}, {near}, {far})");
    }
    // Random values, specials mixed in: the guarded and plain formulas agree everywhere.
    let mut r = rng(5);
    let special = [0.0, -0.0, 1e-45, 1e38, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1.0, 1e7];
    let pick = |r: &mut rand_pcg::Pcg64| {
        if r.random_bool(0.3) {
            special[r.random_range(0..special.len())]
        } else {
            common::log_uniform(r, 1e-6, 1e8) * if r.random_bool(0.1) { -1.0 } else { 1.0 }
        }
    };
    for _ in 0..100_000 {
        let (a, b, c) = (pick(&mut r), pick(&mut r), pick(&mut r));
        assert_eq!(depth_bin(a, b, c), plain_bin(a, b, c), "({a}, {b}, {c})");
    }
}

#[test]
fn depth_bin_is_monotone() {
    let mut r = rng(6);
    for _ in 0..100_000 {
        let near = common::log_uniform(&mut r, 1e-4, 1e6);
        let far = near + common::log_uniform(&mut r, 1e-6, 1e7);
        let a = near + (far - near) * r.random_range(-0.2..1.2);
        let b = a + (far - near) * r.random_range(0.0..0.1);
        assert!(depth_bin(a, near, far) <= depth_bin(b, near, far), "{a} <= {b} in [{near}, {far}]");
    }
}

#[test]
fn light_masks() {
    assert_eq!(light_depth_mask(16.0, 0.1, 0.0, 32.0), 1 << 15 | 1 << 16);
    assert_eq!(light_depth_mask(16.5, 0.1, 0.0, 32.0), 1 << 16);
    assert_eq!(light_depth_mask(16.0, 100.0, 0.0, 32.0), u32::MAX);
    assert_eq!(light_depth_mask(-50.0, 1.0, 0.0, 32.0), 1);
    assert_eq!(light_depth_mask(500.0, 1.0, 0.0, 32.0), 1 << 31);
    assert_eq!(light_depth_mask(5.0, 1.0, 1.0, f32::INFINITY), 1);
}

/// One 16x16 tile: its left half a pane 2 m away, its right half a wall at 50 m.
fn pane_and_wall() -> (tiledlight_cull::Camera, Vec<f32>) {
    let cam = axis_camera(1.0);
    let dp = cam.depth_params();
    let depth = (0..16 * 16).map(|i| if i % 16 < 8 { dp.depth(2.0) } else { dp.depth(50.0) }).collect();
    (cam, depth)
}

#[test]
fn a_light_between_pane_and_wall_is_dropped() {
    let (cam, depth) = pane_and_wall();
    let grid = TileGrid::new(16, 16, 16).unwrap();
    let masks = tile_depth_masks(&depth, &grid, 1, &cam);
    assert_eq!(masks, vec![1 | 1 << 31], "the pane in the first bin, the wall in the last");
    let lights = [
        point_light(Vec3::new(0.0, 0.0, -25.0), 3.0), // in the gap: bins 13..=17
        point_light(Vec3::new(0.0, 0.0, -49.0), 3.0), // at the wall
        point_light(Vec3::new(0.0, 0.0, -3.0), 0.5),  // at the pane
    ];
    let packed = pack_lights(&order_points_first(&lights));
    for aabb in [false, true] {
        let plain = CullConfig { tile_size: 16, aabb, ..CullConfig::default() };
        let masked = CullConfig { depth_mask: true, ..plain };
        assert_eq!(cull_tiles(&depth, 16, 16, &cam, &packed, &plain).unwrap().lists, vec![vec![0, 1, 2]]);
        let lists = cull_tiles(&depth, 16, 16, &cam, &packed, &masked).unwrap();
        assert_eq!(lists.lists, vec![vec![1, 2]], "aabb {aabb}");
        assert!(lists.config.depth_mask, "the lists say which layout made them");
    }
}

#[test]
fn masks_of_random_frames() {
    let mut r = rng(9);
    let (mut tiles, mut dropped) = (0, 0);
    for i in 0..200 {
        let spec = CamSpec::random(&mut r);
        let cam = spec.camera();
        let (w, h, samples) = (r.random_range(1..50), r.random_range(1..50), [1, 2, 4, 8][i % 4]);
        let mode = DEPTH_MODES[i % DEPTH_MODES.len()];
        let depth = common::random_depth_samples(&mut r, mode, &cam, w, h, samples, None, 0.1);
        let tile_size = [1, 8, 16, 32][i % 4];
        let grid = TileGrid::new(w, h, tile_size).unwrap();
        let masks = tile_depth_masks(&depth, &grid, samples, &cam);
        let dp = cam.depth_params();
        for (t, &mask) in masks.iter().enumerate() {
            let (tx, ty) = (t as u32 % grid.tiles_x, t as u32 / grid.tiles_x);
            let range = tile_depth_bounds_samples(&grid, &depth, samples, tx, ty)
                .map(|b| (dp.view_distance(b.max_depth), dp.view_distance(b.min_depth)));
            match range {
                None => assert_eq!(mask, 0, "sky tile {t}"),
                Some((near, far)) => {
                    tiles += 1;
                    assert!(mask & 1 != 0, "the nearest sample is in bin 0");
                    if far > near && (32.0 / (far - near)).is_finite() && 32.0 / (far - near) > 0.0 {
                        assert!(mask & 1 << 31 != 0, "the farthest sample is in bin 31 ({near}..{far})");
                    }
                }
            }
        }
        let targets: Vec<Vec3> = (0..8).map(|_| spec.eye + common::unit(&mut r) * 10.0).collect();
        let lights = common::random_lights(&mut r, &spec, &targets, 24);
        let packed = pack_lights(&order_points_first(&lights));
        let plain = CullConfig { tile_size, samples, ..CullConfig::default() };
        let a = cull_tiles(&depth, w, h, &cam, &packed, &plain).unwrap();
        let b = cull_tiles(&depth, w, h, &cam, &packed, &CullConfig { depth_mask: true, ..plain }).unwrap();
        for (la, lb) in a.lists.iter().zip(&b.lists) {
            assert!(lb.iter().all(|l| la.binary_search(l).is_ok()), "2.5D lists are subsets");
            dropped += la.len() - lb.len();
        }
    }
    assert!(tiles > 1000 && dropped > 0, "{tiles} tiles, {dropped} lights dropped by the masks");
}

#[test]
fn depth_mask_options() {
    let (cam, depth) = pane_and_wall();
    let packed = pack_lights(&[point_light(Vec3::new(0.0, 0.0, -25.0), 3.0)]);
    let cfg = CullConfig { tile_size: 16, depth_mask: true, ..CullConfig::default() };
    match cull_tiles(&depth, 16, 16, &cam, &packed, &CullConfig { half_z: true, ..cfg }) {
        Err(CullError::InvalidSize(m)) => assert!(m.contains("depth_mask") && m.contains("half_z"), "{m}"),
        other => panic!("depth_mask with half_z accepted: {other:?}"),
    }
    // Two-level culling stays allowed.
    cull_tiles(&depth, 16, 16, &cam, &packed, &CullConfig { coarse: true, ..cfg }).unwrap();
    // The blended lists ignore the opaque masks (and say so in their config).
    let blended = vec![0.0; depth.len()];
    let lists = cull_tiles_blended(&depth, &blended, 16, 16, &cam, &packed, &cfg).unwrap();
    assert!(!lists.config.depth_mask);
}
