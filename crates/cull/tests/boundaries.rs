//! Integer packings of the CPU twins at the boundary of their ranges (issue 43, class 4),
//! where a GPU scene would be too large to build:
//!
//! - the visibility buffer's ID layout (`visibility::IdLayout`): the largest scenes whose
//!   IDs fit 32 bits with the sky's all-ones ID kept free, and the first ones past them,
//!   which must be refused with an error naming the bits (never packed into a wrapped or
//!   sky-coloured ID); pack and unpack round-trip at the largest ID and the field edges;
//! - the caster ranking's quantisation and 64-bit sums (`contribution::light_scores`): with
//!   a scale that drives every pair past `PAIR_MAX`, each pair stores exactly `u32::MAX`
//!   and a light's score is their exact `u64` sum (past `2^32`, no wrap); just below the
//!   saturation a pair keeps its truncated value.
//!
//! A failure means a bit width off by one (a layout refused that fits, or accepted that
//! does not), an ID colliding with the sky, or a saturation or sum that wraps.

use glam::Vec3;
use tiledlight_cull::contribution::{light_scores, PAIR_MAX};
use tiledlight_cull::light::try_pack_lights;
use tiledlight_cull::visibility::{IdLayout, NO_TRIANGLE};
use tiledlight_cull::{Camera, Light, TileGrid};

/// Layouts at the edge of 32 bits: (instances, largest mesh) that fit, each with the
/// triangle bits it must get.
const FITS: [(u32, u32, u32); 6] = [
    // One instance: the triangle field takes all 32 bits; the last index u32::MAX - 1 is
    // the largest ID below the sky's.
    (1, u32::MAX, 32),
    // 2^16 instances, 2^16 - 1 triangles: 16 + 16 bits, the largest ID 0xfffffffe.
    (65_536, 65_535, 16),
    // 2^16 - 1 instances of 2^16 triangles: the top instance field is not all ones.
    (65_535, 65_536, 16),
    // Two instances of 2^31 - 1 triangles: 1 + 31 bits.
    (2, 0x7fff_ffff, 31),
    // One-triangle meshes: an empty triangle field, 2^32 - 1 instances.
    (u32::MAX, 1, 0),
    // A power of two exactly: 2^8 triangles need 8 bits, not 9 (23 + 8 bits).
    (1 << 23, 256, 8),
];

/// Layouts one past those: their largest ID would be the sky's or need 33 bits.
const REFUSED: [(u32, u32); 6] = [
    // 2^16 x 2^16: the largest ID would be 0xffffffff, the sky.
    (65_536, 65_536),
    // 17 + 16 bits.
    (65_537, 65_535),
    // 1 + 31 bits, the largest ID all ones.
    (2, 0x8000_0000),
    // 24 + 8 bits, the largest ID all ones.
    (1 << 24, 256),
    // 2^24 + 1 instances (25 bits) of 2^8 triangles.
    ((1 << 24) + 1, 256),
    // 2^8 + 1 triangles (9 bits) with 2^24 instances.
    (1 << 24, 257),
];

#[test]
fn id_layouts_at_the_edge_of_32_bits() {
    for (instances, triangles, bits) in FITS {
        let l = IdLayout::for_scene(instances, triangles)
            .unwrap_or_else(|e| panic!("{instances} x {triangles} fits 32 bits: {e}"));
        assert_eq!(l.triangle_bits, bits, "{instances} instances x {triangles} triangles");
        // The largest ID, and the edges of each field, round-trip and are not the sky's.
        for (i, t) in [(instances - 1, triangles - 1), (instances - 1, 0), (0, triangles - 1), (0, 0)] {
            let id = l.pack(i, t);
            assert_ne!(id, NO_TRIANGLE, "{instances} x {triangles}: ({i}, {t}) packs to the sky's ID");
            assert_eq!(l.unpack(id), Some((i, t)), "{instances} x {triangles}: ({i}, {t}) -> {id:#x}");
        }
        assert_eq!(l.unpack(NO_TRIANGLE), None);
    }
    // The largest IDs are what their fields make them: all ones but the sky's.
    assert_eq!(IdLayout::for_scene(65_536, 65_535).unwrap().pack(65_535, 65_534), 0xffff_fffe);
    assert_eq!(IdLayout::for_scene(1, u32::MAX).unwrap().pack(0, u32::MAX - 1), 0xffff_fffe);
    for (instances, triangles) in REFUSED {
        let e =
            IdLayout::for_scene(instances, triangles).expect_err(&format!("{instances} x {triangles} must not fit"));
        let text = e.to_string();
        assert!(
            text.contains(&format!("{instances} instances")) && text.contains("bits needed") && text.contains("sky"),
            "{instances} x {triangles}: the error must name the counts and the bits: {text}"
        );
    }
}

/// IDs past a layout's instances or largest mesh are not unpacked into a real triangle (a
/// stray ID names nothing rather than wrapping into another instance's field).
#[test]
fn ids_past_the_scene_unpack_to_nothing() {
    let l = IdLayout::for_scene(5, 5).unwrap();
    assert_eq!(l.triangle_bits, 3);
    assert_eq!(l.unpack(l.pack(4, 4)), Some((4, 4)));
    // Triangle 5..7 fit the field but not the mesh; instance 5 fits the bits but not the scene.
    assert_eq!(l.unpack((4 << 3) | 5), None);
    assert_eq!(l.unpack(5 << 3), None);
}

/// A 32 x 16 floor seen from above (two tiles of 16 px), every pixel's depth 0.5.
fn flat() -> (Camera, TileGrid, Vec<f32>) {
    let grid = TileGrid::new(32, 16, 16).unwrap();
    let cam = Camera::perspective(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, Vec3::Z, 0.5, 2.0, 0.1, Some(10.0)).unwrap();
    (cam, grid, vec![0.5; 32 * 16])
}

#[test]
fn saturated_pairs_store_u32_max_and_sum_past_2_32_without_wrapping() {
    let (cam, grid, depth) = flat();
    // Intensity 50, threshold 0.01: a 70 m radius covers the whole floor.
    let light = Light::point(Vec3::new(0.0, 0.5, 0.0), Vec3::ONE, 50.0, 0.01).unwrap();
    let packed = try_pack_lights(&[light, light]).unwrap();
    let lists = vec![vec![0, 1]; grid.tile_count()];
    let at = |scale: f32| light_scores(&cam, &depth, (&grid, &lists), &packed, scale).unwrap();
    let unit = at(1.0);
    assert!(unit[0] > 0, "the floor is lit");
    // Far past saturation: every pair stores u32::MAX exactly, two pairs sum past 2^32.
    let huge = at(1e30);
    assert_eq!(huge[0], 2 * u64::from(u32::MAX), "two saturated pairs: 2 x u32::MAX, not wrapped");
    assert!(huge[0] > 1 << 32);
    // Below the saturation a pair keeps its own value: one tile's pair scaled to 3/4 of
    // PAIR_MAX (its unit-scale value is in the thousands, so truncation moves the ratio by
    // under 1e-3) stays between 2^31 and u32::MAX.
    let tile = light_scores(&cam, &depth, (&grid, &[vec![0], vec![]]), &packed, 1.0).unwrap()[0];
    assert!(tile > 1000, "the unit-scale pair must be large enough to scale: {tile}");
    let below =
        light_scores(&cam, &depth, (&grid, &[vec![0], vec![]]), &packed, PAIR_MAX / tile as f32 * 0.75).unwrap();
    assert!(
        below[0] < u64::from(u32::MAX) && below[0] > 1 << 31,
        "3/4 of PAIR_MAX stays unsaturated: {below:?} (unit {tile})"
    );
}
