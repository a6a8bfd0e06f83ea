//! The scene model on the CPU: the built-in courtyard (TiledLighting11's scene, with the
//! Figure 9 grid of 280 spheres), its random lights (radii from the intensity threshold:
//! `r = sqrt(I / T)`), and what a renderer would upload. Nothing here touches a GPU.
//!
//! Run with `cargo run -p tiledlight-scene --example courtyard`.

use tiledlight_scene::{default_scene, random_lights, DefaultSceneOptions, LightOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = default_scene(&DefaultSceneOptions { grid_objects: 280, ..Default::default() })?;
    let triangles: usize = scene.instances.iter().map(|i| scene.meshes[i.mesh].indices.len() / 3).sum();
    println!(
        "{}: {} meshes, {} instances, {triangles} triangles, {} materials, bounds {:?} .. {:?}",
        scene.name,
        scene.meshes.len(),
        scene.instances.len(),
        scene.materials.len(),
        scene.bounds.min,
        scene.bounds.max
    );
    for threshold in [0.1, 0.01, 0.001] {
        let opts = LightOptions { num_point: 1024, num_spot: 256, threshold, seed: 1, ..Default::default() };
        let lights = random_lights(&scene.bounds, &opts)?;
        let mean = lights.iter().map(|l| l.radius).sum::<f32>() / lights.len() as f32;
        println!("threshold {threshold}: {} lights, mean radius {mean:.2} m", lights.len());
    }
    Ok(())
}
