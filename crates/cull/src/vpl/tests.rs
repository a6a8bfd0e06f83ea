//! Tests of the VPL twin: settings, texel flux, generation (energy, thresholds, cap), the
//! two shading models at their singular points, and the convergence of the physical model
//! to the every-texel reference.

use super::*;
use proptest::prelude::*;

/// A spot light 3 m above a floor (y = 0, a white/grey checker) next to a red wall (x =
/// 1.5, facing -x), looking straight down with a 60 degree outer cone; the face's view is
/// built as the shadow faces build theirs (looking down -Z), and every texel is ray-cast
/// analytically, so the RSM is exact.
fn scene_face(size: u32) -> RsmFace {
    let position = Vec3::new(0.0, 3.0, 0.0);
    let axis = Vec3::NEG_Y;
    let (right, up) = (Vec3::X, Vec3::NEG_Z);
    let tan_w = 60f32.to_radians().tan();
    let (scale, offset) = crate::light::spot_scale_offset(40f32.to_radians(), 60f32.to_radians());
    let light = RsmLight {
        position,
        radius: 8.0,
        radiance: Vec3::new(1.0, 0.9, 0.8) * 40.0,
        axis,
        texel_sq: (2.0 * tan_w / size as f32).powi(2),
        vpl_radius: 4.0,
        spot: Some((axis, scale, offset)),
    };
    let mut texels = Vec::new();
    for ty in 0..size {
        for tx in 0..size {
            let u = ((tx as f32 + 0.5) / size as f32 * 2.0 - 1.0) * tan_w;
            let v = (1.0 - (ty as f32 + 0.5) / size as f32 * 2.0) * tan_w;
            let dir = (axis + right * u + up * v).normalize();
            let t_floor = position.y / -dir.y;
            let t_wall = if dir.x > 0.0 { (1.5 - position.x) / dir.x } else { f32::INFINITY };
            let t = if t_wall < t_floor {
                let p = position + dir * t_wall;
                Some(RsmTexel { position: p, normal: Vec3::NEG_X, albedo: Vec3::new(0.9, 0.1, 0.1) })
            } else {
                let p = position + dir * t_floor;
                let checker = ((p.x * 2.0).floor() as i32 + (p.z * 2.0).floor() as i32).rem_euclid(2) == 0;
                let albedo = if checker { Vec3::splat(0.8) } else { Vec3::splat(0.3) };
                Some(RsmTexel { position: p, normal: Vec3::Y, albedo })
            };
            texels.push(t);
        }
    }
    RsmFace { size, light, texels }
}

/// Receivers on the floor near and far from the wall, and on the wall.
fn receivers() -> Vec<(Vec3, Vec3)> {
    let mut r = Vec::new();
    for x in [-1.5, -0.5, 0.5, 1.0, 1.3] {
        for z in [-1.0, 0.0, 1.0] {
            r.push((Vec3::new(x, 0.0, z), Vec3::Y));
        }
    }
    for y in [0.3, 1.0, 2.0] {
        for z in [-1.0, 0.0, 1.0] {
            r.push((Vec3::new(1.5, y, z), Vec3::NEG_X));
        }
    }
    r
}

/// Relative L1 error of `model`'s irradiance at the receivers against the reference.
fn error(faces: &[RsmFace], cfg: &VplConfig) -> f32 {
    let g = generate(faces, cfg).unwrap();
    let (mut err, mut total) = (0.0, 0.0);
    for (x, n) in receivers() {
        let reference = reference_irradiance(faces, x, n, cfg.distance_clamp);
        let approx = vpl_irradiance(&g.vpls, x, n, VplShading::Physical, cfg.distance_clamp);
        err += (approx - reference).abs().element_sum();
        total += reference.element_sum();
    }
    assert!(total > 0.0, "the receivers must see indirect light");
    err / total
}

#[test]
fn config_checks_name_the_bad_field() {
    let ok = VplConfig::default();
    assert!(ok.validate().is_ok());
    let cases: [(VplConfig, &str); 9] = [
        (VplConfig { rsm_size: 2, ..ok }, "RSM size"),
        (VplConfig { block: 3, ..ok }, "block"),
        (VplConfig { block: 0, ..ok }, "block"),
        (VplConfig { rsm_size: 64, block: 32, ..ok }, "at most 16"),
        (VplConfig { colour_threshold: 1.5, ..ok }, "colour threshold"),
        (VplConfig { brightness_threshold: f32::NAN, ..ok }, "brightness"),
        (VplConfig { cap: 0, ..ok }, "cap"),
        (VplConfig { distance_clamp: 0.0, ..ok }, "clamp"),
        (VplConfig { radius_fraction: -1.0, ..ok }, "radius fraction"),
    ];
    for (cfg, word) in cases {
        let e = cfg.validate().unwrap_err().to_string();
        assert!(e.contains(word), "{e:?} should name {word:?}");
    }
    assert_eq!(VplShading::from_name("physical").unwrap(), VplShading::Physical);
    assert!(VplShading::from_name("fancy").unwrap_err().to_string().contains("sample or physical"));
}

#[test]
fn texel_flux_is_tint_times_peak_radiance_times_solid_angle() {
    let face = scene_face(32);
    let t = face.texels[16 * 32 + 16].unwrap();
    let l = texel_light(&face.light, t.position, t.albedo);
    let peak = face.light.radiance.max_element();
    assert!((l.flux - l.tint * peak * l.solid_angle).abs().max_element() < 1e-6 * l.flux.max_element());
    // Straight below the light: the solid angle is the texel's own (cos = 1, to 1e-3).
    assert!((l.solid_angle / face.light.texel_sq - 1.0).abs() < 1e-2, "{}", l.solid_angle / face.light.texel_sq);
    // Outside the cone (the corner texel is 67 degrees off the axis): nothing reflected.
    let c = face.texels[0].unwrap();
    assert_eq!(texel_light(&face.light, c.position, c.albedo).flux, Vec3::ZERO);
}

#[test]
fn texel_position_inverts_the_projection() {
    let view = Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    let m = proj * view;
    let p = Vec3::new(0.2, -0.1, 0.3);
    let clip = m * p.extend(1.0);
    let ndc = clip.truncate() / clip.w;
    let size = 32;
    // The texel whose centre the point projects to, exactly: choose a point on a centre.
    let tx = ((ndc.x + 1.0) / 2.0 * size as f32 - 0.5).round() as u32;
    let ty = ((1.0 - ndc.y) / 2.0 * size as f32 - 0.5).round() as u32;
    let q = texel_position(&m.inverse(), size, (tx, ty), ndc.z);
    // Not the same point (texel centre vs point) but the same depth along the same texel's
    // ray: within a texel's width at that distance (~0.06 m at 3.7 m with a 1 rad field).
    assert!((q - p).length() < 0.1, "{q} vs {p}");
    let back = m * q.extend(1.0);
    assert!((back.z / back.w - ndc.z).abs() < 1e-5);
}

#[test]
fn shading_is_finite_and_zero_at_the_vpl_behind_it_and_past_the_radius() {
    let v = Vpl { position: Vec3::ZERO, normal: Vec3::Y, flux: Vec3::ONE, tint: Vec3::ONE, radius: 2.0 };
    for model in [VplShading::Sample, VplShading::Physical] {
        let (l, f) = vpl_intensity(&v, Vec3::ZERO, model, 0.1);
        assert_eq!((l, f), (Vec3::ZERO, Vec3::ZERO), "{model:?} at d = 0");
        let (_, f) = vpl_intensity(&v, Vec3::new(0.0, -1.0, 0.0), model, 0.1);
        assert_eq!(f, Vec3::ZERO, "{model:?} behind the VPL");
        let (_, f) = vpl_intensity(&v, Vec3::new(0.0, 1e-20, 0.0), model, 0.1);
        assert!(f.is_finite(), "{model:?} next to the VPL: {f}");
    }
    // Sample: zero at and past the radius, smooth inside; no inverse square.
    assert_eq!(vpl_intensity(&v, Vec3::new(0.0, 2.0, 0.0), VplShading::Sample, 0.1).1, Vec3::ZERO);
    let near = vpl_intensity(&v, Vec3::new(0.0, 0.01, 0.0), VplShading::Sample, 0.1).1.x;
    assert!((near * std::f32::consts::PI * 4.0 - 1.0).abs() < 1e-3, "{near}");
    // Physical: inverse square beyond the clamp, constant inside it.
    let at = |y: f32| vpl_intensity(&v, Vec3::new(0.0, y, 0.0), VplShading::Physical, 0.1).1.x;
    assert!((at(1.0) / at(2.0) - 4.0).abs() < 1e-4);
    assert_eq!(at(0.05), at(0.01));
}

#[test]
fn thresholds_at_their_extremes() {
    let red = Vec3::new(0.5, 0.0, 0.0);
    let grey = Vec3::splat(0.5);
    // Zero thresholds keep any light, never black.
    assert!(passes_thresholds(grey, 0.0, 0.0));
    assert!(!passes_thresholds(Vec3::ZERO, 0.0, 0.0));
    // A colour threshold of 1 keeps only pure channels; grey's channels are 1/sqrt(3).
    assert!(passes_thresholds(red, 1.0, 0.0));
    assert!(!passes_thresholds(grey, 1.0, 0.0));
    assert!(passes_thresholds(grey, 0.577, 0.0) && !passes_thresholds(grey, 0.578, 0.0));
    // Brightness: strictly above.
    assert!(!passes_thresholds(red, 0.0, 0.5) && passes_thresholds(red, 0.0, 0.499));
    assert!(!passes_thresholds(Vec3::ONE, 0.0, f32::MAX));

    // On the scene: a colour threshold of 0.9 keeps exactly the red wall's blocks.
    let face = scene_face(32);
    let cfg = VplConfig { block: 1, colour_threshold: 0.9, ..Default::default() };
    let g = generate(std::slice::from_ref(&face), &cfg).unwrap();
    assert!(g.candidates > 0);
    let off_wall = g.vpls.iter().find(|v| v.normal.dot(Vec3::NEG_X) < 0.9999);
    assert!(off_wall.is_none(), "only the wall is saturated enough: {off_wall:?}");
    let walls = face
        .texels
        .iter()
        .flatten()
        .filter(|t| t.normal == Vec3::NEG_X)
        .filter(|t| texel_light(&face.light, t.position, t.albedo).flux != Vec3::ZERO);
    assert_eq!(g.vpls.len(), walls.count());
    // A brightness threshold above any tint keeps none.
    let none = generate(&[face], &VplConfig { brightness_threshold: 2.0, ..Default::default() }).unwrap();
    assert_eq!((none.candidates, none.vpls.len()), (0, 0));
}

#[test]
fn the_cap_keeps_the_first_and_counts_the_rest() {
    let face = scene_face(32);
    let all = generate(std::slice::from_ref(&face), &VplConfig::default()).unwrap();
    assert!(all.candidates > 100, "{}", all.candidates);
    assert_eq!((all.refused, all.vpls.len() as u32), (0, all.candidates));
    let capped = generate(&[face], &VplConfig { cap: 37, ..Default::default() }).unwrap();
    assert_eq!(capped.candidates, all.candidates);
    assert_eq!(capped.vpls.len(), 37);
    assert_eq!(capped.refused, all.candidates - 37);
    assert_eq!(capped.vpls[..], all.vpls[..37]);
}

#[test]
fn a_face_of_the_wrong_size_is_an_error() {
    let e = generate(&[scene_face(16)], &VplConfig::default()).unwrap_err().to_string();
    assert!(e.contains("face 0") && e.contains("32"), "{e}");
}

#[test]
fn physical_model_converges_to_the_reference_as_blocks_and_thresholds_fall() {
    let faces = [scene_face(32)];
    let base = VplConfig { shading: VplShading::Physical, ..Default::default() };
    // Blocks 16 -> 1 with no thresholds: the error falls at every step and vanishes at 1
    // (one VPL per texel is the reference's own sum; 1e-5 is f32 rounding of the weighted
    // mean position).
    let by_block: Vec<f32> = [16, 8, 4, 2, 1].iter().map(|&b| error(&faces, &VplConfig { block: b, ..base })).collect();
    for w in by_block.windows(2) {
        assert!(w[1] < w[0], "error must fall with the block size: {by_block:?}");
    }
    assert!(by_block[4] < 1e-5, "{by_block:?}");
    assert!(by_block[0] > 1e-2, "16x16 blocks must be visibly wrong: {by_block:?}");
    // Thresholds -> 0 at block 1: fewer VPLs dropped, the error never grows, and reaches 0.
    let by_brightness: Vec<f32> = [0.4, 0.2, 0.1, 0.05, 0.0]
        .iter()
        .map(|&t| error(&faces, &VplConfig { block: 1, brightness_threshold: t, ..base }))
        .collect();
    let by_colour: Vec<f32> = [0.9, 0.7, 0.6, 0.0]
        .iter()
        .map(|&t| error(&faces, &VplConfig { block: 1, colour_threshold: t, ..base }))
        .collect();
    for e in [&by_brightness, &by_colour] {
        for w in e.windows(2) {
            assert!(w[1] <= w[0], "error must not grow as a threshold falls: {e:?}");
        }
        assert!(e[0] > e[e.len() - 1] + 1e-2, "the largest threshold must cost something: {e:?}");
        assert!(e[e.len() - 1] < 1e-5, "{e:?}");
    }
}

#[test]
fn red_wall_bleeds_onto_the_floor_next_to_it() {
    let faces = [scene_face(32)];
    let g = generate(&faces, &VplConfig::default()).unwrap();
    for model in [VplShading::Sample, VplShading::Physical] {
        let near = vpl_irradiance(&g.vpls, Vec3::new(1.2, 0.0, 0.0), Vec3::Y, model, 0.1);
        assert!(near.x > 2.0 * near.y && near.x > 2.0 * near.z, "{model:?}: {near}");
    }
}

fn arb_face(size: u32) -> impl Strategy<Value = RsmFace> {
    let texel = proptest::option::weighted(
        0.8,
        (
            proptest::array::uniform3(-5.0f32..5.0),
            proptest::array::uniform3(-1.0f32..1.0),
            proptest::array::uniform3(0.0f32..1.0),
        ),
    );
    (proptest::collection::vec(texel, (size * size) as usize), 0.0f32..50.0, any::<bool>()).prop_map(
        move |(ts, intensity, spot)| {
            let axis = Vec3::NEG_Y;
            let (scale, offset) = crate::light::spot_scale_offset(0.3, 0.9);
            RsmFace {
                size,
                light: RsmLight {
                    position: Vec3::new(0.0, 6.0, 0.0),
                    radius: 10.0,
                    radiance: Vec3::new(1.0, 0.5, 0.25) * intensity,
                    axis,
                    texel_sq: 0.01,
                    vpl_radius: 3.0,
                    spot: spot.then_some((axis, scale, offset)),
                },
                texels: ts
                    .into_iter()
                    .map(|t| {
                        t.map(|(p, n, a)| RsmTexel {
                            position: Vec3::from(p),
                            normal: Vec3::from(n).normalize_or(Vec3::Y),
                            albedo: Vec3::from(a),
                        })
                    })
                    .collect(),
            }
        },
    )
}

proptest! {
    #![proptest_config(crate::test_seed::proptest_config(64))]

    /// Whatever the RSM: finite VPLs, at most `cap` of them, kept + refused = candidates,
    /// and with no thresholds the flux of all blocks is the flux of all texels (a block
    /// whose normals cancel makes no VPL and loses its flux: then it is less).
    #[test]
    fn generation_is_finite_capped_and_keeps_energy(
        face in arb_face(8),
        block in prop::sample::select(vec![1u32, 2, 4, 8]),
        colour in 0.0f32..=1.0,
        brightness in 0.0f32..2.0,
        cap in 1u32..80,
    ) {
        let cfg = VplConfig { rsm_size: 8, block, colour_threshold: colour, brightness_threshold: brightness, cap, ..Default::default() };
        let g = generate(std::slice::from_ref(&face), &cfg).unwrap();
        prop_assert!(g.vpls.len() as u32 <= cap);
        prop_assert_eq!(g.vpls.len() as u32 + g.refused, g.candidates);
        for v in &g.vpls {
            prop_assert!(v.position.is_finite() && v.normal.is_finite() && v.flux.is_finite() && v.tint.is_finite());
            prop_assert!((v.normal.length() - 1.0).abs() < 1e-4);
            prop_assert!(passes_thresholds(v.tint, colour, brightness));
            for model in [VplShading::Sample, VplShading::Physical] {
                let (_, f) = vpl_intensity(v, v.position, model, 0.1);
                prop_assert!(f.is_finite());
            }
        }
        let all = generate(std::slice::from_ref(&face), &VplConfig { rsm_size: 8, block, cap: MAX_CAP, ..Default::default() }).unwrap();
        let blocks: Vec3 = all.vpls.iter().map(|v| v.flux).sum();
        let texels: Vec3 = face.texels.iter().flatten().map(|t| texel_light(&face.light, t.position, t.albedo).flux).sum();
        prop_assert!((blocks - texels).max_element() <= 1e-4 * texels.max_element().max(1e-6));
    }
}
