//! Shared generators for the integration tests of tiledlight-cull: cameras described by
//! plain parameters (so a failing case prints them), random depth buffers and random
//! lights placed where they actually light something. Every generator is driven by a
//! seeded PCG so a case is reproducible from what the failure message prints.

#![allow(dead_code)] // Each test binary uses a different part of this module.

use glam::{DVec3, EulerRot, Mat4, Quat, Vec3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::{Camera, Light, LightKind};

mod seed;
#[allow(unused_imports)] // Each test binary uses a different part of this module.
pub use seed::{proptest_config, DEFAULT_SEED};

/// f32 machine epsilon (2^-23), the unit of every tolerance below.
pub const EPS: f32 = f32::EPSILON;

/// A deterministic generator.
pub fn rng(seed: u64) -> Pcg64 {
    Pcg64::seed_from_u64(seed)
}

/// Log-uniform in [lo, hi): every decade equally likely.
pub fn log_uniform(rng: &mut impl Rng, lo: f32, hi: f32) -> f32 {
    let (a, b) = (lo.ln(), hi.ln());
    (a + (b - a) * rng.random::<f32>()).exp().clamp(lo, hi)
}

/// A uniformly distributed unit vector.
pub fn unit(rng: &mut impl Rng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let l = v.length();
        if l > 0.05 && l <= 1.0 {
            return v / l;
        }
    }
}

/// Projection kind of a [`CamSpec`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CamKind {
    /// Perspective with a finite far plane.
    Finite,
    /// Perspective with an infinite far plane.
    Infinite,
    /// Orthographic.
    Ortho,
}

/// A camera as plain numbers: printed by a failing proptest case.
#[derive(Clone, Copy, Debug)]
pub struct CamSpec {
    /// Projection kind.
    pub kind: CamKind,
    /// Near plane distance (orthographic: may be 0).
    pub near: f32,
    /// Far plane distance (ignored for `Infinite`).
    pub far: f32,
    /// Vertical field of view, degrees (perspective).
    pub fov_deg: f32,
    /// Orthographic half-height.
    pub half_height: f32,
    /// Width / height.
    pub aspect: f32,
    /// Eye position.
    pub eye: Vec3,
    /// Yaw, pitch, roll (radians) of the view direction and up vector.
    pub euler: Vec3,
}

impl CamSpec {
    /// Unit view direction and up vector (orthogonal by construction).
    pub fn basis(&self) -> (Vec3, Vec3) {
        let q = Quat::from_euler(EulerRot::YXZ, self.euler.x, self.euler.y, self.euler.z);
        (q * Vec3::NEG_Z, q * Vec3::Y)
    }

    /// Builds the camera; the specs generated here are always valid.
    pub fn camera(&self) -> Camera {
        let (fwd, up) = self.basis();
        let target = self.eye + fwd;
        match self.kind {
            CamKind::Finite => Camera::perspective(
                self.eye,
                target,
                up,
                self.fov_deg.to_radians(),
                self.aspect,
                self.near,
                Some(self.far),
            ),
            CamKind::Infinite => {
                Camera::perspective(self.eye, target, up, self.fov_deg.to_radians(), self.aspect, self.near, None)
            }
            CamKind::Ortho => {
                Camera::orthographic(self.eye, target, up, self.half_height, self.aspect, self.near, self.far)
            }
        }
        .unwrap_or_else(|e| panic!("generated camera {self:?} rejected: {e}"))
    }

    /// A random spec over the ranges the brief asks for: near 1e-4..10, far 1e2..1e7,
    /// FOV 1..170 degrees, aspect 0.1..10, any position (within 1e3) and orientation.
    pub fn random(rng: &mut impl Rng) -> Self {
        let kind = [CamKind::Finite, CamKind::Infinite, CamKind::Ortho][rng.random_range(0..3)];
        let near = if kind == CamKind::Ortho && rng.random_bool(0.3) { 0.0 } else { log_uniform(rng, 1e-4, 10.0) };
        Self {
            kind,
            near,
            far: log_uniform(rng, 1e2, 1e7),
            fov_deg: rng.random_range(1.0..170.0),
            half_height: log_uniform(rng, 0.1, 1e3),
            aspect: log_uniform(rng, 0.1, 10.0),
            eye: unit(rng) * log_uniform(rng, 1e-3, 1e3),
            euler: Vec3::new(
                rng.random_range(0.0..std::f32::consts::TAU),
                rng.random_range(-1.5..1.5),
                rng.random_range(0.0..std::f32::consts::TAU),
            ),
        }
    }
}

/// View-space point to world space.
pub fn view_to_world(camera: &Camera, p: Vec3) -> Vec3 {
    camera.view().inverse().transform_point3(p)
}

/// How a random depth buffer is filled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthMode {
    /// One depth everywhere.
    Constant,
    /// Depth affine in NDC: a plane in view space (reversed-Z is affine in 1/z, and 1/z
    /// of a plane is affine in screen space); non-positive values become sky.
    Plane,
    /// Independent per-pixel view distances, log-uniform between near and far.
    PerPixel,
    /// Depths within 1e-6 of 1, including exactly 1 (surfaces on the near plane).
    NearOne,
    /// Depths near 0 (far away), down to the smallest subnormal, where an infinite far
    /// plane makes the view distance overflow.
    NearZero,
}

/// All modes, for picking one at random.
pub const DEPTH_MODES: [DepthMode; 5] =
    [DepthMode::Constant, DepthMode::Plane, DepthMode::PerPixel, DepthMode::NearOne, DepthMode::NearZero];

/// One depth value of a mode at pixel-space position (x, y) (a pixel's centre, or one of
/// its MSAA sample positions); `base` carries the mode's per-buffer constants.
fn depth_value(
    rng: &mut impl Rng,
    mode: DepthMode,
    camera: &Camera,
    base: [f32; 3],
    (x, y): (f32, f32),
    (w, h): (u32, u32),
) -> f32 {
    let dp = camera.depth_params();
    let v = match mode {
        DepthMode::Constant => base[0],
        DepthMode::Plane => {
            let nx = 2.0 * x / w as f32 - 1.0;
            let ny = 1.0 - 2.0 * y / h as f32;
            base[0] + base[1] * nx + base[2] * ny
        }
        DepthMode::PerPixel => {
            if rng.random_bool(0.5) {
                rng.random::<f32>()
            } else {
                let far = if dp.far.is_finite() { dp.far } else { 1e7 };
                dp.depth(log_uniform(rng, dp.near.max(1e-4), far))
            }
        }
        DepthMode::NearOne => {
            if rng.random_bool(0.2) {
                1.0
            } else {
                1.0 - rng.random::<f32>() * 1e-6
            }
        }
        DepthMode::NearZero => match rng.random_range(0..4) {
            0 => f32::from_bits(1),
            1 => f32::MIN_POSITIVE * rng.random::<f32>(),
            _ => log_uniform(rng, 1e-38, 1e-3),
        },
    };
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

fn mode_base(rng: &mut impl Rng, mode: DepthMode) -> [f32; 3] {
    match mode {
        DepthMode::Constant => [rng.random_range(0.0..1.0), 0.0, 0.0],
        DepthMode::Plane => [rng.random_range(-0.2..1.2), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)],
        _ => [0.0; 3],
    }
}

/// A random depth buffer for a `w` x `h` screen. `geometry_tiles`: when `Some((tile, k))`,
/// only `k` random tiles (of side `tile`) have geometry and the rest is sky (large screens);
/// otherwise the whole screen is filled and random rectangles are cut out as sky.
pub fn random_depth(
    rng: &mut impl Rng,
    mode: DepthMode,
    camera: &Camera,
    w: u32,
    h: u32,
    geometry_tiles: Option<(u32, u32)>,
) -> Vec<f32> {
    let mut depth = vec![0.0f32; (w * h) as usize];
    let base = mode_base(rng, mode);
    match geometry_tiles {
        Some((tile, k)) => {
            let (tx, ty) = (w.div_ceil(tile), h.div_ceil(tile));
            for i in 0..k {
                // The last one is a partial corner tile whenever the screen has one.
                let (cx, cy) =
                    if i + 1 == k { (tx - 1, ty - 1) } else { (rng.random_range(0..tx), rng.random_range(0..ty)) };
                for y in cy * tile..((cy + 1) * tile).min(h) {
                    for x in cx * tile..((cx + 1) * tile).min(w) {
                        depth[(y * w + x) as usize] = depth_value(rng, mode, camera, base, centre(x, y), (w, h));
                    }
                }
            }
        }
        None => {
            for y in 0..h {
                for x in 0..w {
                    depth[(y * w + x) as usize] = depth_value(rng, mode, camera, base, centre(x, y), (w, h));
                }
            }
            for _ in 0..rng.random_range(0..3) {
                let (x0, y0) = (rng.random_range(0..w), rng.random_range(0..h));
                let (x1, y1) = (rng.random_range(x0..=w), rng.random_range(y0..=h));
                for y in y0..y1 {
                    depth[(y * w) as usize + x0 as usize..(y * w) as usize + x1 as usize].fill(0.0);
                }
            }
        }
    }
    depth
}

/// Pixel-space position of pixel (x, y)'s centre.
fn centre(x: u32, y: u32) -> (f32, f32) {
    (x as f32 + 0.5, y as f32 + 0.5)
}

/// The standard MSAA sample positions (Vulkan, D3D and Metal agree), in pixels from the
/// pixel's top-left corner: the CPU copy of `sample_position` in `shaders/common/deferred_shade.wgsl`,
/// where Tiled Deferred shades each sample. 1 sample: the pixel centre.
pub fn sample_positions(samples: u32) -> &'static [(f32, f32)] {
    tiledlight_cull::blended_depth::standard_sample_positions(samples)
        .unwrap_or_else(|| panic!("{samples} samples: the GPU accepts 1, 2, 4 or 8"))
}

/// A random multisampled depth buffer: `samples` values per pixel, pixel-major (the layout
/// `CullConfig::samples` reads). With 1 sample exactly [`random_depth`] (same values from
/// the same generator state, so recorded cases replay). With more, each sample gets its
/// mode's value at its own standard position (planes tilt across the pixel, per-pixel
/// noise differs per sample), and edge pixels are made by turning single samples into sky
/// with probability `sky_sample` (silhouettes: some samples on geometry, some not).
#[allow(clippy::too_many_arguments)]
pub fn random_depth_samples(
    rng: &mut impl Rng,
    mode: DepthMode,
    camera: &Camera,
    w: u32,
    h: u32,
    samples: u32,
    geometry_tiles: Option<(u32, u32)>,
    sky_sample: f64,
) -> Vec<f32> {
    if samples == 1 {
        return random_depth(rng, mode, camera, w, h, geometry_tiles);
    }
    // Which pixels have geometry: the single-sample layout decides (sky rectangles, or a
    // few geometry tiles on large screens), then every sample gets its own value.
    let layout = random_depth(rng, mode, camera, w, h, geometry_tiles);
    let base = mode_base(rng, mode);
    let positions = sample_positions(samples);
    let mut depth = vec![0.0f32; layout.len() * samples as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if layout[i] <= 0.0 {
                continue;
            }
            for (s, &(sx, sy)) in positions.iter().enumerate() {
                let pos = (x as f32 + sx, y as f32 + sy);
                let v = depth_value(rng, mode, camera, base, pos, (w, h));
                depth[i * samples as usize + s] = if rng.random_bool(sky_sample) { 0.0 } else { v };
            }
        }
    }
    depth
}

/// A random blended depth buffer over the multisampled `opaque` one (same layout): what
/// drawing alpha-blended geometry depth-only into its own buffer (cleared to 0, depth-tested
/// against `opaque`, not writing it) leaves. Per buffer, either a tilted pane (depth affine
/// in NDC, drawn only where it is in front of the opaque surface, as the depth test does) or
/// per-sample surfaces; per sample, blended values from exactly the opaque depth (a decal)
/// through any distance in front of it down to the near plane (depth 1), including
/// subnormal depths over sky (a pane ~1e38 m away, or at infinity for an infinite far plane).
/// Some pixels are left empty (0), and in covered pixels single samples too (pane edges
/// under MSAA). `only_over_geometry`: blended only on pixels with some opaque sample (large
/// screens, to keep the number of covered tiles small).
#[allow(clippy::too_many_arguments)]
pub fn random_blended_depth(
    rng: &mut impl Rng,
    camera: &Camera,
    opaque: &[f32],
    w: u32,
    h: u32,
    samples: u32,
    only_over_geometry: bool,
) -> Vec<f32> {
    let dp = camera.depth_params();
    let n = samples as usize;
    let positions = sample_positions(samples);
    let pane = rng.random_bool(0.3).then(|| mode_base(rng, DepthMode::Plane));
    let cover = rng.random_range(0.2..1.0);
    let far = if dp.far.is_finite() { dp.far } else { 1e7 };
    let mut blended = vec![0.0f32; opaque.len()];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let px = &opaque[i * n..(i + 1) * n];
            if (only_over_geometry && px.iter().all(|&d| d <= 0.0)) || !rng.random_bool(cover) {
                continue;
            }
            for (s, &(sx, sy)) in positions.iter().enumerate() {
                let o = px[s];
                if n > 1 && rng.random_bool(0.1) {
                    continue;
                }
                let b = if let Some(base) = pane {
                    let v = depth_value(rng, DepthMode::Plane, camera, base, (x as f32 + sx, y as f32 + sy), (w, h));
                    // The depth test (greater-or-equal) drops the pane behind the opaque surface.
                    if v >= o {
                        v
                    } else {
                        0.0
                    }
                } else {
                    match rng.random_range(0..10) {
                        0 => o,
                        1 => 1.0,
                        2 => o.max(f32::from_bits(rng.random_range(1..1 << 23))),
                        _ => {
                            let behind = if o > 0.0 { dp.view_distance(o).min(far) } else { far };
                            let lo = dp.near.max(1e-4);
                            let d = if behind > lo { dp.depth(log_uniform(rng, lo, behind)) } else { 1.0 };
                            if d.is_nan() {
                                0.0
                            } else {
                                d.clamp(o, 1.0)
                            }
                        }
                    }
                };
                blended[i * n + s] = b;
            }
        }
    }
    blended
}

/// A white point light of radius `r` at `pos`.
pub fn point_light(pos: Vec3, r: f32) -> Light {
    Light::with_radius(pos, Vec3::ONE, 1.0, r, LightKind::Point).unwrap()
}

/// Camera at the origin looking down -Z (identity view), 90 degree FOV, infinite far.
pub fn axis_camera(aspect: f32) -> Camera {
    Camera::perspective(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90f32.to_radians(), aspect, 0.1, None).unwrap()
}

/// A random light colour whose brightest channel is 1.
pub fn colour(rng: &mut impl Rng) -> Vec3 {
    let mut c = [1.0, rng.random::<f32>(), rng.random::<f32>()];
    let i = rng.random_range(0..3);
    c.swap(0, i);
    Vec3::from(c)
}

/// A light of radius ~`radius` at `pos` built through one of the four public
/// constructors (chosen at random): `Light::point`, `Light::spot` (radius from an
/// intensity threshold), or `Light::with_radius` with a point or spot kind. `dir` and
/// `outer` are used for spots; `outer` may lie outside the accepted range (it is clamped).
pub fn random_light(rng: &mut impl Rng, pos: Vec3, radius: f32, spot: Option<(Vec3, f32)>) -> Light {
    let color = colour(rng);
    let intensity = log_uniform(rng, 0.1, 100.0);
    // Light::point/spot derive r = sqrt(intensity * max(colour) / threshold), and max(colour) = 1.
    let threshold = intensity / (radius * radius);
    let by_threshold = rng.random_bool(0.5);
    let l = match spot {
        None if by_threshold => Light::point(pos, color, intensity, threshold),
        None => Light::with_radius(pos, color, intensity, radius, LightKind::Point),
        Some((dir, outer)) => {
            let inner = outer * rng.random::<f32>();
            if by_threshold {
                Light::spot(pos, dir, color, intensity, inner, outer, threshold)
            } else {
                Light::spot_kind(dir, inner, outer).and_then(|k| Light::with_radius(pos, color, intensity, radius, k))
            }
        }
    };
    l.unwrap_or_else(|e| panic!("generated light at {pos} radius {radius} rejected: {e}"))
}

/// Rotates unit `dir` by `angle` about a random axis perpendicular to it.
pub fn tilt(rng: &mut impl Rng, dir: Vec3, angle: f32) -> Vec3 {
    let perp = dir.cross(unit(rng)).normalize_or(dir.any_orthonormal_vector());
    Quat::from_axis_angle(perp, angle) * dir
}

/// Random lights around a camera: half aimed at `targets` (world points of visible
/// surfaces: placed closer than their radius, spots pointed at them), the rest at the
/// eye, behind the camera, straddling the near plane, or anywhere in front.
/// Up to `n` world-space points on the visible surfaces of a `w` x `h` depth buffer of
/// `samples` values per pixel (sample 0 of random pixels; sky and far-overflowing points
/// skipped): where the property tests put half their lights.
pub fn surface_targets(
    rng: &mut impl Rng,
    camera: &Camera,
    depth: &[f32],
    (w, h, samples): (u32, u32, u32),
    n: usize,
) -> Vec<Vec3> {
    (0..n)
        .filter_map(|_| {
            let (x, y) = (rng.random_range(0..w), rng.random_range(0..h));
            let d = depth[((y * w + x) * samples) as usize];
            tiledlight_cull::reference::pixel_view_position(camera, w, h, x, y, d)
        })
        .map(|p| view_to_world(camera, p))
        .filter(|t| t.abs().max_element() < 1e30)
        .collect()
}

pub fn random_lights(rng: &mut impl Rng, spec: &CamSpec, targets: &[Vec3], n: usize) -> Vec<Light> {
    let (fwd, up) = spec.basis();
    let right = fwd.cross(up);
    let far = if spec.kind == CamKind::Infinite { 1e7 } else { spec.far };
    (0..n)
        .map(|i| {
            let radius = log_uniform(rng, 1e-4, 1e6);
            let is_spot = rng.random_bool(0.5);
            // Requested half-angles from 0.2 to 90 degrees: both clamps get exercised.
            let outer = log_uniform(rng, 0.2f32.to_radians(), 90f32.to_radians());
            let clamped = outer.clamp(tiledlight_cull::light::MIN_SPOT_ANGLE, tiledlight_cull::light::MAX_SPOT_ANGLE);
            if i % 2 == 0 && !targets.is_empty() {
                let target = targets[rng.random_range(0..targets.len())];
                let offset = unit(rng) * radius * rng.random::<f32>();
                let pos = target + offset;
                let to_target = (target - pos).normalize_or(unit(rng));
                // Tilted by less than the cone's half-angle: the target is inside the cone.
                let angle = clamped * 0.99 * rng.random::<f32>();
                let dir = tilt(rng, to_target, angle);
                return random_light(rng, pos, radius, is_spot.then_some((dir, outer)));
            }
            let lateral = right * rng.random_range(-1.0..1.0) + up * rng.random_range(-1.0..1.0);
            let pos = match rng.random_range(0..4) {
                0 => spec.eye,
                1 => spec.eye - fwd * log_uniform(rng, 1e-3, 1e3) + lateral * radius,
                2 => spec.eye + fwd * (spec.near + radius * rng.random_range(-0.9..0.9)) + lateral * radius * 0.3,
                _ => spec.eye + unit(rng) * log_uniform(rng, 1e-3, far.min(1e5)),
            };
            let dir = unit(rng);
            random_light(rng, pos, radius, is_spot.then_some((dir, outer)))
        })
        .collect()
}

/// World-to-view point transform, as the culler does it.
pub fn to_view(view: &Mat4, p: Vec3) -> Vec3 {
    tiledlight_cull::bounds::to_view(view, p)
}

/// True when `l` is a spot light and f32 cannot say whether view point `p` is in it: too
/// close to its fitted sphere's surface ([`near_spot_sphere_surface`]: at its apex and
/// cap rim) or to its cone's surface ([`near_spot_rim`]).
/// The no-false-negative checks skip such (pixel, light) pairs.
pub fn spot_pair_unresolvable(camera: &Camera, packed: &PackedLights, l: u32, p: Vec3) -> bool {
    near_spot_sphere_surface(camera, packed, l, p) || near_spot_rim(camera, packed, l, p)
}

/// True when `l` is a spot light and the cosine of the angle between its axis and the
/// direction to view point `p` is within 8 eps of the cone's `cos_outer`.
///
/// Why: `lights_reaching` decides the cone by `dot(d, axis) / |d| > cos_outer` in f32.
/// Near 1 the cosine's ulp is 6e-8 and it carries ~4 ulps of error (the rotated axis is
/// unit only to ~1 ulp, the dot product and the division add ~3), so the ground truth
/// misplaces the cone's surface by up to ~2.4e-7 in cosine, which for a 0.5 degree cone
/// is 0.3% of the half-angle. The culler's cone test works with `perp * cos - t * sin` and
/// resolves the surface far better; the two disagree inside that band, where the shaded
/// spot falloff `((cos - cos_outer) * scale)^2` is at most `(9.5e-7 * scale)^2`, under 1e-3
/// for every cone with a ramp (`scale = 1 / (cos_inner - cos_outer)`) of 3e-5 in cosine or
/// more; a hard-edged spot (inner == outer) has its edge in that band, and f32 cannot place
/// the edge any closer. Found
/// by no_false_negatives.rs: a 0.5 degree spot, a pixel at 0.5008 degrees that the
/// ground truth's cosine put at 0.4997, and a 1 px tile 2e-7 m across. 8 eps (9.5e-7) is
/// twice the ~4 ulps, and spans 1.3% of a 0.5 degree cone's half-angle, less for wider.
pub fn near_spot_rim(camera: &Camera, packed: &PackedLights, l: u32, p: Vec3) -> bool {
    if l < packed.num_point {
        return false;
    }
    let view = camera.view();
    let rot = Mat4::from_mat3(glam::Mat3::from_mat4(view));
    let spot = packed.spots[(l - packed.num_point) as usize];
    let axis = to_view(&rot, Vec3::from(spot.direction));
    let d = p - to_view(&view, Vec3::from(packed.shading[l as usize].position));
    (d.dot(axis) / d.length() - spot.cos_outer).abs() < 8.0 * EPS
}

/// True when `l` is a spot light and view point `p` lies closer to the surface of the
/// spot's fitted bounding sphere (inside or outside it) than f32 can resolve at the
/// light's position.
///
/// Why: the culler tests the fitted sphere (`GpuCullLight::center`, `radius`), the ground
/// truth the cone from the apex (`GpuShadingLight::position`). In exact arithmetic the
/// sphere holds the cone, but the two points are rounded separately (the centre
/// `apex + dir * offset` in world space, then each by the view transform) at magnitude
/// `s = |apex| + R + |eye|`: each rounding is at most half an ulp, `0.5 * EPS * s`, and
/// about 8 of them add up, so they can disagree by `4 * EPS * s` (measured over 2000
/// random cases: at most 1.54 EPS * s). A point of the cone whose exact distance inside
/// the sphere (computed here relative to the apex, at the light's own scale) is less than
/// that may land outside the culler's sphere. The sphere touches the cone at the apex
/// (half-angles up to 45 degrees) and along the cap's rim, so this covers those two
/// places, and whole spots smaller than `4 * EPS * s`. Found by no_false_negatives.rs: a
/// spot at the eye with R = 5.2e5 m and a surface 1.9e-4 m in front of it; a 0.7 mm spot
/// 1.4 km from the origin. `pack_lights` now pads spot spheres by 8 eps of their world
/// coordinates, which covers those; it cannot cover the `|eye|` part: a 0.1 mm spot at
/// the origin seen from 1 km has its apex and centre rounded to the same view z (ulp
/// 6e-5 m) and is still missed by the AABB test, so the exclusion stays.
pub fn near_spot_sphere_surface(camera: &Camera, packed: &PackedLights, l: u32, p: Vec3) -> bool {
    if l < packed.num_point {
        return false;
    }
    let view = camera.view();
    let rot = Mat4::from_mat3(glam::Mat3::from_mat4(view));
    let spot = packed.spots[(l - packed.num_point) as usize];
    let sh = packed.shading[l as usize];
    let apex = Vec3::from(sh.position);
    let axis = to_view(&rot, Vec3::from(spot.direction));
    let angle = spot.sin_outer.atan2(spot.cos_outer);
    let (c_rel, radius) = tiledlight_cull::light::spot_bounding_sphere(Vec3::ZERO, axis, sh.radius, angle);
    let slack = radius - (p - to_view(&view, apex) - c_rel).length();
    // Two-sided: only points within float error of the surface, on either side. A point
    // that reaches the spot but lies clearly outside the sphere (negative slack beyond
    // the error) means the fitted sphere is too small: that must fail, not be skipped.
    slack.abs() < 4.0 * EPS * (apex.length() + radius + camera.eye().length())
}

/// Checks a (view point, spot light) pair that [`spot_pair_unresolvable`] skipped, with an
/// independent computation: in f64, from the packed apex, axis, radius and outer angle, with
/// the fitted sphere written out here (half-angles up to 45 degrees: through the apex and
/// the cap rim, radius `R / (2 cos a)` on the axis; wider: centred on the cap's centre,
/// radius `R sin a`). The skip is justified when `p` lies within twice the predicate's
/// bands of that sphere's surface (`2 * 4 EPS s`) or of the cone's (`2 * 8 EPS` in
/// cosine): twice, because the predicate works in f32 and may err by its own band. Fails
/// when `spot_bounding_sphere` (which the predicate shares with the culler) were wrong,
/// since then the predicate would skip points the exact sphere holds with room to spare.
pub fn spot_skip_justified(camera: &Camera, packed: &PackedLights, l: u32, p: Vec3) -> Result<(), String> {
    if l < packed.num_point {
        return Err("point lights are never skipped".into());
    }
    let view = camera.view().as_dmat4();
    let spot = packed.spots[(l - packed.num_point) as usize];
    let sh = packed.shading[l as usize];
    let apex_world = Vec3::from(sh.position);
    let apex = view.transform_point3(apex_world.as_dvec3());
    let axis = view.transform_vector3(Vec3::from(spot.direction).as_dvec3()).normalize();
    let len = f64::from(sh.radius);
    let (sin_a, cos_a) = (f64::from(spot.sin_outer), f64::from(spot.cos_outer));
    let (centre, radius) = if sin_a > cos_a {
        (apex + axis * (len * cos_a), len * sin_a)
    } else {
        let r = len / (2.0 * cos_a);
        (apex + axis * r, r)
    };
    let p = p.as_dvec3();
    let slack = radius - (p - centre).length();
    let scale = f64::from(apex_world.length() + packed.cull[l as usize].radius + camera.eye().length());
    let sphere_band = 2.0 * 4.0 * f64::from(EPS) * scale;
    let d: DVec3 = p - apex;
    let cos = d.dot(axis) / d.length();
    // The f32 predicate's cosine also inherits the rounding of the apex's view position
    // (~4 EPS s, see `near_spot_sphere_surface`), an angle of 4 EPS s / |d| as seen from
    // `p`: large when `p` is close to an apex far from the origin.
    let cone_band = 2.0 * (8.0 * f64::from(EPS) + 4.0 * f64::from(EPS) * scale / d.length());
    if slack.abs() < sphere_band || (cos - cos_a).abs() < cone_band {
        Ok(())
    } else {
        Err(format!(
            "{:e} m inside the exact fitted sphere (band {sphere_band:e}), cos to the axis {cos} vs cos outer {cos_a} (band {cone_band:e})",
            slack
        ))
    }
}

/// `10^e` for `e` uniform in [`lo`, `hi`): magnitudes spread over decades.
pub fn exp10(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    (lo..hi).prop_map(|e| 10f32.powf(e))
}

/// Cameras at DESIGN.md's extremes: perspective with finite or infinite far plane and
/// orthographic (near down to 0), fov 1-170 degrees, near 1e-4..10, far 1e2..1e7, eyes up
/// to 1 km from the origin in any orientation; `aspect` from the caller (the GPU property
/// test sets it from the screen, so passes `Just(1.0)`, which draws nothing).
pub fn cam_strategy(aspect: impl Strategy<Value = f32>) -> impl Strategy<Value = CamSpec> {
    let kind = prop_oneof![Just(CamKind::Finite), Just(CamKind::Infinite), Just(CamKind::Ortho)];
    let near = prop_oneof![4 => exp10(-4.0, 1.0), 1 => Just(0.0)];
    let eye =
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0, exp10(-3.0, 3.0)).prop_map(|(x, y, z, s)| Vec3::new(x, y, z) * s);
    let euler = (0.0f32..std::f32::consts::TAU, -1.5f32..1.5, 0.0f32..std::f32::consts::TAU)
        .prop_map(|(a, b, c)| Vec3::new(a, b, c));
    (kind, near, exp10(2.0, 7.0), 1.0f32..170.0, exp10(-1.0, 3.0), aspect, eye, euler).prop_map(
        |(kind, near, far, fov_deg, half_height, aspect, eye, euler)| {
            // Near 0 is only valid (and only interesting) for orthographic cameras.
            let near = if near == 0.0 && kind != CamKind::Ortho { 1e-4 } else { near };
            CamSpec { kind, near, far, fov_deg, half_height, aspect, eye, euler }
        },
    )
}
