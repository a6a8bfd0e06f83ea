//! Fuzz target: any bytes, loaded as a glTF or GLB file by `load_gltf_bytes`. The file is
//! "in" a folder made once per process holding a small buffer (`a.bin`) and image
//! (`a.png`), so URIs naming them get past the file checks and feed the accessor and
//! image paths. Loading must return (Ok or Err) without panicking; libFuzzer's own
//! timeout and RSS limit catch hangs and runaway allocation, kept far away by the small
//! `LoadLimits` below.

#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use tiledlight_scene::{load_gltf_bytes, LoadLimits, LoadOptions};

/// The folder the fuzzed file is loaded from, with its two files.
fn model_dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("tiledlight-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("creating the fuzz model folder");
        let bin: Vec<u8> = (0..=255u8).cycle().take(1024).collect();
        std::fs::write(dir.join("a.bin"), bin).expect("writing a.bin");
        let img = image::RgbaImage::from_fn(4, 4, |x, y| image::Rgba([(x * 60) as u8, (y * 60) as u8, 128, 255]));
        img.save(dir.join("a.png")).expect("writing a.png");
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let options = LoadOptions {
        limits: LoadLimits { image_bytes: 4 << 20, texture_bytes: 16 << 20, scene_bytes: 64 << 20 },
        ..LoadOptions::new(0.01)
    };
    let name = if data.starts_with(b"glTF") { "input.glb" } else { "input.gltf" };
    let _ = load_gltf_bytes(data, &model_dir().join(name), &options);
});
