//! Forward+ against the brute-force reference on the same frame (same BRDF, same radius
//! cutoff): the images must be the same up to float summation order, since culling is
//! conservative and every light a pixel sees is in its tile list.
//!
//! Tolerances: `tiledlight_tests::compare::FORWARD_VS_REFERENCE` (HDR 4e-3 relative, FLIP
//! mean 1e-3, p99 1e-2) and the reasons for them.

use tiledlight_cull::Camera;
use tiledlight_frame::{FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::GpuContext;
use tiledlight_scene::Scene;
use tiledlight_tests::compare::{assert_matches_reference_frame, Frame, FORWARD_VS_REFERENCE};
use tiledlight_tests::images::FlipThresholds;
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

fn render(
    ctx: &GpuContext,
    scene: &SceneGpu,
    lights: &LightBuffers,
    camera: &Camera,
    settings: FrameSettings,
) -> Frame {
    let mut r = FrameRenderer::new(ctx, scene, lights, W, H, settings).unwrap();
    tiledlight_tests::compare::render_frame(ctx, &mut r, scene, camera)
}

fn compare(name: &str, scene: &Scene, n_point: u32, n_spot: u32, camera: &Camera, cull: CullOptions) {
    let ctx = gpu();
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
    let light_list = scenes::lights(scene, n_point, n_spot, 42);
    let lights = LightBuffers::new(&ctx.device, &light_list).unwrap();
    let reference = render(
        ctx,
        &scene_gpu,
        &lights,
        camera,
        FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() },
    );
    let tiled = render(
        ctx,
        &scene_gpu,
        &lights,
        camera,
        FrameSettings { method: Method::ForwardPlus, cull, ..Default::default() },
    );
    // The frame must be lit: a black or ambient-only image would pass trivially.
    let lit = reference.hdr.iter().filter(|p| p[0] + p[1] + p[2] > 0.1).count();
    assert!(
        lit * 4 > reference.hdr.len(),
        "{name}: only {lit} of {} pixels are lit; the comparison would test nothing",
        reference.hdr.len()
    );
    assert_matches_reference_frame(name, W, &reference, &tiled, FORWARD_VS_REFERENCE);
}

#[test]
fn courtyard_points() {
    let scene = scenes::courtyard();
    compare("fwd-courtyard", &scene, 1024, 0, &scenes::courtyard_camera(&scene, W, H), CullOptions::default());
}

#[test]
fn courtyard_points_and_spots_tile32_aabb_cone() {
    let scene = scenes::courtyard();
    let cull = CullOptions { tile_size: 32, aabb: true, spot_cone: true, ..Default::default() };
    compare("fwd-courtyard-spots", &scene, 512, 256, &scenes::courtyard_camera(&scene, W, H), cull);
}

#[test]
fn mixed_materials_half_z_tile8() {
    let scene = scenes::mixed_scene();
    let cull = CullOptions { tile_size: 8, half_z: true, ..Default::default() };
    compare("fwd-mixed-halfz", &scene, 400, 100, &scenes::mixed_camera(W, H), cull);
}

/// Regression guard: the Forward+ image of the mixed scene against the stored
/// `tests/reference/forward-mixed.png`, made on lavapipe (rewrite it with
/// TILEDLIGHT_UPDATE_REFERENCES=1 after an intended change, and look at it).
///
/// Per adapter, as wgpu's suite states its expectations: on lavapipe FLIP mean <= 5e-3 and
/// p99 <= 5e-2 (another Mesa version rasterises edges and rounds f16 slightly
/// differently). Other GPUs: measured on the H200 while textures went through its texture
/// unit (Vulkan guarantees 4 sub-texel bits, which moved where the checker screen's
/// filtered alpha mask crosses its cutoff): the difference lay on the screen alone, FLIP
/// mean 0.0052, p99 0.036; there mean <= 1e-2, p99 <= 5e-2. Textures are now filtered in the
/// shader in f32 on every adapter (issue 46), so that part of the difference should shrink;
/// not yet measured. A changed BRDF, tonemap, camera or culling fault moves the whole frame,
/// far more than either bound. The stored image was redrawn at issue 46 (mips averaged in
/// linear light, filtered in the shader): the checker screen alone changed (FLIP mean
/// 0.0084 against the old image, nothing elsewhere).
#[test]
fn mixed_scene_matches_stored_reference() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 200, 40, 42)).unwrap();
    let frame = render(ctx, &scene_gpu, &lights, &scenes::mixed_camera(W, H), FrameSettings::default());
    tiledlight_tests::images::assert_matches_reference(
        "forward-mixed",
        W,
        H,
        &frame.ldr,
        if tiledlight_tests::is_lavapipe(ctx) {
            FlipThresholds { mean: 5e-3, percentile: (0.99, 5e-2) }
        } else {
            FlipThresholds { mean: 1e-2, percentile: (0.99, 5e-2) }
        },
    );
}
