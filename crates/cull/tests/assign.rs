//! The light-centric tile rectangle (`assign::light_tile_rect`) and the scatter culler
//! built on it. For random cameras at DESIGN.md's extremes (near 1e-4, far 1e7 and
//! infinite, FOV 1..170 degrees, orthographic, any pose), random screens and tile sizes
//! (1..=512 px) and random lights (in and around the view, across the eye plane, behind
//! it, radius 1e-4..1e6):
//! - every tile whose side planes the sphere passes lies in the rectangle, and every tile
//!   of the rectangle passes them, except decisions within float error (the sphere shrunk,
//!   respectively grown, by `1e-5 * (r + |c|)` decides them the rectangle's way);
//! - a perspective sphere reaching the eye plane gets a rectangle holding every tile that
//!   its part beyond the near plane reaches into by more than a sample's margin (1/16
//!   pixel), the part's projected extent computed exactly in f64 (`cap_extent`: tangent
//!   lines through the eye and the near-plane chord), every tile checked, edges included;
//! - `cull_tiles_scatter` (and `cull_tiles` with `scatter`) equals `cull_tiles` for every
//!   config switch and sample count but for pairs of lights reaching the eye plane in
//!   tiles outside their near-plane rectangle.

mod common;

use common::{log_uniform, rng, CamKind, CamSpec, DepthMode, DEPTH_MODES};
use glam::Vec3;
use proptest::prelude::*;
use rand::Rng;
use tiledlight_cull::assign::{cull_tiles_scatter, light_tile_rect, lower_bound, near_cap_rect, TileRect};
use tiledlight_cull::bounds::sphere_vs_frustum;
use tiledlight_cull::camera::view_point_at;
use tiledlight_cull::light::{order_points_first, pack_lights};
use tiledlight_cull::lists::COARSE_SIZE;
use tiledlight_cull::tiles::{TileFrustum, TileGrid};
use tiledlight_cull::{cull_tiles, Camera, CullConfig};

/// `cases` cases from the workspace's fixed seed (`common::proptest_config`);
/// `PROPTEST_CASES=n` runs more, `PROPTEST_RNG_SEED=s` others.
fn cases(cases: u32) -> ProptestConfig {
    common::proptest_config(cases)
}

/// Relative radius slack for decisions within float error: a fraction of `r + |c|`.
const SLACK: f32 = 1e-5;

/// A grid with any tile size (the clusters' grids go past `TileGrid::new`'s 64 px).
fn grid(width: u32, height: u32, tile_size: u32) -> TileGrid {
    TileGrid { width, height, tile_size, tiles_x: width.div_ceil(tile_size), tiles_y: height.div_ceil(tile_size) }
}

/// Whether the sphere passes tile (tx, ty)'s four side planes, as `sphere_vs_frustum`
/// tests them (depth range open).
fn passes_tile(g: &TileGrid, camera: &Camera, tx: u32, ty: u32, c: Vec3, r: f32) -> bool {
    let dp = camera.depth_params();
    let f = TileFrustum::from_parts(&camera.proj(), &dp, g.tile_ndc(tx, ty), f32::NEG_INFINITY, f32::INFINITY);
    sphere_vs_frustum(&f, c, r)
}

/// Random view-space lights around a camera: in view (a random NDC point at a random
/// distance, offset by up to twice the radius), across or behind the eye plane, or anywhere.
fn random_view_lights(r: &mut impl Rng, camera: &Camera, n: usize) -> Vec<(Vec3, f32)> {
    let dp = camera.depth_params();
    let far = if dp.far.is_finite() { dp.far } else { 1e7 };
    (0..n)
        .map(|_| {
            let radius = log_uniform(r, 1e-4, 1e6);
            let c = match r.random_range(0..4) {
                0 | 1 => {
                    let (x, y) = (r.random_range(-1.5..1.5), r.random_range(-1.5..1.5));
                    let d = log_uniform(r, dp.near.max(1e-4), far);
                    let p = view_point_at(&camera.proj(), dp.orthographic, x, y, d);
                    p + common::unit(r) * radius * r.random_range(0.0..2.0)
                }
                2 => Vec3::new(
                    r.random_range(-1.0..1.0) * radius,
                    r.random_range(-1.0..1.0) * radius,
                    r.random_range(-1.5..0.5) * radius,
                ),
                _ => common::unit(r) * log_uniform(r, 1e-4, far),
            };
            (c, radius)
        })
        .collect()
}

/// Checks one light's rectangle against every tile; returns the number of passing tiles.
fn check_rect(g: &TileGrid, camera: &Camera, c: Vec3, r: f32) -> Result<usize, TestCaseError> {
    let dp = camera.depth_params();
    let rect = light_tile_rect(g, &camera.proj(), &dp, c, r);
    // Reaching the eye plane: the plane tests are not monotone; the rectangle bounds the
    // part beyond the near plane instead (checked against its exact extent), not the
    // passing tiles.
    let cap = !dp.orthographic && c.z + r >= 0.0;
    if cap {
        check_cap(g, camera, c, r, rect)?;
    }
    let slack = SLACK * (r + c.length());
    let mut passing = 0;
    for ty in 0..g.tiles_y {
        for tx in 0..g.tiles_x {
            let pass = passes_tile(g, camera, tx, ty, c, r);
            passing += usize::from(pass);
            let inside = rect.is_some_and(|q| q.contains(tx, ty));
            if pass && !inside && !cap {
                prop_assert!(
                    !passes_tile(g, camera, tx, ty, c, r - slack),
                    "tile ({tx}, {ty}) passes but lies outside {rect:?}: light {c} r {r:e}"
                );
            }
            if inside && !pass && !cap {
                prop_assert!(
                    passes_tile(g, camera, tx, ty, c, r + slack),
                    "tile ({tx}, {ty}) of {rect:?} fails by more than float error: light {c} r {r:e}"
                );
            }
        }
    }
    Ok(passing)
}

/// The exact extent of `a / -z` over the part of the sphere (`c`, `r`) beyond the near
/// plane, `a` being view-space x (`axis` 0) or y (1), in f64; `None` when that part is
/// empty. `a / -z` depends on (a, z) only, and the ball cut at `z <= -near` projects onto
/// the (a, z) plane as the disc of radius `r` about `(c.a, c.z)` cut at `z <= -near`. The
/// ratio's level sets are lines through the origin (the eye), so its extremes over the cut
/// disc lie where such a line is tangent to the circle (the tangent point beyond the near
/// plane) or at the cut chord's ends (`z = -near`, where the ratio is `a / near`, linear
/// in `a`); both kinds of candidate are computed and the valid ones compared.
fn cap_extent(c: glam::DVec3, r: f64, near: f64, axis: usize) -> Option<(f64, f64)> {
    let (a0, z0) = (if axis == 0 { c.x } else { c.y }, c.z);
    if z0 - r > -near {
        return None;
    }
    let mut cands = Vec::new();
    // The chord at z = -near.
    let h = r * r - (z0 + near) * (z0 + near);
    if h >= 0.0 {
        cands.push((a0 - h.sqrt()) / near);
        cands.push((a0 + h.sqrt()) / near);
    }
    // Lines a + u z = 0 tangent to the circle: (z0^2 - r^2) u^2 + 2 a0 z0 u + a0^2 - r^2 = 0.
    let (qa, qb, qc) = (z0 * z0 - r * r, 2.0 * a0 * z0, a0 * a0 - r * r);
    let mut roots = Vec::new();
    if qa.abs() > 1e-300 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            roots.push((-qb + disc.sqrt()) / (2.0 * qa));
            roots.push((-qb - disc.sqrt()) / (2.0 * qa));
        }
    } else if qb != 0.0 {
        roots.push(-qc / qb);
    }
    for u in roots {
        // The tangent point: the centre's foot on the line, whose normal is (1, u).
        let t = (a0 + u * z0) / (1.0 + u * u);
        let z = z0 - t * u;
        if z <= -near {
            cands.push(u);
        }
    }
    // The cut disc is compact, beyond the eye: its extremes are among the candidates.
    let lo = cands.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = cands.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo <= hi).then_some((lo, hi))
}

/// Distance of the outermost sample of a pixel from the pixel's edge, in pixels: 1/16,
/// 8x MSAA's standard positions (1x samples at the centre, 1/2).
const SAMPLE_MARGIN_PX: f64 = 1.0 / 16.0;

/// A sphere reaching the eye plane: the rectangle holds every tile that the part of the
/// sphere beyond the near plane reaches into by more than [`SAMPLE_MARGIN_PX`] (where a
/// sample of a drawn surface the light reaches can lie). The part's projected extent is
/// computed exactly ([`cap_extent`], f64), not sampled, and every tile of the grid is
/// checked, edge tiles and tiles the extent ends in included: nothing is skipped. The
/// extent function is itself checked against points of the sphere (a Fibonacci sphere
/// at three radii and the cut circle): none projects outside it.
fn check_cap(g: &TileGrid, camera: &Camera, c: Vec3, r: f32, rect: Option<TileRect>) -> Result<(), TestCaseError> {
    if !(r.is_finite() && c.is_finite()) {
        return Ok(());
    }
    let proj = camera.proj();
    let near = f64::from(camera.depth_params().near);
    let cd = c.as_dvec3();
    let rd = f64::from(r);
    let (Some(ex), Some(ey)) = (cap_extent(cd, rd, near, 0), cap_extent(cd, rd, near, 1)) else {
        return Ok(());
    };
    // The camera's projection is glam's symmetric perspective: ndc = (P00 x / -z, P11 y / -z).
    prop_assert!(
        proj.x_axis.y == 0.0 && proj.x_axis.w == 0.0 && proj.y_axis.x == 0.0 && proj.y_axis.w == 0.0,
        "not a symmetric perspective: {proj}"
    );
    prop_assert!(proj.z_axis.x == 0.0 && proj.z_axis.y == 0.0 && proj.z_axis.w == -1.0, "{proj}");
    let (sx, sy) = (f64::from(proj.x_axis.x), f64::from(proj.y_axis.y));
    let (lo_x, hi_x, lo_y, hi_y) = (ex.0 * sx, ex.1 * sx, ey.0 * sy, ey.1 * sy);
    // The extent bounds every point of the part beyond the near plane (a check of
    // `cap_extent`; 1e-9 relative for f64 rounding).
    let n = 200;
    let rim = (rd * rd - (cd.z + near).powi(2)).max(0.0).sqrt();
    let mut points: Vec<glam::DVec3> = (0..64)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 64.0;
            glam::DVec3::new(cd.x + rim * a.cos(), cd.y + rim * a.sin(), -near)
        })
        .collect();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let (s, phi) = ((1.0 - z * z).sqrt(), i as f64 * 2.399_963);
        let d = glam::DVec3::new(s * phi.cos(), s * phi.sin(), z);
        for f in [0.5, 1.0] {
            points.push(cd + d * rd * f);
        }
    }
    for p in points {
        if p.z > -near || (p - cd).length() > rd * (1.0 + 1e-12) {
            continue;
        }
        let (u, v) = (p.x / -p.z, p.y / -p.z);
        let tol = |e: (f64, f64)| 1e-9 * (e.0.abs().max(e.1.abs()) + 1.0);
        prop_assert!(
            u >= ex.0 - tol(ex) && u <= ex.1 + tol(ex) && v >= ey.0 - tol(ey) && v <= ey.1 + tol(ey),
            "point {p} of light {c} r {r:e} projects to ({u}, {v}), outside the exact extent {ex:?} {ey:?}"
        );
    }
    // Every tile the extent reaches into by more than a sample's margin.
    let (w, h) = (f64::from(g.width), f64::from(g.height));
    let (mx, my) = (2.0 * SAMPLE_MARGIN_PX / w, 2.0 * SAMPLE_MARGIN_PX / h);
    for ty in 0..g.tiles_y {
        let top = 1.0 - 2.0 * f64::from(ty * g.tile_size) / h;
        let bottom = 1.0 - 2.0 * f64::from(((ty + 1) * g.tile_size).min(g.height)) / h;
        if !(hi_y > bottom + my && lo_y < top - my) {
            continue;
        }
        for tx in 0..g.tiles_x {
            let left = 2.0 * f64::from(tx * g.tile_size) / w - 1.0;
            let right = 2.0 * f64::from(((tx + 1) * g.tile_size).min(g.width)) / w - 1.0;
            if !(hi_x > left + mx && lo_x < right - mx) {
                continue;
            }
            prop_assert!(
                rect.is_some_and(|q| q.contains(tx, ty)),
                "light {c} r {r:e}: its part beyond the near plane covers NDC x {lo_x}..{hi_x}, y {lo_y}..{hi_y}, \
                 reaching into tile ({tx}, {ty}), outside {rect:?}"
            );
        }
    }
    Ok(())
}

/// The exact extent against closed forms: a sphere wholly beyond the near plane straight
/// ahead spans `+-tan(asin(r / d))`; one centred on the near plane, its cut circle
/// `(c.x +- r) / near`; one around the eye reaching past the near plane, at least the
/// cut circle's.
#[test]
fn cap_extent_matches_closed_forms() {
    let e = cap_extent(glam::DVec3::new(0.0, 0.0, -10.0), 1.0, 0.1, 0).unwrap();
    let t = (1.0f64 / 10.0).asin().tan();
    assert!((e.0 + t).abs() < 1e-12 && (e.1 - t).abs() < 1e-12, "{e:?} vs {t}");
    let e = cap_extent(glam::DVec3::new(0.5, 0.0, -0.1), 1.0, 0.1, 0).unwrap();
    assert!((e.0 + 5.0).abs() < 1e-12 && (e.1 - 15.0).abs() < 1e-12, "{e:?}");
    let e = cap_extent(glam::DVec3::new(0.0, 0.0, 0.0), 1.0, 0.1, 1).unwrap();
    let chord = (1.0f64 - 0.01).sqrt() / 0.1;
    assert!((e.0 + chord).abs() < 1e-9 && (e.1 - chord).abs() < 1e-9, "{e:?} vs {chord}");
    assert_eq!(cap_extent(glam::DVec3::new(0.0, 0.0, 2.0), 1.0, 0.1, 0), None);
}

/// Cameras at the extremes: the common strategy with near pinned to 1e-4 or the far plane
/// to 1e7 in some cases, and aspect 0.1..10.
fn extreme_cam() -> impl Strategy<Value = CamSpec> {
    (common::cam_strategy(common::exp10(-1.0, 1.0)), 0u32..4).prop_map(|(c, pin)| match pin {
        0 => CamSpec { near: 1e-4, ..c },
        1 => CamSpec { far: 1e7, ..c },
        _ => c,
    })
}

proptest! {
    #![proptest_config(cases(256))]

    /// The rectangle holds exactly the tiles passing their side planes, up to float error.
    #[test]
    fn rect_is_the_set_of_passing_tiles(
        cam in extreme_cam(),
        (w, h) in (1u32..1200, 1u32..1200),
        tile in prop::sample::select(vec![1u32, 3, 8, 16, 32, 64, 128, 256, 512]),
        seed in any::<u64>(),
    ) {
        // Keep the per-case tile count (tested exhaustively per light) manageable.
        let mut tile = tile;
        while w.div_ceil(tile) * h.div_ceil(tile) > 20_000 {
            tile *= 2;
        }
        let g = grid(w, h, tile);
        let camera = cam.camera();
        let mut r = rng(seed);
        for (c, radius) in random_view_lights(&mut r, &camera, 8) {
            check_rect(&g, &camera, c, radius)?;
        }
    }
}

proptest! {
    #![proptest_config(cases(256))]

    /// Spheres reaching the eye plane only (centre within a radius of the eye, behind or
    /// ahead of it, radius 1e-4..1e4): `near_cap_rect` holds every tile their part beyond
    /// the near plane reaches into ([`check_cap`]: exact extent, every tile).
    #[test]
    fn near_cap_rect_holds_every_tile_the_cap_reaches(
        cam in extreme_cam(),
        (w, h) in (1u32..1200, 1u32..1200),
        tile in prop::sample::select(vec![1u32, 3, 8, 16, 32, 64, 128]),
        seed in any::<u64>(),
    ) {
        let mut tile = tile;
        while w.div_ceil(tile) * h.div_ceil(tile) > 20_000 {
            tile *= 2;
        }
        let g = grid(w, h, tile);
        let camera = cam.camera();
        prop_assume!(!camera.depth_params().orthographic);
        let mut r = rng(seed);
        let near = camera.depth_params().near;
        for _ in 0..16 {
            let radius = log_uniform(&mut r, near.max(1e-4), 1e4);
            let c = Vec3::new(
                r.random_range(-1.0..1.0) * radius,
                r.random_range(-1.0..1.0) * radius,
                r.random_range(-1.0..1.0) * radius,
            );
            let rect = near_cap_rect(&g, &camera.proj(), near, c, radius);
            prop_assert_eq!(rect, light_tile_rect(&g, &camera.proj(), &camera.depth_params(), c, radius));
            check_cap(&g, &camera, c, radius, rect)?;
        }
    }
}

/// The generator of `rect_is_the_set_of_passing_tiles` makes lights that pass some tiles
/// but not all (so the searches' both ends are exercised), for every camera kind.
#[test]
fn rect_cases_are_not_trivial() {
    let mut r = rng(3);
    let (mut partial, mut none, mut full) = (0, 0, 0);
    for i in 0..300 {
        let mut cam = CamSpec::random(&mut r);
        cam.kind = [CamKind::Finite, CamKind::Infinite, CamKind::Ortho][i % 3];
        if cam.kind != CamKind::Ortho {
            cam.near = cam.near.max(1e-4);
        }
        let camera = cam.camera();
        let g = grid(r.random_range(1..300), r.random_range(1..300), [1, 8, 16, 64][i % 4]);
        for (c, radius) in random_view_lights(&mut r, &camera, 4) {
            let n = check_rect(&g, &camera, c, radius).expect("rect property");
            match n {
                0 => none += 1,
                n if n == g.tile_count() => full += 1,
                _ => partial += 1,
            }
        }
    }
    eprintln!("{partial} partial, {none} empty, {full} full rectangles");
    assert!(partial > 200 && none > 50 && full > 50, "{partial} partial, {none} empty, {full} full");
}

#[test]
fn rect_edge_cases() {
    let cam = common::axis_camera(1.0);
    let (proj, g) = (cam.proj(), grid(64, 64, 16));
    let dp = cam.depth_params();
    let ortho_dp = tiledlight_cull::camera::DepthParams { orthographic: true, ..dp };
    for r in [0.0, -1.0, f32::NAN] {
        assert_eq!(light_tile_rect(&g, &proj, &dp, Vec3::new(0.0, 0.0, -5.0), r), None, "radius {r}");
    }
    // An infinite radius passes every plane, as in the per-tile test (the CPU's `inflate`
    // makes one from a centre beyond ~1e19 m).
    for d in [&dp, &ortho_dp] {
        let c = Vec3::new(1e3, 0.0, -5.0);
        assert_eq!(light_tile_rect(&g, &proj, d, c, f32::INFINITY), Some(TileRect::full(&g)));
    }
    // Around the eye: the whole grid. Reaching the eye plane far to the right (its part
    // beyond the near plane projects off the screen), or wholly nearer than the near
    // plane: no tile. Behind and to the left, reaching forward past x = -0.1: the columns
    // left of NDC -0.2 (the corner (-0.1, -0.5) projects there), every row.
    assert_eq!(light_tile_rect(&g, &proj, &dp, Vec3::ZERO, 1.0), Some(TileRect::full(&g)));
    assert_eq!(light_tile_rect(&g, &proj, &dp, Vec3::new(50.0, 0.0, -1.0), 1.0), None);
    assert_eq!(light_tile_rect(&g, &proj, &dp, Vec3::new(0.0, 0.0, 2.0), 1.0), None);
    assert_eq!(
        light_tile_rect(&g, &proj, &dp, Vec3::new(-1.1, 0.0, 0.5), 1.0),
        Some(TileRect { x0: 0, x1: 1, y0: 0, y1: 3 })
    );
    assert_eq!(
        near_cap_rect(&g, &proj, dp.near, Vec3::new(-1.1, 0.0, 0.5), 1.0),
        Some(TileRect { x0: 0, x1: 1, y0: 0, y1: 3 })
    );
    // A small light straight ahead: the 2x2 tiles around the centre of a 4x4 grid.
    assert_eq!(
        light_tile_rect(&g, &proj, &dp, Vec3::new(0.0, 0.0, -10.0), 0.1),
        Some(TileRect { x0: 1, x1: 2, y0: 1, y1: 2 })
    );
    // Upper left quadrant (90 degree FOV: NDC (-0.7, 0.7)).
    assert_eq!(
        light_tile_rect(&g, &proj, &dp, Vec3::new(-7.0, 7.0, -10.0), 0.1),
        Some(TileRect { x0: 0, x1: 0, y0: 0, y1: 0 })
    );
    assert_eq!(light_tile_rect(&g, &proj, &dp, Vec3::new(30.0, 0.0, -10.0), 1.0), None);
    assert_eq!(lower_bound(0, |_| true), 0);
    assert_eq!(lower_bound(5, |_| false), 5);
    assert_eq!(lower_bound(5, |i| i >= 3), 3);
}

/// A random frame with every config switch: camera, depth, lights and config.
fn scatter_case(seed: u64) -> (Camera, Vec<f32>, tiledlight_cull::light::PackedLights, u32, u32, CullConfig) {
    let mut r = rng(seed);
    let spec = CamSpec::random(&mut r);
    let camera = spec.camera();
    let (w, h) = (r.random_range(1..70), r.random_range(1..70));
    let samples = [1, 2, 4, 8][r.random_range(0..4)];
    let tile_size = [1, 3, 8, 16, 32, 64][r.random_range(0..6)];
    let mode: DepthMode = DEPTH_MODES[r.random_range(0..DEPTH_MODES.len())];
    let depth = common::random_depth_samples(&mut r, mode, &camera, w, h, samples, None, 0.1);
    let targets = common::surface_targets(&mut r, &camera, &depth, (w, h, samples), 16);
    let lights = common::random_lights(&mut r, &spec, &targets, 32);
    let half_z = r.random_bool(0.3);
    let config = CullConfig {
        tile_size,
        samples,
        aabb: r.random_bool(0.5),
        half_z,
        spot_cone: r.random_bool(0.5),
        coarse: r.random_bool(0.5) && COARSE_SIZE.is_multiple_of(tile_size),
        depth_mask: !half_z && r.random_bool(0.5),
        inflate: [0.0, 1e-3, -1e-3][r.random_range(0..3)],
        ..CullConfig::default()
    };
    (camera, depth, pack_lights(&order_points_first(&lights)), w, h, config)
}

proptest! {
    #![proptest_config(cases(256))]

    /// The scatter culler runs the same per-tile test on the same tiles: its lists are
    /// `cull_tiles`'s (it is what `cull_tiles` runs with `scatter`), but for lights
    /// reaching the eye plane, which are missing exactly from the tiles outside their
    /// near-plane rectangle. (Lists could also differ where a tile's plane test goes
    /// against the rectangle's monotone trend by f32 rounding; no case has shown it.)
    #[test]
    fn scatter_is_cull_tiles_less_eye_plane_false_positives(seed in any::<u64>()) {
        let (camera, depth, packed, w, h, config) = scatter_case(seed);
        let a = cull_tiles(&depth, w, h, &camera, &packed, &config).unwrap();
        let b = cull_tiles_scatter(&depth, w, h, &camera, &packed, &config).unwrap();
        let via_config = cull_tiles(&depth, w, h, &camera, &packed, &CullConfig { scatter: true, ..config }).unwrap();
        prop_assert_eq!(&b.lists, &via_config.lists);
        let (view, proj, near) = (camera.view(), camera.proj(), camera.depth_params().near);
        let per = config.lists_per_tile();
        for (l, (gathered, scattered)) in a.lists.iter().zip(&b.lists).enumerate() {
            let t = (l / per) as u32;
            let (tx, ty) = (t % a.grid.tiles_x, t / a.grid.tiles_x);
            let mut rest = gathered.clone();
            for i in scattered {
                let at = rest.iter().position(|x| x == i);
                prop_assert!(at.is_some(), "list {} holds light {} the gather does not; config {:?}", l, i, config);
                rest.remove(at.unwrap());
            }
            for i in rest {
                // The light as the culler sees it (radius grown by `inflate`).
                let cl = packed.cull[i as usize];
                let c = (view * Vec3::from(cl.center).extend(1.0)).truncate();
                let grow = if config.inflate == 0.0 { 0.0 } else { config.inflate * (cl.radius + c.length()) };
                let r = cl.radius + grow;
                prop_assert!(
                    !camera.depth_params().orthographic
                        && c.z + r >= 0.0
                        && !near_cap_rect(&a.grid, &proj, near, c, r).is_some_and(|q| q.contains(tx, ty)),
                    "list {} misses light {} (centre {}, r {}) the gather keeps; config {:?}", l, i, c, r, config
                );
            }
        }
    }
}

/// The scatter cases are not vacuous: lists hold lights.
#[test]
fn scatter_cases_have_lights() {
    let pairs: usize = (0..64)
        .map(|seed| {
            let (camera, depth, packed, w, h, config) = scatter_case(seed);
            cull_tiles_scatter(&depth, w, h, &camera, &packed, &config)
                .unwrap()
                .lists
                .iter()
                .map(Vec::len)
                .sum::<usize>()
        })
        .sum();
    assert!(pairs > 10_000, "only {pairs} (list, light) pairs");
}
