//! Spatial reuse of the stochastic method's reservoirs (issue 48, item 3; ReSTIR DI,
//! Bitterli et al. 2020, section 4 and Algorithm 4): each pixel merges its own reservoir
//! with those of a few neighbours that see a similar surface, re-weighting each
//! neighbour's light by the target at its own surface, so that one frame's pixel chooses
//! among `(1 + k) M` candidates for the price of `k` more target evaluations and no more
//! rays. The CPU twin of `shaders/common/stochastic_shade.wgsl` with `REUSE`
//! (`tests/tests/stochastic_reuse.rs` compares the two).
//!
//! 1. **Record.** The sampling pass leaves each pixel's reservoir as a [`Record`] (32
//!    bytes: the kept light, the candidates the reservoir stands for, its contribution
//!    weight `W`, the surface's normal, view distance and material; a view distance of 0 is
//!    the sky: no reservoir). [`Record::pack`] is the layout both sides read. With temporal
//!    reuse ([`crate::temporal`]) the count includes the history's share.
//! 2. **Neighbours.** `k` pixels drawn uniformly from the `(2R + 1)^2` box around the
//!    pixel ([`neighbour`], integer offsets from [`rand01`]: the GPU draws the same ones);
//!    one off the screen, the pixel itself or the sky is skipped.
//! 3. **Similarity.** A neighbour whose normal turns more than 25 degrees from the pixel's
//!    or whose view distance differs by more than 10% of the pixel's is skipped
//!    ([`similar`]: ReSTIR's thresholds); the rest see nearly the same lights with
//!    nearly the same contribution.
//! 4. **Merge** (generalised RIS with the balance heuristic, Lin et al. 2022, section 5):
//!    the pixel's own record and each kept neighbour's are the merge's inputs `S`. Input
//!    `i` with light `y_i` enters with weight `m_i(y_i) p_hat(y_i) W_i`, where `p_hat` is
//!    the target at *this* pixel's surface and `m_i(y) = M_i p_i'(y) / sum_j M_j p_j'(y)`
//!    its share of the light over `S` ([`offers`]). `p_j'` is input `j`'s own target: the
//!    light's unshadowed contribution at its point (rebuilt from its pixel and view
//!    distance), normal and material (albedo and roughness to 8 bits), so the shares of
//!    the inputs that can draw `y` add up to 1.
//! 5. **Weight.** `W = w_sum / p_hat(y)` for the kept light `y` (the reservoir's count is
//!    1: the shares did the normalising). Unbiased for this pixel's sum of every light's
//!    shadowed light. The shares are what keeps the merge's noise down: a light that sits
//!    much brighter here than at the neighbour that chose it (closer, or in this pixel's
//!    specular lobe, so its `W` there is large) gets the small share that neighbour's
//!    target gives it, where ReSTIR's 1/M combination (this module's first version) let it
//!    in with its whole weight; a geometric proxy without the BRDF (its second) left the
//!    lobes' tail: on the courtyard both made a frame noisier than without reuse.
//!
//! Depends on this crate's stochastic, octahedral and brdf modules and glam.

use glam::Vec3;

use crate::brdf::Surface;
use crate::octahedral::{decode_u32, encode_u32};
use crate::stochastic::{rand01, Reservoir};

/// Half the side of the box neighbours are drawn from, in pixels (step 2): ReSTIR's 30
/// pixel radius at 1080p, as a box of that width.
pub const RADIUS: i32 = 15;

/// The most neighbours a pixel merges (the setting's limit: the GPU keeps the merge's
/// inputs in a fixed array of `1 + MAX_NEIGHBOURS`, `shaders/common/reuse.wgsl`).
pub const MAX_NEIGHBOURS: u32 = 16;

/// The cosine of the largest angle between the pixel's and a kept neighbour's normal
/// (step 3): 25 degrees.
pub const NORMAL_COS: f32 = 0.906_307_8;

/// The largest difference of view distance a kept neighbour may have, as a share of the
/// pixel's (step 3).
pub const DISTANCE_SHARE: f32 = 0.1;

/// The first draw ([`rand01`]'s third argument) of the reuse: past every candidate's draws
/// (two a candidate, at most 8,192 candidates), so no number is used twice.
pub const DRAW_BASE: u32 = 1 << 16;

/// A pixel's reservoir as the sampling pass leaves it (step 1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Record {
    /// The kept light (meaningless while `weight` is 0).
    pub light: u32,
    /// The candidates the reservoir stands for (its confidence `M` in a merge): the near
    /// and far candidates the pixel drew (the far alone when its list was empty), plus
    /// what temporal reuse merged; after a merge, the merged inputs' sum.
    pub count: u32,
    /// The reservoir's contribution weight `W` (0: nothing kept).
    pub weight: f32,
    /// The surface's unit normal.
    pub normal: Vec3,
    /// The surface's view distance; 0 for the sky (no reservoir).
    pub dist: f32,
    /// The surface's material as [`pack_surface`] stores it.
    pub surface: [u32; 2],
}

/// A material in two words: albedo and roughness as `pack4x8unorm`, metallic's bits.
pub fn pack_surface(s: &Surface) -> [u32; 2] {
    let unorm = |c: f32| (0.5 + 255.0 * c.clamp(0.0, 1.0)).floor() as u32;
    let a = s.albedo;
    [unorm(a.x) | unorm(a.y) << 8 | unorm(a.z) << 16 | unorm(s.roughness) << 24, s.metallic.to_bits()]
}

/// The material of two words written by [`pack_surface`] (`unpack4x8unorm`).
pub fn unpack_surface(w: [u32; 2]) -> Surface {
    let c = |shift: u32| ((w[0] >> shift) & 0xff) as f32 / 255.0;
    Surface { albedo: Vec3::new(c(0), c(8), c(16)), roughness: c(24), metallic: f32::from_bits(w[1]) }
}

impl Record {
    /// The eight words the GPU stores: the light, `W`'s bits, the normal as
    /// `pack2x16snorm` of its octahedral map, the view distance's bits; the material's two
    /// words, the count and one unused.
    pub fn pack(&self) -> [u32; 8] {
        let (normal, dist) = (encode_u32(self.normal), self.dist.to_bits());
        [self.light, self.weight.to_bits(), normal, dist, self.surface[0], self.surface[1], self.count, 0]
    }

    /// The record of eight stored words (the normal decoded: within 0.004 degrees).
    pub fn unpack(w: [u32; 8]) -> Self {
        Self {
            light: w[0],
            count: w[6],
            weight: f32::from_bits(w[1]),
            normal: decode_u32(w[2]),
            dist: f32::from_bits(w[3]),
            surface: [w[4], w[5]],
        }
    }

    /// Whether the record is a surface's (the sky's has none).
    pub fn is_surface(&self) -> bool {
        self.dist > 0.0
    }
}

/// Step 2: neighbour `j` of pixel `(x, y)` on a `width` x `height` screen in `frame`, or
/// None when it falls off the screen or on the pixel itself.
pub fn neighbour((x, y): (u32, u32), (width, height): (u32, u32), frame: u32, j: u32) -> Option<(u32, u32)> {
    let pixel = y * width + x;
    let side = (2 * RADIUS + 1) as f32;
    let offset = |draw: u32| (rand01(pixel, frame, draw) * side) as i32 - RADIUS;
    let (dx, dy) = (offset(DRAW_BASE + 3 * j), offset(DRAW_BASE + 3 * j + 1));
    let (nx, ny) = (x as i32 + dx, y as i32 + dy);
    let on_screen = nx >= 0 && ny >= 0 && nx < width as i32 && ny < height as i32;
    (on_screen && (dx, dy) != (0, 0)).then_some((nx as u32, ny as u32))
}

/// Step 3: whether a neighbour's surface is close enough to the pixel's to lend its
/// reservoir (both must be surfaces).
pub fn similar(pixel: &Record, other: &Record) -> bool {
    pixel.is_surface()
        && other.is_surface()
        && pixel.normal.dot(other.normal) >= NORMAL_COS
        && (pixel.dist - other.dist).abs() <= DISTANCE_SHARE * pixel.dist
}

/// What a pixel's merge needs of its scene: `position(x, y, dist)` the world point of a
/// pixel at a view distance, `proxy(light, point, normal, surface)` the balance
/// heuristic's `p'` (on the GPU the target at that point: the luminance of the light's
/// unshadowed contribution), `target(light)` the target `p_hat` at this pixel's surface.
pub struct Scene<P, Q, T> {
    /// A pixel's world point at a view distance.
    pub position: P,
    /// `p'` of a light at a point with a normal and a material ([`pack_surface`]).
    pub proxy: Q,
    /// `p_hat` of a light at this pixel's surface.
    pub target: T,
}

/// A [`Scene`] of plain functions (no state: a test's tables).
pub type FnScene = Scene<fn(u32, u32, f32) -> Vec3, fn(u32, Vec3, Vec3, [u32; 2]) -> f32, fn(u32) -> f32>;

/// Steps 2-4 for pixel `(x, y)` of a `size` screen whose records are `records`
/// (row-major): the inputs merged (its own record first, then the similar neighbours'
/// of `k` drawn, [`neighbour`], [`similar`]), each as `(light, weight, p_hat, u, count)`:
/// the light, its weight `m_i p_hat W_i`, its target here, the number that decides
/// whether it is kept and its record's count.
pub fn offers<P, Q, T>(
    records: &[Record],
    ((x, y), size): ((u32, u32), (u32, u32)),
    (k, frame): (u32, u32),
    scene: &Scene<P, Q, T>,
) -> Vec<(u32, f32, f32, f32, u32)>
where
    P: Fn(u32, u32, f32) -> Vec3,
    Q: Fn(u32, Vec3, Vec3, [u32; 2]) -> f32,
    T: Fn(u32) -> f32,
{
    let pixel = y * size.0 + x;
    let own = records[pixel as usize];
    let mut inputs = vec![((x, y), own, rand01(pixel, frame, DRAW_BASE - 1))];
    for j in 0..k {
        let Some((nx, ny)) = neighbour((x, y), size, frame, j) else { continue };
        let other = records[(ny * size.0 + nx) as usize];
        if similar(&own, &other) {
            inputs.push(((nx, ny), other, rand01(pixel, frame, DRAW_BASE + 3 * j + 2)));
        }
    }
    let at: Vec<(Vec3, Vec3, [u32; 2], f32)> = inputs
        .iter()
        .map(|&((px, py), r, _)| ((scene.position)(px, py, r.dist), r.normal, r.surface, r.count as f32))
        .collect();
    inputs
        .iter()
        .enumerate()
        .map(|(i, &(_, rec, u))| {
            if rec.weight <= 0.0 {
                return (rec.light, 0.0, 0.0, u, rec.count);
            }
            let share = |&(p, n, s, m): &(Vec3, Vec3, [u32; 2], f32)| m * (scene.proxy)(rec.light, p, n, s);
            let total: f32 = at.iter().map(share).sum();
            let mine = share(&at[i]);
            let p_hat = (scene.target)(rec.light);
            let w = if total > 0.0 { mine / total * p_hat * rec.weight } else { 0.0 };
            (rec.light, w, p_hat, u, rec.count)
        })
        .collect()
}

/// Steps 2-5: [`offers`] kept in one reservoir, whose [`Reservoir::weight`] is `W`, and
/// the merged inputs' summed count (the merged reservoir's confidence in the next frame's
/// temporal reuse).
pub fn combine<P, Q, T>(
    records: &[Record],
    pixel: ((u32, u32), (u32, u32)),
    draws: (u32, u32),
    scene: &Scene<P, Q, T>,
) -> (Reservoir, u32)
where
    P: Fn(u32, u32, f32) -> Vec3,
    Q: Fn(u32, Vec3, Vec3, [u32; 2]) -> f32,
    T: Fn(u32) -> f32,
{
    let mut r = Reservoir::default();
    let mut count = 0u32;
    for (light, w, p_hat, u, m) in offers(records, pixel, draws, scene) {
        r.update(light, (w, p_hat), u);
        count += m;
    }
    r.m = 1;
    (r, count)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(light: u32, weight: f32, normal: Vec3, dist: f32) -> Record {
        Record { light, count: 20, weight, normal, dist, surface: [0; 2] }
    }

    /// The packing keeps the light (up to the largest index), the count, `W` and the
    /// view distance bit for bit, and the normal within the octahedral code's bound, at the
    /// extremes: the largest light index, a sky record, huge and tiny weights.
    #[test]
    fn a_record_survives_its_packing_at_the_extremes() {
        let largest = (1u32 << 20) - 1;
        for rec in [
            record(largest, f32::MAX, Vec3::Z, 1e-30),
            Record { light: 0, count: u32::MAX, weight: 0.0, normal: -Vec3::Z, dist: 0.0, surface: [u32::MAX; 2] },
            record(7, 1e-38, Vec3::new(1.0, -1.0, -1.0).normalize(), 1e30),
        ] {
            let back = Record::unpack(rec.pack());
            assert_eq!(
                (back.light, back.count, back.weight, back.dist, back.surface),
                (rec.light, rec.count, rec.weight, rec.dist, rec.surface)
            );
            assert!(back.normal.dot(rec.normal) > 0.999_999, "{rec:?} -> {back:?}");
        }
    }

    /// Neighbours fall in the box, never on the pixel or off the screen, cover the box
    /// (both extremes of each offset are drawn), and differ from frame to frame.
    #[test]
    fn neighbours_fill_the_box_and_stay_on_the_screen() {
        let size = (64, 48);
        let mut seen = std::collections::HashSet::new();
        let mut skipped = 0;
        for frame in 0..40 {
            for j in 0..50 {
                match neighbour((20, 20), size, frame, j) {
                    Some((nx, ny)) => {
                        let (dx, dy) = (nx as i32 - 20, ny as i32 - 20);
                        assert!(dx.abs() <= RADIUS && dy.abs() <= RADIUS && (dx, dy) != (0, 0));
                        seen.insert((dx, dy));
                    }
                    None => skipped += 1,
                }
            }
        }
        let side = (2 * RADIUS + 1) as usize;
        assert!(seen.len() > side * side * 8 / 10, "{} of {} offsets drawn", seen.len(), side * side);
        assert!([-RADIUS, RADIUS].iter().all(|&e| seen.iter().any(|&(dx, _)| dx == e)));
        assert!(skipped < 10, "{skipped} draws fell on the pixel");
        // At a corner most draws fall off the screen, and none is returned off it.
        let corner: Vec<_> = (0..200).filter_map(|j| neighbour((0, 0), size, 3, j)).collect();
        assert!(!corner.is_empty() && corner.len() < 100);
        assert!(neighbour((5, 5), (1, 1), 0, 0).is_none());
    }

    /// The similarity test keeps a neighbour within 25 degrees and 10% of the distance,
    /// and no sky.
    #[test]
    fn similar_surfaces_pass_and_edges_do_not() {
        let a = record(0, 1.0, Vec3::Z, 10.0);
        let turn = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
        assert!(similar(&a, &record(0, 1.0, turn(24.0), 10.9)));
        assert!(!similar(&a, &record(0, 1.0, turn(26.0), 10.0)));
        assert!(!similar(&a, &record(0, 1.0, Vec3::Z, 11.1)));
        assert!(!similar(&a, &record(0, 1.0, Vec3::Z, 8.9)));
        assert!(!similar(&a, &record(0, 1.0, Vec3::Z, 0.0)));
        assert!(!similar(&record(0, 1.0, Vec3::Z, 0.0), &record(0, 1.0, Vec3::Z, 0.0)));
    }

    /// The target of the flat scene: brighter for a larger index.
    fn p_hat(light: u32) -> f32 {
        1.0 + light as f32
    }

    /// A scene whose proxy and target are [`p_hat`] wherever the point is.
    fn flat() -> FnScene {
        Scene { position: |x, y, d| Vec3::new(x as f32, y as f32, d), proxy: |l, _, _, _| p_hat(l), target: p_hat }
    }

    /// With every neighbour's light as bright here as there, merging keeps the weights'
    /// meaning: `W p_hat(y)` of the merged reservoir is the mean of the merged pixels' own
    /// estimates' expectation, here all 1 (each record's `W p_hat = 1`); a dissimilar
    /// neighbour is not merged.
    #[test]
    fn merged_reservoirs_keep_the_estimate_and_skip_other_surfaces() {
        let size = (32, 32);
        let scene = flat();
        let mut records: Vec<Record> = (0..32 * 32).map(|i| record(i % 8, 1.0 / p_hat(i % 8), Vec3::Z, 5.0)).collect();
        let own = 16 * 32 + 16;
        let draws = (8, 1);
        assert!(offers(&records, ((16, 16), size), draws, &scene).len() > 2, "no neighbour merged");
        let (r, count) = combine(&records, ((16, 16), size), draws, &scene);
        let merged = offers(&records, ((16, 16), size), draws, &scene).len() as u32;
        assert_eq!(count, 20 * merged, "the merged reservoir stands for every merged record's candidates");
        assert!((r.weight() * r.p_hat - 1.0).abs() < 1e-5, "W p_hat = {}", r.weight() * r.p_hat);
        // Every other pixel a wall (normal across): only the pixel's own reservoir counts.
        for (i, rec) in records.iter_mut().enumerate() {
            if i != own {
                rec.normal = Vec3::X;
            }
        }
        assert_eq!(offers(&records, ((16, 16), size), draws, &scene).len(), 1);
        let (alone, count) = combine(&records, ((16, 16), size), draws, &scene);
        assert_eq!(count, 20);
        assert_eq!(alone.light, own as u32 % 8);
        assert!((alone.weight() * alone.p_hat - 1.0).abs() < 1e-6);
    }

    /// The balance heuristic's shares: a light that only this pixel's proxy sees (behind
    /// the neighbour's surface) takes all its weight from this pixel, and one the neighbour
    /// sees 9x as brightly gives this pixel's sample a tenth of the share when the counts
    /// are equal.
    #[test]
    fn the_shares_follow_the_proxy_and_the_counts() {
        let size = (2, 1);
        let records = [record(1, 1.0, Vec3::Z, 5.0), record(2, 1.0, Vec3::Z, 5.0)];
        // Find a frame whose one draw lands on the other pixel.
        let frame = (0..1000).find(|&f| neighbour((0, 0), size, f, 0) == Some((1, 0))).expect("a frame");
        let scene = Scene {
            position: |x: u32, _: u32, _: f32| Vec3::new(x as f32, 0.0, 0.0),
            // Light 1: seen from pixel 0 only; light 2: 9x brighter at pixel 1.
            proxy: |l: u32, p: Vec3, _: Vec3, _: [u32; 2]| match (l, p.x > 0.5) {
                (1, false) => 1.0,
                (1, true) => 0.0,
                (_, false) => 1.0,
                (_, true) => 9.0,
            },
            target: |_: u32| 1.0,
        };
        let o = offers(&records, ((0, 0), size), (1, frame), &scene);
        assert_eq!(o.len(), 2);
        assert!((o[0].1 - 1.0).abs() < 1e-6 && (o[1].1 - 0.9).abs() < 1e-6, "{o:?}");
        // The neighbour drew only its far candidates (16 of 20): its share shrinks.
        let few = [records[0], Record { count: 16, ..records[1] }];
        let o = offers(&few, ((0, 0), size), (1, frame), &scene);
        let expected = 9.0 * 16.0 / (9.0 * 16.0 + 20.0);
        assert!((o[1].1 - expected).abs() < 1e-6, "{o:?}");
    }

    /// A material survives its two words: metallic bit for bit, albedo and roughness to
    /// 8 bits (within half a step), clamped to [0, 1].
    #[test]
    fn a_material_survives_its_packing() {
        for s in [
            Surface { albedo: Vec3::new(0.0, 0.5, 1.0), roughness: 0.04, metallic: 0.3 },
            Surface { albedo: Vec3::new(2.0, -1.0, 0.999), roughness: 1.0, metallic: 1.0 },
        ] {
            let back = unpack_surface(pack_surface(&s));
            let clamped = s.albedo.clamp(Vec3::ZERO, Vec3::ONE);
            assert!((back.albedo - clamped).abs().max_element() <= 0.5 / 255.0 + 1e-6, "{s:?} -> {back:?}");
            assert!((back.roughness - s.roughness).abs() <= 0.5 / 255.0 + 1e-6);
            assert_eq!(back.metallic, s.metallic);
        }
    }
}
