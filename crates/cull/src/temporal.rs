//! Temporal reuse of the stochastic method's reservoirs (issue 48, item 3; ReSTIR DI,
//! Bitterli et al. 2020, section 4 and Algorithm 5): each pixel merges this frame's
//! reservoir with the one its surface had last frame, found by reprojection, so a light
//! chosen well once keeps being offered while the camera holds still or moves. The CPU twin
//! of `shaders/common/reuse.wgsl`'s temporal half (`tests/tests/stochastic_twin.rs` compares
//! the two on tables, `tests/tests/stochastic_method.rs` on frames).
//!
//! 1. **History.** The pass that shades leaves each pixel's final reservoir (after every
//!    merge) as a [`Record`], with the count of candidates it stands for, and the view it
//!    was seen through (the next frame's previous view). The first frame, and the first
//!    after the scene or the lights changed, have no history.
//! 2. **Reprojection.** The pixel's world point through the previous view's world-to-clip
//!    matrix ([`reproject`]): the previous frame's pixel that held it and the view distance
//!    it had there. Behind the previous camera or off its screen: no history.
//! 3. **Disocclusion.** The history's record is kept only when it shows the same surface
//!    ([`crate::reuse::similar`] of this pixel's normal at the *expected* distance and the
//!    record): a surface that was hidden last frame finds the occluder's record there (a
//!    distance 10% off, or a normal 25 degrees off) or the sky's, and starts afresh. No
//!    ghost of another surface's light survives, whichever way the camera moved.
//! 4. **Cap.** The history's count enters at most `cap` times this frame's candidates
//!    (ReSTIR's 20): an old reservoir cannot outvote the new candidates forever, so the
//!    lights' changes reach the image within a few frames.
//! 5. **Merge** ([`merge`]): generalised RIS with the balance heuristic over the two inputs,
//!    as the spatial merge (`crate::reuse`, step 4): this frame's reservoir with its count
//!    and the target here, the history's with its capped count and the target at its own
//!    point, normal and material seen from the previous eye. `W = w_sum / p_hat(y)`; the
//!    merged reservoir stands for both counts. Unbiased whatever the history holds: the
//!    shares of a light add up to 1 over the inputs that can draw it.
//! 6. **Only while the mean restarts.** The merge runs while the frames' running mean
//!    starts again every frame (the view moves, or no mean is kept); once a still view
//!    accumulates, its frames are left independent and the history only follows along for
//!    the next move: a mean of frames that reuse each other's lights converges slowly
//!    (lavapipe's courtyard, 8 frames: FLIP 0.19 without temporal reuse, 0.33 with it
//!    merged every frame).
//!
//! Depends on this crate's reuse and stochastic modules and glam.

use glam::{Mat4, Vec3};

use crate::reuse::{similar, Record, DRAW_BASE};
use crate::stochastic::{rand01, Reservoir};

/// The draw ([`rand01`]'s third argument) that decides whether the history's light
/// replaces this frame's: below the spatial merge's (its own is `DRAW_BASE - 1`).
pub const DRAW: u32 = DRAW_BASE - 2;

/// The default cap: the history counts at most this many times a frame's candidates
/// (ReSTIR DI's 20).
pub const DEFAULT_CAP: u32 = 20;

/// The largest cap the setting takes: beyond it the history's light reaches the image
/// too slowly after the lights move (and a count could near `u32::MAX`).
pub const MAX_CAP: u32 = 64;

/// Step 2: the previous frame's pixel that showed world point `world` through
/// `world_to_clip` on a `(width, height)` screen, and the view distance the point had
/// there (`-z` through `world_to_view`); None behind the camera or off the screen.
pub fn reproject(
    world: Vec3,
    (world_to_clip, world_to_view): (&Mat4, &Mat4),
    (width, height): (u32, u32),
) -> Option<((u32, u32), f32)> {
    let clip = *world_to_clip * world.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let (nx, ny) = (clip.x / clip.w, clip.y / clip.w);
    let fx = (nx + 1.0) * 0.5 * width as f32;
    let fy = (1.0 - ny) * 0.5 * height as f32;
    let on_screen = fx >= 0.0 && fy >= 0.0 && fx < width as f32 && fy < height as f32;
    let dist = -(*world_to_view * world.extend(1.0)).z;
    on_screen.then_some(((fx as u32, fy as u32), dist))
}

/// Step 3: whether the history's record at the reprojected pixel shows the surface of
/// normal `normal` this pixel sees, expected at view distance `dist` there.
pub fn same_surface(normal: Vec3, dist: f32, history: &Record) -> bool {
    let here = Record { normal, dist, ..Record::default() };
    similar(&here, history)
}

/// Step 4: the count the history enters with: at most `cap` times this frame's.
pub fn capped(history: u32, own: u32, cap: u32) -> u32 {
    history.min(own.saturating_mul(cap))
}

/// Steps 4-5 for pixel `pixel` of `frame`: this frame's reservoir `own` (its count is its
/// `m`) merged with the history's record `history` (None: none kept), capped at `cap`.
/// `target(light)` is `p_hat` here; `proxy(light)` the target at the history's point,
/// normal and material seen from the previous eye. Returns the merged reservoir (count 1:
/// [`Reservoir::weight`] is `W`) and the count it stands for.
pub fn merge(
    own: &Reservoir,
    history: Option<&Record>,
    (pixel, frame, cap): (u32, u32, u32),
    target: impl Fn(u32) -> f32,
    proxy: impl Fn(u32) -> f32,
) -> (Reservoir, u32) {
    let m_own = own.m;
    let m_history = history.map_or(0, |h| capped(h.count, m_own, cap));
    let (a, b) = (m_own as f32, m_history as f32);
    let mut r = Reservoir::default();
    // This frame's light: its share is its count's part of the light's targets.
    let w0 = own.weight();
    let mut w = 0.0;
    if w0 > 0.0 {
        // Without history its proxy is not evaluated (the GPU's point is then unset).
        let (p, q) = (own.p_hat, if m_history > 0 { proxy(own.light) } else { 0.0 });
        w = a * p / (a * p + b * q) * p * w0;
    }
    r.update(own.light, (w, own.p_hat), 0.0);
    if let Some(h) = history.filter(|h| m_history > 0 && h.weight > 0.0) {
        let (p, q) = (target(h.light), proxy(h.light));
        let total = a * p + b * q;
        let w = if total > 0.0 { b * q / total * p * h.weight } else { 0.0 };
        r.update(h.light, (w, p), rand01(pixel, frame, DRAW));
    }
    r.m = 1;
    (r, m_own + m_history)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;

    fn camera(eye: Vec3) -> Camera {
        Camera::perspective(eye, Vec3::ZERO, Vec3::Y, 60f32.to_radians(), 1.5, 0.1, None).expect("camera")
    }

    /// A point seen through the centre of the previous view reprojects to the screen's
    /// centre at its distance; one behind the camera or beside the frustum has no pixel.
    #[test]
    fn reprojection_finds_the_pixel_and_the_distance() {
        let c = camera(Vec3::new(0.0, 0.0, 10.0));
        let (vp, v) = (c.view_proj(), c.view());
        let m = (&vp, &v);
        let ((x, y), d) = reproject(Vec3::ZERO, m, (300, 200)).expect("on screen");
        assert_eq!((x, y), (150, 100));
        assert!((d - 10.0).abs() < 1e-4, "{d}");
        // Up and to the right: a smaller row, a larger column.
        let ((x, y), _) = reproject(Vec3::new(1.0, 1.0, 0.0), m, (300, 200)).expect("on screen");
        assert!(x > 150 && y < 100, "({x}, {y})");
        assert!(reproject(Vec3::new(0.0, 0.0, 20.0), m, (300, 200)).is_none(), "behind the eye");
        assert!(reproject(Vec3::new(100.0, 0.0, 0.0), m, (300, 200)).is_none(), "beside the frustum");
        assert!(reproject(Vec3::new(0.0, -100.0, 0.0), m, (300, 200)).is_none(), "below the frustum");
    }

    fn record(light: u32, weight: f32, count: u32) -> Record {
        Record { light, count, weight, normal: Vec3::Z, dist: 10.0, surface: [0; 2] }
    }

    /// The same surface passes; the occluder's (nearer by more than 10%), another normal
    /// and the sky do not.
    #[test]
    fn a_disoccluded_pixel_finds_no_history() {
        let h = record(3, 1.0, 20);
        assert!(same_surface(Vec3::Z, 10.5, &h));
        assert!(!same_surface(Vec3::Z, 12.0, &h), "the history is an occluder in front");
        assert!(!same_surface(Vec3::X, 10.0, &h), "another face");
        assert!(!same_surface(Vec3::Z, 10.0, &Record { dist: 0.0, ..h }), "the sky");
    }

    /// The cap bounds the history's count by this frame's, and an empty frame takes none.
    #[test]
    fn the_history_is_capped_by_this_frames_count() {
        assert_eq!(capped(1000, 20, 20), 400);
        assert_eq!(capped(100, 20, 20), 100);
        assert_eq!(capped(100, 0, 20), 0);
        assert_eq!(capped(u32::MAX, u32::MAX, MAX_CAP), u32::MAX);
    }

    /// A reservoir of `m` candidates that kept `light` with target `p_hat` and `W` `w`.
    fn reservoir(light: u32, p_hat: f32, w: f32, m: u32) -> Reservoir {
        Reservoir { light, p_hat, w_sum: w * m as f32 * p_hat, m }
    }

    /// With the same target here and there, each input's share is its count's part, so
    /// the merged `W p_hat` is the count-weighted mean of the two `W p_hat`s (the
    /// estimate's expectation is kept); without history the reservoir is this frame's.
    #[test]
    fn the_merge_weighs_each_input_by_its_count() {
        let own = reservoir(1, 2.0, 0.5, 20);
        let hist = record(1, 1.5, 60);
        let (r, count) = merge(&own, Some(&hist), (0, 0, 20), |_| 2.0, |_| 2.0);
        assert_eq!(count, 80);
        // Both inputs hold light 1: W p_hat = (20 * 0.5 * 2 + 60 * 1.5 * 2) / 80 = 2.5.
        assert!((r.weight() * r.p_hat - 2.5).abs() < 1e-5, "{r:?}");
        let (alone, count) = merge(&own, None, (0, 0, 20), |_| 2.0, |_| 2.0);
        assert_eq!((alone.light, count), (1, 20));
        assert!((alone.weight() - own.weight()).abs() < 1e-6);
        // A history the cap holds to 1x: its share falls to a half.
        let (r, count) = merge(&own, Some(&hist), (0, 0, 1), |_| 2.0, |_| 2.0);
        assert_eq!(count, 40);
        assert!((r.weight() * r.p_hat - 2.0).abs() < 1e-5, "{r:?}");
    }

    /// The balance heuristic's shares follow the targets: a light the history's surface
    /// cannot see (proxy 0) takes its whole weight from this frame, and a history light
    /// dark here (target 0) is never kept.
    #[test]
    fn the_shares_follow_where_each_input_sees_the_light() {
        let own = reservoir(1, 2.0, 0.5, 20);
        let hist = record(2, 1.0, 20);
        let (r, _) = merge(&own, Some(&hist), (0, 0, 20), |_| 2.0, |l| if l == 1 { 0.0 } else { 2.0 });
        // Light 1 enters with its whole share (1 x 2 x 0.5), light 2 with half (0.5 x 2 x 1).
        let mut kept = std::collections::HashSet::new();
        for pixel in 0..64 {
            let (r2, _) = merge(&own, Some(&hist), (pixel, 0, 20), |_| 2.0, |l| if l == 1 { 0.0 } else { 2.0 });
            kept.insert(r2.light);
            assert!((r2.w_sum - 2.0).abs() < 1e-5, "{r2:?}");
        }
        assert_eq!(kept.len(), 2, "both lights are kept by some pixel");
        assert!(r.w_sum > 0.0);
        let dark = |l: u32| if l == 2 { 0.0 } else { 2.0 };
        for pixel in 0..64 {
            let (r2, _) = merge(&own, Some(&hist), (pixel, 0, 20), dark, |_| 2.0);
            assert_eq!(r2.light, 1, "a light dark here is kept");
        }
        // An empty history record (no light kept) offers nothing.
        let (r2, count) = merge(&own, Some(&Record { weight: 0.0, ..hist }), (0, 0, 20), |_| 2.0, |_| 2.0);
        assert_eq!((r2.light, count), (1, 40));
        // Its count still takes half of light 1's share: it could have drawn it.
        assert!((r2.w_sum - 0.5).abs() < 1e-5, "{r2:?}");
    }
}
