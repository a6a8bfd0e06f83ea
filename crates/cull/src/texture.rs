//! Material texture sampling as the shaders do it (`shaders/common/material_textures.wgsl`),
//! the CPU twin: the mip chain every image is uploaded with, and a sample of it through a
//! glTF sampler at texture coordinates with their screen-space gradients.
//!
//! 1. **Mip chain** ([`mip_chain`]): each level halves the previous one (rounding down, at
//!    least 1), each texel the area average of the texels it covers (a fractional box for
//!    odd sizes), computed in linear light (sRGB colour decoded first, encoded back) so a
//!    minified texture keeps its brightness.
//! 2. **Level** ([`Mips::sample`]): `λ = log2(ρ)`, `ρ` the longer of the two gradients in
//!    texels of level 0 (isotropic: the samplers have no anisotropy). `λ ≤ 0` (or not a
//!    number) magnifies: level 0 with the magnification filter. Otherwise the
//!    minification filter on level 0 without mipmapping, on the nearest level
//!    (`ceil(λ + 0.5) - 1`, Vulkan's rounding) or between the two nearest (linear), levels
//!    past the image's last clamped to it.
//! 3. **Texels** ([`Mips::filter`]): the coordinate first reduced to one period of its
//!    wrap mode (repeat: `[0, 1)`, mirrored: `[0, 2)`, clamp: `[-1, 2]`), so a coordinate far
//!    from the origin keeps its sub-texel precision; nearest takes the texel holding it,
//!    linear the four around it (half-texel offset) with bilinear weights; every texel
//!    index is wrapped on integers within the image's own size ([`wrap_texel`]), so any
//!    index, however wild, reads a texel of the image.
//!
//! Depends on glam and [`crate::gbuffer`]'s sRGB transfer functions.

use glam::{Vec2, Vec4};

use crate::gbuffer::{linear_to_srgb, srgb_to_linear};

/// Wrap code: repeat.
pub const WRAP_REPEAT: u32 = 0;
/// Wrap code: mirrored repeat.
pub const WRAP_MIRROR: u32 = 1;
/// Wrap code: clamp to edge.
pub const WRAP_CLAMP: u32 = 2;
/// Mipmap code: level 0 only.
pub const MIPMAP_NONE: u32 = 0;
/// Mipmap code: the nearest level.
pub const MIPMAP_NEAREST: u32 = 1;
/// Mipmap code: between the two nearest levels.
pub const MIPMAP_LINEAR: u32 = 2;

/// A sampler as the shaders read it (bits 0-7 of a texture slot's `sampling`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampling {
    /// Wrap codes along u and v.
    pub wrap: [u32; 2],
    /// Magnification filter: linear (else nearest).
    pub mag_linear: bool,
    /// Minification filter within a level: linear (else nearest).
    pub min_linear: bool,
    /// Mipmap code.
    pub mipmap: u32,
}

impl Sampling {
    /// The packed bits: wrap u (0-1), wrap v (2-3), mag (4), min (5), mipmap (6-7).
    pub fn bits(&self) -> u32 {
        self.wrap[0]
            | (self.wrap[1] << 2)
            | (u32::from(self.mag_linear) << 4)
            | (u32::from(self.min_linear) << 5)
            | (self.mipmap << 6)
    }

    /// The sampler of packed `bits`.
    pub fn from_bits(bits: u32) -> Self {
        Self {
            wrap: [bits & 3, (bits >> 2) & 3],
            mag_linear: (bits >> 4) & 1 != 0,
            min_linear: (bits >> 5) & 1 != 0,
            mipmap: (bits >> 6) & 3,
        }
    }
}

/// Texel index `i` wrapped into `0..n` by wrap code `mode` (any `i`, any `n >= 1`).
pub fn wrap_texel(i: i32, n: i32, mode: u32) -> i32 {
    let n = n.max(1);
    match mode {
        WRAP_REPEAT => i.rem_euclid(n),
        WRAP_MIRROR => {
            let t = i.rem_euclid(2 * n);
            if t >= n {
                2 * n - 1 - t
            } else {
                t
            }
        }
        _ => i.clamp(0, n - 1),
    }
}

/// Coordinate `x` reduced to one period of wrap code `mode` (step 3); a coordinate that is
/// not a finite number reads as 0 (the comparison below is false for NaN).
pub fn reduce(x: f32, mode: u32) -> f32 {
    let (r, lo, hi) = match mode {
        WRAP_REPEAT => (x - x.floor(), 0.0, 1.0),
        WRAP_MIRROR => (x - 2.0 * (x * 0.5).floor(), 0.0, 2.0),
        _ => (x.clamp(-1.0, 2.0), -1.0, 2.0),
    };
    if r >= lo && r <= hi {
        r
    } else {
        0.0
    }
}

/// The size of level `level` of a `width` x `height` image.
pub fn level_size(width: u32, height: u32, level: u32) -> (u32, u32) {
    ((width >> level).max(1), (height >> level).max(1))
}

/// The number of levels of a full chain (down to 1x1).
pub fn mip_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// One axis of the area average: `src` rows of `n_in` texels (stride `stride` between
/// texels along the axis) into `n_out`.
fn box_weights(n_in: u32, n_out: u32) -> Vec<Vec<(usize, f32)>> {
    let scale = n_in as f64 / n_out as f64;
    (0..n_out)
        .map(|o| {
            let (a, b) = (o as f64 * scale, (o + 1) as f64 * scale);
            let mut w = Vec::new();
            let mut i = a.floor() as u32;
            while (i as f64) < b && i < n_in {
                let cover = (b.min(i as f64 + 1.0) - a.max(i as f64)) / scale;
                if cover > 0.0 {
                    w.push((i as usize, cover as f32));
                }
                i += 1;
            }
            w
        })
        .collect()
}

/// The decoded (linear) value of RGBA8 texel bytes: rgb through the sRGB curve when `srgb`.
pub fn decode(texel: [u8; 4], srgb: bool) -> Vec4 {
    let c = |b: u8| {
        let v = b as f32 / 255.0;
        if srgb {
            srgb_to_linear(v)
        } else {
            v
        }
    };
    Vec4::new(c(texel[0]), c(texel[1]), c(texel[2]), texel[3] as f32 / 255.0)
}

fn encode(v: Vec4, srgb: bool) -> [u8; 4] {
    let c = |x: f32, curve: bool| {
        let x = if curve { linear_to_srgb(x.clamp(0.0, 1.0)) } else { x.clamp(0.0, 1.0) };
        (x * 255.0).round() as u8
    };
    [c(v.x, srgb), c(v.y, srgb), c(v.z, srgb), c(v.w, false)]
}

/// The mip chain of an RGBA8 image (step 1): `(width, height, texels)` per level, level 0
/// the image itself.
pub fn mip_chain(width: u32, height: u32, rgba: &[u8], srgb: bool) -> Vec<(u32, u32, Vec<u8>)> {
    let mut levels = vec![(width, height, rgba.to_vec())];
    for level in 1..mip_count(width, height) {
        let (pw, ph, prev) = levels.last().expect("level 0");
        let (pw, ph) = (*pw, *ph);
        let (w, h) = level_size(width, height, level);
        let texel = |x: usize, y: usize| {
            let at = (y * pw as usize + x) * 4;
            decode([prev[at], prev[at + 1], prev[at + 2], prev[at + 3]], srgb)
        };
        let (wx, wy) = (box_weights(pw, w), box_weights(ph, h));
        let mut out = Vec::with_capacity((w * h * 4) as usize);
        for row in &wy {
            for col in &wx {
                let mut sum = Vec4::ZERO;
                for &(y, fy) in row {
                    for &(x, fx) in col {
                        sum += texel(x, y) * (fx * fy);
                    }
                }
                out.extend_from_slice(&encode(sum, srgb));
            }
        }
        levels.push((w, h, out));
    }
    levels
}

/// An image's levels, decoded to linear values: what a sample reads.
#[derive(Clone, Debug)]
pub struct Mips {
    levels: Vec<(u32, u32, Vec<Vec4>)>,
}

impl Mips {
    /// The decoded mip chain of an RGBA8 image read as sRGB colour or linear data.
    pub fn new(width: u32, height: u32, rgba: &[u8], srgb: bool) -> Self {
        let levels = mip_chain(width, height, rgba, srgb)
            .into_iter()
            .map(|(w, h, t)| (w, h, t.chunks_exact(4).map(|c| decode([c[0], c[1], c[2], c[3]], srgb)).collect()))
            .collect();
        Self { levels }
    }

    /// Texel `(x, y)` of `level` (indices already wrapped).
    pub fn texel(&self, level: usize, x: i32, y: i32) -> Vec4 {
        let (w, _, t) = &self.levels[level];
        t[y as usize * *w as usize + x as usize]
    }

    /// The level [`Mips::sample`] reads and the filter it reads it with, as (first level,
    /// second level, weight of the second, linear filter within the level): step 2.
    pub fn levels(&self, s: Sampling, dx: Vec2, dy: Vec2) -> (usize, usize, f32, bool) {
        let (w, h, _) = self.levels[0];
        let size = Vec2::new(w as f32, h as f32);
        let rho = (dx * size).length().max((dy * size).length());
        let lambda = rho.log2();
        let last = (self.levels.len() - 1) as f32;
        // Magnified, or not a number (NaN gradients): level 0 with the magnification filter.
        if lambda.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return (0, 0, 0.0, s.mag_linear);
        }
        match s.mipmap {
            MIPMAP_NEAREST => {
                let l = ((lambda + 0.5).ceil() - 1.0).clamp(0.0, last) as usize;
                (l, l, 0.0, s.min_linear)
            }
            MIPMAP_LINEAR => {
                let d = lambda.min(last);
                let l0 = d.floor();
                let l1 = (l0 + 1.0).min(last);
                (l0 as usize, l1 as usize, d - l0, s.min_linear)
            }
            _ => (0, 0, 0.0, s.min_linear),
        }
    }

    /// The filtered value of `level` at `uv` (step 3).
    pub fn filter(&self, level: usize, s: Sampling, uv: Vec2, linear: bool) -> Vec4 {
        let (w, h, _) = self.levels[level];
        let (n, size) = ([w as i32, h as i32], [w as f32, h as f32]);
        let u = [reduce(uv.x, s.wrap[0]), reduce(uv.y, s.wrap[1])];
        let at = |a: usize, i: i32| wrap_texel(i, n[a], s.wrap[a]);
        if !linear {
            let (x, y) = ((u[0] * size[0]).floor() as i32, (u[1] * size[1]).floor() as i32);
            return self.texel(level, at(0, x), at(1, y));
        }
        let p = [u[0] * size[0] - 0.5, u[1] * size[1] - 0.5];
        let i0 = [p[0].floor(), p[1].floor()];
        let f = [p[0] - i0[0], p[1] - i0[1]];
        let (x0, y0) = (i0[0] as i32, i0[1] as i32);
        // The four taps' weighted sum, in the shader's order.
        let mut sum = Vec4::ZERO;
        for k in 0..4 {
            let (ox, oy) = (k & 1, k >> 1);
            let wx = if ox == 1 { f[0] } else { 1.0 - f[0] };
            let wy = if oy == 1 { f[1] } else { 1.0 - f[1] };
            sum += wx * wy * self.texel(level, at(0, x0.wrapping_add(ox)), at(1, y0.wrapping_add(oy)));
        }
        sum
    }

    /// The sample at `uv` with screen-space gradients `dx`, `dy` through `s` (module doc).
    pub fn sample(&self, s: Sampling, uv: Vec2, dx: Vec2, dy: Vec2) -> Vec4 {
        let (l0, l1, t, linear) = self.levels(s, dx, dy);
        let a = self.filter(l0, s, uv, linear);
        if t > 0.0 {
            (1.0 - t) * a + t * self.filter(l1, s, uv, linear)
        } else {
            a
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn checker(w: u32, h: u32) -> Vec<u8> {
        (0..w * h)
            .flat_map(|i| if (i % w + i / w).is_multiple_of(2) { [255, 0, 0, 255] } else { [0, 0, 255, 0] })
            .collect()
    }

    const LINEAR_REPEAT: Sampling =
        Sampling { wrap: [WRAP_REPEAT, WRAP_REPEAT], mag_linear: true, min_linear: true, mipmap: MIPMAP_LINEAR };

    #[test]
    fn wraps_match_their_definitions() {
        let n = 5;
        for i in -12..12 {
            assert_eq!(wrap_texel(i, n, WRAP_REPEAT), ((i % n) + n) % n);
            assert_eq!(wrap_texel(i, n, WRAP_CLAMP), i.clamp(0, n - 1));
        }
        // Mirrored: 0 1 2 3 4 4 3 2 1 0 0 1 ..., and -1 reads 0.
        let m: Vec<i32> = (0..12).map(|i| wrap_texel(i, n, WRAP_MIRROR)).collect();
        assert_eq!(m, vec![0, 1, 2, 3, 4, 4, 3, 2, 1, 0, 0, 1]);
        assert_eq!(wrap_texel(-1, n, WRAP_MIRROR), 0);
        assert_eq!(wrap_texel(-6, n, WRAP_MIRROR), 4);
        for mode in [WRAP_REPEAT, WRAP_MIRROR, WRAP_CLAMP] {
            for i in [i32::MIN, i32::MIN + 1, i32::MAX] {
                assert!((0..n).contains(&wrap_texel(i, n, mode)), "{i} {mode}");
            }
        }
    }

    #[test]
    fn mip_chain_averages_in_linear_light_and_handles_odd_sizes() {
        let levels = mip_chain(4, 2, &checker(4, 2), true);
        assert_eq!(levels.iter().map(|l| (l.0, l.1)).collect::<Vec<_>>(), vec![(4, 2), (2, 1), (1, 1)]);
        // Half full red, half black in linear light: linear 0.5 is sRGB 188, not 128.
        assert_eq!(levels[1].2[0], 188);
        assert_eq!(levels[1].2[2], 188);
        assert_eq!(levels[1].2[3], 128);
        let linear = mip_chain(4, 2, &checker(4, 2), false);
        assert_eq!(linear[1].2[0], 128);
        // A uniform image keeps its value at every level, in either space: mid-grey sRGB
        // 128 decoded, averaged and encoded back is 128 again.
        let grey = vec![128u8; 4 * 4 * 4];
        for srgb in [true, false] {
            assert!(mip_chain(4, 4, &grey, srgb).iter().all(|(_, _, t)| t.iter().all(|&b| b == 128)), "{srgb}");
        }
        // sRGB 128 averaged with 255 in linear light is sRGB 205, not (128 + 255) / 2 = 192.
        let pair = [128u8, 128, 128, 255, 255, 255, 255, 255];
        assert_eq!(mip_chain(2, 1, &pair, true)[1].2[0], 205);
        // 3 texels into 1: each weighs a third.
        let row = [30u8, 0, 0, 0, 60, 0, 0, 0, 90, 0, 0, 0];
        assert_eq!(mip_chain(3, 1, &row, false)[1].2[0], 60);
        // 5 into 2: (10 + 20 + 15) / 2.5 and (15 + 40 + 50) / 2.5.
        let row: Vec<u8> = [10u8, 20, 30, 40, 50].iter().flat_map(|&v| [v, 0, 0, 0]).collect();
        let l1 = &mip_chain(5, 1, &row, false)[1].2;
        assert_eq!((l1[0], l1[4]), (18, 42));
    }

    #[test]
    fn magnified_linear_sampling_is_bilinear_and_wraps_per_mode() {
        let bytes: Vec<u8> = [0u8, 100, 200, 250].iter().flat_map(|&v| [v, v, v, 255]).collect();
        let mips = Mips::new(4, 1, &bytes, false);
        let zero = Vec2::ZERO;
        let at = |s: Sampling, u: f32| mips.sample(s, Vec2::new(u, 0.5), zero, zero).x * 255.0;
        // Texel centres read their texel; between two, the mean.
        assert!((at(LINEAR_REPEAT, 0.375) - 100.0).abs() < 1e-3);
        assert!((at(LINEAR_REPEAT, 0.5) - 150.0).abs() < 1e-3);
        // At u = 0 repeat blends the last and first texels, mirror and clamp read the first.
        assert!((at(LINEAR_REPEAT, 0.0) - 125.0).abs() < 1e-3);
        let mirror = Sampling { wrap: [WRAP_MIRROR, WRAP_REPEAT], ..LINEAR_REPEAT };
        let clamp = Sampling { wrap: [WRAP_CLAMP, WRAP_REPEAT], ..LINEAR_REPEAT };
        assert!(at(mirror, 0.0).abs() < 1e-3 && at(clamp, 0.0).abs() < 1e-3);
        // Far from the origin: repeat keeps the same value (the coordinate is reduced first).
        assert!((at(LINEAR_REPEAT, 40_000.5) - 150.0).abs() < 0.5);
        // Mirror beyond 1 reads backwards; clamp stays at the edge.
        assert!((at(mirror, 1.125) - 250.0).abs() < 1e-3);
        assert!((at(clamp, 7.0) - 250.0).abs() < 1e-3);
        let nearest = Sampling { mag_linear: false, ..LINEAR_REPEAT };
        assert!((at(nearest, 0.49) - 100.0).abs() < 1e-3);
    }

    #[test]
    fn levels_follow_the_gradients_and_the_mipmap_mode() {
        let mips = Mips::new(16, 16, &checker(16, 16), false);
        let g = |texels: f32| Vec2::new(texels / 16.0, 0.0);
        assert_eq!(mips.levels(LINEAR_REPEAT, g(1.0), Vec2::ZERO), (0, 0, 0.0, true));
        let (l0, l1, t, _) = mips.levels(LINEAR_REPEAT, g(2.0f32.powf(2.25)), Vec2::ZERO);
        assert_eq!((l0, l1), (2, 3));
        assert!((t - 0.25).abs() < 1e-5);
        // Past the last level: the last, alone.
        assert_eq!(mips.levels(LINEAR_REPEAT, g(1e6), Vec2::ZERO).0, 4);
        let nearest = Sampling { mipmap: MIPMAP_NEAREST, ..LINEAR_REPEAT };
        assert_eq!(mips.levels(nearest, g(2.0f32.powf(2.5)), Vec2::ZERO).0, 2);
        assert_eq!(mips.levels(nearest, g(2.0f32.powf(2.51)), Vec2::ZERO).0, 3);
        let none = Sampling { mipmap: MIPMAP_NONE, min_linear: false, ..LINEAR_REPEAT };
        assert_eq!(mips.levels(none, g(64.0), Vec2::ZERO), (0, 0, 0.0, false));
        // A minified linear sample of the checker is its mean colour.
        let v = mips.sample(LINEAR_REPEAT, Vec2::splat(0.3), g(16.0), Vec2::ZERO);
        assert!((v - Vec4::new(0.5, 0.0, 0.5, 0.5)).abs().max_element() < 1.0 / 255.0, "{v}");
        // The longer gradient decides, whichever axis it is on.
        assert_eq!(mips.levels(LINEAR_REPEAT, Vec2::ZERO, Vec2::new(0.0, 4.0 / 16.0)).0, 2);
    }

    proptest! {
        /// Any coordinate and gradient, however extreme or not a number, reads a finite
        /// value within the image's range: no index leaves the image.
        #[test]
        fn any_input_reads_inside_the_image(
            u in prop_oneof![-1e30f32..1e30, -4.0f32..4.0, Just(f32::NAN), Just(f32::INFINITY)],
            v in prop_oneof![-1e30f32..1e30, -4.0f32..4.0, Just(f32::NEG_INFINITY)],
            d in prop_oneof![0.0f32..1e9, Just(f32::NAN), Just(0.0)],
            wrap_u in 0u32..3, wrap_v in 0u32..3, bits in 0u32..16,
            w in 1u32..9, h in 1u32..9,
        ) {
            let s = Sampling {
                wrap: [wrap_u, wrap_v],
                mag_linear: bits & 1 != 0,
                min_linear: bits & 2 != 0,
                mipmap: (bits >> 2) % 3,
            };
            let mips = Mips::new(w, h, &checker(w, h), false);
            let r = mips.sample(s, Vec2::new(u, v), Vec2::new(d, 0.0), Vec2::new(0.0, d));
            prop_assert!(r.is_finite() && r.min_element() >= 0.0 && r.max_element() <= 1.0, "{r}");
        }
    }
}
