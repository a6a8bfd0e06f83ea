//! The stochastic method's denoiser (issue 48, step 4), the CPU twin of
//! `shaders/stochastic_denoise.wgsl`: an edge-avoiding à-trous wavelet filter guided by
//! each pixel's surface and by the variance of its estimate (Dammertz et al. 2010; the
//! variance guidance of SVGF, Schied et al. 2017), on the lit part of the image divided by
//! the surface's albedo (so textures are not blurred), the result multiplied back.
//!
//! 1. [`demodulate`]: each pixel's accumulated light (the mean of `frames` frames' estimates)
//!    divided by its albedo, and the variance of that mean: from the history's second
//!    moment once [`SHORT_HISTORY`] frames are in it, else from the 3x3 neighbours on the
//!    same surface (one frame has no variance of its own).
//! 2. [`atrous`], `iterations` times with steps 1, 2, 4, ...: a 5x5 B3-spline kernel whose
//!    taps are weighted by how alike the two surfaces are (normal, view distance against the
//!    local depth slope) and how alike the two estimates are relative to the noise the
//!    variance predicts (the larger of the two pixels' predictions, so a dark pixel takes
//!    the light a bright neighbour gives away: with each pixel's own, as SVGF has it, a
//!    first frame lost 15% of its light in the GPU test); the variance is filtered along
//!    (squared weights).
//! 3. [`remodulate`]: the unlit term plus the albedo times the filtered light.
//!
//! As frames accumulate the variance of the mean falls, so the luminance weight narrows
//! and a still view converges to the accumulated (unbiased) mean; the first frames are
//! smoothed the most. Sky pixels (view distance 0) are neither filtered nor taps.
//!
//! Pure math on slices of `[f32; 4]` texels, as the GPU buffers hold them. Depends on
//! [`crate::exposure`] (the luminance) only.

use crate::exposure::luminance;

/// The smallest albedo a channel is divided by (a black texel would make the division
/// blow up its noise).
pub const DEMOD_FLOOR: f32 = 0.01;
/// Frames in the history from which its own variance is trusted; fewer take the 3x3
/// neighbours' spread.
pub const SHORT_HISTORY: u32 = 4;
/// How many predicted standard deviations two estimates may differ by at weight 1/e.
pub const SIGMA_L: f32 = 4.0;
/// How many local depth slopes two view distances may differ by at weight 1/e.
pub const SIGMA_Z: f32 = 1.0;
/// A floor on the luminance tolerance (a converged pixel filters nothing but its equals).
pub const EPS_L: f32 = 1e-6;
/// A floor on the depth tolerance, relative to the view distance.
pub const EPS_Z: f32 = 1e-3;
/// The B3-spline kernel's weights at offsets 0, 1 and 2.
pub const KERNEL: [f32; 3] = [3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];
/// The most iterations (steps up to 2^7 = 128 pixels).
pub const MAX_ITERATIONS: u32 = 8;

/// What the shading pass leaves for the filter, one `[f32; 4]` a pixel, row-major.
#[derive(Clone, Copy, Debug)]
pub struct Guide<'a> {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Unit normal (xyz) and view distance (w; 0: sky).
    pub surface: &'a [[f32; 4]],
    /// The albedo the light is divided by (rgb, each at least [`DEMOD_FLOOR`]).
    pub albedo: &'a [[f32; 4]],
    /// The unlit term (rgb: ambient, emission).
    pub unlit: &'a [[f32; 4]],
}

impl Guide<'_> {
    fn at(&self, x: i64, y: i64) -> Option<usize> {
        let inside = x >= 0 && y >= 0 && x < i64::from(self.width) && y < i64::from(self.height);
        let i = (y * i64::from(self.width) + x) as usize;
        (inside && self.surface[i][3] > 0.0).then_some(i)
    }
}

fn rgb(v: [f32; 4]) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

fn dot3(a: [f32; 4], b: [f32; 4]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `x^128` by squaring (the shader computes it the same way).
pub fn pow128(x: f32) -> f32 {
    let mut v = x;
    for _ in 0..7 {
        v *= v;
    }
    v
}

/// Whether two pixels are on one surface for the short history's spread: normals within
/// about 37 degrees, distances within 10%.
fn same_surface(p: [f32; 4], q: [f32; 4]) -> bool {
    dot3(p, q) > 0.8 && (p[3] - q[3]).abs() < 0.1 * p[3]
}

/// Step 1: the history's light (rgb of `history`: the mean of `frames` frames; a: the mean
/// of the squared luminance of each frame's light divided by the albedo) divided by the
/// albedo, and the variance of that mean. Sky pixels are zero.
pub fn demodulate(history: &[[f32; 4]], g: &Guide<'_>, frames: u32) -> Vec<[f32; 4]> {
    let n = frames.max(1) as f32;
    let d = |i: usize| {
        let a = g.albedo[i];
        [history[i][0] / a[0], history[i][1] / a[1], history[i][2] / a[2]]
    };
    let mut out = vec![[0.0; 4]; history.len()];
    for y in 0..i64::from(g.height) {
        for x in 0..i64::from(g.width) {
            let Some(i) = g.at(x, y) else { continue };
            let c = d(i);
            let l = luminance(c);
            let spread = if frames >= SHORT_HISTORY {
                (history[i][3] - l * l).max(0.0)
            } else {
                let (mut s1, mut s2, mut k) = (0.0f32, 0.0f32, 0.0f32);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let Some(j) = g.at(x + dx, y + dy) else { continue };
                        if same_surface(g.surface[i], g.surface[j]) {
                            let lj = luminance(d(j));
                            (s1, s2, k) = (s1 + lj, s2 + lj * lj, k + 1.0);
                        }
                    }
                }
                (s2 / k - (s1 / k) * (s1 / k)).max(0.0)
            };
            out[i] = [c[0], c[1], c[2], spread / n];
        }
    }
    out
}

/// The depth slope at `i` along one axis: the smaller difference to its two neighbours
/// there (0 without one on the surface).
fn slope(g: &Guide<'_>, (x, y): (i64, i64), (ax, ay): (i64, i64)) -> f32 {
    let here = g.surface[g.at(x, y).expect("a surface pixel")][3];
    let diff = |s: i64| g.at(x + s * ax, y + s * ay).map(|j| (g.surface[j][3] - here).abs());
    match (diff(1), diff(-1)) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => 0.0,
    }
}

/// Step 2, one iteration at `step` pixels: every surface pixel the weighted mean of its 5x5
/// taps (`step` apart) on surfaces like its own, and the variance of that mean.
pub fn atrous(src: &[[f32; 4]], g: &Guide<'_>, step: u32) -> Vec<[f32; 4]> {
    let s = i64::from(step);
    let mut out = src.to_vec();
    for y in 0..i64::from(g.height) {
        for x in 0..i64::from(g.width) {
            let Some(i) = g.at(x, y) else { continue };
            let p = g.surface[i];
            let (gx, gy) = (slope(g, (x, y), (1, 0)), slope(g, (x, y), (0, 1)));
            let l_p = luminance(rgb(src[i]));
            let (mut sum_w, mut sum_c, mut sum_v) = (0.0f32, [0.0f32; 3], 0.0f32);
            for dy in -2i64..=2 {
                for dx in -2i64..=2 {
                    let Some(j) = g.at(x + dx * s, y + dy * s) else { continue };
                    let h = KERNEL[dx.unsigned_abs() as usize] * KERNEL[dy.unsigned_abs() as usize];
                    let w = if dx == 0 && dy == 0 {
                        h
                    } else {
                        let q = g.surface[j];
                        let tol_z =
                            SIGMA_Z * (gx * dx.abs() as f32 + gy * dy.abs() as f32) * step as f32 + EPS_Z * p[3];
                        let l_q = luminance(rgb(src[j]));
                        // The larger of the two predicted deviations: a dark pixel next to
                        // a bright sample takes its share as the bright one gives it away.
                        let tol_l = SIGMA_L * src[i][3].max(src[j][3]).sqrt() + EPS_L;
                        let e = (p[3] - q[3]).abs() / tol_z + (l_p - l_q).abs() / tol_l;
                        h * pow128(dot3(p, q).max(0.0)) * (-e).exp()
                    };
                    sum_w += w;
                    for (k, c) in sum_c.iter_mut().enumerate() {
                        *c += w * src[j][k];
                    }
                    sum_v += w * w * src[j][3];
                }
            }
            out[i] = [sum_c[0] / sum_w, sum_c[1] / sum_w, sum_c[2] / sum_w, sum_v / (sum_w * sum_w)];
        }
    }
    out
}

/// Step 3: the linear HDR colour of every surface pixel (None for the sky, which the
/// filter leaves as the shading pass wrote it).
pub fn remodulate(filtered: &[[f32; 4]], g: &Guide<'_>) -> Vec<Option<[f32; 3]>> {
    (0..filtered.len())
        .map(|i| {
            (g.surface[i][3] > 0.0).then(|| {
                let (a, u, c) = (g.albedo[i], g.unlit[i], filtered[i]);
                [u[0] + a[0] * c[0], u[1] + a[1] * c[1], u[2] + a[2] * c[2]]
            })
        })
        .collect()
}

/// Steps 1 to 3: the denoised image of `history` (the mean of `frames` frames) after
/// `iterations` à-trous steps (0: the history itself, remodulated).
pub fn denoise(history: &[[f32; 4]], g: &Guide<'_>, frames: u32, iterations: u32) -> Vec<Option<[f32; 3]>> {
    let mut v = demodulate(history, g, frames);
    for k in 0..iterations {
        v = atrous(&v, g, 1 << k);
    }
    remodulate(&v, g)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One `[f32; 4]` a pixel.
    type Plane = Vec<[f32; 4]>;

    /// A w x h floor facing the camera at distance 5, albedo 0.5, nothing unlit: the
    /// surface, albedo and unlit planes.
    fn flat(w: u32, h: u32) -> (Plane, Plane, Plane) {
        let n = (w * h) as usize;
        (vec![[0.0, 0.0, 1.0, 5.0]; n], vec![[0.5, 0.5, 0.5, 0.0]; n], vec![[0.0; 4]; n])
    }

    /// Noise of a fixed pattern around 1 (mean 1 over the image).
    fn noisy(n: usize, amplitude: f32) -> Vec<[f32; 4]> {
        (0..n)
            .map(|i| {
                let u = ((i * 7919 + 13) % 101) as f32 / 100.0 - 0.5;
                let v = 1.0 + amplitude * u;
                [v, v, v, v * v / 0.25]
            })
            .collect()
    }

    fn mean_sq_error(img: &[Option<[f32; 3]>], want: f32) -> f32 {
        let e: Vec<f32> = img.iter().flatten().map(|c| (c[0] - want).powi(2)).collect();
        e.iter().sum::<f32>() / e.len() as f32
    }

    /// On one flat surface a first frame's noise falls by an order of magnitude, and the
    /// image's mean stays (the filter moves light, it does not make it).
    #[test]
    fn noise_on_one_surface_falls_and_the_mean_stays() {
        let (w, h) = (32, 24);
        let (surface, albedo, unlit) = flat(w, h);
        let g = Guide { width: w, height: h, surface: &surface, albedo: &albedo, unlit: &unlit };
        let history: Vec<[f32; 4]> =
            noisy((w * h) as usize, 0.8).iter().map(|c| [c[0] * 0.5, c[1] * 0.5, c[2] * 0.5, c[3]]).collect();
        let raw = denoise(&history, &g, 1, 0);
        let filtered = denoise(&history, &g, 1, 4);
        let (before, after) = (mean_sq_error(&raw, 0.5), mean_sq_error(&filtered, 0.5));
        assert!(after < before / 10.0, "{before} -> {after}");
        let mean = |img: &[Option<[f32; 3]>]| img.iter().flatten().map(|c| c[0]).sum::<f32>() / img.len() as f32;
        assert!((mean(&filtered) - mean(&raw)).abs() < 0.01 * mean(&raw), "{} {}", mean(&raw), mean(&filtered));
    }

    /// Two surfaces (a step in depth between the halves) keep their own light: nothing
    /// bleeds across, however long the filter's reach.
    #[test]
    fn light_does_not_cross_an_edge() {
        let (w, h) = (32, 16);
        let (mut surface, albedo, unlit) = flat(w, h);
        let mut history = vec![[0.5, 0.5, 0.5, 1.0]; (w * h) as usize];
        for y in 0..h {
            for x in w / 2..w {
                let i = (y * w + x) as usize;
                surface[i][3] = 9.0;
                history[i] = [0.05, 0.05, 0.05, 0.01];
            }
        }
        let g = Guide { width: w, height: h, surface: &surface, albedo: &albedo, unlit: &unlit };
        let out = denoise(&history, &g, 1, 5);
        for y in 0..h {
            let (left, right) = (out[(y * w + w / 2 - 1) as usize].unwrap(), out[(y * w + w / 2) as usize].unwrap());
            assert!((left[0] - 0.5).abs() < 1e-3 && (right[0] - 0.05).abs() < 1e-3, "{left:?} {right:?}");
        }
        // A surface turned away (normals 90 degrees apart at one distance) is an edge too.
        let mut turned = surface.clone();
        for s in turned.iter_mut().skip((w * h / 2) as usize) {
            *s = [1.0, 0.0, 0.0, 5.0];
        }
        let g = Guide { surface: &turned, ..g };
        let mut split = vec![[0.5, 0.5, 0.5, 1.0]; (w * h / 2) as usize];
        split.extend(vec![[0.05, 0.05, 0.05, 0.01]; (w * h / 2) as usize]);
        let out = denoise(&split, &g, 1, 5);
        assert!((out[0].unwrap()[0] - 0.5).abs() < 1e-3 && (out[(w * h - 1) as usize].unwrap()[0] - 0.05).abs() < 1e-3);
    }

    /// A converged history (its variance 0) is returned as it is: the filter adds no bias
    /// once the frames have removed the noise. Textures survive: the albedo is divided out
    /// and multiplied back.
    #[test]
    fn a_converged_history_and_its_texture_are_kept() {
        let (w, h) = (16, 16);
        let (surface, mut albedo, unlit) = flat(w, h);
        let mut history = vec![[0.0; 4]; (w * h) as usize];
        for (i, (a, hh)) in albedo.iter_mut().zip(history.iter_mut()).enumerate() {
            let t = if (i / 3) % 2 == 0 { 0.9 } else { 0.1 };
            *a = [t, t, t, 0.0];
            // Light 1 on every texel, the mean of many frames: a = l^2 exactly.
            *hh = [t, t, t, 1.0];
        }
        let g = Guide { width: w, height: h, surface: &surface, albedo: &albedo, unlit: &unlit };
        let out = denoise(&history, &g, 64, 5);
        for (o, a) in out.iter().zip(&albedo) {
            assert!((o.unwrap()[0] - a[0]).abs() < 1e-5, "{o:?} {a:?}");
        }
    }

    /// The sky is left alone and is no tap; the unlit term is added back; a broken guide
    /// (normals flipped) changes the result, so the twin test can tell.
    #[test]
    fn sky_unlit_and_a_broken_guide() {
        let (w, h) = (8, 8);
        let (mut surface, albedo, _) = flat(w, h);
        surface[0][3] = 0.0;
        let unlit = vec![[0.25, 0.0, 0.0, 0.0]; (w * h) as usize];
        let history = noisy((w * h) as usize, 0.5);
        let g = Guide { width: w, height: h, surface: &surface, albedo: &albedo, unlit: &unlit };
        let out = denoise(&history, &g, 1, 3);
        assert_eq!(out[0], None);
        assert!(out[1..].iter().all(|c| c.unwrap()[0] > 0.25 && c.unwrap()[1] < c.unwrap()[0]));
        let flipped: Vec<[f32; 4]> =
            surface.iter().enumerate().map(|(i, s)| if i % 2 == 0 { [0.0, 0.0, -1.0, s[3]] } else { *s }).collect();
        let broken = denoise(&history, &Guide { surface: &flipped, ..g }, 1, 3);
        assert_ne!(broken, out);
        assert_eq!(pow128(0.5), 0.5f32.powi(128));
    }
}
