//! The stochastic method's light sampler on the CPU (issue 48: every light shadowed): the
//! twin its WGSL will be checked against, and the place its unbiasedness is proven.
//! Resampled importance sampling (Talbot et al. 2005) with a weighted reservoir (Chao
//! 1982), as ReSTIR DI (Bitterli et al. 2020) starts each pixel; `../shared/DESIGN.md`,
//! "Stochastic many-light shadows".
//!
//! 1. **Candidates.** `M` lights drawn uniformly (`q = 1 / N`) from the pixel's candidate
//!    set (its tile's list, or every light), each draw from [`rand01`] of a hash of (pixel,
//!    frame, draw), so the GPU can draw the same ([`resample`]). The method draws from two
//!    sources that split the lights ([`resample_near_far`]): the pixel's list for the
//!    lights whose radius reaches it (stratified, [`near_draw`]: with as many candidates as
//!    the list is long, every light in it once), every light for the rest (uniformly, or
//!    from a [`FarSource`] such as `crate::light_tree::LightTree`, with its own draw).
//! 2. **Target.** `p_hat(l)`: the luminance of the light's unshadowed contribution at the
//!    surface point ([`unshadowed`]: `brdf_cos` x radiance x attenuation x cone), the
//!    integrand without its visibility; positive wherever the integrand is.
//! 3. **Reservoir.** Each candidate enters with weight `w = p_hat / q`; the reservoir keeps
//!    one with probability `w / w_sum` ([`Reservoir::update`]), its `w_sum` and `M`. Two
//!    reservoirs of one pixel merge into one of `M1 + M2` candidates
//!    ([`Reservoir::merge`], the step spatial and temporal reuse build on).
//! 4. **Estimate.** One shadow ray to the kept light `y`: the pixel's light is
//!    `f(y) V(y) W` with `W = w_sum / (M p_hat(y))` ([`Reservoir::weight`]), an unbiased
//!    estimate of `sum_l f(l) V(l)` over the candidate set; with `M` candidates its
//!    variance falls as the target approaches `f V`. With K rays
//!    ([`resample_near_far_rays`]) K reservoirs take the same candidates, their numbers
//!    shifted apart ([`ray_number`]), and the pixel's light is the mean of their K
//!    estimates.
//!
//! Depends on this crate's light and brdf modules only (the shadow ray is the caller's:
//! the tests use [`crate::raycast::Triangles`], the GPU its BVH).

use glam::Vec3;

use crate::brdf::{brdf_cos, spot_falloff, unwindowed_attenuation, windowed_attenuation, Surface};
use crate::light::{spot_scale_offset, Light, LightKind};

/// One step of the PCG hash (O'Neill's `pcg32` output permutation on an LCG step, as in
/// Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020): the same integers
/// on the CPU and in WGSL.
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A uniform number in [0, 1) for draw `draw` of `pixel` in `frame`: 24 bits of a hash of
/// the three (exact in f32, so the GPU's is the same).
pub fn rand01(pixel: u32, frame: u32, draw: u32) -> f32 {
    let h = pcg_hash(pixel ^ pcg_hash(frame ^ pcg_hash(draw)));
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// A light's contribution at surface point `p` (unit normal `n`, unit direction to the eye
/// `v`, surface `s`) without its shadow: radiance x attenuation (windowed at the light's
/// radius with `cutoff`, plain inverse-square without) x spot cone x `brdf_cos`.
pub fn unshadowed(light: &Light, (p, n, v): (Vec3, Vec3, Vec3), s: &Surface, cutoff: bool) -> Vec3 {
    let to = light.position - p;
    let d2 = to.length_squared();
    if d2 <= 0.0 {
        return Vec3::ZERO;
    }
    let l = to / d2.sqrt();
    let attenuation = if cutoff { windowed_attenuation(d2, light.radius) } else { unwindowed_attenuation(d2) };
    let cone = match light.kind {
        LightKind::Point => 1.0,
        LightKind::Spot { direction, inner_angle, outer_angle } => {
            let (scale, offset) = spot_scale_offset(inner_angle, outer_angle);
            spot_falloff((-l).dot(direction), scale, offset)
        }
    };
    light.color * light.intensity * attenuation * cone * brdf_cos(n, v, l, s)
}

/// Rec. 709 luminance: the scalar target of a colour ([`crate::exposure::luminance`]).
pub fn luminance(c: Vec3) -> f32 {
    crate::exposure::luminance(c.to_array())
}

/// A weighted reservoir holding one light (step 3).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reservoir {
    /// The kept light's index into the candidate set (meaningless while `w_sum` is 0).
    pub light: u32,
    /// Its target `p_hat` at this pixel.
    pub p_hat: f32,
    /// Sum of the candidates' weights.
    pub w_sum: f32,
    /// Candidates seen.
    pub m: u32,
}

impl Reservoir {
    /// Offers candidate `light` with weight `w` (`p_hat / q`) and target `p_hat`; `u` in
    /// [0, 1) decides whether it replaces the kept one (probability `w / w_sum`).
    pub fn update(&mut self, light: u32, (w, p_hat): (f32, f32), u: f32) {
        self.w_sum += w;
        self.m += 1;
        if w > 0.0 && u * self.w_sum < w {
            self.light = light;
            self.p_hat = p_hat;
        }
    }

    /// Merges `other` (a reservoir of the same pixel, so the same target) into this one: it
    /// enters as one candidate of weight `p_hat(y) W M`, which is its `w_sum`, and the
    /// counts add.
    pub fn merge(&mut self, other: &Reservoir, u: f32) {
        let m = self.m;
        self.update(other.light, (other.w_sum, other.p_hat), u);
        self.m = m + other.m;
    }

    /// The unbiased contribution weight `W = w_sum / (M p_hat(y))` (0 when nothing was
    /// kept: every candidate had a zero target).
    pub fn weight(&self) -> f32 {
        if self.m == 0 || self.p_hat <= 0.0 {
            0.0
        } else {
            self.w_sum / (self.m as f32 * self.p_hat)
        }
    }
}

/// Steps 1-3 for one pixel: `m` candidates drawn uniformly from `candidates` (indices into
/// `lights`), resampled by their target at the surface `(p, n, v)` of `s`. Draw `k` of the
/// pixel uses `rand01(pixel, frame, 2k)` to pick and `2k + 1` to resample.
pub fn resample(
    lights: &[Light],
    candidates: &[u32],
    (p, n, v): (Vec3, Vec3, Vec3),
    s: &Surface,
    (m, cutoff): (u32, bool),
    (pixel, frame): (u32, u32),
) -> Reservoir {
    let mut r = Reservoir::default();
    if candidates.is_empty() {
        return r;
    }
    let n_cand = candidates.len() as u32;
    let q = 1.0 / n_cand as f32;
    for k in 0..m {
        let i = ((rand01(pixel, frame, 2 * k) * n_cand as f32) as u32).min(n_cand - 1);
        let light = candidates[i as usize];
        let p_hat = luminance(unshadowed(&lights[light as usize], (p, n, v), s, cutoff));
        r.update(light, (p_hat / q, p_hat), rand01(pixel, frame, 2 * k + 1));
    }
    r
}

/// True when the point `p` is inside `light`'s radius: the lights whose windowed
/// contribution can be non-zero there, every one of which the culling puts in the list of
/// the pixel's tile (no false negatives). `shaders/common/stochastic_shade.wgsl`'s
/// `reaches`, the same comparison as the windowed falloff's `in_range`.
pub fn reaches(light: &Light, p: Vec3) -> bool {
    (light.position - p).length_squared() < light.radius * light.radius
}

/// The near candidates a pixel draws from a list of `count` lights when `candidates` are
/// asked for: as many, at most one a light (0 for an empty list).
pub fn near_count(candidates: u32, count: u32) -> u32 {
    candidates.min(count)
}

/// Near draw `k` of `m` (`m` at most `count`, from [`near_count`]) over a list of `count`
/// lights, with `u` in [0, 1): the list is cut into `m` strata of consecutive entries
/// (stratum `k` from `k count / m` to `(k + 1) count / m`, integer division, so sizes differ
/// by at most one) and one entry is drawn uniformly from stratum `k`. Returns the entry and
/// the stratum's size `s`: the entry's probability is `1 / s`, so the candidate's RIS
/// weight is `p_hat s` (scaled as [`resample_near_far`] says).
/// Stratified draws never repeat an entry in one frame and, with `m = count`, take every
/// entry once: the near lights' unshadowed sum is then exact and the kept light is drawn in
/// proportion to its contribution, so only the shadows are left to noise (a light that
/// nearly touches the surface no longer makes fireflies when a uniform draw misses it).
/// Integer maths without overflow for `count` up to `u32::MAX` and `m` up to 65,536 (the
/// GPU has no 64-bit integers): `k count / m = k (count / m) + k (count % m) / m`.
pub fn near_draw(k: u32, m: u32, count: u32, u: f32) -> (u32, u32) {
    let start = |k: u32| k * (count / m) + k * (count % m) / m;
    let (first, end) = (start(k), start(k + 1));
    let size = end - first;
    let i = ((u * size as f32) as u32).min(size - 1);
    (first + i, size)
}

/// The most shadow rays a pixel casts a frame (the `rays` setting): each of its picks is a
/// reservoir over the same candidates ([`resample_near_far_rays`]).
pub const MAX_RAYS: u32 = 8;

/// The number pick `j` of `rays` decides a candidate with, where pick 0 used `u` (from
/// [`rand01`], a multiple of 2^-24): `u` shifted by `j / rays` of the unit interval and
/// wrapped, in 24-bit integers so the GPU's is the same bit for bit. Each pick's numbers are
/// uniform (a shift is a bijection), so each pick alone is a reservoir as pick 0 is; shifted
/// together they are stratified, so the picks spread over the candidates' weights rather
/// than repeat the heaviest.
pub fn ray_number(u: f32, j: u32, rays: u32) -> f32 {
    let i = (u * 16_777_216.0) as u32;
    let step = (1u32 << 24) / rays;
    (i.wrapping_add(j.wrapping_mul(step)) & 0xFF_FFFF) as f32 / 16_777_216.0
}

/// Steps 1-3 with two candidate sources whose domains split the lights (the method's
/// sampler): `m_near` candidates drawn stratified from the pixel's `list` ([`near_draw`]:
/// at most one a light; the light grid's list holds every light that [`reaches`] the
/// point) that count only when they reach it, and `m_far` drawn uniformly from every light
/// that count only when they do not. Each
/// candidate's weight is `p_hat / (q_s M_s)` for its source `s` (the generalised RIS of
/// Lin et al. 2022 with disjoint domains: a light is made by one source only), scaled by
/// the reservoir's total `M` so that [`Reservoir::weight`] (which divides by it) is the
/// estimator's `W`. The near lights' share then costs few candidates (a short list) and
/// the far lights' share (beyond the radius: what the cutoff drops) is still sampled;
/// `m_far = 0` drops it (the cutoff's bias). Draw `k` (near first, then far) uses
/// `rand01(pixel, frame, 2k)` to pick and `2k + 1` to resample. With `tree` the far
/// candidates are drawn from it (a [`FarSource`]: the light tree draws in proportion to
/// each light's power over its distance, with draw `2k`'s level numbers), weighed by one
/// over their probability; without, uniformly from every light.
pub fn resample_near_far(
    lights: &[Light],
    list: &[u32],
    (p, n, v): (Vec3, Vec3, Vec3),
    s: &Surface,
    (m_near, m_far): (u32, u32),
    (pixel, frame): (u32, u32),
    tree: Option<&dyn FarSource>,
) -> Reservoir {
    resample_near_far_rays(lights, list, (p, n, v), s, (m_near, m_far), (pixel, frame), (tree, 1))[0]
}

/// [`resample_near_far`] with `rays` picks (at most [`MAX_RAYS`]): as many reservoirs over
/// the same candidates, pick `j` deciding with [`ray_number`]`(u, j, rays)` where pick 0
/// decides with `u`. Each is the estimator's reservoir on its own; the pixel's light is the
/// mean of their estimates (one shadow ray each): `rays` times the rays for the shading of
/// one set of candidates. Pick 0 is [`resample_near_far`]'s.
pub fn resample_near_far_rays(
    lights: &[Light],
    list: &[u32],
    (p, n, v): (Vec3, Vec3, Vec3),
    s: &Surface,
    (m_near, m_far): (u32, u32),
    (pixel, frame): (u32, u32),
    (tree, rays): (Option<&dyn FarSource>, u32),
) -> Vec<Reservoir> {
    let mut picks = vec![Reservoir::default(); rays as usize];
    let m_near = near_count(m_near, list.len() as u32);
    let total = (m_near + m_far) as f32;
    let sources: [(u32, u32, bool); 2] = [(m_near, list.len() as u32, true), (m_far, lights.len() as u32, false)];
    let mut draw = 0;
    for (m, count, near) in sources {
        for k in 0..m {
            let u = rand01(pixel, frame, 2 * draw);
            let i = ((u * count as f32) as u32).min(count - 1);
            // The light and one over its probability (from a stratum of the list, one over
            // the probability a uniform draw of the same weight would have: the stratum's
            // size times the draws).
            let (light, inv_q) = match (near, tree) {
                (true, _) => {
                    let (i, size) = near_draw(k, m, count, u);
                    (list[i as usize], size as f32 * m as f32)
                }
                (false, None) => (i, count as f32),
                (false, Some(t)) => {
                    match t.draw(p, (pixel, frame, 2 * draw), &|l, q| reaches(&lights[l as usize], q)) {
                        Some((l, q)) if q > 0.0 => (l, 1.0 / q),
                        _ => (0, 0.0),
                    }
                }
            };
            let l = &lights[light as usize];
            let p_hat =
                if reaches(l, p) == near && inv_q > 0.0 { luminance(unshadowed(l, (p, n, v), s, false)) } else { 0.0 };
            let (w, u) = (p_hat * inv_q * total / m as f32, rand01(pixel, frame, 2 * draw + 1));
            for (j, r) in picks.iter_mut().enumerate() {
                r.update(light, (w, p_hat), ray_number(u, j as u32, rays));
            }
            draw += 1;
        }
    }
    picks
}

/// A source of far candidates other than uniform draws (`crate::light_tree::LightTree`):
/// a light and its probability at point `p`, drawn with the numbers of draw `draw` of
/// `pixel` in `frame`, the lights that `reaches(light, p)` (the list's) left out.
pub trait FarSource {
    /// One draw; None when the source has no light to give.
    fn draw(&self, p: Vec3, draws: (u32, u32, u32), reaches: &dyn Fn(u32, Vec3) -> bool) -> Option<(u32, f32)>;
}

/// Step 4: the pixel's light from reservoir `r`, `f(y) V(y) W`, with `visible(light)` the
/// shadow ray's answer (called once, for the kept light only; not at all when nothing was
/// kept).
pub fn estimate(
    lights: &[Light],
    r: &Reservoir,
    (p, n, v): (Vec3, Vec3, Vec3),
    s: &Surface,
    cutoff: bool,
    visible: impl FnOnce(u32) -> bool,
) -> Vec3 {
    let w = r.weight();
    if w <= 0.0 || !visible(r.light) {
        return Vec3::ZERO;
    }
    unshadowed(&lights[r.light as usize], (p, n, v), s, cutoff) * w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hash spreads neighbouring inputs and its numbers fill [0, 1): the mean of 20,000
    /// draws is 1/2 within 1%, none reaches 1.
    #[test]
    fn the_hash_draws_uniform_numbers() {
        let xs: Vec<f32> = (0..20_000).map(|i| rand01(i, 3, 7)).collect();
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        let mean = xs.iter().sum::<f32>() / xs.len() as f32;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
        assert_ne!(pcg_hash(1), pcg_hash(2));
        assert_eq!(pcg_hash(0), pcg_hash(0));
    }

    /// The near draw's strata cover the list: over every `k`, each entry lies in exactly
    /// one stratum, the sizes differ by at most one, `u` near 1 stays inside the stratum, and
    /// `m = count` is every entry once. At the extremes (a list of `u32::MAX` entries in
    /// 65,536 strata, a million in 4,096) the integer maths does not overflow (a debug build
    /// would panic) and the last stratum ends at the list's end.
    #[test]
    fn near_draws_are_strata_that_cover_the_list() {
        for count in 1..=40u32 {
            for m in 1..=count {
                let mut seen = vec![0u32; count as usize];
                let mut sizes = Vec::new();
                for k in 0..m {
                    let (first, size) = near_draw(k, m, count, 0.0);
                    let (last, size_hi) = near_draw(k, m, count, 0.999_999_9);
                    assert_eq!(size, size_hi);
                    assert_eq!(last, first + size - 1, "m {m} count {count} k {k}");
                    sizes.push(size);
                    for i in first..first + size {
                        seen[i as usize] += 1;
                    }
                }
                assert!(seen.iter().all(|&c| c == 1), "m {m} count {count}: {seen:?}");
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= 1, "m {m} count {count}: {sizes:?}");
            }
        }
        for (m, count) in [(65_536u32, u32::MAX), (4096, 1_000_000), (4095, 1_000_003)] {
            let (first, size) = near_draw(m - 1, m, count, 0.999_999_9);
            assert_eq!(first, count - 1, "m {m} count {count}");
            assert!((count / m..=count / m + 1).contains(&size));
        }
        assert_eq!((near_count(16, 5), near_count(4, 100), near_count(8, 0)), (5, 4, 0));
    }

    /// Two picks of two candidates of equal weight never agree: the first candidate is
    /// kept by both, the second replaces it where a pick's number is below 1/2, and the
    /// two numbers are 1/2 apart. Pick 0 is the one-ray sampler's.
    #[test]
    fn the_picks_of_one_pixel_spread_over_its_candidates() {
        let lights: Vec<Light> = (0..2)
            .map(|i| Light::point(Vec3::new(i as f32 * 0.5 - 0.25, 1.0, 0.0), Vec3::ONE, 1.0, 0.01).unwrap())
            .collect();
        let s = Surface { albedo: Vec3::splat(0.5), roughness: 1.0, metallic: 0.0 };
        let at = (Vec3::ZERO, Vec3::Y, Vec3::Y);
        for pixel in 0..200 {
            let picks = resample_near_far_rays(&lights, &[0, 1], at, &s, (2, 0), (pixel, 7), (None, 2));
            assert_ne!(picks[0].light, picks[1].light, "pixel {pixel}: {picks:?}");
            assert_eq!(picks[0], resample_near_far(&lights, &[0, 1], at, &s, (2, 0), (pixel, 7), None));
        }
    }

    /// A pick's numbers are the first pick's shifted by `j / rays` and wrapped: pick 0's is
    /// the number itself, the shifts are exact multiples of 2^-24, every result in [0, 1),
    /// and over 4 picks a number near 1 wraps.
    #[test]
    fn ray_numbers_are_the_first_shifted_and_wrapped() {
        let top = 0xFF_FFFF as f32 / 16_777_216.0;
        assert_eq!(ray_number(0.3, 0, 4), 0.3_f32 * 16_777_216.0 / 16_777_216.0);
        assert_eq!(ray_number(0.0, 1, 4), 0.25);
        assert_eq!(ray_number(0.5, 3, 4), 0.25);
        assert_eq!(ray_number(top, 1, 2), 0.5 - 1.0 / 16_777_216.0);
        for rays in 1..=MAX_RAYS {
            for j in 0..rays {
                for k in 0..1000 {
                    let x = ray_number(rand01(k, rays, j), j, rays);
                    assert!((0.0..1.0).contains(&x) && (x * 16_777_216.0).fract() == 0.0, "{x}");
                }
            }
        }
    }

    /// A reservoir keeps each candidate with probability proportional to its weight
    /// (three weights 1 : 2 : 5 over 40,000 reservoirs, within 2%), and a merge counts both
    /// reservoirs' candidates.
    #[test]
    fn a_reservoir_keeps_candidates_in_proportion_to_their_weight() {
        let mut counts = [0u32; 3];
        for t in 0..40_000u32 {
            let mut r = Reservoir::default();
            for (i, w) in [1.0f32, 2.0, 5.0].into_iter().enumerate() {
                r.update(i as u32, (w, w), rand01(t, 0, i as u32));
            }
            counts[r.light as usize] += 1;
        }
        for (c, w) in counts.iter().zip([1.0f32, 2.0, 5.0]) {
            let share = *c as f32 / 40_000.0;
            assert!((share - w / 8.0).abs() < 0.02 * 1.0, "{counts:?}");
        }
        let mut a = Reservoir { light: 0, p_hat: 1.0, w_sum: 3.0, m: 4 };
        a.merge(&Reservoir { light: 1, p_hat: 2.0, w_sum: 5.0, m: 6 }, 0.0);
        assert_eq!((a.m, a.w_sum), (10, 8.0));
        assert_eq!(Reservoir::default().weight(), 0.0, "an empty reservoir weighs nothing");
    }
}
