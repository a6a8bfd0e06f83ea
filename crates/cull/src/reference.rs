//! The CPU reference culler: (depth buffer, packed lights, camera, config) -> per-tile light
//! lists, running the exact algorithm of the GPU kernel (`shaders/cull.wgsl`): per tile,
//! min/max depth of its non-sky pixels, side planes and depth range, optional AABB and
//! spot-cone tests, optional half-z split. The lists of alpha-blended geometry
//! ([`cull_tiles_blended`]) run the same tests over the range from the nearest blended
//! surface to the opaque surface behind it. Also the ground truth (which lights really
//! reach a pixel) and culling statistics. Depends on the other modules of this crate.

use glam::{Mat4, Vec3};

use crate::bounds::{aabb_sphere, cone_vs_sphere, sphere_vs_aabb, sphere_vs_frustum, to_view};
use crate::camera::Camera;
use crate::cluster::ClusterConfig;
use crate::depth_mask::{light_depth_mask, tile_depth_masks};
use crate::error::CullError;
use crate::light::PackedLights;
use crate::tiles::{
    pixel_to_ndc_x, pixel_to_ndc_y, tile_depth_bounds, tile_depth_bounds_samples, tile_sample_spans, DepthBounds,
    TileFrustum, TileGrid,
};

/// Default per-list capacity of the library types (the app picks the light count, up to
/// 2048, instead). Enough for the default scene up to about 4k lights (longest list 306 at
/// 4,096 lights; 1,209 at 16,384, which overflows it).
pub const DEFAULT_CAPACITY: u32 = 512;
/// Largest per-list capacity the GPU kernel accepts (its workgroup list lives in 16 KiB).
pub const MAX_CAPACITY: u32 = 2048;
/// Side in pixels of the coarse cells of two-level culling (a multiple of every tile size).
pub const COARSE_SIZE: u32 = 64;
/// Light indices a coarse cell stores; a cell with more falls back to testing every light.
pub const COARSE_CAPACITY: u32 = 8192;

/// What the culler tests and how lists are stored. Mirrors the GPU pass's options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CullConfig {
    /// Tile side in pixels (8, 16 or 32 on the GPU; any 1..=64 on the CPU).
    pub tile_size: u32,
    /// Indices stored per list at most; the count still reports every light found.
    pub capacity: u32,
    /// Also test the sphere against the tile's view-space AABB (removes the large-sphere
    /// false positives of plane tests).
    pub aabb: bool,
    /// Two lists per tile, split at the middle of the tile's depth range.
    pub half_z: bool,
    /// Also test spot cones against the tile's bounding sphere.
    pub spot_cone: bool,
    /// Two-level culling: lights are first culled against 64x64-pixel cells (planes and
    /// depth range only), and each tile tests only its cell's survivors (every light when
    /// the cell overflowed [`COARSE_CAPACITY`]). The cell volume contains the tile's, so
    /// this stays conservative; it may drop a false positive the flat test would keep.
    pub coarse: bool,
    /// CPU only: grow (>0) or shrink (<0) every light's radius by this fraction of
    /// `radius + |centre|`, to find decisions within float error of the boundary.
    pub inflate: f32,
    /// Depth samples per pixel (MSAA: 1, 2, 4 or 8). The depth buffer holds `samples`
    /// values per pixel, pixel-major; a tile's depth range covers every sample, as the
    /// GPU kernel's does over a multisampled depth buffer.
    pub samples: u32,
    /// 2.5D culling (Harada 2012): each tile also keeps a 32-bit mask of the depth bins
    /// (of its own depth range) that hold a surface, and a light must overlap one of them
    /// ([`crate::depth_mask`]). One list per tile: not with `half_z`.
    pub depth_mask: bool,
    /// Light-centric assignment's lists: each light visits only the tiles of its
    /// [`crate::assign::light_tile_rect`], which for a light reaching the eye plane leaves
    /// out tiles its part beyond the near plane cannot cover (the per-tile test's false
    /// positives there); [`cull_tiles`] then runs [`crate::assign::cull_tiles_scatter`].
    pub scatter: bool,
}

impl Default for CullConfig {
    fn default() -> Self {
        Self {
            tile_size: 16,
            capacity: DEFAULT_CAPACITY,
            aabb: false,
            half_z: false,
            spot_cone: false,
            coarse: false,
            inflate: 0.0,
            samples: 1,
            depth_mask: false,
            scatter: false,
        }
    }
}

impl CullConfig {
    /// Lists per tile: 2 with half-z, else 1.
    pub fn lists_per_tile(&self) -> usize {
        if self.half_z {
            2
        } else {
            1
        }
    }

    /// Checks the options the GPU kernel relies on.
    pub fn validate(&self) -> Result<(), CullError> {
        if self.capacity == 0 || self.capacity > MAX_CAPACITY {
            return Err(CullError::InvalidSize(format!(
                "per-tile capacity {} must be in 1..={MAX_CAPACITY}",
                self.capacity
            )));
        }
        if self.coarse && !COARSE_SIZE.is_multiple_of(self.tile_size) {
            return Err(CullError::InvalidSize(format!(
                "two-level culling needs a tile size dividing {COARSE_SIZE}, not {}",
                self.tile_size
            )));
        }
        if !matches!(self.samples, 1 | 2 | 4 | 8) {
            return Err(CullError::InvalidSize(format!(
                "{} depth samples per pixel: must be 1, 2, 4 or 8",
                self.samples
            )));
        }
        if self.depth_mask && self.half_z {
            return Err(CullError::InvalidSize(
                "depth_mask (2.5D) and half_z are alternative layouts of one tile's depth range; turn one off".into(),
            ));
        }
        if !self.inflate.is_finite() {
            return Err(CullError::InvalidSize(format!("inflate {} is not finite", self.inflate)));
        }
        Ok(())
    }
}

/// Per-tile light lists. List `i` of tile `t` is `lists[t * lists_per_tile + i]`
/// ([`TileLists::lists_per_tile`]); with half-z, list 0 covers the near half of the tile's
/// depth range; with clusters (`cluster` is `Some`), list `i` is depth slice `i`. Which
/// layout made them: `cluster`, `config.half_z`, `config.depth_mask`.
#[derive(Clone, Debug, PartialEq)]
pub struct TileLists {
    /// The tiling.
    pub grid: TileGrid,
    /// The options used.
    pub config: CullConfig,
    /// Every light found per list, ascending (not truncated: the GPU stores at most
    /// `capacity` of them, in no particular order).
    pub lists: Vec<Vec<u32>>,
    /// Per tile, the view-distance range of its surfaces (None for all-sky tiles). For
    /// blended lists ([`cull_tiles_blended`]): from the nearest blended surface to the
    /// farthest opaque one behind it (`f32::INFINITY` where that is sky under an infinite
    /// far plane), None for tiles without blended geometry.
    pub ranges: Vec<Option<(f32, f32)>>,
    /// `Some` for clustered lists ([`crate::cluster::cull_clusters`]): `slices` lists per
    /// tile, list `t * slices + s` for depth slice `s`; `None` for the tile layouts, whose
    /// lists per tile `config` gives.
    pub cluster: Option<ClusterConfig>,
}

impl TileLists {
    /// Number of lists whose light count exceeds the capacity.
    pub fn overflowing_lists(&self) -> usize {
        self.lists.iter().filter(|l| l.len() > self.config.capacity as usize).count()
    }

    /// Lists per tile: the cluster slices, else 2 with half-z, else 1.
    pub fn lists_per_tile(&self) -> usize {
        self.cluster.map_or(self.config.lists_per_tile(), |c| c.slices as usize)
    }

    /// The list a pixel at view distance `dist` of tile `tile` uses.
    pub fn list_index(&self, tile: usize, dist: f32) -> usize {
        if let Some(c) = &self.cluster {
            return tile * c.slices as usize + c.slice_of(dist) as usize;
        }
        if !self.config.half_z {
            return tile;
        }
        match self.ranges[tile] {
            Some((near, far)) if dist > half_z_split(near, far) => tile * 2 + 1,
            _ => tile * 2,
        }
    }
}

/// The distance where half-z splits a tile's range `[near, far]`.
pub fn half_z_split(near: f32, far: f32) -> f32 {
    0.5 * (near + far)
}

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

/// Culls `lights` (packed points first, as uploaded) against every tile of a reversed-Z
/// `depth` buffer (row-major, `width * height`), as the GPU kernel does.
pub fn cull_tiles(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &Camera,
    lights: &PackedLights,
    config: &CullConfig,
) -> Result<TileLists, CullError> {
    if config.scatter {
        return crate::assign::cull_tiles_scatter(depth, width, height, camera, lights, config);
    }
    let (grid, vls, cells) = cull_setup(depth, (width, height), camera, lights, config)?;
    let masks = config.depth_mask.then(|| tile_depth_masks(depth, &grid, config.samples, camera));
    let bounds = |tx, ty| tile_depth_bounds_samples(&grid, depth, config.samples, tx, ty);
    Ok(cull_with_bounds(grid, camera, &vls, config, cells.as_ref(), masks.as_deref(), bounds))
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
/// [`cull_tiles_blended`] of this buffer.
pub fn depth_tested_blended(opaque: &[f32], blended: &[f32]) -> Vec<f32> {
    opaque.iter().zip(blended).map(|(&o, &b)| if b > o { b } else { 0.0 }).collect()
}

/// Culls `lights` for the alpha-blended geometry of a frame: as [`cull_tiles`] (same side
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

/// Per tile (row-major), the volumes its lists cover (`None` for tiles without bounds), and
/// per tile its view-distance range: what both culler loops share.
type Volumes = (Vec<Option<Vec<TileFrustum>>>, Vec<Option<(f32, f32)>>);

/// [`Volumes`] of every tile whose `bounds(tx, ty)` exist: its frustum, or the two
/// half-z halves.
fn volumes_with_bounds(
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

/// Per coarse cell, its lights, or `None` when the cell overflowed.
pub type CellLists = Vec<Option<Vec<u32>>>;

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

/// View-space position of the centre of pixel (x, y) with reversed-Z depth `d`, or `None`
/// for sky. The position every renderer shades.
pub fn pixel_view_position(camera: &Camera, width: u32, height: u32, x: u32, y: u32, d: f32) -> Option<Vec3> {
    if d <= 0.0 {
        return None;
    }
    camera.unproject_view(pixel_to_ndc_x(x as f32 + 0.5, width), pixel_to_ndc_y(y as f32 + 0.5, height), d)
}

/// Lights in view space, ready for the ground-truth test of whether a light reaches a point.
struct ReachTest {
    lights: Vec<ReachLight>,
}

/// A light's centre, radius, and a spot's view-space axis and cos outer.
type ReachLight = (Vec3, f32, Option<(Vec3, f32)>);

impl ReachTest {
    fn new(view: &Mat4, lights: &PackedLights) -> Self {
        let rot = Mat4::from_mat3(glam::Mat3::from_mat4(*view));
        let lights = (0..lights.len())
            .map(|i| {
                let sh = lights.shading[i];
                let spot = (i >= lights.num_point as usize).then(|| {
                    let s = lights.spots[i - lights.num_point as usize];
                    (to_view(&rot, Vec3::from(s.direction)), s.cos_outer)
                });
                (to_view(view, Vec3::from(sh.position)), sh.radius, spot)
            })
            .collect();
        Self { lights }
    }

    /// Whether light `i` reaches view-space `p` with `margin` (a fraction of the radius,
    /// and of the cone's angular width) to spare.
    fn reaches(&self, i: u32, p: Vec3, margin: f32) -> bool {
        let (pos, radius, spot) = self.lights[i as usize];
        let d = p - pos;
        let len = d.length();
        if len >= radius * (1.0 - margin) {
            return false;
        }
        // Inside the cone by an angular margin too: cos of the angle to the axis above cos_outer.
        spot.is_none_or(|(axis, c)| len > 0.0 && d.dot(axis) / len > c + margin * (1.0 - c))
    }
}

/// Ground truth: the lights (indices into the packed order) whose light volume contains
/// view-space point `p` with at least `margin` (a fraction of the radius) to spare:
/// strictly inside the radius and, for spots, inside the outer cone.
pub fn lights_reaching(view: &Mat4, lights: &PackedLights, p: Vec3, margin: f32) -> Vec<u32> {
    let t = ReachTest::new(view, lights);
    (0..lights.len() as u32).filter(|&i| t.reaches(i, p, margin)).collect()
}

/// Culling statistics of a set of lists.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CullStats {
    /// Mean lights per list over lists of tiles with geometry (for clusters: over every
    /// slice of those tiles, empty slices included).
    pub mean_per_list: f64,
    /// Largest light count of a list.
    pub max_per_list: u32,
    /// Lists whose count exceeds the capacity.
    pub overflowing: u32,
    /// Tiles with geometry.
    pub tiles_with_geometry: u32,
}

/// Mean/max/overflow statistics of `lists`.
pub fn stats(lists: &TileLists) -> CullStats {
    let per = lists.lists_per_tile();
    let mut s = CullStats::default();
    let mut sum = 0u64;
    let mut n = 0u64;
    for (t, r) in lists.ranges.iter().enumerate() {
        if r.is_none() {
            continue;
        }
        s.tiles_with_geometry += 1;
        for k in 0..per {
            let c = lists.lists[t * per + k].len() as u32;
            sum += c as u64;
            n += 1;
            s.max_per_list = s.max_per_list.max(c);
        }
    }
    s.overflowing = lists.overflowing_lists() as u32;
    s.mean_per_list = if n > 0 { sum as f64 / n as f64 } else { 0.0 };
    s
}

/// How well a set of lists fits the pixels that use them, the cost side of culling.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ListQuality {
    /// Fraction of listed (list, light) pairs whose light reaches no pixel using the list:
    /// the culling test's false-positive rate.
    pub false_positive_rate: f64,
    /// Per pixel with geometry, lights in its list that do not reach it (the shader
    /// evaluates them for nothing), averaged over those pixels.
    pub wasted_per_pixel: f64,
    /// Per pixel with geometry, lights in its list, averaged: the evaluations shading does.
    pub evaluated_per_pixel: f64,
    /// Pixels with geometry.
    pub pixels: u64,
}

/// The view distance range of every tile's surfaces (None for all-sky tiles), as the
/// culler computes it: what half-z splits and [`TileLists::list_index`] needs.
pub fn tile_ranges(depth: &[f32], grid: &TileGrid, camera: &Camera) -> Result<Vec<Option<(f32, f32)>>, CullError> {
    check_depth(grid, depth)?;
    let mut ranges = vec![None; grid.tile_count()];
    for ty in 0..grid.tiles_y {
        for tx in 0..grid.tiles_x {
            if let Some(b) = tile_depth_bounds(grid, depth, tx, ty) {
                let f = TileFrustum::new(grid, camera, tx, ty, b);
                ranges[(ty * grid.tiles_x + tx) as usize] = Some((f.near, f.far));
            }
        }
    }
    Ok(ranges)
}

/// [`ListQuality`] of `lists` (from this culler or read back from a GPU) for a frame:
/// every pixel tests only the lights of its own list with [`lights_reaching`]'s test (margin
/// 0), so it costs pixels x mean list length and runs on full-HD frames in seconds. A light
/// that reaches a pixel but is missing from its list (a false negative) counts nowhere.
pub fn list_quality(depth: &[f32], camera: &Camera, lights: &PackedLights, lists: &TileLists) -> ListQuality {
    let g = lists.grid;
    let test = ReachTest::new(&camera.view(), lights);
    // Rows of tiles touch disjoint lists, so bands of them run on separate threads with no
    // shared state, and the integer sums are the same whatever the thread count.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(g.tiles_y as usize).max(1);
    let band = (g.tiles_y as usize).div_ceil(threads) as u32;
    let counts: Vec<[u64; 5]> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..g.tiles_y)
            .step_by(band as usize)
            .map(|ty0| {
                let test = &test;
                s.spawn(move || quality_of_rows(depth, camera, test, lists, ty0..(ty0 + band).min(g.tiles_y)))
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("a list-quality thread panicked")).collect()
    });
    let [evaluated, wasted, pixels, listed, unused] =
        counts.iter().fold([0u64; 5], |acc, c| std::array::from_fn(|i| acc[i] + c[i]));
    let per_pixel = |n: u64| if pixels > 0 { n as f64 / pixels as f64 } else { 0.0 };
    ListQuality {
        false_positive_rate: if listed > 0 { unused as f64 / listed as f64 } else { 0.0 },
        wasted_per_pixel: per_pixel(wasted),
        evaluated_per_pixel: per_pixel(evaluated),
        pixels,
    }
}

/// [`list_quality`]'s counts over the tile rows `rows`: evaluated, wasted, pixels, listed
/// pairs, listed pairs reaching no pixel.
fn quality_of_rows(
    depth: &[f32],
    camera: &Camera,
    test: &ReachTest,
    lists: &TileLists,
    rows: std::ops::Range<u32>,
) -> [u64; 5] {
    let g = lists.grid;
    let dp = camera.depth_params();
    let per = lists.lists_per_tile();
    let first = rows.start as usize * g.tiles_x as usize * per;
    let last = rows.end as usize * g.tiles_x as usize * per;
    let mut used: Vec<Vec<bool>> = lists.lists[first..last].iter().map(|l| vec![false; l.len()]).collect();
    let (mut evaluated, mut wasted, mut pixels) = (0u64, 0u64, 0u64);
    let y_end = (rows.end * g.tile_size).min(g.height);
    for y in rows.start * g.tile_size..y_end {
        for x in 0..g.width {
            let d = depth[(y * g.width + x) as usize];
            let Some(p) = pixel_view_position(camera, g.width, g.height, x, y, d) else { continue };
            let li = lists.list_index(g.tile_of_pixel(x, y), dp.view_distance(d));
            pixels += 1;
            for (k, &i) in lists.lists[li].iter().enumerate() {
                evaluated += 1;
                if test.reaches(i, p, 0.0) {
                    used[li - first][k] = true;
                } else {
                    wasted += 1;
                }
            }
        }
    }
    let listed = used.iter().map(|u| u.len() as u64).sum();
    let unused = used.iter().map(|u| u.iter().filter(|&&b| !b).count() as u64).sum();
    [evaluated, wasted, pixels, listed, unused]
}

/// Fraction of listed (tile, light) pairs whose light reaches no pixel of the tile (or of
/// the list's half, with half-z): the culling test's false-positive rate
/// ([`list_quality`]'s, which also gives the wasted evaluations per pixel).
pub fn false_positive_rate(depth: &[f32], camera: &Camera, lights: &PackedLights, lists: &TileLists) -> f64 {
    list_quality(depth, camera, lights, lists).false_positive_rate
}
