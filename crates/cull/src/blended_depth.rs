//! An independent CPU raster of a depth buffer, with bounds: per depth sample, the nearest
//! depth of a set of world-space triangles (what a depth-only pass with `Greater`
//! reversed-Z testing and a clear of 0 stores), computed from the triangles and the camera
//! alone. Tests check the GPU's blended lists with it (`tests/tests/blended.rs`) without
//! reading the GPU's own blended depth buffer: a GPU pass that skipped an instance, drew
//! the wrong layer or kept the wrong depth cannot then agree with its own twin.
//!
//! A GPU does not rasterise the exact triangles: it snaps the projected vertices to its
//! sub-pixel grid and rounds in f32, so a sample near a silhouette may be covered or not,
//! and a covered sample's depth may move with the plane's slope. [`raster_depth`] therefore
//! returns, per sample, the exact value and a `least` and a `most` value that every GPU
//! within `reach` pixels of vertex displacement lies between (first principles in
//! [`raster_depth`]'s docs). Depth-only: no alpha test, no face culling (the triangles
//! must be the double-sided or front-facing ones the GPU draws).
//!
//! Pure CPU; depends on glam and [`crate::Camera`].

use glam::{DVec2, DVec4, Vec3};

use crate::Camera;

/// The standard MSAA sample positions (Vulkan, D3D and Metal agree), in pixels from the
/// pixel's top-left corner; 1 sample is the pixel centre. `None` for other counts.
pub fn standard_sample_positions(samples: u32) -> Option<&'static [(f32, f32)]> {
    Some(match samples {
        1 => &[(0.5, 0.5)],
        2 => &[(0.75, 0.75), (0.25, 0.25)],
        4 => &[(0.375, 0.125), (0.875, 0.375), (0.125, 0.625), (0.625, 0.875)],
        8 => &[
            (0.5625, 0.3125),
            (0.4375, 0.6875),
            (0.8125, 0.5625),
            (0.3125, 0.1875),
            (0.1875, 0.8125),
            (0.0625, 0.4375),
            (0.6875, 0.9375),
            (0.9375, 0.0625),
        ],
        _ => return None,
    })
}

/// Per depth sample (`samples` values per pixel, pixel-major, row-major pixels: the layout
/// of `CullConfig::samples`), reversed-Z depths; 0 where no triangle is drawn.
#[derive(Clone, Debug, Default)]
pub struct DepthBounds {
    /// The exact triangles' nearest depth at the sample position.
    pub exact: Vec<f32>,
    /// At most the GPU's value: 0 unless some triangle certainly covers the sample, else
    /// the largest lower bound of such a triangle's depth there.
    pub least: Vec<f32>,
    /// At least the GPU's value: the largest upper bound of the depth of every triangle
    /// that may cover the sample (0 when none may).
    pub most: Vec<f32>,
}

/// The relative depth rounding allowed per triangle: 2^-16 of its largest vertex depth.
/// The GPU computes each vertex's `z / w` and interpolates it in f32 (a few ulps, ~1e-7
/// relative); 2^-16 is far above that and still only 0.15 mm at 10 m of view distance.
pub const DEPTH_ROUNDING: f64 = 1.0 / 65536.0;

/// Rasterises `triangles` (world space) seen by `camera` into a `width` x `height` buffer
/// of `samples` samples a pixel at the standard positions ([`standard_sample_positions`]).
///
/// Bounds, for a GPU whose rasterised triangle has every projected vertex within `reach`
/// pixels of the exact one (sub-pixel snapping and f32 rounding):
/// - **Coverage.** Every point of the snapped triangle is a convex combination of the
///   snapped vertices, so it lies within `reach` of the exact triangle: a sample farther
///   than `reach` outside some edge line cannot be covered. Conversely a
///   sample deeper than `reach` inside every edge has a disc of that radius inside the
///   exact triangle; were it outside the snapped one, a line through it would leave all
///   snapped vertices on one side and the exact vertices within `reach` of that side,
///   which the disc contradicts. So signed edge distance `> reach`: covered; `< -reach`:
///   not; between: either (`least` ignores the triangle, `most` counts it).
/// - **Depth.** Reversed-Z depth is affine in screen space over a triangle. The GPU
///   interpolates the exact vertex depths with the snapped triangle's barycentrics `l'`,
///   which is the exact plane's depth at `sum l'_i v_i`, a point within `reach` of the
///   sample: so it differs from the exact plane's by at most `|grad z| reach`, plus
///   [`DEPTH_ROUNDING`].
///
/// Errors (no raster is made) when `samples` is not 1, 2, 4 or 8, a size is 0, or a
/// triangle has a vertex behind the eye or in front of the near plane (depth > 1): this
/// raster does not clip (keep such triangles out).
pub fn raster_depth(
    camera: &Camera,
    (width, height): (u32, u32),
    samples: u32,
    triangles: &[[Vec3; 3]],
    reach: f64,
) -> Result<DepthBounds, String> {
    let positions = standard_sample_positions(samples).ok_or_else(|| format!("{samples} samples: use 1, 2, 4 or 8"))?;
    if width == 0 || height == 0 {
        return Err(format!("{width}x{height}: empty buffer"));
    }
    let n = width as usize * height as usize * samples as usize;
    let mut out = DepthBounds { exact: vec![0.0; n], least: vec![0.0; n], most: vec![0.0; n] };
    let vp = camera.view_proj().as_dmat4();
    let (w, h) = (f64::from(width), f64::from(height));
    for (t, tri) in triangles.iter().enumerate() {
        // Screen position (pixels from the top-left corner) and depth of each vertex.
        let mut v = [DVec2::ZERO; 3];
        let mut z = [0.0f64; 3];
        for k in 0..3 {
            let c: DVec4 = vp * tri[k].as_dvec3().extend(1.0);
            let d = c.z / c.w;
            // Written so NaN fails it.
            let in_front = c.w > 0.0 && d <= 1.0 && c.is_finite();
            if !in_front {
                return Err(format!("triangle {t}: vertex {} is behind the eye or the near plane", tri[k]));
            }
            v[k] = DVec2::new((c.x / c.w + 1.0) * 0.5 * w, (1.0 - c.y / c.w) * 0.5 * h);
            z[k] = d;
        }
        let area = (v[1] - v[0]).perp_dot(v[2] - v[0]);
        if area == 0.0 || !area.is_finite() {
            continue; // edge-on: no sample is covered, by the GPU either.
        }
        // Depth plane z = z0 + a (x - x0) + b (y - y0) (Cramer's rule).
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let (dz1, dz2) = (z[1] - z[0], z[2] - z[0]);
        let a = (dz1 * e2.y - dz2 * e1.y) / area;
        let b = (e1.x * dz2 - e2.x * dz1) / area;
        let slack = (a * a + b * b).sqrt() * reach + DEPTH_ROUNDING * z.iter().fold(0.0f64, |m, &d| m.max(d.abs()));
        let plane = |p: DVec2| z[0] + a * (p.x - v[0].x) + b * (p.y - v[0].y);
        // Edge lines as unit normals pointing inside, so `n . p + c` is the signed distance.
        let sign = area.signum();
        let edges: [(DVec2, f64); 3] = std::array::from_fn(|k| {
            let (p, q) = (v[k], v[(k + 1) % 3]);
            let d = q - p;
            let normal = DVec2::new(-d.y, d.x) * sign / d.length();
            (normal, -normal.dot(p))
        });
        let lo = v.iter().fold(DVec2::splat(f64::INFINITY), |m, p| m.min(*p)) - reach;
        let hi = v.iter().fold(DVec2::splat(f64::NEG_INFINITY), |m, p| m.max(*p)) + reach;
        let (x0, y0) = (lo.x.floor().max(0.0) as u32, lo.y.floor().max(0.0) as u32);
        let (x1, y1) = ((hi.x.ceil().min(w) as u32).min(width), (hi.y.ceil().min(h) as u32).min(height));
        for py in y0..y1 {
            for px in x0..x1 {
                for (s, &(sx, sy)) in positions.iter().enumerate() {
                    let p = DVec2::new(f64::from(px) + f64::from(sx), f64::from(py) + f64::from(sy));
                    let inside = edges.iter().map(|(nrm, c)| nrm.dot(p) + c).fold(f64::INFINITY, f64::min);
                    if inside < -reach {
                        continue;
                    }
                    let i = (py as usize * width as usize + px as usize) * samples as usize + s;
                    let d = plane(p);
                    // `most`: possibly covered, at its largest depth; `least`: certainly.
                    out.most[i] = out.most[i].max((d + slack) as f32);
                    if inside > reach {
                        out.least[i] = out.least[i].max((d - slack).max(f64::MIN_POSITIVE) as f32);
                    }
                    if inside >= 0.0 {
                        out.exact[i] = out.exact[i].max(d as f32);
                    }
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 1.0, 16.0 / 9.0, 0.1, None)
            .unwrap()
    }

    /// A square facing the camera, `2 half` wide at height `z`: 9 px wide at 7 m in [`camera`] at 64x36.
    fn square(z: f32, half: f32) -> Vec<[Vec3; 3]> {
        let c = |x: f32, y: f32| Vec3::new(x, y, z);
        vec![[c(-half, -half), c(half, -half), c(half, half)], [c(-half, -half), c(half, half), c(-half, half)]]
    }

    /// A front-facing square's depth is the camera's depth of its distance at every covered
    /// sample; `least <= exact <= most` everywhere; the bounds differ only near its edges.
    #[test]
    fn a_square_has_the_cameras_depth_and_tight_bounds() {
        let cam = camera();
        let (w, h) = (64, 36);
        let b = raster_depth(&cam, (w, h), 4, &square(-3.0, 1.0), 0.125).unwrap();
        let want = cam.depth_params().depth(7.0);
        let mut covered = 0;
        for i in 0..b.exact.len() {
            assert!(b.least[i] <= b.exact[i] && b.exact[i] <= b.most[i], "sample {i}: {b:?}");
            if b.exact[i] > 0.0 {
                covered += 1;
                assert!((b.exact[i] - want).abs() <= 1e-6 * want, "{} vs {want}", b.exact[i]);
            }
        }
        let uncertain = (0..b.exact.len()).filter(|&i| (b.least[i] > 0.0) != (b.most[i] > 0.0)).count();
        assert!(covered > 300 && uncertain < covered / 4, "{covered} covered, {uncertain} uncertain");
    }

    /// The nearer of two overlapping squares wins; a triangle through the near plane is
    /// refused; a bad sample count is refused.
    #[test]
    fn nearest_wins_and_bad_input_is_refused() {
        let cam = camera();
        let mut tris = square(-5.0, 1.0);
        tris.extend(square(-3.0, 0.5));
        let b = raster_depth(&cam, (64, 36), 1, &tris, 0.125).unwrap();
        let centre = 18 * 64 + 32;
        assert!((b.exact[centre] - cam.depth_params().depth(7.0)).abs() < 1e-6);
        assert!(raster_depth(&cam, (64, 36), 3, &tris, 0.125).is_err());
        let through = vec![[Vec3::new(0.0, 0.0, 5.0), Vec3::new(1.0, 0.0, -5.0), Vec3::new(0.0, 1.0, -5.0)]];
        assert!(raster_depth(&cam, (64, 36), 1, &through, 0.125).is_err());
    }
}
