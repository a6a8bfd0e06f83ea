//! Cameras: construction rejects NaN/inf and degenerate parameters with
//! `CullError::InvalidCamera` naming the parameter; reversed-Z depth <-> view distance
//! (`DepthParams`) round trips for finite, infinite and orthographic projections over
//! near 1e-4..10 and far 1e2..1e7; `proj()` followed by the perspective divide gives the
//! same depth (near plane 1, far plane 0); sky (depth 0, infinite far) is infinitely far,
//! never NaN; `view_point_at` inverts the projection.

mod common;

use common::{log_uniform, rng, CamKind, CamSpec, EPS};
use glam::{Mat4, Vec3, Vec4};
use rand::Rng;
use tiledlight_cull::{Camera, CullError, Projection};

const NEARS: [f32; 5] = [1e-4, 1e-3, 0.1, 1.0, 10.0];
const FARS: [f32; 4] = [1e2, 1e4, 1e5, 1e7];

fn persp(fov_deg: f32, aspect: f32, near: f32, far: Option<f32>) -> Result<Camera, CullError> {
    Camera::perspective(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, fov_deg.to_radians(), aspect, near, far)
}

fn ortho(half_height: f32, aspect: f32, near: f32, far: f32) -> Result<Camera, CullError> {
    Camera::orthographic(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, half_height, aspect, near, far)
}

/// Asserts `r` is `InvalidCamera` and its message mentions `word`.
#[track_caller]
fn rejected(r: Result<Camera, CullError>, word: &str) {
    match r {
        Err(CullError::InvalidCamera(msg)) => assert!(msg.contains(word), "message {msg:?} does not mention {word:?}"),
        other => panic!("expected InvalidCamera mentioning {word:?}, got {other:?}"),
    }
}

#[test]
fn rejects_non_finite_parameters() {
    let (e, t, u) = (Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    let fov = 60f32.to_radians();
    rejected(Camera::perspective(Vec3::NAN, t, u, fov, 1.0, 0.1, None), "eye");
    rejected(Camera::perspective(Vec3::new(f32::INFINITY, 0.0, 0.0), t, u, fov, 1.0, 0.1, None), "eye");
    rejected(Camera::perspective(e, Vec3::new(0.0, f32::NAN, -1.0), u, fov, 1.0, 0.1, None), "target");
    rejected(Camera::perspective(e, t, Vec3::new(0.0, f32::NEG_INFINITY, 0.0), fov, 1.0, 0.1, None), "up");
    rejected(Camera::perspective(e, t, u, f32::NAN, 1.0, 0.1, None), "field of view");
    rejected(Camera::perspective(e, t, u, f32::INFINITY, 1.0, 0.1, None), "field of view");
    rejected(Camera::perspective(e, t, u, fov, f32::NAN, 0.1, None), "aspect");
    rejected(Camera::perspective(e, t, u, fov, f32::INFINITY, 0.1, None), "aspect");
    rejected(Camera::perspective(e, t, u, fov, 1.0, f32::NAN, None), "near");
    rejected(Camera::perspective(e, t, u, fov, 1.0, f32::INFINITY, None), "near");
    rejected(Camera::perspective(e, t, u, fov, 1.0, 0.1, Some(f32::NAN)), "far");
    // An infinite far plane is spelled `None`; `Some(inf)` would put inf into the matrix.
    rejected(Camera::perspective(e, t, u, fov, 1.0, 0.1, Some(f32::INFINITY)), "far");
    rejected(ortho(f32::NAN, 1.0, 0.0, 10.0), "half-height");
    rejected(ortho(1.0, f32::INFINITY, 0.0, 10.0), "aspect");
    rejected(ortho(1.0, 1.0, f32::NAN, 10.0), "near");
    rejected(ortho(1.0, 1.0, 0.0, f32::INFINITY), "far");
    rejected(
        Camera::from_view(
            Mat4::from_cols(Vec4::X, Vec4::Y, Vec4::Z, Vec4::new(f32::NAN, 0.0, 0.0, 1.0)),
            Projection::Perspective { fov_y: fov, aspect: 1.0, near: 0.1, far: None },
        ),
        "not finite",
    );
}

#[test]
fn rejects_degenerate_parameters() {
    rejected(persp(0.0, 1.0, 0.1, None), "field of view");
    rejected(persp(-10.0, 1.0, 0.1, None), "field of view");
    rejected(persp(180.0, 1.0, 0.1, None), "field of view");
    rejected(persp(270.0, 1.0, 0.1, None), "field of view");
    rejected(persp(60.0, 0.0, 0.1, None), "aspect");
    rejected(persp(60.0, -1.0, 0.1, None), "aspect");
    rejected(persp(60.0, 1.0, 0.0, None), "near");
    rejected(persp(60.0, 1.0, -0.1, None), "near");
    rejected(persp(60.0, 1.0, 0.1, Some(0.1)), "far");
    rejected(persp(60.0, 1.0, 10.0, Some(1.0)), "far");
    rejected(ortho(0.0, 1.0, 0.0, 10.0), "half-height");
    rejected(ortho(1.0, 0.0, 0.0, 10.0), "aspect");
    rejected(ortho(1.0, 1.0, -1e-3, 10.0), "near");
    rejected(ortho(1.0, 1.0, 5.0, 5.0), "far");
    rejected(ortho(1.0, 1.0, 5.0, 1.0), "far");
    let fov = 60f32.to_radians();
    let eye = Vec3::new(3.0, 4.0, 5.0);
    rejected(Camera::perspective(eye, eye, Vec3::Y, fov, 1.0, 0.1, None), "coincides");
    rejected(Camera::orthographic(eye, eye, Vec3::Y, 1.0, 1.0, 0.0, 10.0), "coincides");
    // Up along, against, and (almost) along the view direction, and zero.
    rejected(Camera::perspective(eye, eye + Vec3::Y, Vec3::Y, fov, 1.0, 0.1, None), "parallel");
    rejected(Camera::perspective(eye, eye - Vec3::Y * 2.0, Vec3::Y * 3.0, fov, 1.0, 0.1, None), "parallel");
    rejected(Camera::perspective(eye, eye + Vec3::new(1e-6, 1.0, 0.0), Vec3::Y, fov, 1.0, 0.1, None), "parallel");
    rejected(Camera::perspective(eye, eye + Vec3::X, Vec3::ZERO, fov, 1.0, 0.1, None), "up");
    rejected(
        Camera::from_view(Mat4::ZERO, Projection::Perspective { fov_y: fov, aspect: 1.0, near: 0.1, far: None }),
        "singular",
    );
}

#[test]
fn accepts_the_extremes_of_the_valid_ranges() {
    for fov in [1e-3, 1.0, 90.0, 170.0, 179.9] {
        for aspect in [1e-3, 0.1, 10.0, 1e3] {
            persp(fov, aspect, 1e-4, Some(1e7)).unwrap();
            persp(fov, aspect, 10.0, None).unwrap();
        }
    }
    ortho(1e-3, 0.1, 0.0, 1e-3).unwrap();
    // A resized window keeps the rest of the camera and is validated too.
    let c = persp(60.0, 1.0, 0.1, Some(100.0)).unwrap();
    let wide = c.with_aspect(2.0).unwrap();
    assert_eq!(wide.view(), c.view());
    assert!(matches!(wide.projection(), Projection::Perspective { aspect, .. } if aspect == 2.0));
    assert!(matches!(c.with_aspect(0.0), Err(CullError::InvalidCamera(_))));
}

#[test]
fn eye_and_view_matrix_agree() {
    let mut r = rng(3);
    for _ in 0..200 {
        let spec = CamSpec::random(&mut r);
        let cam = spec.camera();
        // The eye is recovered from an inverted view matrix: a few ulps of |eye| (1e-5
        // relative, ~80 eps, covers the inverse's error on a rigid transform).
        assert!((cam.eye() - spec.eye).length() <= 1e-5 * spec.eye.length().max(1e-3), "{spec:?}: eye {}", cam.eye());
        let (fwd, _) = spec.basis();
        // One metre ahead of the eye lies on the view axis at z = -1.
        let p = cam.view().transform_point3(spec.eye + fwd);
        assert!((p - Vec3::NEG_Z).length() <= 1e-5 * (1.0 + spec.eye.length()), "{spec:?}: {p}");
    }
}

/// Distances from `near` to `far` (and beyond for infinite), log-spaced.
fn distances(near: f32, far: f32) -> impl Iterator<Item = f32> {
    let n = 200;
    (0..=n).map(move |i| (near.ln() + (far.ln() - near.ln()) * i as f32 / n as f32).exp().clamp(near, far))
}

#[test]
fn depth_distance_round_trip_perspective() {
    for near in NEARS {
        for far in FARS.map(Some).into_iter().chain([None]) {
            let dp = persp(60.0, 1.0, near, far).unwrap().depth_params();
            let top = far.unwrap_or(1e30);
            for dist in distances(near, top) {
                let d = dp.depth(dist);
                assert!((0.0..=1.0).contains(&d), "near {near} far {far:?}: depth({dist}) = {d}");
                let back = dp.view_distance(d);
                // depth() and view_distance() take 3 roundings each; the subtraction of
                // k = near/far cancels near the far plane but its absolute error stays
                // within an ulp of near/dist, which is the size of the denominator it
                // feeds: six half-ulp roundings, 3 eps; 4 eps bounds it (1.55 seen).
                assert!((back - dist).abs() <= 4.0 * EPS * dist, "near {near} far {far:?}: {dist} -> {d} -> {back}");
            }
            // The planes themselves: depth 1 exactly at near (x / x), 0 at far.
            assert_eq!(dp.depth(near), 1.0, "near {near} far {far:?}");
            if let Some(far) = far {
                assert!(
                    dp.depth(far).abs() <= 2.0 * EPS * (near / far),
                    "near {near} far {far}: depth(far) {}",
                    dp.depth(far)
                );
            }
        }
    }
}

#[test]
fn depth_distance_round_trip_orthographic() {
    for near in [0.0].into_iter().chain(NEARS) {
        for far in FARS {
            let dp = ortho(1.0, 1.0, near, far).unwrap().depth_params();
            for dist in distances(near.max(1e-4), far) {
                let back = dp.view_distance(dp.depth(dist));
                // Orthographic depth is linear in distance: its resolution is uniform,
                // an ulp of 1 times (far - near), whatever the distance. Three roundings
                // each way at magnitude `far`: 4 eps * far bounds the absolute error.
                assert!((back - dist).abs() <= 4.0 * EPS * far, "near {near} far {far}: {dist} -> {back}");
            }
            assert_eq!(dp.depth(near), 1.0, "(far - near) / (far - near)");
            assert_eq!(dp.depth(far), 0.0, "0 / (far - near)");
            assert_eq!(dp.view_distance(0.0), far);
            // far - (far - near): near comes back to within the rounding of far - near.
            assert!((dp.view_distance(1.0) - near).abs() <= EPS * far, "near {near} far {far}");
        }
    }
}

#[test]
fn sky_is_infinitely_far_never_nan() {
    for near in NEARS {
        let dp = persp(60.0, 1.0, near, None).unwrap().depth_params();
        assert_eq!(dp.view_distance(0.0), f32::INFINITY);
        assert_eq!(dp.view_distance(-0.0), f32::INFINITY);
        // Subnormal depths: huge or infinite, never NaN, never negative.
        for d in [f32::from_bits(1), f32::MIN_POSITIVE, 1e-30] {
            let v = dp.view_distance(d);
            assert!(v > 0.0 && !v.is_nan(), "near {near}: depth {d:e} -> {v}");
        }
        let cam = persp(60.0, 1.0, near, None).unwrap();
        assert_eq!(cam.unproject_view(0.3, -0.2, 0.0), None, "sky has no position");
        // Finite far: depth 0 is the far plane, within the rounding of k = near/far.
        let dp = persp(60.0, 1.0, near, Some(1e4)).unwrap().depth_params();
        assert!((dp.view_distance(0.0) - 1e4).abs() <= 2.0 * EPS * 1e4, "near {near}: {}", dp.view_distance(0.0));
    }
}

/// `proj * (0, 0, -dist, 1)` divided by w: the depth the rasteriser writes.
fn projected_depth(cam: &Camera, dist: f32) -> f32 {
    let c = cam.proj() * Vec4::new(0.0, 0.0, -dist, 1.0);
    c.z / c.w
}

#[test]
fn projection_matrix_writes_the_same_reversed_z_depth() {
    for near in NEARS {
        for far in FARS.map(Some).into_iter().chain([None]) {
            let cam = persp(75.0, 1.5, near, far).unwrap();
            let dp = cam.depth_params();
            assert!((projected_depth(&cam, near) - 1.0).abs() <= 4.0 * EPS, "near plane -> 1");
            if let Some(far) = far {
                // glam forms r*far - r*dist with r = near/(far-near): at the far plane the
                // terms are equal and cancel exactly; 8 eps * near/far as below.
                assert!(
                    projected_depth(&cam, far).abs() <= 8.0 * EPS * near / far,
                    "far plane -> 0: {}",
                    projected_depth(&cam, far)
                );
            }
            for dist in distances(near, far.unwrap_or(1e30)) {
                // Both sides compute near/dist-sized terms, cancelling near the far plane:
                // the error is a few ulps of near/dist, not of the (smaller) depth.
                let tol = 8.0 * EPS * (near / dist);
                let (a, b) = (projected_depth(&cam, dist), dp.depth(dist));
                assert!((a - b).abs() <= tol, "near {near} far {far:?} dist {dist}: proj {a} vs depth {b}");
            }
        }
    }
    for near in [0.0, 1e-4, 1.0, 10.0] {
        for far in FARS {
            let cam = ortho(5.0, 0.5, near, far).unwrap();
            let dp = cam.depth_params();
            for dist in distances(near.max(1e-4), far) {
                // Linear depth: absolute error a few ulps of 1.
                let (a, b) = (projected_depth(&cam, dist), dp.depth(dist));
                assert!((a - b).abs() <= 4.0 * EPS, "ortho near {near} far {far} dist {dist}: {a} vs {b}");
            }
        }
    }
}

#[test]
fn view_point_at_inverts_the_projection() {
    let mut r = rng(5);
    let mut checked = 0;
    for _ in 0..2000 {
        let spec = CamSpec::random(&mut r);
        let cam = spec.camera();
        let dp = cam.depth_params();
        let far = if spec.kind == CamKind::Infinite { 1e7 } else { spec.far };
        let dist = log_uniform(&mut r, dp.near.max(1e-4), far);
        // A random view point inside the view volume: NDC in [-1, 1]^2.
        let (nx, ny): (f32, f32) = (r.random_range(-1.0..=1.0), r.random_range(-1.0..=1.0));
        let p = cam.view_point_at(nx, ny, dist);
        let c = cam.proj() * Vec4::from((p, 1.0));
        let (ndc_x, ndc_y, depth) = (c.x / c.w, c.y / c.w, c.z / c.w);
        let q = cam.view_point_at(ndc_x, ndc_y, dist);
        // Projecting and unprojecting a coordinate is about 5 roundings, each half an
        // ulp of at most |p|: 4 eps * |p| bounds it (0.99 eps seen over 20000 points).
        assert!((q - p).length() <= 4.0 * EPS * p.length(), "{spec:?}: {p} -> ({ndc_x}, {ndc_y}) -> {q}");
        // And back through the depth the matrix wrote (where it is not sky).
        if depth > 0.0 {
            let u = cam.unproject_view(ndc_x, ndc_y, depth).unwrap();
            let tol = if spec.kind == CamKind::Ortho {
                // Orthographic: x, y do not depend on depth; the distance comes back
                // within the uniform depth resolution, 4 eps * far (see the round trip;
                // 1.3 eps * far seen).
                4.0 * EPS * p.length() + 4.0 * EPS * far
            } else {
                // Perspective: the depth's absolute error is a few ulps of near/dist (the
                // matrix's terms before they cancel) and near/dist is also the size of the
                // denominator it enters, so the distance keeps ~8 eps relative error, and
                // x, y scale with it: 8 eps * |p| for the round trip (2.6 eps seen).
                8.0 * EPS * p.length()
            };
            assert!((u - p).length() <= tol, "{spec:?}: {p} -> depth {depth} -> {u}");
            checked += 1;
        }
    }
    assert!(checked > 1500, "only {checked} points went through depth");
}
