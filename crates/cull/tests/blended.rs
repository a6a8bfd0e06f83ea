//! The lists of alpha-blended geometry (`cull_tiles_blended`, `blended_tile_bounds`) on
//! hand-built frames: a tile without blended samples has no range and an empty list; a
//! pane in front of a far wall gets the range from the pane to the wall (lights between
//! them kept, which the opaque lists drop); sky behind a pane makes the range reach the far
//! plane (infinitely far with an infinite far plane); MSAA samples without blended geometry
//! do not count; half-z is rejected by name, two-level culling ignored; bad buffers are
//! rejected naming the buffer; with blended depth equal to the opaque depth the lists are
//! `cull_tiles`' own. The no-false-negative property is in no_false_negatives.rs.

mod common;

use common::{axis_camera, point_light, rng, CamSpec, DEPTH_MODES};
use glam::Vec3;
use rand::Rng;
use tiledlight_cull::light::{order_points_first, pack_lights, PackedLights};
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::volumes::blended_tile_bounds;
use tiledlight_cull::{cull_tiles, cull_tiles_blended, Camera, CullConfig, CullError, Light, TileGrid, TileLists};

/// The screen of the hand-built frames: 64x32 px, 16 px tiles, so 4x2 tiles.
const W: u32 = 64;
const H: u32 = 32;

/// A `W` x `H` single-sample buffer from a per-pixel function.
fn buffer(f: impl Fn(u32, u32) -> f32) -> Vec<f32> {
    let f = &f;
    (0..H).flat_map(|y| (0..W).map(move |x| f(x, y))).collect()
}

/// Every switch the blended lists honour (half-z excluded), two-level culling included
/// (ignored by them).
fn configs() -> impl Iterator<Item = CullConfig> {
    (0..8).map(|bits| CullConfig {
        aabb: bits & 1 != 0,
        spot_cone: bits & 2 != 0,
        coarse: bits & 4 != 0,
        ..CullConfig::default()
    })
}

fn cull_blended(opaque: &[f32], blended: &[f32], cam: &Camera, packed: &PackedLights, cfg: &CullConfig) -> TileLists {
    cull_tiles_blended(opaque, blended, W, H, cam, packed, cfg).expect("valid frame")
}

/// View-space point on the central ray of tile (tx, ty) of the `W` x `H` screen at view
/// distance `dist` (world space too: `axis_camera` has the identity view).
fn on_tile_ray(cam: &Camera, tx: u32, ty: u32, dist: f32) -> Vec3 {
    let (l, r, b, t) = TileGrid::new(W, H, 16).unwrap().tile_ndc(tx, ty);
    cam.view_point_at(0.5 * (l + r), 0.5 * (b + t), dist)
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * b.abs()
}

#[test]
fn tiles_without_blended_samples_get_no_range_and_no_lights() {
    // A wall 10 m away everywhere; a pane 5 m away over the left half (tile columns 0 and
    // 1). One light around the eye reaches every surface, opaque or blended.
    let cam = axis_camera(2.0);
    let dp = cam.depth_params();
    let opaque = buffer(|_, _| dp.depth(10.0));
    let blended = buffer(|x, _| if x < 32 { dp.depth(5.0) } else { 0.0 });
    let packed = pack_lights(&[point_light(Vec3::ZERO, 1e3)]);
    let grid = TileGrid::new(W, H, 16).unwrap();
    for cfg in configs() {
        let lists = cull_blended(&opaque, &blended, &cam, &packed, &cfg);
        let opaque_lists = cull_tiles(&opaque, W, H, &cam, &packed, &cfg).unwrap();
        for t in 0..grid.tile_count() {
            let (tx, ty) = (t as u32 % grid.tiles_x, t as u32 / grid.tiles_x);
            let has_pane = tx < 2;
            assert_eq!(blended_tile_bounds(&grid, &opaque, &blended, 1, tx, ty).is_some(), has_pane, "tile {t}");
            assert_eq!(lists.ranges[t].is_some(), has_pane, "tile {t} ({cfg:?})");
            let expected: &[u32] = if has_pane { &[0] } else { &[] };
            assert_eq!(lists.lists[t], expected, "tile {t} ({cfg:?})");
            // The opaque lists of the same frame hold the light everywhere.
            assert_eq!(opaque_lists.lists[t], [0], "tile {t} ({cfg:?})");
        }
    }
}

#[test]
fn pane_in_front_of_a_far_wall_covers_pane_to_wall() {
    // A wall 20 m away; in tile 0 a pane 5 m away over an 8x8 px patch, in tile 1 a
    // pane 8 m away over a single pixel, elsewhere nothing blended.
    let cam = axis_camera(2.0);
    let dp = cam.depth_params();
    let (pane, wall) = (dp.depth(5.0), dp.depth(20.0));
    let opaque = buffer(|_, _| wall);
    let blended = buffer(|x, y| match (x, y) {
        (4..12, 4..12) => pane,
        (20, 9) => dp.depth(8.0),
        _ => 0.0,
    });
    let grid = TileGrid::new(W, H, 16).unwrap();
    assert_eq!(blended_tile_bounds(&grid, &opaque, &blended, 1, 0, 0), Some((pane, wall)));
    assert_eq!(blended_tile_bounds(&grid, &opaque, &blended, 1, 1, 0), Some((dp.depth(8.0), wall)));
    assert_eq!(blended_tile_bounds(&grid, &opaque, &blended, 1, 2, 0), None);
    // On tile 0's central ray: before the pane, between pane and wall, straddling the
    // wall, beyond the wall.
    let lights = [
        point_light(on_tile_ray(&cam, 0, 0, 2.0), 1.0),
        point_light(on_tile_ray(&cam, 0, 0, 12.0), 1.0),
        point_light(on_tile_ray(&cam, 0, 0, 19.5), 1.0),
        point_light(on_tile_ray(&cam, 0, 0, 25.0), 2.0),
    ];
    let packed = pack_lights(&lights);
    for cfg in configs() {
        let lists = cull_blended(&opaque, &blended, &cam, &packed, &cfg);
        let (near, far) = lists.ranges[0].unwrap();
        assert!(close(near, 5.0) && close(far, 20.0), "range {near}..{far}");
        assert_eq!(lists.lists[0], [1, 2], "{cfg:?}");
        assert!(lists.ranges[2..4].iter().all(Option::is_none) && lists.lists[2..4].iter().all(Vec::is_empty));
        // The opaque list of the tile covers the wall only: the light between pane and
        // wall, which lights the pane, is not in it.
        let opaque_lists = cull_tiles(&opaque, W, H, &cam, &packed, &cfg).unwrap();
        assert_eq!(opaque_lists.lists[0], [2], "{cfg:?}");
        assert!(!lists.config.coarse && lists.config.aabb == cfg.aabb);
    }
}

#[test]
fn sky_behind_a_pane_reaches_the_far_plane() {
    // No opaque geometry at all; a pane 5 m away over tile 0. Lights on tile 0's central
    // ray: 1e4 m away (a point, and a spot looking back at the eye, 1e4 m long), 90 m away
    // (inside a finite far plane of 100 m); one behind the eye, one on another tile's ray.
    let ray = |tx, ty, dist| on_tile_ray(&axis_camera(2.0), tx, ty, dist);
    let spot = Light::spot(ray(0, 0, 1e4), -ray(0, 0, 1e4), Vec3::ONE, 1.0, 0.1, 0.3, 1e-8).unwrap();
    let lights = [
        point_light(ray(0, 0, 1e4), 10.0),
        point_light(ray(0, 0, 90.0), 1.0),
        point_light(Vec3::new(0.0, 0.0, 10.0), 1.0),
        point_light(ray(3, 1, 100.0), 1.0),
        spot,
    ];
    let packed = pack_lights(&order_points_first(&lights));
    let finite =
        Camera::perspective(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90f32.to_radians(), 2.0, 0.1, Some(100.0)).unwrap();
    let grid = TileGrid::new(W, H, 16).unwrap();
    let opaque = vec![0.0; (W * H) as usize];
    for (cam, far, expected) in [(axis_camera(2.0), f32::INFINITY, vec![0, 1, 4]), (finite, 100.0, vec![1])] {
        let pane = cam.depth_params().depth(5.0);
        let blended = buffer(|x, y| if x < 16 && y < 16 { pane } else { 0.0 });
        assert_eq!(blended_tile_bounds(&grid, &opaque, &blended, 1, 0, 0), Some((pane, 0.0)));
        for cfg in configs() {
            let lists = cull_blended(&opaque, &blended, &cam, &packed, &cfg);
            let (near, f) = lists.ranges[0].unwrap();
            assert!(close(near, 5.0) && (f == far || close(f, far)), "range {near}..{f}, far plane {far}");
            assert_eq!(lists.lists[0], expected, "far plane {far}, {cfg:?}");
            assert!(lists.lists[1..].iter().all(Vec::is_empty));
        }
    }
    // Orthographic: the far plane again.
    let ortho = Camera::orthographic(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 10.0, 2.0, 0.0, 50.0).unwrap();
    let blended = buffer(|x, y| if x < 16 && y < 16 { ortho.depth_params().depth(5.0) } else { 0.0 });
    let lists = cull_blended(&opaque, &blended, &ortho, &packed, &CullConfig::default());
    let (near, f) = lists.ranges[0].unwrap();
    assert!(close(near, 5.0) && close(f, 50.0), "orthographic range {near}..{f}");
}

#[test]
fn only_samples_with_blended_geometry_count() {
    // One 2x1 px tile, 4 samples per pixel. Samples without blended geometry (0) are
    // ignored whatever their opaque depth; sky behind a blended sample makes far 0.
    let grid = TileGrid::new(2, 1, 2).unwrap();
    let opaque = [0.05, 0.2, 0.3, 0.9, /* pixel 1 */ 0.4, 0.35, 0.6, 0.7];
    let blended = [0.0, 0.5, 0.3, 0.0, /* pixel 1 */ 0.0, 0.8, 0.0, 0.0];
    assert_eq!(blended_tile_bounds(&grid, &opaque, &blended, 4, 0, 0), Some((0.8, 0.2)));
    let mut sky = opaque;
    sky[2] = 0.0;
    assert_eq!(blended_tile_bounds(&grid, &sky, &blended, 4, 0, 0), Some((0.8, 0.0)));
    // A blended sample behind its opaque one (impossible after the depth test) still
    // lies inside the range: far covers it.
    let mut behind = blended;
    behind[4] = 0.1;
    assert_eq!(blended_tile_bounds(&grid, &opaque, &behind, 4, 0, 0), Some((0.8, 0.1)));
    assert_eq!(blended_tile_bounds(&grid, &opaque, &[0.0; 8], 4, 0, 0), None);
}

#[test]
fn half_z_is_rejected_and_bad_buffers_are_named() {
    let cam = axis_camera(1.0);
    let packed = pack_lights(&[point_light(Vec3::ZERO, 1.0)]);
    let ok = [0.5f32; 4];
    let cfg = CullConfig { tile_size: 2, ..CullConfig::default() };
    let run = |o: &[f32], b: &[f32], cfg: &CullConfig| cull_tiles_blended(o, b, 2, 2, &cam, &packed, cfg);
    match run(&ok, &ok, &CullConfig { half_z: true, ..cfg }) {
        Err(CullError::InvalidSize(m)) => assert!(m.contains("half_z"), "{m}"),
        r => panic!("half_z accepted: {r:?}"),
    }
    for (o, b, name) in [
        (&ok[..], &ok[..3], "blended"),
        (&ok[..3], &ok[..], "opaque"),
        (&ok[..], &[0.5, f32::NAN, 0.5, 0.5][..], "blended"),
        (&[0.5, 0.5, 1.5, 0.5][..], &ok[..], "opaque"),
    ] {
        match run(o, b, &cfg) {
            Err(CullError::InvalidDepth(m)) => assert!(m.starts_with(name), "{m}"),
            r => panic!("{name} buffer {b:?} accepted: {r:?}"),
        }
    }
    // The options `cull_tiles` rejects are rejected here too.
    assert!(matches!(run(&ok, &ok, &CullConfig { samples: 3, ..cfg }), Err(CullError::InvalidSize(_))));
    // Two-level culling is ignored, not rejected, even with a tile size it could not use.
    for tile_size in [2, 3] {
        let lists = run(&ok, &ok, &CullConfig { coarse: true, tile_size, ..cfg }).unwrap();
        assert_eq!(lists, run(&ok, &ok, &CullConfig { tile_size, ..cfg }).unwrap());
        assert!(!lists.config.coarse);
    }
}

#[test]
fn blended_depth_equal_to_opaque_gives_the_opaque_lists() {
    // Blended geometry on every opaque surface (decals): the same bounds per tile, so the
    // same lists and ranges as `cull_tiles`, over random cameras, depths and lights.
    for seed in 0..40u64 {
        let mut r = rng(500 + seed);
        let spec = CamSpec::random(&mut r);
        let cam = spec.camera();
        let (w, h) = (r.random_range(1..40), r.random_range(1..40));
        let depth = common::random_depth(&mut r, DEPTH_MODES[seed as usize % DEPTH_MODES.len()], &cam, w, h, None);
        let targets: Vec<Vec3> = (0..16)
            .filter_map(|_| {
                let (x, y) = (r.random_range(0..w), r.random_range(0..h));
                pixel_view_position(&cam, w, h, x, y, depth[(y * w + x) as usize])
            })
            .map(|p| common::view_to_world(&cam, p))
            .filter(|t| t.abs().max_element() < 1e30)
            .collect();
        let packed = pack_lights(&order_points_first(&common::random_lights(&mut r, &spec, &targets, 24)));
        for cfg in configs() {
            let cfg = CullConfig { tile_size: [1, 4, 8, 16][seed as usize % 4], coarse: false, ..cfg };
            let blended = cull_tiles_blended(&depth, &depth, w, h, &cam, &packed, &cfg).unwrap();
            let opaque = cull_tiles(&depth, w, h, &cam, &packed, &cfg).unwrap();
            assert_eq!(blended, opaque, "seed {seed} {cfg:?}");
        }
    }
}
