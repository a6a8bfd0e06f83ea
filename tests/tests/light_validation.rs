//! Lights with NaN, infinite or out-of-range fields (`Light`'s fields are public, so the
//! constructors' checks can be bypassed) are refused by the upload, `LightBuffers::new`,
//! with an error naming the light's index in the caller's list and the bad field, instead
//! of being packed into NaN spheres that the culling kernel silently drops. The field by
//! field cases are unit tests in `tiledlight-cull` (`light::tests`); this checks that the
//! one GPU entry point runs them.

use glam::Vec3;
use tiledlight_cull::{Light, LightKind};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_tests::{err_text, gpu};

/// Catches an upload that skips validation (it would return Ok), validates after
/// reordering points first (the index would be 2, the packed position, not 3), or loses
/// the field in the message.
#[test]
fn upload_names_the_bad_light_and_field() {
    let ctx = gpu();
    let point = Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 0.1).unwrap();
    let spot = Light::spot(Vec3::Y, Vec3::NEG_Y, Vec3::ONE, 1.0, 0.2, 0.4, 0.1).unwrap();
    let cases = [
        (Light { position: Vec3::new(0.0, f32::NAN, 0.0), ..point }, "position"),
        (Light { color: Vec3::new(1.0, f32::INFINITY, 0.0), ..point }, "colour"),
        (Light { radius: f32::NAN, ..point }, "radius NaN"),
        (Light { intensity: -2.0, ..point }, "intensity -2"),
        (
            Light { kind: LightKind::Spot { direction: Vec3::ZERO, inner_angle: 0.2, outer_angle: 0.4 }, ..spot },
            "spot direction",
        ),
        (
            Light { kind: LightKind::Spot { direction: Vec3::NEG_Y, inner_angle: 0.6, outer_angle: 0.4 }, ..spot },
            "spot inner angle 0.6",
        ),
        (
            Light {
                kind: LightKind::Spot { direction: Vec3::NEG_Y, inner_angle: 0.2, outer_angle: 90f32.to_radians() },
                ..spot
            },
            "spot outer angle",
        ),
    ];
    for (bad, what) in cases {
        // Spots first in the caller's list: packing moves the points (the bad one too)
        // ahead of them, so only an index taken before reordering says 3.
        let lights = [spot, spot, point, bad, point];
        let e = err_text(LightBuffers::new(&ctx.device, &lights));
        assert!(e.contains("light 3:"), "{what}: {e}");
        assert!(e.contains(what), "{e:?} should name {what:?}");
    }
    // The same lights without the bad one upload.
    let ok = LightBuffers::new(&ctx.device, &[spot, spot, point, point]).expect("valid lights upload");
    assert_eq!((ok.len(), ok.num_point()), (4, 2));
}
