//! Spatial reuse of the stochastic method's reservoirs (issue 48, item 3; ReSTIR DI,
//! Bitterli et al. 2020, section 4 and Algorithm 4): each pixel merges its own reservoir
//! with those of a few neighbours that see a similar surface, re-weighting each
//! neighbour's light by the target at its own surface, so that one frame's pixel chooses
//! among `(1 + k) M` candidates for the price of `k` more target evaluations and no more
//! rays. The CPU twin of `shaders/common/stochastic_shade.wgsl` with `REUSE`
//! (`tests/tests/stochastic_reuse.rs` compares the two).
//!
//! 1. **Record.** The sampling pass leaves each pixel's reservoir as a [`Record`] (16
//!    bytes: the kept light and whether the pixel's list had candidates, its contribution
//!    weight `W`, the surface's normal and view distance; a view distance of 0 is the sky:
//!    no reservoir). [`Record::pack`] is the layout both sides read.
//! 2. **Neighbours.** `k` pixels drawn uniformly from the `(2R + 1)^2` box around the
//!    pixel ([`neighbour`], integer offsets from [`rand01`]: the GPU draws the same ones);
//!    one off the screen, the pixel itself or the sky is skipped.
//! 3. **Similarity.** A neighbour whose normal turns more than 25 degrees from the pixel's
//!    or whose view distance differs by more than 10% of the pixel's is skipped
//!    ([`similar`]: ReSTIR's thresholds); the rest see nearly the same lights with
//!    nearly the same contribution.
//! 4. **Merge.** The pixel's own reservoir and each kept neighbour's enter one reservoir as
//!    a candidate of weight `p_hat(y) W M` with `p_hat` the target at *this* pixel's
//!    surface ([`combine`]); the candidates' counts `M` add up.
//! 5. **Weight.** `W = w_sum / (M p_hat(y))` with `M` the sum of the merged counts:
//!    ReSTIR's biased combination. It is unbiased where every merged pixel can produce the
//!    light the pixel can (its target non-zero there too); where a neighbour's target is 0
//!    for a light this pixel sees (the light behind the neighbour's surface, outside its
//!    spot cone), its count still divides, so such lights lose a little: steps 2-3 keep that
//!    share small, and the tests bound it against the truth.
//!
//! Depends on this crate's stochastic and octahedral modules and glam.

use glam::Vec3;

use crate::octahedral::{decode_u32, encode_u32};
use crate::stochastic::{rand01, Reservoir};

/// Half the side of the box neighbours are drawn from, in pixels (step 2): ReSTIR's 30
/// pixel radius at 1080p, as a box of that width.
pub const RADIUS: i32 = 15;

/// The cosine of the largest angle between the pixel's and a kept neighbour's normal
/// (step 3): 25 degrees.
pub const NORMAL_COS: f32 = 0.906_307_8;

/// The largest difference of view distance a kept neighbour may have, as a share of the
/// pixel's (step 3).
pub const DISTANCE_SHARE: f32 = 0.1;

/// The first draw ([`rand01`]'s third argument) of the reuse: past every candidate's draws
/// (two a candidate, at most 8,192 candidates), so no number is used twice.
pub const DRAW_BASE: u32 = 1 << 16;

/// The bit of a record's first word that says the pixel's list had candidates (its
/// reservoir saw the near candidates; light indices are below 2^20).
pub const NEAR_BIT: u32 = 1 << 31;

/// A pixel's reservoir as the sampling pass leaves it (step 1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Record {
    /// The kept light (meaningless while `weight` is 0).
    pub light: u32,
    /// Whether the pixel drew near candidates (its list was not empty): its reservoir's
    /// count is the near and far candidates, else the far ones alone.
    pub near: bool,
    /// The reservoir's contribution weight `W` (0: nothing kept).
    pub weight: f32,
    /// The surface's unit normal.
    pub normal: Vec3,
    /// The surface's view distance; 0 for the sky (no reservoir).
    pub dist: f32,
}

impl Record {
    /// The four words the GPU stores: the light with [`NEAR_BIT`], `W`'s bits, the normal
    /// as `pack2x16snorm` of its octahedral map, the view distance's bits.
    pub fn pack(&self) -> [u32; 4] {
        [
            self.light | if self.near { NEAR_BIT } else { 0 },
            self.weight.to_bits(),
            encode_u32(self.normal),
            self.dist.to_bits(),
        ]
    }

    /// The record of four stored words (the normal decoded: within 0.004 degrees).
    pub fn unpack(w: [u32; 4]) -> Self {
        Self {
            light: w[0] & !NEAR_BIT,
            near: w[0] & NEAR_BIT != 0,
            weight: f32::from_bits(w[1]),
            normal: decode_u32(w[2]),
            dist: f32::from_bits(w[3]),
        }
    }

    /// The candidates the reservoir saw: `near` of the pixel's list (when it had any) and
    /// `far` of every light.
    pub fn count(&self, (near, far): (u32, u32)) -> u32 {
        if self.near {
            near + far
        } else {
            far
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

/// Steps 2-4 for pixel `(x, y)` of a `size` screen whose records are `records` (row-major):
/// its own reservoir and those of `k` neighbours ([`neighbour`], [`similar`]) merged, each
/// light weighed by `p_hat_at(light)`, the target at this pixel's surface. `counts` are the
/// near and far candidates a pixel drew this frame. [`Reservoir::weight`] of the result is
/// step 5's `W`.
pub fn combine(
    records: &[Record],
    ((x, y), size): ((u32, u32), (u32, u32)),
    (k, counts, frame): (u32, (u32, u32), u32),
    p_hat_at: impl Fn(u32) -> f32,
) -> Reservoir {
    let pixel = y * size.0 + x;
    let own = &records[pixel as usize];
    let mut r = Reservoir::default();
    let mut offer = |rec: &Record, u: f32| {
        let p_hat = if rec.weight > 0.0 { p_hat_at(rec.light) } else { 0.0 };
        let m = rec.count(counts);
        let before = r.m;
        r.update(rec.light, (p_hat * rec.weight * m as f32, p_hat), u);
        r.m = before + m;
    };
    offer(own, rand01(pixel, frame, DRAW_BASE - 1));
    for j in 0..k {
        let Some((nx, ny)) = neighbour((x, y), size, frame, j) else { continue };
        let other = &records[(ny * size.0 + nx) as usize];
        if similar(own, other) {
            offer(other, rand01(pixel, frame, DRAW_BASE + 3 * j + 2));
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(light: u32, weight: f32, normal: Vec3, dist: f32) -> Record {
        Record { light, near: true, weight, normal, dist }
    }

    /// The packing keeps the light (up to the largest index), the near flag, `W` and the
    /// view distance bit for bit, and the normal within the octahedral code's bound, at the
    /// extremes: the largest light index, a sky record, huge and tiny weights.
    #[test]
    fn a_record_survives_its_packing_at_the_extremes() {
        let largest = (1u32 << 20) - 1;
        for rec in [
            record(largest, f32::MAX, Vec3::Z, 1e-30),
            Record { light: 0, near: false, weight: 0.0, normal: -Vec3::Z, dist: 0.0 },
            record(7, 1e-38, Vec3::new(1.0, -1.0, -1.0).normalize(), 1e30),
        ] {
            let back = Record::unpack(rec.pack());
            assert_eq!((back.light, back.near, back.weight, back.dist), (rec.light, rec.near, rec.weight, rec.dist));
            assert!(back.normal.dot(rec.normal) > 0.999_999, "{rec:?} -> {back:?}");
        }
    }

    /// A record's count is the near and far candidates, the far alone without a list.
    #[test]
    fn a_record_counts_the_candidates_its_pixel_drew() {
        let mut r = record(0, 1.0, Vec3::Z, 1.0);
        assert_eq!(r.count((4, 16)), 20);
        r.near = false;
        assert_eq!(r.count((4, 16)), 16);
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

    /// With every neighbour's light as bright here as there, merging keeps the weights'
    /// meaning: `W p_hat(y)` of the merged reservoir is the mean of the merged pixels' own
    /// estimates' expectation, here all 1 (each record's `W p_hat = 1`); a dissimilar
    /// neighbour is not merged (its count does not enter).
    #[test]
    fn merged_reservoirs_keep_the_estimate_and_skip_other_surfaces() {
        let size = (32, 32);
        let p_hat = |light: u32| 1.0 + light as f32;
        let mut records: Vec<Record> = (0..32 * 32).map(|i| record(i % 8, 1.0 / p_hat(i % 8), Vec3::Z, 5.0)).collect();
        let own = 16 * 32 + 16;
        let r = combine(&records, ((16, 16), size), (8, (4, 16), 1), p_hat);
        let merged = r.m / 20;
        assert!(merged > 1, "no neighbour merged");
        assert!((r.weight() * r.p_hat - 1.0).abs() < 1e-5, "W p_hat = {}", r.weight() * r.p_hat);
        // Every other pixel a wall (normal across): only the pixel's own reservoir counts.
        for (i, rec) in records.iter_mut().enumerate() {
            if i != own {
                rec.normal = Vec3::X;
            }
        }
        let alone = combine(&records, ((16, 16), size), (8, (4, 16), 1), p_hat);
        assert_eq!((alone.m, alone.light), (20, own as u32 % 8));
    }
}
