//! Virtual point lights (VPLs), the CPU twin of `shaders/vpl_generate.wgsl`: one-bounce
//! indirect light from reflective shadow maps (RSMs; Dachsbacher and Stamminger 2005), as
//! TiledLighting11 makes it, plus the every-texel reference the lab measures it against.
//!
//! It lives here, not in tiledlight-vpl, because this crate is the CPU reference of every
//! GPU kernel and has no GPU dependency: an engine (or a test) can generate and shade VPLs
//! from its own RSM arrays with nothing but glam.
//!
//! The steps:
//! 1. **RSM.** Each shadow face of a caster (a spot's one face, a point's six) is drawn
//!    again from the light into an RSM tile of `rsm_size` texels (32 by default, as the
//!    sample): depth (the texel's world position), the surface normal facing the light,
//!    the diffuse albedo (`base x (1 - metallic)`). [`RsmFace`] holds one tile. A face is
//!    drawn through the face proper (a cube face's 90 degrees, a spot's outer cone), not
//!    the shadow atlas's field of view widened for its filter: a point light's six faces
//!    then tile the sphere of directions once, and its VPLs carry `albedo x intensity x 4
//!    pi` (the GPU test `a_point_lights_vpls_carry_its_flux_once_in_a_closed_box`; through
//!    the widened faces the seams counted 2.65% more at shadow tile 256, 5.36% at 128).
//! 2. **Texel flux.** A texel at `p` reflects the flux `albedo x radiance x window(d) x
//!    spot x omega` ([`texel_light`]): the light's radiant intensity through the texel's
//!    solid angle `omega = texel^2 cos^3(theta)` (theta from the face's axis), times the
//!    diffuse albedo. The receiver's cosine cancels against the surfel's area, so the flux
//!    does not depend on the surfel's normal. Its *tint* (the same without the light's
//!    intensity and the solid angle: `albedo x colour x window x spot`, in [0, 1]) is what
//!    the thresholds look at, so they do not depend on RSM size, block size or intensity.
//!    This first bounce stays Lambertian although the renderers' diffuse term is
//!    Ashikhmin-Shirley's ([`crate::brdf::diffuse`]): a VPL is a diffuse point emitter, and
//!    the Ashikhmin-Shirley weighting belongs to the receiving surface, which the shared
//!    BRDF applies when it shades the VPL's light (that weighting at the texel would scale
//!    its flux by `(1 - F0) (1 - (1 - n.l/2)^5)`, the term's directional albedo: 0.93 for
//!    light arriving head-on, falling to 0 at grazing incidence).
//! 3. **Generation** ([`generate`]). One VPL per `block x block` texels (AMD: 2x2): flux
//!    summed (energy kept whatever the block), position and tint the solid-angle-weighted
//!    means, normal the normalised weighted sum. Kept when a channel of its normalised tint
//!    reaches the colour threshold and the tint's length exceeds the brightness threshold
//!    (AMD's two sliders), appended up to the cap; the rest are counted as refused.
//! 4. **Shading** ([`vpl_intensity`], times the shared BRDF with `n . l`):
//!    - *sample* (TiledLighting11): `smoothstep(1, 0, d/r) x max(0, n_vpl . -l)`, no inverse
//!      square (biased by design, little noise). The sample's colour scale is arbitrary;
//!      here the flux is divided by `pi r^2` so its units are the physical model's.
//!    - *physical* (Dachsbacher and Stamminger 2005): a Lambertian emitter of flux `F`,
//!      radiant intensity `F/pi x max(0, n_vpl . -l)`, over `max(d^2, clamp^2)`. The clamp
//!      removes the `1/d^2` singularity next to a VPL (and with it some energy: a bias).
//! 5. **Reference** ([`reference_irradiance`]): the physical model summed over every RSM
//!    texel, with no blocks, thresholds, cap or radius cutoff.
//!
//! Depends on glam, bytemuck and [`crate::error`].

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};

use crate::error::CullError;

/// RSM texels per side of each face by default (the sample's 32x32).
pub const DEFAULT_RSM_SIZE: u32 = 32;
/// RSM sizes accepted.
pub const RSM_SIZES: std::ops::RangeInclusive<u32> = 4..=512;
/// Texels per side of a VPL's block by default (the sample's 2x2).
pub const DEFAULT_BLOCK: u32 = 2;
/// Most VPLs by default (the sample's 65,535).
pub const DEFAULT_CAP: u32 = 65_535;
/// Most VPLs accepted as a cap: 16 Mi VPLs of 48 + 16 bytes are 1 GiB.
pub const MAX_CAP: u32 = 1 << 24;
/// VPL indices the VPLs' light grid holds per tile (its whole budget is this times the
/// tiles, or the cap times the tiles when the cap is lower): the VPLs of one 32 x 32 RSM
/// face at block 1. The grid does not grow: lists past the budget lose VPLs, counted in
/// its header and reported as dropped.
pub const VPL_GRID_PER_TILE: u32 = 1024;
/// Distance clamp of the physical model by default, metres: `1/d^2` is at most 100 next to
/// a VPL.
pub const DEFAULT_DISTANCE_CLAMP: f32 = 0.1;
/// A VPL's radius (its culling bound and the sample model's falloff) as a fraction of its
/// caster's radius, by default.
pub const DEFAULT_RADIUS_FRACTION: f32 = 0.5;

/// How a VPL lights a surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum VplShading {
    /// TiledLighting11's: smoothstep to the radius, no inverse square.
    #[default]
    Sample,
    /// Dachsbacher and Stamminger's: flux x cos x cos / max(d^2, clamp^2).
    Physical,
}

impl VplShading {
    /// The flag value.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sample => "sample",
            Self::Physical => "physical",
        }
    }
    /// The model of flag value `name` (`sample`, `physical`).
    pub fn from_name(name: &str) -> Result<Self, CullError> {
        match name {
            "sample" => Ok(Self::Sample),
            "physical" => Ok(Self::Physical),
            _ => Err(CullError::InvalidVpl(format!("VPL shading {name:?}: use sample or physical"))),
        }
    }
    /// The value of the `VPL_PHYSICAL` shading switch on the GPU.
    pub fn index(self) -> u32 {
        match self {
            Self::Sample => 0,
            Self::Physical => 1,
        }
    }
}

/// The VPL settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplConfig {
    /// RSM texels per side of each face.
    pub rsm_size: u32,
    /// Texels per side of one VPL's block; divides `rsm_size`.
    pub block: u32,
    /// A channel of the normalised tint must reach this (0: any colour; 1: only pure
    /// red, green or blue).
    pub colour_threshold: f32,
    /// The tint's length must exceed this (0: any light at all).
    pub brightness_threshold: f32,
    /// Most VPLs kept; the rest are refused and counted.
    pub cap: u32,
    /// The shading model.
    pub shading: VplShading,
    /// The physical model's distance clamp, metres.
    pub distance_clamp: f32,
    /// A VPL's radius as a fraction of its caster's radius.
    pub radius_fraction: f32,
}

impl Default for VplConfig {
    fn default() -> Self {
        Self {
            rsm_size: DEFAULT_RSM_SIZE,
            block: DEFAULT_BLOCK,
            colour_threshold: 0.0,
            brightness_threshold: 0.0,
            cap: DEFAULT_CAP,
            shading: VplShading::Sample,
            distance_clamp: DEFAULT_DISTANCE_CLAMP,
            radius_fraction: DEFAULT_RADIUS_FRACTION,
        }
    }
}

impl VplConfig {
    /// Checks every field, naming the one out of range.
    pub fn validate(&self) -> Result<(), CullError> {
        let bad = |m: String| Err(CullError::InvalidVpl(m));
        if !RSM_SIZES.contains(&self.rsm_size) {
            return bad(format!("RSM size {}: use {}..={}", self.rsm_size, RSM_SIZES.start(), RSM_SIZES.end()));
        }
        if self.block == 0 || self.block > self.rsm_size || !self.rsm_size.is_multiple_of(self.block) {
            return bad(format!("VPL block {}: must divide the RSM size {}", self.block, self.rsm_size));
        }
        if self.block > 16 {
            return bad(format!("VPL block {}: at most 16 (one GPU thread sums a block)", self.block));
        }
        if !(0.0..=1.0).contains(&self.colour_threshold) {
            return bad(format!("VPL colour threshold {}: use 0..=1", self.colour_threshold));
        }
        if !(self.brightness_threshold >= 0.0 && self.brightness_threshold.is_finite()) {
            return bad(format!("VPL brightness threshold {}: use a finite value >= 0", self.brightness_threshold));
        }
        if self.cap == 0 || self.cap > MAX_CAP {
            return bad(format!("VPL cap {}: use 1..={MAX_CAP}", self.cap));
        }
        if !(self.distance_clamp > 0.0 && self.distance_clamp.is_finite()) {
            return bad(format!("VPL distance clamp {}: use a finite value > 0", self.distance_clamp));
        }
        if !(self.radius_fraction > 0.0 && self.radius_fraction.is_finite()) {
            return bad(format!("VPL radius fraction {}: use a finite value > 0", self.radius_fraction));
        }
        Ok(())
    }

    /// VPL blocks per face side.
    pub fn blocks_per_side(&self) -> u32 {
        self.rsm_size / self.block
    }
}

/// The light an RSM face was drawn from, as the generation reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsmLight {
    /// Light position, world space.
    pub position: Vec3,
    /// Radius of the light's windowed falloff.
    pub radius: f32,
    /// `colour x intensity`.
    pub radiance: Vec3,
    /// The face's view axis (unit, world space).
    pub axis: Vec3,
    /// Squared world size of one RSM texel per unit of view depth: `(2 tan_w / size)^2`.
    pub texel_sq: f32,
    /// The radius of the VPLs made from this face.
    pub vpl_radius: f32,
    /// Spot lights: unit direction, angular falloff scale and offset.
    pub spot: Option<(Vec3, f32, f32)>,
}

/// One RSM texel where a surface was drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsmTexel {
    /// World position.
    pub position: Vec3,
    /// Unit normal, facing the light.
    pub normal: Vec3,
    /// Diffuse albedo, linear (`base x (1 - metallic)`).
    pub albedo: Vec3,
}

/// One face of an RSM: `size x size` texels, row-major (row 0 at the top), None where
/// nothing was drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct RsmFace {
    /// Texels per side.
    pub size: u32,
    /// The light it was drawn from.
    pub light: RsmLight,
    /// The texels.
    pub texels: Vec<Option<RsmTexel>>,
}

/// What one texel reflects: its flux (watts, rgb), its tint (for the thresholds) and its
/// solid angle from the light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelLight {
    /// Reflected flux.
    pub flux: Vec3,
    /// `albedo x colour x window x spot`, colour being the radiance over its largest channel.
    pub tint: Vec3,
    /// Solid angle of the texel seen from the light.
    pub solid_angle: f32,
}

/// What the texel at `p` with diffuse `albedo` reflects of `light` (step 2 of the module
/// doc). The GPU's `texel_light` in `shaders/vpl_generate.wgsl` computes the same in f32.
pub fn texel_light(light: &RsmLight, p: Vec3, albedo: Vec3) -> TexelLight {
    let to = p - light.position;
    let d2 = to.length_squared();
    let dir = to.normalize_or_zero();
    let cos_axis = light.axis.dot(dir).max(0.0);
    let solid_angle = light.texel_sq * cos_axis * cos_axis * cos_axis;
    let x = d2 / (light.radius * light.radius);
    let w = (1.0 - x * x).clamp(0.0, 1.0);
    let window = w * w;
    let spot = light.spot.map_or(1.0, |(axis, scale, offset)| crate::brdf::spot_falloff(axis.dot(dir), scale, offset));
    let peak = light.radiance.max_element().max(f32::MIN_POSITIVE);
    let tint = albedo * (light.radiance / peak) * (window * spot);
    TexelLight { flux: albedo * light.radiance * (window * spot * solid_angle), tint, solid_angle }
}

/// The world position of RSM texel (`tx`, `ty`) of a `size`-texel face with `depth`
/// (reversed-Z, > 0) and the face's clip-to-world matrix.
pub fn texel_position(clip_to_world: &Mat4, size: u32, (tx, ty): (u32, u32), depth: f32) -> Vec3 {
    let ndc_x = (tx as f32 + 0.5) / size as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - (ty as f32 + 0.5) / size as f32 * 2.0;
    let h = *clip_to_world * Vec4::new(ndc_x, ndc_y, depth, 1.0);
    h.truncate() / h.w
}

/// One virtual point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vpl {
    /// World position.
    pub position: Vec3,
    /// Unit normal of the surface it stands for.
    pub normal: Vec3,
    /// Reflected flux, watts rgb.
    pub flux: Vec3,
    /// Mean tint of its texels (what the thresholds read).
    pub tint: Vec3,
    /// Culling radius and the sample model's falloff radius.
    pub radius: f32,
}

/// The VPL of block (`bx`, `by`) of `face`, before the thresholds: None when no texel of
/// the block was drawn, none reflects anything, or their normals cancel.
pub fn block_vpl(face: &RsmFace, (bx, by): (u32, u32), block: u32) -> Option<Vpl> {
    let (mut flux, mut tint, mut pos, mut normal, mut omega) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0);
    for y in by * block..(by + 1) * block {
        for x in bx * block..(bx + 1) * block {
            let Some(t) = face.texels[(y * face.size + x) as usize] else { continue };
            let l = texel_light(&face.light, t.position, t.albedo);
            flux += l.flux;
            tint += l.tint * l.solid_angle;
            pos += t.position * l.solid_angle;
            normal += t.normal * l.solid_angle;
            omega += l.solid_angle;
        }
    }
    // The GPU's test, in the same words: a block whose weights or normals vanish makes no VPL.
    if omega <= 0.0 || normal.length_squared() <= 1e-12 * omega * omega {
        return None;
    }
    Some(Vpl {
        position: pos / omega,
        normal: normal.normalize(),
        flux,
        tint: tint / omega,
        radius: face.light.vpl_radius,
    })
}

/// True when a VPL of mean `tint` passes both thresholds: a channel of the normalised tint
/// reaches `colour`, and the tint's length exceeds `brightness`.
pub fn passes_thresholds(tint: Vec3, colour: f32, brightness: f32) -> bool {
    let len = tint.length();
    let normalised = tint / len.max(f32::MIN_POSITIVE);
    normalised.max_element() >= colour && len > brightness
}

/// The VPLs of some RSM faces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Generated {
    /// Kept VPLs: the first `cap` candidates in face, row, column order (the GPU keeps
    /// `cap` of them in an order of its own).
    pub vpls: Vec<Vpl>,
    /// Blocks that passed the thresholds.
    pub candidates: u32,
    /// Candidates the cap refused: `candidates - vpls.len()`.
    pub refused: u32,
}

/// One VPL per block of every face that passes the thresholds, up to the cap (step 3 of
/// the module doc). Errors on a bad config or a face whose size is not `cfg.rsm_size`.
pub fn generate(faces: &[RsmFace], cfg: &VplConfig) -> Result<Generated, CullError> {
    cfg.validate()?;
    let mut out = Generated::default();
    for (i, face) in faces.iter().enumerate() {
        if face.size != cfg.rsm_size || face.texels.len() != (face.size * face.size) as usize {
            return Err(CullError::InvalidVpl(format!(
                "RSM face {i} has {} texels of size {}; the config's RSM size is {}",
                face.texels.len(),
                face.size,
                cfg.rsm_size
            )));
        }
        let n = cfg.blocks_per_side();
        for by in 0..n {
            for bx in 0..n {
                let Some(v) = block_vpl(face, (bx, by), cfg.block) else { continue };
                if !passes_thresholds(v.tint, cfg.colour_threshold, cfg.brightness_threshold) {
                    continue;
                }
                out.candidates += 1;
                if out.vpls.len() < cfg.cap as usize {
                    out.vpls.push(v);
                } else {
                    out.refused += 1;
                }
            }
        }
    }
    Ok(out)
}

/// The light a VPL sends to a surface point `x`: the unit direction towards the VPL and
/// the radiance-like factor that multiplies the shared BRDF times `n . l`
/// (`crate::brdf::brdf_cos`), per `model`. Zero (never NaN) at the VPL itself, behind it,
/// and (sample model) at and beyond its radius. `vpl_light` in `shaders/common/vpl.wgsl`
/// computes the same in f32.
pub fn vpl_intensity(vpl: &Vpl, x: Vec3, model: VplShading, distance_clamp: f32) -> (Vec3, Vec3) {
    let to = vpl.position - x;
    let d2 = to.length_squared();
    let l = to.normalize_or_zero();
    let emit = vpl.normal.dot(-l).max(0.0);
    let factor = match model {
        VplShading::Sample => {
            let r = vpl.radius.max(f32::MIN_POSITIVE);
            let t = (1.0 - d2.sqrt() / r).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t) * emit / (std::f32::consts::PI * r * r)
        }
        VplShading::Physical => emit / (std::f32::consts::PI * d2.max(distance_clamp * distance_clamp)),
    };
    (l, vpl.flux * factor)
}

/// Irradiance-like light (before the BRDF: `sum of factor x max(0, n . l)`) at `x` with
/// normal `n` from `vpls`.
pub fn vpl_irradiance(vpls: &[Vpl], x: Vec3, n: Vec3, model: VplShading, distance_clamp: f32) -> Vec3 {
    vpls.iter()
        .map(|v| {
            let (l, f) = vpl_intensity(v, x, model, distance_clamp);
            f * n.dot(l).max(0.0)
        })
        .sum()
}

/// The reference (step 5): the physical model's irradiance at `x` with normal `n` summed
/// over every drawn texel of every face, no blocks, thresholds, cap or cutoff.
pub fn reference_irradiance(faces: &[RsmFace], x: Vec3, n: Vec3, distance_clamp: f32) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for face in faces {
        for t in face.texels.iter().flatten() {
            let l = texel_light(&face.light, t.position, t.albedo);
            let v = Vpl { position: t.position, normal: t.normal, flux: l.flux, tint: l.tint, radius: f32::INFINITY };
            sum += vpl_irradiance(&[v], x, n, VplShading::Physical, distance_clamp);
        }
    }
    sum
}

/// One VPL as the GPU stores it (shading data; its culling sphere is a `GpuCullLight` of
/// its own buffer). 48 bytes.
///
/// Keep in sync with `shaders/common/vpl.wgsl` (`Vpl`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVpl {
    /// World position.
    pub position: [f32; 3],
    /// Culling and falloff radius.
    pub radius: f32,
    /// Unit normal.
    pub normal: [f32; 3],
    /// Padding.
    pub _pad0: f32,
    /// Reflected flux.
    pub flux: [f32; 3],
    /// Padding.
    pub _pad1: f32,
}

impl GpuVpl {
    /// The VPL it holds (its tint is not stored: zero).
    pub fn to_vpl(&self) -> Vpl {
        Vpl {
            position: self.position.into(),
            normal: self.normal.into(),
            flux: self.flux.into(),
            tint: Vec3::ZERO,
            radius: self.radius,
        }
    }
}

/// One RSM face as the generation pass reads it. 144 bytes.
///
/// Keep in sync with `shaders/vpl_generate.wgsl` (`RsmFace`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRsmFace {
    /// Clip (reversed-Z) to world: the inverse of the face's world-to-clip.
    pub clip_to_world: [[f32; 4]; 4],
    /// Light position.
    pub light_position: [f32; 3],
    /// Light radius.
    pub light_radius: f32,
    /// `colour x intensity`.
    pub radiance: [f32; 3],
    /// [`RsmLight::texel_sq`].
    pub texel_sq: f32,
    /// The face's view axis.
    pub axis: [f32; 3],
    /// The radius of its VPLs.
    pub vpl_radius: f32,
    /// Spot direction (zero for a point light's face).
    pub spot_direction: [f32; 3],
    /// Spot falloff scale.
    pub spot_scale: f32,
    /// Spot falloff offset.
    pub spot_offset: f32,
    /// 1 for a spot light's face.
    pub is_spot: u32,
    /// Top-left texel of the face's tile in the RSM atlas.
    pub origin: [u32; 2],
}

impl GpuRsmFace {
    /// The face of `light` seen through `world_to_clip`, at texel `origin` of the RSM atlas.
    pub fn new(light: &RsmLight, world_to_clip: &Mat4, origin: [u32; 2]) -> Self {
        let (spot_direction, spot_scale, spot_offset) =
            light.spot.map_or(([0.0; 3], 0.0, 0.0), |(d, s, o)| (d.into(), s, o));
        Self {
            clip_to_world: world_to_clip.inverse().to_cols_array_2d(),
            light_position: light.position.into(),
            light_radius: light.radius,
            radiance: light.radiance.into(),
            texel_sq: light.texel_sq,
            axis: light.axis.into(),
            vpl_radius: light.vpl_radius,
            spot_direction,
            spot_scale,
            spot_offset,
            is_spot: light.spot.is_some() as u32,
            origin,
        }
    }
}

/// The generation pass's parameters. 32 bytes.
///
/// Keep in sync with `shaders/vpl_generate.wgsl` (`VplParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVplParams {
    /// RSM texels per face side.
    pub rsm_size: u32,
    /// Texels per block side.
    pub block: u32,
    /// Most VPLs kept.
    pub cap: u32,
    /// Faces.
    pub faces: u32,
    /// Colour threshold.
    pub colour_threshold: f32,
    /// Brightness threshold.
    pub brightness_threshold: f32,
    /// Padding.
    pub _pad: [u32; 2],
}

impl GpuVplParams {
    /// The parameters of `cfg` over `faces` faces.
    pub fn new(cfg: &VplConfig, faces: u32) -> Self {
        Self {
            rsm_size: cfg.rsm_size,
            block: cfg.block,
            cap: cfg.cap,
            faces,
            colour_threshold: cfg.colour_threshold,
            brightness_threshold: cfg.brightness_threshold,
            _pad: [0; 2],
        }
    }
}

/// How the shading passes read the VPLs. 16 bytes.
///
/// Keep in sync with `shaders/common/vpl.wgsl` (`VplShading`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVplShading {
    /// Most VPLs: the passes read `min(count, cap)`.
    pub cap: u32,
    /// [`VplShading::index`]: 0 sample, 1 physical.
    pub model: u32,
    /// The physical model's distance clamp.
    pub distance_clamp: f32,
    /// Padding.
    pub _pad: u32,
}

impl GpuVplShading {
    /// The uniform of `cfg`.
    pub fn new(cfg: &VplConfig) -> Self {
        Self { cap: cfg.cap, model: cfg.shading.index(), distance_clamp: cfg.distance_clamp, _pad: 0 }
    }
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<crate::layout::StructLayout> {
    vec![
        crate::struct_layout!(GpuVpl, "Vpl", "common/vpl.wgsl", [position, radius, normal, flux]),
        crate::struct_layout!(GpuVplShading, "VplShading", "common/vpl.wgsl", [cap, model, distance_clamp]),
        crate::struct_layout!(
            GpuRsmFace,
            "RsmFace",
            "vpl_generate.wgsl",
            [
                clip_to_world,
                light_position,
                light_radius,
                radiance,
                texel_sq,
                axis,
                vpl_radius,
                spot_direction,
                spot_scale,
                spot_offset,
                is_spot,
                origin
            ]
        ),
        crate::struct_layout!(
            GpuVplParams,
            "VplParams",
            "vpl_generate.wgsl",
            [rsm_size, block, cap, faces, colour_threshold, brightness_threshold]
        ),
    ]
}

#[cfg(test)]
mod tests;
