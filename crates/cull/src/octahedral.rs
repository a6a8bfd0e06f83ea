//! Unit normals in two signed fixed-point numbers: the octahedral map (Meyer et al. 2010;
//! Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit
//! Vectors"), the CPU twin of the compact G-buffer's normal (issue 31).
//!
//! 1. The vector is divided by its largest component's magnitude (so no sum below
//!    overflows or underflows, whatever its length: 1e-38 and 1e38 encode alike); a zero
//!    or non-finite vector encodes as +Z.
//! 2. It is projected onto the octahedron `|x| + |y| + |z| = 1`; the upper half maps to the
//!    diamond `|u| + |v| <= 1` of the square, the lower half is folded out to the square's
//!    corners (`(1 - |v|, 1 - |u|)` with the signs of `(u, v)`).
//! 3. Each coordinate is quantised as WGSL's `pack2x16snorm` does,
//!    `floor(0.5 + m * clamp(c, -1, 1))` with `m = 2^(bits - 1) - 1` (32,767 for 16 bits),
//!    and read back as `max(q / m, -1)`.
//! 4. Decoding unfolds the lower half and normalises.
//!
//! The error bound ([`angular_error_bound`]): rounding moves each coordinate by at most
//! `0.5 / m`, so the point by `sqrt(2) / 2 / m` in the square; the map from the square to
//! the sphere stretches by at most 3 (the octahedron's point `(1/3, 1/3, 1/3)` is
//! `1/sqrt(3)` from the centre, and a step along `(1, 1)` moves it `sqrt(3)` times as
//! far), so the direction turns by at most `3 sqrt(2) / (2 m)` radians, 0.0037 degrees at
//! 16 bits and 0.059 at 12; f32 arithmetic adds a few 1e-7. Depends on glam only.

use glam::{Vec2, Vec3};

/// The largest quantised value of a `bits`-bit signed coordinate: `2^(bits - 1) - 1`.
pub fn snorm_max(bits: u32) -> f32 {
    ((1u32 << (bits - 1)) - 1) as f32
}

/// Step 1 and 2: the point of the square `[-1, 1]^2` that `n` maps to (+Z's, the
/// origin, for a zero or non-finite `n`).
pub fn oct_map(n: Vec3) -> Vec2 {
    // Checked first: `max_element` would skip a NaN component.
    if !n.is_finite() {
        return Vec2::ZERO;
    }
    let m = n.abs().max_element();
    if m <= 0.0 {
        return Vec2::ZERO;
    }
    let n = n / m;
    let p = Vec2::new(n.x, n.y) / (n.x.abs() + n.y.abs() + n.z.abs());
    if n.z < 0.0 {
        fold(p)
    } else {
        p
    }
}

/// The lower half's fold (its own inverse): `(1 - |v|, 1 - |u|)` with the signs of `(u, v)`.
fn fold(p: Vec2) -> Vec2 {
    let sign = Vec2::new(if p.x >= 0.0 { 1.0 } else { -1.0 }, if p.y >= 0.0 { 1.0 } else { -1.0 });
    (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign
}

/// Step 4: the unit vector of a point of the square.
pub fn oct_unmap(p: Vec2) -> Vec3 {
    let z = 1.0 - p.x.abs() - p.y.abs();
    let xy = if z < 0.0 { fold(p) } else { p };
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// Step 3: a coordinate quantised to `bits` bits (`pack2x16snorm`'s rounding at 16).
pub fn quantise(c: f32, bits: u32) -> i32 {
    (0.5 + snorm_max(bits) * c.clamp(-1.0, 1.0)).floor() as i32
}

/// Step 3's reading: `max(q / m, -1)` (`unpack2x16snorm` at 16 bits).
pub fn dequantise(q: i32, bits: u32) -> f32 {
    (q as f32 / snorm_max(bits)).max(-1.0)
}

/// `n` encoded in two `bits`-bit signed coordinates.
pub fn encode(n: Vec3, bits: u32) -> (i32, i32) {
    let p = oct_map(n);
    (quantise(p.x, bits), quantise(p.y, bits))
}

/// The unit vector two `bits`-bit coordinates decode to.
pub fn decode(q: (i32, i32), bits: u32) -> Vec3 {
    oct_unmap(Vec2::new(dequantise(q.0, bits), dequantise(q.1, bits)))
}

/// `n` in one `u32` as WGSL's `pack2x16snorm(oct_map(n))` stores it: x in the low half.
pub fn encode_u32(n: Vec3) -> u32 {
    let (x, y) = encode(n, 16);
    (x as i16 as u16 as u32) | ((y as i16 as u16 as u32) << 16)
}

/// The unit vector of a `u32` written by [`encode_u32`] (`unpack2x16snorm`, then unmap).
pub fn decode_u32(bits: u32) -> Vec3 {
    decode(((bits & 0xffff) as u16 as i16 as i32, (bits >> 16) as u16 as i16 as i32), 16)
}

/// The largest angle, in radians, between a unit vector and its decoded `bits`-bit code
/// (module doc): `3 sqrt(2) / (2 m)`, plus 1e-6 for the f32 arithmetic of both ends.
pub fn angular_error_bound(bits: u32) -> f64 {
    3.0 * std::f64::consts::SQRT_2 / (2.0 * f64::from(snorm_max(bits))) + 1e-6
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The angle between two vectors in f64 (atan2, accurate near 0, unlike f32 acos).
    fn angle(a: Vec3, b: Vec3) -> f64 {
        let (a, b): (glam::DVec3, glam::DVec3) = (a.as_dvec3(), b.as_dvec3());
        a.cross(b).length().atan2(a.dot(b))
    }

    #[test]
    fn axes_and_the_seam_round_trip() {
        for n in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            assert!(angle(decode(encode(n, 16), 16), n) < 1e-6, "{n}");
            assert_eq!(decode_u32(encode_u32(n)), decode(encode(n, 16), 16));
        }
        // The equator, where the fold meets the diamond, from both sides.
        for z in [1e-7f32, 0.0, -0.0, -1e-7] {
            let n = Vec3::new(0.6, 0.8, z).normalize();
            assert!(angle(decode(encode(n, 16), 16), n) <= angular_error_bound(16), "z {z}");
        }
    }

    #[test]
    fn extreme_lengths_and_bad_input_encode_sanely() {
        let n = Vec3::new(0.3, -0.5, -0.8).normalize();
        for scale in [1e-38f32, 1e-20, 1.0, 1e20, 3e38] {
            assert_eq!(encode(n * scale, 16), encode(n, 16), "scale {scale}");
        }
        for bad in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::NAN, 0.5, -0.5), Vec3::new(f32::INFINITY, 0.0, 0.0)] {
            assert_eq!(decode(encode(bad, 16), 16), Vec3::Z, "{bad}");
        }
        // Out-of-range codes read back in range (the most negative one as -1).
        assert_eq!(dequantise(-32768, 16), -1.0);
        assert!(decode((i32::from(i16::MIN), i32::from(i16::MIN)), 16).is_normalized());
    }

    #[test]
    fn codes_are_stable_under_re_encoding() {
        // Decoding and encoding again gives the same code inside the square (its border is
        // where the fold names one direction twice: the four corners are all -Z), and the
        // same direction everywhere: a G-buffer read and written again does not drift.
        for x in (-32767..=32767).step_by(4099).chain([-32767, 32767]) {
            for y in (-32767..=32767).step_by(3217).chain([-32767, 0, 32767]) {
                let q = (x, y);
                let again = encode(decode(q, 16), 16);
                if x.abs() < 32767 && y.abs() < 32767 {
                    assert_eq!(again, q);
                }
                let turn = angle(decode(again, 16), decode(q, 16));
                assert!(turn < 1e-6, "{q:?} -> {again:?} turns {turn}");
            }
        }
    }

    #[test]
    fn the_u32_is_pack2x16snorm() {
        // pack2x16snorm(vec2(1, -1)) = 0x8001_7fff; (0.5, 0) -> round(16383.5) = 16384.
        assert_eq!((quantise(1.0, 16), quantise(-1.0, 16), quantise(0.5, 16)), (32767, -32767, 16384));
        let n = Vec3::new(1.0, -1.0, 0.0).normalize();
        assert_eq!(oct_map(n), Vec2::new(0.5, -0.5));
        assert_eq!(encode_u32(n), (16384u32) | ((-16383i16 as u16 as u32) << 16));
    }
}
