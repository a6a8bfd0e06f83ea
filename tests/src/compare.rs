//! The image comparisons with the brute-force reference that the Forward+ and Tiled
//! Deferred tests make, as functions returning their numbers and verdicts, so a test can
//! assert that a comparison passes (`forward_vs_reference.rs`, `deferred.rs`) or that it
//! fails on a deliberately broken frame (`negative.rs`, which proves the thresholds bite).
//! The thresholds live here once, with the reasons for them.

use glam::Vec3;
use tiledlight_cull::brdf::{
    windowed_attenuation, MAX_DIFFUSE_COS, MAX_DIFFUSE_LIGHT_SLOPE, MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT, MAX_DIFFUSE_SLOPE,
};
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::Camera;
use tiledlight_frame::{FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::GpuContext;

use crate::images::{assert_flip, max_relative_error, save_png, FlipResult, FlipThresholds};

/// A rendered frame: linear HDR and the tonemapped sRGB image (RGBA8).
#[derive(Clone)]
pub struct Frame {
    /// Linear HDR, row-major.
    pub hdr: Vec<[f32; 4]>,
    /// Tonemapped sRGB, RGBA8, row-major.
    pub ldr: Vec<u8>,
    /// Per pixel, an absolute HDR difference a comparison with this frame as the reference
    /// forgives before the relative limit applies (empty: none); see
    /// [`Frame::allow_gbuffer_normals`].
    pub allowance: Vec<f32>,
}

/// How far the packed G-buffer normal's rounding can move `n.l`: the normal turns by at
/// most [`tiledlight_cull::gbuffer::max_normal_error`] (2.64e-4 rad, 0.0151 degrees: 14-bit
/// octahedral coordinates), and a unit vector turned by `e` changes its dot product with
/// another by at most `e`. The f16 xyz normal it replaced needed 4.9e-4 (2^-11).
pub fn gbuffer_normal_error() -> f32 {
    tiledlight_cull::gbuffer::max_normal_error() as f32
}

impl Frame {
    /// Adds, per pixel, what Tiled Deferred's packed normal may legitimately change: each
    /// light's diffuse term is `radiance x attenuation x diffuse(n.l, n.v) x n.l`, and the
    /// rounded normal moves `n.l` and `n.v` by up to [`gbuffer_normal_error`], so up to
    /// `radiance x attenuation x MAX_DIFFUSE_SLOPE x gbuffer_normal_error()` a light
    /// (`tiledlight_cull::brdf::MAX_DIFFUSE_SLOPE` holds for every albedo and metallic; spot
    /// falloff at most 1). Relative to the pixel that is small except for lights at grazing
    /// incidence: measured on the H200 (with the f16 normal, 2^-11, and the former Lambert
    /// diffuse), a courtyard pixel whose brightest light arrives at `n.l` = 0.0036 moved
    /// 3.1%, and the CPU BRDF fed that pixel's G-buffer normal gives the deferred value to
    /// 1e-4. A light missing from a pixel is far outside this allowance unless it arrives at
    /// grazing incidence (the allowance is 7e-4 of a light's contribution head-on and about
    /// 2.6e-4 / n.l^2 of it at small n.l, where the diffuse term falls as n.l^2).
    pub fn allow_gbuffer_normals(mut self, depth: &[f32], w: u32, camera: &Camera, lights: &PackedLights) -> Self {
        let h = (self.hdr.len() / w as usize) as u32;
        let inv_view = camera.view().inverse();
        self.allowance = (0..self.hdr.len())
            .map(|i| {
                let (x, y) = (i as u32 % w, i as u32 / w);
                let Some(pv) = pixel_view_position(camera, w, h, x, y, depth[i]) else { return 0.0 };
                let p = (inv_view * pv.extend(1.0)).truncate();
                let sum: f32 = lights
                    .shading
                    .iter()
                    .map(|l| {
                        let d2 = (Vec3::from(l.position) - p).length_squared();
                        if d2 >= l.radius * l.radius {
                            return 0.0;
                        }
                        Vec3::from(l.radiance).max_element() * windowed_attenuation(d2, l.radius)
                    })
                    .sum();
                sum * MAX_DIFFUSE_SLOPE * gbuffer_normal_error()
            })
            .collect();
        self
    }
}

impl Frame {
    /// Raises the per-pixel allowance to `extra` where that is larger (e.g.
    /// [`crate::gbuffer::surface_allowance`] on top of [`Frame::allow_gbuffer_normals`]).
    pub fn with_allowance(mut self, extra: &[f32]) -> Self {
        if self.allowance.is_empty() {
            self.allowance = vec![0.0; self.hdr.len()];
        }
        for (a, &e) in self.allowance.iter_mut().zip(extra) {
            *a = a.max(e);
        }
        self
    }
}

/// How far (as a fraction of a pixel's footprint on its surface) the rasteriser's
/// interpolated surface point may sit from the exact one that the visibility buffer
/// rebuilds ([`Frame::allow_position_error`]): one step of the sub-pixel grid the
/// rasteriser snaps vertices to (Vulkan's subPixelPrecisionBits, 8 on lavapipe and the
/// H200).
pub const RASTER_POSITION_ERROR_PX: f32 = 1.0 / 256.0;

impl Frame {
    /// Adds, per pixel, what moving the shaded point by `eps_px` of the pixel's footprint
    /// may legitimately change, for comparing the visibility buffer with brute force. The
    /// rasteriser interpolates attributes over vertices snapped to its sub-pixel grid (1/256
    /// px on lavapipe and the H200) with precision the API leaves to the implementation;
    /// the visibility buffer intersects the pixel's ray with the exact triangle. Where a
    /// light sits closer to the surface than a pixel is wide (surface lights, the million
    /// preset's), its inverse-square falloff turns that tiny shift into a visible change:
    /// measured on the H200, brute force moved 3.3% and 21% at two such pixels, where
    /// lavapipe's brute force and both adapters' visibility buffers agree to 1e-3. The
    /// footprint is the smallest distance from the pixel's point to a neighbour's (its own
    /// surface, grazing angles included). A light reaching the point adds `r A T`: its
    /// radiance (largest channel) `r`, attenuation `A` and `T = diffuse(n.l, n.v) x n.l`
    /// (diffuse light, the bounds `tiledlight_cull::brdf`'s over every albedo and metallic;
    /// Lambert's `1/pi` served for all of them before the diffuse term depended on the
    /// view). The shift changes that by at most the sum of three parts, over the lights:
    /// - the attenuation's change `dA` times `T`: at most `sum r dA MAX_DIFFUSE_COS`; the
    ///   lights' diffuse light `sum r A T` is part of the pixel `P` (its largest channel; a
    ///   blended layer over the surface scales that light and its change alike), so also at
    ///   most `max(dA / A) P` and, as
    ///   `T <= sqrt(T MAX_DIFFUSE_COS)` and by Cauchy-Schwarz, `sqrt(MAX_DIFFUSE_COS P sum
    ///   r dA^2 / A)`: the smallest of the three (the last two are far below the first
    ///   where the lights arrive at grazing incidence or are seen at grazing view, where `T`
    ///   is far below its maximum). Lights that reach the point only after the shift (A = 0)
    ///   count `r dA MAX_DIFFUSE_COS`;
    /// - the turn of `l` (`n.l` moves by up to `t = delta / d`) times `dT/d(n.l)`: at most
    ///   `sum r A t MAX_DIFFUSE_LIGHT_SLOPE`, and, as `dT/d(n.l) <= K sqrt(T)` (`K =
    ///   MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT`) and by Cauchy-Schwarz, at most `K sqrt(P sum r A
    ///   t^2)`: the smaller;
    /// - the turn of `v` (`n.v` moves by up to `delta` over the eye's distance; 0 in truth
    ///   for an orthographic camera) times `MAX_DIFFUSE_SLOPE`.
    ///
    /// The bounds that use `P` make the allowance tighter than Lambert's was on the
    /// negative test's frame (median 2.6e-3 of the pixel, p99 3.1e-2, against 2.4e-3 and
    /// 8.9e-2; without them 4.1e-3 and 0.13, over the limit in 19% of the lit pixels). A
    /// wrong triangle or a missing light changes a pixel by a whole light's contribution and
    /// stays far outside it.
    pub fn allow_position_error(
        mut self,
        depth: &[f32],
        w: u32,
        (camera, lights): (&Camera, &PackedLights),
        eps_px: f32,
    ) -> Self {
        let h = (self.hdr.len() / w as usize) as u32;
        let inv_view = camera.view().inverse();
        let eye = camera.eye();
        let world = |x: u32, y: u32| {
            let i = (y * w + x) as usize;
            pixel_view_position(camera, w, h, x, y, depth[i]).map(|v| (inv_view * v.extend(1.0)).truncate())
        };
        if self.allowance.is_empty() {
            self.allowance = vec![0.0; self.hdr.len()];
        }
        for i in 0..self.hdr.len() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let Some(p) = world(x, y) else { continue };
            let neighbours = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
            let footprint = neighbours
                .iter()
                .filter(|&&(nx, ny)| nx < w && ny < h)
                .filter_map(|&(nx, ny)| world(nx, ny))
                .map(|q| (q - p).length())
                .fold(f32::INFINITY, f32::min);
            if !footprint.is_finite() {
                continue;
            }
            let delta = eps_px * footprint;
            let turn_v = (delta / (p - eye).length().max(1e-6)).min(1.0);
            // The sums of the doc's three parts: sum r dA, sum r dA^2 / A and max dA / A over
            // the lights that reach the point, sum r dA over those that reach it only after
            // the shift; sum r A t and sum r A t^2; sum r A (for the turn of v).
            let (mut da, mut da_sq, mut da_ratio, mut entering) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
            let (mut turn, mut turn_sq, mut reach) = (0.0f32, 0.0f32, 0.0f32);
            for l in &lights.shading {
                let d = (Vec3::from(l.position) - p).length();
                if d >= l.radius + delta {
                    continue;
                }
                let at = |r: f32| windowed_attenuation(r * r, l.radius);
                let (a, near) = (at(d), at((d - delta).max(d * 0.5).max(1e-6)));
                let change = (near - a).abs().max((at(d + delta) - a).abs());
                let r = Vec3::from(l.radiance).max_element();
                if a > 0.0 {
                    da += r * change;
                    da_sq += r * change * change / a;
                    da_ratio = da_ratio.max(change / a);
                } else {
                    entering += r * change;
                }
                let t = (delta / d.max(1e-6)).min(1.0);
                turn += r * a * t;
                turn_sq += r * a * t * t;
                reach += r * a;
            }
            let pixel = self.hdr[i][0].max(self.hdr[i][1]).max(self.hdr[i][2]).max(0.0);
            let attenuation =
                (da * MAX_DIFFUSE_COS).min(da_ratio * pixel).min((MAX_DIFFUSE_COS * da_sq * pixel).sqrt());
            let turn_l =
                (turn * MAX_DIFFUSE_LIGHT_SLOPE).min(MAX_DIFFUSE_LIGHT_SLOPE_PER_SQRT * (turn_sq * pixel).sqrt());
            let sum = attenuation + entering * MAX_DIFFUSE_COS + turn_l + reach * turn_v * MAX_DIFFUSE_SLOPE;
            self.allowance[i] = self.allowance[i].max(sum);
        }
        self
    }
}

/// Renders one frame with `r` and reads both images back, through the lab's frame loop
/// (`tiledlight_lab::bench::render_frame`, the frame `render` and shadow-accuracy use).
pub fn render_frame(ctx: &GpuContext, r: &mut FrameRenderer, scene: &SceneGpu, camera: &Camera) -> Frame {
    let f = tiledlight_lab::bench::render_frame(ctx, r, scene, camera).expect("render");
    Frame { hdr: f.hdr, ldr: f.ldr, allowance: Vec::new() }
}

/// Renders the brute-force reference (same BRDF, radius cutoff on) of `scene` lit by
/// `lights` at `size` through `camera`: what every renderer's image is compared with.
pub fn reference_frame(
    ctx: &GpuContext,
    scene: &SceneGpu,
    lights: &LightBuffers,
    (w, h): (u32, u32),
    camera: &Camera,
) -> Frame {
    let settings = FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() };
    let mut r = FrameRenderer::new(ctx, scene, lights, w, h, settings).expect("brute-force renderer");
    render_frame(ctx, &mut r, scene, camera)
}

/// The limits of one comparison with the reference.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    /// Largest relative error of a linear HDR channel.
    pub hdr_rel: f32,
    /// Absolute floor of the relative error's denominator (near-black pixels).
    pub hdr_floor: f32,
    /// Limits on FLIP of the tonemapped images.
    pub flip: FlipThresholds,
}

/// Forward+ vs the brute-force reference (same BRDF, same radius cutoff): the lights are
/// summed in a different order (tile list order vs index order) in f32 and stored as f16,
/// so a pixel may differ by about one f16 ulp (2^-10 relative); 4e-3 relative (floor 1e-3
/// absolute for near-black) allows that with margin, while a single missing light
/// (typically >5% of a lit pixel) fails. On the tonemapped image, FLIP mean <= 1e-3 and
/// 99th percentile <= 1e-2.
pub const FORWARD_VS_REFERENCE: Tolerance =
    Tolerance { hdr_rel: 4e-3, hdr_floor: 1e-3, flip: FlipThresholds { mean: 1e-3, percentile: (0.99, 1e-2) } };

/// The visibility buffer vs the brute-force reference (same BRDF, cutoff and light grid as
/// Forward+; nothing quantised between its raster and its shading), compared with the
/// reference's position allowance ([`Frame::allow_position_error`]) and a few outliers
/// ([`VISIBILITY_OUTLIERS`]): its attributes are interpolated analytically on the triangle
/// as given, while the rasteriser interpolates them over vertex positions snapped to its
/// sub-pixel grid (8 bits on lavapipe and the H200) with precision the API leaves open.
/// HDR: on a magnified high-contrast texture that shifts the bilinear blend (measured on
/// lavapipe: 5.0e-3 on the mixed scene's 16x16 checker, at its cells' edges; untextured
/// surfaces 9.7e-4), so 1e-2 relative (floor 1e-3). FLIP: measured vis vs brute force,
/// mean / p99, lavapipe courtyard 0.0003 / 0.0049, H200 courtyard 0.0015 / 0.0103 and mixed
/// scene 0.0007 / 0.0077 (the H200's brute force strays from lavapipe's where the
/// visibility buffer does not: see `VISIBILITY_OUTLIERS`), so mean 3e-3, p99 2e-2. A
/// missing light (typically >5% of a lit pixel, over a whole tile) or a wrong triangle
/// fails.
pub const VISIBILITY_VS_REFERENCE: Tolerance =
    Tolerance { hdr_rel: 1e-2, hdr_floor: 1e-3, flip: FlipThresholds { mean: 3e-3, percentile: (0.99, 2e-2) } };

/// [`DEFERRED_VS_REFERENCE`] for a scene whose emission Tiled Deferred stores in
/// `Rg11b10Ufloat` (emissive, nothing occlusion-mapped, a device that renders to it:
/// `tiledlight_deferred::gbuffer::emission_format`): its 5-bit blue mantissa rounds to 2^-6
/// relative, 6-bit red and green to 2^-7, which an emission-only image shows: measured on
/// lavapipe, the emissive quad's FLIP mean 0.0156 (HDR 1.34e-2, blue). FLIP mean 0.02;
/// the HDR limit (3e-2) already holds it. The emission's per-channel bounds are checked
/// exactly in `materials.rs` (emissive_quad_lit_by_nothing).
pub const DEFERRED_SMALL_EMISSION_VS_REFERENCE: Tolerance =
    Tolerance { flip: FlipThresholds { mean: 0.02, ..DEFERRED_VS_REFERENCE.flip }, ..DEFERRED_VS_REFERENCE };

/// How far lavapipe's sRGB texture decode strays from the IEC 61966-2-1 formula, relative
/// (measured by `gbuffer_texel.rs`, the_texture_units_srgb_decode_against_the_formula:
/// 2.54e-2 at code 5, Mesa 22.3.6; the H200's 5.4e-3 at code 7).
/// Tiled Deferred's packed base colour therefore decodes through a table the texture unit
/// reads, as the other methods' textures do, not by the formula.
pub const LAVAPIPE_SRGB_DECODE_ERROR: f32 = 3e-2;

/// Tiled Deferred vs the brute-force reference (same BRDF and cutoff): the G-buffer stores
/// the albedo in 8-bit sRGB, as real deferred renderers do: half an sRGB step is about 1%
/// of the linear value in mid-dark tones (sRGB 100/255), so lit pixels differ by up to
/// ~1.5% everywhere. Measured on the courtyard (with the f16 normal this layout replaced):
/// max relative HDR error 1.3e-2, FLIP mean 0.0104 (p99 0.031); with an f16 albedo instead
/// (tried, not kept: 4 more bytes a pixel) 6.3e-3 and 0.0023, the rest coming from the
/// normal, roughness (8 bits) and positions rebuilt from depth. Limits: HDR 3e-2 relative
/// (floor 1e-2), FLIP mean 0.015 and p99 0.05; a missing light changes a lit pixel by well
/// over 5% and fails. The packed normal's effect on lights at grazing incidence (where
/// `n.l` is tiny, a 2.6e-4 shift is many percent) is not a relative error: a reference for
/// Tiled Deferred carries it per pixel ([`Frame::allow_gbuffer_normals`]).
pub const DEFERRED_VS_REFERENCE: Tolerance =
    Tolerance { hdr_rel: 3e-2, hdr_floor: 1e-2, flip: FlipThresholds { mean: 0.015, percentile: (0.99, 0.05) } };

/// The numbers and verdicts of one comparison.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Worst relative HDR error.
    pub hdr_error: f32,
    /// Pixel index of the worst HDR error.
    pub hdr_at: usize,
    /// FLIP of the tonemapped images (mean, the tolerance's percentile, max).
    pub flip: FlipResult,
    /// The HDR error is within the tolerance.
    pub hdr_ok: bool,
    /// FLIP mean and percentile are within the tolerance.
    pub flip_ok: bool,
}

impl Comparison {
    /// Both checks pass.
    pub fn passes(&self) -> bool {
        self.hdr_ok && self.flip_ok
    }
}

/// Compares `actual` with `reference` (both `w` x `h`) under `t`, and prints the numbers
/// under `name`.
pub fn compare_with_reference(name: &str, w: u32, reference: &Frame, actual: &Frame, t: Tolerance) -> Comparison {
    let (hdr_error, hdr_at) = if reference.allowance.is_empty() {
        max_relative_error(&reference.hdr, &actual.hdr, t.hdr_floor)
    } else {
        // What the reference's allowance forgives, then relative as above.
        let mut worst = (0.0f32, 0usize);
        for (i, (e, a)) in reference.hdr.iter().zip(&actual.hdr).enumerate() {
            for c in 0..3 {
                let err = ((a[c] - e[c]).abs() - reference.allowance[i]).max(0.0) / e[c].abs().max(t.hdr_floor);
                let err = if err.is_nan() { f32::INFINITY } else { err };
                if err > worst.0 {
                    worst = (err, i);
                }
            }
        }
        worst
    };
    if !reference.allowance.is_empty() {
        // The margin: how much the allowance forgave (the worst error without it, and the
        // pixels it was needed for).
        let (bare, bare_at) = max_relative_error(&reference.hdr, &actual.hdr, t.hdr_floor);
        let needed = (0..reference.hdr.len())
            .filter(|&i| {
                (0..3).any(|c| {
                    let d = (actual.hdr[i][c] - reference.hdr[i][c]).abs();
                    d / reference.hdr[i][c].abs().max(t.hdr_floor) > t.hdr_rel
                })
            })
            .count();
        eprintln!(
            "{name}: without the per-pixel allowance the worst error would be {bare:.2e} at ({}, {}); {needed} \
             pixel(s) need the allowance (limit {:.0e})",
            bare_at as u32 % w,
            bare_at as u32 / w,
            t.hdr_rel
        );
    }
    let h = (reference.hdr.len() / w as usize) as u32;
    let map = tiledlight_metrics::flip(w, h, &reference.ldr, &actual.ldr);
    let flip = map.summary(t.flip.percentile.0);
    eprintln!(
        "{name}: max relative HDR error {hdr_error:.2e} at ({}, {}); FLIP mean {:.5}, p{} {:.5}, max {:.5}",
        hdr_at as u32 % w,
        hdr_at as u32 / w,
        flip.mean,
        t.flip.percentile.0 * 100.0,
        flip.percentile,
        flip.max
    );
    let flip_ok = flip.mean <= t.flip.mean && flip.percentile <= t.flip.percentile.1;
    Comparison { hdr_error, hdr_at, hdr_ok: hdr_error <= t.hdr_rel, flip, flip_ok }
}

/// Asserts that `actual` matches `reference` under `t` (HDR first, then FLIP); on failure
/// writes `<name>-actual.png`, `<name>-expected.png` (and for FLIP `<name>-difference.png`)
/// to [`crate::output_dir`] and panics with the numbers.
pub fn assert_matches_reference_frame(name: &str, w: u32, reference: &Frame, actual: &Frame, t: Tolerance) {
    let c = compare_with_reference(name, w, reference, actual, t);
    let h = (reference.hdr.len() / w as usize) as u32;
    if !c.hdr_ok {
        let dir = crate::output_dir();
        save_png(&dir.join(format!("{name}-actual.png")), w, h, &actual.ldr);
        save_png(&dir.join(format!("{name}-expected.png")), w, h, &reference.ldr);
        let at = c.hdr_at;
        panic!(
            "{name}: HDR error {} (limit {}) at pixel ({}, {}): expected {:?}, got {:?}; images in {}",
            c.hdr_error,
            t.hdr_rel,
            at as u32 % w,
            at as u32 / w,
            reference.hdr[at],
            actual.hdr[at],
            dir.display()
        );
    }
    if !c.flip_ok {
        // Writes the three images and panics with the numbers.
        assert_flip(name, w, h, &reference.ldr, &actual.ldr, t.flip);
        unreachable!("assert_flip passed a comparison that failed");
    }
}

/// How far apart (relative view distance, via reversed-Z depth) two depth samples of one
/// pixel may be before [`msaa_silhouettes`] counts the pixel as a silhouette: 2%, a step
/// between two surfaces (one plane spans that much of its distance within a pixel only at
/// grazing incidence, where excluding a pixel costs only coverage).
pub const SILHOUETTE_STEP: f32 = 0.02;

/// The pixels of a perspective MSAA depth buffer (`samples` values a pixel, as read back)
/// whose samples mix sky and geometry, differ by more than [`SILHOUETTE_STEP`]
/// (reversed-Z depth is inversely proportional to view distance), or (4 samples or more)
/// do not lie on one plane: silhouettes and creases, where two triangles share the pixel.
pub fn msaa_silhouettes(depth: &[f32], samples: u32) -> Vec<bool> {
    depth
        .chunks_exact(samples as usize)
        .map(|s| {
            let sky = s.iter().filter(|&&d| d <= 0.0).count();
            let (lo, hi) = s.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &d| (lo.min(d), hi.max(d)));
            let step = (sky > 0 && sky < s.len()) || (sky == 0 && hi > lo * (1.0 + SILHOUETTE_STEP));
            step || (sky == 0 && !coplanar(s))
        })
        .collect()
}

/// Whether a pixel's depth samples (at the standard positions, 4 or more) lie on one
/// plane: reversed-Z depth is affine in screen space across a plane, so samples 0-2
/// predict the others to f32 rounding (1e-4 relative; `msaa.rs`'s depth-only edge
/// detector uses it too). Two triangles meeting inside the pixel (a crease) break it; so do
/// silhouettes. One or two samples always pass. The sample positions are the standard ones
/// (`tiledlight_cull::blended_depth::standard_sample_positions`), which
/// `independent.rs` measures on the adapter.
pub fn coplanar(s: &[f32]) -> bool {
    let Some(pos) = tiledlight_cull::blended_depth::standard_sample_positions(s.len() as u32) else { return true };
    if s.len() < 4 {
        return true;
    }
    let p = |i: usize| (f64::from(pos[i].0), f64::from(pos[i].1), f64::from(s[i]));
    let ((x0, y0, d0), (x1, y1, d1), (x2, y2, d2)) = (p(0), p(1), p(2));
    let (dx1, dy1, dd1, dx2, dy2, dd2) = (x1 - x0, y1 - y0, d1 - d0, x2 - x0, y2 - y0, d2 - d0);
    let det = dx1 * dy2 - dx2 * dy1;
    let b = (dd1 * dy2 - dd2 * dy1) / det;
    let c = (dx1 * dd2 - dx2 * dd1) / det;
    (3..s.len()).all(|i| {
        let (x, y, d) = p(i);
        (d0 + b * (x - x0) + c * (y - y0) - d).abs() <= 1e-4 * d.abs().max(d0.abs())
    })
}

/// The pixels of a `w`-wide MSAA frame where hardware MSAA (brute force) and Tiled Deferred
/// sample the pixel differently by design, so only FLIP compares them: silhouettes and
/// creases of either depth buffer ([`msaa_silhouettes`]: hardware MSAA shades each partly
/// covered triangle once at the pixel centre, outside the triangle, with its own normal;
/// deferred each sample where it lies, or, under its edge test's thresholds, the whole
/// pixel with sample 0's normal and material) and deferred's own edge pixels (`deferred_edges`, shaded per sample, where light
/// varying within the pixel, a VPL at a crease, averages otherwise than its centre value).
/// Elsewhere deferred shades once at the pixel centre on sample 0's plane, as hardware MSAA
/// does.
pub fn msaa_by_design(
    w: u32,
    (reference_depth, deferred_depth): (&[f32], &[f32]),
    samples: u32,
    deferred_edges: &[(u32, u32)],
) -> Vec<bool> {
    let mut mask = msaa_silhouettes(reference_depth, samples);
    for (m, d) in mask.iter_mut().zip(msaa_silhouettes(deferred_depth, samples)) {
        *m |= d;
    }
    for &(x, y) in deferred_edges {
        mask[(y * w + x) as usize] = true;
    }
    mask
}

/// Per pixel, the worst relative HDR error of `actual` against `reference` over the three
/// channels, after the reference's allowance (as [`compare_with_reference`] measures it).
pub fn pixel_errors(reference: &Frame, actual: &Frame, t: Tolerance) -> Vec<f32> {
    (0..reference.hdr.len())
        .map(|i| {
            let allow = reference.allowance.get(i).copied().unwrap_or(0.0);
            (0..3)
                .map(|c| {
                    let (e, a) = (reference.hdr[i][c], actual.hdr[i][c]);
                    let err = ((a - e).abs() - allow).max(0.0) / e.abs().max(t.hdr_floor);
                    if err.is_nan() {
                        f32::INFINITY
                    } else {
                        err
                    }
                })
                .fold(0.0f32, f32::max)
        })
        .collect()
}

/// How many pixels of a comparison may exceed its HDR limit, and by how much at most.
#[derive(Clone, Copy, Debug)]
pub struct Outliers {
    /// Largest share of the compared (not forgiven) pixels beyond the limit.
    pub share: f32,
    /// No pixel beyond this multiple of the limit.
    pub factor: f32,
}

/// Hardware MSAA (brute force) against a method that shades a fully covered pixel once at
/// its centre: the two differ by design where the light is discontinuous within the pixel
/// or two coplanar triangles share it (measured on lavapipe at 4x: Tiled Deferred, 16
/// pixels of 56,838, worst 6.7e-2 against its 3e-2; the visibility buffer, 8 pixels along
/// the blended scene's floor crease, worst 1.56e-2 against 1e-2, at the values Tiled
/// Deferred has there). 0.05% of the pixels, at most 3x the limit.
pub const MSAA_OUTLIERS: Outliers = Outliers { share: 1.0 / 2000.0, factor: 3.0 };

/// The visibility buffer against a rasterised reference: pixels where the reference's own
/// surface point strays past the allowance of [`Frame::allow_position_error`]. On the H200
/// every rasterised method (brute force, Forward+, Tiled Deferred) agrees with the others
/// and differs from lavapipe's brute force at such pixels, while the visibility buffer
/// matches lavapipe's brute force on both adapters (courtyard (66, 13): 21% on the H200,
/// 1e-3 on lavapipe; (230, 33): 12%; mixed scene (308, 87): 3.3%): the H200's interpolated
/// surface point, not the reconstruction, moves. After the allowance, measured on the H200
/// at 320x180: courtyard 39 and 31 pixels (0.068%, 0.054%) beyond 1e-2, worst 0.104; mixed
/// scene 1, 1.96e-2; lavapipe none. So on hardware rasterisers 0.2% of the pixels (115 at
/// 320x180), at most 25x the limit (one wrong triangle ID is off by 3x its pixel on
/// lavapipe, 304x the limit, 5x with the former Lambert diffuse; the dropped-light test's
/// light by 99.5%); on lavapipe, whose rasteriser agrees, none ([`visibility_outliers`]).
pub const VISIBILITY_OUTLIERS: Outliers = Outliers { share: 1.0 / 500.0, factor: 25.0 };

/// The outliers a visibility comparison allows on this adapter: on lavapipe none, or with
/// MSAA (`msaa`) hardware MSAA's by-design pixels ([`MSAA_OUTLIERS`]); on hardware
/// rasterisers [`VISIBILITY_OUTLIERS`], which holds both.
pub fn visibility_outliers(msaa: bool) -> Outliers {
    match (crate::is_lavapipe(crate::gpu()), msaa) {
        (true, false) => Outliers { share: 0.0, factor: 1.0 },
        (true, true) => MSAA_OUTLIERS,
        (false, _) => VISIBILITY_OUTLIERS,
    }
}

/// Compares as [`compare_with_reference`] and counts the pixels beyond `t`'s HDR limit:
/// passes when FLIP is within `t`, at most `o.share` of the compared pixels (those not
/// forgiven) exceed the limit, and none exceeds `o.factor` times it. Returns the comparison,
/// the count and the verdict.
pub fn compare_with_outliers(
    name: &str,
    w: u32,
    (reference, actual): (&Frame, &Frame),
    t: Tolerance,
    o: Outliers,
) -> (Comparison, usize, bool) {
    let c = compare_with_reference(name, w, reference, actual, t);
    let errors = pixel_errors(reference, actual, t);
    let forgiven = reference.allowance.iter().filter(|&&a| a == f32::MAX).count();
    let over = errors.iter().filter(|&&e| e > t.hdr_rel).count();
    let compared = reference.hdr.len() - forgiven;
    eprintln!("{name}: {over} of {compared} compared pixels beyond {} (worst {:.2e})", t.hdr_rel, c.hdr_error);
    let ok = c.flip_ok && over as f32 <= o.share * compared as f32 && c.hdr_error <= o.factor * t.hdr_rel;
    (c, over, ok)
}

/// [`compare_with_outliers`], panicking with the numbers (and writing the images) when it
/// fails.
pub fn assert_matches_with_outliers(
    name: &str,
    w: u32,
    (reference, actual): (&Frame, &Frame),
    t: Tolerance,
    o: Outliers,
) -> Comparison {
    let (c, over, ok) = compare_with_outliers(name, w, (reference, actual), t, o);
    if !ok {
        let h = (reference.hdr.len() / w as usize) as u32;
        if !c.flip_ok {
            assert_flip(name, w, h, &reference.ldr, &actual.ldr, t.flip);
            unreachable!("assert_flip passed a comparison that failed");
        }
        let dir = crate::output_dir();
        save_png(&dir.join(format!("{name}-actual.png")), w, h, &actual.ldr);
        save_png(&dir.join(format!("{name}-expected.png")), w, h, &reference.ldr);
        panic!(
            "{name}: {over} pixels beyond the HDR limit {} (at most {} of the compared), worst {} at pixel ({}, {}) \
             (at most {}); images in {}",
            t.hdr_rel,
            o.share,
            c.hdr_error,
            c.hdr_at as u32 % w,
            c.hdr_at as u32 / w,
            o.factor * t.hdr_rel,
            dir.display()
        );
    }
    c
}

/// An MSAA frame against hardware MSAA: [`assert_matches_with_outliers`] with
/// [`MSAA_OUTLIERS`].
pub fn assert_matches_reference_msaa(
    name: &str,
    w: u32,
    reference: &Frame,
    actual: &Frame,
    t: Tolerance,
) -> Comparison {
    assert_matches_with_outliers(name, w, (reference, actual), t, MSAA_OUTLIERS)
}

/// The visibility buffer against a rasterised reference (with its position allowance):
/// [`assert_matches_with_outliers`] with [`VISIBILITY_VS_REFERENCE`] and this adapter's
/// [`visibility_outliers`].
pub fn assert_visibility_matches(name: &str, w: u32, (reference, actual): (&Frame, &Frame), msaa: bool) -> Comparison {
    assert_matches_with_outliers(name, w, (reference, actual), VISIBILITY_VS_REFERENCE, visibility_outliers(msaa))
}

/// The verdict of [`assert_visibility_matches`] without panicking (negative tests).
pub fn visibility_matches(name: &str, w: u32, reference: &Frame, actual: &Frame) -> bool {
    compare_with_outliers(name, w, (reference, actual), VISIBILITY_VS_REFERENCE, visibility_outliers(false)).2
}

impl Frame {
    /// Forgives the pixels of `mask` in the HDR comparison with this frame as the reference
    /// (FLIP still covers them): for MSAA pixels where hardware MSAA (brute force) and Tiled
    /// Deferred sample the pixel differently by design (the callers say which and why).
    /// Returns the frame and the number of pixels forgiven.
    pub fn forgive_hdr(mut self, mask: &[bool]) -> (Self, usize) {
        assert_eq!(mask.len(), self.hdr.len(), "forgive_hdr: one flag a pixel");
        if self.allowance.is_empty() {
            self.allowance = vec![0.0; self.hdr.len()];
        }
        let mut n = 0;
        for (a, &m) in self.allowance.iter_mut().zip(mask) {
            if m {
                *a = f32::MAX;
                n += 1;
            }
        }
        (self, n)
    }
}

/// The visibility buffer's frames with settings `s` (its `raster` replaced) drawn by each
/// raster at its sample count ([`crate::visibility_rasters`]), with, per frame, the pixels
/// where it kept another triangle than the hardware raster at a depth equal within
/// [`RASTER_TIE_DEPTH`] (relative): coplanar surfaces, where the hardware keeps the later
/// draw and the compute raster the larger ID (`tiledlight_cull::raster`, rule 7), both
/// valid; a rasterised reference agrees with the hardware. The callers forgive them in the
/// HDR comparison (FLIP still sees them); there are at most 0.2% of the covered pixels
/// (asserted here; measured on lavapipe: 3 of 54,212 in the courtyard).
pub fn visibility_frames(
    ctx: &GpuContext,
    (scene, lights, camera): (&SceneGpu, &LightBuffers, &Camera),
    (w, h): (u32, u32),
    s: FrameSettings,
) -> Vec<(tiledlight_gpu::features::Raster, Frame, Vec<bool>)> {
    use tiledlight_frame::{Diagnostics as _, VisibilityFrame};
    let mut hardware_ids: Option<(Vec<f32>, Vec<u32>)> = None;
    let mut out = Vec::new();
    for raster in crate::visibility_rasters(s.msaa) {
        let s = FrameSettings { knobs: Knobs { raster, ..s.knobs }, ..s };
        let mut r = FrameRenderer::new(ctx, scene, lights, w, h, s)
            .unwrap_or_else(|e| panic!("visibility renderer ({}): {e}", raster.name()));
        let frame = render_frame(ctx, &mut r, scene, camera);
        let mut ties = vec![false; (w * h) as usize];
        if s.msaa == 1 {
            let ids = r.passes::<VisibilityFrame>().expect("visibility").raster().read_ids(&ctx.device, &ctx.queue);
            let (depth, ids) = (r.read_depth(ctx).expect("depth"), ids.expect("IDs"));
            match &hardware_ids {
                None => hardware_ids = Some((depth, ids)),
                Some((hd, hi)) => {
                    let none = tiledlight_cull::visibility::NO_TRIANGLE;
                    ties = raster_ties((hd, hi), (&depth, &ids));
                    let (n, covered) =
                        (ties.iter().filter(|&&t| t).count(), ids.iter().filter(|&&i| i != none).count());
                    eprintln!("{} raster: {n} pixels tie with the hardware's at another triangle", raster.name());
                    assert!(n * 500 <= covered, "{n} tie pixels of {covered} covered: more than 0.2%");
                }
            }
        }
        out.push((raster, frame, ties));
    }
    out
}

/// The pixels where raster `b` kept another triangle than raster `a` (depth, ID per pixel)
/// at a depth within [`RASTER_TIE_DEPTH`] of `a`'s, neither being the clear value. Only the
/// depth is checked, not that both triangles lie there: a wrong ID at an unchanged depth
/// passes here, which the raster-level comparison (`tests/tests/compute_raster.rs`, with
/// every fragment of every triangle) rejects.
pub fn raster_ties((ad, ai): (&[f32], &[u32]), (bd, bi): (&[f32], &[u32])) -> Vec<bool> {
    let none = tiledlight_cull::visibility::NO_TRIANGLE;
    (0..ad.len())
        .map(|p| {
            ai[p] != bi[p]
                && ai[p] != none
                && bi[p] != none
                && (ad[p] - bd[p]).abs() <= RASTER_TIE_DEPTH * ad[p].max(bd[p])
        })
        .collect()
}

/// Two rasters' depths at a pixel tie when within this fraction of each other: the
/// vertex transforms' rounding moves a depth by up to ~1e-5 relative on surfaces seen at
/// grazing angles (`tests/tests/compute_raster.rs` bounds it per triangle).
pub const RASTER_TIE_DEPTH: f32 = 1e-4;

/// Whether two HDR pixels are the same image's: equal in every colour channel when
/// `exact` (lavapipe runs a frame the same way every time), else within one f16 step of
/// the larger (a parallel GPU changes the order of a list's lights, so the last bit of a
/// sum, from run to run). A NaN is the same as nothing.
pub fn same_hdr_pixel(a: &[f32; 4], b: &[f32; 4], exact: bool) -> bool {
    (0..3).all(|c| {
        let step = if exact { 0.0 } else { a[c].abs().max(b[c].abs()) * 2f32.powi(-10) };
        (a[c] - b[c]).abs() <= step
    })
}

/// Asserts two HDR images (`w` pixels wide) are the same by [`same_hdr_pixel`], naming
/// `what` and the first pixel that differs.
pub fn assert_same_hdr(a: &[[f32; 4]], b: &[[f32; 4]], w: u32, exact: bool, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: the images differ in size");
    if let Some(i) = a.iter().zip(b).position(|(p, q)| !same_hdr_pixel(p, q, exact)) {
        panic!("{what}: pixel ({}, {}) differs: {:?} vs {:?}", i as u32 % w, i as u32 / w, a[i], b[i]);
    }
}

/// The pixels of `mask` whose `actual` HDR value lies outside the range of `reference`'s
/// values over the pixel's 3x3 neighbourhood (per channel, widened by `t`'s relative limit
/// and floor): for pixels that the two sample differently by design (an MSAA edge pixel
/// shaded per sample against hardware MSAA's one shading per triangle at the centre), each
/// of the pixel's samples shades a point of one of the triangles the neighbourhood shows,
/// so its average lies within what the neighbourhood's centres span unless the shading
/// varies faster than a pixel (a light's core, a texel smaller than the gap). Returns the
/// indices of the pixels outside.
pub fn outside_neighbourhood(
    w: u32,
    reference: &[[f32; 4]],
    actual: &[[f32; 4]],
    mask: &[bool],
    t: Tolerance,
) -> Vec<usize> {
    let h = (reference.len() / w as usize) as i64;
    let w = w as i64;
    let mut out = Vec::new();
    for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
        let (x, y) = (i as i64 % w, i as i64 / w);
        let inside = (0..3).all(|c| {
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
                let (nx, ny) = (x + dx, y + dy);
                if (0..w).contains(&nx) && (0..h).contains(&ny) {
                    let v = reference[(ny * w + nx) as usize][c];
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            let a = actual[i][c];
            let slack = |v: f32| v.abs().max(t.hdr_floor) * t.hdr_rel;
            a >= lo - slack(lo) && a <= hi + slack(hi)
        });
        if !inside {
            out.push(i);
        }
    }
    out
}

/// For a scene whose MSAA edge pixels lie on high-contrast textures: the pixels of `mask`
/// (sampled otherwise than hardware MSAA by design) must lie within their reference
/// neighbourhood's range ([`outside_neighbourhood`] with `t`) but for 1% of them, where a
/// sample reads a texel or a light gradient that no neighbouring centre shows (measured on
/// the many-material scene at 4x: the visibility buffer 25 of 3,627, Tiled Deferred 24 of 3,136).
/// Returns `actual` with those pixels' tonemapped values taken from `reference`, so that
/// FLIP compares the others: per-sample shading reads the texture at each sample and
/// hardware MSAA once per triangle at the centre, which FLIP sees (the visibility buffer:
/// FLIP mean 0.0033 over the whole image, 0.0008 without these pixels).
pub fn bound_by_design(name: &str, w: u32, (reference, actual): (&Frame, Frame), mask: &[bool], t: Tolerance) -> Frame {
    let outside = outside_neighbourhood(w, &reference.hdr, &actual.hdr, mask, t);
    let designed = mask.iter().filter(|&&m| m).count();
    eprintln!("{name}: {} of {designed} pixels sampled by design outside their neighbourhood", outside.len());
    assert!(
        outside.len() * 100 <= designed,
        "{name}: {} of {designed} pixels sampled by design lie outside their neighbourhood's range, first at {:?}",
        outside.len(),
        outside.first().map(|i| (i % w as usize, i / w as usize))
    );
    actual.with_ldr_from(mask, reference)
}

impl Frame {
    /// This frame with the tonemapped pixels of `mask` taken from `other`: FLIP then sees
    /// only the other pixels (for pixels compared by another rule, the caller says which).
    pub fn with_ldr_from(mut self, mask: &[bool], other: &Frame) -> Self {
        assert_eq!(mask.len() * 4, self.ldr.len(), "with_ldr_from: one flag a pixel");
        for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
            self.ldr[4 * i..4 * i + 4].copy_from_slice(&other.ldr[4 * i..4 * i + 4]);
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One f16 step apart passes only off lavapipe; two steps, a NaN or another size never.
    #[test]
    fn same_hdr_rejects_a_changed_pixel() {
        let a = [[1.0, 2.0, 4.0, 1.0]; 3];
        let mut b = a;
        b[1][2] = 4.0 * (1.0 + 2f32.powi(-11));
        assert!(same_hdr_pixel(&a[1], &b[1], false) && !same_hdr_pixel(&a[1], &b[1], true));
        assert_same_hdr(&a, &b, 3, false, "one step");
        b[1][2] = 4.0 * (1.0 + 2f32.powi(-8));
        assert!(!same_hdr_pixel(&a[1], &b[1], false));
        let e = std::panic::catch_unwind(|| assert_same_hdr(&a, &b, 3, false, "two steps")).unwrap_err();
        assert!(e.downcast_ref::<String>().is_some_and(|m| m.contains("two steps: pixel (1, 0) differs")));
        b[1][2] = f32::NAN;
        assert!(!same_hdr_pixel(&a[1], &b[1], false));
        assert!(std::panic::catch_unwind(|| assert_same_hdr(&a, &a[..2], 3, true, "size")).is_err());
    }

    fn flat(v: f32, n: usize) -> Frame {
        Frame { hdr: vec![[v, v, v, 1.0]; n], ldr: vec![128; n * 4], allowance: Vec::new() }
    }

    /// Ties: another triangle at the same depth only; another triangle at another depth,
    /// the same triangle, or a pixel either raster left empty is none.
    #[test]
    fn raster_ties_are_only_other_triangles_at_the_same_depth() {
        let none = tiledlight_cull::visibility::NO_TRIANGLE;
        let a = ([0.5f32, 0.5, 0.5, 0.5, 0.0], [1u32, 1, 1, 1, none]);
        let b = ([0.5f32 * (1.0 + 1e-6), 0.4, 0.5, 0.0, 0.5], [2u32, 2, 1, none, 3]);
        assert_eq!(raster_ties((&a.0, &a.1), (&b.0, &b.1)), [true, false, false, false, false]);
    }

    /// The MSAA comparison passes a few pixels a little off and rejects a frame with one
    /// pixel far off, or with too many a little off (a tile missing a light).
    #[test]
    fn msaa_comparison_rejects_far_or_many_pixels() {
        let t = FORWARD_VS_REFERENCE;
        let (w, n) = (100u32, 10_000usize);
        let reference = flat(0.5, n);
        let mut few = flat(0.5, n);
        few.hdr[7] = [0.505, 0.5, 0.5, 1.0];
        assert_matches_reference_msaa("few", w, &reference, &few, t);
        let mut far = flat(0.5, n);
        far.hdr[7] = [0.6, 0.5, 0.5, 1.0];
        let r = std::panic::catch_unwind(|| assert_matches_reference_msaa("far", w, &reference, &far, t));
        assert!(r.is_err(), "one pixel 20% off must fail");
        let mut many = flat(0.5, n);
        for p in many.hdr.iter_mut().take(16) {
            p[0] = 0.505;
        }
        let r = std::panic::catch_unwind(|| assert_matches_reference_msaa("many", w, &reference, &many, t));
        assert!(r.is_err(), "16 pixels of 10,000 beyond the limit must fail");
    }

    /// A pixel between its neighbours' values passes; one above their maximum or below their
    /// minimum by more than the limit, or a NaN, is reported; pixels outside the mask never.
    #[test]
    fn neighbourhood_bound_rejects_a_value_outside_the_range() {
        let t = VISIBILITY_VS_REFERENCE;
        let mut reference = vec![[0.5f32, 0.5, 0.5, 1.0]; 9];
        reference[0] = [0.2, 0.9, 0.5, 1.0];
        let mut actual = reference.clone();
        let mask = [false, false, false, false, true, false, false, false, false];
        actual[4] = [0.3, 0.8, 0.5, 1.0];
        assert!(outside_neighbourhood(3, &reference, &actual, &mask, t).is_empty());
        actual[4] = [0.5, 0.9 * 1.02, 0.5, 1.0];
        assert_eq!(outside_neighbourhood(3, &reference, &actual, &mask, t), vec![4]);
        actual[4] = [0.2 * 0.98, 0.5, 0.5, 1.0];
        assert_eq!(outside_neighbourhood(3, &reference, &actual, &mask, t), vec![4]);
        actual[4] = [f32::NAN, 0.5, 0.5, 1.0];
        assert_eq!(outside_neighbourhood(3, &reference, &actual, &mask, t), vec![4]);
        actual[4] = [0.5; 4];
        actual[8] = [9.0; 4];
        assert!(outside_neighbourhood(3, &reference, &actual, &mask, t).is_empty());
        let f = |v: u8| Frame { hdr: vec![[0.0; 4]; 2], ldr: vec![v; 8], allowance: Vec::new() };
        assert_eq!(f(1).with_ldr_from(&[false, true], &f(2)).ldr, [1, 1, 1, 1, 2, 2, 2, 2]);
        // bound_by_design: one pixel of 100 outside passes, two fail.
        let (w, n) = (10u32, 100usize);
        let reference = Frame { hdr: vec![[0.5; 4]; n], ldr: vec![128; 4 * n], allowance: Vec::new() };
        let mask = vec![true; n];
        let mut one = reference.clone();
        one.hdr[55] = [0.9; 4];
        bound_by_design("one", w, (&reference, one.clone()), &mask, t);
        one.hdr[22] = [0.1; 4];
        assert!(std::panic::catch_unwind(|| bound_by_design("two", w, (&reference, one), &mask, t)).is_err());
    }

    /// A plane's 4x samples pass; one sample moved off it by 0.1% (a crease, a second
    /// triangle) fails, and so does a step between surfaces in the silhouette mask.
    #[test]
    fn coplanar_accepts_a_plane_and_rejects_a_crease() {
        let pos = tiledlight_cull::blended_depth::standard_sample_positions(4).unwrap();
        let plane: Vec<f32> = pos.iter().map(|&(x, y)| 0.3 + 0.001 * x - 0.002 * y).collect();
        assert!(coplanar(&plane));
        let mut crease = plane.clone();
        crease[3] *= 1.001;
        assert!(!coplanar(&crease));
        let mut step = plane.clone();
        step[1] *= 1.05;
        assert_eq!(msaa_silhouettes(&[plane, crease, step].concat(), 4), vec![false, true, true]);
    }
}
