//! `Prepared::reconfigure` on a real device (lavapipe in CI), through a sequence of
//! changes on one GPU context: each returns the plan `rebuild_plan` gives, leaves the run
//! in the state a fresh load of the new settings has (lights, light counts, camera, scene,
//! settings), and a renderer built before a light-data change keeps working and draws the
//! new lights. A change that fails (a missing glTF file) changes nothing. Shadow casters
//! travel the same way: a caster change uploads new lights, a light-data change keeps the
//! renderer, which redraws every caster's faces once told (`Renderer::lights_moved`).
//! Transparent grid objects reload the scene and bring the blended path; the blend mode
//! rebuilds only the renderer.

use tiledlight_cull::light::{try_pack_lights_ranked, CasterRank};
use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat};
use tiledlight_frame::caster_rank::contribution_scores;
use tiledlight_frame::Diagnostics as _;
use tiledlight_gpu::features::BlendMode;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::GridDensity;
use tiledlight_setup::{
    rebuild_plan, CasterChoice, Method, Prepared, Rebuild, Reload, SceneCpu, SceneSource, Settings,
};

/// The run holds what loading `s` from scratch gives.
fn assert_matches_a_fresh_load(prep: &Prepared, s: &Settings) {
    let cpu = SceneCpu::load(s).unwrap();
    // Casters by contribution: ranked from a frame of the fresh load's camera.
    let scores = (s.casters_by == CasterChoice::Contribution && s.has_shadows()).then(|| {
        contribution_scores(&prep.ctx, &prep.scene_gpu, &cpu.lights, &cpu.camera, (s.width, s.height)).unwrap().scores
    });
    let rank = scores.as_deref().map_or(CasterRank::Brightest, CasterRank::Scores);
    let packed = try_pack_lights_ranked(&cpu.lights, s.shadow_casters(), rank).unwrap();
    let bytes = |p: &tiledlight_cull::light::PackedLights| {
        let mut b: Vec<u8> = bytemuck::cast_slice(&p.cull).to_vec();
        b.extend_from_slice(bytemuck::cast_slice(&p.shading));
        b.extend_from_slice(bytemuck::cast_slice(&p.spots));
        b
    };
    assert_eq!(bytes(&prep.lights.packed), bytes(&packed), "lights");
    assert_eq!(prep.lights.len() as usize, cpu.lights.len());
    assert_eq!((prep.lights.packed.shadow_points, prep.lights.packed.shadow_spots), s.shadow_casters());
    assert_eq!(prep.light_summary, tiledlight_setup::LightSummary::of(&cpu.lights, cpu.file_lights));
    assert_eq!(prep.camera.view_proj(), cpu.camera.view_proj(), "camera");
    assert_eq!(prep.camera_source, cpu.camera_source);
    assert_eq!((prep.scene_name.as_str(), prep.instances), (cpu.scene.name.as_str(), cpu.scene.instances.len()));
    assert_eq!(prep.requested(), s);
    assert!(prep.settings.capacity.is_some(), "the capacity is chosen for the lights");
    assert_eq!(Settings { capacity: s.capacity, ..prep.settings.clone() }, *s);
}

/// Two renderers drawing the same frame drew the same image. Bit-exact on lavapipe, which
/// runs a workgroup's threads in order, so every tile list is appended in the same order
/// and the lights are summed in the same order. A parallel GPU appends lights to a tile's
/// list atomically, in an order that varies between dispatches, and f32 sums in another
/// order can round to a neighbouring f16: there each channel may differ by two f16 ulps
/// relative (2^-9) above an absolute floor of 1e-4 (near-black pixels), far below what a
/// missing or stale light changes (the first `assert_ne!` above: other lights, another image).
fn assert_same_frame(ctx: &tiledlight_gpu::GpuContext, what: &str, a: &[[f32; 4]], b: &[[f32; 4]]) {
    assert_eq!(a.len(), b.len(), "{what}: frame sizes");
    if ctx.info.name.to_lowercase().contains("llvmpipe") {
        assert!(a == b, "{what}: lavapipe must draw the same frame bit for bit");
        return;
    }
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        for c in 0..4 {
            let limit = (2f32.powi(-9) * p[c].abs()).max(1e-4);
            assert!((p[c] - q[c]).abs() <= limit, "{what}: pixel {i} channel {c}: {} vs {}", p[c], q[c]);
        }
    }
}

#[test]
fn reconfigure_rebuilds_what_the_plan_says_and_ends_where_a_fresh_load_would() {
    let s0 = Settings { width: 64, height: 36, lights: Some(48), ..Settings::default() };
    let mut prep = Prepared::new(&s0).unwrap();
    assert_matches_a_fresh_load(&prep, &s0);
    let mut timer = GpuTimer::new(&prep.ctx).unwrap();

    // Light data in place: the renderer built before stays valid and draws the new lights.
    let mut before = prep.renderer(false).unwrap();
    before.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    let seed_1 = before.read_hdr(&prep.ctx).unwrap();
    let lights_buffer = prep.lights.cull.clone();
    let s1 = Settings { seed: 2, ..s0.clone() };
    let plan = prep.reconfigure(&s1).unwrap();
    assert_eq!(plan, Rebuild { reload: Reload::LightData, ..Rebuild::default() });
    assert_eq!(prep.lights.cull, lights_buffer, "rewritten in place");
    assert_matches_a_fresh_load(&prep, &s1);
    before.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    let mut fresh = prep.renderer(false).unwrap();
    fresh.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    let seed_2 = before.read_hdr(&prep.ctx).unwrap();
    assert_ne!(seed_1, seed_2, "other lights, another image");
    assert_same_frame(&prep.ctx, "light data in place", &seed_2, &fresh.read_hdr(&prep.ctx).unwrap());
    let stats = prep.culling_stats(&fresh).unwrap().expect("Forward+ culls");
    assert!(stats.tiles_with_geometry > 0 && stats.pairs > 0, "{stats}");
    drop((before, fresh));

    let steps = [
        Settings { lights: Some(20), spot_lights: Some(6), ..s1.clone() },
        Settings { lights: Some(20), spot_lights: Some(6), method: Method::TiledDeferred, width: 80, ..s1.clone() },
        Settings {
            lights: Some(20),
            spot_lights: Some(6),
            method: Method::TiledDeferred,
            width: 80,
            grid_objects: 4,
            density: GridDensity::Low,
            ..s1.clone()
        },
    ];
    let mut old = s1;
    for s in steps {
        let plan = prep.reconfigure(&s).unwrap();
        assert_eq!(plan, rebuild_plan(&old, &s));
        assert!(plan.renderer);
        assert_matches_a_fresh_load(&prep, &s);
        prep.renderer(false).unwrap().render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
        prep.check_gpu_errors().unwrap();
        old = s;
    }
    assert!(prep.reconfigure(&old).unwrap().is_nothing());

    // A failed change leaves everything as it was.
    let missing =
        Settings { scene: SceneSource::File("/nonexistent/scene.glb".into()), grid_objects: 0, ..old.clone() };
    let e = prep.reconfigure(&missing).unwrap_err();
    assert!(format!("{e:#}").contains("loading the scene"), "{e:#}");
    assert_matches_a_fresh_load(&prep, &old);
    let bad = Settings { tile_size: 7, ..old.clone() };
    assert!(format!("{:#}", prep.reconfigure(&bad).unwrap_err()).contains("--tile-size 7"));
    assert_matches_a_fresh_load(&prep, &old);
}

#[test]
fn shadow_casters_follow_the_settings_through_reconfigure() {
    let s0 = Settings {
        width: 64,
        height: 36,
        lights: Some(24),
        spot_lights: Some(6),
        shadow_point_lights: 2,
        shadow_spot_lights: 1,
        knobs: Knobs { shadow_size: 128, ..Knobs::default() },
        ..Settings::default()
    };
    let mut prep = Prepared::new(&s0).unwrap();
    assert_matches_a_fresh_load(&prep, &s0);
    let mut timer = GpuTimer::new(&prep.ctx).unwrap();
    let faces = |r: &dyn tiledlight_frame::Renderer| r.outputs().shadow_atlas.map(|a| a.faces_drawn_last_frame());

    // The first frame draws every face (2 x 6 + 1), a still one none.
    let mut before = prep.renderer(false).unwrap();
    before.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    assert_eq!(faces(&before), Some(13));
    before.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    assert_eq!(faces(&before), Some(0));

    // New light data, the same casters: in place; told, the renderer redraws every caster
    // and draws what a fresh renderer draws.
    let s1 = Settings { seed: 7, ..s0.clone() };
    assert_eq!(prep.reconfigure(&s1).unwrap().reload, Reload::LightData);
    assert_matches_a_fresh_load(&prep, &s1);
    before.lights_moved(&prep.ctx.queue, &prep.lights.packed).unwrap();
    before.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    assert_eq!(faces(&before), Some(13));
    let mut fresh = prep.renderer(false).unwrap();
    fresh.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    assert_same_frame(
        &prep.ctx,
        "casters redrawn",
        &before.read_hdr(&prep.ctx).unwrap(),
        &fresh.read_hdr(&prep.ctx).unwrap(),
    );
    drop((before, fresh));

    // Casters chosen by their contribution to the frame: ranked from a frame of the
    // camera, the light data rewritten in place (same counts).
    let by = Settings { casters_by: CasterChoice::Contribution, ..s1.clone() };
    let brightest = prep.lights.packed.shading[..2].to_vec();
    assert_eq!(prep.reconfigure(&by).unwrap().reload, Reload::LightData);
    assert_matches_a_fresh_load(&prep, &by);
    assert_ne!(prep.lights.packed.shading[..2], brightest, "here the largest contributions are not the brightest");
    // A new screen ranks them again (the same as a fresh load at that size).
    let wider = Settings { width: 96, ..by.clone() };
    assert_eq!(prep.reconfigure(&wider).unwrap().reload, Reload::LightData);
    assert_matches_a_fresh_load(&prep, &wider);
    assert_eq!(prep.reconfigure(&s1).unwrap().reload, Reload::LightData);
    assert_matches_a_fresh_load(&prep, &s1);

    // Other casters: new light buffers and a renderer with another atlas.
    let s2 = Settings { shadow_point_lights: 0, shadow_spot_lights: 4, ..s1.clone() };
    let plan = prep.reconfigure(&s2).unwrap();
    assert_eq!((plan.reload, plan.renderer), (Reload::LightBuffers, true));
    assert_matches_a_fresh_load(&prep, &s2);
    let mut r = prep.renderer(false).unwrap();
    r.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    assert_eq!(faces(&r), Some(4));
    drop(r);

    // How they are drawn: the renderer only.
    let shadow_knobs =
        Knobs { shadow_size: 256, shadow_filter: ShadowFilter::Tap1, shadow_format: ShadowFormat::Depth32, ..s2.knobs };
    let s3 = Settings { knobs: shadow_knobs, ..s2.clone() };
    assert_eq!(prep.reconfigure(&s3).unwrap(), Rebuild { renderer: true, ..Rebuild::default() });
    let r = prep.renderer(false).unwrap();
    let atlas = r.outputs().shadow_atlas.expect("spots cast shadows");
    assert_eq!((atlas.layout.tile, atlas.options.format), (256, ShadowFormat::Depth32));
    drop(r);

    // No casters: no atlas.
    let s4 = Settings { shadow_spot_lights: 0, ..s3 };
    assert_eq!(prep.reconfigure(&s4).unwrap().reload, Reload::LightBuffers);
    assert!(prep.renderer(false).unwrap().outputs().shadow_atlas.is_none());
    prep.check_gpu_errors().unwrap();
}

#[test]
fn transparent_objects_and_the_blend_mode_follow_the_settings_through_reconfigure() {
    let s0 = Settings { width: 64, height: 36, lights: Some(32), grid_objects: 40, ..Settings::default() };
    let mut prep = Prepared::new(&s0).unwrap();
    let mut timer = GpuTimer::new(&prep.ctx).unwrap();
    let mut r = prep.renderer(false).unwrap();
    r.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    // No transparent objects: no blended path, no report line.
    assert!(!prep.has_blend && r.outputs().blended.is_none());
    assert_eq!(prep.blended_stats(&r).unwrap(), None);
    assert!(prep.describe().iter().all(|(k, _)| k != "blended"));
    drop(r);

    // Glass: the scene is loaded again and the renderer draws 10 blended instances.
    let s1 = Settings { transparent_objects: 10, ..s0.clone() };
    let plan = prep.reconfigure(&s1).unwrap();
    assert_eq!(plan, Rebuild { reload: Reload::Scene, camera: true, renderer: true, exposure: false });
    assert_matches_a_fresh_load(&prep, &s1);
    assert!(prep.has_blend);
    let line = prep.describe().into_iter().find(|(k, _)| k == "blended").expect("a blended line").1;
    assert_eq!(line, "10 transparent grid objects (glass), sorted back to front, --blend-mode sorted");
    let mut r = prep.renderer(false).unwrap();
    r.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    let b = prep.blended_stats(&r).unwrap().expect("blended geometry");
    assert_eq!((b.instances, b.mode), (10, BlendMode::Sorted));
    let lists = b.culling.as_ref().expect("Forward+ culls the blended geometry");
    assert_eq!(lists.lists_per_tile, 1);
    assert!(lists.tiles_with_geometry > 0 && lists.pairs > 0, "{b}");
    assert!(b.memory > 0 && r.memory().entries.iter().any(|(c, _)| c.starts_with("blended.")), "{b}");
    let sorted = r.read_hdr(&prep.ctx).unwrap();
    drop(r);

    // The blend mode: the renderer only.
    let s2 = Settings { knobs: Knobs { blend_mode: BlendMode::WeightedOit, ..s1.knobs }, ..s1.clone() };
    assert_eq!(prep.reconfigure(&s2).unwrap(), Rebuild { renderer: true, ..Rebuild::default() });
    let mut r = prep.renderer(false).unwrap();
    r.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    let b = prep.blended_stats(&r).unwrap().expect("blended geometry");
    assert_eq!((b.instances, b.mode), (10, BlendMode::WeightedOit));
    assert_ne!(r.read_hdr(&prep.ctx).unwrap(), sorted, "another way of compositing, another image");
    drop(r);

    // Tiled Deferred culls its own blended lists too; brute force has none.
    for (method, lists) in [(Method::TiledDeferred, true), (Method::BruteForce { cutoff: true }, false)] {
        let s = Settings { method, ..s2.clone() };
        assert_eq!(prep.reconfigure(&s).unwrap(), Rebuild { renderer: true, ..Rebuild::default() });
        let mut r = prep.renderer(false).unwrap();
        r.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
        let b = prep.blended_stats(&r).unwrap().expect("blended geometry");
        assert_eq!((b.instances, b.culling.is_some()), (10, lists), "{method:?}: {b}");
    }

    // Back to no glass: the blend mode no longer matters.
    let s3 = Settings { transparent_objects: 0, ..s2 };
    assert_eq!(prep.reconfigure(&s3).unwrap().reload, Reload::Scene);
    assert!(!prep.has_blend);
    assert!(prep
        .reconfigure(&Settings { knobs: Knobs { blend_mode: BlendMode::Sorted, ..s3.knobs }, ..s3 })
        .unwrap()
        .is_nothing());
    prep.check_gpu_errors().unwrap();
}
