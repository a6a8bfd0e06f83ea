//! The octahedral normal encoding's precision over the sphere, in f64 (issue 31: the
//! compact G-buffer's normal). Directions: 2^20 points of a Fibonacci sphere plus the
//! axes, the octant diagonals and the equator seam. Each is given to the encoder in f32 (as
//! a G-buffer pass gets it) and the decoded f32 vector is compared with the f64 direction.
//! The bound is derived in `tiledlight_cull::octahedral` (not fitted to the measurement);
//! the measured numbers are printed for docs/ARCHITECTURE.md. The f16-per-component normal
//! the G-buffer stores today is measured alongside as the baseline.

use glam::{DVec3, Vec3};
use proptest::prelude::*;
use tiledlight_cull::octahedral::{angular_error_bound, decode, encode, oct_map, oct_unmap};

mod common;

/// The angle between two directions, accurate for tiny angles (atan2 of |a x b| and a.b,
/// not acos, which loses half the digits near 0).
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// 2^20 Fibonacci-sphere directions and the special ones.
fn directions() -> Vec<DVec3> {
    let n = 1 << 20;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut v: Vec<DVec3> = (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    for x in [-1.0, 0.0, 1.0] {
        for y in [-1.0, 0.0, 1.0] {
            for z in [-1.0, -1e-7, 0.0, 1e-7, 1.0] {
                let d = DVec3::new(x, y, z);
                if d.length() > 0.5 {
                    v.push(d.normalize());
                }
            }
        }
    }
    v
}

/// Largest and mean angle (radians) between each direction and what `round_trip` makes of
/// its f32 copy.
fn errors(dirs: &[DVec3], round_trip: impl Fn(Vec3) -> Vec3) -> (f64, f64) {
    let mut max: f64 = 0.0;
    let mut sum = 0.0;
    for &d in dirs {
        let e = angle(d, round_trip(d.as_vec3()).as_dvec3());
        max = max.max(e);
        sum += e;
    }
    (max, sum / dirs.len() as f64)
}

/// The verdict: `Err` naming the encoding when its largest error passes the bound.
fn check(name: &str, (max, mean): (f64, f64), bound: f64) -> Result<(), String> {
    let deg = |r: f64| r.to_degrees();
    println!("{name}: max {:.5} deg, mean {:.5} deg (bound {:.5} deg)", deg(max), deg(mean), deg(bound));
    if max <= bound {
        Ok(())
    } else {
        Err(format!("{name}: max error {:.5} deg past the bound {:.5} deg", deg(max), deg(bound)))
    }
}

/// The f16-per-component normal (today's G-buffer: xyz in `Rgba16Float`, normalised when
/// read).
fn f16_xyz(n: Vec3) -> Vec3 {
    let h = |c: f32| half::f16::from_f32(c).to_f32();
    Vec3::new(h(n.x), h(n.y), h(n.z)).normalize()
}

#[test]
fn octahedral_normals_stay_within_their_derived_bound_over_the_sphere() {
    let dirs = directions();
    let oct16 = errors(&dirs, |n| decode(encode(n, 16), 16));
    let oct12 = errors(&dirs, |n| decode(encode(n, 12), 12));
    let f16 = errors(&dirs, f16_xyz);
    check("octahedral 2x16", oct16, angular_error_bound(16)).unwrap();
    check("octahedral 2x12", oct12, angular_error_bound(12)).unwrap();
    // The baseline has no derived bound here; it is what the compact layout replaces.
    let _ = check("f16 xyz (today)", f16, f64::INFINITY);
    assert!(oct16.0 < f16.0 / 4.0, "2x16 octahedral must be well inside f16 xyz: {oct16:?} vs {f16:?}");
    assert!(oct16.1 < 0.5 * oct16.0, "the mean sits well below the worst case: {oct16:?}");
}

/// Negative: a decoder that forgets to unfold the lower hemisphere must fail the check.
#[test]
fn a_decoder_without_the_fold_is_rejected() {
    let dirs = directions();
    let broken = |n: Vec3| {
        let p = oct_map(n);
        let q = glam::Vec2::new((p.x * 32767.0 + 0.5).floor() / 32767.0, (p.y * 32767.0 + 0.5).floor() / 32767.0);
        Vec3::new(q.x, q.y, 1.0 - q.x.abs() - q.y.abs()).normalize()
    };
    assert!(check("no fold", errors(&dirs, broken), angular_error_bound(16)).is_err());
    // And the map itself is its own inverse away from quantisation.
    for d in dirs.iter().step_by(997) {
        let n = d.as_vec3();
        let e = angle(oct_unmap(oct_map(n)).as_dvec3(), n.as_dvec3());
        assert!(e < 1e-6, "{n}: {e}");
    }
}

proptest! {
    #![proptest_config(common::proptest_config(256))]
    /// Any finite non-zero vector, of any length from 1e-30 to 1e30 and any direction,
    /// decodes within the bound of its own direction (computed in f64).
    #[test]
    fn any_length_any_direction_stays_within_the_bound(
        x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0, exp in -30i32..30,
    ) {
        let d = DVec3::new(x, y, z);
        prop_assume!(d.length() > 1e-3);
        let scaled = (d * 10f64.powi(exp)).as_vec3();
        prop_assume!(scaled.is_finite() && scaled.abs().max_element() > 0.0);
        let got = decode(encode(scaled, 16), 16).as_dvec3();
        // The f32 copy's own direction error (rounding of tiny components) is far below
        // the bound's 1e-6 slack.
        prop_assert!(angle(got, d.normalize()) <= angular_error_bound(16), "{d} x 1e{exp}: {got}");
    }
}
