//! A whole run without a command line: plain `Settings` in, a PNG out. `Prepared::new`
//! checks the settings (an error names the setting), builds the scene, its lights and the
//! camera, creates the device and uploads everything; `renderer` builds the method's
//! frame; a change of settings would go through `Prepared::reconfigure`, which rebuilds
//! only what the change needs.
//!
//! Run with `cargo run --release -p tiledlight-setup --example render_png -- out/render_png.png`.

use tiledlight_frame::Diagnostics as _;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_setup::{Method, Prepared, Settings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "out/render_png.png".into());
    // Tiled Deferred, 1,024 lights (the default), 16 of them casting shadows.
    let settings = Settings {
        method: Method::TiledDeferred,
        width: 640,
        height: 360,
        shadow_point_lights: 16,
        ..Settings::default()
    };
    let prep = Prepared::new(&settings)?;
    println!("adapter: {}", prep.ctx.describe());
    let mut renderer = prep.renderer(false)?;
    let mut timer = GpuTimer::new(&prep.ctx)?;
    renderer.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera)?;
    let rgba = renderer.read_ldr(&prep.ctx)?;
    let image = image::RgbaImage::from_raw(settings.width, settings.height, rgba).ok_or("RGBA8 pixels")?;
    if let Some(dir) = std::path::Path::new(&out).parent() {
        std::fs::create_dir_all(dir)?;
    }
    image.save(&out)?;
    println!("{}, {} lights: wrote {out}", prep.scene_name, prep.lights.len());
    Ok(())
}
