//! Integer packing, carries and saturation driven across their boundaries on the GPU
//! (issue 43, class 4), each against its CPU twin:
//!
//! - the caster ranking's scores (`shaders/light_contribution.wgsl`, twin
//!   `tiledlight_cull::contribution`): (tile, light) pairs quantised to `u32` units,
//!   saturating at `PAIR_MAX`, summed per light in a 64-bit (low word, carry into the high
//!   word) atomic score. Under the production scale no pair comes near `2^32` (by design),
//!   so the scale is raised through the kernel's test hook (`LightContribution::set_scale`)
//!   until many pairs saturate and most lights' sums cross `2^32` several times: a
//!   failure means a dropped or doubled carry, or a saturation value other than the twin's
//!   `u32::MAX`;
//! - the visibility buffer's IDs (`(instance << triangle_bits) | triangle`,
//!   `tiledlight_cull::visibility::IdLayout`) in scenes whose largest instance slot and
//!   triangle index fill their bit fields exactly (2^k triangles, 2^m instances), whose
//!   triangle field is empty (one-triangle meshes: 0 bits) and whose mesh needs one bit
//!   more than a power of two (5 triangles: 3 bits), drawn by the hardware and the compute
//!   raster and compared with the twin's IDs exactly: a failure means a shift or a bit
//!   width off by one between the CPU's layout and a raster's packing.
//!
//! The refusal of a scene past 32 bits, the largest layout that fits and the first that
//! does not are checked on the CPU (`crates/cull/tests/boundaries.rs`): no GPU scene that
//! large fits in a test.

use glam::{Mat4, Vec3, Vec4};
use tiledlight_cull::camera::Projection;
use tiledlight_cull::contribution::light_scores;
use tiledlight_cull::raster::{unpack, Cull, Raster};
use tiledlight_cull::visibility::IdLayout;
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::caster_rank::ranking_settings;
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method, VisibilityFrame};
use tiledlight_gpu::contribution::{ContributionInputs, LightContribution};
use tiledlight_gpu::features::Raster as RasterPath;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::{Aabb, Instance, Mesh, Scene};
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::{gpu, scenes};
use tiledlight_visibility::compute_raster::{ComputeRasterOptions, LargeRaster};

// ---- Caster-ranking scores past 2^32 ----

const W: u32 = 160;
const H: u32 = 96;

/// Relative allowance between a GPU score and its twin's where some pair is not saturated
/// with margin: the f32 sums differ by fused multiply-adds and the GPU's sqrt rounding, a
/// few ulps a term (tests/tests/casters.rs derives the same 1e-4), plus one unit a pair
/// for the truncation to whole units.
const REL: f64 = 1e-4;

/// The factor the production scale is raised by: the courtyard's strongest pairs are
/// ~1e-4 of the theoretical peak `pair_scale` maps to `PAIR_MAX`, so 2^24 makes them
/// saturate with a wide margin while the far, dim pairs stay below.
const RAISE: f32 = 16_777_216.0;

#[test]
fn contribution_scores_saturate_and_carry_past_2_32_like_the_twin() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let lights = scenes::lights(&scene, 64, 16, 11);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();
    let mut r = FrameRenderer::new(ctx, &sg, &lb, W, H, ranking_settings(lb.len(), &ctx.device.limits())).unwrap();
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, &sg, &camera).unwrap();
    let out = r.outputs();
    let grid = out.light_grid.expect("Forward+ has a light grid");
    let inputs = ContributionInputs {
        depth: tiledlight_gpu::targets::target_handles(out.targets).0,
        lights: &lb,
        lighting: &r.shared().lighting,
        grid,
    };
    let mut kernel = LightContribution::new(&ctx.device, &r.shared().views, inputs).unwrap();
    let scale = kernel.scale * RAISE;
    kernel.set_scale(&ctx.queue, scale);
    let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test") });
    kernel.record(&mut encoder, &timer, r.shared().main_view());
    ctx.queue.submit([encoder.finish()]);
    let gpu_scores = kernel.read(&ctx.device, &ctx.queue, lb.len()).unwrap();
    let lists = r.read_lists(ctx).unwrap();
    assert_eq!(lists.overflowing, 0, "the ranking frame's grid holds every pair");
    let (lists, grid, depth) = (lists.lists, r.shared().grid, r.read_depth(ctx).unwrap());
    let packed = &lb.packed;
    let twin = |s: f32| light_scores(&camera, &depth, (&grid, &lists), packed, s).unwrap();
    let cpu = twin(scale);
    // Per light: its pairs, and whether every one of them saturates even at half the scale
    // (then no rounding on either side can bring it under PAIR_MAX: the score is exactly
    // pairs x u32::MAX on both).
    let n = packed.len();
    let mut pairs = vec![0u64; n];
    lists.iter().flatten().for_each(|&i| pairs[i as usize] += 1);
    let half = twin(scale / 2.0);
    let saturated: Vec<bool> = (0..n).map(|i| pairs[i] > 0 && half[i] == pairs[i] * u64::from(u32::MAX)).collect();
    let carried = cpu.iter().filter(|&&s| s >> 32 >= 2).count();
    let sat = saturated.iter().filter(|&&s| s).count();
    let partial = (0..n).filter(|&i| !saturated[i] && cpu[i] > 0).count();
    eprintln!("{n} lights: {sat} with every pair saturated, {partial} others lit, {carried} past 2 x 2^32");
    assert!(sat >= 3 && partial >= 3 && carried >= 5, "the raised scale must saturate some lights and not others");
    let mut wrong = Vec::new();
    for i in 0..n {
        let (g, c) = (gpu_scores[i], cpu[i]);
        let allowed = if saturated[i] { 0 } else { (REL * g.max(c) as f64) as u64 + pairs[i] };
        if g.abs_diff(c) > allowed {
            wrong.push((i, g, c, saturated[i]));
        }
    }
    assert!(wrong.is_empty(), "scores outside the allowance (light, GPU, CPU, saturated): {wrong:?}");
    // The comparison's teeth: a score with one carry dropped, and a saturated pair stored
    // as PAIR_MAX's 4294967040 instead of u32::MAX, fail it.
    let i = (0..n).find(|&i| saturated[i] && pairs[i] >= 2).expect("a saturated light with two pairs");
    assert_ne!(gpu_scores[i] - (1 << 32), cpu[i]);
    assert_ne!(gpu_scores[i] - 255, cpu[i], "a saturated score must match to the unit");
}

// ---- Visibility-buffer IDs at their bit boundaries ----

const VW: u32 = 64;
const VH: u32 = 64;

/// One unit a pixel, exactly (see tests/tests/raster_rules.rs): world (x, y) = window
/// (x - 32, 32 - y); depth 0.5 at z = -1.
fn pixel_camera() -> Camera {
    let p = Projection::Orthographic { half_height: VH as f32 / 2.0, aspect: 1.0, near: 0.0, far: 2.0 };
    Camera::from_view(Mat4::IDENTITY, p).expect("camera")
}

/// `instances` instances of a mesh of `triangles` small triangles (a strip of 2-pixel right
/// triangles), each instance placed on its own cell of an 8 x 8 grid of 8-pixel cells.
fn id_scene(instances: u32, triangles: u32) -> Scene {
    let mut mesh = Mesh { name: "strip".into(), ..Mesh::default() };
    for t in 0..triangles {
        // Triangle t in row t / 3, column t % 3 of the cell: 2 px legs, vertices off the
        // pixel centres (no fill-rule ties here).
        let (x, y) = ((t % 3) as f32 * 2.4 + 0.3, (t / 3) as f32 * 2.4 + 0.3);
        for (dx, dy) in [(0.0, 0.0), (2.1, 0.0), (0.0, 2.1)] {
            mesh.indices.push(mesh.positions.len() as u32);
            mesh.positions.push([x + dx, -(y + dy), 0.0]);
            mesh.normals.push([0.0, 0.0, 1.0]);
            mesh.uvs.push([0.0, 0.0]);
        }
    }
    let mut m = scenes::material("m", [0.8, 0.8, 0.8, 1.0], 0.5, 0.0);
    m.double_sided = true;
    let instances = (0..instances)
        .map(|k| {
            let (cx, cy) = ((k % 8) as f32 * 8.0 - 32.0, 32.0 - (k / 8) as f32 * 8.0);
            Instance { mesh: 0, material: 0, transform: Mat4::from_translation(Vec3::new(cx, cy, -1.0)) }
        })
        .collect();
    Scene {
        name: "ids".into(),
        meshes: vec![mesh],
        materials: vec![m],
        textures: vec![],
        instances,
        lights: vec![],
        camera: None,
        bounds: Aabb::new(Vec3::new(-32.0, -32.0, -2.0), Vec3::new(32.0, 32.0, 0.0)),
    }
}

#[test]
fn ids_fill_their_bit_fields_exactly_in_every_raster() {
    let ctx = gpu();
    let need = wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX;
    assert!(ctx.device.features().contains(need), "the compute raster needs 64-bit atomics: {}", ctx.info.name);
    let cam = pixel_camera();
    // (instances, triangles a mesh, the expected triangle bits): both fields full (2 + 6
    // bits, the largest ID 255 all ones), an empty triangle field, and a mesh one past a
    // power of two.
    for (instances, triangles, bits) in [(64, 4, 2), (40, 1, 0), (3, 5, 3), (1, 9, 4)] {
        let scene = id_scene(instances, triangles);
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let layout = IdLayout::for_scene(instances, triangles).unwrap();
        assert_eq!(layout.triangle_bits, bits, "{instances} instances x {triangles} triangles");
        // The twin: every triangle of every instance slot, with the layout's ID.
        let vp = cam.view_proj();
        let mut twin = Raster::new(VW, VH);
        let mut largest = 0;
        for (slot, &i) in sg.instance_order.iter().enumerate() {
            let inst = &scene.instances[i];
            for (t, idx) in scene.meshes[0].indices.chunks_exact(3).enumerate() {
                let clip: [Vec4; 3] = [0, 1, 2].map(|k| {
                    vp * (inst.transform * Vec3::from(scene.meshes[0].positions[idx[k] as usize]).extend(1.0))
                });
                let id = layout.pack(slot as u32, t as u32);
                largest = largest.max(id);
                twin.draw(clip, id, Cull::None);
            }
        }
        let twin_ids: Vec<u32> = twin.texels.iter().map(|&t| unpack(t).1).collect();
        if instances == 64 {
            assert_eq!(largest, 255, "the largest ID fills both fields");
        }
        assert!(twin_ids.contains(&largest), "the largest ID is on screen");
        let light = Light::point(Vec3::new(0.0, 0.0, 1.0), Vec3::ONE, 1.0, 100.0).unwrap();
        let lights = LightBuffers::new(&ctx.device, &[light]).unwrap();
        let opts = |large_px, large| ComputeRasterOptions { large_px, large };
        for (what, raster, options) in [
            ("hardware", RasterPath::Hardware, ComputeRasterOptions::default()),
            ("compute", RasterPath::Compute, opts(u32::MAX, LargeRaster::Compute)),
            ("compute, large by a workgroup", RasterPath::Compute, opts(0, LargeRaster::Compute)),
            ("compute, large by the hardware", RasterPath::Compute, opts(0, LargeRaster::Hardware)),
        ] {
            let knobs =
                Knobs { raster, raster_large_px: options.large_px, raster_large: options.large, ..Knobs::default() };
            let s = FrameSettings { method: Method::Visibility, knobs, ..Default::default() };
            let mut r = FrameRenderer::new(ctx, &sg, &lights, VW, VH, s).unwrap();
            render_frame(ctx, &mut r, &sg, &cam);
            let vf = r.passes::<VisibilityFrame>().unwrap();
            assert_eq!(vf.raster().layout, layout, "{what}: the frame's layout");
            let ids = vf.raster().read_ids(&ctx.device, &ctx.queue).unwrap();
            let differ: Vec<(u32, u32, u32)> =
                (0..ids.len()).filter(|&p| ids[p] != twin_ids[p]).map(|p| (p as u32, ids[p], twin_ids[p])).collect();
            assert!(
                differ.is_empty(),
                "{instances} x {triangles} ({bits} triangle bits), {what}: {} pixels (pixel, GPU, twin): {:?}",
                differ.len(),
                &differ[..differ.len().min(8)]
            );
        }
    }
}
