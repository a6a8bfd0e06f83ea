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
//! (`bound` below: each adjugate entry is a difference of two products, each weight a
//! three-term dot product, then one division), so a sliver gets the looser bound its
//! conditioning earns and an ordinary triangle a tight one; the test also checks that
//! ordinary triangles' bound stays below 1e-4, so the comparison keeps its teeth.

mod common;

use common::{log_uniform, proptest_config, rng, unit, view_to_world, CamSpec};
use glam::{DVec2, Vec2, Vec3, Vec4};
use proptest::prelude::*;
use rand::Rng;
use tiledlight_cull::visibility::{barycentrics, barycentrics_f64, pixel_ndc};

/// Triangle shapes the property draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Ordinary,
    Sliver,
    SubPixel,
    Far,
    CrossesEyePlane,
}

/// f32's unit roundoff, times the few operations each quantity passes through.
const GAMMA: f32 = 8.0 * f32::EPSILON;

/// The f64 reference's own rounding (it is a different formula, not exact): 1e-9 of the
/// largest value compared (at least of 1), four thousand times below f32's resolution,
/// far above f64's 1e-16 times any conditioning the generated triangles reach.
fn f64_slack(v: glam::DVec3) -> f64 {
    1e-9 * v.abs().max_element().max(1.0)
}

/// The f32 weights of `barycentrics` at `q` (`(x, y, 1)` for a point, `(dx, dy, 0)` for a
/// step) as it computes them (rows from the edges at vertex 0), with each weight's and
/// the sum's rounding bound: every row entry is a difference of two products of inputs
/// or of edges (an edge carries one rounding of its own size), every weight a three-term
/// dot product, weight 0 the sum minus the other two.
struct Weights {
    u: Vec3,
    sum: f32,
    err_u: Vec3,
    err_sum: f32,
}

fn weights(clip: [Vec4; 3], q: Vec3) -> Weights {
    let [c0, c1, c2] = clip.map(|c| Vec3::new(c.x, c.y, c.w));
    let (e1, e2) = (c1 - c0, c2 - c0);
    let (n, a, b) = (e1.cross(e2), e2.cross(c0), c0.cross(e1));
    let cross_abs = |a: Vec3, b: Vec3| Vec3::new(a.y * b.z + a.z * b.y, a.z * b.x + a.x * b.z, a.x * b.y + a.y * b.x);
    let qa = q.abs();
    let (u1, u2, sum) = (a.dot(q), b.dot(q), n.dot(q));
    let err_sum = GAMMA * cross_abs(e1.abs(), e2.abs()).dot(qa);
    let err_1 = GAMMA * cross_abs(e2.abs(), c0.abs()).dot(qa);
    let err_2 = GAMMA * cross_abs(c0.abs(), e1.abs()).dot(qa);
    let u0 = sum - u1 - u2;
    let err_0 = err_sum + err_1 + err_2 + GAMMA * (sum.abs() + u1.abs() + u2.abs());
    Weights { u: Vec3::new(u0, u1, u2), sum, err_u: Vec3::new(err_0, err_1, err_2), err_sum }
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
    let (Some(got), Some((l, dx, dy))) = (got, want) else {
        // f32 gives up only where its weights' sum is within its rounding of zero (the
        // pixel's ray within rounding of the triangle's plane: seen edge-on, or a sliver
        // that f32 world coordinates collapsed); f64 only on an exactly parallel ray.
        let w = weights(clip, ndc.extend(1.0));
        prop_assert!(
            want.is_none() || w.sum.abs() <= 2.0 * w.err_sum,
            "{shape:?} seed {seed}: f32 gave up where the weights' sum {} is not rounding ({}); f64 {want:?}",
            w.sum,
            w.err_sum
        );
        return Ok(());
    };
    let one_px = Vec2::new(2.0 / size.0 as f32, -2.0 / size.1 as f32);
    let sum_w = |v: Vec3| v.x + v.y + v.z;
    for (axis, (d_got, d_want)) in [(got.ddx, dx), (got.ddy, dy)].into_iter().enumerate() {
        let step = if axis == 0 { Vec2::new(one_px.x, 0.0) } else { Vec2::new(0.0, one_px.y) };
        let p = weights(clip, ndc.extend(1.0));
        let d = weights(clip, step.extend(0.0));
        let s = p.sum.abs();
        if s <= 2.0 * p.err_sum {
            // The weights' sum is within f32 rounding of zero: the pixel's ray lies in the
            // triangle's plane as far as f32 can tell (a sliver, or a triangle seen
            // edge-on); f32 decides nothing there, so nothing is compared.
            continue;
        }
        let rel_sum = p.err_sum / (s - p.err_sum);
        let tol_l = p.err_u / (s - p.err_sum) + got.lambda.abs() * (rel_sum + f32::EPSILON);
        prop_assert!(
            (got.lambda.as_dvec3() - l).abs().cmple(tol_l.as_dvec3() * 1.0001 + f64_slack(l)).all(),
            "{shape:?} seed {seed}: lambda {} vs f64 {l}, bound {tol_l} ({spec:?}, size {size:?}, pixel {pixel:?})",
            got.lambda
        );
        // The derivative is (d sum - u sum(d)) / (sum s_next) (`neighbour_step`), with
        // s_next = sum + sum(d), signed: a neighbour sum of the other sign is a ray meeting
        // the plane behind the eye (the f64 route still finds that point; no pixel sees it).
        let s_next = (p.sum + d.sum) * p.sum.signum();
        let err_next = p.err_sum + d.err_sum;
        if s_next <= 2.0 * err_next || s_next <= s * tiledlight_cull::visibility::NEIGHBOUR_SUM_FLOOR * 2.0 {
            // The neighbour's ray is within rounding of parallel to the triangle's plane,
            // or past it (a sub-pixel triangle under a wide lens, a triangle crossing the
            // eye plane seen near its horizon): its weights, and any hardware derivative
            // there, are unbounded. The twin keeps them finite and large (the sampler's
            // coarsest level decides); that is all there is to check.
            prop_assert!(d_got.is_finite() && sum_w(d_got).abs() <= 1e-3 * d_got.abs().max_element().max(1.0));
            continue;
        }
        let num = (d.u * p.sum).abs() + (p.u * d.sum).abs();
        let num_err = d.err_u * s + d.u.abs() * p.err_sum + p.err_u * d.sum.abs() + p.u.abs() * d.err_sum + num * GAMMA;
        let rel_den = rel_sum + err_next / (s_next - err_next);
        let tol_d = num_err / (s * s_next) * (1.0 + rel_den) + d_got.abs() * (rel_den + f32::EPSILON);
        prop_assert!(
            (d_got.as_dvec3() - d_want).abs().cmple(tol_d.as_dvec3() * 1.0001 + f64_slack(d_want)).all(),
            "{shape:?} seed {seed}: d{} {d_got} vs f64 {d_want}, bound {tol_d} ({spec:?}, size {size:?})",
            if axis == 0 { "x" } else { "y" }
        );
        // Where the weights do not cancel (a triangle not seen edge-on: the magnitudes in
        // each weight and the sum within 100 times the sum), the bound stays below 1e-3 (0.1% of a texel
        // step across the triangle), so the comparison can fail.
        let condition = p.err_sum.max(p.err_u.max_element()) / GAMMA / s;
        if shape == Shape::Ordinary && condition < 100.0 {
            prop_assert!(
                tol_l.max_element() < 1e-3,
                "{shape:?} seed {seed}: bound {tol_l} too loose to test anything (condition {condition})"
            );
        }
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
    let w = weights(clip_of(&clip, [0, 1, 2]), ndc.extend(1.0));
    let tol = (w.err_u / (w.sum.abs() - w.err_sum)).max_element() as f64;
    assert!((right.lambda.as_dvec3() - wrong.0).abs().max_element() > 1e3 * tol, "{tol}");
}

fn clip_of(c: &[Vec4; 4], i: [usize; 3]) -> [Vec4; 3] {
    i.map(|k| c[k])
}
