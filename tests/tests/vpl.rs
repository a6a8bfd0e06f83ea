//! Virtual point lights on the GPU (crates/vpl) against their CPU twin
//! (`tiledlight_cull::vpl`), on lavapipe and real GPUs.
//!
//! A red wall (x = 2, facing -x) stands on a white floor; one shadow-casting spot light
//! aims at their corner. The reflective shadow map is drawn by the GPU and read back; the
//! CPU twin generates VPLs from that same RSM, and the GPU's VPL set must equal it
//! (count, positions, normals, flux; compared as sets, the GPU appends in any order), with
//! no thresholds, with each threshold biting, and with a cap below the candidates (the
//! count stops at the cap, the refused count is the rest, every kept VPL is a candidate).
//!
//! Tolerances: the GPU and the CPU rebuild texel positions from the same depth and matrix
//! in f32 (a few ulps of ~5 m, 1e-5 m), and decode the same 8-bit linear albedo, so a VPL's
//! position must agree to 1e-4 m, its normal to 1e-4 and its flux to 1e-4 of its value
//! (plus 1e-6 of the largest VPL's flux). A block whose tint lies within 1e-4 of a
//! threshold (or of zero, at the rim of the spot's cone) may fall either side on either
//! device: it may be missing from one set, and is counted as such.

use glam::{Mat4, Vec3};
use tiledlight_cull::shadow::{AtlasLayout, ShadowOptions};
use tiledlight_cull::vpl::{self, GpuVpl, RsmFace, Vpl, VplConfig};
use tiledlight_cull::Light;
use tiledlight_gpu::features::{Features, Method};
use tiledlight_gpu::light_cull::CullOptions;
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::view::Views;
use tiledlight_scene::{Instance, Scene};
use tiledlight_tests::gpu;
use tiledlight_tests::scenes::{material, quad};
use tiledlight_vpl::VplPath;

/// The red wall on the white floor.
fn wall_scene() -> Scene {
    let mut scene = Scene {
        name: "red wall".into(),
        meshes: vec![quad("plane", 10.0)],
        materials: vec![
            material("white", [0.8, 0.8, 0.8, 1.0], 0.8, 0.0),
            material("red", [0.8, 0.05, 0.05, 1.0], 0.8, 0.0),
        ],
        instances: vec![
            Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY },
            // +Y turned to -X, standing on the floor from y = 0 to 10.
            Instance {
                mesh: 0,
                material: 1,
                transform: Mat4::from_translation(Vec3::new(2.0, 5.0, 0.0))
                    * Mat4::from_rotation_z(std::f32::consts::FRAC_PI_2),
            },
        ],
        textures: Vec::new(),
        lights: Vec::new(),
        camera: None,
        bounds: tiledlight_scene::Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene
}

/// The spot aimed at the wall's foot.
fn spot() -> Light {
    let pos = Vec3::new(-1.0, 3.0, 0.0);
    let dir = Vec3::new(2.0, 0.5, 0.0) - pos;
    Light::spot(pos, dir, Vec3::ONE, 30.0, 30f32.to_radians(), 45f32.to_radians(), 0.01).expect("spot")
}

/// What one GPU run gives: the RSM as the twin reads it, the GPU's VPLs and its count.
struct Run {
    faces: Vec<RsmFace>,
    vpls: Vec<GpuVpl>,
    count: tiledlight_vpl::VplCount,
}

fn run(cfg: &VplConfig) -> Run {
    let ctx = gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let scene = SceneGpu::new(device, queue, &wall_scene()).expect("scene");
    let lights = LightBuffers::with_casters(device, &[spot()], (0, 1)).expect("lights");
    let shadow = ShadowOptions::default();
    let features = Features::new(&scene, &lights, Method::ForwardPlus, &CullOptions::default(), (1, 2), shadow);
    let limits = device.limits();
    let layout =
        AtlasLayout::new(shadow.tile_size, 0, 1, limits.max_texture_dimension_2d, limits.max_texture_array_layers)
            .expect("layout");
    let views = Views::new(device, 1 + layout.faces());
    let atlas = ShadowAtlas::new(device, &views, &scene, &features, layout, shadow, 1).expect("atlas");
    atlas.update(queue, &views, &lights.packed).expect("atlas update");
    let path = VplPath::new(device, queue, (&views, &scene), &atlas, &lights.packed, cfg).expect("vpl path");
    let mut timer = GpuTimer::new(ctx).expect("timer");
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test.vpl") });
    atlas.record(&mut encoder, &timer, &views, &scene);
    assert!(path.record(&mut encoder, &timer, &views, &scene), "a fresh path draws its RSM");
    timer.resolve(&mut encoder);
    queue.submit([encoder.finish()]);
    timer.end_frame().expect("timer");
    // A still frame keeps its VPLs: nothing recorded.
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test.vpl.still") });
    assert!(!path.record(&mut encoder, &timer, &views, &scene), "a still frame draws no RSM");
    drop(encoder);
    let faces = path.rsm.read_faces(device, queue, &atlas, &lights.packed).expect("rsm readback");
    let count = path.buffers.read_count(device, queue).expect("count");
    let vpls = path.buffers.read_vpls(device, queue).expect("vpls");
    let cull = path.buffers.read_cull(device, queue).expect("cull spheres");
    for (v, c) in vpls.iter().zip(&cull) {
        assert_eq!((v.position, v.radius), (c.center, c.radius), "the culling sphere is the VPL's");
    }
    Run { faces, vpls, count }
}

/// The tint length and normalised largest channel of a CPU VPL, for the borderline test.
fn borderline(v: &Vpl, cfg: &VplConfig) -> bool {
    let len = v.tint.length();
    let colour = v.tint.max_element() / len.max(f32::MIN_POSITIVE);
    len < 1e-4 || (len - cfg.brightness_threshold).abs() < 1e-4 || (colour - cfg.colour_threshold).abs() < 1e-4
}

/// The CPU VPL in `cpu` (not yet `used`) that `g` equals within the tolerances.
fn find(g: &Vpl, cpu: &[Vpl], used: &[bool], max_flux: f32) -> Option<usize> {
    cpu.iter().enumerate().position(|(i, c)| {
        !used[i]
            && (c.position - g.position).length() < 1e-4
            && (c.normal - g.normal).length() < 1e-4
            && (c.flux - g.flux).abs().max_element() <= 1e-4 * c.flux.max_element() + 1e-6 * max_flux
            && c.radius == g.radius
    })
}

/// Matches the GPU's VPLs with the CPU's kept ones (`cpu`), order-independently. A GPU VPL
/// matching none must be a borderline block of the twin's unthresholded set (`all`); the
/// CPU VPLs left unmatched are returned, and each must be borderline unless `capped`.
fn match_sets<'a>(gpu: &[GpuVpl], cpu: &'a [Vpl], all: &[Vpl], cfg: &VplConfig, capped: bool) -> Vec<&'a Vpl> {
    let max_flux = all.iter().map(|v| v.flux.max_element()).fold(0.0, f32::max);
    let mut used = vec![false; cpu.len()];
    for g in gpu {
        let g = g.to_vpl();
        match find(&g, cpu, &used, max_flux) {
            Some(i) => used[i] = true,
            None => {
                let extra = find(&g, all, &vec![false; all.len()], max_flux).map(|i| &all[i]);
                assert!(
                    extra.is_some_and(|v| borderline(v, cfg)),
                    "GPU VPL {g:?} matches no CPU VPL kept; in the unthresholded set: {extra:?}"
                );
            }
        }
    }
    let missing: Vec<&Vpl> = cpu.iter().zip(&used).filter(|(_, u)| !**u).map(|(v, _)| v).collect();
    for v in missing.iter().filter(|_| !capped) {
        assert!(borderline(v, cfg), "CPU VPL {v:?} is missing from the GPU's set");
    }
    missing
}

/// The twin's VPLs of `faces` with `cfg` and with no thresholds nor cap.
fn twin(faces: &[RsmFace], cfg: &VplConfig) -> (vpl::Generated, Vec<Vpl>) {
    let all = VplConfig { colour_threshold: 0.0, brightness_threshold: 0.0, cap: vpl::MAX_CAP, ..*cfg };
    (vpl::generate(faces, cfg).expect("twin"), vpl::generate(faces, &all).expect("twin").vpls)
}

#[test]
fn rsm_holds_the_wall_and_the_floor_seen_from_the_light() {
    let r = run(&VplConfig::default());
    assert_eq!(r.faces.len(), 1);
    let texels: Vec<_> = r.faces[0].texels.iter().flatten().collect();
    let (mut wall, mut floor) = (0, 0);
    for t in &texels {
        if t.normal.dot(Vec3::NEG_X) > 0.999 {
            wall += 1;
            assert!((t.position.x - 2.0).abs() < 1e-3, "a wall texel off the wall: {t:?}");
            assert!(t.albedo.x > 0.75 && t.albedo.y < 0.06, "the wall is red (0.8, 0.05, 0.05): {t:?}");
        } else if t.normal.dot(Vec3::Y) > 0.999 {
            floor += 1;
            assert!(t.position.y.abs() < 1e-3, "a floor texel off the floor: {t:?}");
            // 0.8 through an 8-bit linear target: within half a step (0.002).
            assert!((t.albedo - Vec3::splat(0.8)).abs().max_element() < 2.5e-3, "the floor is white 0.8: {t:?}");
        } else {
            panic!("a texel on neither plane: {t:?}");
        }
    }
    // The spot's cone (and its shadow tile's border) shows both planes, the wall more.
    assert!(wall > 200 && floor > 50, "wall {wall}, floor {floor} of {} texels", texels.len());
}

#[test]
fn gpu_vpls_equal_the_cpu_twin_without_thresholds() {
    let cfg = VplConfig::default();
    let r = run(&cfg);
    let (cpu, all) = twin(&r.faces, &cfg);
    assert!(cpu.candidates > 100, "{}", cpu.candidates);
    assert_eq!(r.count.refused, 0);
    let missing = match_sets(&r.vpls, &cpu.vpls, &all, &cfg, false);
    assert_eq!(r.vpls.len() + missing.len(), cpu.vpls.len(), "every GPU VPL matched one CPU VPL");
    assert!(missing.len() <= 4, "{} borderline blocks at the cone's rim", missing.len());
    // Block 1 (one VPL per texel) and 4 too.
    for block in [1, 4] {
        let cfg = VplConfig { block, ..cfg };
        let r = run(&cfg);
        let (cpu, all) = twin(&r.faces, &cfg);
        let missing = match_sets(&r.vpls, &cpu.vpls, &all, &cfg, false);
        assert_eq!(r.vpls.len() + missing.len(), cpu.vpls.len(), "block {block}");
    }
}

#[test]
fn gpu_thresholds_equal_the_cpu_twins() {
    let base = VplConfig::default();
    let all = vpl::generate(&run(&base).faces, &base).expect("twin").candidates;
    // Colour: 0.9 keeps only the red wall's saturated blocks.
    let cfg = VplConfig { colour_threshold: 0.9, ..base };
    let r = run(&cfg);
    let (cpu, unthresholded) = twin(&r.faces, &cfg);
    assert!(cpu.candidates > 20 && cpu.candidates < all, "colour threshold kept {} of {all}", cpu.candidates);
    assert!(cpu.vpls.iter().all(|v| v.normal.dot(Vec3::NEG_X) > 0.99), "only wall VPLs are saturated");
    let missing = match_sets(&r.vpls, &cpu.vpls, &unthresholded, &cfg, false);
    assert_eq!(r.vpls.len() + missing.len(), cpu.vpls.len());
    // Brightness: the median tint length keeps about half.
    let mut lens: Vec<f32> =
        vpl::generate(&r.faces, &base).expect("twin").vpls.iter().map(|v| v.tint.length()).collect();
    lens.sort_by(f32::total_cmp);
    let cfg = VplConfig { brightness_threshold: lens[lens.len() / 2], ..base };
    let r = run(&cfg);
    let (cpu, unthresholded) = twin(&r.faces, &cfg);
    assert!(cpu.candidates > all / 3 && cpu.candidates < 2 * all / 3, "brightness kept {} of {all}", cpu.candidates);
    let missing = match_sets(&r.vpls, &cpu.vpls, &unthresholded, &cfg, false);
    // GPU VPLs matched to kept CPU ones, plus borderline extras, minus borderline misses.
    assert!(r.vpls.len().abs_diff(cpu.vpls.len()) <= 4, "GPU {} vs CPU {}", r.vpls.len(), cpu.vpls.len());
    assert!(missing.len() <= 4);
}

#[test]
fn the_cap_stops_the_count_and_counts_the_refused() {
    let base = VplConfig::default();
    let r = run(&base);
    let cpu = vpl::generate(&r.faces, &base).expect("twin");
    let cap = cpu.candidates / 3;
    let cfg = VplConfig { cap, ..base };
    let r = run(&cfg);
    assert_eq!(r.count.kept, cap);
    assert_eq!(r.vpls.len() as u32, cap);
    // The refused count is the rest, to the borderline blocks either device may drop.
    let d = (r.count.kept + r.count.refused).abs_diff(cpu.candidates);
    assert!(d <= 4, "kept {} + refused {} vs {} candidates", r.count.kept, r.count.refused, cpu.candidates);
    // Which `cap` of them the GPU kept depends on its threads' order: each is a candidate.
    let missing = match_sets(&r.vpls, &cpu.vpls, &cpu.vpls, &cfg, true);
    assert_eq!(missing.len() as u32, cpu.vpls.len() as u32 - cap);
}

#[test]
fn bad_settings_are_errors_naming_the_setting() {
    let ctx = gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let scene = SceneGpu::new(device, queue, &wall_scene()).expect("scene");
    let lights = LightBuffers::with_casters(device, &[spot()], (0, 1)).expect("lights");
    let shadow = ShadowOptions::default();
    let features = Features::new(&scene, &lights, Method::ForwardPlus, &CullOptions::default(), (1, 2), shadow);
    let limits = device.limits();
    let layout =
        AtlasLayout::new(shadow.tile_size, 0, 1, limits.max_texture_dimension_2d, limits.max_texture_array_layers)
            .expect("layout");
    let views = Views::new(device, 1 + layout.faces());
    let atlas = ShadowAtlas::new(device, &views, &scene, &features, layout, shadow, 1).expect("atlas");
    let bad = VplConfig { block: 3, ..Default::default() };
    let e = tiledlight_tests::err_text(VplPath::new(device, queue, (&views, &scene), &atlas, &lights.packed, &bad));
    assert!(e.contains("block 3"), "{e}");
    let e = tiledlight_tests::err_text(VplPath::new(
        device,
        queue,
        (&views, &scene),
        &atlas,
        &lights.packed,
        &VplConfig { cap: u32::MAX, ..Default::default() },
    ));
    assert!(e.contains("cap"), "{e}");
}
