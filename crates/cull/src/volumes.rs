//! Tile volumes and the per-volume light test shared by every CPU culler: the depth
//! buffer's checks, the lights in view space (`ViewLight`), each tile's frustum (its two
//! half-z halves) over its depth bounds, the bounds of blended geometry, and the test of one
//! light against one volume (side planes and depth range, AABB, spot cone, 2.5D mask).
//! Depends on [`crate::lists`] (the options), [`crate::tiles`] (frusta, bounds),
//! [`crate::bounds`], [`crate::depth_mask`], [`crate::camera`], [`crate::light`].

use glam::{Mat4, Vec3};

use crate::bounds::{aabb_sphere, cone_vs_sphere, sphere_vs_aabb, sphere_vs_frustum, to_view};
use crate::camera::Camera;
use crate::depth_mask::{light_depth_mask, tile_depth_masks};
use crate::error::CullError;
use crate::light::PackedLights;
use crate::lists::{half_z_split, CullConfig};
use crate::tiles::{tile_depth_bounds_samples, tile_sample_spans, DepthBounds, TileFrustum, TileGrid};

/// Validates a depth buffer against a grid: right size, values finite and in [0, 1].
pub fn check_depth(grid: &TileGrid, depth: &[f32]) -> Result<(), CullError> {
    check_depth_samples(grid, depth, 1)
}

/// Validates a depth buffer of `samples` values per pixel (pixel-major) against a grid.
pub fn check_depth_samples(grid: &TileGrid, depth: &[f32], samples: u32) -> Result<(), CullError> {
    let n = grid.width as usize * grid.height as usize * samples as usize;
    if depth.len() != n {
        return Err(CullError::InvalidDepth(format!(
            "{} values for a {}x{} screen with {} sample(s) per pixel",
            depth.len(),
            grid.width,
            grid.height,
            samples
        )));
    }
    if let Some(i) = depth.iter().position(|d| !(0.0..=1.0).contains(d)) {
        let s = samples as usize;
        return Err(CullError::InvalidDepth(format!(
            "pixel {} sample {} has depth {} outside [0, 1]",
            i / s,
            i % s,
            depth[i]
        )));
    }
    Ok(())
}

/// One light as the kernel sees it, in view space.
pub(crate) struct ViewLight {
    pub(crate) center: Vec3,
    pub(crate) radius: f32,
    /// Apex, axis, length, cos, sin of a spot's cone.
    cone: Option<(Vec3, Vec3, f32, f32, f32)>,
}

/// The lights in view space, radii grown by `inflate` (see [`CullConfig::inflate`]).
pub(crate) fn view_lights(view: &Mat4, lights: &PackedLights, inflate: f32) -> Vec<ViewLight> {
    let rot = Mat4::from_mat3(glam::Mat3::from_mat4(*view));
    (0..lights.len())
        .map(|i| {
            let cl = lights.cull[i];
            let center = to_view(view, Vec3::from(cl.center));
            // Skipped when 0: beyond ~1.8e19 m `center.length()` overflows to inf and
            // 0 * inf = NaN would turn the radius into NaN, which culls the light everywhere.
            let grow = if inflate == 0.0 { 0.0 } else { inflate * (cl.radius + center.length()) };
            let radius = cl.radius + grow;
            let cone = (i >= lights.num_point as usize).then(|| {
                let s = lights.spots[i - lights.num_point as usize];
                let sh = lights.shading[i];
                let apex = to_view(view, Vec3::from(sh.position));
                let axis = to_view(&rot, Vec3::from(s.direction));
                (apex, axis, sh.radius + grow, s.cos_outer, s.sin_outer)
            });
            ViewLight { center, radius, cone }
        })
        .collect()
}

/// The per-tile test of one light against one volume: side planes and depth range, then
/// the AABB and cone tests the config asks for, then (`tile_mask`: the tile's 2.5D depth
/// mask, when `depth_mask` is on) the depth-mask overlap.
pub(crate) fn light_in_volume(
    l: &ViewLight,
    f: &TileFrustum,
    proj: &Mat4,
    ortho: bool,
    cfg: &CullConfig,
    tile_mask: Option<u32>,
) -> bool {
    if !light_in_box(l, f, proj, ortho, cfg) {
        return false;
    }
    // The volume is the whole tile range here (`depth_mask` excludes half-z), the range
    // the tile's mask was binned over.
    tile_mask.is_none_or(|m| m & light_depth_mask(-l.center.z, l.radius, f.near, f.far) != 0)
}

/// [`light_in_volume`] without the depth mask.
fn light_in_box(l: &ViewLight, f: &TileFrustum, proj: &Mat4, ortho: bool, cfg: &CullConfig) -> bool {
    if l.radius <= 0.0 || !sphere_vs_frustum(f, l.center, l.radius) {
        return false;
    }
    // A volume reaching infinitely far (sky behind blended geometry, or a surface so far
    // that its distance overflows) has an unbounded box, which rejects nothing. Its corners
    // at infinity come out NaN (0 * inf), and whether the tests then keep the light would
    // depend on how min/max treat NaN (WGSL leaves it undefined), so they are skipped.
    let need_box = (cfg.aabb || (cfg.spot_cone && l.cone.is_some())) && f.far.is_finite();
    if !need_box {
        return true;
    }
    let (lo, hi) = f.aabb(proj, ortho);
    if cfg.aabb && !sphere_vs_aabb(lo, hi, l.center, l.radius) {
        return false;
    }
    if let (true, Some((apex, axis, len, c, s))) = (cfg.spot_cone, l.cone) {
        let (sc, sr) = aabb_sphere(lo, hi);
        return cone_vs_sphere(apex, axis, len, c, s, sc, sr);
    }
    true
}

/// The depth bounds of tile (tx, ty) for alpha-blended geometry, over the samples where
/// some blended surface was drawn (`blended > 0`; 0 is the blended buffer's clear value,
/// nothing blended there). Both buffers are reversed-Z, row-major, `samples` values per
/// pixel, pixel-major (as [`tile_depth_bounds_samples`] reads them).
///
/// Returns `(near, far)` as reversed-Z depth values, in the convention of
/// [`tile_depth_bounds_samples`]'s [`DepthBounds`]: `near` is its `max_depth` (the nearest
/// surface, the largest value) and `far` its `min_depth` (the farthest surface, the
/// smallest value), so `near >= far`. `near` is the largest blended depth of those samples,
/// `far` the smallest opaque depth at those same samples: the volume runs from the nearest
/// blended surface to the farthest opaque surface behind any blended one. Where that
/// opaque depth is 0 (sky), `far` is 0, which [`TileFrustum::new`] turns into
/// `DepthParams::view_distance(0)`: `f32::INFINITY` with an infinite far plane (then the
/// culler skips the AABB and cone tests, which bound the volume by a box, unbounded here), the far
/// plane's distance otherwise. `None` when no sample of the tile has blended geometry
/// (the tile gets an empty blended list).
///
/// The blended pass is depth-tested against the opaque depth, so `blended >= opaque`
/// wherever something is blended; should a sample break that, `far` also covers its
/// blended depth (the smaller of the two), so the blended surface stays inside the range.
///
/// # Panics
///
/// If a buffer holds fewer than `grid.width * grid.height * samples` values.
pub fn blended_tile_bounds(
    grid: &TileGrid,
    opaque: &[f32],
    blended: &[f32],
    samples: u32,
    tx: u32,
    ty: u32,
) -> Option<(f32, f32)> {
    let mut near = 0.0f32;
    let mut far = f32::INFINITY;
    for span in tile_sample_spans(grid, samples, tx, ty) {
        for (&b, &o) in blended[span.clone()].iter().zip(&opaque[span]) {
            if b > 0.0 {
                near = near.max(b);
                far = far.min(o.min(b));
            }
        }
    }
    (near > 0.0).then_some((near, far))
}

/// The blended depth buffer as if depth-tested against `opaque`: each sample's blended
/// depth where it lies in front of the opaque one, else 0 (nothing blended). The GPU draws
/// blended depth without that test (a multisampled opaque buffer cannot be copied into the
/// blended one) and its kernel makes the same comparison per sample, so the GPU's lists are
/// [`crate::cull_tiles_blended`] of this buffer.
pub fn depth_tested_blended(opaque: &[f32], blended: &[f32]) -> Vec<f32> {
    opaque.iter().zip(blended).map(|(&o, &b)| if b > o { b } else { 0.0 }).collect()
}

/// Per tile (row-major), the volumes its lists cover (`None` for tiles without bounds), and
/// per tile its view-distance range: what both culler loops share.
pub(crate) type Volumes = (Vec<Option<Vec<TileFrustum>>>, Vec<Option<(f32, f32)>>);

/// [`Volumes`] of every tile whose `bounds(tx, ty)` exist: its frustum, or the two
/// half-z halves.
pub(crate) fn volumes_with_bounds(
    grid: &TileGrid,
    camera: &Camera,
    config: &CullConfig,
    bounds: impl Fn(u32, u32) -> Option<DepthBounds>,
) -> Volumes {
    let mut volumes = vec![None; grid.tile_count()];
    let mut ranges = vec![None; grid.tile_count()];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            let t = (ty * grid.tiles_x + tx) as usize;
            let Some(b) = bounds(tx, ty) else { continue };
            let f = TileFrustum::new(grid, camera, tx, ty, b);
            ranges[t] = Some((f.near, f.far));
            volumes[t] = Some(if config.half_z {
                let mid = half_z_split(f.near, f.far);
                vec![f.with_range(f.near, mid), f.with_range(mid, f.far)]
            } else {
                vec![f]
            });
        }
    }
    (volumes, ranges)
}

/// The opaque culler's per-tile data: volumes, depth masks (with `depth_mask`), ranges.
/// The depth buffer must have been checked.
#[allow(clippy::type_complexity)]
pub(crate) fn tile_volumes(
    grid: &TileGrid,
    depth: &[f32],
    camera: &Camera,
    config: &CullConfig,
) -> (Vec<Option<Vec<TileFrustum>>>, Option<Vec<u32>>, Vec<Option<(f32, f32)>>) {
    let (volumes, ranges) = volumes_with_bounds(grid, camera, config, |tx, ty| {
        tile_depth_bounds_samples(grid, depth, config.samples, tx, ty)
    });
    let masks = config.depth_mask.then(|| tile_depth_masks(depth, grid, config.samples, camera));
    (volumes, masks, ranges)
}
