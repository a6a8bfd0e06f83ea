//! Tiled Deferred's compact G-buffer texel: everything the shared BRDF reads of a surface
//! sample in one `Rgba16Uint` texel (8 bytes), the CPU twin of
//! `shaders/common/gbuffer_texel.wgsl` (keep the two in step).
//!
//! One 64-bit target instead of several: on the H200 each extra colour target of the
//! G-buffer pass costs about as much as doubling a target's bytes (`docs/PERFORMANCE.md`,
//! the G-buffer stress knob), so the surface is packed into a single target. 64 bits hold:
//!
//! | channel | bits 15-8 | bits 7-0 |
//! | --- | --- | --- |
//! | x | metallic bits 1-0 in 15-14, normal u code in 13-0 | |
//! | y | metallic bits 3-2 in 15-14, normal v code in 13-0 | |
//! | z | base red, sRGB 8-bit | base green, sRGB 8-bit |
//! | w | base blue, sRGB 8-bit | perceptual roughness, 8-bit unorm |
//!
//! 1. The normal is mapped to the octahedral square ([`octahedral::oct_map`]) and each
//!    coordinate quantised to [`NORMAL_BITS`] signed bits, stored offset by
//!    [`NORMAL_OFFSET`] (so the field is never negative). Its angular error is at most
//!    [`max_normal_error`] (0.0151 degrees), 1.5x tighter than the f16 xyz normal it
//!    replaces (0.0226 degrees measured, `tests/octahedral.rs`).
//! 2. The base colour is sRGB-encoded and rounded to 8 bits a channel: what an
//!    `Rgba8UnormSrgb` target stores (base colours come from 8-bit sRGB textures and
//!    factors, so little is lost).
//! 3. Roughness is rounded to 8 bits (perceptual, before squaring: steps of 1/255).
//! 4. Metallic is rounded to [`METALLIC_BITS`] bits (steps of 1/15). 0 and 1, the values of
//!    every built-in material, are exact; a glTF metallic texture's 8-bit values move by up
//!    to 1/30. These are the bits the 14-bit normal leaves: 2 x 14 + 24 + 8 + 4 = 64.
//!
//! Values outside `[0, 1]` are clamped; a zero or non-finite normal stores +Z. Depends on
//! glam and [`octahedral`].

use glam::Vec3;

use crate::octahedral;

/// Bits of each octahedral normal coordinate.
pub const NORMAL_BITS: u32 = 14;
/// Added to a signed normal code to store it (`2^(NORMAL_BITS - 1)`).
pub const NORMAL_OFFSET: i32 = 1 << (NORMAL_BITS - 1);
/// Bits of metallic (split over the top two bits of x and y).
pub const METALLIC_BITS: u32 = 4;
/// Bytes of one sample of the packed surface target.
pub const TEXEL_BYTES: u64 = 8;

/// What the G-buffer holds of one surface sample (linear base colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceTexel {
    /// Linear base colour, each channel in `[0, 1]`.
    pub base: Vec3,
    /// Metallic, `[0, 1]`.
    pub metallic: f32,
    /// Unit shading normal.
    pub normal: Vec3,
    /// Perceptual roughness, `[0, 1]`.
    pub roughness: f32,
}

/// The largest angle (radians) between a unit normal and the one its texel decodes to.
pub fn max_normal_error() -> f64 {
    octahedral::angular_error_bound(NORMAL_BITS)
}

/// Largest change of a metallic value by its rounding (half a step).
pub fn max_metallic_error() -> f32 {
    0.5 / unorm_max(METALLIC_BITS)
}

/// Largest change of a roughness value by its rounding (half a step).
pub fn max_roughness_error() -> f32 {
    0.5 / unorm_max(8)
}

fn unorm_max(bits: u32) -> f32 {
    ((1u32 << bits) - 1) as f32
}

/// `c` in `[0, 1]` rounded to a `bits`-bit unsigned code (`pack4x8unorm`'s rounding);
/// NaN stores 0.
pub fn unorm(c: f32, bits: u32) -> u32 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    (0.5 + unorm_max(bits) * c).floor() as u32
}

/// The value of a `bits`-bit unsigned code.
pub fn from_unorm(q: u32, bits: u32) -> f32 {
    q as f32 / unorm_max(bits)
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in `[0, 1]`.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`linear_to_srgb`].
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Packs `t` into the four 16-bit channels of an `Rgba16Uint` texel.
pub fn pack(t: &SurfaceTexel) -> [u32; 4] {
    let (u, v) = octahedral::encode(t.normal, NORMAL_BITS);
    let m = unorm(t.metallic, METALLIC_BITS);
    let srgb = |c: f32| unorm(linear_to_srgb(c), 8);
    [
        (u + NORMAL_OFFSET) as u32 | (m & 3) << 14,
        (v + NORMAL_OFFSET) as u32 | (m >> 2) << 14,
        srgb(t.base.x) << 8 | srgb(t.base.y),
        srgb(t.base.z) << 8 | unorm(t.roughness, 8),
    ]
}

/// The surface a texel written by [`pack`] holds (bits above 16 are ignored).
pub fn unpack(p: [u32; 4]) -> SurfaceTexel {
    let code = |c: u32| (c & 0x3fff) as i32 - NORMAL_OFFSET;
    let srgb = |q: u32| srgb_to_linear(from_unorm(q & 0xff, 8));
    SurfaceTexel {
        base: Vec3::new(srgb(p[2] >> 8), srgb(p[2]), srgb(p[3] >> 8)),
        metallic: from_unorm((p[0] >> 14 & 3) | (p[1] >> 14 & 3) << 2, METALLIC_BITS),
        normal: octahedral::decode((code(p[0]), code(p[1])), NORMAL_BITS),
        roughness: from_unorm(p[3] & 0xff, 8),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texel(normal: Vec3) -> SurfaceTexel {
        SurfaceTexel { base: Vec3::new(0.8, 0.5, 0.25), metallic: 1.0, normal, roughness: 0.35 }
    }

    #[test]
    fn round_trip_within_each_fields_precision() {
        for (i, n) in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(1.0, -2.0, 0.5).normalize(), Vec3::new(-0.3, 0.2, -0.9)]
            .into_iter()
            .enumerate()
        {
            let n = n.normalize();
            for metallic in [0.0, 0.2, 0.5, 1.0] {
                let t = SurfaceTexel { metallic, roughness: 0.05 + 0.2 * i as f32, ..texel(n) };
                let p = pack(&t);
                assert!(p.iter().all(|&c| c < 1 << 16), "{p:?}");
                let u = unpack(p);
                let angle = f64::from(u.normal.dot(n).clamp(-1.0, 1.0)).acos();
                assert!(angle <= max_normal_error(), "{n}: {angle} rad");
                assert!((u.metallic - metallic).abs() <= max_metallic_error() + 1e-6, "{metallic} -> {}", u.metallic);
                assert!((u.roughness - t.roughness).abs() <= max_roughness_error() + 1e-6);
                // 8-bit sRGB: half a code in sRGB space, at most 1/510 / (d srgb / d linear).
                for c in 0..3 {
                    let want = t.base[c];
                    let slope = (linear_to_srgb(want + 1e-3) - linear_to_srgb(want)) / 1e-3;
                    assert!((u.base[c] - want).abs() <= 0.5 / 255.0 / slope * 1.05, "{want} -> {}", u.base[c]);
                }
            }
        }
    }

    #[test]
    fn built_in_metallic_values_and_unit_extremes_are_exact() {
        for m in [0.0, 1.0] {
            assert_eq!(unpack(pack(&SurfaceTexel { metallic: m, ..texel(Vec3::Y) })).metallic, m);
        }
        let t = SurfaceTexel { base: Vec3::new(0.0, 1.0, 1.0), metallic: 0.0, normal: Vec3::Z, roughness: 1.0 };
        let u = unpack(pack(&t));
        assert_eq!((u.base, u.roughness), (t.base, 1.0));
        assert_eq!(u.normal, Vec3::Z);
    }

    #[test]
    fn out_of_range_and_nan_inputs_are_clamped_not_spilled() {
        let t = SurfaceTexel {
            base: Vec3::new(-1.0, 2.0, f32::NAN),
            metallic: 7.0,
            normal: Vec3::new(f32::NAN, 0.0, 1.0),
            roughness: -3.0,
        };
        let p = pack(&t);
        assert!(p.iter().all(|&c| c < 1 << 16), "{p:?}");
        let u = unpack(p);
        assert_eq!((u.base, u.metallic, u.normal, u.roughness), (Vec3::new(0.0, 1.0, 0.0), 1.0, Vec3::Z, 0.0));
    }

    #[test]
    fn fields_do_not_overlap() {
        // Each field at its largest with the others at zero sets disjoint bits.
        let zero = SurfaceTexel { base: Vec3::ZERO, metallic: 0.0, normal: Vec3::Z, roughness: 0.0 };
        let base = pack(&zero);
        let fields = [
            SurfaceTexel { metallic: 1.0, ..zero },
            SurfaceTexel { roughness: 1.0, ..zero },
            SurfaceTexel { base: Vec3::X, ..zero },
            SurfaceTexel { base: Vec3::Y, ..zero },
            SurfaceTexel { base: Vec3::Z, ..zero },
        ];
        let mut seen = [0u32; 4];
        for f in &fields {
            let p = pack(f);
            for c in 0..4 {
                let changed = p[c] ^ base[c];
                assert_eq!(changed & seen[c], 0, "{f:?} overlaps channel {c}");
                seen[c] |= changed;
            }
        }
        // And the normal's codes leave the metallic bits alone.
        let p = pack(&SurfaceTexel { normal: Vec3::new(1.0, 1.0, -0.2).normalize(), ..zero });
        assert_eq!((p[0] >> 14, p[1] >> 14), (0, 0));
    }
}
