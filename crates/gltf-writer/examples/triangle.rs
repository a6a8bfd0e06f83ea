//! A glTF file written piece by piece: one buffer of a triangle's positions, normals, UVs
//! and indices, a mesh, a node and a scene, saved as `.gltf` with its `.bin` beside it and
//! as one `.glb`. Any glTF viewer (or `tiledlight render --scene out/triangle.glb`) opens it.
//!
//! Run with `cargo run -p tiledlight-gltf-writer --example triangle -- out`.

use serde_json::json;
use tiledlight_gltf_writer::{save_glb, save_gltf, Buffer};

fn main() -> std::io::Result<()> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".into()));
    std::fs::create_dir_all(&dir)?;
    let mut buffer = Buffer::default();
    let primitive = buffer.triangle();
    let root = buffer.document(json!({
        "meshes": [{ "primitives": [primitive] }],
        "nodes": [{ "mesh": 0 }],
        "scenes": [{ "nodes": [0] }],
        "scene": 0,
    }));
    let gltf = dir.join("triangle.gltf");
    let bin = save_gltf(&gltf, root.clone(), &buffer.data)?;
    let glb = dir.join("triangle.glb");
    save_glb(&glb, &root, &buffer.data)?;
    println!(
        "wrote {} (with {}) and {} ({} bytes of buffer)",
        gltf.display(),
        bin.display(),
        glb.display(),
        buffer.data.len()
    );
    Ok(())
}
