//! Point and spot lights: construction with validation, the radius from an intensity
//! threshold, bounding spheres for culling, and the packed GPU layouts (culling data
//! kept apart from shading data). Depends on glam and bytemuck only.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::error::CullError;

/// The narrowest spot cone accepted, in radians (0.5 degree). Narrower cones make the
/// smooth angular falloff divide by almost zero and the fitted sphere degenerate;
/// Filament clamps for the same reason.
pub const MIN_SPOT_ANGLE: f32 = 0.5 * std::f32::consts::PI / 180.0;
/// The widest spot cone accepted (half-angle), just under 90 degrees.
pub const MAX_SPOT_ANGLE: f32 = 89.5 * std::f32::consts::PI / 180.0;

/// What kind of light, with the data only that kind needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Emits in every direction.
    Point,
    /// Emits in a cone around `direction` (unit), full intensity inside `inner_angle`,
    /// smoothly falling to zero at `outer_angle` (half-angles, radians).
    Spot {
        /// Unit axis of the cone.
        direction: Vec3,
        /// Half-angle of full intensity.
        inner_angle: f32,
        /// Half-angle where the light reaches zero.
        outer_angle: f32,
    },
}

/// A punctual light with a finite radius of influence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// World-space position (metres).
    pub position: Vec3,
    /// Linear colour, components in [0, 1] with the largest being 1 for generated lights.
    pub color: Vec3,
    /// Intensity: the light delivers `color * intensity / d^2` at distance `d`.
    pub intensity: f32,
    /// Radius of influence: nothing is lit beyond it (windowed falloff).
    pub radius: f32,
    /// Point or spot.
    pub kind: LightKind,
}

/// The radius at which `intensity / d^2` falls to `threshold`: `sqrt(intensity / threshold)`.
/// This turns the threshold into the one dial that trades image error for lights per tile.
pub fn radius_from_threshold(intensity: f32, threshold: f32) -> f32 {
    (intensity / threshold).sqrt()
}

fn finite3(v: Vec3) -> bool {
    v.is_finite()
}

impl Light {
    /// A point light whose radius comes from `threshold` (see [`radius_from_threshold`]),
    /// applied to the brightest colour channel.
    pub fn point(position: Vec3, color: Vec3, intensity: f32, threshold: f32) -> Result<Self, CullError> {
        let radius = Self::checked_radius(color, intensity, threshold)?;
        Self::with_radius(position, color, intensity, radius, LightKind::Point)
    }

    /// A spot light whose radius comes from `threshold`. Angles are half-angles in radians;
    /// `outer_angle` is clamped to [[`MIN_SPOT_ANGLE`], [`MAX_SPOT_ANGLE`]] and `inner_angle`
    /// to [0, outer].
    #[allow(clippy::too_many_arguments)]
    pub fn spot(
        position: Vec3,
        direction: Vec3,
        color: Vec3,
        intensity: f32,
        inner_angle: f32,
        outer_angle: f32,
        threshold: f32,
    ) -> Result<Self, CullError> {
        let radius = Self::checked_radius(color, intensity, threshold)?;
        let kind = Self::spot_kind(direction, inner_angle, outer_angle)?;
        Self::with_radius(position, color, intensity, radius, kind)
    }

    /// Builds the [`LightKind::Spot`] after checking and clamping its parameters.
    pub fn spot_kind(direction: Vec3, inner_angle: f32, outer_angle: f32) -> Result<LightKind, CullError> {
        if !finite3(direction) || direction.length_squared() < 1e-12 {
            return Err(CullError::InvalidLight(format!("spot direction {direction} is not a finite non-zero vector")));
        }
        if !inner_angle.is_finite() || !outer_angle.is_finite() {
            return Err(CullError::InvalidLight(format!(
                "spot angles must be finite (inner {inner_angle}, outer {outer_angle})"
            )));
        }
        let outer_angle = outer_angle.clamp(MIN_SPOT_ANGLE, MAX_SPOT_ANGLE);
        let inner_angle = inner_angle.clamp(0.0, outer_angle);
        Ok(LightKind::Spot { direction: direction.normalize(), inner_angle, outer_angle })
    }

    /// A light with an explicit radius (glTF `range`, tests). Rejects NaN/inf and non-positive values.
    pub fn with_radius(
        position: Vec3,
        color: Vec3,
        intensity: f32,
        radius: f32,
        kind: LightKind,
    ) -> Result<Self, CullError> {
        let light = Self { position, color, intensity, radius, kind };
        light.problem().map_or(Ok(light), |p| Err(CullError::InvalidLight(p)))
    }

    /// Checks every field, since they are public and a light can be built without the
    /// constructors: finite position; finite, non-negative colour and intensity whose
    /// product (the radiance uploaded) is finite; finite positive radius; for spots a
    /// finite unit direction and angles with `0 <= inner <= outer` and `outer` in
    /// [[`MIN_SPOT_ANGLE`], [`MAX_SPOT_ANGLE`]] (the range the constructors clamp to). The
    /// error names the field and its value. [`validate_lights`] adds the light's index.
    pub fn validate(&self) -> Result<(), CullError> {
        self.problem().map_or(Ok(()), |p| Err(CullError::InvalidLight(p)))
    }

    /// What is wrong with this light, if anything (see [`Light::validate`]).
    fn problem(&self) -> Option<String> {
        let Self { position, color, intensity, radius, kind } = *self;
        if !finite3(position) {
            return Some(format!("position {position} is not finite"));
        }
        if !finite3(color) || color.min_element() < 0.0 {
            return Some(format!("colour {color} must be finite and non-negative"));
        }
        if !intensity.is_finite() || intensity < 0.0 {
            return Some(format!("intensity {intensity} must be finite and non-negative"));
        }
        if !finite3(color * intensity) {
            return Some(format!("radiance (colour {color} x intensity {intensity}) overflows f32"));
        }
        if !radius.is_finite() || radius <= 0.0 {
            return Some(format!("radius {radius} must be finite and positive"));
        }
        if let LightKind::Spot { direction, inner_angle, outer_angle } = kind {
            if !finite3(direction) || direction.length_squared() < 1e-12 {
                return Some(format!("spot direction {direction} is not a finite non-zero vector"));
            }
            // The shaders and the cone test use the direction as uploaded: it must be unit.
            // `normalize` leaves it within a few ulps of 1; 1e-4 also accepts values
            // normalised in f64 or read from files with 6 decimals.
            if (direction.length() - 1.0).abs() > 1e-4 {
                return Some(format!(
                    "spot direction {direction} has length {}, not 1 (normalise it, or use Light::spot_kind)",
                    direction.length()
                ));
            }
            if !inner_angle.is_finite() || !outer_angle.is_finite() {
                return Some(format!("spot angles must be finite (inner {inner_angle}, outer {outer_angle})"));
            }
            if !(MIN_SPOT_ANGLE..=MAX_SPOT_ANGLE).contains(&outer_angle) {
                return Some(format!(
                    "spot outer angle {outer_angle} rad ({} deg) is outside [{MIN_SPOT_ANGLE}, {MAX_SPOT_ANGLE}] rad (0.5 to 89.5 deg)",
                    outer_angle.to_degrees()
                ));
            }
            if !(0.0..=outer_angle).contains(&inner_angle) {
                return Some(format!(
                    "spot inner angle {inner_angle} rad must be in [0, outer angle {outer_angle}] rad"
                ));
            }
        }
        None
    }

    fn checked_radius(color: Vec3, intensity: f32, threshold: f32) -> Result<f32, CullError> {
        if !threshold.is_finite() || threshold <= 0.0 {
            return Err(CullError::InvalidLight(format!(
                "intensity threshold {threshold} must be finite and positive"
            )));
        }
        let peak = intensity * color.max_element();
        let r = radius_from_threshold(peak, threshold);
        if !r.is_finite() || r <= 0.0 {
            return Err(CullError::InvalidLight(format!(
                "intensity {intensity} and colour {color} give radius {r} at threshold {threshold}"
            )));
        }
        Ok(r)
    }

    /// True for spot lights.
    pub fn is_spot(&self) -> bool {
        matches!(self.kind, LightKind::Spot { .. })
    }

    /// The sphere that bounds everything this light can reach (centre, radius).
    ///
    /// For a spot light this is the smallest sphere around the cone of length `radius`
    /// (AMD's fitted sphere): for half-angles up to 45 degrees the sphere through the
    /// apex and the cap rim, centred on the axis; wider cones use the cap's centre and
    /// rim radius. Always at least as tight as the full light sphere.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        match self.kind {
            LightKind::Point => (self.position, self.radius),
            LightKind::Spot { direction, outer_angle, .. } => {
                spot_bounding_sphere(self.position, direction, self.radius, outer_angle)
            }
        }
    }
}

/// Smallest sphere around a cone with apex `apex`, unit axis `dir`, length `len` and
/// half-angle `angle`.
pub fn spot_bounding_sphere(apex: Vec3, dir: Vec3, len: f32, angle: f32) -> (Vec3, f32) {
    let (s, c) = angle.sin_cos();
    if angle > std::f32::consts::FRAC_PI_4 {
        // The cap's rim circle is the widest part: centre it there.
        (apex + dir * (len * c), len * s)
    } else {
        // Sphere through the apex and the rim: r = len / (2 cos a), centre r along the axis.
        let r = len / (2.0 * c);
        (apex + dir * r, r)
    }
}

/// Culling data of one light: its bounding sphere. 16 bytes, in its own buffer so the
/// culling kernel reads only what it tests (references 000 and 002 measured the gain).
///
/// Keep in sync with `shaders/common/lights.wgsl` (`CullLight`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCullLight {
    /// Bounding-sphere centre, world space.
    pub center: [f32; 3],
    /// Bounding-sphere radius.
    pub radius: f32,
}

/// Shading data of one light. 32 bytes.
///
/// Keep in sync with `shaders/common/lights.wgsl` (`ShadingLight`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShadingLight {
    /// Light position, world space.
    pub position: [f32; 3],
    /// Radius of influence (the window of the falloff).
    pub radius: f32,
    /// `color * intensity`.
    pub radiance: [f32; 3],
    /// Padding to 16-byte alignment.
    pub _pad: f32,
}

/// Spot-only shading data, in a buffer that exists only when the scene has spot lights.
/// 32 bytes. Spot light `i` of the light list (spots follow points) uses entry
/// `i - num_point_lights`.
///
/// Keep in sync with `shaders/common/lights.wgsl` (`SpotLight`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSpotLight {
    /// Unit cone axis, world space.
    pub direction: [f32; 3],
    /// Cosine of the outer half-angle.
    pub cos_outer: f32,
    /// `1 / (cos_inner - cos_outer)` (guarded): the angular falloff's scale.
    pub angle_scale: f32,
    /// `-cos_outer * angle_scale`: the angular falloff's offset.
    pub angle_offset: f32,
    /// Sine of the outer half-angle (for the cone culling test).
    pub sin_outer: f32,
    /// Padding to 16-byte alignment.
    pub _pad: f32,
}

/// Angular falloff scale and offset for a spot (as in Filament): `saturate(cos * scale + offset)`
/// is 0 at the outer angle and 1 at the inner angle.
///
/// The ramp's width in cosine is kept at least `f32::EPSILON` (2 ulps of a cosine near 1)
/// so that inner == outer gives a finite scale (a hard edge) instead of a division by zero.
/// It was 1e-4, which is wider than the whole ramp of cones under ~0.8 degrees: a 0.5
/// degree spot then reached only 15% of its intensity on its own axis.
pub fn spot_scale_offset(inner_angle: f32, outer_angle: f32) -> (f32, f32) {
    let cos_outer = outer_angle.cos();
    let cos_inner = inner_angle.cos();
    let scale = 1.0 / (cos_inner - cos_outer).max(f32::EPSILON);
    (scale, -cos_outer * scale)
}

/// Lights split and packed for the GPU: points first, then spots.
#[derive(Clone, Debug, Default)]
pub struct PackedLights {
    /// Culling data, one per light.
    pub cull: Vec<GpuCullLight>,
    /// Shading data, one per light.
    pub shading: Vec<GpuShadingLight>,
    /// Spot data, one per spot light (empty when there are none).
    pub spots: Vec<GpuSpotLight>,
    /// Number of point lights (they come first).
    pub num_point: u32,
    /// Shadow-casting point lights: the first `shadow_points` lights.
    pub shadow_points: u32,
    /// Shadow-casting spot lights: the first `shadow_spots` spots (lights `num_point..`).
    pub shadow_spots: u32,
}

impl PackedLights {
    /// Total number of lights.
    pub fn len(&self) -> usize {
        self.cull.len()
    }
    /// True when there are no lights.
    pub fn is_empty(&self) -> bool {
        self.cull.is_empty()
    }
}

/// Orders `lights` points first (stable), as every kernel indexes them; returns the
/// ordered lights. The CPU reference and the GPU must use the same order.
pub fn order_points_first(lights: &[Light]) -> Vec<Light> {
    let mut v: Vec<Light> = lights.iter().copied().filter(|l| !l.is_spot()).collect();
    v.extend(lights.iter().copied().filter(|l| l.is_spot()));
    v
}

/// Checks every light with [`Light::validate`]; the error names the first bad light's
/// index in `lights` and what is wrong with it.
pub fn validate_lights(lights: &[Light]) -> Result<(), CullError> {
    for (i, l) in lights.iter().enumerate() {
        if let Some(p) = l.problem() {
            return Err(CullError::InvalidLight(format!("light {i}: {p}")));
        }
    }
    Ok(())
}

/// Validates `lights` ([`validate_lights`]: errors name the index in `lights`, before
/// reordering), orders them points first and packs them: the path every upload takes.
pub fn try_pack_lights(lights: &[Light]) -> Result<PackedLights, CullError> {
    validate_lights(lights)?;
    Ok(pack_lights(&order_points_first(lights)))
}

/// Validates `lights`, orders them points first with the shadow casters first within each
/// kind, and packs them: `casters` = (point, spot) casters, the brightest of each kind
/// (intensity times the largest colour channel; ties keep the input order). Spots wider
/// than [`crate::shadow::MAX_SHADOW_SPOT_ANGLE`] are never chosen. Asking for more casters
/// than there are (eligible) lights of a kind is an error naming both numbers.
pub fn try_pack_lights_with_casters(lights: &[Light], casters: (u32, u32)) -> Result<PackedLights, CullError> {
    try_pack_lights_ranked(lights, casters, CasterRank::Brightest)
}

/// How the shadow casters of each kind are chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CasterRank<'a> {
    /// The brightest: intensity times the largest colour channel.
    Brightest,
    /// The highest scores, one per light in the order of the `lights` given (e.g. each
    /// light's contribution to the frame, [`crate::contribution`]).
    Scores(&'a [u64]),
}

/// [`try_pack_lights_with_casters`] with the casters of each kind chosen by `rank` (ties
/// keep the input order; spots too wide to cast are never chosen). A score list of
/// another length than `lights` is an error naming both.
pub fn try_pack_lights_ranked(
    lights: &[Light],
    casters: (u32, u32),
    rank: CasterRank<'_>,
) -> Result<PackedLights, CullError> {
    let out = order_with_casters(lights, casters, rank)?;
    let mut packed = pack_lights(&out);
    packed.shadow_points = casters.0;
    packed.shadow_spots = casters.1;
    Ok(packed)
}

/// The shadow casters [`try_pack_lights_with_casters`] chooses among `lights`, in the
/// order they are packed: the `casters.0` point casters, then the `casters.1` spot
/// casters (the first lights of each kind on the GPU). Same validation and errors.
pub fn shadow_casters(lights: &[Light], casters: (u32, u32)) -> Result<Vec<Light>, CullError> {
    let ordered = order_with_casters(lights, casters, CasterRank::Brightest)?;
    let num_point = ordered.iter().filter(|l| !l.is_spot()).count();
    let points = &ordered[..casters.0 as usize];
    let spots = &ordered[num_point..num_point + casters.1 as usize];
    Ok(points.iter().chain(spots).copied().collect())
}

/// `lights` validated and ordered as [`try_pack_lights_ranked`] packs them: points
/// first, the casters first within each kind (in input order), then the others.
fn order_with_casters(lights: &[Light], casters: (u32, u32), rank: CasterRank<'_>) -> Result<Vec<Light>, CullError> {
    validate_lights(lights)?;
    // Each light with its score (brightness, or the given score), then ordered points
    // first as the lights are (a stable partition, so the scores follow their lights).
    let scored: Vec<(Light, f64)> = match rank {
        CasterRank::Brightest => lights.iter().map(|l| (*l, (l.intensity * l.color.max_element()) as f64)).collect(),
        CasterRank::Scores(s) if s.len() == lights.len() => {
            lights.iter().zip(s).map(|(l, &v)| (*l, v as f64)).collect()
        }
        CasterRank::Scores(s) => {
            return Err(CullError::InvalidShadow(format!("{} caster scores for {} lights", s.len(), lights.len())))
        }
    };
    let mut ordered: Vec<(Light, f64)> = scored.iter().copied().filter(|(l, _)| !l.is_spot()).collect();
    ordered.extend(scored.iter().copied().filter(|(l, _)| l.is_spot()));
    let num_point = ordered.iter().filter(|(l, _)| !l.is_spot()).count();
    let (points, spots) = ordered.split_at(num_point);
    let wide = |l: &Light| match l.kind {
        LightKind::Spot { outer_angle, .. } => outer_angle > crate::shadow::MAX_SHADOW_SPOT_ANGLE,
        LightKind::Point => false,
    };
    let mut out = Vec::with_capacity(ordered.len());
    for (kind, group, n) in [("point", points, casters.0), ("spot", spots, casters.1)] {
        let eligible = group.iter().filter(|(l, _)| !wide(l)).count();
        if n as usize > eligible {
            let narrow = if kind == "spot" && eligible < group.len() {
                format!(
                    " ({eligible} of its {} spots are at most {:.0} degrees wide)",
                    group.len(),
                    crate::shadow::MAX_SHADOW_SPOT_ANGLE.to_degrees()
                )
            } else {
                String::new()
            };
            return Err(CullError::InvalidShadow(format!(
                "{n} shadow-casting {kind} lights requested; the scene has {}{narrow}",
                group.len()
            )));
        }
        let mut idx: Vec<usize> = (0..group.len()).filter(|&i| !wide(&group[i].0)).collect();
        // Highest score first; the sort is stable, so ties keep the input order.
        idx.sort_by(|&a, &b| group[b].1.total_cmp(&group[a].1));
        idx.truncate(n as usize);
        idx.sort_unstable();
        let mut chosen = vec![false; group.len()];
        for &i in &idx {
            chosen[i] = true;
            out.push(group[i].0);
        }
        out.extend(group.iter().zip(&chosen).filter(|(_, &c)| !c).map(|(l, _)| l.0));
    }
    Ok(out)
}

/// Packs lights that are already ordered points-first (see [`order_points_first`]).
/// Does not validate: a NaN field packs into NaN data that every culling test rejects, so
/// the light silently vanishes. Uploads go through [`try_pack_lights`] instead.
pub fn pack_lights(ordered: &[Light]) -> PackedLights {
    let mut out = PackedLights::default();
    for l in ordered {
        let (c, mut r) = l.bounding_sphere();
        if l.is_spot() {
            // The fitted sphere passes exactly through the apex and the cap rim, where the
            // light is brightest: grow it by a few ulps of the coordinates so float error in
            // the tests can never cut those points off.
            r += 8.0 * f32::EPSILON * (c.abs().max_element() + r);
        }
        out.cull.push(GpuCullLight { center: c.to_array(), radius: r });
        out.shading.push(GpuShadingLight {
            position: l.position.to_array(),
            radius: l.radius,
            radiance: (l.color * l.intensity).to_array(),
            _pad: 0.0,
        });
        match l.kind {
            LightKind::Point => {
                debug_assert!(out.spots.is_empty(), "lights must be ordered points first");
                out.num_point += 1;
            }
            LightKind::Spot { direction, inner_angle, outer_angle } => {
                let (angle_scale, angle_offset) = spot_scale_offset(inner_angle, outer_angle);
                out.spots.push(GpuSpotLight {
                    direction: direction.to_array(),
                    cos_outer: outer_angle.cos(),
                    angle_scale,
                    angle_offset,
                    sin_outer: outer_angle.sin(),
                    _pad: 0.0,
                });
            }
        }
    }
    out
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<crate::layout::StructLayout> {
    vec![
        crate::struct_layout!(GpuCullLight, "CullLight", "common/lights.wgsl", [center, radius]),
        crate::struct_layout!(GpuShadingLight, "ShadingLight", "common/lights.wgsl", [position, radius, radiance]),
        crate::struct_layout!(
            GpuSpotLight,
            "SpotLight",
            "common/lights.wgsl",
            [direction, cos_outer, angle_scale, angle_offset, sin_outer]
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radius_threshold_roundtrip() {
        let l = Light::point(Vec3::ZERO, Vec3::ONE, 4.0, 0.01).unwrap();
        assert!((l.radius - 20.0).abs() < 1e-5);
        assert!((l.intensity / (l.radius * l.radius) - 0.01).abs() < 1e-7);
    }

    #[test]
    fn rejects_bad_lights() {
        assert!(Light::point(Vec3::NAN, Vec3::ONE, 1.0, 0.01).is_err());
        assert!(Light::point(Vec3::ZERO, Vec3::ONE, f32::INFINITY, 0.01).is_err());
        assert!(Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 0.0).is_err());
        assert!(Light::point(Vec3::ZERO, Vec3::ZERO, 1.0, 0.01).is_err(), "black light has no radius");
        assert!(Light::spot(Vec3::ZERO, Vec3::ZERO, Vec3::ONE, 1.0, 0.1, 0.2, 0.01).is_err());
    }

    /// A valid spot built without the constructors, for `validation_names_index_and_problem`.
    fn raw_spot() -> Light {
        Light {
            position: Vec3::new(1.0, 2.0, 3.0),
            color: Vec3::new(1.0, 0.5, 0.25),
            intensity: 2.0,
            radius: 5.0,
            kind: LightKind::Spot { direction: Vec3::NEG_Y, inner_angle: 0.2, outer_angle: 0.4 },
        }
    }

    /// Every invalid field of a light built by hand (the fields are public) is rejected by
    /// `validate_lights` with the light's index and a message naming the field. Catches a
    /// validation that misses a field (NaN would pack into NaN spheres the culler drops
    /// silently, or NaN radiance that turns pixels NaN) or reports the wrong index.
    #[test]
    fn validation_names_index_and_problem() {
        let spot = |direction: Vec3, inner_angle: f32, outer_angle: f32| LightKind::Spot {
            direction,
            inner_angle,
            outer_angle,
        };
        let deg = |d: f32| d.to_radians();
        let ok = raw_spot();
        let cases: Vec<(Light, &str)> = vec![
            (Light { position: Vec3::new(f32::NAN, 0.0, 0.0), ..ok }, "position"),
            (Light { position: Vec3::new(0.0, f32::INFINITY, 0.0), ..ok }, "position"),
            (Light { position: Vec3::new(0.0, 0.0, f32::NEG_INFINITY), ..ok }, "position"),
            (Light { color: Vec3::new(f32::NAN, 1.0, 1.0), ..ok }, "colour"),
            (Light { color: Vec3::new(1.0, f32::INFINITY, 1.0), ..ok }, "colour"),
            (Light { color: Vec3::new(1.0, 1.0, -0.1), ..ok }, "colour"),
            (Light { intensity: f32::NAN, ..ok }, "intensity"),
            (Light { intensity: f32::INFINITY, ..ok }, "intensity"),
            (Light { intensity: -1.0, ..ok }, "intensity"),
            // Both finite, but their product (the uploaded radiance) is not.
            (Light { intensity: 1e38, color: Vec3::new(10.0, 1.0, 1.0), ..ok }, "radiance"),
            (Light { radius: f32::NAN, ..ok }, "radius"),
            (Light { radius: f32::INFINITY, ..ok }, "radius"),
            (Light { radius: 0.0, ..ok }, "radius"),
            (Light { radius: -1.0, ..ok }, "radius"),
            (Light { kind: spot(Vec3::ZERO, 0.2, 0.4), ..ok }, "spot direction"),
            (Light { kind: spot(Vec3::new(f32::NAN, 1.0, 0.0), 0.2, 0.4), ..ok }, "spot direction"),
            (Light { kind: spot(Vec3::new(0.0, f32::INFINITY, 0.0), 0.2, 0.4), ..ok }, "spot direction"),
            (Light { kind: spot(Vec3::new(0.0, 2.0, 0.0), 0.2, 0.4), ..ok }, "has length 2"),
            (Light { kind: spot(Vec3::Y, f32::NAN, 0.4), ..ok }, "spot angles must be finite"),
            (Light { kind: spot(Vec3::Y, 0.2, f32::NAN), ..ok }, "spot angles must be finite"),
            (Light { kind: spot(Vec3::Y, 0.2, f32::INFINITY), ..ok }, "spot angles must be finite"),
            (Light { kind: spot(Vec3::Y, 0.5, 0.4), ..ok }, "inner angle 0.5"),
            (Light { kind: spot(Vec3::Y, -0.1, 0.4), ..ok }, "inner angle -0.1"),
            (Light { kind: spot(Vec3::Y, 0.0, 0.0), ..ok }, "outer angle 0 rad"),
            (Light { kind: spot(Vec3::Y, 0.0, -0.3), ..ok }, "outer angle -0.3"),
            (Light { kind: spot(Vec3::Y, 0.0, deg(0.4)), ..ok }, "outer angle"),
            (Light { kind: spot(Vec3::Y, 0.1, deg(90.0)), ..ok }, "outer angle 1.5707964 rad"),
            (Light { kind: spot(Vec3::Y, 0.1, deg(89.6)), ..ok }, "outer angle"),
            (Light { kind: spot(Vec3::Y, 0.1, deg(120.0)), ..ok }, "outer angle"),
        ];
        for (k, (bad, what)) in cases.iter().enumerate() {
            // The bad light third of four, so a validator reporting the wrong index fails.
            let list = [ok, Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 0.01).unwrap(), *bad, ok];
            let e = validate_lights(&list).expect_err(&format!("case {k} ({what}) accepted: {bad:?}")).to_string();
            assert!(e.starts_with("invalid light: light 2: "), "case {k}: {e}");
            assert!(e.contains(what), "case {k}: {e:?} should name {what:?}");
            assert_eq!(bad.validate().map_err(|e| e.to_string()), Err(e.replace("light 2: ", "")), "case {k}");
            // Uploads go through `try_pack_lights`: it must reject the same list.
            assert!(try_pack_lights(&list).is_err(), "case {k}");
            // The explicit-radius constructor agrees with `validate` (spot kinds given
            // directly, not through the clamping `spot_kind`).
            let built = Light::with_radius(bad.position, bad.color, bad.intensity, bad.radius, bad.kind);
            assert_eq!(built.map_err(|e| e.to_string()), Err(e.replace("light 2: ", "")), "case {k}");
        }
    }

    /// The accepted extremes stay accepted: the clamped angle limits exactly, inner == outer,
    /// inner 0, black and zero-intensity lights with an explicit radius, a direction
    /// normalised in f64. Catches a validation stricter than the constructors' clamps
    /// (which would reject lights the loader and generators produce).
    #[test]
    fn validation_accepts_the_limits_constructors_produce() {
        let ok = raw_spot();
        let spot = |inner_angle: f32, outer_angle: f32| LightKind::Spot {
            direction: Vec3::new(0.3, -0.9, 0.1).normalize(),
            inner_angle,
            outer_angle,
        };
        for l in [
            ok,
            Light { kind: spot(0.0, MIN_SPOT_ANGLE), ..ok },
            Light { kind: spot(MIN_SPOT_ANGLE, MIN_SPOT_ANGLE), ..ok },
            Light { kind: spot(MAX_SPOT_ANGLE, MAX_SPOT_ANGLE), ..ok },
            Light { kind: LightKind::Point, color: Vec3::ZERO, intensity: 0.0, ..ok },
            Light { kind: LightKind::Point, radius: f32::MIN_POSITIVE, ..ok },
            Light { kind: LightKind::Point, radius: f32::MAX, position: Vec3::splat(-f32::MAX), ..ok },
        ] {
            l.validate().unwrap_or_else(|e| panic!("{l:?}: {e}"));
        }
        // The clamping constructor maps out-of-range angles onto accepted ones.
        for (inner, outer) in [(0.0, 0.0), (1.0, 0.5), (2.0, 3.0), (-1.0, 1e-9)] {
            let kind = Light::spot_kind(Vec3::new(0.0, 5.0, 0.0), inner, outer).unwrap();
            Light { kind, ..ok }.validate().unwrap_or_else(|e| panic!("inner {inner} outer {outer}: {e}"));
        }
        assert!(validate_lights(&[]).is_ok());
    }

    #[test]
    fn spot_sphere_contains_cone() {
        for deg in [0.5f32, 5.0, 30.0, 44.9, 45.1, 60.0, 89.5] {
            let a = deg.to_radians();
            let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
            let (c, r) = spot_bounding_sphere(Vec3::ONE, dir, 10.0, a);
            assert!(r <= 10.0 + 1e-4, "never looser than the light sphere");
            // apex, and points on the cap rim and cap centre must be inside.
            let perp = dir.any_orthonormal_vector();
            let rim = Vec3::ONE + dir * 10.0 * a.cos() + perp * 10.0 * a.sin();
            for p in [Vec3::ONE, rim, Vec3::ONE + dir * 10.0] {
                assert!((p - c).length() <= r * (1.0 + 1e-5) + 1e-5, "deg {deg}: {p} outside");
            }
        }
    }

    #[test]
    fn shadow_casters_are_the_packed_casters() {
        let p = |i: f32| Light::point(Vec3::splat(i), Vec3::ONE, i, 0.01).unwrap();
        let s = |i: f32| Light::spot(Vec3::splat(i), Vec3::NEG_Y, Vec3::ONE, i, 0.1, 0.3, 0.01).unwrap();
        let lights = [s(1.0), p(1.0), p(3.0), s(5.0), p(2.0), s(4.0), p(0.5)];
        let casters = shadow_casters(&lights, (2, 1)).unwrap();
        // The two brightest points in input order, then the brightest spot.
        let intensities: Vec<f32> = casters.iter().map(|l| l.intensity).collect();
        assert_eq!(intensities, [3.0, 2.0, 5.0]);
        assert!(!casters[1].is_spot() && casters[2].is_spot());
        let packed = try_pack_lights_with_casters(&lights, (2, 1)).unwrap();
        let np = packed.num_point as usize;
        let packed_casters = [0, 1, np].map(|i| packed.shading[i].position);
        let positions: Vec<[f32; 3]> = casters.iter().map(|l| l.position.to_array()).collect();
        assert_eq!(packed_casters.to_vec(), positions);
        assert!(shadow_casters(&lights, (5, 0)).is_err(), "more casters than point lights");
        assert!(shadow_casters(&lights, (0, 0)).unwrap().is_empty());
    }

    #[test]
    fn casters_by_score_follow_the_scores_not_the_brightness() {
        let p = |i: f32| Light::point(Vec3::splat(i), Vec3::ONE, i, 0.01).unwrap();
        let s = |i: f32| Light::spot(Vec3::splat(i), Vec3::NEG_Y, Vec3::ONE, i, 0.1, 0.3, 0.01).unwrap();
        let lights = [s(1.0), p(1.0), p(3.0), s(5.0), p(2.0), s(4.0), p(0.5)];
        // The dimmest point and the dimmest spot score highest.
        let scores = [9, 1, 2, 1, 3, 0, 7];
        let packed = try_pack_lights_ranked(&lights, (2, 1), CasterRank::Scores(&scores)).unwrap();
        let np = packed.num_point as usize;
        let x = |i: usize| packed.shading[i].position[0];
        // Points 0.5 (score 7) and 2 (score 3), in input order; then spot 1 (score 9).
        assert_eq!([x(0), x(1), x(np)], [2.0, 0.5, 1.0]);
        // Ties keep the input order: equal scores pick the first lights of each kind.
        let tied = try_pack_lights_ranked(&lights, (1, 1), CasterRank::Scores(&[0; 7])).unwrap();
        assert_eq!([tied.shading[0].position[0], tied.shading[np].position[0]], [1.0, 1.0]);
        // Brightest-first is the same as the unranked packing.
        let b = try_pack_lights_ranked(&lights, (2, 1), CasterRank::Brightest).unwrap();
        assert_eq!(b.shading, try_pack_lights_with_casters(&lights, (2, 1)).unwrap().shading);
        let e = try_pack_lights_ranked(&lights, (1, 0), CasterRank::Scores(&[1, 2])).unwrap_err();
        assert!(e.to_string().contains("2 caster scores for 7 lights"), "{e}");
    }

    #[test]
    fn pack_orders_and_splits() {
        let p = Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 0.01).unwrap();
        let s = Light::spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 1.0, 0.1, 0.3, 0.01).unwrap();
        let ordered = order_points_first(&[s, p, s]);
        let packed = pack_lights(&ordered);
        assert_eq!(packed.num_point, 1);
        assert_eq!(packed.spots.len(), 2);
        assert_eq!(packed.cull.len(), 3);
    }
}
