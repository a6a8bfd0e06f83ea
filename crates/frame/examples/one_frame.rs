//! One frame of any method, driven as an engine would drive `tiledlight-frame`: its own
//! device, scene, lights and camera, one `FrameRenderer`, one frame, the image read back.
//!
//! 1. A headless device (`GpuContext::headless`).
//! 2. The built-in courtyard and 1,024 seeded random lights (tiledlight-scene), uploaded
//!    once (`SceneGpu`, `LightBuffers`); the traced reference also needs the scene's BVH.
//! 3. A `FrameRenderer` for the method: every pipeline, buffer and bind group is built
//!    here, once; `render_once` records and submits frames until the automatic exposure
//!    has settled.
//! 4. The tonemapped image (RGBA8) read back and written as a PNG.
//!
//! Run with `cargo run --release -p tiledlight-frame --example one_frame -- deferred
//! out/one_frame.png` (the method's name as `--method` spells it: forward-plus, deferred,
//! visibility, brute-force, traced-reference...).

use tiledlight_cull::Camera;
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::context::{ContextOptions, GpuContext};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::{default_scene, random_lights, DefaultSceneOptions, LightOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let method = Method::from_name(&args.next().unwrap_or_else(|| "forward-plus".into()))?;
    let out = args.next().unwrap_or_else(|| "out/one_frame.png".into());
    let (w, h) = (640u32, 360u32);

    // 1. The device.
    let ctx = GpuContext::headless(ContextOptions::default())?;
    println!("adapter: {}", ctx.describe());

    // 2. Scene, lights, camera.
    let scene = default_scene(&DefaultSceneOptions::default())?;
    let lights = random_lights(&scene.bounds, &LightOptions { num_point: 1024, seed: 1, ..Default::default() })?;
    let mut scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene)?;
    if method.is_traced() {
        scene_gpu.add_trace(&ctx.device, &scene)?;
    }
    let lights = LightBuffers::new(&ctx.device, &lights)?;
    let c = scene.camera.ok_or("the courtyard has a camera")?;
    let camera = Camera::perspective(c.eye, c.target, c.up, c.fov_y, w as f32 / h as f32, c.near, c.far)?;

    // 3. The renderer, built once; one frame.
    let mut renderer =
        FrameRenderer::new(&ctx, &scene_gpu, &lights, w, h, FrameSettings { method, ..Default::default() })?;
    let mut timer = GpuTimer::new(&ctx)?;
    renderer.render_once(&ctx, &mut timer, &scene_gpu, &camera)?;

    // 4. The image.
    let rgba = renderer.read_ldr(&ctx)?;
    let image = image::RgbaImage::from_raw(w, h, rgba).ok_or("one RGBA8 pixel per pixel")?;
    if let Some(dir) = std::path::Path::new(&out).parent() {
        std::fs::create_dir_all(dir)?;
    }
    image.save(&out)?;
    println!("{}: {w}x{h}, 1,024 lights, wrote {out}", method.label());
    Ok(())
}
