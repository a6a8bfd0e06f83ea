//! Tiled Deferred and the visibility buffer against Forward+ and the brute-force reference
//! on the same frame (the visibility buffer by `compare::assert_visibility_matches`), the
//! G-buffer stress knob (2 vs 5 targets: the same image), and its per-tile light lists
//! against the CPU reference culler.
//!
//! Tolerance vs the reference: `tiledlight_tests::compare::DEFERRED_VS_REFERENCE` (HDR 3e-2
//! relative, FLIP mean 0.015, p99 0.05) and the reasons for them (8-bit sRGB albedo, f16
//! normal, positions rebuilt from depth); deferred vs Forward+ uses its FLIP limits.

use tiledlight_frame::{DeferredFrame, Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;
use tiledlight_tests::compare::{
    assert_matches_reference_frame, assert_same_hdr, assert_visibility_matches, render_frame, visibility_frames,
    DEFERRED_VS_REFERENCE, RASTER_POSITION_ERROR_PX, VISIBILITY_VS_REFERENCE,
};
use tiledlight_tests::images::{assert_flip, documented_heat_colour, linear_to_srgb, srgb_to_linear};
use tiledlight_tests::lists::{assert_lists_match, CulledFrame};
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

fn frame(
    ctx: &GpuContext,
    r: &mut FrameRenderer,
    scene: &SceneGpu,
    camera: &tiledlight_cull::Camera,
) -> (Vec<[f32; 4]>, Vec<u8>) {
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, scene, camera).unwrap();
    (r.read_hdr(ctx).unwrap(), r.read_ldr(ctx).unwrap())
}

fn compare_with_forward(
    name: &str,
    scene: &tiledlight_scene::Scene,
    n_point: u32,
    n_spot: u32,
    camera: tiledlight_cull::Camera,
    cull: CullOptions,
) {
    let ctx = gpu();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(scene, n_point, n_spot, 21)).unwrap();
    let mut bf = FrameRenderer::new(
        ctx,
        &sg,
        &lights,
        W,
        H,
        FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() },
    )
    .unwrap();
    // The G-buffer's packed normal moves grazing lights (tiledlight_tests::compare::Frame::allow_gbuffer_normals).
    let plain_reference = render_frame(ctx, &mut bf, &sg, &camera);
    let depth = bf.read_depth(ctx).unwrap();
    let reference = plain_reference.clone().allow_gbuffer_normals(&depth, W, &camera, &lights.packed);
    let mut forward =
        FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings { cull, ..Default::default() }).unwrap();
    let forward = render_frame(ctx, &mut forward, &sg, &camera);
    let mut deferred = FrameRenderer::new(
        ctx,
        &sg,
        &lights,
        W,
        H,
        FrameSettings {
            method: Method::TiledDeferred,
            cull,
            knobs: Knobs { gbuffer_rts: 3, ..Knobs::default() },
            ..Default::default()
        },
    )
    .unwrap();
    let deferred = render_frame(ctx, &mut deferred, &sg, &camera);
    let lit = reference.hdr.iter().filter(|p| p[0] + p[1] + p[2] > 0.1).count();
    assert!(lit * 4 > reference.hdr.len(), "{name}: frame mostly unlit; the comparison would test nothing");
    assert_matches_reference_frame(
        &format!("{name}-deferred-vs-reference"),
        W,
        &reference,
        &deferred,
        DEFERRED_VS_REFERENCE,
    );
    assert_flip(&format!("{name}-deferred-vs-forward"), W, H, &forward.ldr, &deferred.ldr, DEFERRED_VS_REFERENCE.flip);
    // The visibility buffer: the same lists as Forward+ (its culling pass), no G-buffer;
    // drawn by each raster.
    let plain_reference =
        plain_reference.allow_position_error(&depth, W, (&camera, &lights.packed), RASTER_POSITION_ERROR_PX);
    let s = FrameSettings { method: Method::Visibility, cull, ..Default::default() };
    for (raster, vis, ties) in visibility_frames(ctx, (&sg, &lights, &camera), (W, H), s) {
        let name = format!("{name}-visibility-{}", raster.name());
        let reference = plain_reference.clone().forgive_hdr(&ties).0;
        assert_visibility_matches(&format!("{name}-vs-reference"), W, (&reference, &vis), false);
        assert_flip(&format!("{name}-vs-forward"), W, H, &forward.ldr, &vis.ldr, VISIBILITY_VS_REFERENCE.flip);
        assert_flip(&format!("{name}-vs-deferred"), W, H, &deferred.ldr, &vis.ldr, DEFERRED_VS_REFERENCE.flip);
    }
}

#[test]
fn courtyard_matches_forward_and_reference() {
    let scene = scenes::courtyard();
    compare_with_forward("courtyard", &scene, 1024, 0, scenes::courtyard_camera(&scene, W, H), CullOptions::default());
}

#[test]
fn mixed_scene_spots_half_z_aabb_tile8_match() {
    let scene = scenes::mixed_scene();
    let cull = CullOptions { tile_size: 8, half_z: true, aabb: true, spot_cone: true, ..Default::default() };
    compare_with_forward("mixed", &scene, 300, 100, scenes::mixed_camera(W, H), cull);
}

/// The extra G-buffer targets are white and multiplied in: 2 to 5 targets give the same
/// image. On lavapipe bit for bit. On a parallel GPU within one f16 step per channel
/// (2^-10 relative): a tile's lights are appended to its list with atomics, so their order,
/// and with it the f32 summation order, changes from run to run even at the same settings
/// (measured on the H200: 1-6 of 57,600 pixels differ by at most 9.6e-4 relative between
/// two identical runs). A target multiplied in that is not white, or shading that depends
/// on the target count, moves pixels by far more.
#[test]
fn gbuffer_targets_do_not_change_the_image() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 200, 20, 3)).unwrap();
    let camera = scenes::mixed_camera(W, H);
    let images: Vec<Vec<[f32; 4]>> = (2..=5)
        .map(|rts| {
            let mut r = FrameRenderer::new(
                ctx,
                &sg,
                &lights,
                W,
                H,
                FrameSettings {
                    method: Method::TiledDeferred,
                    knobs: Knobs { gbuffer_rts: rts, ..Knobs::default() },
                    ..Default::default()
                },
            )
            .unwrap();
            assert_eq!(r.passes::<DeferredFrame>().expect("Tiled Deferred").gbuffer().rts(), rts);
            frame(ctx, &mut r, &sg, &camera).0
        })
        .collect();
    let exact = tiledlight_tests::is_lavapipe(ctx);
    for (i, img) in images.iter().enumerate().skip(1) {
        if exact {
            assert!(img == &images[0], "{} targets differ from 2", i + 2);
            continue;
        }
        assert_same_hdr(img, &images[0], W, false, &format!("{} targets against 2", i + 2));
    }
    let e = FrameRenderer::new(
        ctx,
        &sg,
        &lights,
        W,
        H,
        FrameSettings {
            method: Method::TiledDeferred,
            knobs: Knobs { gbuffer_rts: 6, ..Knobs::default() },
            ..Default::default()
        },
    )
    .err()
    .expect("6 targets refused");
    assert!(e.to_string().contains("2..=5"), "{e}");
}

/// The lights each tile of the deferred pass is shaded with (the lists it writes to the
/// light grid) equal the CPU reference culler's, list for list as sets, with the
/// shared float-borderline acceptance (`tiledlight_tests::lists`); the per-list counts (the
/// heat map's input, read by the same reader) must equal the stored lists. Catches a
/// deferred pass that shades a tile with the wrong lights even when their number is right
/// (a count-only check passes that).
#[test]
fn deferred_lists_equal_cpu_reference() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let (w, h) = (327, 183);
    let camera = scenes::courtyard_camera(&scene, w, h);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 700, 100, 4)).unwrap();
    for cull in [
        CullOptions::default(),
        CullOptions { tile_size: 32, half_z: true, aabb: true, spot_cone: true, coarse: false, ..Default::default() },
    ] {
        let mut r = FrameRenderer::new(
            ctx,
            &sg,
            &lights,
            w,
            h,
            FrameSettings { method: Method::TiledDeferred, cull, heatmap: true, ..Default::default() },
        )
        .unwrap();
        let mut timer = GpuTimer::new(ctx).unwrap();
        r.render_once(ctx, &mut timer, &sg, &camera).unwrap();
        let depth = r.read_depth(ctx).unwrap();
        let gpu_lists = r.read_lists(ctx).unwrap();
        let frame = CulledFrame { depth: &depth, width: w, height: h, camera: &camera, lights: &lights.packed };
        let c = assert_lists_match(&format!("deferred {cull:?}"), &frame, &gpu_lists, &cull.to_config(true));
        assert!(c.pairs > 0, "lights reach the tiles");
        // The heat map over the same frame without it: every tile's centre pixel is the
        // documented blend for the tile's count (summed over half-z's two lists, as
        // shaders/heatmap.wgsl documents), within
        // 2/255 (8-bit rounding of two images; the light order, and so the plain image, may
        // differ by an f16 step between runs). Catches a heat map fed another buffer, other
        // counts, or not drawn (the old check, "some blue pixel", passed on random light
        // colours alone).
        let heat = r.read_ldr(ctx).unwrap();
        let mut plain = FrameRenderer::new(
            ctx,
            &sg,
            &lights,
            w,
            h,
            FrameSettings { method: Method::TiledDeferred, cull, ..Default::default() },
        )
        .unwrap();
        plain.render_once(ctx, &mut timer, &sg, &camera).unwrap();
        let base = plain.read_ldr(ctx).unwrap();
        let per_tile = if cull.half_z { 2 } else { 1 };
        let grid = c.cpu.grid;
        let mut coloured = 0;
        for ty in 0..grid.tiles_y {
            for tx in 0..grid.tiles_x {
                let t = (ty * grid.tiles_x + tx) as usize;
                let lists = t * per_tile..(t + 1) * per_tile;
                // Magenta when a list lost lights (the grid was full: never with the
                // automatic budget); otherwise the sum of the lists' counts (past the
                // capacity: the palette's end, red).
                let dropped = lists.clone().any(|l| gpu_lists.lists[l].len() < gpu_lists.counts[l] as usize);
                let count: u32 = gpu_lists.counts[lists].iter().sum();
                let (x0, x1, y0, y1) = grid.tile_pixels(tx, ty);
                let i = ((((y0 + y1) / 2) * w + (x0 + x1) / 2) * 4) as usize;
                let under = glam::Vec3::from_array(std::array::from_fn(|k| srgb_to_linear(base[i + k] as f32 / 255.0)));
                let want = match documented_heat_colour(count, cull.capacity, dropped) {
                    None => under,
                    Some((colour, alpha)) => {
                        coloured += 1;
                        colour * alpha + under * (1.0 - alpha)
                    }
                };
                for k in 0..3 {
                    let want = linear_to_srgb(want[k]) * 255.0;
                    let got = heat[i + k] as f32;
                    assert!(
                        (want - got).abs() <= 2.0,
                        "{cull:?}: tile ({tx}, {ty}) count {count}: channel {k} is {got}, expected {want:.1}"
                    );
                }
            }
        }
        assert!(coloured > 0, "{cull:?}: no tile with lights");
    }
}

/// The emission target's write mask: an emissive floor under a plain plate (no lights, only
/// ambient, so every pixel is `ambient x albedo (+ emission)`). The plate's material writes
/// nothing to the emission target and is drawn first; the floor, drawn after, fails the
/// depth test under it, so no floor emission may show through the plate. Tiled Deferred must
/// equal brute force (`DEFERRED_SMALL_EMISSION_VS_REFERENCE` where the emission target is
/// `Rg11b10Ufloat`: its rounding), and the plate's pixels must be ambient x albedo within
/// the G-buffer's 3e-2 (the albedo's 8-bit rounding and the adapter's sRGB decode; measured
/// 1.1% on lavapipe): the floor's emission (0.5, 0.3, 0.1) under them adds 1x to 5x the
/// pixel (measured with the draws swapped: 5.0).
#[test]
fn emission_of_a_hidden_surface_never_shows_through() {
    use glam::{Mat4, Vec3};
    use tiledlight_scene::Material;
    let ctx = gpu();
    let mut scene = scenes::floor_scene(0.8, 0.0, vec![]);
    scene.materials[0].emissive = [0.5, 0.3, 0.1];
    scene.materials[0].emissive_strength = 1.0;
    scene.meshes.push(scenes::quad("plate", 3.0));
    scene.materials.push(Material { name: "plate".into(), base_color: [0.2, 0.4, 0.6, 1.0], ..Material::default() });
    let transform = Mat4::from_translation(Vec3::Y);
    scene.instances.push(tiledlight_scene::Instance { mesh: 1, material: 1, transform });
    let camera = scenes::floor_camera(W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    assert_eq!(sg.material_unlit, vec![true, false]);
    let lights = LightBuffers::new(&ctx.device, &[]).unwrap();
    let ambient = Vec3::splat(0.5);
    let settings = |method| FrameSettings { method, ambient, ..Default::default() };
    let mut bf = FrameRenderer::new(ctx, &sg, &lights, W, H, settings(Method::BruteForce { cutoff: true })).unwrap();
    let reference = render_frame(ctx, &mut bf, &sg, &camera);
    let mut dr = FrameRenderer::new(ctx, &sg, &lights, W, H, settings(Method::TiledDeferred)).unwrap();
    let deferred = render_frame(ctx, &mut dr, &sg, &camera);
    let small = dr.passes::<DeferredFrame>().unwrap().gbuffer().emission_format()
        == Some(tiledlight_deferred::gbuffer::EMISSION_FORMAT_SMALL);
    let t = if small { tiledlight_tests::compare::DEFERRED_SMALL_EMISSION_VS_REFERENCE } else { DEFERRED_VS_REFERENCE };
    assert_matches_reference_frame("hidden-emission-deferred", W, &reference, &deferred, t);
    // The plate's pixels: ambient x its albedo, whatever lies under them.
    let plate_albedo = Vec3::new(0.2, 0.4, 0.6);
    let want = ambient * plate_albedo;
    let plate_pixels: Vec<usize> = (0..(W * H) as usize)
        .filter(|&i| {
            let r = Vec3::from_slice(&reference.hdr[i][..3]);
            (r - want).abs().max_element() < 1e-3
        })
        .collect();
    assert!(plate_pixels.len() > 1000, "the plate covers too few pixels ({})", plate_pixels.len());
    for &i in &plate_pixels {
        let d = Vec3::from_slice(&deferred.hdr[i][..3]);
        assert!(
            ((d - want).abs() / want).max_element() < 3e-2,
            "pixel {i}: deferred {d}, ambient x albedo {want}: emission from under the plate?"
        );
    }
}
