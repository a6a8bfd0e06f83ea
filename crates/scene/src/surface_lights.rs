//! Point lights placed on a scene's surfaces, for the million-light preset: triangles
//! sampled by area (every instance's world-space triangles), each light lifted off its
//! triangle along the geometric normal by a fraction of its radius, colours as
//! [`crate::random_lights`] gives them, and one radius for all, chosen from the light
//! count so that the mean number of lights reaching a surface point stays at a target
//! `k` however many lights there are ([`surface_light_radius`]).
//!
//! Spot lights of a loaded scene go near its surfaces too ([`SurfaceSampler::spot_lights`]):
//! lifted off a sampled point, never past the first geometry above it, aimed back at the
//! surface around that point, the radius following the count as for point lights
//! ([`surface_spot_radius`]).
//!
//! Deterministic per seed; sampling is a CDF of triangle areas and a binary search per
//! light (2^20 lights over a 250k-triangle scene take a fraction of a second in release).
//! Depends on glam, rand, rand_pcg, tiledlight-cull ([`Light`]) and this crate's model,
//! error and lights modules.

use std::f64::consts::PI;

use glam::Vec3;
use rand::Rng;
use rand_pcg::Pcg64;
use tiledlight_cull::Light;

use crate::error::SceneError;
use crate::lights::{hue_color, stream_rng, MAX_LIGHTS};
use crate::model::Scene;

/// Default height of a surface light above its triangle, as a fraction of its radius.
/// Low enough that each light still lights a pool around itself (peak irradiance under
/// it `threshold / 0.25^2 = 16 * threshold`), high enough that the pool is not a dot.
pub const DEFAULT_SURFACE_OFFSET: f32 = 0.25;

/// Stream tag of the surface lights (see `lights.rs`: streams differ in their increment).
const SURFACE_STREAM: u64 = 0x0073_7572_6661_6365;

/// Stream tag of the surface spot lights.
const SURFACE_SPOT_STREAM: u64 = 0x7370_6f74_7375_7266;

/// Default height of a surface spot light above its surface, as a fraction of its radius:
/// high enough that its cone (15 to 45 degrees) lights a pool, not a dot; low enough that
/// the pool stays inside its radius (the pool's edge is at most `0.5 r / cos 45 = 0.71 r`
/// away).
pub const DEFAULT_SPOT_OFFSET: f32 = 0.5;

/// Outer half-angles of surface spot lights, degrees (the range [`crate::random_lights`]
/// gives; inner = 0.7 * outer).
const SPOT_OUTER_DEG: (f32, f32) = (15.0, 45.0);

/// Most a surface spot light's axis leans away from its surface's normal, degrees.
const SPOT_MAX_TILT_DEG: f32 = 30.0;

/// Mean of `tan^2` of the outer half-angle, uniform over [`SPOT_OUTER_DEG`]:
/// `(tan b - b - tan a + a) / (b - a)`, about 0.398.
fn mean_tan_squared() -> f64 {
    let (a, b) = (f64::from(SPOT_OUTER_DEG.0).to_radians(), f64::from(SPOT_OUTER_DEG.1).to_radians());
    (b.tan() - b - a.tan() + a) / (b - a)
}

/// Options of [`SurfaceSampler::lights`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceLightOptions {
    /// Number of point lights, 1 to [`MAX_LIGHTS`].
    pub count: u32,
    /// Target mean number of lights reaching a surface point (`k`, positive): sets the
    /// radius ([`surface_light_radius`]).
    pub lights_per_point: f32,
    /// Random seed: the same seed gives the same lights.
    pub seed: u64,
    /// Intensity threshold (positive): `intensity = threshold * radius^2`.
    pub threshold: f32,
    /// Height above the triangle as a fraction of the radius, in `[0, 1)`.
    pub offset: f32,
}

impl Default for SurfaceLightOptions {
    /// The million-light preset: 1,000,000 lights, 8 lights per surface point, seed 1, the
    /// default threshold and offset. In the default courtyard from its own camera at
    /// 1920x1080 that is about 100 lights per 16 px tile after the GPU's default culling
    /// (estimated on the CPU: 106 per tile showing a surface, 99.7 over all tiles; a test
    /// checks it).
    fn default() -> Self {
        Self {
            count: 1_000_000,
            lights_per_point: 8.0,
            seed: 1,
            threshold: crate::DEFAULT_LIGHT_THRESHOLD,
            offset: DEFAULT_SURFACE_OFFSET,
        }
    }
}

/// Lights made by [`SurfaceSampler::lights`], with what they were made from.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceLights {
    /// The point lights, all of radius `radius`.
    pub lights: Vec<Light>,
    /// The radius every light has (metres).
    pub radius: f32,
    /// The intensity every light has (`threshold * radius^2`).
    pub intensity: f32,
    /// Total area of the surfaces they were placed on (square metres).
    pub area: f64,
}

/// The radius that puts `k` lights, on average, within reach of a surface point when
/// `count` lights are spread uniformly over `area` square metres of surface, each lifted
/// by `offset * radius` along its surface's normal.
///
/// Derivation: the lights have density `s = count / area` per square metre. Seen from a
/// point of a flat surface (flat over a radius), its own surface's lights lie on the plane
/// at height `h = offset * r`, and those within `r` of the point fill a disc of radius
/// `sqrt(r^2 - h^2)`: `k = s * pi * r^2 * (1 - offset^2)`, so
/// `r = sqrt(k * area / (pi * count * (1 - offset^2)))`. Lights only light the side they
/// are on: a wall's lights on one side do not count for the other side, which has its own
/// (the area counts both sides). Near concave corners (floor meeting a wall) a point also
/// sees the other surface's lights, near convex edges it loses part of its disc; the mean
/// over a whole scene stays near `k` (the tests check +-30% on the courtyard).
///
/// Returns NaN for a non-positive or non-finite argument or `offset` outside `[0, 1)`
/// ([`SurfaceSampler::lights`] checks them first and names the problem).
pub fn surface_light_radius(area: f64, count: u32, k: f32, offset: f32) -> f32 {
    let ok = area.is_finite() && area > 0.0 && count > 0 && k.is_finite() && k > 0.0 && (0.0..1.0).contains(&offset);
    if !ok {
        return f32::NAN;
    }
    let flat = 1.0 - f64::from(offset).powi(2);
    (f64::from(k) * area / (PI * f64::from(count) * flat)).sqrt() as f32
}

/// The radius of surface spot lights that puts `k` of their pools, on average, over a
/// surface point when `count` of them are spread over `area` square metres, each
/// `offset * radius` above its surface and aimed at it.
///
/// Derivation: a spot at height `h` aimed straight at a flat surface lights a disc of radius
/// `h tan(outer)` (inside its radius while `offset <= 0.7`); with outer angles uniform in 15
/// to 45 degrees the mean disc is `pi h^2 E[tan^2] = pi (offset r)^2 * 0.398`, so
/// `k = count / area * pi offset^2 r^2 * 0.398` and
/// `r = sqrt(k * area / (pi * count * offset^2 * 0.398))`. A tilted axis stretches the
/// pool a little; a spot lowered to clear geometry above it lights a smaller one.
///
/// NaN for a non-positive or non-finite argument or `offset` outside `(0, 1)`.
pub fn surface_spot_radius(area: f64, count: u32, k: f32, offset: f32) -> f32 {
    let ok = area.is_finite() && area > 0.0 && count > 0 && k.is_finite() && k > 0.0 && offset > 0.0 && offset < 1.0;
    if !ok {
        return f32::NAN;
    }
    let pool = PI * f64::from(offset).powi(2) * mean_tan_squared();
    (f64::from(k) * area / (f64::from(count) * pool)).sqrt() as f32
}

/// Mean irradiance on a flat surface covered by surface lights of colour 1, per light
/// reaching a point and per unit of threshold: `E = factor * k * threshold`.
///
/// With `u = d / r`, the windowed falloff `w(u) = (1 - u^4)^2` and the cosine `h / d`, the
/// disc of lights around a point gives `E = 2 pi s I h * integral from h to r of w(d/r) / d^2 dd`;
/// with `s pi r^2 (1 - f^2) = k`, `I = threshold * r^2` and `h = f r` this is
/// `E = k * threshold * 2 f / (1 - f^2) * (1/f - 32/21 + 2 f^3 / 3 - f^7 / 7)`
/// (about 2 for a small offset, 1.33 at 0.25). Used to pick an exposure. Returns 0 for an
/// `offset` outside `(0, 1)` (at 0 the integral has no finite value; the limit is 2).
pub fn surface_irradiance_factor(offset: f32) -> f32 {
    let f = f64::from(offset);
    if !(f > 0.0 && f < 1.0) {
        return if f == 0.0 { 2.0 } else { 0.0 };
    }
    let integral = 1.0 / f - 32.0 / 21.0 + 2.0 * f.powi(3) / 3.0 - f.powi(7) / 7.0;
    (2.0 * f / (1.0 - f * f) * integral) as f32
}

/// A scene's triangles ready to be sampled by area: the triangles, their normals and the
/// cumulative area.
#[derive(Clone, Debug)]
pub struct SurfaceSampler {
    triangles: Vec<[Vec3; 3]>,
    /// `cumulative[i]`: area of triangles `0..=i` (f64: a million small areas summed in
    /// f32 would lose the last ones).
    cumulative: Vec<f64>,
}

impl SurfaceSampler {
    /// A sampler over `triangles` (world space, counter-clockwise front faces). Triangles
    /// with no area or a non-finite corner are never picked.
    ///
    /// Errors: no triangle with a positive, finite area.
    pub fn new(triangles: Vec<[Vec3; 3]>) -> Result<Self, SceneError> {
        let mut total = 0.0f64;
        let cumulative = triangles
            .iter()
            .map(|t| {
                let a = triangle_area(t);
                if a.is_finite() && a > 0.0 {
                    total += a;
                }
                total
            })
            .collect();
        if !(total > 0.0 && total.is_finite()) {
            return Err(SceneError::InvalidArgument(format!(
                "no surface to place lights on: the scene has {} triangles and none has a positive, finite area",
                triangles.len()
            )));
        }
        Ok(Self { triangles, cumulative })
    }

    /// A sampler over `scene`'s world-space triangles (every instance's,
    /// [`Scene::world_triangles`]); the error names the scene.
    pub fn of_scene(scene: &Scene) -> Result<Self, SceneError> {
        Self::new(scene.world_triangles()).map_err(|e| SceneError::InvalidScene {
            scene: scene.name.clone(),
            problem: match e {
                SceneError::InvalidArgument(m) => m,
                other => other.to_string(),
            },
        })
    }

    /// Total area of the triangles, square metres.
    pub fn area(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// The triangles sampled.
    pub fn triangles(&self) -> &[[Vec3; 3]] {
        &self.triangles
    }

    /// A point of the surface, uniform by area, from three uniform numbers in `[0, 1)`:
    /// its position, its triangle's unit geometric normal (the counter-clockwise front
    /// side) and the triangle's index.
    pub fn sample(&self, pick: f64, u: f32, v: f32) -> (Vec3, Vec3, usize) {
        let target = pick * self.area();
        // First triangle whose cumulative area passes the target; zero-area triangles
        // repeat the previous sum, so they are never the first to pass it.
        let i = self.cumulative.partition_point(|&c| c <= target).min(self.triangles.len() - 1);
        let [a, b, c] = self.triangles[i];
        // Uniform on the triangle: fold the unit square's upper half onto the lower one.
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        let n = (b - a).cross(c - a).normalize_or_zero();
        (a + u * (b - a) + v * (c - a), n, i)
    }

    /// `opts.count` point lights on the surfaces: positions uniform by area, each lifted
    /// `opts.offset * radius` along its triangle's front normal; saturated hues as
    /// [`crate::random_lights`]; one radius, [`surface_light_radius`] of the total area,
    /// and intensity `threshold * radius^2`.
    ///
    /// Errors, each naming the argument: 0 lights or more than [`MAX_LIGHTS`];
    /// `lights_per_point` or `threshold` not finite and positive; `offset` outside `[0, 1)`.
    pub fn lights(&self, opts: &SurfaceLightOptions) -> Result<SurfaceLights, SceneError> {
        check(opts)?;
        let area = self.area();
        let radius = surface_light_radius(area, opts.count, opts.lights_per_point, opts.offset);
        let intensity = opts.threshold * radius * radius;
        if !(radius.is_finite() && radius > 0.0 && intensity.is_finite() && intensity > 0.0) {
            return Err(SceneError::InvalidArgument(format!(
                "surface lights: radius {radius} m and intensity {intensity} from {} lights over {area} m^2 with \
                 {} lights per point and threshold {} are not finite and positive",
                opts.count, opts.lights_per_point, opts.threshold
            )));
        }
        let lift = opts.offset * radius;
        let mut rng: Pcg64 = stream_rng(opts.seed, SURFACE_STREAM);
        let wrap =
            |e: tiledlight_cull::CullError| SceneError::InvalidArgument(format!("cannot build a surface light: {e}"));
        let mut lights = Vec::with_capacity(opts.count as usize);
        for _ in 0..opts.count {
            let (pick, u, v) = (rng.random::<f64>(), rng.random::<f32>(), rng.random::<f32>());
            let (p, n, _) = self.sample(pick, u, v);
            let color = hue_color(rng.random::<f32>());
            lights.push(Light::point(p + lift * n, color, intensity, opts.threshold).map_err(wrap)?);
        }
        Ok(SurfaceLights { lights, radius, intensity, area })
    }
}

impl SurfaceSampler {
    /// `opts.count` spot lights near the surfaces, aimed at them: each at a point sampled by
    /// area, lifted `opts.offset * radius` along its triangle's front normal but never more
    /// than half way to the first geometry above it (so it is never inside a wall or an
    /// object, however large the radius), its axis within 30 degrees of straight back at its
    /// surface and hitting geometry within its radius (straight back when the leaning one
    /// would miss: off the model's edge); outer half-angles 15 to 45 degrees, inner 0.7 of
    /// outer; saturated hues as [`crate::random_lights`]; one radius,
    /// [`surface_spot_radius`] of the total area, intensity `threshold * radius^2`.
    ///
    /// Builds a ray-casting hierarchy of the triangles for the clearance tests (a fraction
    /// of a second for a few hundred thousand triangles in release).
    ///
    /// Errors, each naming the argument: as [`SurfaceSampler::lights`], and `offset` must be
    /// in `(0, 1)`.
    pub fn spot_lights(&self, opts: &SurfaceLightOptions) -> Result<SurfaceLights, SceneError> {
        check(opts)?;
        if opts.offset <= 0.0 {
            return Err(SceneError::InvalidArgument(format!(
                "surface spot lights: offset {} must be in (0, 1) (a fraction of the radius)",
                opts.offset
            )));
        }
        let area = self.area();
        let radius = surface_spot_radius(area, opts.count, opts.lights_per_point, opts.offset);
        let intensity = opts.threshold * radius * radius;
        if !(radius.is_finite() && radius > 0.0 && intensity.is_finite() && intensity > 0.0) {
            return Err(SceneError::InvalidArgument(format!(
                "surface spot lights: radius {radius} m and intensity {intensity} from {} lights over {area} m^2 \
                 with {} lights per point and threshold {} are not finite and positive",
                opts.count, opts.lights_per_point, opts.threshold
            )));
        }
        let bvh = tiledlight_cull::raycast::Triangles::new(self.triangles.clone());
        let lift = opts.offset * radius;
        let cos_max_tilt = SPOT_MAX_TILT_DEG.to_radians().cos();
        let mut rng: Pcg64 = stream_rng(opts.seed, SURFACE_SPOT_STREAM);
        let wrap = |e: tiledlight_cull::CullError| {
            SceneError::InvalidArgument(format!("cannot build a surface spot light: {e}"))
        };
        let mut lights = Vec::with_capacity(opts.count as usize);
        for _ in 0..opts.count {
            let (pick, u, v) = (rng.random::<f64>(), rng.random::<f32>(), rng.random::<f32>());
            let (p, n, _) = self.sample(pick, u, v);
            // Start the clearance ray off the surface (it would hit its own triangle), by
            // a step that is not lost to rounding far from the origin.
            let step = (1e-4 * lift).max(4.0 * f32::EPSILON * p.abs().max_element());
            let above = bvh.first_hit(p + step * n, n, 2.0 * lift).map_or(f32::INFINITY, |t| t + step);
            let position = p + lift.min(0.5 * above) * n;
            // Uniform over the cap of directions within 30 degrees of -n.
            let cos_tilt = cos_max_tilt + (1.0 - cos_max_tilt) * rng.random::<f32>();
            let sin_tilt = (1.0 - cos_tilt * cos_tilt).max(0.0).sqrt();
            let azimuth = std::f32::consts::TAU * rng.random::<f32>();
            let (t1, t2) = n.any_orthonormal_pair();
            let leaning = -cos_tilt * n + sin_tilt * (azimuth.cos() * t1 + azimuth.sin() * t2);
            let direction = if bvh.first_hit(position, leaning, radius).is_some() { leaning } else { -n };
            let outer = (SPOT_OUTER_DEG.0 + (SPOT_OUTER_DEG.1 - SPOT_OUTER_DEG.0) * rng.random::<f32>()).to_radians();
            let color = hue_color(rng.random::<f32>());
            let light = Light::spot(position, direction, color, intensity, 0.7 * outer, outer, opts.threshold);
            lights.push(light.map_err(wrap)?);
        }
        Ok(SurfaceLights { lights, radius, intensity, area })
    }
}

/// Area of a triangle in f64 (NaN for a non-finite corner).
fn triangle_area([a, b, c]: &[Vec3; 3]) -> f64 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    0.5 * (b - a).cross(c - a).length()
}

fn check(opts: &SurfaceLightOptions) -> Result<(), SceneError> {
    let bad = |m: String| Err(SceneError::InvalidArgument(m));
    if opts.count == 0 {
        return bad("surface lights: 0 lights asked for (at least 1)".into());
    }
    if u64::from(opts.count) > MAX_LIGHTS {
        return Err(SceneError::TooManyLights { requested: opts.count.into(), limit: MAX_LIGHTS });
    }
    if !(opts.lights_per_point.is_finite() && opts.lights_per_point > 0.0) {
        return bad(format!("surface lights: lights per point {} must be finite and positive", opts.lights_per_point));
    }
    if !(opts.threshold.is_finite() && opts.threshold > 0.0) {
        return bad(format!("surface lights: threshold {} must be finite and positive", opts.threshold));
    }
    if !(0.0..1.0).contains(&opts.offset) {
        return bad(format!("surface lights: offset {} must be in [0, 1) (a fraction of the radius)", opts.offset));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{default_scene, shadow_box_scene, DefaultSceneOptions};
    use std::collections::HashMap;

    /// Distance from `p` to the triangle (closest point by projection, then the edges).
    fn distance_to_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> f32 {
        let n = (b - a).cross(c - a).normalize_or_zero();
        let q = p - n * n.dot(p - a);
        let inside = [(a, b), (b, c), (c, a)].iter().all(|&(e0, e1)| (e1 - e0).cross(q - e0).dot(n) >= 0.0);
        if inside {
            return (p - q).length();
        }
        let seg = |e0: Vec3, e1: Vec3| {
            let t = ((p - e0).dot(e1 - e0) / (e1 - e0).length_squared()).clamp(0.0, 1.0);
            (p - (e0 + t * (e1 - e0))).length()
        };
        seg(a, b).min(seg(b, c)).min(seg(c, a))
    }

    fn courtyard() -> SurfaceSampler {
        SurfaceSampler::of_scene(&default_scene(&DefaultSceneOptions::default()).unwrap()).unwrap()
    }

    #[test]
    fn deterministic_per_seed() {
        let s = SurfaceSampler::of_scene(&shadow_box_scene(0.5)).unwrap();
        let opts = SurfaceLightOptions { count: 2000, seed: 7, ..SurfaceLightOptions::default() };
        let a = s.lights(&opts).unwrap();
        assert_eq!(a, s.lights(&opts).unwrap());
        assert_eq!(a.lights.len(), 2000);
        assert_ne!(a.lights, s.lights(&SurfaceLightOptions { seed: 8, ..opts }).unwrap().lights);
        for l in &a.lights {
            assert!((l.radius - a.radius).abs() <= 1e-4 * a.radius, "radius {} vs {}", l.radius, a.radius);
            assert!((l.color.max_element() - 1.0).abs() < 1e-6 && l.color.min_element() >= 0.0, "{}", l.color);
        }
        // 400 m^2 floor + 6 faces of 4 m^2.
        assert!((s.area() - 424.0).abs() < 1e-3, "area {}", s.area());
    }

    #[test]
    fn lights_sit_on_the_lit_side_within_their_offset() {
        // The shadow box: a floor and a hovering cube placed by its instance's transform.
        let scene = shadow_box_scene(0.5);
        let s = SurfaceSampler::of_scene(&scene).unwrap();
        let opts =
            SurfaceLightOptions { count: 3000, lights_per_point: 4.0, seed: 3, ..SurfaceLightOptions::default() };
        let out = s.lights(&opts).unwrap();
        let lift = opts.offset * out.radius;
        let tris = scene.world_triangles();
        let mut on_cube = 0;
        for l in &out.lights {
            let p = l.position;
            let ok = tris.iter().any(|&t| {
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                distance_to_triangle(p, t) <= lift + 1e-4 && n.dot(p - t[0]) > 0.0
            });
            assert!(ok, "light at {p} is not within {lift} m of a triangle on its front side");
            // Lights of the cube are outside it (the cube spans y 0.5..2.5, x and z -1..1).
            let in_cube = p.x.abs() < 1.0 - 1e-4 && p.z.abs() < 1.0 - 1e-4 && p.y > 0.5 + 1e-4 && p.y < 2.5 - 1e-4;
            assert!(!in_cube, "light at {p} inside the cube");
            on_cube += usize::from(p.y > lift + 1e-3);
        }
        // The cube holds 24 of 424 m^2: about 170 of 3000 lights.
        assert!((100..250).contains(&on_cube), "{on_cube} lights on the cube");
    }

    /// Mean number of lights within `r` of sampled surface points and on their front side.
    fn mean_lights_per_point(s: &SurfaceSampler, lights: &[Light], r: f32, points: usize) -> f64 {
        let cell = |p: Vec3| (p / r).floor().as_ivec3();
        let mut grid: HashMap<glam::IVec3, Vec<Vec3>> = HashMap::new();
        for l in lights {
            grid.entry(cell(l.position)).or_default().push(l.position);
        }
        let mut rng = stream_rng(99, 1);
        let mut total = 0usize;
        for _ in 0..points {
            let (x, n, _) = s.sample(rng.random(), rng.random(), rng.random());
            let c = cell(x);
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let Some(v) = grid.get(&(c + glam::IVec3::new(dx, dy, dz))) else { continue };
                        total += v.iter().filter(|&&p| (p - x).length_squared() < r * r && n.dot(p - x) > 0.0).count();
                    }
                }
            }
        }
        total as f64 / points as f64
    }

    #[test]
    fn the_radius_keeps_lights_per_point_near_k() {
        let s = courtyard();
        let k = SurfaceLightOptions::default().lights_per_point;
        for count in [10_000, 100_000, 1_000_000] {
            let t = std::time::Instant::now();
            let out = s
                .lights(&SurfaceLightOptions { count, lights_per_point: k, ..SurfaceLightOptions::default() })
                .unwrap();
            println!("{count} lights generated in {:?} (test profile)", t.elapsed());
            let mean = mean_lights_per_point(&s, &out.lights, out.radius, 3000);
            println!("{count} lights: radius {:.3} m, {mean:.2} lights per point (k {k})", out.radius);
            assert!((mean / f64::from(k) - 1.0).abs() < 0.3, "{count} lights: {mean} per point, k {k}");
        }
    }

    #[test]
    fn radius_follows_the_formula_and_the_count() {
        let r = surface_light_radius(1000.0, 1000, 2.0, 0.0);
        assert!((f64::from(r) - (2.0 / PI).sqrt()).abs() < 1e-6, "{r}");
        // Four times the lights: half the radius.
        let r4 = surface_light_radius(1000.0, 4000, 2.0, 0.0);
        assert!((r / r4 - 2.0).abs() < 1e-5);
        // The lift shrinks the disc of lights a point sees: the radius grows to make up.
        assert!(surface_light_radius(1000.0, 1000, 2.0, 0.5) > r);
        for bad in [surface_light_radius(0.0, 1, 1.0, 0.0), surface_light_radius(1.0, 1, f32::NAN, 0.0)] {
            assert!(bad.is_nan());
        }
        // The irradiance factor tends to 2 for a small offset, drops as the lights rise.
        assert!((surface_irradiance_factor(1e-4) - 2.0).abs() < 1e-3);
        assert!(surface_irradiance_factor(0.25) < surface_irradiance_factor(0.1));
        assert_eq!(surface_irradiance_factor(1.0), 0.0);
    }

    #[test]
    fn bad_inputs_are_named() {
        let s = SurfaceSampler::of_scene(&shadow_box_scene(0.0)).unwrap();
        let e = |o: SurfaceLightOptions| s.lights(&o).unwrap_err().to_string();
        let o = SurfaceLightOptions { count: 10, ..SurfaceLightOptions::default() };
        assert!(e(SurfaceLightOptions { count: 0, ..o }).contains("0 lights"));
        let too_many = e(SurfaceLightOptions { count: (1 << 20) + 1, ..o });
        assert!(too_many.contains("1048577") && too_many.contains("1048576"), "{too_many}");
        for k in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(e(SurfaceLightOptions { lights_per_point: k, ..o }).contains("lights per point"), "k {k}");
        }
        assert!(e(SurfaceLightOptions { threshold: 0.0, ..o }).contains("threshold"));
        assert!(e(SurfaceLightOptions { offset: 1.0, ..o }).contains("offset"));
        // No triangles, or only degenerate ones.
        let mut empty = shadow_box_scene(0.0);
        empty.name = "empty".into();
        empty.instances.clear();
        let msg = SurfaceSampler::of_scene(&empty).unwrap_err().to_string();
        assert!(msg.contains("'empty'") && msg.contains("no surface to place lights on"), "{msg}");
        let flat = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(SurfaceSampler::new(vec![flat, [Vec3::NAN; 3]]).is_err());
        // 2^20 lights is allowed.
        let max = s.lights(&SurfaceLightOptions { count: 1 << 20, ..o }).unwrap();
        assert_eq!(max.lights.len(), 1 << 20);
    }

    /// The 12 triangles of the box `min..max`, front faces outward (or inward: a room).
    fn box_triangles(min: Vec3, max: Vec3, inward: bool) -> Vec<[Vec3; 3]> {
        let (c, h) = ((min + max) * 0.5, (max - min) * 0.5);
        let mut out = Vec::new();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let e = |i: usize| Vec3::AXES[i % 3];
                let normal = e(axis) * sign * if inward { -1.0 } else { 1.0 };
                let centre = c + e(axis) * sign * h[axis];
                let (u, v) = (e(axis + 1) * h[(axis + 1) % 3], e(axis + 2) * h[(axis + 2) % 3]);
                let q = [centre - u - v, centre + u - v, centre + u + v, centre - u + v];
                for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                    let front = (t[1] - t[0]).cross(t[2] - t[0]).dot(normal) > 0.0;
                    out.push(if front { t } else { [t[0], t[2], t[1]] });
                }
            }
        }
        out
    }

    #[test]
    fn spot_lights_stay_out_of_a_closed_box_s_walls_and_aim_at_geometry() {
        use tiledlight_cull::raycast::Triangles;
        use tiledlight_cull::LightKind;
        // A 4 m room with 0.1 m walls: the inner box faces inward, the outer one outward.
        let (inner, outer) = (2.0f32, 2.1f32);
        let mut tris = box_triangles(Vec3::splat(-inner), Vec3::splat(inner), true);
        tris.extend(box_triangles(Vec3::splat(-outer), Vec3::splat(outer), false));
        let s = SurfaceSampler::new(tris.clone()).unwrap();
        let bvh = Triangles::new(tris);
        // 8 lights: a radius of ~25 m, far more than the room, so the lift must be cut; 3000:
        // a radius under 1 m.
        for count in [8, 3000] {
            let opts = SurfaceLightOptions { count, offset: DEFAULT_SPOT_OFFSET, ..SurfaceLightOptions::default() };
            let out = s.spot_lights(&opts).unwrap();
            assert_eq!(out.lights.len(), count as usize);
            println!("{count} spot lights: radius {:.3} m", out.radius);
            let (mut in_room, mut lowered) = (0, 0);
            for l in &out.lights {
                let p = l.position;
                let m = p.abs().max_element();
                assert!(!(m > inner - 1e-4 && m < outer + 1e-4), "light at {p} in the walls (count {count})");
                in_room += usize::from(m < inner);
                let LightKind::Spot { direction, outer_angle, inner_angle } = l.kind else { panic!("not a spot") };
                // Aimed at geometry within its radius.
                let hit = bvh.first_hit(p, direction, l.radius);
                assert!(hit.is_some(), "spot at {p} aims {direction} at nothing within {}", l.radius);
                let deg = outer_angle.to_degrees();
                assert!((15.0 - 1e-3..=45.0 + 1e-3).contains(&deg) && (inner_angle - 0.7 * outer_angle).abs() < 1e-6);
                assert!((l.intensity - opts.threshold * out.radius * out.radius).abs() < 1e-4 * l.intensity);
                // The lift is the offset's share of the radius, or half the way to the wall.
                let lift = if m < inner { inner - m } else { m - outer };
                lowered += usize::from(lift < 0.5 * out.radius - 1e-3);
                assert!(lift <= 0.5 * out.radius + 1e-3, "lift {lift} of radius {}", out.radius);
            }
            // Inner faces hold 96 of 202 m^2: about half the lights are in the room.
            assert!(in_room > 0 && in_room < count as usize, "{in_room} of {count} in the room");
            if count == 8 {
                // The room is 4 m across: every light inside it was lowered to at most 2 m.
                assert!(lowered >= in_room, "{lowered} lowered, {in_room} in the room");
            }
        }
    }

    #[test]
    fn spot_radii_follow_the_scene_s_size() {
        // The same closed cube as a 2 m model and as a 100 m building.
        let scene = |side: f32| SurfaceSampler::new(box_triangles(Vec3::ZERO, Vec3::splat(side), false)).unwrap();
        let opts = SurfaceLightOptions { count: 256, offset: DEFAULT_SPOT_OFFSET, ..SurfaceLightOptions::default() };
        let (small, large) = (scene(2.0).spot_lights(&opts).unwrap(), scene(100.0).spot_lights(&opts).unwrap());
        assert!((large.radius / small.radius - 50.0).abs() < 50.0 * 1e-4, "{} {}", small.radius, large.radius);
        for (a, b) in small.lights.iter().zip(&large.lights) {
            assert!((b.position - 50.0 * a.position).length() < 1e-3 * 50.0, "{} vs {}", a.position, b.position);
        }
        // The formula: 256 spots, k = 8, offset 0.5, 24 m^2.
        let expected = (8.0 * 24.0 / (256.0 * PI * 0.25 * mean_tan_squared())).sqrt();
        assert!((f64::from(small.radius) - expected).abs() < 1e-5, "{} vs {expected}", small.radius);
        assert!((mean_tan_squared() - 0.398).abs() < 1e-3, "{}", mean_tan_squared());
        // Four times the spots: half the radius. Bad offsets are named.
        assert!(
            (surface_spot_radius(24.0, 256, 8.0, 0.5) / surface_spot_radius(24.0, 1024, 8.0, 0.5) - 2.0).abs() < 1e-5
        );
        let e = scene(2.0).spot_lights(&SurfaceLightOptions { offset: 0.0, ..opts }).unwrap_err().to_string();
        assert!(e.contains("offset 0"), "{e}");
    }

    /// The estimate behind the million-light preset's `k`: the courtyard from its own
    /// camera at 1920x1080, 16 px tiles, 2^20 lights.
    #[test]
    fn lights_per_tile_at_1080p_in_the_courtyard() {
        use tiledlight_cull::estimate::estimate_lights_per_tile;
        use tiledlight_cull::raycast::Triangles;
        use tiledlight_cull::Camera;
        let scene = default_scene(&DefaultSceneOptions::default()).unwrap();
        let s = SurfaceSampler::of_scene(&scene).unwrap();
        let d = scene.camera.unwrap();
        let cam = Camera::perspective(d.eye, d.target, d.up, d.fov_y, 16.0 / 9.0, d.near, d.far).unwrap();
        let tris = Triangles::new(s.triangles().to_vec());
        // Every 4th tile in x and y: 510 tiles, 130k rays.
        let opts = SurfaceLightOptions::default();
        let out = s.lights(&opts).unwrap();
        let e = estimate_lights_per_tile(&tris, &cam, (1920, 1080), 16, &out.lights, 4).unwrap();
        println!("{} lights, k {}, radius {:.3} m: {e:?}", opts.count, opts.lights_per_point, out.radius);
        assert!((80.0..130.0).contains(&e.mean_culled), "{e:?}");
        // The lights that really reach a pixel of the tile are fewer: the plane test keeps
        // spheres off the tile's corners and in front of or behind its surfaces.
        assert!(e.mean_reaching < e.mean_culled && e.mean_reaching > 0.4 * e.mean_culled, "{e:?}");
    }
}
