//! What a change of [`Settings`] must rebuild, decided in one place ([`rebuild_plan`])
//! and returned as a value ([`Rebuild`]) that `Prepared::reconfigure` carries out and the
//! viewer and the lab read:
//!
//! | changed | reload | camera | renderer |
//! | --- | --- | --- | --- |
//! | scene, grid objects, density, transparent objects, emissive banners (threshold, strict, allow-any-path of a glTF scene), lights on surfaces on/off | scene + all lights | yes | yes |
//! | random point/spot light counts | new light buffers (bind groups and list capacity follow the count) | | yes |
//! | shadow-casting point/spot light counts | new light buffers (the casters are ordered first) | | yes |
//! | seed, threshold, lights per surface point (same counts); how casters are chosen (while some light casts a shadow); with casters chosen by contribution, the camera or screen | light data rewritten in place (renderers with shadows are told: `Renderer::lights_moved`) | | |
//! | camera bookmark | | yes | |
//! | width, height | | yes (aspect ratio) | yes |
//! | method, tile size, capacity, light-grid budget, culling tests, half-z, G-buffer targets, MSAA, edge test | | | yes |
//! | shadow tile size, filter, format (while some light casts a shadow; unused otherwise) | | | yes |
//! | blend mode (while the scene may have blended geometry: transparent objects or a glTF file; unused otherwise) | | | yes |
//! | exposure | | | no: `exposure` (the tonemap pass's uniform is rewritten) |
//! | automatic exposure on/off | | yes | |
//!
//! Pure data: depends on [`crate::settings`] and [`crate::table`] (each row's
//! [`Rebuilds`]).

use crate::settings::{CasterChoice, SceneSource, Settings};
use crate::table::Rebuilds;
use tiledlight_gpu::knobs::Needs;

/// What is loaded or generated again, from the least to the most work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Reload {
    /// Scene and lights stay as they are.
    #[default]
    Nothing,
    /// The random lights are generated again with the same counts and written over the
    /// existing light buffers: renderers built before stay valid (with shadow casters, give
    /// them the new lights: `Renderer::lights_moved`).
    LightData,
    /// The random lights are generated again with other counts into new light buffers:
    /// renderers built before must be rebuilt.
    LightBuffers,
    /// The scene is loaded (or generated) again, with all its lights and its camera.
    Scene,
}

/// What going from one [`Settings`] to another rebuilds ([`rebuild_plan`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Rebuild {
    /// Scene and lights.
    pub reload: Reload,
    /// The camera is chosen again (the bookmark, the scene's own, or one framing the
    /// scene) at the new aspect ratio.
    pub camera: bool,
    /// Renderers built before no longer fit: build a new one.
    pub renderer: bool,
    /// Only the exposure changed for the renderer: set it (`Renderer::set_exposure`), nothing
    /// is rebuilt (a new renderer is built with the new exposure anyway).
    pub exposure: bool,
}

impl Rebuild {
    /// True when nothing needs rebuilding.
    pub fn is_nothing(&self) -> bool {
        *self == Rebuild::default()
    }
}

/// Whether a row that `needs` this is read by the frame of `s`: the shadow rows while
/// some light casts a shadow, the blend mode while the scene may blend.
fn read_now(needs: Needs, s: &Settings) -> bool {
    match needs {
        Needs::Always => true,
        Needs::Shadows => s.has_shadows(),
        Needs::Blended => s.may_blend(),
    }
}

/// What going from `old` to `new` must rebuild (see the module's table): each changed row
/// of the run settings' table by its [`Rebuilds`], each changed pass setting the frame
/// reads, then the settings that are not rows.
pub fn rebuild_plan(old: &Settings, new: &Settings) -> Rebuild {
    let (a, b) = (old, new);
    let file_scene = matches!(b.scene, SceneSource::File(_));
    let (mut reload, mut screen, mut renderer) = (Reload::Nothing, false, false);
    for row in a.changed_rows(b) {
        let (row_reload, row_screen, row_renderer) = match row.rebuild {
            Rebuilds::Scene => (Reload::Scene, false, false),
            // A glTF file's own lights get their radii from the threshold when it is loaded,
            // and its load reads the input checks.
            Rebuilds::SceneOfFile => (if file_scene { Reload::Scene } else { Reload::Nothing }, false, false),
            Rebuilds::SceneOfFileElseLightData => {
                (if file_scene { Reload::Scene } else { Reload::LightData }, false, false)
            }
            // Counts given that equal the defaults (or casters beyond the lights) are the same lights.
            Rebuilds::LightBuffers => {
                let same =
                    a.random_light_counts() == b.random_light_counts() && a.shadow_casters() == b.shadow_casters();
                (if same { Reload::Nothing } else { Reload::LightBuffers }, false, false)
            }
            Rebuilds::LightData => (Reload::LightData, false, false),
            Rebuilds::Casters => (if b.has_shadows() { Reload::LightData } else { Reload::Nothing }, false, false),
            Rebuilds::Screen => (Reload::Nothing, true, false),
            Rebuilds::Renderer => (Reload::Nothing, false, true),
        };
        (reload, screen, renderer) = (reload.max(row_reload), screen || row_screen, renderer || row_renderer);
    }
    // A demo places its own lights, camera and props when the scene is built; the surfaces
    // are sampled when the scene is loaded (kept while lights are on them), and another
    // density of surface lights keeps the counts (the light data is rewritten).
    if a.demo != b.demo || a.placement.on_surfaces() != b.placement.on_surfaces() {
        reload = Reload::Scene;
    } else if a.placement != b.placement {
        reload = reload.max(Reload::LightData);
    }
    let camera = reload == Reload::Scene || screen || a.camera != b.camera;
    // Casters chosen by contribution are ranked from a frame of the camera: a new camera or
    // screen chooses them again (same counts: the light data is rewritten).
    if b.has_shadows() && b.casters_by == CasterChoice::Contribution && camera {
        reload = reload.max(Reload::LightData);
    }
    let renderer = renderer
        || reload >= Reload::LightBuffers
        || screen
        || a.grid_pairs != b.grid_pairs
        // The cluster options (the grid row says whether there are clusters).
        || a.clusters != b.clusters
        // A pass setting (a row of the table) the new frame reads: the shadow rows only
        // while some light casts a shadow.
        || a.knobs.changed(&b.knobs).iter().any(|k| (k.applies)(b.method.traits()) && read_now(k.needs, b))
        // Automatic exposure is a pass and a tonemap variant of its own.
        || a.auto_exposure != b.auto_exposure
        // VPLs are passes, buffers and a shading variant of their own.
        || a.vpl != b.vpl;
    Rebuild { reload, camera, renderer, exposure: !b.auto_exposure && a.exposure != b.exposure }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{CameraBookmark, Method};
    use glam::Vec3;
    use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat};
    use tiledlight_gpu::culling::ClusterOptions;
    use tiledlight_gpu::features::BlendMode;
    use tiledlight_gpu::knobs::{Kind, Knobs, KNOBS};
    use tiledlight_scene::{CameraDesc, GridDensity};

    fn base() -> Settings {
        Settings { width: 320, height: 180, ..Settings::default() }
    }

    fn with(f: impl FnOnce(&mut Settings)) -> Rebuild {
        with_from(base(), f)
    }

    fn with_from(old: Settings, f: impl FnOnce(&mut Settings)) -> Rebuild {
        let mut new = old.clone();
        f(&mut new);
        rebuild_plan(&old, &new)
    }

    const RENDERER: Rebuild = Rebuild { reload: Reload::Nothing, camera: false, renderer: true, exposure: false };

    #[test]
    fn nothing_changed_rebuilds_nothing() {
        assert!(with(|_| {}).is_nothing());
        // The default light count, given explicitly, is the same lights.
        assert!(with(|s| s.lights = Some(1024)).is_nothing());
    }

    #[test]
    fn surface_lights_reload_the_scene_only_when_switched() {
        use crate::settings::LightPlacement;
        let on = with(|s| s.placement = LightPlacement::SURFACES);
        assert_eq!((on.reload, on.camera, on.renderer), (Reload::Scene, true, true));
        let surfaces = Settings { placement: LightPlacement::SURFACES, ..base() };
        let off = with_from(surfaces.clone(), |s| s.placement = LightPlacement::Bounds);
        assert_eq!(off.reload, Reload::Scene);
        // Another k keeps the counts: the light data is rewritten in place.
        let k = with_from(surfaces, |s| s.placement = LightPlacement::Surfaces { lights_per_point: 2.0 });
        assert_eq!(k, Rebuild { reload: Reload::LightData, ..Rebuild::default() });
    }

    #[test]
    fn renderer_settings_rebuild_only_the_renderer() {
        for f in [
            (|s: &mut Settings| s.method = Method::TiledDeferred) as fn(&mut Settings),
            |s| s.tile_size = 32,
            |s| s.capacity = Some(64),
            |s| s.aabb = true,
            |s| s.half_z = true,
            |s| s.spot_cone = true,
            |s| s.flat_cull = true,
            |s| s.msaa = 4,
            |s| s.grid_pairs = Some(1 << 20),
            |s| s.depth_mask = true,
            |s| s.scatter = true,
            |s| s.clusters = Some(ClusterOptions::default()),
        ] {
            assert_eq!(with(f), RENDERER);
        }
    }

    /// A value of a row of either table other than its default `default`.
    fn other_value(kind: Kind, default: &str) -> String {
        match kind {
            Kind::Count if default == tiledlight_gpu::knobs::AUTO => "7".to_string(),
            Kind::Switch => if default == "on" { "off" } else { "on" }.to_string(),
            Kind::Count => (default.parse::<u64>().unwrap() + 1).to_string(),
            Kind::Number => (default.parse::<f32>().unwrap() + 0.5).to_string(),
            Kind::Choice(names) | Kind::Values(names) => names.iter().find(|n| **n != default).unwrap().to_string(),
            Kind::Text => "materials".to_string(),
        }
    }

    /// Every row of the run settings' table rebuilds what its [`Rebuilds`] says when it
    /// changes on the default scene with shadows (no row rebuilds nothing there but the
    /// input checks, which only a glTF file's load reads).
    #[test]
    fn run_settings_rebuild_what_their_rows_say() {
        let from = Settings { shadow_point_lights: 2, ..base() };
        for r in crate::table::SETTINGS {
            let mut to = from.clone();
            (r.set)(&mut to, &other_value(r.kind, &(r.default)())).unwrap();
            let got = rebuild_plan(&from, &to);
            let scene = Rebuild { reload: Reload::Scene, camera: true, renderer: true, exposure: false };
            let want = match r.rebuild {
                Rebuilds::Scene => scene,
                Rebuilds::SceneOfFile => Rebuild::default(),
                Rebuilds::SceneOfFileElseLightData => Rebuild { reload: Reload::LightData, ..Rebuild::default() },
                Rebuilds::LightBuffers => {
                    Rebuild { reload: Reload::LightBuffers, renderer: true, ..Rebuild::default() }
                }
                Rebuilds::LightData | Rebuilds::Casters => Rebuild { reload: Reload::LightData, ..Rebuild::default() },
                Rebuilds::Screen => Rebuild { camera: true, renderer: true, ..Rebuild::default() },
                Rebuilds::Renderer => RENDERER,
            };
            assert_eq!(got, want, "{}", r.name);
            // A glTF scene reloads for the rows its load reads.
            if matches!(r.rebuild, Rebuilds::SceneOfFile | Rebuilds::SceneOfFileElseLightData) {
                let file = Settings { scene: SceneSource::File("a.glb".into()), ..from.clone() };
                let mut to = file.clone();
                (r.set)(&mut to, &other_value(r.kind, &(r.default)())).unwrap();
                assert_eq!(rebuild_plan(&file, &to), scene, "{} of a file", r.name);
            }
        }
    }

    /// Every row of the pass settings' table rebuilds the renderer of a method it applies
    /// to, and nothing for a method that ignores it.
    #[test]
    fn pass_settings_rebuild_the_renderer_of_the_methods_they_apply_to() {
        for k in KNOBS {
            let other = other_value(k.kind, &(k.default)());
            let mut changed = Knobs::default();
            (k.set)(&mut changed, &other).unwrap();
            // Each method with and without casters, with and without glass.
            let cases = Method::ALL.into_iter().flat_map(|m| [(m, 0, 0), (m, 2, 0), (m, 0, 5), (m, 2, 5)]);
            for (method, casters, glass) in cases {
                let from = Settings {
                    method,
                    shadow_point_lights: casters,
                    grid_objects: 10,
                    transparent_objects: glass,
                    ..base()
                };
                let to = Settings { knobs: changed, ..from.clone() };
                let needed = match k.needs {
                    Needs::Always => true,
                    Needs::Shadows => casters > 0,
                    Needs::Blended => glass > 0,
                };
                let want = if (k.applies)(method.traits()) && needed { RENDERER } else { Rebuild::default() };
                assert_eq!(
                    rebuild_plan(&from, &to),
                    want,
                    "{} = {other} with {}, {casters} casters, {glass} glass objects",
                    k.name,
                    method.name()
                );
            }
        }
    }

    #[test]
    fn shadow_casters_reupload_the_lights_and_rebuild_the_renderer() {
        let buffers = Rebuild { reload: Reload::LightBuffers, ..RENDERER };
        assert_eq!(with(|s| s.shadow_point_lights = 8), buffers);
        assert_eq!(with(|s| (s.spot_lights, s.shadow_spot_lights) = (Some(8), 4)), buffers);
        let shadowed = Settings { spot_lights: Some(8), shadow_point_lights: 2, shadow_spot_lights: 2, ..base() };
        assert_eq!(with_from(shadowed.clone(), |s| s.shadow_spot_lights = 0), buffers);
        assert_eq!(with_from(shadowed, |s| s.shadow_point_lights = 0), buffers);
    }

    #[test]
    fn shadow_options_rebuild_the_renderer_while_lights_cast_shadows() {
        let shadowed = Settings { shadow_point_lights: 2, ..base() };
        for f in [
            (|s: &mut Settings| s.knobs.shadow_size = 512) as fn(&mut Settings),
            |s| s.knobs.shadow_filter = ShadowFilter::Pcf3,
            |s| s.knobs.shadow_format = ShadowFormat::Depth32,
        ] {
            assert_eq!(with_from(shadowed.clone(), f), RENDERER);
            // Without casters the renderer does not use them.
            assert!(with(f).is_nothing());
        }
        // Casters and how they are drawn, together: both.
        let both = with(|s| (s.shadow_point_lights, s.knobs.shadow_size) = (2, 1024));
        assert_eq!(both, Rebuild { reload: Reload::LightBuffers, ..RENDERER });
        // New light data with the same casters: in place (the renderer is told, not rebuilt).
        assert_eq!(with_from(Settings { shadow_point_lights: 2, ..base() }, |s| s.seed = 4).reload, Reload::LightData);
    }

    #[test]
    fn the_caster_choice_rewrites_the_light_data_while_lights_cast_shadows() {
        let by = |c| move |s: &mut Settings| s.casters_by = c;
        let shadowed = Settings { shadow_point_lights: 2, ..base() };
        let data = with_from(shadowed.clone(), by(CasterChoice::Contribution));
        assert_eq!((data.reload, data.renderer), (Reload::LightData, false));
        assert!(with(by(CasterChoice::Contribution)).is_nothing(), "no casters: nothing to choose");
        // By contribution, a new camera or screen ranks the lights again.
        let ranked = Settings { casters_by: CasterChoice::Contribution, ..shadowed.clone() };
        let moved = with_from(ranked.clone(), |s| s.width = 640);
        assert_eq!((moved.reload, moved.camera), (Reload::LightData, true));
        // Brightest-first does not depend on the camera.
        assert_eq!(with_from(shadowed, |s| s.width = 640).reload, Reload::Nothing);
    }

    #[test]
    fn vpls_rebuild_the_renderer() {
        let vpl = Some(tiledlight_cull::vpl::VplConfig::default());
        let casters = Settings { spot_lights: Some(4), shadow_spot_lights: 2, ..base() };
        assert_eq!(with_from(casters.clone(), |s| s.vpl = vpl), RENDERER);
        let on = Settings { vpl, ..casters };
        assert_eq!(with_from(on, |s| s.vpl = vpl.map(|v| tiledlight_cull::vpl::VplConfig { block: 4, ..v })), RENDERER);
    }

    #[test]
    fn blend_mode_rebuilds_the_renderer_while_the_scene_may_blend() {
        let wboit = |s: &mut Settings| s.knobs.blend_mode = BlendMode::WeightedOit;
        let glass = Settings { grid_objects: 50, transparent_objects: 20, ..base() };
        assert_eq!(with_from(glass.clone(), wboit), RENDERER);
        let back = Settings { knobs: Knobs { blend_mode: BlendMode::WeightedOit, ..glass.knobs }, ..glass };
        assert_eq!(with_from(back, |s| s.knobs.blend_mode = BlendMode::Sorted), RENDERER);
        // A glTF file's blended materials are found when it loads: rebuilt too.
        assert_eq!(with_from(Settings { scene: SceneSource::File("a.glb".into()), ..base() }, wboit), RENDERER);
        // Without blended geometry the renderer does not use it.
        assert!(with(wboit).is_nothing());
        assert!(with_from(Settings { grid_objects: 50, ..base() }, wboit).is_nothing());
    }

    #[test]
    fn exposure_rebuilds_nothing() {
        assert_eq!(with(|s| s.exposure = 2.0), Rebuild { exposure: true, ..Rebuild::default() });
        assert!(!with(|s| s.exposure = 2.0).renderer);
        // Switching automatic exposure on or off rebuilds the renderer (its pass and variant).
        assert!(with(|s| s.auto_exposure = true).renderer);
    }

    #[test]
    fn screen_size_rebuilds_renderer_and_camera() {
        assert_eq!(with(|s| s.width = 640), Rebuild { camera: true, ..RENDERER });
        assert_eq!(with(|s| s.height = 640), Rebuild { camera: true, ..RENDERER });
    }

    #[test]
    fn lights_are_rewritten_in_place_when_their_counts_stay() {
        let data = Rebuild { reload: Reload::LightData, ..Rebuild::default() };
        assert_eq!(with(|s| s.seed = 9), data);
        assert_eq!(with(|s| s.threshold *= 2.0), data);
        let buffers = Rebuild { reload: Reload::LightBuffers, ..RENDERER };
        assert_eq!(with(|s| s.lights = Some(7)), buffers);
        assert_eq!(with(|s| s.spot_lights = Some(7)), buffers);
        assert_eq!(with(|s| (s.lights, s.seed) = (Some(7), 3)), buffers);
        // Light data and a renderer setting together: both.
        assert_eq!(with(|s| (s.seed, s.half_z) = (3, true)), Rebuild { reload: Reload::LightData, ..RENDERER });
    }

    #[test]
    fn scene_settings_reload_everything() {
        let scene = Rebuild { reload: Reload::Scene, camera: true, renderer: true, exposure: false };
        assert_eq!(with(|s| s.grid_objects = 10), scene);
        assert_eq!(with(|s| s.density = GridDensity::High), scene);
        // The many-material scene at another count (a lab sweep over `materials`).
        let materials = Settings { scene: SceneSource::Materials, ..base() };
        assert_eq!(with_from(materials, |s| s.materials = 16), scene);
        assert_eq!(with_from(Settings { grid_objects: 50, ..base() }, |s| s.transparent_objects = 20), scene);
        let glass = Settings { grid_objects: 50, transparent_objects: 20, ..base() };
        assert_eq!(with_from(glass.clone(), |s| s.transparent_objects = 0), scene);
        // A new count and a new mode together: the scene (and so the renderer).
        assert_eq!(
            with_from(glass, |s| (s.transparent_objects, s.knobs.blend_mode) = (10, BlendMode::WeightedOit)),
            scene
        );
        assert_eq!(with(|s| s.scene = SceneSource::File("a.glb".into())), scene);
        assert_eq!(with(|s| (s.scene, s.seed) = (SceneSource::File("a.glb".into()), 5)), scene);
    }

    #[test]
    fn threshold_of_a_gltf_scene_reloads_it() {
        let gltf = Settings { scene: SceneSource::File("a.glb".into()), ..base() };
        assert_eq!(with_from(gltf, |s| s.threshold *= 2.0).reload, Reload::Scene);
    }

    #[test]
    fn how_a_gltf_file_is_loaded_reloads_it() {
        let gltf = Settings { scene: SceneSource::File("a.glb".into()), ..base() };
        assert_eq!(with_from(gltf.clone(), |s| s.strict = true).reload, Reload::Scene);
        assert_eq!(with_from(gltf, |s| s.allow_any_path = true).reload, Reload::Scene);
        // The procedural scene reads no file: nothing to reload.
        assert_eq!(with(|s| (s.strict, s.allow_any_path) = (true, true)), Rebuild::default());
    }

    #[test]
    fn a_new_bookmark_only_moves_the_camera() {
        let desc = CameraDesc {
            eye: Vec3::new(0.0, 1.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 1.0,
            near: 0.1,
            far: None,
        };
        let bookmark = CameraBookmark { path: "cam.txt".into(), camera: desc };
        let moved = with(|s| s.camera = Some(bookmark.clone()));
        assert_eq!(moved, Rebuild { camera: true, ..Rebuild::default() });
        let mut other = bookmark.clone();
        other.camera.eye.x = 1.0;
        let from = Settings { camera: Some(bookmark), ..base() };
        assert_eq!(with_from(from, |s| s.camera = Some(other)), moved);
    }
}
