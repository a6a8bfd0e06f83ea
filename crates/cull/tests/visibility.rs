//! The visibility buffer's barycentrics at the extremes (issue 28): the f32 formula the
//! material pass uses (`tiledlight_cull::visibility::barycentrics`) against the f64
//! reference (`barycentrics_f64`, another route: the pixel's ray meets the triangle's
//! plane), over random cameras (near 1e-4..10 m, far to 1e7, FOV 1-170 degrees, any
//! aspect and orientation, orthographic too), targets from 1x1 to 16384x16384 pixels and
//! five kinds of triangle: ordinary, slivers, sub-pixel, huge ones 1e6 m away, and ones
//! crossing the eye plane (a vertex behind the camera, which hardware clips and the
//! homogeneous formula needs no clipping for).
//!
//! Tolerance: not one number but the f32 formula's own rounding bound, evaluated per case
//! (`visibility::rounding_bound`: each adjugate entry a difference of two products, each
//! weight a three-term dot product, then the divisions), so a sliver gets the looser
//! bound its conditioning earns and an ordinary triangle a tight one; the test also
//! checks that a well-shaped ordinary triangle seen at least 17 degrees off edge-on gets a bound
//! below 1e-3, so the comparison keeps its teeth.

mod common;

use common::{log_uniform, proptest_config, rng, unit, view_to_world, CamSpec};
use glam::{DVec2, Vec2, Vec3, Vec4};
use proptest::prelude::*;
use rand::Rng;
use tiledlight_cull::visibility::{barycentrics, barycentrics_f64, pixel_ndc, rounding_bound};

/// Triangle shapes the property draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Ordinary,
    Sliver,
    SubPixel,
    Far,
    CrossesEyePlane,
}

/// The f64 reference's own rounding (it is a different formula, not exact): 1e-9 of the
/// largest value compared (at least of 1), four thousand times below f32's resolution,
/// far above f64's 1e-16 times any conditioning the generated triangles reach.
fn f64_slack(v: glam::DVec3) -> f64 {
    1e-9 * v.abs().max_element().max(1.0)
}

fn shape_triangle(rng: &mut impl Rng, shape: Shape, spec: &CamSpec) -> [Vec3; 3] {
    // View space: the camera looks down -Z. A centre in front of the camera, at a distance
    // between the near plane and far away (1e6 m for Far).
    let near = spec.near.max(1e-3);
    let dist = match shape {
        Shape::Far => log_uniform(rng, 1e5, 1e6).min(spec.far * 0.9).max(near * 2.0),
        _ => log_uniform(rng, near * 2.0, (near * 1e3).min(spec.far * 0.5).max(near * 4.0)),
    };
    let dir = Vec3::new(rng.random_range(-0.3..0.3), rng.random_range(-0.3..0.3), -1.0).normalize();
    let centre = dir * dist;
    let size = match shape {
        Shape::SubPixel => dist * 1e-5,
        Shape::Far => dist * log_uniform(rng, 1e-3, 1.0),
        _ => dist * log_uniform(rng, 1e-2, 2.0),
    };
    let mut v = [centre + unit(rng) * size, centre + unit(rng) * size, centre + unit(rng) * size];
    match shape {
        Shape::Sliver => {
            // The third vertex a hair off the line through the other two.
            let t: f32 = rng.random_range(0.1..0.9);
            let off = unit(rng) * size * log_uniform(rng, 1e-6, 1e-3);
            v[2] = v[0] + (v[1] - v[0]) * t + off;
        }
        Shape::CrossesEyePlane => {
            // One vertex behind the camera (view z > 0).
            v[0] = Vec3::new(v[0].x, v[0].y, dist * log_uniform(rng, 1e-3, 2.0));
        }
        _ => {}
    }
    v
}

fn check_case(seed: u64, shape: Shape) -> Result<(), TestCaseError> {
    let mut rng = rng(seed);
    let spec = CamSpec::random(&mut rng);
    let camera = spec.camera();
    let size = (log_uniform(&mut rng, 1.0, 16384.0) as u32, log_uniform(&mut rng, 1.0, 16384.0) as u32);
    let view_tri = shape_triangle(&mut rng, shape, &spec);
    // A point of the triangle in front of the near plane, inside the screen.
    let w = {
        let a: f32 = rng.random_range(0.01..1.0);
        let b: f32 = rng.random_range(0.01..1.0);
        let c: f32 = rng.random_range(0.01..1.0);
        Vec3::new(a, b, c) / (a + b + c)
    };
    let p_view = view_tri[0] * w.x + view_tri[1] * w.y + view_tri[2] * w.z;
    prop_assume!(-p_view.z > spec.near * 1.01);
    // The pixel whose centre the triangle covers, as the raster pass would have stored
    // its ID there: a random pixel, and the triangle moved (in view space, at the same
    // depth) so that its point `p_view` lies on that pixel centre's ray.
    let pixel = (rng.random_range(0..size.0), rng.random_range(0..size.1));
    let ndc = pixel_ndc(pixel, size);
    let target = camera.view_point_at(ndc.x, ndc.y, -p_view.z);
    let view_tri = view_tri.map(|v| v + (target - p_view));
    let world = view_tri.map(|p| view_to_world(&camera, p));
    let vp = camera.view_proj();
    let clip = world.map(|p| vp * p.extend(1.0));
    let got = barycentrics(clip, ndc, size);
    let want = barycentrics_f64(clip.map(|c| c.as_dvec4()), ndc.as_dvec2(), size);
    let bound = rounding_bound(clip, ndc, size);
    let (Some(got), Some((l, dx, dy))) = (got, want) else {
        // f32 gives up only where its weights' sum is within its rounding of zero (the
        // pixel's ray within rounding of the triangle's plane: seen edge-on, or a sliver
        // that f32 world coordinates collapsed); f64 only on an exactly parallel ray.
        prop_assert!(
            want.is_none() || bound.is_none(),
            "{shape:?} seed {seed}: f32 gave up where its weights' sum is not rounding; f64 {want:?}"
        );
        return Ok(());
    };
    let Some(bound) = bound else {
        // The weights' sum is within f32 rounding of zero: the pixel's ray lies in the
        // triangle's plane as far as f32 can tell (a sliver, or a triangle seen edge-on);
        // f32 decides nothing there, so nothing is compared.
        return Ok(());
    };
    prop_assert!(
        (got.lambda.as_dvec3() - l).abs().cmple(bound.lambda.as_dvec3() * 1.0001 + f64_slack(l)).all(),
        "{shape:?} seed {seed}: lambda {} vs f64 {l}, bound {} ({spec:?}, size {size:?}, pixel {pixel:?})",
        got.lambda,
        bound.lambda
    );
    let sum_w = |v: Vec3| v.x + v.y + v.z;
    for (axis, (d_got, d_want, tol_d)) in [(got.ddx, dx, bound.ddx), (got.ddy, dy, bound.ddy)].into_iter().enumerate() {
        if !tol_d.is_finite() {
            // The neighbour's ray is within rounding of parallel to the triangle's plane,
            // or past it (a sub-pixel triangle under a wide lens, a triangle crossing the
            // eye plane seen near its horizon): its weights, and any hardware derivative
            // there, are unbounded. The twin keeps them finite and large (the sampler's
            // coarsest level decides), summing to zero; that is all there is to check.
            prop_assert!(d_got.is_finite() && sum_w(d_got).abs() <= 1e-3 * d_got.abs().max_element().max(1.0));
            continue;
        }
        prop_assert!(
            (d_got.as_dvec3() - d_want).abs().cmple(tol_d.as_dvec3() * 1.0001 + f64_slack(d_want)).all(),
            "{shape:?} seed {seed}: d{} {d_got} vs f64 {d_want}, bound {tol_d} ({spec:?}, size {size:?})",
            if axis == 0 { "x" } else { "y" }
        );
    }
    // The comparison's teeth: an ordinary triangle seen at least 17 degrees off edge-on,
    // at least 2.5% of the screen across (its edges then do not vanish against its corner's
    // NDC position) and well shaped on screen (above 0.2), the pixel inside it, gets a bound below
    // 1e-3 (0.1% of a texel step).
    let n = (view_tri[1] - view_tri[0]).cross(view_tri[2] - view_tri[0]).normalize();
    let facing = n.dot(target.normalize()).abs();
    // On screen: a triangle seen face-on can still be a sliver in NDC (an anamorphic
    // projection squashes one axis), so its NDC shape counts: twice its area over its
    // longest edge squared (1 for an equilateral-ish, 0 for a sliver).
    let ndc_of = |c: Vec4| Vec2::new(c.x, c.y) / c.w;
    let (e1, e2) = (ndc_of(clip[1]) - ndc_of(clip[0]), ndc_of(clip[2]) - ndc_of(clip[0]));
    let longest = e1.length().max(e2.length()).max((e2 - e1).length());
    let extent = e1.length().min(e2.length());
    let ndc_shape = e1.perp_dot(e2).abs() / (longest * longest);
    if shape == Shape::Ordinary && facing > 0.3 && extent > 0.05 && ndc_shape > 0.2 && l.min_element() > 0.0 {
        prop_assert!(
            bound.lambda.max_element() < 1e-3,
            "{shape:?} seed {seed}: bound {} too loose to test anything (facing {facing}, extent {extent}, shape {ndc_shape})",
            bound.lambda
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(proptest_config(256))]

    #[test]
    fn barycentrics_match_the_f64_reference_at_the_extremes(seed in any::<u64>(), shape in 0usize..5) {
        let shape = [Shape::Ordinary, Shape::Sliver, Shape::SubPixel, Shape::Far, Shape::CrossesEyePlane][shape];
        check_case(seed, shape)?;
    }
}

#[test]
fn a_triangle_behind_the_eye_plane_keeps_its_visible_part() {
    // A floor quad's triangle from under the camera to far ahead: two vertices 3 m behind
    // the eye. The pixel straight ahead and down sees the floor at a known point.
    let camera = tiledlight_cull::Camera::perspective(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        90f32.to_radians(),
        1.0,
        0.1,
        None,
    )
    .unwrap();
    let tri = [Vec3::new(-10.0, 0.0, 3.0), Vec3::new(10.0, 0.0, 3.0), Vec3::new(0.0, 0.0, -30.0)];
    let clip = tri.map(|p| camera.view_proj() * p.extend(1.0));
    assert!(clip[0].w < 0.0 || clip[1].w < 0.0, "a vertex is behind the eye: {clip:?}");
    let size = (64, 64);
    let ndc = pixel_ndc((32, 50), size);
    let b = barycentrics(clip, ndc, size).expect("the visible part has barycentrics");
    let p = tri[0] * b.lambda.x + tri[1] * b.lambda.y + tri[2] * b.lambda.z;
    // The point is on the floor and on the pixel's ray.
    let pc = camera.view_proj() * p.extend(1.0);
    assert!(p.y.abs() < 1e-5 && p.z < 0.0, "{p}");
    assert!((Vec2::new(pc.x, pc.y) / pc.w - ndc).length() < 1e-5, "{pc} vs {ndc}");
    let (l, _, _) = barycentrics_f64(clip.map(|c| c.as_dvec4()), DVec2::new(ndc.x as f64, ndc.y as f64), size).unwrap();
    assert!((b.lambda.as_dvec3() - l).abs().max_element() < 1e-6);
}

#[test]
fn the_comparison_rejects_a_wrong_triangle() {
    // Negative test of the comparison above: the barycentrics of the neighbouring
    // triangle of a quad (another ID) at the same pixel are outside the bound.
    let mut rng = rng(7);
    let spec = CamSpec::random(&mut rng);
    let camera = spec.camera();
    let d = spec.near.max(1e-3) * 10.0;
    let quad = [Vec3::new(-d, -d, -d), Vec3::new(d, -d, -d), Vec3::new(d, d, -d), Vec3::new(-d, d, -d)];
    let world = quad.map(|p| view_to_world(&camera, p));
    let clip = world.map(|p| camera.view_proj() * p.extend(1.0));
    let size = (320, 180);
    let ndc = Vec2::new(0.0, 0.0);
    let right = barycentrics(clip_of(&clip, [0, 1, 2]), ndc, size).unwrap();
    let wrong = barycentrics_f64(clip_of(&clip, [0, 2, 3]).map(|c| c.as_dvec4()), ndc.as_dvec2(), size).unwrap();
    let tol = rounding_bound(clip_of(&clip, [0, 1, 2]), ndc, size).unwrap().lambda.max_element() as f64;
    assert!((right.lambda.as_dvec3() - wrong.0).abs().max_element() > 1e3 * tol, "{tol}");
}

fn clip_of(c: &[Vec4; 4], i: [usize; 3]) -> [Vec4; 3] {
    i.map(|k| c[k])
}
