//! The CPU half of a run, built before any GPU work so that file and settings errors come
//! before the slow device creation: the scene (the procedural courtyard or a glTF file),
//! its lights (the file's own, then the random ones asked for: in the bounds, or point
//! lights on the scene's surfaces) and the camera ([`SceneCpu`]); and the light counts a
//! report shows ([`LightSummary`], [`SurfacePlacement`]).
//!
//! Depends on tiledlight-scene (scene model, procedural scene, glTF loading, light
//! generation), tiledlight-cull and [`crate::settings`] / [`crate::camera`]; no GPU work.

use std::sync::Arc;

use anyhow::{ensure, Context, Result};
use tiledlight_cull::{Camera, LightKind};
use tiledlight_scene::{
    default_scene, load_gltf_with, random_lights, Aabb, DefaultSceneOptions, Light, LightOptions, LoadOptions, Scene,
    SurfaceSampler, DEFAULT_INTENSITY_RANGE, MAX_LIGHTS,
};

use crate::camera::choose_camera;
use crate::settings::{SceneSource, Settings};

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
        let (lights, surface_placement) = build_lights(settings, &scene.bounds, surfaces.as_deref(), &scene.lights)?;
        let (camera, camera_source) = choose_camera(settings, scene.camera.as_ref(), &scene.bounds)?;
        Ok(Self { scene, lights, file_lights, camera, camera_source, surfaces, surface_placement, warnings })
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

/// Loads or builds the scene; returns it with the number of lights it brought along and
/// the loader's warnings.
fn load_scene(settings: &Settings) -> Result<(Scene, usize, Vec<String>)> {
    match &settings.scene {
        SceneSource::Default => {
            let opts = DefaultSceneOptions {
                grid_objects: settings.grid_objects,
                density: settings.density,
                transparent_objects: settings.transparent_objects,
            };
            let scene = default_scene(&opts).context("building the default scene")?;
            Ok((scene, 0, Vec::new()))
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
/// then spot lights in `bounds`. Also how the surface lights were made, if any.
pub(crate) fn build_lights(
    settings: &Settings,
    bounds: &Aabb,
    surfaces: Option<&SurfaceSampler>,
    scene_lights: &[Light],
) -> Result<(Vec<Light>, Option<SurfacePlacement>)> {
    let file_lights = scene_lights.len();
    let (points, spots) = settings.random_light_counts();
    let total = file_lights as u64 + points + spots;
    ensure!(
        total <= MAX_LIGHTS,
        "{file_lights} lights from the scene plus {} random: at most {MAX_LIGHTS} lights are supported",
        points + spots
    );
    let mut lights = scene_lights.to_vec();
    let mut placement = None;
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
    if random_points + spots > 0 {
        let opts = LightOptions {
            // Both fit: validate() capped them at MAX_LIGHTS (2^20).
            num_point: random_points as u32,
            num_spot: spots as u32,
            seed: settings.seed,
            threshold: settings.threshold,
            intensity_range: DEFAULT_INTENSITY_RANGE,
        };
        lights.extend(random_lights(bounds, &opts).context("generating random lights")?);
    }
    Ok((lights, placement))
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
