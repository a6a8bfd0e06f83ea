//! `tiledlight export`: writes the scene, the lights and the camera that `render` with the
//! same flags draws as one glTF file (`.gltf` + `.bin`, or `.glb`) another engine reads
//! (tiledlight-setup's `export`, whose docs say what is written; the lights as
//! `KHR_lights_punctual` with range = radius and intensity 1:1 in candela). Reading the
//! file back (`--scene FILE`) gives the same lights and camera. Renderer flags are
//! accepted (the flags are `render`'s) and change nothing but the camera's
//! `extras.tiledlight` (size, exposure, ambient light).
//!
//! May depend on [`crate::scene_setup`] and tiledlight-setup.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use tiledlight_setup::export::{export, ExportFormat, FrameExtras};
use tiledlight_setup::SceneCpu;

use crate::scene_setup::SceneArgs;
use tiledlight_lab::output::print_load_warnings;

/// Flags of `tiledlight export`.
#[derive(Args, Clone, Debug)]
pub struct ExportArgs {
    /// Scene, lights and screen (the renderer flags change nothing in the file but the
    /// camera's extras).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Output file: .gltf (its buffer in a .bin of the same name beside it) or .glb.
    #[arg(long, value_name = "FILE.gltf|FILE.glb")]
    pub out: PathBuf,
}

/// Runs `tiledlight export`.
pub fn run(args: &ExportArgs) -> Result<()> {
    // The extension first: a typo costs no scene building.
    ExportFormat::of_path(&args.out)?;
    tiledlight_lab::output::check_output("--out", &args.out)?;
    let settings = args.scene.settings()?;
    let cpu = SceneCpu::load(&settings)?;
    print_load_warnings(&cpu.warnings);
    let s = export(&cpu, &settings, &args.out)?;
    let frame = FrameExtras::of(&settings);
    println!(
        "scene:      {} ({} instances, {} glTF meshes, {} materials, {} images)",
        cpu.scene.name, s.instances, s.meshes, s.materials, s.images
    );
    println!(
        "lights:     {} point + {} spot, KHR_lights_punctual: range = radius, intensity in candela = tiledlight intensity (both deliver colour x intensity / d^2)",
        s.point_lights, s.spot_lights
    );
    println!("camera:     {} ({}x{})", cpu.camera_source, frame.width, frame.height);
    match frame.exposure {
        Some(e) => println!("exposure:   {e}, fixed (in the camera's extras.tiledlight)"),
        None => println!(
            "exposure:   automatic in tiledlight: the file holds none (give --exposure for a renderer without automatic exposure)"
        ),
    }
    let files: Vec<String> = s.files.iter().map(|f| f.display().to_string()).collect();
    println!("wrote {} ({} bytes)", files.join(" + "), s.bytes);
    Ok(())
}
