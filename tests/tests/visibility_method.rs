//! The visibility buffer as a method (issue 28): what it models, its lists, its layouts and
//! the negative test of its comparison. Its images against brute force, Forward+ and Tiled
//! Deferred are in the suites that compare the other methods, at
//! `tiledlight_tests::compare::VISIBILITY_VS_REFERENCE` (Forward+'s limits): `deferred.rs`
//! (courtyard; mixed scene with spots, half-z, AABB, 8 px tiles), `materials.rs` (normal,
//! metallic-roughness, occlusion and emissive maps, the second uv set, texture transforms,
//! wrap modes, quantised meshes), `msaa.rs` (every sample count the adapter has, the
//! masked screen's depth samples) and `blended.rs` (blended geometry, shadows and VPLs,
//! each sample count). The reconstruction's arithmetic is `visibility.rs`.

use tiledlight_cull::Camera;
use tiledlight_frame::plan::Step;
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method, TestHooks, VisibilityFrame};
use tiledlight_gpu::culling::{ClusterOptions, CullOptions};
use tiledlight_gpu::features::Raster;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;
use tiledlight_gpu::{ContextOptions, GpuError};
use tiledlight_tests::compare::{
    assert_visibility_matches, compare_with_reference, render_frame, same_hdr_pixel, visibility_matches, Frame,
    RASTER_POSITION_ERROR_PX, VISIBILITY_VS_REFERENCE,
};
use tiledlight_tests::lists::{assert_lists_match, CulledFrame};
use tiledlight_tests::{gpu, scenes, visibility_rasters};

const W: u32 = 320;
const H: u32 = 180;

fn renderer(ctx: &GpuContext, sg: &SceneGpu, lights: &LightBuffers, s: FrameSettings) -> FrameRenderer {
    FrameRenderer::new(ctx, sg, lights, W, H, s).unwrap_or_else(|e| panic!("{:?}: {e}", s.method))
}

/// Brute force's frame, with the allowance for the rasteriser's interpolated surface point
/// (`Frame::allow_position_error`).
fn brute_force(ctx: &GpuContext, sg: &SceneGpu, lights: &LightBuffers, camera: &Camera, cull: CullOptions) -> Frame {
    let s = FrameSettings { method: Method::BruteForce { cutoff: true }, cull, ..Default::default() };
    let mut r = renderer(ctx, sg, lights, s);
    let frame = render_frame(ctx, &mut r, sg, camera);
    let depth = r.read_depth(ctx).unwrap();
    frame.allow_position_error(&depth, W, (camera, &lights.packed), RASTER_POSITION_ERROR_PX)
}

/// Every light-grid layout and assignment the culling pass writes is read correctly: the
/// image matches brute force at Forward+'s limits, and the lists it was shaded with equal
/// the CPU reference culler's (the same pass as Forward+, over the visibility buffer's
/// depth). The mixed scene has spots, five materials (two dispatches: the textured screen's
/// and the four untextured materials'), a
/// masked double-sided screen and a double-sided panel seen from both sides.
#[test]
fn every_layout_matches_reference_and_cpu_lists() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let camera = scenes::mixed_camera(W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 300, 100, 21)).unwrap();
    let layouts = [
        ("tiles", CullOptions::default()),
        (
            "half-z-aabb-cone-8px",
            CullOptions { tile_size: 8, half_z: true, aabb: true, spot_cone: true, ..Default::default() },
        ),
        ("2.5d", CullOptions { depth_mask: true, ..Default::default() }),
        ("scatter", CullOptions { scatter: true, ..Default::default() }),
        ("clustered", CullOptions { clusters: Some(ClusterOptions::default()), ..Default::default() }),
    ];
    let reference = brute_force(ctx, &sg, &lights, &camera, CullOptions::default());
    for ((name, cull), raster) in
        layouts.into_iter().flat_map(|l| visibility_rasters(1).into_iter().map(move |r| (l, r)))
    {
        let name = format!("{name}-{}", raster.name());
        let s = FrameSettings {
            method: Method::Visibility,
            cull,
            knobs: Knobs { raster, ..Knobs::default() },
            ..Default::default()
        };
        let mut v = renderer(ctx, &sg, &lights, s);
        let frame = render_frame(ctx, &mut v, &sg, &camera);
        assert_visibility_matches(&format!("visibility-{name}-vs-reference"), W, (&reference, &frame), false);
        if cull.clusters.is_none() {
            let depth = v.read_depth(ctx).unwrap();
            let lists = v.read_lists(ctx).unwrap();
            let f = CulledFrame { depth: &depth, width: W, height: H, camera: &camera, lights: &lights.packed };
            let c = assert_lists_match(&format!("visibility {name}"), &f, &lists, &cull.to_config(true));
            assert!(c.pairs > 0, "{name}: lights reach the tiles");
        }
    }
}

/// The comparison catches one wrong triangle ID: the same frame with one pixel's ID
/// replaced by another valid triangle's (instance 0's triangle 0, the floor's far corner;
/// the test hook `TestHooks::wrong_id`) fails against brute force, at that pixel,
/// while the frame without it passes. The pixel is on a box, not the floor.
#[test]
fn one_wrong_triangle_id_is_caught() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let camera = scenes::mixed_camera(W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 300, 100, 21)).unwrap();
    let reference = brute_force(ctx, &sg, &lights, &camera, CullOptions::default());
    for raster in visibility_rasters(1) {
        one_wrong_id(ctx, (&sg, &lights, &camera), &reference, raster);
    }
}

/// [`one_wrong_triangle_id_is_caught`] with `raster`.
fn one_wrong_id(
    ctx: &GpuContext,
    (sg, lights, camera): (&SceneGpu, &LightBuffers, &Camera),
    reference: &Frame,
    raster: Raster,
) {
    let s =
        FrameSettings { method: Method::Visibility, knobs: Knobs { raster, ..Knobs::default() }, ..Default::default() };
    let good = render_frame(ctx, &mut renderer(ctx, sg, lights, s), sg, camera);
    assert!(visibility_matches("visibility-good", W, reference, &good), "the right IDs must pass");
    // A pixel of a box (the boxes stand at x -6..6, z -3..-1; the camera looks from the corner).
    let box_centre = camera.view_proj() * glam::Vec4::new(-1.2, 0.75, -1.0, 1.0);
    let (x, y) = (
        ((box_centre.x / box_centre.w + 1.0) * 0.5 * W as f32) as u32,
        ((1.0 - box_centre.y / box_centre.w) * 0.5 * H as f32) as u32,
    );
    let hook = |pixel| TestHooks { wrong_id: Some(pixel), ..TestHooks::default() };
    let mut wrong = FrameRenderer::with_hooks(ctx, (sg, lights), (W, H), s, hook((x, y))).unwrap();
    let bad = render_frame(ctx, &mut wrong, sg, camera);
    let i = (y * W + x) as usize;
    eprintln!(
        "pixel ({x}, {y}): reference {:?}, right ID {:?}, wrong ID {:?}",
        reference.hdr[i], good.hdr[i], bad.hdr[i]
    );
    // Beyond one f16 step: on a parallel GPU the lights' order in a list, and so the last
    // bit of a sum, changes from run to run.
    let differing = good.hdr.iter().zip(&bad.hdr).filter(|(a, b)| !same_hdr_pixel(a, b, false)).count();
    assert_eq!(differing, 1, "the hook changes exactly the one pixel");
    assert!(!visibility_matches("visibility-wrong-id", W, reference, &bad), "one wrong triangle ID must fail");
    let c = compare_with_reference("visibility-wrong-id", W, reference, &bad, VISIBILITY_VS_REFERENCE);
    assert_eq!(c.hdr_at, i, "the worst pixel is the wrong one");
    // The hook is refused where it cannot work.
    let e = FrameRenderer::with_hooks(ctx, (sg, lights), (W, H), FrameSettings::default(), hook((0, 0)));
    assert!(e.err().expect("Forward+ refuses the hook").to_string().contains("visibility"));
    let e = FrameRenderer::with_hooks(ctx, (sg, lights), (W, H), s, hook((W, 0)));
    assert!(e.err().expect("a pixel off screen is refused").to_string().contains("320x180"));
}

/// Only what the method needs: its plan has the ID raster and no pre-pass, G-buffer or
/// forward shading; memory holds the ID target (4 bytes a sample) and no G-buffer or
/// multisampled HDR target; the compute raster's texels and its R32Float depth target only
/// with it; the texture arrays only in a textured scene.
#[test]
fn models_only_what_it_needs() {
    let ctx = gpu();
    let textured = scenes::mixed_scene();
    let mut plain = textured.clone();
    plain.instances.retain(|i| plain.materials[i.material].base_color_texture.is_none());
    for (scene, textures) in [(&textured, true), (&plain, false)] {
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
        let lights = LightBuffers::new(&ctx.device, &scenes::lights(scene, 50, 10, 3)).unwrap();
        for (msaa, raster) in [(1, Raster::Hardware), (4, Raster::Hardware), (1, Raster::Compute)] {
            let s = FrameSettings {
                method: Method::Visibility,
                msaa,
                knobs: Knobs { raster, ..Knobs::default() },
                ..Default::default()
            };
            let r = renderer(ctx, &sg, &lights, s);
            let plan = r.plan();
            assert!(plan.has(Step::VisibilityRaster) && plan.has(Step::Cull) && plan.has(Step::VisibilityShade));
            assert_eq!(plan.has(Step::VisibilityResolve), msaa > 1);
            for step in [Step::DepthPrepass, Step::GBuffer, Step::ForwardShade, Step::DeferredShade] {
                assert!(!plan.has(step), "{step:?} in the visibility buffer's plan");
            }
            let memory = r.outputs().memory;
            assert_eq!(memory.get("visibility.ids"), u64::from(W * H * msaa * 4));
            // The texture arrays only for the scene with a texture.
            assert_eq!(memory.get("scene.textures") > 0, textures);
            // The compute raster's texels (8 bytes a pixel) only with it; its own R32Float
            // depth only with blended geometry (none here: it writes the frame's).
            let compute = raster == Raster::Compute;
            assert_eq!(memory.get("visibility.compute_raster.texels"), if compute { u64::from(W * H * 8) } else { 0 });
            assert_eq!(memory.get("visibility.compute_depth"), 0);
            assert_eq!(r.passes::<VisibilityFrame>().expect("visibility").raster().compute().is_some(), compute);
            let depth_format = r.outputs().targets.depth.format();
            assert_eq!(depth_format == wgpu::TextureFormat::R32Float, compute, "{depth_format:?}");
            for (category, _) in &memory.entries {
                assert!(
                    !category.starts_with("deferred.") && !category.starts_with("forward."),
                    "{category} allocated for the visibility buffer"
                );
            }
        }
    }
}

/// The IDs split per scene: the mixed scene's 9 instances take 4 bits and its largest mesh
/// (the cube, 12 triangles) 4; the raster's IDs read back name only real (instance,
/// triangle) pairs or the clear value, and cover exactly the pixels with depth.
#[test]
fn ids_name_real_triangles_where_there_is_depth() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let camera = scenes::mixed_camera(W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 50, 10, 3)).unwrap();
    let mut r = renderer(ctx, &sg, &lights, FrameSettings { method: Method::Visibility, ..Default::default() });
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, &sg, &camera).unwrap();
    let vf = r.passes::<VisibilityFrame>().expect("visibility");
    let layout = vf.raster().layout;
    assert_eq!((layout.triangle_bits, layout.instances, layout.max_triangles), (4, 9, 12));
    let ids = vf.raster().read_ids(&ctx.device, &ctx.queue).unwrap();
    let depth = r.read_depth(ctx).unwrap();
    let mut covered = 0;
    for (i, (&id, &d)) in ids.iter().zip(&depth).enumerate() {
        match layout.unpack(id) {
            None => assert!(d <= 0.0, "pixel {i}: depth {d} without a triangle"),
            Some((instance, triangle)) => {
                assert!(d > 0.0, "pixel {i}: triangle ({instance}, {triangle}) without depth");
                let mesh = scene.instances[sg.instance_order[instance as usize]].mesh;
                assert!((triangle as usize) < scene.meshes[mesh].indices.len() / 3, "pixel {i}: triangle {triangle}");
                covered += 1;
            }
        }
    }
    assert!(covered > (W * H / 2) as usize, "{covered} pixels covered");
}

/// The compute raster where it cannot run: MSAA is refused by name (it draws one sample),
/// as is Forward+ with it; on a device without 64-bit buffer atomics (lavapipe and the H200
/// have them: the device is made without) it is refused naming the feature, and the
/// default (`Raster::Auto`) draws with the hardware raster there, as it does on a CPU
/// adapter and with MSAA.
#[test]
fn the_compute_raster_refuses_what_it_cannot_draw() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 20, 0, 3)).unwrap();
    let compute = FrameSettings {
        method: Method::Visibility,
        knobs: Knobs { raster: Raster::Compute, ..Knobs::default() },
        ..Default::default()
    };
    let e = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings { msaa: 4, ..compute }).err().expect("MSAA");
    assert!(e.to_string().contains("one sample a pixel") && e.to_string().contains("4x MSAA"), "{e}");
    let e = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings { method: Method::ForwardPlus, ..compute });
    assert!(e.err().expect("Forward+").to_string().contains("visibility buffer only"));
    let auto = FrameSettings { method: Method::Visibility, msaa: 4, ..Default::default() };
    assert_eq!(renderer(ctx, &sg, &lights, auto).settings().knobs.raster, Raster::Hardware, "Auto with MSAA");
    let expected =
        if ctx.info.device_type == wgpu::DeviceType::DiscreteGpu { Raster::Compute } else { Raster::Hardware };
    let auto = FrameSettings { method: Method::Visibility, ..Default::default() };
    assert_eq!(
        renderer(ctx, &sg, &lights, auto).settings().knobs.raster,
        expected,
        "Auto on {:?}",
        ctx.info.device_type
    );
    // A device without the atomics.
    let without = wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX;
    let small = GpuContext::headless(ContextOptions { without_features: without, ..Default::default() }).unwrap();
    assert!(!small.device.features().contains(without));
    let sg = SceneGpu::new(&small.device, &small.queue, &scene).unwrap();
    let lights = LightBuffers::new(&small.device, &scenes::lights(&scene, 20, 0, 3)).unwrap();
    let e: GpuError = FrameRenderer::new(&small, &sg, &lights, W, H, compute).err().expect("no atomics");
    assert!(
        e.to_string().contains("SHADER_INT64_ATOMIC_MIN_MAX") && e.to_string().contains("--raster hardware"),
        "{e}"
    );
    let r = FrameRenderer::new(&small, &sg, &lights, W, H, auto).expect("Auto without the atomics");
    assert_eq!(r.settings().knobs.raster, Raster::Hardware);
}
