//! Shadow-map math for shadow-casting point and spot lights: the atlas layout, each shadow
//! face's view and projection, the lookup a shader does (face choice, atlas coordinates,
//! reference depth, bias), and the filter's footprint. The GPU builds its per-face data
//! from these functions and `shaders/common/shadow.wgsl` repeats the lookup; the tests
//! check the lookup's guarantees here (every tap of a filter stays inside its face's tile,
//! the faces of a point light cover every direction) and compare the GPU's shadows with a
//! ray-cast reference ([`crate::raycast`]).
//!
//! The steps:
//! 1. **Atlas.** One `texture_depth_2d_array`; each layer is `6 x rows` tiles of `tile`
//!    texels. A point caster takes one row (its six cube faces, as TiledLighting11 packs
//!    them), spot casters share rows, six to a row. Rows fill a layer top to bottom
//!    ([`AtlasLayout`]).
//! 2. **Face borders (PlayCanvas's approach).** A filter of radius `r` taps texels up to
//!    `r + 1` away from the lookup point (hardware 2x2 comparison per tap). Each face is
//!    rendered with its field of view widened so that the face proper covers only the
//!    tile's inner `tile - 2 (r + 1)` texels; the border ring holds real depth from just
//!    beyond the face. A lookup then never reads a neighbouring face or tile and needs no
//!    clamping per tap (which a fragment-heavy GPU would pay for on every tap).
//! 3. **Projection.** Reversed-Z, infinite far plane (`depth = near / view_depth`), as the
//!    main camera, so the brute-force reference without the radius cutoff is shadowed
//!    beyond the radius too. The near plane is [`NEAR_FRACTION`] of the light's radius,
//!    pulled in short of the nearest geometry so no occluder next to the light is clipped
//!    ([`shadow_near`]).
//! 4. **Bias** (from the texel's size at the receiver, so scale-free): a normal offset of
//!    [`NORMAL_OFFSET_TEXELS`] texel times `sin(theta)` ([`biased_position`]), and a
//!    slope-scaled depth bias: the depth a plane spans over the filter's `r + 1` texels as
//!    the face sees it, plus half a texel ([`slope_bias`], [`biased_depth`]); for 16-bit
//!    depth, two depth quanta more.
//!
//! Depends on glam and [`crate::error`].

use glam::{Mat4, Vec3, Vec4, Vec4Swizzles};

use crate::error::CullError;

/// Tiles per atlas row: a point light's six cube faces.
pub const ROW_TILES: u32 = 6;

/// Near plane of a shadow face, as a fraction of the light's radius. Geometry closer to
/// the light than this casts no shadow; 16-bit depth resolves `d^2 / (near * 65535)`, so
/// a smaller near plane costs precision far away (about 1.5% of the radius at the radius).
pub const NEAR_FRACTION: f32 = 0.01;

/// Widest spot cone (outer half-angle) that casts a shadow from one tile: beyond it the
/// projection's texels at the cone's rim stretch by more than `1 / cos^2(80 deg)` = 33x.
pub const MAX_SHADOW_SPOT_ANGLE: f32 = 80.0 * std::f32::consts::PI / 180.0;

/// Tile sizes accepted (texels per side).
pub const TILE_SIZES: std::ops::RangeInclusive<u32> = 128..=1024;

/// The percentage-closer filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadowFilter {
    /// One comparison tap (hardware 2x2 bilinear comparison).
    Tap1,
    /// 3x3 taps, each a hardware 2x2 comparison.
    Pcf3,
    /// 5x5 taps, as TiledLighting11.
    #[default]
    Pcf5,
}

impl ShadowFilter {
    /// Every filter, fewest taps first.
    pub const ALL: [ShadowFilter; 3] = [Self::Tap1, Self::Pcf3, Self::Pcf5];

    /// Taps per side as the flag writes it: `1`, `3` or `5`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Tap1 => "1",
            Self::Pcf3 => "3",
            Self::Pcf5 => "5",
        }
    }

    /// The filter of `size` taps per side (1, 3 or 5).
    pub fn from_size(size: u32) -> Result<Self, CullError> {
        match size {
            1 => Ok(Self::Tap1),
            3 => Ok(Self::Pcf3),
            5 => Ok(Self::Pcf5),
            _ => Err(CullError::InvalidShadow(format!("shadow filter {size}: use 1, 3 or 5 taps per side"))),
        }
    }
    /// Taps per side.
    pub fn size(self) -> u32 {
        2 * self.radius() + 1
    }
    /// Taps each side of the centre tap.
    pub fn radius(self) -> u32 {
        match self {
            Self::Tap1 => 0,
            Self::Pcf3 => 1,
            Self::Pcf5 => 2,
        }
    }
    /// Texels of border each tile keeps around its face: the outermost tap's offset plus
    /// the hardware comparison's second texel.
    pub fn margin(self) -> u32 {
        self.radius() + 1
    }
}

/// Depth format of the atlas (`Depth16Unorm` or `Depth32Float`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadowFormat {
    /// `Depth16Unorm` (core in WebGPU; TiledLighting11's D16).
    #[default]
    Depth16,
    /// `Depth32Float`.
    Depth32,
}

impl ShadowFormat {
    /// Both formats.
    pub const ALL: [ShadowFormat; 2] = [Self::Depth16, Self::Depth32];

    /// Bytes per texel.
    pub fn bytes(self) -> u32 {
        match self {
            Self::Depth16 => 2,
            Self::Depth32 => 4,
        }
    }
    /// Added to the lookup's reference depth: two quanta of 16-bit depth (the rasteriser
    /// rounds to the nearest), nothing for 32-bit float (the world-space bias covers it).
    pub fn depth_bias(self) -> f32 {
        match self {
            Self::Depth16 => 2.0 / 65535.0,
            Self::Depth32 => 0.0,
        }
    }
    /// The flag value.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Depth16 => "d16",
            Self::Depth32 => "d32",
        }
    }
    /// The format of flag value `name` (`d16`, `d32`).
    pub fn from_name(name: &str) -> Result<Self, CullError> {
        match name {
            "d16" => Ok(Self::Depth16),
            "d32" => Ok(Self::Depth32),
            _ => Err(CullError::InvalidShadow(format!("shadow format {name:?}: use d16 or d32"))),
        }
    }
}

/// How shadows are drawn; which lights cast them is decided with the lights
/// (`try_pack_lights_with_casters` in [`crate::light`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShadowOptions {
    /// Texels per tile side (128 to 1024; 256 as TiledLighting11).
    pub tile_size: u32,
    /// Percentage-closer filter.
    pub filter: ShadowFilter,
    /// Depth format.
    pub format: ShadowFormat,
}

impl Default for ShadowOptions {
    fn default() -> Self {
        Self { tile_size: 256, filter: ShadowFilter::Pcf5, format: ShadowFormat::Depth16 }
    }
}

/// Where the shadow faces lie in the atlas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasLayout {
    /// Texels per tile side.
    pub tile: u32,
    /// Shadow-casting point lights (one row each, first).
    pub points: u32,
    /// Shadow-casting spot lights (six to a row, after the points' rows).
    pub spots: u32,
    /// Rows of tiles per layer.
    pub rows_per_layer: u32,
    /// Layers.
    pub layers: u32,
}

/// A face's place in the atlas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaceRect {
    /// Atlas layer.
    pub layer: u32,
    /// Left texel.
    pub x: u32,
    /// Top texel.
    pub y: u32,
    /// Side in texels.
    pub size: u32,
}

impl AtlasLayout {
    /// The layout of `points` point and `spots` spot casters in tiles of `tile` texels, for
    /// a GPU whose 2D textures are at most `max_side` texels and `max_layers` layers. The
    /// error names the numbers that do not fit.
    pub fn new(tile: u32, points: u32, spots: u32, max_side: u32, max_layers: u32) -> Result<Self, CullError> {
        if !TILE_SIZES.contains(&tile) {
            return Err(CullError::InvalidShadow(format!(
                "shadow tile {tile}: use {} to {} texels",
                TILE_SIZES.start(),
                TILE_SIZES.end()
            )));
        }
        if ROW_TILES * tile > max_side {
            return Err(CullError::InvalidShadow(format!(
                "shadow tile {tile}: a row of six tiles: limit max_texture_dimension_2d = {max_side}, asked for {} texels",
                ROW_TILES * tile
            )));
        }
        let rows = points as u64 + (spots as u64).div_ceil(ROW_TILES as u64);
        let rows_per_layer = (max_side / tile).max(1);
        let layers = rows.div_ceil(rows_per_layer as u64).max(1);
        if layers > max_layers as u64 {
            return Err(CullError::InvalidShadow(format!(
                "{points} point + {spots} spot shadow casters need {rows} rows of {tile}-texel tiles, \
                 {rows_per_layer} rows a layer (the atlas holds {} rows): limit max_texture_array_layers = \
                 {max_layers} layers, asked for {layers} layers",
                max_layers as u64 * rows_per_layer as u64
            )));
        }
        Ok(Self { tile, points, spots, rows_per_layer, layers: layers as u32 })
    }

    /// Rows in use.
    pub fn rows(&self) -> u32 {
        self.points + self.spots.div_ceil(ROW_TILES)
    }
    /// Width of a layer in texels.
    pub fn width(&self) -> u32 {
        ROW_TILES * self.tile
    }
    /// Height of a layer in texels (the rows of the fullest layer).
    pub fn height(&self) -> u32 {
        self.rows().clamp(1, self.rows_per_layer) * self.tile
    }
    /// Number of faces: six per point caster, one per spot caster.
    pub fn faces(&self) -> u32 {
        ROW_TILES * self.points + self.spots
    }
    /// The face index of point caster `caster`'s cube face `face` (0..6).
    pub fn point_face(&self, caster: u32, face: u32) -> u32 {
        ROW_TILES * caster + face
    }
    /// The face index of spot caster `caster`.
    pub fn spot_face(&self, caster: u32) -> u32 {
        ROW_TILES * self.points + caster
    }
    /// Where face `face` lies.
    pub fn rect(&self, face: u32) -> FaceRect {
        let (row, col) = if face < ROW_TILES * self.points {
            (face / ROW_TILES, face % ROW_TILES)
        } else {
            let s = face - ROW_TILES * self.points;
            (self.points + s / ROW_TILES, s % ROW_TILES)
        };
        FaceRect {
            layer: row / self.rows_per_layer,
            x: col * self.tile,
            y: (row % self.rows_per_layer) * self.tile,
            size: self.tile,
        }
    }
    /// Bytes of the atlas at `bytes_per_texel`.
    pub fn bytes(&self, bytes_per_texel: u32) -> u64 {
        self.width() as u64 * self.height() as u64 * self.layers as u64 * bytes_per_texel as u64
    }
}

/// The six cube faces' axes and up vectors, in face order +X, -X, +Y, -Y, +Z, -Z.
const CUBE_FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::Z),
    (Vec3::Z, Vec3::Y),
    (Vec3::NEG_Z, Vec3::Y),
];

/// The cube face a direction from the light falls in: the axis of its largest component,
/// ties to x, then y (as `shaders/common/shadow.wgsl` decides).
pub fn cube_face(dir: Vec3) -> u32 {
    let a = dir.abs();
    if a.x >= a.y && a.x >= a.z {
        if dir.x >= 0.0 {
            0
        } else {
            1
        }
    } else if a.y >= a.z {
        if dir.y >= 0.0 {
            2
        } else {
            3
        }
    } else if dir.z >= 0.0 {
        4
    } else {
        5
    }
}

/// Tangent of half the widened field of view: the face (or cone) of half-angle tangent
/// `tan_half` covers the inner `tile - 2 margin` texels of the tile.
pub fn widened_tan(tan_half: f32, tile: u32, filter: ShadowFilter) -> f32 {
    let inner = tile as f32 - 2.0 * filter.margin() as f32;
    tan_half * tile as f32 / inner
}

/// World to view and view to clip of a point caster at `position` with near plane `near`
/// ([`shadow_near`]), cube face `face`.
pub fn point_face_view_proj(position: Vec3, near: f32, face: u32, tile: u32, filter: ShadowFilter) -> (Mat4, Mat4) {
    let (fwd, up) = CUBE_FACES[face as usize];
    let fov = 2.0 * widened_tan(1.0, tile, filter).atan();
    (Mat4::look_to_rh(position, fwd, up), Mat4::perspective_infinite_reverse_rh(fov, 1.0, near))
}

/// World to clip of a point caster at `position` with near plane `near`, cube face `face`.
pub fn point_face_matrix(position: Vec3, near: f32, face: u32, tile: u32, filter: ShadowFilter) -> Mat4 {
    let (view, proj) = point_face_view_proj(position, near, face, tile, filter);
    proj * view
}

/// World to clip of a spot caster at `position` along unit `direction`, near plane `near`, outer half-angle
/// with sine and cosine `(sin_outer, cos_outer)`. Errors for cones wider than
/// [`MAX_SHADOW_SPOT_ANGLE`].
pub fn spot_matrix(
    position: Vec3,
    direction: Vec3,
    near: f32,
    sin_cos: (f32, f32),
    tile: u32,
    filter: ShadowFilter,
) -> Result<Mat4, CullError> {
    let (view, proj) = spot_view_proj(position, direction, near, sin_cos, tile, filter)?;
    Ok(proj * view)
}

/// World to view and view to clip of a spot caster (see [`spot_matrix`]).
pub fn spot_view_proj(
    position: Vec3,
    direction: Vec3,
    near: f32,
    (sin_outer, cos_outer): (f32, f32),
    tile: u32,
    filter: ShadowFilter,
) -> Result<(Mat4, Mat4), CullError> {
    if cos_outer < MAX_SHADOW_SPOT_ANGLE.cos() - 1e-6 {
        return Err(CullError::InvalidShadow(format!(
            "a spot light of outer half-angle {:.1} degrees cannot cast a shadow from one tile \
             (at most {:.0} degrees)",
            sin_outer.atan2(cos_outer).to_degrees(),
            MAX_SHADOW_SPOT_ANGLE.to_degrees()
        )));
    }
    let up = if direction.y.abs() < 0.99 { Vec3::Y } else { Vec3::X };
    let fov = 2.0 * widened_tan(sin_outer / cos_outer, tile, filter).atan();
    Ok((Mat4::look_to_rh(position, direction, up), Mat4::perspective_infinite_reverse_rh(fov, 1.0, near)))
}

/// A shadow lookup: where to sample and what to compare with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    /// Atlas coordinates in texels (x right, y down).
    pub texel: [f32; 2],
    /// Reference depth (reversed-Z: larger is nearer the light; lit where it is at least
    /// the stored depth).
    pub depth: f32,
    /// Distance along the face's axis (the projection's w).
    pub view_depth: f32,
}

/// Projects world point `p` with face matrix `m` into the face's tile `rect`.
pub fn project(m: &Mat4, rect: FaceRect, p: Vec3) -> Lookup {
    let clip: Vec4 = *m * p.extend(1.0);
    let ndc = clip.xy() / clip.w;
    let s = rect.size as f32;
    Lookup {
        texel: [rect.x as f32 + (0.5 + 0.5 * ndc.x) * s, rect.y as f32 + (0.5 - 0.5 * ndc.y) * s],
        depth: clip.z / clip.w,
        view_depth: clip.w,
    }
}

/// Normal offset, in texels at the receiver per `sin(theta)` (theta: the light's incidence):
/// lifts the lookup off the surface by about one texel where the light grazes it, which
/// covers the rasteriser's rounding and curved surfaces; the slope is [`slope_bias`]'s.
pub const NORMAL_OFFSET_TEXELS: f32 = 1.0;

/// Largest slope factor of [`slope_bias`]: the bias stops growing at ~87 degrees of
/// incidence (a plane lit that flatly gets almost no light).
pub const MAX_SLOPE: f32 = 20.0;

/// The lookup point for surface point `p` with unit normal `n`, unit direction to the light
/// `l`, where one shadow texel spans `texel_world` world units: `p` lifted along `n` by
/// [`NORMAL_OFFSET_TEXELS`] texels times `sin(theta)`.
pub fn biased_position(p: Vec3, n: Vec3, l: Vec3, texel_world: f32) -> Vec3 {
    let cos = n.dot(l).clamp(-1.0, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    p + n * (NORMAL_OFFSET_TEXELS * texel_world * sin)
}

/// Slope-scaled depth bias, in view depth (world units along the face's axis `axis`), for
/// a planar receiver with unit normal `n` lit from unit direction `l` (toward the light):
/// the plane's view depth changes by `texel * sin(alpha) * cos(phi) / cos(theta)` per
/// shadow texel (alpha: between `n` and the axis; phi: between the ray and the axis;
/// theta: between `n` and `l`), and the filter reads `r + 1` texels from the centre; half a
/// texel more covers the rasteriser's rounding. The factor is capped at [`MAX_SLOPE`].
pub fn slope_bias(texel_world: f32, n: Vec3, l: Vec3, axis: Vec3, filter: ShadowFilter) -> f32 {
    let sin_alpha = (1.0 - n.dot(axis).powi(2)).max(0.0).sqrt();
    let cos_phi = (-l).dot(axis).max(0.0);
    let cos_theta = n.dot(l).max(1e-3);
    let slope = (sin_alpha * cos_phi / cos_theta).min(MAX_SLOPE);
    ((filter.radius() as f32 + 1.0) * slope + 0.5) * texel_world
}

/// The reference depth of a lookup at reversed-Z depth `depth` and view depth `w`, moved
/// toward the light by `bias` in view depth (`depth = near / w`, so the biased depth is
/// `near / (w - bias)`), plus `quanta` of the format's resolution.
pub fn biased_depth(depth: f32, w: f32, bias: f32, quanta: f32) -> f32 {
    depth * w / (w - bias).max(w * 1e-3) + quanta
}

/// The near plane of a shadow face of a light of radius `radius` whose nearest geometry
/// (instance bounds) is `nearest` away, for faces of widened half-angle tangent `tan_w`:
/// [`NEAR_FRACTION`] of the radius, but never past 90% of the nearest geometry's depth
/// along any face's axis (a point `d` away at a face's corner is only
/// `d / sqrt(1 + 2 tan_w^2)` deep; a near plane past it clips an occluder next to the
/// light), and not below 1 mm or 1e-4 of the radius. The precision of 16-bit depth falls as
/// `d^2 / near`.
pub fn shadow_near(radius: f32, nearest: f32, tan_w: f32) -> f32 {
    let hi = radius * NEAR_FRACTION;
    let lo = (radius * 1e-4).max(1e-3).min(hi);
    let corner = (1.0 + 2.0 * tan_w * tan_w).sqrt();
    (0.9 * nearest / corner).clamp(lo, hi)
}

/// True unless the box `(min, max)` lies wholly outside one of the side or near planes of
/// the face with world-to-clip matrix `m` (reversed-Z, infinite far: the planes are
/// `w +- x >= 0`, `w +- y >= 0` and `w - z >= 0`, from the matrix's rows). Conservative: a box
/// near a frustum's corner may be kept without touching it, never dropped while touching.
/// The shadow pass draws only the instances each face keeps.
pub fn box_in_face(m: &Mat4, (min, max): (Vec3, Vec3)) -> bool {
    let r = |i: usize| m.row(i);
    let planes = [r(3) + r(0), r(3) - r(0), r(3) + r(1), r(3) - r(1), r(3) - r(2)];
    planes.iter().all(|p| {
        // The box corner furthest along the plane's normal.
        let c = Vec3::new(
            if p.x >= 0.0 { max.x } else { min.x },
            if p.y >= 0.0 { max.y } else { min.y },
            if p.z >= 0.0 { max.z } else { min.z },
        );
        p.truncate().dot(c) + p.w >= 0.0
    })
}

/// Distance from `p` to the nearest of `bounds` (world AABBs as (min, max)) that does not
/// contain `p`; infinity when there is none. A box around the light says nothing about how
/// near its surfaces are (a building whose bounds hold every light), and counting it as 0
/// dropped every near plane to its floor, where 16-bit depth resolves a metre at 11 m
/// (`shadow-accuracy` found a crate's shadow missing on a wall 1.7 m behind it); such an
/// instance's surfaces nearer the light than [`NEAR_FRACTION`] of its radius are clipped.
pub fn nearest_bounds(p: Vec3, bounds: &[(Vec3, Vec3)]) -> f32 {
    bounds
        .iter()
        .filter(|(lo, hi)| !(p.cmpge(*lo).all() && p.cmple(*hi).all()))
        .map(|(lo, hi)| (p.clamp(*lo, *hi) - p).length())
        .fold(f32::INFINITY, f32::min)
}

/// World size of one texel per unit of view depth for a tile of `tile` texels and
/// widened half-angle tangent `tan_w`.
pub fn texel_per_depth(tan_w: f32, tile: u32) -> f32 {
    2.0 * tan_w / tile as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const FILTERS: [ShadowFilter; 3] = [ShadowFilter::Tap1, ShadowFilter::Pcf3, ShadowFilter::Pcf5];

    #[test]
    fn layout_packs_points_by_row_and_spots_six_to_a_row() {
        let l = AtlasLayout::new(256, 64, 64, 8192, 256).unwrap();
        assert_eq!(l.rows(), 64 + 11);
        assert_eq!(l.rows_per_layer, 32);
        assert_eq!(l.layers, 3);
        assert_eq!((l.width(), l.height()), (1536, 8192));
        assert_eq!(l.faces(), 6 * 64 + 64);
        assert_eq!(l.rect(l.point_face(33, 4)), FaceRect { layer: 1, x: 4 * 256, y: 256, size: 256 });
        assert_eq!(l.rect(l.spot_face(7)), FaceRect { layer: 2, x: 256, y: 256, size: 256 });
        // TiledLighting11's 12 + 12 fit one layer of 14 rows.
        let amd = AtlasLayout::new(256, 12, 12, 8192, 256).unwrap();
        assert_eq!((amd.layers, amd.height()), (1, 14 * 256));
    }

    #[test]
    fn layout_rejects_what_does_not_fit_naming_the_numbers() {
        let e = AtlasLayout::new(1024, 1000, 0, 8192, 4).unwrap_err().to_string();
        assert!(e.contains("1000 point") && e.contains("4 layers") && e.contains("32 rows"), "{e}");
        assert!(e.contains("limit max_texture_array_layers = 4 layers, asked for 125 layers"), "{e}");
        assert!(AtlasLayout::new(100, 1, 0, 8192, 4).unwrap_err().to_string().contains("128 to 1024"));
        let e = AtlasLayout::new(1024, 1, 0, 4096, 4).unwrap_err().to_string();
        assert!(e.contains("limit max_texture_dimension_2d = 4096, asked for 6144 texels"), "{e}");
        assert!(ShadowFilter::from_size(4).is_err());
    }

    #[test]
    fn every_face_has_its_own_tile() {
        let l = AtlasLayout::new(128, 7, 13, 1024, 8).unwrap();
        let mut seen = std::collections::HashSet::new();
        for f in 0..l.faces() {
            let r = l.rect(f);
            assert!(r.layer < l.layers && r.x + r.size <= l.width() && r.y + r.size <= l.height());
            assert!(seen.insert((r.layer, r.x, r.y)), "face {f} shares a tile");
        }
    }

    fn unit(v: (f32, f32, f32)) -> Option<Vec3> {
        let v = Vec3::new(v.0, v.1, v.2);
        (v.length() > 1e-3).then(|| v.normalize())
    }

    proptest! {
        #![proptest_config(crate::test_seed::proptest_config(256))]

        /// The face guarantee: for every direction from a point light, at any distance,
        /// every texel an N x N filter reads (each tap's hardware 2x2 footprint) lies
        /// inside the chosen face's tile.
        #[test]
        fn filter_taps_never_leave_the_face_tile(
            d in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
            dist in 1e-2f32..1e4,
            f in 0usize..3,
            tile in prop::sample::select(vec![128u32, 256, 1024]),
            caster in 0u32..4,
        ) {
            let Some(dir) = unit(d) else { return Ok(()) };
            let filter = FILTERS[f];
            let layout = AtlasLayout::new(tile, 4, 6, 8192, 8).unwrap();
            let light = Vec3::new(3.0, -2.0, 5.0);
            let face = cube_face(dir);
            let m = point_face_matrix(light, 0.1, face, tile, filter);
            let rect = layout.rect(layout.point_face(caster, face));
            let lk = project(&m, rect, light + dir * dist);
            let r = filter.radius() as f32;
            for (t, lo) in lk.texel.iter().zip([rect.x, rect.y]) {
                // A tap at t +- r reads texels floor(t +- r - 0.5) and the one after.
                let first = (t - r - 0.5).floor();
                let last = (t + r - 0.5).floor() + 1.0;
                prop_assert!(first >= lo as f32 && last <= (lo + rect.size) as f32 - 1.0,
                    "taps {first}..={last} leave the tile {lo}..{}", lo + rect.size);
            }
            prop_assert!(lk.depth > 0.0 && lk.depth.is_finite());
        }

        /// The same for a spot light: every point inside its cone.
        #[test]
        fn spot_taps_never_leave_the_tile(
            d in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
            angle in 0.01f32..MAX_SHADOW_SPOT_ANGLE,
            u in 0.0f32..1.0, phi in 0.0f32..std::f32::consts::TAU,
            dist in 1e-2f32..1e4,
            f in 0usize..3,
        ) {
            let Some(axis) = unit(d) else { return Ok(()) };
            let filter = FILTERS[f];
            let m = spot_matrix(Vec3::ZERO, axis, 0.1, (angle.sin(), angle.cos()), 256, filter).unwrap();
            // A direction inside the cone: rotate the axis by up to the outer angle.
            let side = axis.any_orthonormal_vector();
            let side = glam::Quat::from_axis_angle(axis, phi) * side;
            let dir = glam::Quat::from_axis_angle(side, angle * u) * axis;
            let rect = FaceRect { layer: 0, x: 256, y: 512, size: 256 };
            let lk = project(&m, rect, dir * dist);
            let r = filter.radius() as f32;
            for (t, lo) in lk.texel.iter().zip([rect.x, rect.y]) {
                let first = (t - r - 0.5).floor();
                let last = (t + r - 0.5).floor() + 1.0;
                prop_assert!(first >= lo as f32 - 1e-3 && last <= (lo + rect.size) as f32 - 1.0 + 1e-3,
                    "taps {first}..={last} leave the tile");
            }
        }
    }

    #[test]
    fn faces_meet_without_a_gap() {
        // A direction exactly on the +X/+Y edge lands inside the inner region of both
        // faces' projections: the seam is covered from both sides.
        let dir = Vec3::new(1.0, 1.0, 0.3).normalize();
        for face in [0, 2] {
            let m = point_face_matrix(Vec3::ZERO, 0.1, face, 256, ShadowFilter::Pcf5);
            let lk = project(&m, FaceRect { layer: 0, x: 0, y: 0, size: 256 }, dir * 5.0);
            for t in lk.texel {
                assert!((3.0..=253.0).contains(&t), "face {face}: {t}");
            }
        }
    }

    #[test]
    fn depth_is_reversed_and_infinite() {
        let m = point_face_matrix(Vec3::ZERO, 0.1, 0, 256, ShadowFilter::Tap1);
        let r = FaceRect { layer: 0, x: 0, y: 0, size: 256 };
        let near = project(&m, r, Vec3::new(0.1, 0.0, 0.0));
        let far = project(&m, r, Vec3::new(1000.0, 0.0, 0.0));
        assert!((near.depth - 1.0).abs() < 1e-5, "{}", near.depth);
        assert!(far.depth > 0.0 && far.depth < 1e-3);
        assert!((far.view_depth - 1000.0).abs() < 1e-2);
    }

    #[test]
    fn wide_spots_are_refused_with_their_angle() {
        let a = 85f32.to_radians();
        let e = spot_matrix(Vec3::ZERO, Vec3::Y, 0.01, (a.sin(), a.cos()), 256, ShadowFilter::Pcf5).unwrap_err();
        assert!(e.to_string().contains("85.0 degrees"), "{e}");
    }

    #[test]
    fn bias_follows_the_slope_seen_from_the_face() {
        let p = Vec3::ZERO;
        // Light straight above, on the face's axis: no normal offset, no slope.
        assert_eq!(biased_position(p, Vec3::Y, Vec3::Y, 0.1), p);
        let b = slope_bias(0.1, Vec3::Y, Vec3::Y, Vec3::NEG_Y, ShadowFilter::Pcf5);
        assert!((b - 0.05).abs() < 1e-6, "{b}");
        // Grazing: one texel of normal offset; the slope bias is capped.
        let l = Vec3::new(1.0, 0.01, 0.0).normalize();
        assert!((biased_position(p, Vec3::Y, l, 0.1).y - 0.1).abs() < 1e-3);
        let b = slope_bias(0.1, Vec3::Y, l, -l, ShadowFilter::Pcf5);
        assert!((b - (3.0 * MAX_SLOPE + 0.5) * 0.1).abs() < 1e-3, "{b}");
        // A spot looking 28 degrees off the normal at a point straight below it: the
        // plane tilts in the face even though the light is overhead.
        let axis = Vec3::new(0.47, -0.883, 0.0).normalize();
        let b = slope_bias(0.1, Vec3::Y, Vec3::Y, axis, ShadowFilter::Pcf3);
        assert!(b > 0.1 * (2.0 * 0.4 + 0.5), "{b}");
        // Depth: near / (w - bias).
        let d = biased_depth(0.01, 10.0, 1.0, 0.0);
        assert!((d - 0.01 * 10.0 / 9.0).abs() < 1e-7);
    }

    proptest! {
        #![proptest_config(crate::test_seed::proptest_config(256))]

        /// No false negative: a box containing any point the face sees (in front of the
        /// near plane, inside the widened frustum) is kept.
        #[test]
        fn boxes_touching_a_face_are_kept(
            d in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
            dist in 0.2f32..1e3,
            half in (1e-3f32..5.0, 1e-3f32..5.0, 1e-3f32..5.0),
            off in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
        ) {
            let Some(dir) = unit(d) else { return Ok(()) };
            let light = Vec3::new(1.0, 2.0, 3.0);
            let face = cube_face(dir);
            let m = point_face_matrix(light, 0.1, face, 256, ShadowFilter::Pcf5);
            let p = light + dir * dist;
            let half = Vec3::new(half.0, half.1, half.2);
            // A box around p, p anywhere inside it.
            let centre = p + half * Vec3::new(off.0, off.1, off.2);
            prop_assert!(box_in_face(&m, (centre - half, centre + half)));
        }
    }

    #[test]
    fn boxes_behind_or_beside_a_face_are_dropped() {
        let m = point_face_matrix(Vec3::ZERO, 0.1, 0, 256, ShadowFilter::Pcf5);
        // +X face: a box at -X, a box far off to +Y beyond 45 degrees, a box inside the near plane.
        assert!(!box_in_face(&m, (Vec3::new(-3.0, -1.0, -1.0), Vec3::new(-2.0, 1.0, 1.0))));
        assert!(!box_in_face(&m, (Vec3::new(1.0, 5.0, -1.0), Vec3::new(2.0, 6.0, 1.0))));
        assert!(!box_in_face(&m, (Vec3::new(0.01, -0.01, -0.01), Vec3::new(0.05, 0.01, 0.01))));
        assert!(box_in_face(&m, (Vec3::new(2.0, -1.0, -1.0), Vec3::new(3.0, 1.0, 1.0))));
    }

    #[test]
    fn near_plane_stays_short_of_the_nearest_geometry() {
        let boxes = [(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0))];
        let d = nearest_bounds(Vec3::new(0.0, 3.0, 0.0), &boxes);
        assert!((d - 1.0).abs() < 1e-6);
        // A face's corner sees the box at depth d / sqrt(3).
        assert!((shadow_near(100.0, d, 1.0) - 0.9 / 3f32.sqrt()).abs() < 1e-6, "clipped by the box");
        assert!((shadow_near(10.0, d, 1.0) - 0.1).abs() < 1e-6, "1% of the radius");
        assert!((shadow_near(100.0, 0.0, 1.0) - 0.01).abs() < 1e-6, "touching a box: 1e-4 of the radius");
        assert_eq!(nearest_bounds(Vec3::ZERO, &[]), f32::INFINITY);
        // A box around the light is not counted: the near plane stays at 1% of the radius.
        let around = [(Vec3::splat(-50.0), Vec3::splat(50.0)), boxes[0]];
        assert!((nearest_bounds(Vec3::new(0.0, 3.0, 0.0), &around) - 1.0).abs() < 1e-6);
        assert_eq!(nearest_bounds(Vec3::ZERO, &around[..1]), f32::INFINITY);
    }
}
