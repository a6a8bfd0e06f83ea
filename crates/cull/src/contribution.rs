//! Each light's contribution to a frame, estimated from the light grid and the distance of
//! the pixels it reaches: what chooses the shadow casters "by contribution" instead of
//! brightest-first. The CPU twin of `shaders/light_contribution.wgsl`
//! (`tiledlight_gpu::contribution::LightContribution`).
//!
//! 1. Every pixel that shows a surface (reversed-Z depth > 0) is put back in the world at its
//!    centre, as deferred shading does (the camera's depth parameters, `view_point_at`,
//!    the inverse view matrix).
//! 2. For each tile and each light of the tile's list, the light's unshadowed arrival at
//!    the tile's surface pixels is summed: windowed attenuation times, for spots, the cone
//!    falloff ([`crate::brdf`]). No normal, no BRDF: the estimate asks how much light a
//!    light pours onto what the camera sees, which is what its shadow can take away.
//! 3. The sum times the light's brightness (its largest radiance channel) is scaled by
//!    [`pair_scale`] and quantised to a `u32` per (tile, light) pair, saturating; each
//!    light's pairs are summed in a `u64`. Integer sums do not depend on the order the GPU's
//!    atomics add them in, so the GPU's scores are reproducible, and the twin's are equal
//!    to them up to the f32 rounding of step 2 (a few units a pair).
//!
//! One list per tile (the plain tiled layout): the estimate is a setup step that builds
//! its own grid, the same for every method, so every method shades the same casters.
//! Depends on this crate's camera, tiles, light, brdf and reference (the pixel's point)
//! modules.

use glam::{Mat4, Vec3};

use crate::brdf::{spot_falloff, windowed_attenuation, LIGHT_SIZE_SQ};
use crate::camera::Camera;
use crate::error::CullError;
use crate::light::PackedLights;
use crate::reference::pixel_view_position;
use crate::tiles::TileGrid;

/// The largest f32 below 2^32: a pair's quantised value saturates there.
pub const PAIR_MAX: f32 = 4_294_967_040.0;

/// The factor from a (tile, light) pair's brightness-weighted attenuation sum to its `u32`
/// units: the largest sum any pair could reach (the brightest light at its emitter's
/// distance from every pixel of a full tile) maps to [`PAIR_MAX`], so no pair saturates
/// and the dimmest pairs that matter keep many units. 0 when no light has any brightness.
pub fn pair_scale(lights: &PackedLights, tile_size: u32) -> f32 {
    let brightest = lights.shading.iter().map(brightness).fold(0.0f32, f32::max);
    let peak = brightest * (tile_size * tile_size) as f32 / LIGHT_SIZE_SQ;
    if peak > 0.0 && peak.is_finite() {
        PAIR_MAX / peak
    } else {
        0.0
    }
}

/// A packed light's brightness: its largest radiance channel (`color * intensity`), the
/// measure brightest-first ranks by.
fn brightness(l: &crate::light::GpuShadingLight) -> f32 {
    l.radiance[0].max(l.radiance[1]).max(l.radiance[2])
}

/// The world position of every pixel's surface at its centre (None for sky), row-major:
/// step 1, as the GPU kernel reconstructs it.
pub fn surface_points(camera: &Camera, depth: &[f32], grid: &TileGrid) -> Vec<Option<Vec3>> {
    let to_world: Mat4 = camera.view().inverse();
    let (w, h) = (grid.width, grid.height);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            pixel_view_position(camera, w, h, x, y, depth[(y * w + x) as usize]).map(|p| to_world.transform_point3(p))
        })
        .collect()
}

/// The unshadowed arrival of packed light `i` at world point `p`: windowed attenuation,
/// times the cone falloff for a spot (step 2).
fn arrival(lights: &PackedLights, i: usize, p: Vec3) -> f32 {
    let l = &lights.shading[i];
    let to_light = Vec3::from(l.position) - p;
    let d2 = to_light.length_squared();
    let mut a = windowed_attenuation(d2, l.radius);
    if i >= lights.num_point as usize {
        let s = &lights.spots[i - lights.num_point as usize];
        let dir = to_light / d2.sqrt().max(f32::MIN_POSITIVE);
        a *= spot_falloff((-dir).dot(Vec3::from(s.direction)), s.angle_scale, s.angle_offset);
    }
    a
}

/// A pair's `u32` units: `brightness * sum * scale`, saturating at [`PAIR_MAX`] (step 3).
fn quantise(value: f32) -> u32 {
    if value >= PAIR_MAX {
        u32::MAX
    } else if value > 0.0 {
        value as u32
    } else {
        0
    }
}

/// Every packed light's score (steps 1-3) for a frame of `camera` with reversed-Z `depth`
/// (one value a pixel, row-major over `grid`'s screen) and one light list per tile of
/// `grid` (`lists[t]`: packed light indices). `scale` is [`pair_scale`] of the lights for the
/// grid's tile size (the GPU is given the same value). Errors name a depth buffer or list
/// count that does not match the grid, or a light index past the lights.
pub fn light_scores(
    camera: &Camera,
    depth: &[f32],
    (grid, lists): (&TileGrid, &[Vec<u32>]),
    lights: &PackedLights,
    scale: f32,
) -> Result<Vec<u64>, CullError> {
    let pixels = grid.width as usize * grid.height as usize;
    if depth.len() != pixels {
        return Err(CullError::InvalidEstimate(format!(
            "a depth buffer of {} values for a {}x{} screen",
            depth.len(),
            grid.width,
            grid.height
        )));
    }
    if lists.len() != grid.tile_count() {
        return Err(CullError::InvalidEstimate(format!(
            "{} light lists for {} tiles: the contribution estimate needs one list per tile",
            lists.len(),
            grid.tile_count()
        )));
    }
    let n = lights.len();
    if let Some(&bad) = lists.iter().flatten().find(|&&i| i as usize >= n) {
        return Err(CullError::InvalidEstimate(format!("light index {bad} in a list of {n} lights")));
    }
    let points = surface_points(camera, depth, grid);
    let mut scores = vec![0u64; n];
    for (t, list) in lists.iter().enumerate() {
        let (tx, ty) = (t as u32 % grid.tiles_x, t as u32 / grid.tiles_x);
        let (x0, y0) = (tx * grid.tile_size, ty * grid.tile_size);
        let tile: Vec<Vec3> = (y0..(y0 + grid.tile_size).min(grid.height))
            .flat_map(|y| (x0..(x0 + grid.tile_size).min(grid.width)).map(move |x| (y * grid.width + x) as usize))
            .filter_map(|p| points[p])
            .collect();
        for &i in list {
            let sum: f32 = tile.iter().map(|&p| arrival(lights, i as usize, p)).sum();
            scores[i as usize] += quantise(brightness(&lights.shading[i as usize]) * sum * scale) as u64;
        }
    }
    Ok(scores)
}

/// Scores of packed lights (points first, as uploaded with no casters) mapped back to the
/// order of `lights` as given: `order_points_first` is a stable partition, so packed index
/// `k` is the `k`-th point, or the `(k - points)`-th spot, of the input.
pub fn scores_in_input_order(lights: &[crate::Light], packed_scores: &[u64]) -> Result<Vec<u64>, CullError> {
    if packed_scores.len() != lights.len() {
        return Err(CullError::InvalidEstimate(format!("{} scores for {} lights", packed_scores.len(), lights.len())));
    }
    let mut next_point = 0;
    let mut next_spot = lights.iter().filter(|l| !l.is_spot()).count();
    let mut out = Vec::with_capacity(lights.len());
    for l in lights {
        let k = if l.is_spot() { &mut next_spot } else { &mut next_point };
        out.push(packed_scores[*k]);
        *k += 1;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::{try_pack_lights, Light};
    use crate::tiles::{pixel_to_ndc_x, pixel_to_ndc_y};

    fn camera(w: u32, h: u32) -> Camera {
        Camera::perspective(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 1.0, w as f32 / h as f32, 0.1, Some(100.0))
            .unwrap()
    }

    /// A floor (y = 0) seen by `camera`: the reversed-Z depth of every pixel, by ray cast.
    fn floor_depth(cam: &Camera, grid: &TileGrid) -> Vec<f32> {
        let to_world = cam.view().inverse();
        let eye = to_world.transform_point3(Vec3::ZERO);
        let clip = cam.proj() * cam.view();
        let mut depth = Vec::new();
        for y in 0..grid.height {
            for x in 0..grid.width {
                let ndc = (pixel_to_ndc_x(x as f32 + 0.5, grid.width), pixel_to_ndc_y(y as f32 + 0.5, grid.height));
                let far = to_world.transform_point3(cam.view_point_at(ndc.0, ndc.1, 1.0));
                let dir = far - eye;
                let t = -eye.y / dir.y;
                depth.push(if dir.y < 0.0 && t > 0.0 { clip.project_point3(eye + dir * t).z } else { 0.0 });
            }
        }
        depth
    }

    fn scene() -> (Camera, TileGrid, Vec<f32>) {
        let grid = TileGrid::new(64, 32, 16).unwrap();
        let cam = camera(64, 32);
        let depth = floor_depth(&cam, &grid);
        (cam, grid, depth)
    }

    /// Every tile lists every light: the estimate then sees all the light there is.
    fn all_lists(grid: &TileGrid, n: u32) -> Vec<Vec<u32>> {
        vec![(0..n).collect(); grid.tile_count()]
    }

    #[test]
    fn a_dim_light_on_the_floor_outranks_a_bright_one_off_screen() {
        let (cam, grid, depth) = scene();
        assert!(depth.iter().any(|&d| d > 0.0) && depth.contains(&0.0), "floor and sky");
        let near = Light::point(Vec3::new(0.0, 0.3, 0.0), Vec3::ONE, 1.0, 0.01).unwrap();
        let far = Light::point(Vec3::new(0.0, 0.3, -60.0), Vec3::ONE, 50.0, 0.01).unwrap();
        let packed = try_pack_lights(&[near, far]).unwrap();
        let scale = pair_scale(&packed, grid.tile_size);
        let s = light_scores(&cam, &depth, (&grid, &all_lists(&grid, 2)), &packed, scale).unwrap();
        assert!(s[0] > 10 * s[1], "the near light should dominate: {s:?}");
        assert!(s[1] > 0, "the far one still reaches the far floor: {s:?}");
    }

    #[test]
    fn a_light_missing_from_the_lists_scores_nothing() {
        let (cam, grid, depth) = scene();
        let l = Light::point(Vec3::new(0.0, 0.3, 0.0), Vec3::ONE, 1.0, 0.01).unwrap();
        let packed = try_pack_lights(&[l, l]).unwrap();
        let scale = pair_scale(&packed, grid.tile_size);
        let mut lists = all_lists(&grid, 2);
        let full = light_scores(&cam, &depth, (&grid, &lists), &packed, scale).unwrap();
        assert_eq!(full[0], full[1], "two equal lights score the same");
        lists.iter_mut().for_each(|l| l.retain(|&i| i == 0));
        let half = light_scores(&cam, &depth, (&grid, &lists), &packed, scale).unwrap();
        assert_eq!(half, vec![full[0], 0]);
    }

    #[test]
    fn a_spot_scores_only_where_its_cone_falls() {
        let (cam, grid, depth) = scene();
        let down = Light::spot(Vec3::new(0.0, 1.0, 0.0), -Vec3::Y, Vec3::ONE, 1.0, 0.2, 0.3, 0.01).unwrap();
        let away = Light::spot(Vec3::new(0.0, 1.0, 0.0), Vec3::Y, Vec3::ONE, 1.0, 0.2, 0.3, 0.01).unwrap();
        let packed = try_pack_lights(&[down, away]).unwrap();
        let scale = pair_scale(&packed, grid.tile_size);
        let s = light_scores(&cam, &depth, (&grid, &all_lists(&grid, 2)), &packed, scale).unwrap();
        assert!(s[0] > 0 && s[1] == 0, "only the spot facing the floor lights it: {s:?}");
    }

    #[test]
    fn no_pair_saturates_at_the_brightest_light_on_every_pixel() {
        // The scale is chosen so that even the brightest light at its emitter's size from
        // a full tile stays below the u32 range; a realistic frame is far below it.
        let (cam, grid, depth) = scene();
        let l = Light::point(Vec3::new(0.0, 0.01, 1.0), Vec3::ONE, 1e6, 1e-3).unwrap();
        let packed = try_pack_lights(&[l]).unwrap();
        let scale = pair_scale(&packed, grid.tile_size);
        let s = light_scores(&cam, &depth, (&grid, &all_lists(&grid, 1)), &packed, scale).unwrap();
        assert!(s[0] > 0 && s[0] < grid.tile_count() as u64 * u32::MAX as u64, "{s:?}");
        assert_eq!(quantise(PAIR_MAX * 2.0), u32::MAX);
        assert_eq!(quantise(f32::NAN), 0, "NaN quantises to nothing, never to a huge value");
    }

    #[test]
    fn bad_inputs_are_named() {
        let (cam, grid, depth) = scene();
        let packed = try_pack_lights(&[Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 0.01).unwrap()]).unwrap();
        let e = |r: Result<Vec<u64>, CullError>| r.unwrap_err().to_string();
        let lists = all_lists(&grid, 1);
        assert!(e(light_scores(&cam, &depth[1..], (&grid, &lists), &packed, 1.0)).contains("depth buffer of 2047"));
        assert!(e(light_scores(&cam, &depth, (&grid, &lists[1..]), &packed, 1.0)).contains("7 light lists for 8 tiles"));
        let bad = vec![vec![3]; grid.tile_count()];
        assert!(e(light_scores(&cam, &depth, (&grid, &bad), &packed, 1.0)).contains("light index 3 in a list of 1"));
        assert_eq!(pair_scale(&try_pack_lights(&[]).unwrap(), 16), 0.0);
    }

    #[test]
    fn scores_map_back_to_the_input_order() {
        let p = |x: f32| Light::point(Vec3::splat(x), Vec3::ONE, 1.0, 0.01).unwrap();
        let s = Light::spot(Vec3::ZERO, -Vec3::Y, Vec3::ONE, 1.0, 0.2, 0.3, 0.01).unwrap();
        // Input: spot, point, spot, point -> packed: point, point, spot, spot.
        let lights = [s, p(1.0), s, p(2.0)];
        assert_eq!(scores_in_input_order(&lights, &[10, 20, 30, 40]).unwrap(), vec![30, 10, 40, 20]);
        assert!(scores_in_input_order(&lights, &[1]).is_err());
    }
}
