//! Bad input gets a clear error naming the problem, never a panic or a wrong image:
//! zero-size screens, absurd light counts, NaN in a scene, impossible culling settings
//! (Forward+ and Tiled Deferred), and a device without timestamp queries (the renderer runs, untimed).

use glam::Vec3;
use tiledlight_cull::lists::MAX_CAPACITY;
use tiledlight_cull::Light;
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::{LightBuffers, MAX_LIGHTS};
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::{ContextOptions, GpuContext};
use tiledlight_tests::{err_text, gpu, scenes};

#[test]
fn renderer_rejects_bad_settings_with_reasons() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 16, 0, 1)).unwrap();
    let new = |w, h, s: FrameSettings| FrameRenderer::new(ctx, &sg, &lights, w, h, s).map(|_| ());
    let d = FrameSettings::default();
    let e = err_text(new(0, 180, d));
    assert!(e.contains("0x180") && e.contains("no pixels"), "{e}");
    let e = err_text(new(320, 0, d));
    assert!(e.contains("no pixels"), "{e}");
    let e = err_text(new(100_000, 10, d));
    assert!(e.contains("100000"), "{e}");
    let e = err_text(new(64, 64, FrameSettings { cull: CullOptions { tile_size: 7, ..Default::default() }, ..d }));
    assert!(e.contains("tile size 7"), "{e}");
    let e = err_text(new(64, 64, FrameSettings { cull: CullOptions { capacity: 0, ..Default::default() }, ..d }));
    assert!(e.contains("capacity 0"), "{e}");
    // 2048 indices x 2 lists x 4 bytes is 16 KiB of workgroup memory, over WebGPU's default
    // limit: a device asking for only that (as on a GPU that has no more) refuses it; the
    // default device asks for 32 KiB where the adapter has it, and takes it.
    let half_z_2048 = FrameSettings { cull: CullOptions { capacity: 2048, half_z: true, ..Default::default() }, ..d };
    let small = GpuContext::headless(ContextOptions { workgroup_memory_cap: Some(16384), ..Default::default() })
        .expect("adapter");
    assert_eq!(small.device.limits().max_compute_workgroup_storage_size, 16384);
    let small_scene = SceneGpu::new(&small.device, &small.queue, &scene).unwrap();
    let small_lights = LightBuffers::new(&small.device, &scenes::lights(&scene, 16, 0, 1)).unwrap();
    let e = err_text(FrameRenderer::new(&small, &small_scene, &small_lights, 64, 64, half_z_2048));
    assert!(e.contains("workgroup memory") && e.contains("16384"), "{e}");
    if ctx.device.limits().max_compute_workgroup_storage_size >= 2048 * 2 * 4 + 16 {
        new(64, 64, half_z_2048).expect("fits 32 KiB of workgroup memory");
    }
    let e = err_text(new(64, 64, FrameSettings { method: Method::BruteForce { cutoff: true }, heatmap: true, ..d }));
    assert!(e.contains("heat map"), "{e}");
}

#[test]
fn absurd_light_counts_are_refused() {
    let ctx = gpu();
    let l = Light::point(Vec3::ZERO, Vec3::ONE, 1.0, 0.1).unwrap();
    let e = err_text(LightBuffers::new(&ctx.device, &vec![l; MAX_LIGHTS + 1]));
    assert!(e.contains(&format!("{}", MAX_LIGHTS + 1)) && e.contains("at most"), "{e}");
    // Zero lights is a valid (ambient-only) frame: every floor pixel is exactly the ambient
    // light times the floor's albedo, sky pixels are black. A black frame (nothing drawn, or
    // the ambient term lost), NaN from an empty light loop, or stray light all fail.
    let mut scene = scenes::mixed_scene();
    scene.instances.truncate(1); // the floor alone: one albedo
    let albedo = Vec3::from_slice(&scene.materials[scene.instances[0].material].base_color[..3]);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let none = LightBuffers::new(&ctx.device, &[]).unwrap();
    for method in [Method::ForwardPlus, Method::BruteForce { cutoff: true }] {
        let settings = FrameSettings { method, ..Default::default() };
        let ambient = settings.ambient;
        assert!(ambient.min_element() > 0.0, "the default ambient light is not black");
        let mut r = FrameRenderer::new(ctx, &sg, &none, 64, 36, settings).unwrap();
        let mut timer = GpuTimer::new(ctx).unwrap();
        r.render_once(ctx, &mut timer, &sg, &scenes::mixed_camera(64, 36)).unwrap();
        let hdr = r.read_hdr(ctx).unwrap();
        let depth = r.read_depth(ctx).unwrap();
        let want = ambient * albedo;
        let mut floor = 0;
        for (p, d) in hdr.iter().zip(&depth) {
            let expected = if *d > 0.0 { want } else { Vec3::ZERO };
            floor += (*d > 0.0) as usize;
            for c in 0..3 {
                // f16 output: 2^-11 relative.
                assert!(
                    (p[c] - expected[c]).abs() <= 1e-3 * expected[c] + 1e-6,
                    "{method:?}, no lights: pixel {p:?}, expected {expected} (ambient x albedo, or black sky)"
                );
            }
        }
        assert!(floor * 2 > hdr.len(), "{method:?}: the floor must fill most of the frame ({floor} pixels)");
    }
}

#[test]
fn nan_in_scene_is_reported_not_rendered() {
    let ctx = gpu();
    let mut scene = scenes::mixed_scene();
    scene.meshes[1].positions[3][1] = f32::NAN;
    let e = err_text(SceneGpu::new(&ctx.device, &ctx.queue, &scene));
    assert!(e.to_lowercase().contains("nan") || e.contains("finite"), "{e}");
    assert!(e.contains("cube"), "names the mesh: {e}");
    let mut scene = scenes::mixed_scene();
    scene.instances[2].material = 99;
    let e = err_text(SceneGpu::new(&ctx.device, &ctx.queue, &scene));
    assert!(e.contains("99"), "{e}");
}

/// A device without TIMESTAMP_QUERY (forced off here; some adapters lack it) still renders
/// the same image; the timer reports that it is disabled and yields no pass times.
#[test]
fn renders_without_timestamp_queries() {
    let ctx = GpuContext::headless(ContextOptions { no_timestamps: true, ..Default::default() }).expect("adapter");
    assert!(!ctx.timestamps);
    assert!(ctx.describe().contains("no GPU timestamps"));
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 64, 8, 2)).unwrap();
    let mut r = FrameRenderer::new(&ctx, &sg, &lights, 64, 36, FrameSettings::default()).unwrap();
    let mut timer = GpuTimer::new(&ctx).unwrap();
    assert!(!timer.enabled());
    for _ in 0..3 {
        r.render_once(&ctx, &mut timer, &sg, &scenes::mixed_camera(64, 36)).unwrap();
    }
    let times: Vec<_> = std::iter::from_fn(|| timer.finished_frame()).flatten().collect();
    assert!(times.is_empty(), "no timestamps, no times: {times:?}");
    let hdr = r.read_hdr(&ctx).unwrap();
    assert!(hdr.iter().any(|p| p[0] + p[1] + p[2] > 0.1), "the frame is lit");
}

/// With timestamps (lavapipe has them), every pass of a Forward+ frame is timed.
#[test]
fn every_pass_is_timed_when_timestamps_exist() {
    let ctx = gpu();
    if !ctx.timestamps {
        panic!("this adapter has no TIMESTAMP_QUERY; run on lavapipe or a GPU that has it");
    }
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 64, 0, 2)).unwrap();
    let mut r =
        FrameRenderer::new(ctx, &sg, &lights, 64, 36, FrameSettings { heatmap: true, ..Default::default() }).unwrap();
    let mut timer = GpuTimer::new(ctx).unwrap();
    let mut frames = Vec::new();
    for _ in 0..6 {
        r.render_once(ctx, &mut timer, &sg, &scenes::mixed_camera(64, 36)).unwrap();
        frames.extend(std::iter::from_fn(|| timer.finished_frame()));
    }
    let last = frames.last().expect("a finished frame");
    let labels: Vec<&str> = last.iter().map(|t| t.label.as_str()).collect();
    assert_eq!(labels, ["depth_prepass", "forward.cull", "forward.shade", "tonemap", "heatmap"]);
    assert!(last.iter().all(|t| t.ms.is_finite() && t.ms >= 0.0), "{last:?}");
}

/// Tiled Deferred refuses impossible settings with a message naming the problem: a tile
/// size the kernel has no variant for, capacity 0 or above the kernel's maximum, a sample
/// count that is not 1/2/4/8, and lists that fit the device's workgroup memory alone but
/// not once the MSAA edge queue (4 bytes a tile pixel) takes its share. Catches a renderer
/// that builds the pipeline anyway (a wgpu validation panic or a silently wrong frame) or
/// reports the memory overflow without saying the MSAA queue caused it.
#[test]
fn deferred_rejects_bad_settings_with_reasons() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 16, 4, 1)).unwrap();
    let new = |s: FrameSettings| FrameRenderer::new(ctx, &sg, &lights, 64, 64, s).map(|_| ());
    let d = FrameSettings::of(Method::TiledDeferred);
    let cull = |c: CullOptions| FrameSettings { method: Method::TiledDeferred, cull: c, ..d };
    let e = err_text(new(cull(CullOptions { tile_size: 7, ..Default::default() })));
    assert!(e.contains("tile size 7") && e.contains("8, 16 or 32"), "{e}");
    let e = err_text(new(cull(CullOptions { capacity: 0, ..Default::default() })));
    assert!(e.contains("capacity 0"), "{e}");
    let e = err_text(new(cull(CullOptions { capacity: MAX_CAPACITY + 1, ..Default::default() })));
    assert!(e.contains(&format!("capacity {}", MAX_CAPACITY + 1)) && e.contains(&format!("{MAX_CAPACITY}")), "{e}");
    let e = err_text(new(FrameSettings { method: Method::TiledDeferred, msaa: 3, ..d }));
    assert!(e.contains("MSAA 3x") && e.contains("1, 2, 4 or 8"), "{e}");
    let e = err_text(new(FrameSettings {
        method: Method::TiledDeferred,
        msaa: 4,
        knobs: Knobs { edge_distance: f32::NAN, ..d.knobs },
        ..d
    }));
    assert!(e.contains("edge distance"), "{e}");

    // 2043 indices x 2 lists x 4 bytes + 40 bytes (depth range, counts, grid writer) is
    // exactly WebGPU's 16 KiB: without MSAA it fits a device that has only that; with 4x
    // MSAA the 16 px tile's edge queue (8 + 4 x 256 bytes) does not, and the error must say
    // that the queue is why.
    let small = GpuContext::headless(ContextOptions { workgroup_memory_cap: Some(16384), ..Default::default() })
        .expect("adapter");
    assert_eq!(small.device.limits().max_compute_workgroup_storage_size, 16384);
    let small_scene = SceneGpu::new(&small.device, &small.queue, &scene).unwrap();
    let small_lights = LightBuffers::new(&small.device, &scenes::lights(&scene, 16, 4, 1)).unwrap();
    let full = cull(CullOptions { capacity: 2043, half_z: true, ..Default::default() });
    FrameRenderer::new(&small, &small_scene, &small_lights, 64, 64, full).expect("2043 x 2 lists fit 16 KiB");
    let e = err_text(FrameRenderer::new(
        &small,
        &small_scene,
        &small_lights,
        64,
        64,
        FrameSettings { method: Method::TiledDeferred, msaa: 4, ..full },
    ));
    assert!(
        e.contains("capacity 2043") && e.contains("17416") && e.contains("MSAA edge queue") && e.contains("16384"),
        "{e}"
    );
}

/// A typed handle carries its target's sample count, and a pass built over it checks it
/// against its own: the light culling over a 4x depth buffer with options for 1x, or the
/// reverse, is a named error, not a pipeline that reads the wrong texture type (a wgpu
/// validation panic); the matching handle builds.
#[test]
fn a_depth_handle_of_another_sample_count_is_refused() {
    use tiledlight_cull::TileGrid;
    use tiledlight_gpu::culling::LightCulling;
    use tiledlight_gpu::targets::target_handles;
    use tiledlight_gpu::targets::DisplayTargets;
    use tiledlight_gpu::view::Views;
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 8, 0, 1)).unwrap();
    let lighting = lights.lighting(&ctx.device, Vec3::splat(0.03));
    let views = Views::new(&ctx.device, 1);
    let grid = TileGrid::new(64, 32, 16).unwrap();
    let build = |samples: u32, options_samples: u32| {
        let t = DisplayTargets::new(&ctx.device, "test", (64, 32), samples, wgpu::TextureUsages::empty());
        let options = CullOptions { samples: options_samples, ..Default::default() };
        LightCulling::new(&ctx.device, &views, target_handles(&t).0, &lights, &lighting, grid, options).map(|_| ())
    };
    let e = err_text(build(4, 1));
    assert!(e.contains("a depth buffer of 4 samples a pixel, culling options for 1"), "{e}");
    let e = err_text(build(1, 4));
    assert!(e.contains("a depth buffer of 1 samples a pixel, culling options for 4"), "{e}");
    build(4, 4).expect("the matching handle");
}

/// A plate of 64 x 64 quads (8,192 triangles: 98,304 bytes of indices, 50,700 of
/// positions) instanced 16 times on a grid in the XY plane: 131,072 triangles drawn.
fn plates_scene() -> tiledlight_scene::Scene {
    use tiledlight_scene::{Aabb, Instance, Mesh, Scene};
    const Q: u32 = 64;
    let mut mesh = Mesh { name: "plate".into(), ..Mesh::default() };
    for y in 0..=Q {
        for x in 0..=Q {
            let (u, v) = (x as f32 / Q as f32, y as f32 / Q as f32);
            mesh.positions.push([u - 0.5, v - 0.5, 0.0]);
            mesh.normals.push([0.0, 0.0, 1.0]);
            mesh.uvs.push([u, v]);
        }
    }
    for y in 0..Q {
        for x in 0..Q {
            let i = y * (Q + 1) + x;
            mesh.indices.extend([i, i + 1, i + Q + 2, i, i + Q + 2, i + Q + 1]);
        }
    }
    let instances = (0..16)
        .map(|k| Instance {
            mesh: 0,
            material: 0,
            transform: glam::Mat4::from_translation(Vec3::new(
                (k % 4) as f32 * 1.1 - 1.65,
                (k / 4) as f32 * 1.1 - 1.65,
                0.0,
            )),
        })
        .collect();
    Scene {
        name: "plates".into(),
        meshes: vec![mesh],
        materials: vec![scenes::material("grey", [0.8, 0.8, 0.8, 1.0], 0.5, 0.0)],
        textures: vec![],
        instances,
        lights: vec![],
        camera: None,
        bounds: Aabb::new(Vec3::new(-2.2, -2.2, 0.0), Vec3::new(2.2, 2.2, 0.0)),
    }
}

/// Buffers that grow with the geometry are checked against the device's storage-binding
/// limit before they are made (issue 46 item 4), so a scene too big for a GPU is refused
/// with the limit it exceeds, its value and what was asked, never a wgpu validation panic.
/// Devices asking for smaller bindings stand in for smaller GPUs (the 10-million-triangle
/// file on the real limits is `crates/app/tests/big_scene.rs`): at 256 KiB the scene's own
/// buffers fit and Forward+ renders it, while the compute raster's large-triangle list
/// (8 bytes for each of 131,072 triangles drawn) and the traced reference's triangles
/// (48 bytes each) do not; at 64 KiB the scene's index buffer (98,304 bytes) does not.
#[test]
fn buffers_past_a_smaller_storage_binding_are_refused_by_name() {
    use tiledlight_gpu::features::Raster;
    let scene = plates_scene();
    let camera =
        tiledlight_cull::Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 1.0, 1.0, 0.1, None)
            .unwrap();
    let small = |cap: u64| {
        let ctx = GpuContext::headless(ContextOptions { storage_binding_cap: Some(cap), ..Default::default() })
            .expect("adapter");
        assert_eq!(ctx.device.limits().max_storage_buffer_binding_size, cap);
        ctx
    };

    let ctx = small(256 << 10);
    let mut sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).expect("the scene's own buffers fit 256 KiB");
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 8, 0, 1)).unwrap();
    let mut r = FrameRenderer::new(&ctx, &sg, &lights, 64, 64, FrameSettings::default()).expect("Forward+ fits");
    let frame = tiledlight_tests::compare::render_frame(&ctx, &mut r, &sg, &camera);
    assert!(frame.hdr.iter().any(|p| p[0] > 0.0), "Forward+ drew the plates");

    // The compute raster needs 64-bit atomics (lavapipe and the H200 have them): without
    // them this fails naming them, as every compute-raster test does.
    let knobs = Knobs { raster: Raster::Compute, ..Knobs::default() };
    let s = FrameSettings { method: Method::Visibility, knobs, ..FrameSettings::default() };
    let e = err_text(FrameRenderer::new(&ctx, &sg, &lights, 64, 64, s));
    assert_eq!(
        e,
        "the compute raster's list of large triangles (8 bytes for each of 131072 triangles drawn): \
         limit max_storage_buffer_binding_size = 262144, asked for 1048576 bytes"
    );
    let e = err_text(sg.add_trace(&ctx.device, &scene));
    assert_eq!(
        e,
        "the traced reference's 131072 triangles (48 bytes each): limit max_storage_buffer_binding_size = 262144, \
         asked for 6291456 bytes"
    );

    let ctx = small(64 << 10);
    let e = err_text(SceneGpu::new(&ctx.device, &ctx.queue, &scene));
    assert_eq!(
        e,
        "the scene's indices (4225 vertices, 8192 triangles in 1 meshes): limit \
         max_storage_buffer_binding_size = 65536, asked for 98304 bytes"
    );
}

/// A loop a CPU adapter's driver would cut short is refused by name, before any frame:
/// brute force over 70,000 lights (llvmpipe stops a shader's loops after 65,535 iterations
/// in all; `tiledlight_gpu::error::CPU_LOOP_LIMIT`). A GPU builds the same renderer, and a
/// CPU adapter builds brute force over 60,000 lights.
#[test]
fn brute_force_past_a_cpu_drivers_loop_limit_is_refused() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let build = |n: u32| {
        let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, n, 0, 1)).unwrap();
        let s = FrameSettings { method: Method::BruteForce { cutoff: false }, ..Default::default() };
        FrameRenderer::new(ctx, &sg, &lights, 64, 36, s).map(|_| ())
    };
    let cpu = ctx.info.device_type == wgpu::DeviceType::Cpu;
    match build(70_000) {
        Err(e) if cpu => {
            let e = e.to_string();
            assert!(e.contains("70000 lights") && e.contains("65535 iterations"), "{e}");
        }
        Err(e) => panic!("a GPU refused brute force over 70,000 lights: {e}"),
        Ok(()) => assert!(!cpu, "a CPU adapter built brute force past its loop limit"),
    }
    build(60_000).expect("60,000 lights stay under the limit");
}
