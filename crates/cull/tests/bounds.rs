//! Bounding tests: `sphere_vs_aabb` at huge coordinates (1e20, 1e30), where squaring
//! overflows, still gives the right answer both ways; `cone_vs_sphere` never rejects a
//! sphere that has a point inside the cone (brute-force sampling), does reject spheres
//! clearly outside, and works for 0.5 degree cones far from the apex; `sphere_vs_frustum`
//! against its definition; the fitted spot sphere holds its cone.

mod common;

use common::{log_uniform, rng, unit};
use glam::{Vec3, Vec4};
use rand::Rng;
use tiledlight_cull::bounds::{aabb_sphere, cone_vs_sphere, sphere_vs_aabb, sphere_vs_frustum};
use tiledlight_cull::light::{spot_bounding_sphere, MIN_SPOT_ANGLE};
use tiledlight_cull::tiles::TileFrustum;

#[test]
fn sphere_vs_aabb_at_huge_coordinates() {
    for s in [1.0f32, 1e20, 1e30] {
        let (lo, hi) = (Vec3::splat(-s), Vec3::splat(s));
        // A sphere containing the box: its corners are sqrt(3) s from the centre.
        assert!(sphere_vs_aabb(lo, hi, Vec3::ZERO, 2.0 * s), "scale {s}: containing sphere");
        assert!(
            sphere_vs_aabb(lo + s * 3.0, hi + s * 3.0, Vec3::splat(4.0 * s), 2.0 * s),
            "scale {s}: containing, off-origin"
        );
        // Inside the box, tiny.
        assert!(sphere_vs_aabb(lo, hi, Vec3::splat(0.5 * s), 1e-3), "scale {s}: tiny sphere inside");
        // Beyond a face.
        assert!(!sphere_vs_aabb(lo, hi, Vec3::new(3.0 * s, 0.0, 0.0), s), "scale {s}: beyond a face");
        assert!(sphere_vs_aabb(lo, hi, Vec3::new(1.9 * s, 0.0, 0.0), s), "scale {s}: across a face");
        // Near a corner, where the answer needs all three axes: the corner is
        // sqrt(3) * 0.6 s = 1.039 s away. Squaring 0.6e30 overflows to inf, and so does
        // r^2, so a naive `d2 <= r2` would accept both of these.
        let c = Vec3::splat(1.6 * s);
        assert!(sphere_vs_aabb(lo, hi, c, 1.05 * s), "scale {s}: corner within reach");
        assert!(!sphere_vs_aabb(lo, hi, c, 1.03 * s), "scale {s}: corner out of reach");
    }
}

#[test]
fn sphere_vs_frustum_matches_its_definition() {
    // A hand-made volume: the half-space x >= 0 and the slab y <= 2, z within a depth range.
    let f = TileFrustum {
        planes: [
            Vec4::new(1.0, 0.0, 0.0, 0.0),
            Vec4::new(0.0, -1.0, 0.0, 2.0),
            Vec4::new(0.0, 0.0, 0.0, 1.0),
            Vec4::new(0.0, 0.0, 0.0, 1.0),
        ],
        ndc: (0.0, 0.0, 0.0, 0.0),
        near: 10.0,
        far: 20.0,
    };
    assert!(sphere_vs_frustum(&f, Vec3::new(-0.5, 0.0, -15.0), 0.5), "touching the x = 0 plane counts");
    assert!(!sphere_vs_frustum(&f, Vec3::new(-0.6, 0.0, -15.0), 0.5));
    assert!(!sphere_vs_frustum(&f, Vec3::new(1.0, 3.0, -15.0), 0.5), "above y = 2");
    assert!(sphere_vs_frustum(&f, Vec3::new(1.0, 0.0, -9.5), 0.5), "reaching the near distance");
    assert!(!sphere_vs_frustum(&f, Vec3::new(1.0, 0.0, -9.4), 0.5));
    assert!(sphere_vs_frustum(&f, Vec3::new(1.0, 0.0, -20.5), 0.5), "reaching the far distance");
    assert!(!sphere_vs_frustum(&f, Vec3::new(1.0, 0.0, -20.6), 0.5));
    assert!(sphere_vs_frustum(&f, Vec3::new(1.0, 0.0, 0.0), 1e30), "a huge sphere");
}

/// True when `p` is in the light volume of a spot: within `len` of the apex and within
/// the half-angle of the axis.
fn in_cone(apex: Vec3, axis: Vec3, len: f32, cos_a: f32, p: Vec3) -> bool {
    let v = p - apex;
    let d = v.length();
    d < len && d > 0.0 && v.dot(axis) > cos_a * d
}

#[test]
fn cone_vs_sphere_never_rejects_a_sphere_with_a_point_in_the_cone() {
    let mut r = rng(17);
    let (mut hits, mut culled) = (0, 0);
    for i in 0..20_000 {
        let len = log_uniform(&mut r, 1e-2, 1e3);
        // The apex within `len` of the origin: positions are rounded at eps * |apex|,
        // which must stay far below the smallest sphere (1e-3 len) and the 1% of radius
        // by which samples stay inside it, or the brute force below would judge noise.
        let apex = unit(&mut r) * len * r.random::<f32>();
        let axis = unit(&mut r);
        // Half-angles from the 0.5 degree minimum to the 89.5 degree maximum.
        let angle = if i % 4 == 0 { MIN_SPOT_ANGLE } else { r.random_range(MIN_SPOT_ANGLE..89.5f32.to_radians()) };
        let (sin_a, cos_a) = angle.sin_cos();
        // Sphere centres around the cone's surface, where the decision is close.
        let t = r.random_range(-0.2..1.2) * len;
        let edge =
            apex + axis * t + common::tilt(&mut r, axis, std::f32::consts::FRAC_PI_2) * t.abs() * angle.tan().min(1e3);
        let radius = log_uniform(&mut r, 1e-3, 1.0) * len;
        let centre = edge + unit(&mut r) * radius * r.random_range(0.0..2.0);
        let kept = cone_vs_sphere(apex, axis, len, cos_a, sin_a, centre, radius);
        culled += usize::from(!kept);
        // Points of the ball, uniformly, plus the point nearest the axis.
        let to_axis = {
            let v = centre - apex;
            let foot = apex + axis * v.dot(axis).clamp(0.0, len * 0.999);
            (foot - centre).clamp_length_max(radius * 0.99)
        };
        let samples = (0..64)
            .map(|_| centre + unit(&mut r) * radius * r.random::<f32>().cbrt() * 0.99)
            .chain([centre + to_axis, centre]);
        if let Some(p) = samples.into_iter().find(|&p| in_cone(apex, axis, len, cos_a, p)) {
            hits += 1;
            assert!(kept, "sphere {centre} r {radius} has {p} inside the cone (apex {apex}, axis {axis}, len {len}, angle {} deg) but was rejected", angle.to_degrees());
        }
    }
    // Both outcomes must be common, or this test would not test anything.
    assert!(hits > 2000 && culled > 2000, "hits {hits}, culled {culled}");
}

#[test]
fn narrow_cone_far_from_the_apex() {
    let (s, c) = MIN_SPOT_ANGLE.sin_cos();
    let (apex, axis, len) = (Vec3::new(5.0, -3.0, 2.0), Vec3::X, 2e4);
    // At 1e4 m the 0.5 degree cone is 87.3 m wide (radius).
    let at = |y: f32| apex + Vec3::new(1e4, y, 0.0);
    assert!(cone_vs_sphere(apex, axis, len, c, s, at(0.0), 0.01), "on the axis");
    assert!(cone_vs_sphere(apex, axis, len, c, s, at(87.0), 0.01), "just inside the rim");
    assert!(cone_vs_sphere(apex, axis, len, c, s, at(88.0), 1.0), "outside, but the sphere reaches in");
    assert!(!cone_vs_sphere(apex, axis, len, c, s, at(90.0), 1.0), "outside");
    assert!(!cone_vs_sphere(apex, axis, len, c, s, at(-100.0), 1.0), "outside, other side");
    // Beyond the cone's length, and behind the apex.
    assert!(!cone_vs_sphere(apex, axis, len, c, s, apex + Vec3::X * (len + 2.0), 1.0));
    assert!(cone_vs_sphere(apex, axis, len, c, s, apex + Vec3::X * (len + 0.5), 1.0));
    assert!(!cone_vs_sphere(apex, axis, len, c, s, apex - Vec3::X * 2.0, 1.0));
    assert!(cone_vs_sphere(apex, axis, len, c, s, apex - Vec3::X * 0.5, 1.0), "the apex is inside the sphere");
}

#[test]
fn cone_vs_sphere_at_huge_coordinates() {
    // A 30 degree spot reaching 1e21 m and a small sphere 3e19 m off its axis at 5e20 m
    // along it (3.4 degrees off the axis: well inside). Squaring the 3e19 m offset
    // overflows f32 (max 3.4e38); that must not turn into a rejection.
    let (s, c) = 30f32.to_radians().sin_cos();
    assert!(cone_vs_sphere(Vec3::ZERO, Vec3::X, 1e21, c, s, Vec3::new(5e20, 3e19, 0.0), 1.0));
    assert!(
        !cone_vs_sphere(Vec3::ZERO, Vec3::X, 1e21, c, s, Vec3::new(5e20, 4e20, 0.0), 1.0),
        "39 degrees off: outside"
    );
}

#[test]
fn aabb_sphere_holds_the_box() {
    let mut r = rng(4);
    for i in 0..10_000 {
        // Boxes up to 1e7 from the origin and down to 1e-3 across: far from the origin the
        // rounded centre can be off the middle by more than the box's half-size.
        let a = unit(&mut r) * log_uniform(&mut r, 1e-3, 1e7);
        let b = a + unit(&mut r).abs() * log_uniform(&mut r, 1e-3, 1e3);
        let (c, rad) = aabb_sphere(a, b);
        for corner in 0..8 {
            let p = Vec3::new(
                if corner & 1 == 0 { a.x } else { b.x },
                if corner & 2 == 0 { a.y } else { b.y },
                if corner & 4 == 0 { a.z } else { b.z },
            );
            // Only the final length may round (a relative ulp or two): the sphere must
            // hold the corners of the box it was given, not of a box near it.
            assert!(
                (p - c).length() <= rad * (1.0 + 2.0 * common::EPS),
                "box {i}: corner {p} outside sphere {c} r {rad}"
            );
        }
    }
    // The hunt's case: a 3 m deep, 2.6 cm wide tile volume 9.77e6 m away (orthographic),
    // whose midpoint rounds 0.5 m off (ulp 1 m there) while its half-diagonal is 1.5 m.
    let (lo, hi) = (Vec3::new(0.0, 0.0, -9770554.0), Vec3::new(0.026, 0.026, -9770551.0));
    let (c, rad) = aabb_sphere(lo, hi);
    assert!((lo - c).length() <= rad && (hi - c).length() <= rad, "{c} r {rad}");
}

#[test]
fn fitted_spot_sphere_holds_sampled_cone_points() {
    let mut r = rng(8);
    for i in 0..2000 {
        let apex = unit(&mut r) * r.random_range(0.0..100.0);
        let dir = unit(&mut r);
        let len = log_uniform(&mut r, 1e-3, 1e4);
        let angle =
            if i % 3 == 0 { std::f32::consts::FRAC_PI_4 } else { r.random_range(MIN_SPOT_ANGLE..89.5f32.to_radians()) };
        let (c, rad) = spot_bounding_sphere(apex, dir, len, angle);
        assert!(rad <= len * (1.0 + 1e-6), "never looser than the light's own sphere: {rad} > {len}");
        for _ in 0..32 {
            let off_axis = angle * r.random::<f32>().sqrt();
            let p = apex + common::tilt(&mut r, dir, off_axis) * len * r.random::<f32>().cbrt();
            // The sphere touches the cone at the apex and the rim: the only slack is
            // rounding, a few ulps of |apex| + len.
            let tol = 4.0 * common::EPS * (apex.length() + len);
            assert!((p - c).length() <= rad + tol, "{angle} rad: {p} outside {c} r {rad}");
        }
    }
}
