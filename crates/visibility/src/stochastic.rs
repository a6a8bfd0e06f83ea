//! The stochastic method's frame-to-frame state (issue 48: every light shadowed): which
//! frame this is (the seed of its random numbers) and how many frames before it the
//! per-pixel history holds. The pass itself is the traced kernel with the sampler's light
//! loop ([`crate::shading::ShadeLights::Stochastic`], `shaders/stochastic.wgsl`, body
//! `shaders/common/stochastic_shade.wgsl`):
//!
//! 1. Each frame draws `candidates` lights a pixel from its list in the light grid (the
//!    lights whose radius reaches it; stratified, none twice) and `far_candidates` from
//!    every light (the others), with `rays` picks of them (a shadow ray each),
//!    keeps one by resampled importance sampling with the unshadowed contribution as the
//!    target, and casts one shadow ray to it (`tiledlight_cull::stochastic::
//!    resample_near_far` is the CPU twin).
//! 2. With temporal reuse (`--temporal N`), each frame's reservoirs are merged with the
//!    previous frame's, reprojected ([`FrameParams::previous`]: none for the first frame
//!    and after a reset; `tiledlight_cull::temporal` numbers the steps).
//! 3. The pixel's estimate enters a running mean of the frames since the view or the
//!    lights last changed ([`Accumulation::next`]): after a change the mean starts again
//!    from this frame alone, so nothing of another view survives (no ghost, at the price of
//!    one frame's noise after every move). The count stops at `accumulate` (a moving
//!    average from there); `accumulate` 0 shows each frame's raw estimate.
//!
//! Depends on glam only.

use glam::Mat4;
use std::cell::Cell;

/// What one frame's dispatch reads (`TracedBand` in `shaders/common/traced_shade.wgsl`,
/// after its first row): its seed, its candidates a pixel and the frames its history
/// holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameParams {
    /// The frame's number: the random numbers' seed (wraps at 2^32).
    pub frame: u32,
    /// Candidates drawn a pixel from its list (the lights whose radius reaches it).
    pub candidates: u32,
    /// Candidates drawn a pixel from every light (those whose radius does not reach it).
    pub far_candidates: u32,
    /// Frames in the history before this one (0: this frame's estimate alone).
    pub accumulated: u32,
    /// Whether a frame of this scene came before (through any view): temporal reuse has
    /// its reservoirs to reproject (false for the first frame and after a reset).
    pub previous: bool,
}

/// The frame counter and the history's length, kept between frames.
#[derive(Debug)]
pub struct Accumulation {
    candidates: u32,
    far_candidates: u32,
    accumulate: u32,
    frame: Cell<u32>,
    accumulated: Cell<u32>,
    /// The world-to-clip matrix of the last frame (None before the first, or after
    /// [`Accumulation::reset`]).
    last_view: Cell<Option<Mat4>>,
}

impl Accumulation {
    /// `(candidates, far_candidates)` a pixel each frame, at most `accumulate` frames of
    /// history (0: none).
    pub fn new((candidates, far_candidates): (u32, u32), accumulate: u32) -> Self {
        let (frame, accumulated, last_view) = (Cell::new(0), Cell::new(0), Cell::new(None));
        Self { candidates, far_candidates, accumulate, frame, accumulated, last_view }
    }

    /// The parameters of the next frame, seen through `world_to_clip`: a new seed; the
    /// history continues only when the view is the last frame's (bit for bit) and nothing
    /// reset it since.
    pub fn next(&self, world_to_clip: Mat4) -> FrameParams {
        let frame = self.frame.get();
        self.frame.set(frame.wrapping_add(1));
        let last = self.last_view.replace(Some(world_to_clip));
        let same_view = last == Some(world_to_clip);
        let accumulated = if same_view { (self.accumulated.get() + 1).min(self.accumulate) } else { 0 };
        self.accumulated.set(accumulated);
        let (candidates, far_candidates) = (self.candidates, self.far_candidates);
        FrameParams { frame, candidates, far_candidates, accumulated, previous: last.is_some() }
    }

    /// Forgets the history (the lights or the scene moved): the next frame starts a new
    /// mean and has no previous frame to reuse reservoirs from.
    pub fn reset(&self) {
        self.last_view.set(None);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A still view accumulates up to the limit, every frame has a new seed, a moved view or
    /// a reset starts again at 0, and a limit of 0 never accumulates.
    #[test]
    fn the_history_grows_while_the_view_holds_and_restarts_when_it_moves() {
        let a = Accumulation::new((8, 2), 3);
        let still = Mat4::IDENTITY;
        let counts: Vec<u32> = (0..5).map(|_| a.next(still).accumulated).collect();
        assert_eq!(counts, [0, 1, 2, 3, 3]);
        let moved = Mat4::from_translation(glam::Vec3::X * 1e-6);
        let expected = FrameParams { frame: 5, candidates: 8, far_candidates: 2, accumulated: 0, previous: true };
        assert_eq!(a.next(moved), expected);
        assert_eq!(a.next(moved).accumulated, 1);
        // The first frame after a reset (and the very first) has no previous frame.
        a.reset();
        let first = a.next(moved);
        assert_eq!((first.accumulated, first.previous), (0, false));
        assert!(a.next(moved).previous);
        assert!(!Accumulation::new((8, 2), 3).next(still).previous);
        let off = Accumulation::new((8, 2), 0);
        assert_eq!((0..3).map(|_| off.next(still).accumulated).collect::<Vec<_>>(), [0, 0, 0]);
        let seeds: Vec<u32> = (0..3).map(|_| off.next(still).frame).collect();
        assert_eq!(seeds, [3, 4, 5]);
    }
}
