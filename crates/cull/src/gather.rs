//! The tile-centric (gather) CPU culler, twin of the GPU's `shaders/cull.wgsl`: per tile,
//! every light (or, two-level, every light its 64x64-pixel cell kept) is tested against the
//! tile's volume ([`crate::volumes`]). Also the lists of alpha-blended geometry
//! ([`cull_tiles_blended`]), the same loop over the blended bounds, and the set-up every
//! tile culler shares (`cull_setup`: checks, grid, view-space lights, coarse cells).
//! Depends on [`crate::volumes`], [`crate::lists`], [`crate::tiles`], [`crate::bounds`],
//! [`crate::depth_mask`], [`crate::camera`], [`crate::light`].

use crate::bounds::sphere_vs_frustum;
use crate::camera::Camera;
use crate::depth_mask::tile_depth_masks;
use crate::error::CullError;
use crate::light::PackedLights;
use crate::lists::{CellLists, CullConfig, TileLists, COARSE_CAPACITY, COARSE_SIZE};
use crate::tiles::{tile_depth_bounds_samples, DepthBounds, TileFrustum, TileGrid};
use crate::volumes::{
    blended_tile_bounds, check_depth, check_depth_samples, light_in_volume, view_lights, volumes_with_bounds, ViewLight,
};

/// Culls `lights` (packed points first, as uploaded) against every tile of a reversed-Z
/// `depth` buffer (row-major, `width * height`) tile by tile, as the GPU's gather kernel
/// does: [`crate::cull_tiles`] without `config.scatter`.
pub fn cull_tiles_gather(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
    config: &CullConfig,
) -> Result<TileLists, CullError> {
    let (grid, vls, cells) = cull_setup(depth, (width, height), camera, lights, config)?;
    let masks = config.depth_mask.then(|| tile_depth_masks(depth, &grid, config.samples, camera));
    let bounds = |tx, ty| tile_depth_bounds_samples(&grid, depth, config.samples, tx, ty);
    Ok(cull_with_bounds(grid, camera, &vls, config, cells.as_ref(), masks.as_deref(), bounds))
}

/// Culls `lights` for the alpha-blended geometry of a frame: as [`crate::cull_tiles`] (same side
/// planes, depth-range, AABB and spot-cone tests), but each tile's volume runs from its
/// nearest blended surface to the farthest opaque surface behind its blended samples
/// ([`blended_tile_bounds`]). Tiles without blended geometry get an empty list and a
/// `None` range. `opaque` is the opaque depth buffer, `blended` the blended geometry's own
/// (cleared to 0, depth-tested against the opaque one without writing it); both reversed-Z,
/// row-major, `config.samples` values per pixel.
///
/// Every blended fragment that passes the depth test at a sample lies between the opaque
/// depth and the blended buffer's (nearest) depth there, so the range holds every blended
/// layer of the tile, not only the nearest.
///
/// One list per tile: `config.half_z` is rejected with an error naming it.
/// `config.coarse` and `config.depth_mask` are ignored (not validated either), and the
/// returned `config` has them cleared: the blended lists are one-level, every tile tests
/// every light, with no 2.5D mask (the coarse cells and the depth masks are built from the
/// opaque depth, which does not hold the blended surfaces).
pub fn cull_tiles_blended(
    opaque: &[f32],
    blended: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
    config: &CullConfig,
) -> Result<TileLists, CullError> {
    if config.half_z {
        return Err(CullError::InvalidSize(
            "half_z is not supported for blended light lists (one list per tile); turn half_z off".into(),
        ));
    }
    let config = CullConfig { coarse: false, depth_mask: false, ..*config };
    config.validate()?;
    let grid = TileGrid::new(width, height, config.tile_size)?;
    for (name, depth) in [("opaque", opaque), ("blended", blended)] {
        check_depth_samples(&grid, depth, config.samples).map_err(|e| match e {
            CullError::InvalidDepth(m) => CullError::InvalidDepth(format!("{name} depth buffer: {m}")),
            e => e,
        })?;
    }
    let vls = view_lights(&camera.view(), lights, config.inflate);
    let bounds = |tx, ty| {
        blended_tile_bounds(&grid, opaque, blended, config.samples, tx, ty)
            .map(|(near, far)| DepthBounds { min_depth: far, max_depth: near })
    };
    Ok(cull_with_bounds(grid, camera, &vls, &config, None, None, bounds))
}

/// The per-tile loop of both culler entry points: per tile, `bounds(tx, ty)` gives the depth
/// range its lists cover (None: no lists), `cells` the lights two-level culling left it,
/// `masks` its 2.5D depth mask.
fn cull_with_bounds(
    grid: TileGrid,
    camera: &Camera,
    vls: &[ViewLight],
    config: &CullConfig,
    cells: Option<&(TileGrid, CellLists)>,
    masks: Option<&[u32]>,
    bounds: impl Fn(u32, u32) -> Option<DepthBounds>,
) -> TileLists {
    let proj = camera.proj();
    let dp = camera.depth_params();
    let per = config.lists_per_tile();
    let all: Vec<u32> = (0..vls.len() as u32).collect();
    let (volumes, ranges) = volumes_with_bounds(&grid, camera, config, bounds);
    let mut lists = vec![Vec::new(); grid.tile_count() * per];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            let t = (ty * grid.tiles_x + tx) as usize;
            let Some(vols) = &volumes[t] else { continue };
            let candidates = match cells {
                Some((cgrid, cell_lists)) => {
                    let (x0, _, y0, _) = grid.tile_pixels(tx, ty);
                    cell_lists[cgrid.tile_of_pixel(x0, y0)].as_ref().unwrap_or(&all)
                }
                None => &all,
            };
            let mask = masks.map(|m| m[t]);
            for (k, vol) in vols.iter().enumerate() {
                lists[t * per + k] = candidates
                    .iter()
                    .copied()
                    .filter(|&i| light_in_volume(&vls[i as usize], vol, &proj, dp.orthographic, config, mask))
                    .collect();
            }
        }
    }
    TileLists { grid, config: *config, lists, ranges, cluster: None }
}

/// What both shapes of the tile culler (`cull_tiles`, `assign::cull_tiles_scatter`) set up
/// first: the options and depth buffer checked, the tile grid, the lights in view space
/// and, two-level, the coarse cells.
#[allow(clippy::type_complexity)]
pub(crate) fn cull_setup(
    depth: &[f32],
    (width, height): (u32, u32),
    camera: &Camera,
    lights: &PackedLights,
    config: &CullConfig,
) -> Result<(TileGrid, Vec<ViewLight>, Option<(TileGrid, CellLists)>), CullError> {
    config.validate()?;
    let grid = TileGrid::new(width, height, config.tile_size)?;
    check_depth_samples(&grid, depth, config.samples)?;
    let vls = view_lights(&camera.view(), lights, config.inflate);
    let cells =
        if config.coarse { Some(coarse_cells_of(depth, width, height, config.samples, camera, &vls)?) } else { None };
    Ok((grid, vls, cells))
}

/// The coarse cells of two-level culling: per cell, the lights passing the plane and
/// depth-range test of the cell's volume, or `None` when more than [`COARSE_CAPACITY`] do
/// (the tiles then test every light). All-sky cells get an empty list.
pub(crate) fn coarse_cells_of(
    depth: &[f32],
    width: u32,
    height: u32,
    samples: u32,
    camera: &Camera,
    vls: &[ViewLight],
) -> Result<(TileGrid, CellLists), CullError> {
    let cgrid = TileGrid::new(width, height, COARSE_SIZE)?;
    let mut cells = Vec::with_capacity(cgrid.tile_count());
    for cy in 0..cgrid.tiles_y {
        for cx in 0..cgrid.tiles_x {
            let Some(b) = tile_depth_bounds_samples(&cgrid, depth, samples, cx, cy) else {
                cells.push(Some(Vec::new()));
                continue;
            };
            let f = TileFrustum::new(&cgrid, camera, cx, cy, b);
            let list: Vec<u32> = (0..vls.len() as u32)
                .filter(|&i| {
                    let l = &vls[i as usize];
                    l.radius > 0.0 && sphere_vs_frustum(&f, l.center, l.radius)
                })
                .collect();
            cells.push((list.len() <= COARSE_CAPACITY as usize).then_some(list));
        }
    }
    Ok((cgrid, cells))
}

/// The first level of two-level culling on its own: the cell grid and, per cell, its
/// lights, or `None` for a cell that overflowed [`COARSE_CAPACITY`].
pub fn coarse_cells(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
) -> Result<(TileGrid, CellLists), CullError> {
    check_depth(&TileGrid::new(width, height, COARSE_SIZE)?, depth)?;
    coarse_cells_of(depth, width, height, 1, camera, &view_lights(&camera.view(), lights, 0.0))
}
