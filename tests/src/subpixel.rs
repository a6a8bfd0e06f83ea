//! What one step of the rasteriser's sub-pixel grid does to a textured reference, measured
//! by rendering it: the visibility buffer shades the exact point of its triangle under the
//! pixel's centre, a rasterised reference (brute force) the point its snapped vertices
//! interpolate to, up to half a step of [`RASTER_POSITION_ERROR_PX`] away.
//! [`Frame::allow_position_error`] bounds what that shift does to the lighting in closed
//! form; a texture lookup has no such bound: where a texel edge (or, with a nearest mip
//! filter, a level boundary) passes between the two points, the lookup flips to the next
//! texel, a change as large as the texture's contrast. On the H100 the many-material
//! scene's far, minified boxes showed 40 such pixels among 12,288 (worst 2.34 relative, a
//! checker's two greens), where lavapipe showed none.
//!
//! 1. Render the reference with its camera turned by one grid step in each of the eight
//!    directions of the 3x3 step neighbourhood ([`shifted_camera`]). Half a step in any
//!    direction stays inside the square those eight points span, and a texel edge (a
//!    straight line at this scale) that separates the centre from a point within half a
//!    step also separates it from one of the eight: their projections on any direction
//!    reach at least one step.
//! 2. Per pixel, keep the shifted values whose depth says they show the same surface
//!    ([`same_surface`]): at a silhouette the shift reaches another surface, which the
//!    ID pass decides and this allowance must not forgive.
//! 3. The allowance is the largest change among them ([`Frame::allow_subpixel_shift`]);
//!    [`shifted_lookups`] lets FLIP skip the pixels that needed it, at most 1% of them.
//!
//! Depends on the frame and gpu crates (rendering), the cull crate's camera, and this
//! crate's comparison helpers.

use glam::{Mat4, Vec3};
use tiledlight_cull::camera::Projection;
use tiledlight_cull::Camera;
use tiledlight_frame::{Diagnostics as _, FrameRenderer};
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::GpuContext;

use crate::compare::{pixel_errors, render_frame, Frame, Tolerance, RASTER_POSITION_ERROR_PX};

/// `camera` turned (perspective) or moved (orthographic) so that its image shifts by
/// `(dx, dy)` times `step_px` pixels of an image `h` pixels high (exactly at the centre;
/// towards a wide perspective view's edges by up to `1 / cos^2` of the half-angle more).
pub fn shifted_camera(camera: &Camera, h: u32, (dx, dy): (f32, f32), step_px: f32) -> Camera {
    let shift = match camera.projection() {
        Projection::Perspective { fov_y, .. } => {
            // One pixel at the centre subtends 2 tan(fov / 2) / h radians; turning the
            // view-space points right (about -y) moves the image right, turning them down
            // (about -x) moves it down (pixel rows count downwards).
            let a = step_px * 2.0 * (0.5 * fov_y).tan() / h as f32;
            Mat4::from_rotation_y(-dx * a) * Mat4::from_rotation_x(-dy * a)
        }
        Projection::Orthographic { half_height, .. } => {
            let t = step_px * 2.0 * half_height / h as f32;
            Mat4::from_translation(Vec3::new(dx * t, -dy * t, 0.0))
        }
    };
    Camera::from_view(shift * camera.view(), camera.projection()).expect("a shifted camera of a valid one is valid")
}

/// Whether a shifted frame's depth `shifted` at a pixel shows the surface the reference's
/// `depth` does there: within 1/16 of the largest depth step to the pixel's four neighbours
/// (`neighbour_step`). One grid step moves a surface's depth by 1/256 of a pixel's step
/// (1/181 diagonally); another surface at a silhouette differs by about the step itself.
/// A surface of constant depth (seen head-on by an orthographic camera) has no step: there
/// 2^-20 of the depth (a few f32 roundings) is the same surface.
pub fn same_surface(depth: f32, shifted: f32, neighbour_step: f32) -> bool {
    depth > 0.0 && shifted > 0.0 && (shifted - depth).abs() <= neighbour_step / 16.0 + depth * 2f32.powi(-20)
}

/// The reference of `r` through `camera` shifted by one step of [`RASTER_POSITION_ERROR_PX`]
/// in each of the eight directions, each with its depth (step 1): the input of
/// [`Frame::allow_subpixel_shift`].
pub fn shifted_frames(
    ctx: &GpuContext,
    r: &mut FrameRenderer,
    scene: &SceneGpu,
    camera: &Camera,
    h: u32,
) -> Vec<(Frame, Vec<f32>)> {
    let mut out = Vec::new();
    for dy in -1..=1 {
        for dx in -1..=1 {
            if (dx, dy) == (0, 0) {
                continue;
            }
            let cam = shifted_camera(camera, h, (dx as f32, dy as f32), RASTER_POSITION_ERROR_PX);
            let frame = render_frame(ctx, r, scene, &cam);
            let depth = r.read_depth(ctx).expect("shifted frame's depth");
            out.push((frame, depth));
        }
    }
    out
}

impl Frame {
    /// Raises, per pixel, the allowance to the largest change (largest channel) among the
    /// `shifted` frames that show the same surface there (steps 2 and 3). `depth` is this
    /// frame's depth, `w` its width.
    pub fn allow_subpixel_shift(mut self, depth: &[f32], w: u32, shifted: &[(Frame, Vec<f32>)]) -> Self {
        let h = (self.hdr.len() / w as usize) as u32;
        if self.allowance.is_empty() {
            self.allowance = vec![0.0; self.hdr.len()];
        }
        for i in 0..self.hdr.len() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let neighbours = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
            let step = neighbours
                .iter()
                .filter(|&&(nx, ny)| nx < w && ny < h)
                .map(|&(nx, ny)| (depth[(ny * w + nx) as usize] - depth[i]).abs())
                .fold(0.0f32, f32::max);
            let change = shifted
                .iter()
                .filter(|(_, d)| same_surface(depth[i], d[i], step))
                .map(|(f, _)| (0..3).map(|c| (f.hdr[i][c] - self.hdr[i][c]).abs()).fold(0.0f32, f32::max))
                .fold(0.0f32, f32::max);
            self.allowance[i] = self.allowance[i].max(change);
        }
        self
    }
}

/// `actual` with the tonemapped values of the pixels that only the sub-pixel shift's
/// allowance accepts taken from the reference, so that FLIP compares the others: `without`
/// and `with_shift` are the same reference before and after [`Frame::allow_subpixel_shift`].
/// Asserts that at most 1% of the covered pixels (`covered`) need it: a wrong texture or a
/// shifted image changes far more pixels than a sub-pixel step flips. Prints the count.
pub fn shifted_lookups(
    name: &str,
    (without, with_shift): (&Frame, &Frame),
    actual: Frame,
    t: Tolerance,
    covered: usize,
) -> Frame {
    let (before, after) = (pixel_errors(without, &actual, t), pixel_errors(with_shift, &actual, t));
    let mask: Vec<bool> = before.iter().zip(&after).map(|(&b, &a)| b > t.hdr_rel && a <= t.hdr_rel).collect();
    let n = mask.iter().filter(|&&m| m).count();
    eprintln!("{name}: {n} of {covered} covered pixels within one sub-pixel step's texture lookups only");
    assert!(
        n * 100 <= covered,
        "{name}: {n} of {covered} covered pixels are accepted only by the sub-pixel shift: more than a texel flip explains"
    );
    actual.with_ldr_from(&mask, with_shift)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;

    /// A point at the image centre moves by one step right and down under (1, 1), and one
    /// step left under (-1, 0), for a perspective and an orthographic camera.
    #[test]
    fn a_shifted_camera_moves_the_image_by_the_step() {
        let (w, h) = (320u32, 180u32);
        let persp =
            Camera::perspective(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y, 1.0, w as f32 / h as f32, 0.1, None)
                .unwrap();
        let ortho =
            Camera::orthographic(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y, 3.0, w as f32 / h as f32, 0.1, 50.0)
                .unwrap();
        let pixel = |c: &Camera, p: Vec3| {
            let clip = c.view_proj() * p.extend(1.0);
            let ndc = clip / clip.w;
            // y down in pixels, as the rasteriser counts.
            ((ndc.x + 1.0) * 0.5 * w as f32, (1.0 - ndc.y) * 0.5 * h as f32)
        };
        for cam in [persp, ortho] {
            let p = (cam.view().inverse() * Vec4::new(0.0, 0.0, -5.0, 1.0)).truncate();
            let base = pixel(&cam, p);
            for ((dx, dy), step) in [((1.0, 1.0), 0.5), ((-1.0, 0.0), 1.0 / 256.0)] {
                let moved = pixel(&shifted_camera(&cam, h, (dx, dy), step), p);
                let (mx, my) = (moved.0 - base.0, moved.1 - base.1);
                assert!((mx - dx * step).abs() < 0.02 * step && (my - dy * step).abs() < 0.02 * step, "{mx} {my}");
            }
        }
    }

    /// The same surface passes; another surface at a silhouette, sky and a shift of a
    /// whole pixel's depth step do not.
    #[test]
    fn same_surface_rejects_a_silhouette_and_sky() {
        assert!(same_surface(0.5, 0.5001, 0.01));
        assert!(!same_surface(0.5, 0.49, 0.01), "a whole neighbour step away");
        assert!(!same_surface(0.5, 0.0, 0.5), "sky");
        assert!(!same_surface(0.0, 0.0, 0.0), "sky in the reference");
    }

    /// A pixel whose shifted frames show a flipped texel gets their change; one whose
    /// shifted frames reach another surface (its depth a neighbour's step away) gets none.
    #[test]
    fn the_allowance_takes_the_same_surface_only() {
        let w = 3;
        let depth = vec![0.5, 0.5, 0.9, 0.5, 0.5, 0.5];
        let frame = |v: f32| Frame { hdr: vec![[v, v, v, 1.0]; 6], ldr: vec![0; 24], allowance: Vec::new() };
        let mut flipped = frame(1.0);
        flipped.hdr[0] = [3.0, 1.0, 1.0, 1.0];
        let mut other = frame(1.0);
        other.hdr[1] = [9.0, 9.0, 9.0, 1.0];
        let mut other_depth = depth.clone();
        other_depth[1] = 0.9;
        let shifted = vec![(flipped, depth.clone()), (other, other_depth)];
        let a = frame(1.0).allow_subpixel_shift(&depth, w, &shifted).allowance;
        assert_eq!(a[0], 2.0);
        assert_eq!(a[1], 0.0, "another surface's value is not allowed");
        assert!(a[2..].iter().all(|&v| v == 0.0));
    }
}
