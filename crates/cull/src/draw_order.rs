//! The order a raster pass draws the scene's instances in ([`DrawOrder`]), and the setting
//! that picks it ([`DrawOrderMode`]). CPU only; depends on glam. tiledlight-gpu re-exports
//! it (`SceneGpu::front_to_back` and `SceneGpu::record_draws_of` use it).
//!
//! A pass that writes depth and colour exports every fragment that passes the depth test
//! when it is drawn, even one a later, nearer fragment covers. Drawn nearest first, most
//! hidden fragments fail the early depth test instead, so they are neither shaded nor
//! exported. On the Figure 9 scene (the courtyard and its 280 grid spheres, the scene's
//! camera) the order of the instance buffer passes 2.21 fragments a covered pixel; the
//! front-to-back order below passes 1.06 (counted with the CPU rasteriser,
//! `tiledlight_cull::raster`, at 480x270; `tests/tests/draw_order.rs` keeps it).
//!
//! [`DrawOrder::front_to_back`]:
//! 1. Each instance's key is the distance from the eye to its world bounds' centre. (The
//!    nearest point of the bounds is a worse key: the floor and walls contain the eye, so
//!    they would come first and every column and sphere would be drawn over them: 1.80
//!    fragments a pixel on the same scene.)
//! 2. Within a draw (one mesh and material, one range of instance slots), its instances
//!    are sorted by key.
//! 3. The draws are sorted by their nearest instance's key. A pass still draws pipeline by
//!    pipeline (draw kind), each kind in this order.
//! 4. Recording merges consecutive ascending slots into one instanced draw call; any other
//!    neighbours cost a call each (the grid spheres, stored far row first, become one call
//!    a sphere).
//!
//! Keeping each draw's instances together (steps 2-3) rather than sorting all instances
//! as one list passes fewer fragments (1.06 against 1.15 there) and switches textures less:
//! a draw whose nearest instance is near tends to be large on screen.
//!
//! The depth test keeps the later of two equal depths (`GreaterEqual`), so where two
//! surfaces coincide exactly the order decides which one shows. The visibility buffer's
//! hardware ID pass keeps the instance buffer's order for that reason (its ties must match
//! the compute raster's rule, the larger ID); the G-buffer and the depth pre-pass use the
//! frame's order.

use std::ops::Range;

use glam::Vec3;

/// Which order a frame's depth pre-pass and G-buffer draw in (`--draw-order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DrawOrderMode {
    /// Nearest instances first, sorted again whenever the eye moves ([`DrawOrder::front_to_back`]).
    #[default]
    FrontToBack,
    /// The instance buffer's order (draws by kind, mesh and material; instances as the
    /// scene lists them): the cost of not sorting, for measurement.
    Submission,
}

impl DrawOrderMode {
    /// The name the command line and the reports use.
    pub const fn label(self) -> &'static str {
        match self {
            Self::FrontToBack => "front-to-back",
            Self::Submission => "submission",
        }
    }
}

/// The order of a scene's draws and of each draw's instance slots.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawOrder {
    /// Indices of the scene's draws, in the order drawn.
    draws: Vec<u32>,
    /// Per draw, a permutation of its own slot range, stored at that range: draw `d`
    /// draws `slots[d.instances]` in that order.
    slots: Vec<u32>,
}

impl DrawOrder {
    /// The instance buffer's own order: draws as listed, slots ascending.
    /// `draws` are the draws' slot ranges; together they cover `0..n` once.
    pub fn submission(draws: &[Range<u32>]) -> Self {
        let n = draws.iter().map(|r| r.end).max().unwrap_or(0);
        Self { draws: (0..draws.len() as u32).collect(), slots: (0..n).collect() }
    }

    /// Nearest first as seen from `eye` (the steps in the module doc). `draws` are the
    /// draws' slot ranges, `bounds` each slot's world bounds (min, max). A NaN distance
    /// (bounds or eye not finite) sorts last, deterministically.
    pub fn front_to_back(draws: &[Range<u32>], bounds: &[(Vec3, Vec3)], eye: Vec3) -> Self {
        let mut order = Self::submission(draws);
        // The squared distance's bits, then the slot, in one u64 a slot: a non-negative f32's
        // bits order as its value (NaN made infinite), so integer order is (distance, slot)
        // order, a total one, and integers sort fast (`benches/draw_order.rs`, 2-core CI
        // machine: 100,000 instances 1.0 ms, 3.6 ms with float comparisons; the Figure 9
        // scene's 434 instances 4.6 us).
        let key = |slot: u32| {
            let (lo, hi) = bounds[slot as usize];
            let d = ((lo + hi) * 0.5).distance_squared(eye);
            let d = if d.is_nan() { f32::INFINITY } else { d.max(0.0) };
            (u64::from(d.to_bits()) << 32) | u64::from(slot)
        };
        let mut keyed: Vec<u64> = Vec::new();
        let mut nearest = vec![u64::MAX; draws.len()];
        for (d, r) in draws.iter().enumerate() {
            keyed.clear();
            keyed.extend(r.clone().map(key));
            keyed.sort_unstable();
            for (slot, k) in order.slots[r.start as usize..r.end as usize].iter_mut().zip(&keyed) {
                *slot = *k as u32;
            }
            if let Some(&first) = keyed.first() {
                nearest[d] = first >> 32;
            }
        }
        order.draws.sort_unstable_by_key(|&d| (nearest[d as usize], d));
        order
    }

    /// The draw indices, in order.
    pub fn draws(&self) -> &[u32] {
        &self.draws
    }

    /// The runs of instance slots a draw with slot range `slots` records, in order: its
    /// slots in this order, those not set in `visible` left out (all kept when None),
    /// consecutive ascending slots merged into one run.
    pub fn runs(&self, slots: Range<u32>, visible: Option<&[bool]>) -> Vec<Range<u32>> {
        let mut runs: Vec<Range<u32>> = Vec::new();
        for &s in &self.slots[slots.start as usize..slots.end as usize] {
            if visible.is_some_and(|v| !v[s as usize]) {
                continue;
            }
            match runs.last_mut() {
                Some(r) if r.end == s => r.end += 1,
                _ => runs.push(s..s + 1),
            }
        }
        runs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f32) -> (Vec3, Vec3) {
        (Vec3::new(x - 0.5, 0.0, 0.0), Vec3::new(x + 0.5, 0.0, 0.0))
    }

    #[test]
    fn submission_is_the_buffer_order() {
        let o = DrawOrder::submission(&[0..3, 3..5]);
        assert_eq!(o.draws(), &[0, 1]);
        assert_eq!(o.runs(0..3, None), vec![0..3]);
        assert_eq!(o.runs(3..5, Some(&[true, true, true, false, true])), vec![4..5]);
        assert_eq!(o.runs(0..3, Some(&[true, false, true, true, true])), vec![0..1, 2..3]);
    }

    #[test]
    fn front_to_back_sorts_instances_then_draws_by_nearest() {
        // Draw 0: slots at x = 9, 5, 7; draw 1: slots at x = 6, 2. Eye at the origin.
        let bounds = [at(9.0), at(5.0), at(7.0), at(6.0), at(2.0)];
        let o = DrawOrder::front_to_back(&[0..3, 3..5], &bounds, Vec3::ZERO);
        assert_eq!(o.draws(), &[1, 0], "draw 1's nearest (x = 2) is nearer than draw 0's (x = 5)");
        assert_eq!(o.runs(0..3, None), vec![1..3, 0..1], "5 then 7 (slots 1, 2 merged), then 9");
        assert_eq!(o.runs(3..5, None), vec![4..5, 3..4]);
        // Seen from the other side the order reverses.
        let o = DrawOrder::front_to_back(&[0..3, 3..5], &bounds, Vec3::new(20.0, 0.0, 0.0));
        assert_eq!(o.draws(), &[0, 1]);
        assert_eq!(o.runs(0..3, None), vec![0..1, 2..3, 1..2]);
    }

    #[test]
    fn every_slot_is_drawn_once_whatever_the_order() {
        let bounds: Vec<_> = (0..50).map(|i| at(((i * 37) % 50) as f32)).collect();
        let draws = [0..10, 10..11, 11..11, 11..50];
        let visible: Vec<bool> = (0..50).map(|i| i % 7 != 3).collect();
        for eye in [Vec3::ZERO, Vec3::splat(f32::NAN), Vec3::new(25.0, 1.0, -3.0)] {
            let o = DrawOrder::front_to_back(&draws, &bounds, eye);
            let mut drawn: Vec<u32> =
                o.draws().iter().flat_map(|&d| o.runs(draws[d as usize].clone(), Some(&visible))).flatten().collect();
            drawn.sort_unstable();
            let expected: Vec<u32> = (0..50).filter(|&i| visible[i as usize]).collect();
            assert_eq!(drawn, expected, "eye {eye}");
            let mut ds = o.draws().to_vec();
            ds.sort_unstable();
            assert_eq!(ds, vec![0, 1, 2, 3]);
        }
    }

    #[test]
    fn non_finite_bounds_sort_last() {
        let bounds = [(Vec3::splat(f32::NAN), Vec3::ZERO), at(3.0), at(1.0)];
        let one_draw = vec![Range { start: 0, end: 3 }];
        let o = DrawOrder::front_to_back(&one_draw, &bounds, Vec3::ZERO);
        assert_eq!(o.runs(0..3, None), vec![2..3, 1..2, 0..1]);
    }
}
