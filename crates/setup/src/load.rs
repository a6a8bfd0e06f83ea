//! The CPU half of a run, built before any GPU work so that file and settings errors come
//! before the slow device creation: the scene (the procedural courtyard or a glTF file),
//! its lights (the file's own, then the random ones asked for: in the bounds, or point
//! lights on the scene's surfaces) and the camera ([`SceneCpu`]); and the light counts a
//! report shows ([`LightSummary`], [`SurfacePlacement`], [`FittedLights`]).
//!
//! Random lights of a loaded scene fit its size, whatever it is (a 2 m model, a 100 m
//! building): point lights on its surfaces or, with the bounds placement, radii fitted to
//! its bounds and the count; spot lights near its surfaces aimed at them (in its bounds,
//! fitted, with the bounds placement). Radii scale with the scene and intensities are
//! `threshold * radius^2` (times a fixed spread), so the irradiance a surface gets, and the
//! image, do not depend on the scene's scale. The built-in courtyard keeps TiledLighting11's
//! lights (radii 1.5-4 m uniform in its bounds): every benchmark is measured with them.
//!
//! Depends on tiledlight-scene (scene model, procedural scene, glTF loading, light
//! generation), tiledlight-cull and [`crate::settings`] / [`crate::camera`]; no GPU work.

use std::sync::Arc;

use anyhow::{ensure, Context, Result};
use tiledlight_cull::{Camera, LightKind};
use tiledlight_scene::{
    bounds_light_radius, default_scene, fitted_intensity_range, load_gltf_with, random_lights, Aabb,
    DefaultSceneOptions, Light, LightOptions, LoadOptions, Scene, SurfaceLightOptions, SurfaceSampler,
    DEFAULT_INTENSITY_RANGE, DEFAULT_SPOT_OFFSET, MAX_LIGHTS,
};

use crate::camera::choose_camera;
use crate::settings::{SceneSource, Settings, DEFAULT_LIGHTS_PER_POINT};

/// The lights of a run, counted.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LightSummary {
    /// Point lights in total.
    pub point: usize,
    /// Spot lights in total.
    pub spot: usize,
    /// Lights that came from the glTF file (KHR_lights_punctual).
    pub from_file: usize,
    /// Random lights generated.
    pub random: usize,
}

impl LightSummary {
    /// The counts of `lights`, of which the first `from_file` came from the scene file.
    pub fn of(lights: &[Light], from_file: usize) -> Self {
        let spot = lights.iter().filter(|l| matches!(l.kind, LightKind::Spot { .. })).count();
        Self { point: lights.len() - spot, spot, from_file, random: lights.len() - from_file }
    }
}

/// How the point lights were placed on the surfaces (for the report).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePlacement {
    /// Point lights placed.
    pub count: usize,
    /// Target mean lights per surface point (`k`).
    pub lights_per_point: f32,
    /// The radius every one has (metres).
    pub radius: f32,
    /// Total surface area they were spread over (square metres).
    pub area: f64,
}

impl std::fmt::Display for SurfacePlacement {
    /// "1000000 on the surfaces (5573 m^2, area-weighted), radius 0.123 m for k = 8 lights
    /// per surface point".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} on the surfaces ({:.0} m^2, area-weighted), radius {:.3} m for k = {} lights per surface point",
            self.count, self.area, self.radius, self.lights_per_point
        )
    }
}

/// Random lights of a loaded scene placed uniformly in its bounds with radii fitted to
/// them (for the report).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundsFit {
    /// Lights placed (point and spot).
    pub count: usize,
    /// The mean lights per surface point the radii were fitted for (`k`).
    pub lights_per_point: f32,
    /// The fitted radius ([`bounds_light_radius`]: the lights' mean-cube radius).
    pub radius: f32,
    /// The smallest and largest radius drawn.
    pub radii: (f32, f32),
    /// The bounds' size (metres).
    pub size: glam::Vec3,
}

impl std::fmt::Display for BoundsFit {
    /// "1024 uniform in the bounds (2.0 x 1.5 x 2.0 m), radii 0.140-0.372 m, fitted to the
    /// bounds and the count for k = 8 lights per surface point".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self.size;
        write!(
            f,
            "{} uniform in the bounds ({:.1} x {:.1} x {:.1} m), radii {:.3}-{:.3} m, fitted to the bounds and the \
             count for k = {} lights per surface point",
            self.count, s.x, s.y, s.z, self.radii.0, self.radii.1, self.lights_per_point
        )
    }
}

/// How the spot lights of a loaded scene were placed near its surfaces (for the report).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotPlacement {
    /// Spot lights placed.
    pub count: usize,
    /// Target mean pools of light per surface point (`k`).
    pub lights_per_point: f32,
    /// The radius every one has (metres).
    pub radius: f32,
    /// Total surface area they were spread over (square metres).
    pub area: f64,
}

impl std::fmt::Display for SpotPlacement {
    /// "16 near the surfaces aiming at them (24 m^2, area-weighted, lifted half their radius
    /// or half way to the geometry above), radius 1.234 m for k = 8 pools per surface point".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} near the surfaces aiming at them ({:.0} m^2, area-weighted, lifted {} of their radius or half way to \
             the geometry above), radius {:.3} m for k = {} pools per surface point",
            self.count, self.area, DEFAULT_SPOT_OFFSET, self.radius, self.lights_per_point
        )
    }
}

/// How the random lights of a loaded scene were fitted to it, beyond
/// [`SurfacePlacement`] (both None for the built-in courtyard, whose lights are
/// TiledLighting11's).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FittedLights {
    /// Lights in the bounds with fitted radii (the bounds placement).
    pub bounds: Option<BoundsFit>,
    /// Spot lights near the surfaces (the surface placement).
    pub spots: Option<SpotPlacement>,
}

/// The lights [`build_lights`] made and how.
pub(crate) struct BuiltLights {
    pub lights: Vec<Light>,
    pub surface_placement: Option<SurfacePlacement>,
    pub fitted: FittedLights,
}

/// The scene's triangles ready for surface lights: built when the settings place lights
/// on surfaces, kept so that new surface lights need no new scene.
pub type Surfaces = Option<Arc<SurfaceSampler>>;

/// The CPU half of a run, built before any GPU work so that file and flag errors come
/// before the slow device creation: the scene, all its lights and the camera.
pub struct SceneCpu {
    /// The scene.
    pub scene: Scene,
    /// The scene's own lights followed by the random ones.
    pub lights: Vec<Light>,
    /// How many of `lights` came from the scene file.
    pub file_lights: usize,
    /// The camera (aspect = width / height): the bookmark, the scene's, or one framing it.
    pub camera: Camera,
    /// Where the camera came from, for the report.
    pub camera_source: String,
    /// The surfaces sampled for surface lights (None unless the settings place lights on
    /// surfaces).
    pub surfaces: Surfaces,
    /// How the surface lights were made (None unless there are some).
    pub surface_placement: Option<SurfacePlacement>,
    /// How the other random lights of a loaded scene were fitted to it.
    pub fitted: FittedLights,
    /// What the scene was drawn despite (a missing texture, an unknown extension...): one
    /// sentence each, naming the file. Callers show each one (the app as a `warning:`
    /// line); empty for the default scene and with `strict` settings (those fail instead).
    pub warnings: Vec<String>,
}

impl SceneCpu {
    /// Checks the settings and builds the scene, its lights and the camera.
    pub fn load(settings: &Settings) -> Result<Self> {
        settings.validate()?;
        let (scene, file_lights, warnings) = load_scene(settings)?;
        let surfaces = surfaces_of(settings, &scene)?;
        let mut built = build_lights(settings, &scene.bounds, surfaces.as_deref(), &scene.lights)?;
        if let Some(demo) = settings.demo {
            demo.recolour(&mut built.lights[file_lights..], (scene.bounds.min, scene.bounds.max));
        }
        let (camera, camera_source) = choose_camera(settings, scene.camera.as_ref(), &scene.bounds)?;
        Ok(Self {
            scene,
            lights: built.lights,
            file_lights,
            camera,
            camera_source,
            surfaces,
            surface_placement: built.surface_placement,
            fitted: built.fitted,
            warnings,
        })
    }
}

/// The scene's surfaces, sampled by area, when the settings place lights on them.
pub(crate) fn surfaces_of(settings: &Settings, scene: &Scene) -> Result<Surfaces> {
    if !settings.placement.on_surfaces() {
        return Ok(None);
    }
    let sampler = SurfaceSampler::of_scene(scene).context("placing lights on the surfaces (--lights-on-surfaces)")?;
    Ok(Some(Arc::new(sampler)))
}

/// The scene `settings` draw, without lights or camera (nor the load warnings, which
/// [`SceneCpu::load`] reports): what the lab casts its CPU shadow rays against when it
/// explains a worst pixel.
pub fn scene_of(settings: &Settings) -> Result<Scene> {
    Ok(load_scene(settings)?.0)
}

/// Loads or builds the scene; returns it with the number of lights it brought along and
/// the loader's warnings.
fn load_scene(settings: &Settings) -> Result<(Scene, usize, Vec<String>)> {
    match &settings.scene {
        SceneSource::Default => {
            let opts = DefaultSceneOptions {
                grid_objects: settings.grid_objects,
                density: settings.density,
                transparent_objects: settings.transparent_objects,
                emissive_banners: settings.emissive,
            };
            let mut scene = default_scene(&opts).context("building the default scene")?;
            if let Some(demo) = settings.demo {
                demo.dress(&mut scene).with_context(|| format!("dressing the courtyard for --demo {}", demo.name()))?;
            }
            // A demo's own lights count as the scene's (they come first, as a file's).
            let n = scene.lights.len();
            Ok((scene, n, Vec::new()))
        }
        SceneSource::Materials => {
            let scene = tiledlight_scene::materials::materials_scene(settings.materials)
                .context("building the many-material scene")?;
            let n = scene.lights.len();
            Ok((scene, n, Vec::new()))
        }
        SceneSource::Peer(p) => {
            let scene = p.build();
            let n = scene.lights.len();
            Ok((scene, n, Vec::new()))
        }
        SceneSource::File(path) => {
            let options = LoadOptions {
                strict: settings.strict,
                allow_any_path: settings.allow_any_path,
                ..LoadOptions::new(settings.threshold)
            };
            let loaded = load_gltf_with(path, &options).context("loading the scene")?;
            let n = loaded.scene.lights.len();
            Ok((loaded.scene, n, loaded.warnings))
        }
    }
}

/// The scene's own lights followed by the random ones asked for: point lights in `bounds`
/// or on `surfaces` (which must be given when the settings place lights on surfaces),
/// then spot lights (near the surfaces for a loaded scene whose lights go on surfaces, in
/// `bounds` otherwise). A loaded scene's lights in `bounds` get radii fitted to it
/// ([`fitted_intensity_range`], for [`DEFAULT_LIGHTS_PER_POINT`]); the built-in courtyard's
/// get TiledLighting11's ([`DEFAULT_INTENSITY_RANGE`]). Also how they were made.
pub(crate) fn build_lights(
    settings: &Settings,
    bounds: &Aabb,
    surfaces: Option<&SurfaceSampler>,
    scene_lights: &[Light],
) -> Result<BuiltLights> {
    let file_lights = scene_lights.len();
    let (points, spots) = settings.random_light_counts();
    let total = file_lights as u64 + points + spots;
    ensure!(
        total <= MAX_LIGHTS,
        "{file_lights} lights from the scene plus {} random: at most {MAX_LIGHTS} lights are supported",
        points + spots
    );
    let fit = matches!(settings.scene, SceneSource::File(_));
    let mut lights = scene_lights.to_vec();
    let mut placement = None;
    let mut fitted = FittedLights::default();
    let on_surfaces = settings.surface_light_options().filter(|o| o.count > 0);
    if let Some(opts) = on_surfaces {
        let sampler = surfaces.context("internal: surface lights asked for without the scene's surfaces")?;
        let out = sampler.lights(&opts).context("placing lights on the surfaces (--lights-on-surfaces)")?;
        placement = Some(SurfacePlacement {
            count: out.lights.len(),
            lights_per_point: opts.lights_per_point,
            radius: out.radius,
            area: out.area,
        });
        lights.extend(out.lights);
    }
    let random_points = if on_surfaces.is_some() { 0 } else { points };
    // A loaded scene's spot lights go near its surfaces with its point lights; the
    // courtyard's stay in its bounds (its benchmarks' lights).
    let surface_spots = fit && settings.placement.on_surfaces() && spots > 0;
    let boxed_spots = if surface_spots { 0 } else { spots };
    let boxed = random_points + boxed_spots;
    if boxed > 0 {
        let count = boxed as u32; // validate() capped it at MAX_LIGHTS (2^20).
        let intensity_range = if fit {
            fitted_intensity_range(bounds, count, DEFAULT_LIGHTS_PER_POINT, settings.threshold).with_context(|| {
                format!(
                    "fitting {count} random lights to the scene's bounds {:?}..{:?}: they have no size",
                    bounds.min, bounds.max
                )
            })?
        } else {
            DEFAULT_INTENSITY_RANGE
        };
        let opts = LightOptions {
            num_point: random_points as u32,
            num_spot: boxed_spots as u32,
            seed: settings.seed,
            threshold: settings.threshold,
            intensity_range,
        };
        let made = random_lights(bounds, &opts).context("generating random lights")?;
        if fit {
            let radii = made.iter().fold((f32::MAX, 0f32), |(a, b), l| (a.min(l.radius), b.max(l.radius)));
            fitted.bounds = Some(BoundsFit {
                count: made.len(),
                lights_per_point: DEFAULT_LIGHTS_PER_POINT,
                radius: bounds_light_radius(bounds, count, DEFAULT_LIGHTS_PER_POINT),
                radii,
                size: bounds.size(),
            });
        }
        lights.extend(made);
    }
    if surface_spots {
        let sampler = surfaces.context("internal: surface spot lights asked for without the scene's surfaces")?;
        let k = match settings.placement {
            crate::settings::LightPlacement::Surfaces { lights_per_point } => lights_per_point,
            crate::settings::LightPlacement::Bounds => DEFAULT_LIGHTS_PER_POINT,
        };
        let opts = SurfaceLightOptions {
            count: spots as u32,
            lights_per_point: k,
            seed: settings.seed,
            threshold: settings.threshold,
            offset: DEFAULT_SPOT_OFFSET,
        };
        let out = sampler.spot_lights(&opts).context("placing spot lights near the surfaces")?;
        fitted.spots =
            Some(SpotPlacement { count: out.lights.len(), lights_per_point: k, radius: out.radius, area: out.area });
        lights.extend(out.lights);
    }
    Ok(BuiltLights { lights, surface_placement: placement, fitted })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scene_gets_its_random_lights_and_a_framing_camera() {
        let s = Settings { width: 64, height: 36, lights: Some(10), spot_lights: Some(3), ..Settings::default() };
        let cpu = SceneCpu::load(&s).unwrap();
        assert_eq!(cpu.file_lights, 0);
        assert_eq!(LightSummary::of(&cpu.lights, 0), LightSummary { point: 10, spot: 3, from_file: 0, random: 13 });
        assert!(!cpu.camera_source.is_empty());
        // The same settings give the same lights.
        assert_eq!(SceneCpu::load(&s).unwrap().lights, cpu.lights);
    }

    #[test]
    fn surface_lights_replace_the_random_point_lights() {
        use crate::settings::LightPlacement;
        let s = Settings {
            width: 64,
            height: 36,
            lights: Some(5000),
            spot_lights: Some(3),
            placement: LightPlacement::SURFACES,
            ..Settings::default()
        };
        let cpu = SceneCpu::load(&s).unwrap();
        assert_eq!(LightSummary::of(&cpu.lights, 0), LightSummary { point: 5000, spot: 3, from_file: 0, random: 5003 });
        let p = cpu.surface_placement.unwrap();
        assert_eq!((p.count, p.lights_per_point), (5000, crate::settings::DEFAULT_LIGHTS_PER_POINT));
        assert!(cpu.lights[..5000].iter().all(|l| (l.radius - p.radius).abs() < 1e-4 * p.radius));
        assert!(p.to_string().starts_with("5000 on the surfaces ("), "{p}");
        // The spot lights are the ones the bounds placement gives.
        let boxed = SceneCpu::load(&Settings { placement: LightPlacement::Bounds, ..s.clone() }).unwrap();
        assert_eq!(boxed.lights[5000..], cpu.lights[5000..]);
        assert!(boxed.surface_placement.is_none() && boxed.surfaces.is_none());
        // No lights at all on the surfaces: nothing placed, no error.
        let none = SceneCpu::load(&Settings { lights: Some(0), spot_lights: None, ..s }).unwrap();
        assert!(none.lights.is_empty() && none.surface_placement.is_none());
    }

    /// Every benchmark is measured with the courtyard's random lights: they must stay
    /// TiledLighting11's uniform lights with radii 1.5-4 m, whatever fits loaded scenes.
    #[test]
    fn the_courtyard_keeps_exactly_its_lights() {
        let s = Settings { width: 64, height: 36, spot_lights: Some(256), ..Settings::default() };
        let cpu = SceneCpu::load(&s).unwrap();
        let legacy = LightOptions {
            num_point: 1024,
            num_spot: 256,
            seed: 1,
            threshold: tiledlight_scene::DEFAULT_LIGHT_THRESHOLD,
            intensity_range: DEFAULT_INTENSITY_RANGE,
        };
        assert_eq!(cpu.lights, random_lights(&cpu.scene.bounds, &legacy).unwrap());
        assert!(cpu.surface_placement.is_none() && cpu.fitted == FittedLights::default());
        // Pinned: the sums of the lights' positions and radii at seed 1 (printed by this
        // test), so a change of the generator itself is caught too.
        let pos: f64 = cpu.lights.iter().map(|l| f64::from(l.position.x + l.position.y + l.position.z)).sum();
        let radii: f64 = cpu.lights.iter().map(|l| f64::from(l.radius)).sum();
        println!("courtyard lights: position sum {pos:.3}, radius sum {radii:.3}");
        assert!((pos - PINNED_POSITION_SUM).abs() < 0.01 && (radii - PINNED_RADIUS_SUM).abs() < 0.01, "{pos} {radii}");
        // Its summary says so as before.
        let p = crate::prepared::lights_description(
            &LightSummary::of(&cpu.lights, 0),
            &s,
            cpu.surface_placement.as_ref(),
            &cpu.fitted,
        );
        assert_eq!(p, " (random, seed 1, threshold 0.1)");
    }

    const PINNED_POSITION_SUM: f64 = 7941.070;
    const PINNED_RADIUS_SUM: f64 = 3764.666;

    /// The 12 triangles of the cube `0..side`, front faces outward.
    fn cube(side: f32) -> (Aabb, SurfaceSampler) {
        use glam::Vec3;
        let (lo, hi) = (Vec3::ZERO, Vec3::splat(side));
        let c = |i: u32| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * side;
        // Each face as corner indices (bit 0: x, bit 1: y, bit 2: z), counter-clockwise
        // seen from outside.
        let faces = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
        let mut tris = Vec::new();
        for f in faces {
            tris.push([c(f[0]), c(f[1]), c(f[2])]);
            tris.push([c(f[0]), c(f[2]), c(f[3])]);
        }
        let centre = Vec3::splat(side / 2.0);
        for t in &tris {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            assert!(n.dot(t[0] - centre) > 0.0, "test cube: a face looks inward");
        }
        (Aabb::new(lo, hi), SurfaceSampler::new(tris).unwrap())
    }

    #[test]
    fn a_loaded_scene_s_lights_scale_with_its_size() {
        use crate::settings::LightPlacement;
        let file = Settings {
            scene: SceneSource::File("model.glb".into()),
            lights: Some(64),
            spot_lights: Some(16),
            ..Settings::default()
        };
        for placement in [LightPlacement::SURFACES, LightPlacement::Bounds] {
            let s = Settings { placement, ..file.clone() };
            let ((b2, s2), (b100, s100)) = (cube(2.0), cube(100.0));
            let small = build_lights(&s, &b2, Some(&s2), &[]).unwrap();
            let large = build_lights(&s, &b100, Some(&s100), &[]).unwrap();
            assert_eq!((small.lights.len(), large.lights.len()), (80, 80));
            for (a, b) in small.lights.iter().zip(&large.lights) {
                assert_eq!(a.is_spot(), b.is_spot());
                assert!(
                    (b.radius / a.radius - 50.0).abs() < 50.0 * 1e-3,
                    "{placement:?}: {} vs {}",
                    a.radius,
                    b.radius
                );
                // The irradiance a light gives at a scaled distance stays (I / r^2 is the same).
                let (ia, ib) = (a.intensity / a.radius.powi(2), b.intensity / b.radius.powi(2));
                assert!((ia / ib - 1.0).abs() < 1e-3, "{ia} {ib}");
            }
            // Not the courtyard's 1.5-4 m: a 2 m cube's point lights reach about a metre.
            assert!(small.lights.iter().filter(|l| !l.is_spot()).all(|l| l.radius < 1.5), "{placement:?}");
            let summary = LightSummary::of(&small.lights, 0);
            let text =
                crate::prepared::lights_description(&summary, &s, small.surface_placement.as_ref(), &small.fitted);
            println!("{placement:?}: lights: {} point, {} spot{text}", summary.point, summary.spot);
            assert!(text.starts_with(" (random, seed 1, threshold 0.1"), "{text}");
            if placement.on_surfaces() {
                assert!(text.contains("; point lights: 64 on the surfaces (24 m^2"), "{text}");
                assert!(text.contains("; spot lights: 16 near the surfaces aiming at them (24 m^2"), "{text}");
                let spots = small.fitted.spots.unwrap();
                assert!(text.contains(&format!("radius {:.3} m for k = 8 pools", spots.radius)), "{text}");
                assert!(small.fitted.bounds.is_none());
                // Spots sit outside the cube (its faces look out), points too.
                assert!(small.lights.iter().all(
                    |l| l.position.cmplt(glam::Vec3::ZERO).any() || l.position.cmpgt(glam::Vec3::splat(2.0)).any()
                ));
            } else {
                let fit = small.fitted.bounds.unwrap();
                assert_eq!(fit.count, 80);
                let expect = format!(
                    "; 80 uniform in the bounds (2.0 x 2.0 x 2.0 m), radii {:.3}-{:.3} m, fitted to the bounds and \
                     the count for k = 8 lights per surface point)",
                    fit.radii.0, fit.radii.1
                );
                assert!(text.ends_with(&expect), "{text}");
                assert!(small.fitted.spots.is_none() && small.surface_placement.is_none());
            }
        }
        // A glTF file's own lights come first, and the summary counts them.
        let own = build_lights(&file, &cube(2.0).0, Some(&cube(2.0).1), &[]).unwrap();
        let with_own = LightSummary { point: 65, spot: 16, from_file: 1, random: 80 };
        let text = crate::prepared::lights_description(&with_own, &file, None, &own.fitted);
        assert!(
            text.starts_with(" (1 from the glTF file + 80 random, seed 1, threshold 0.1; 80 uniform in the bounds"),
            "{text}"
        );
    }

    #[test]
    fn emissive_banners_reach_the_default_scene() {
        let s = Settings { width: 64, height: 36, lights: Some(4), ..Settings::default() };
        assert!(!SceneCpu::load(&s).unwrap().scene.materials.iter().any(|m| m.is_emissive()));
        let lit = SceneCpu::load(&Settings { emissive: true, ..s.clone() }).unwrap();
        assert_eq!(lit.scene.materials.iter().filter(|m| m.is_emissive()).count(), 3);
        let file = Settings { emissive: true, scene: SceneSource::File("a.glb".into()), ..s };
        let e = format!("{:#}", SceneCpu::load(&file).err().unwrap());
        assert!(e.contains("--emissive: the glowing banners exist only in the default scene"), "{e}");
    }

    #[test]
    fn transparent_objects_reach_the_default_scene() {
        let s = Settings { width: 64, height: 36, lights: Some(4), grid_objects: 50, ..Settings::default() };
        assert!(!SceneCpu::load(&s).unwrap().scene.has_blend());
        let glass = Settings { transparent_objects: 20, ..s };
        assert!(SceneCpu::load(&glass).unwrap().scene.has_blend());
    }

    #[test]
    fn settings_errors_come_before_any_loading() {
        let s = Settings { scene: SceneSource::File("/nonexistent.glb".into()), width: 0, ..Settings::default() };
        let e = format!("{:#}", SceneCpu::load(&s).err().unwrap());
        assert!(e.contains("--width 0"), "{e}");
        let s = Settings { scene: SceneSource::File("/nonexistent.glb".into()), ..Settings::default() };
        let e = format!("{:#}", SceneCpu::load(&s).err().unwrap());
        assert!(e.contains("loading the scene"), "{e}");
    }
}
