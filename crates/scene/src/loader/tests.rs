//! glTF loader tests. Each test writes its own small glTF (JSON built with serde_json,
//! binary buffers packed with the shared test-support writer, tiledlight-gltf-writer) into
//! a temporary directory, as .gltf with an external .bin, .gltf with a base64 data URI, or
//! .glb.

use std::fs;
use std::path::Path;

use glam::{Mat4, Vec3};
use serde_json::{json, Value};
use tiledlight_cull::LightKind;

use super::load_gltf;
use crate::error::SceneError;
use crate::model::{AlphaMode, Filter, Material, Sampler, Scene, TextureRef, UvTransform, Wrap};

use tiledlight_gltf_writer::{base64, write_embedded, write_glb, write_gltf, Buffer as Bin, F32, I16, I8, U16, U8};

fn png(width: u32, height: u32) -> (Vec<u8>, Vec<u8>) {
    let img = image::RgbaImage::from_fn(width, height, |x, y| {
        image::Rgba([(x * 60) as u8, (y * 70) as u8, 200, 255 - x as u8])
    });
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    (bytes, img.into_raw())
}

fn world_positions(scene: &Scene, instance: usize) -> Vec<Vec3> {
    let inst = &scene.instances[instance];
    scene.meshes[inst.mesh].positions.iter().map(|p| inst.transform.transform_point3(Vec3::from_array(*p))).collect()
}

fn assert_close(a: Vec3, b: Vec3) {
    assert!((a - b).abs().max_element() < 1e-5, "{a} != {b}");
}

/// Asserts that loading failed with a message naming the file and containing `needles`.
fn assert_fails(path: &Path, result: Result<Scene, SceneError>, needles: &[&str]) -> String {
    let msg = result.expect_err("load must fail").to_string();
    let file = path.file_name().unwrap().to_string_lossy();
    assert!(msg.contains(&*file), "message {msg:?} should name the file {file}");
    for n in needles {
        assert!(msg.contains(n), "message {msg:?} should contain {n:?}");
    }
    msg
}

fn one_mesh_scene(prim: Value, extra: Value) -> Value {
    let mut root = json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"name": "tri", "primitives": [prim]}],
    });
    if let Value::Object(map) = extra {
        for (k, v) in map {
            root[k] = v;
        }
    }
    root
}

// ---- valid files, contents asserted exactly ----

#[test]
fn triangle_with_point_lights() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let root = bin.document(json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "name": "lamp", "color": [1.0, 0.5, 0.25], "intensity": 10.0},
            {"type": "point", "intensity": 3.0, "range": 7.0},
            {"type": "directional", "intensity": 3.0}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"mesh": 0, "translation": [1.0, 2.0, 3.0]},
            {"translation": [0.0, 5.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"translation": [1.0, 1.0, 1.0], "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}}
        ],
        "meshes": [{"name": "tri", "primitives": [prim]}],
    }));
    let path = write_gltf(dir.path(), "triangle", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.name, "triangle.gltf");
    assert_eq!(scene.meshes.len(), 1);
    assert_eq!(scene.meshes[0].name, "tri");
    assert_eq!(scene.meshes[0].positions, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(scene.meshes[0].normals, vec![[0.0, 0.0, 1.0]; 3]);
    assert_eq!(scene.meshes[0].uvs, vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
    assert_eq!(scene.meshes[0].indices, vec![0, 1, 2]);
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(
        world_positions(&scene, 0),
        vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(2.0, 2.0, 3.0), Vec3::new(1.0, 3.0, 3.0)]
    );
    assert_eq!(scene.materials, vec![Material::default()], "no material: glTF's default");
    assert_eq!(scene.bounds.min, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.bounds.max, Vec3::new(2.0, 3.0, 3.0));
    assert_eq!(scene.triangle_count(), 1);
    assert!(scene.camera.is_none());

    assert_eq!(scene.lights.len(), 2, "the directional light is skipped");
    let lamp = scene.lights[0];
    assert_eq!(lamp.position, Vec3::new(0.0, 5.0, 0.0));
    assert_eq!(lamp.color, Vec3::new(1.0, 0.5, 0.25));
    assert_eq!(lamp.intensity, 10.0);
    assert_eq!(lamp.kind, LightKind::Point);
    // r = sqrt(intensity * max(colour) / threshold) = sqrt(10 / 0.1)
    assert!((lamp.radius - 10.0).abs() < 1e-5, "radius {}", lamp.radius);
    let ranged = scene.lights[1];
    assert_eq!(ranged.position, Vec3::ONE);
    assert_eq!(ranged.radius, 7.0, "range is the radius");
    assert_eq!(ranged.color, Vec3::ONE, "colour defaults to white");
}

#[test]
fn spot_light_points_down_the_node_axis() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let root = bin.document(json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 4.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}
        ]}},
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0},
            // -90 degrees about X turns the light's -Z axis to -Y.
            {"translation": [0.0, 4.0, 0.0], "rotation": [-h, 0.0, 0.0, h],
             "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "meshes": [{"primitives": [prim]}],
    }));
    let path = write_gltf(dir.path(), "spot", root, &bin.data);
    let scene = load_gltf(&path, 0.01).unwrap();
    assert!(scene.has_spot_lights());
    let l = scene.lights[0];
    assert_close(l.position, Vec3::new(0.0, 4.0, 0.0));
    assert!((l.radius - 20.0).abs() < 1e-4, "sqrt(4 / 0.01) = 20, got {}", l.radius);
    let LightKind::Spot { direction, inner_angle, outer_angle } = l.kind else { panic!("not a spot: {:?}", l.kind) };
    assert_close(direction, Vec3::NEG_Y);
    assert_eq!((inner_angle, outer_angle), (0.2, 0.5));
    assert_eq!(scene.meshes[0].name, "mesh 0");
}

#[test]
fn first_perspective_camera_becomes_the_scene_camera() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let root = bin.document(json!({
        "cameras": [
            {"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}},
            {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05}},
            {"type": "perspective", "perspective": {"yfov": 1.2, "znear": 0.5, "zfar": 100.0}}
        ],
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"mesh": 0},
            {"camera": 0, "translation": [9.0, 9.0, 9.0]},
            {"camera": 1, "translation": [0.0, 1.7, 5.0]},
            {"camera": 2, "translation": [3.0, 3.0, 3.0]}
        ],
        "meshes": [{"primitives": [prim]}],
    }));
    let path = write_embedded(dir.path(), "camera", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    let cam = scene.camera.expect("a camera");
    assert_eq!(cam.eye, Vec3::new(0.0, 1.7, 5.0));
    assert_eq!(cam.target, Vec3::new(0.0, 1.7, 4.0));
    assert_eq!(cam.up, Vec3::Y);
    assert_eq!(cam.fov_y, 0.8);
    assert_eq!(cam.near, 0.05);
    assert_eq!(cam.far, None, "no zfar: infinite");
}

#[test]
fn node_hierarchy_composes_parent_times_local() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let root = bin.document(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"translation": [0.0, 0.0, -1.0], "scale": [2.0, 2.0, 2.0], "children": [1]},
            {"translation": [1.0, 0.0, 0.0], "children": [2], "mesh": 0},
            {"matrix": [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 10.0, 0.0, 1.0], "mesh": 0}
        ],
        "meshes": [{"primitives": [prim]}],
    }));
    let path = write_glb(dir.path(), "hierarchy", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.meshes.len(), 1, "both instances share the mesh");
    assert_eq!(scene.instances.len(), 2);
    // world = parent * child: (x, y, z) -> 2 * ((x, y, z) + (1, 0, 0)) + (0, 0, -1)
    assert_eq!(
        world_positions(&scene, 0),
        vec![Vec3::new(2.0, 0.0, -1.0), Vec3::new(4.0, 0.0, -1.0), Vec3::new(2.0, 2.0, -1.0)]
    );
    // The grandchild adds 10 up in its parent's (scaled) frame: 20 in world space.
    assert_eq!(
        world_positions(&scene, 1),
        vec![Vec3::new(2.0, 20.0, -1.0), Vec3::new(4.0, 20.0, -1.0), Vec3::new(2.0, 22.0, -1.0)]
    );
    assert_eq!(scene.bounds.max, Vec3::new(4.0, 22.0, -1.0));
}

#[test]
fn default_scene_is_chosen_among_several() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let root = bin.document(json!({
        "scene": 1,
        "scenes": [{"nodes": [0]}, {"nodes": [1]}],
        "nodes": [{"mesh": 0, "translation": [100.0, 0.0, 0.0]}, {"mesh": 0, "translation": [0.0, 0.0, 7.0]}],
        "meshes": [{"primitives": [prim]}],
    }));
    let path = write_gltf(dir.path(), "scenes", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.instances[0].transform, Mat4::from_translation(Vec3::new(0.0, 0.0, 7.0)));
}

#[test]
fn materials_and_textures_external_png() {
    let dir = tempfile::tempdir().unwrap();
    let (png_bytes, pixels) = png(3, 2);
    fs::write(dir.path().join("albedo map.png"), &png_bytes).unwrap();
    let mut bin = Bin::default();
    let mut prim = bin.triangle();
    prim["material"] = json!(0);
    let root = bin.document(json!({
        "images": [{"uri": "albedo%20map.png"}],
        "textures": [{"source": 0}],
        "materials": [{
            "name": "painted",
            "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 0.75], "baseColorTexture": {"index": 0},
                                      "metallicFactor": 0.2, "roughnessFactor": 0.7},
            "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": true
        }],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [prim]}],
    }));
    let path = write_gltf(dir.path(), "textured", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(
        scene.materials,
        vec![Material {
            name: "painted".into(),
            base_color: [0.5, 0.25, 1.0, 0.75],
            base_color_texture: Some(TextureRef::new(0)),
            roughness: 0.7,
            metallic: 0.2,
            alpha_mode: AlphaMode::Mask { cutoff: 0.3 },
            double_sided: true,
            ..Material::default()
        }]
    );
    assert!(scene.has_alpha_mask());
    let t = &scene.textures[0];
    assert_eq!((t.width, t.height), (3, 2));
    assert_eq!(t.rgba8, pixels);
    assert_eq!(t.name, "albedo%20map.png");
}

#[test]
fn textures_embedded_in_glb_and_data_uri() {
    let dir = tempfile::tempdir().unwrap();
    let (png_bytes, pixels) = png(4, 4);
    let mut jpeg = Vec::new();
    image::RgbImage::from_pixel(8, 4, image::Rgb([200, 100, 50]))
        .write_to(&mut std::io::Cursor::new(&mut jpeg), image::ImageFormat::Jpeg)
        .unwrap();
    let mut bin = Bin::default();
    let mut prim = bin.triangle();
    prim["material"] = json!(0);
    let mut prim2 = bin.triangle();
    prim2["material"] = json!(1);
    let image_view = bin.view(&png_bytes);
    let root = bin.document(json!({
        "images": [
            {"bufferView": image_view, "mimeType": "image/png", "name": "embedded"},
            {"uri": format!("data:image/jpeg;base64,{}", base64(&jpeg))}
        ],
        "textures": [{"source": 0}, {"source": 1}],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "alphaMode": "BLEND"},
            {"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}}
        ],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [prim, prim2]}],
    }));
    let path = write_glb(dir.path(), "embedded", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.meshes.len(), 2, "one mesh per primitive");
    assert_eq!(scene.meshes[1].name, "mesh 0 primitive 1");
    assert_eq!(scene.textures.len(), 2);
    assert_eq!(scene.textures[0].name, "embedded");
    assert_eq!(scene.textures[0].rgba8, pixels);
    assert_eq!((scene.textures[1].width, scene.textures[1].height), (8, 4));
    assert_eq!(scene.textures[1].rgba8.len(), 8 * 4 * 4);
    let texel = &scene.textures[1].rgba8[..4];
    assert!(texel[0].abs_diff(200) < 8 && texel[1].abs_diff(100) < 8 && texel[3] == 255, "{texel:?}");
    assert_eq!(scene.materials[0].alpha_mode, AlphaMode::Blend);
    assert_eq!(scene.materials[0].base_color_texture, Some(TextureRef::new(0)));
    assert_eq!(scene.materials[1].base_color_texture, Some(TextureRef::new(1)));
    assert!(scene.has_blend());
}

#[test]
fn flat_normals_zero_uvs_and_generated_indices() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    // Two non-indexed triangles without normals or UVs: one facing +Z, one facing +Y.
    let p =
        bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0], "VEC3");
    let root = bin.document(one_mesh_scene(json!({"attributes": {"POSITION": p}}), json!({})));
    let path = write_gltf(dir.path(), "flat", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    let m = &scene.meshes[0];
    assert_eq!(m.indices, vec![0, 1, 2, 3, 4, 5]);
    assert_eq!(
        m.normals,
        vec![[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(m.uvs, vec![[0.0, 0.0]; 6]);
}

#[test]
fn strips_and_fans_become_lists_with_consistent_winding() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    // A unit quad in the XY plane: strip order 0 1 2 3 = (0,0) (1,0) (0,1) (1,1).
    let p = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0], "VEC3");
    let n = bin.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
    let fan_idx = bin.indices_u32(&[0, 1, 3, 2]);
    let root = bin.document(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": p, "NORMAL": n}, "mode": 5},
            {"attributes": {"POSITION": p, "NORMAL": n}, "indices": fan_idx, "mode": 6}
        ]}],
    }));
    let path = write_gltf(dir.path(), "strips", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.meshes[0].indices, vec![0, 1, 2, 2, 1, 3]);
    assert_eq!(scene.meshes[1].indices, vec![0, 1, 3, 0, 3, 2]);
    for mesh in &scene.meshes {
        for t in mesh.indices.chunks_exact(3) {
            let p = [t[0], t[1], t[2]].map(|i| Vec3::from_array(mesh.positions[i as usize]));
            assert!((p[1] - p[0]).cross(p[2] - p[0]).z > 0.0, "{}: {t:?} is clockwise", mesh.name);
        }
    }
}

#[test]
fn mirrored_instances_get_flipped_winding() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let root = bin.document(json!({
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 0, "scale": [-1.0, 1.0, 1.0]}],
        "meshes": [{"name": "tri", "primitives": [prim]}],
    }));
    let path = write_gltf(dir.path(), "mirror", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.meshes.len(), 2);
    assert_eq!(scene.meshes[0].indices, vec![0, 1, 2]);
    assert_eq!(scene.meshes[1].indices, vec![0, 2, 1]);
    assert_eq!(scene.meshes[1].name, "tri (mirrored)");
    // In world space the mirrored triangle still winds counter-clockwise seen from +Z.
    let w = world_positions(&scene, 1);
    let i = &scene.meshes[1].indices;
    let (a, b, c) = (w[i[0] as usize], w[i[1] as usize], w[i[2] as usize]);
    assert!((b - a).cross(c - a).z > 0.0);
}

// ---- bad input: each must fail with the file and the problem in the message ----

#[test]
fn missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nowhere.gltf");
    let result = load_gltf(&path, 0.1);
    assert!(matches!(result, Err(SceneError::Io { .. })));
    assert_fails(&path, result, &["cannot read file"]);
}

#[test]
fn malformed_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.gltf");
    fs::write(&path, b"{ \"asset\": { \"version\": \"2.0\" }, ").unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["malformed glTF JSON"]);
    fs::write(&path, b"").unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["malformed glTF JSON"]);
    // Well-formed JSON that is not valid glTF (a node refers to a missing mesh).
    fs::write(&path, serde_json::to_vec(&json!({"asset": {"version": "2.0"}, "nodes": [{"mesh": 3}]})).unwrap())
        .unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["does not validate", "nodes[0].mesh"]);
}

#[test]
fn malformed_glb() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let path = write_glb(dir.path(), "cut", bin.document(one_mesh_scene(prim, json!({}))), &bin.data);
    let bytes = fs::read(&path).unwrap();
    fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["malformed GLB"]);
}

#[test]
fn missing_external_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let path = write_gltf(dir.path(), "lost", bin.document(one_mesh_scene(prim, json!({}))), &bin.data);
    fs::remove_file(dir.path().join("lost.bin")).unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["buffer 0", "cannot read", "lost.bin"]);
}

#[test]
fn buffer_too_short() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let path = write_gltf(dir.path(), "short", bin.document(one_mesh_scene(prim.clone(), json!({}))), &bin.data[..20]);
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &["buffer 0 is too short", &format!("byteLength is {}", bin.data.len()), "20 bytes"],
    );

    // The buffer is as long as it says, but an accessor reads past its view.
    let mut root = bin.document(one_mesh_scene(prim.clone(), json!({})));
    root["accessors"][0]["count"] = json!(30);
    let path = write_embedded(dir.path(), "overrun", root, &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["POSITION", "accessor 0", "do not fit"]);

    // A buffer view that runs past its buffer.
    let mut root = bin.document(one_mesh_scene(prim, json!({})));
    root["bufferViews"][0]["byteLength"] = json!(10_000);
    let path = write_embedded(dir.path(), "view", root, &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["buffer view 0", "runs past the end"]);
}

#[test]
fn unsupported_primitive_mode() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let mut prim = bin.triangle();
    prim["mode"] = json!(1);
    let path = write_gltf(dir.path(), "lines", bin.document(one_mesh_scene(prim, json!({}))), &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["mesh 0 'tri' primitive 0", "mode Lines is not supported"]);
}

#[test]
fn out_of_range_indices() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let p = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let i = bin.indices_u16(&[0, 1, 5]);
    let prim = json!({"attributes": {"POSITION": p}, "indices": i});
    let path = write_gltf(dir.path(), "indices", bin.document(one_mesh_scene(prim, json!({}))), &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["mesh 0 'tri'", "index 2 is 5", "3 vertices", "out of range"]);
}

#[test]
fn nan_positions() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let p = bin.floats(&[0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let prim = json!({"attributes": {"POSITION": p}});
    let path = write_gltf(dir.path(), "nan", bin.document(one_mesh_scene(prim, json!({}))), &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["mesh 0 'tri'", "POSITION 1 is not finite"]);
}

#[test]
fn missing_texture_image_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let mut prim = bin.triangle();
    prim["material"] = json!(0);
    let extra = json!({
        "images": [{"uri": "gone.png"}],
        "textures": [{"source": 0}],
        "materials": [{"name": "paint", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    });
    let path = write_gltf(dir.path(), "notex", bin.document(one_mesh_scene(prim, extra)), &bin.data);
    // `load_gltf` is strict: the warning is an error.
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &[
            "strict loading",
            "material 0 'paint'",
            "material 0 'paint' (base colour)",
            "image 0 ('gone.png')",
            "cannot read",
            "gone.png",
        ],
    );

    // Present but not an image.
    fs::write(dir.path().join("gone.png"), b"definitely not a png").unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["image 0 ('gone.png')", "cannot decode image"]);
}

#[test]
fn other_bad_inputs_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();

    // TEXCOORD_0 pointing at a VEC3 accessor (a texture coordinate must be VEC2): the
    // message must name the mesh, primitive, attribute, accessor and both types.
    let mut root = bin.document(one_mesh_scene(prim.clone(), json!({})));
    root["accessors"][2]["type"] = json!("VEC3");
    root["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(2);
    let path = write_embedded(dir.path(), "types", root, &bin.data);
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &["mesh 0 'tri'", "primitive 0", "TEXCOORD_0", "accessor 2", "has type Vec3, expected Vec2"],
    );

    // A cycle in the node hierarchy must not hang or overflow the stack.
    let root = bin.document(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}],
        "meshes": [{"primitives": [prim.clone()]}],
    }));
    let path = write_embedded(dir.path(), "cycle", root, &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["node 0 is reached twice", "not a tree"]);

    // Only lights, nothing to draw.
    let root = bin.document(json!({
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"extensions": {"KHR_lights_punctual": {"light": 0}}}],
    }));
    let path = write_embedded(dir.path(), "empty", root, &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["no instances"]);

    // An unsupported buffer URI scheme, and a bad base64 payload.
    let mut root = bin.document(one_mesh_scene(prim.clone(), json!({})));
    root["buffers"][0]["uri"] = json!("https://example.com/a.bin");
    let path = dir.path().join("remote.gltf");
    fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["buffer 0", "unsupported scheme"]);
    root["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@");
    fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
    assert_fails(&path, load_gltf(&path, 0.1), &["buffer 0", "invalid base64"]);

    // A bad threshold is an argument error, caught before reading.
    let e = load_gltf(&path, 0.0).expect_err("threshold 0");
    assert!(matches!(e, SceneError::InvalidArgument(_)), "{e:?}");
    assert!(e.to_string().contains("light threshold 0 must be finite and positive"), "{e}");
    assert!(e.to_string().contains("remote.gltf"), "names the file: {e}");
}

#[test]
fn dangling_light_and_camera_references_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    for (name, extra) in [
        (
            "light_index",
            json!({"extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}},
                   "nodes": [{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 5}}}]}),
        ),
        ("no_lights", json!({"nodes": [{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}}]})),
        ("camera_index", json!({"nodes": [{"mesh": 0}, {"camera": 2}]})),
    ] {
        let mut root = bin.document(one_mesh_scene(prim.clone(), extra));
        root["scenes"] = json!([{"nodes": [0, 1]}]);
        let path = write_embedded(dir.path(), name, root, &bin.data);
        // gltf's validation names the node, the field and what is wrong with it.
        let field =
            if name == "camera_index" { "nodes[1].camera" } else { "nodes[1].extensions.khrLightsPunctual.light" };
        assert_fails(&path, load_gltf(&path, 0.1), &[&format!("{field}: Index out of bounds")]);
    }
}

#[test]
fn sparse_accessors_patch_their_base() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let p = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let pos_idx = bin.view(&2u16.to_le_bytes());
    let pos_val = bin.view(&[0.0f32, 2.0, 0.0].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
    let uv_idx = bin.view(&[1u8]);
    let uv_val = bin.view(&[0.5f32, 0.25].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
    bin.accessors[p]["sparse"] = json!({"count": 1, "indices": {"bufferView": pos_idx, "componentType": U16}, "values": {"bufferView": pos_val}});
    bin.accessors[p]["max"] = json!([1.0, 2.0, 0.0]);
    bin.accessors.push(json!({"componentType": F32, "count": 3, "type": "VEC2",
        "sparse": {"count": 1, "indices": {"bufferView": uv_idx, "componentType": 5121}, "values": {"bufferView": uv_val}}}));
    let uv = bin.accessors.len() - 1;
    let prim = json!({"attributes": {"POSITION": p, "TEXCOORD_0": uv}});
    let path = write_gltf(dir.path(), "sparse", bin.document(one_mesh_scene(prim, json!({}))), &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    let m = &scene.meshes[0];
    // Flat normals unweld the vertices in index order (0, 1, 2).
    assert_eq!(m.positions, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
    assert_eq!(m.uvs, vec![[0.0, 0.0], [0.5, 0.25], [0.0, 0.0]]);
}

// ---- materials in full, texture coordinate sets, tangents, quantisation ----

/// A unit quad in the XY plane facing +Z: positions, normals, two UV sets (set 1 = set 0
/// mirrored in u) and indices; tangents (+x, w = 1) when `tangents`.
fn quad_prim(bin: &mut Bin, tangents: bool) -> Value {
    let p = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let n = bin.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
    let t0 = bin.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let t1 = bin.floats(&[1.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0], "VEC2");
    let i = bin.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mut prim =
        json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t0, "TEXCOORD_1": t1}, "indices": i});
    if tangents {
        let bytes: Vec<u8> = [1.0f32, 0.0, 0.0, 1.0].repeat(4).iter().flat_map(|v| v.to_le_bytes()).collect();
        prim["attributes"]["TANGENT"] = json!(bin.raw(&bytes, (F32, false), 4, "VEC4", None));
    }
    prim
}

/// One 2x2 PNG image per entry, as data URIs, and a texture per image with sampler `k`.
fn images_and_textures(count: usize) -> (Value, Value) {
    let (bytes, _) = png(2, 2);
    let uri = format!("data:image/png;base64,{}", base64(&bytes));
    let images: Vec<Value> = (0..count).map(|k| json!({"uri": uri, "name": format!("img{k}")})).collect();
    let textures: Vec<Value> = (0..count).map(|k| json!({"source": k, "sampler": k % 2})).collect();
    (json!(images), json!(textures))
}

#[test]
fn metallic_roughness_materials_in_full() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = quad_prim(&mut bin, true);
    let (images, textures) = images_and_textures(5);
    let root = bin.document(one_mesh_scene(
        json!({"attributes": prim["attributes"], "indices": prim["indices"], "material": 0}),
        json!({
            "extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength"],
            "images": images,
            "textures": textures,
            "samplers": [
                {"wrapS": 33071, "wrapT": 33648, "magFilter": 9728, "minFilter": 9729},
                {"minFilter": 9986}
            ],
            "materials": [{
                "name": "full",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.5, 0.5, 0.5, 1.0],
                    "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform":
                        {"offset": [0.5, 0.25], "rotation": 0.5, "scale": [2.0, 3.0]}}},
                    "metallicRoughnessTexture": {"index": 1, "texCoord": 1},
                    "metallicFactor": 0.25,
                    "roughnessFactor": 0.75
                },
                "normalTexture": {"index": 2, "scale": 0.5, "extensions": {"KHR_texture_transform":
                    {"scale": [4.0, 4.0], "texCoord": 1}}},
                "occlusionTexture": {"index": 3, "strength": 0.8},
                "emissiveTexture": {"index": 4},
                "emissiveFactor": [1.0, 0.5, 0.25],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}}
            }],
        }),
    ));
    let path = write_gltf(dir.path(), "full", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    let clamp_nearest = Sampler {
        wrap_u: Wrap::ClampToEdge,
        wrap_v: Wrap::MirroredRepeat,
        mag: Filter::Nearest,
        min: Filter::Linear,
        mipmap: None,
    };
    let nearest_mip = Sampler { mipmap: Some(Filter::Linear), min: Filter::Nearest, ..Sampler::default() };
    let r = |texture, tex_coord, sampler, transform| TextureRef { texture, tex_coord, sampler, transform };
    let id = UvTransform::default();
    let m = &scene.materials[0];
    assert_eq!(
        *m,
        Material {
            name: "full".into(),
            base_color: [0.5, 0.5, 0.5, 1.0],
            base_color_texture: Some(r(
                0,
                0,
                clamp_nearest,
                UvTransform { offset: [0.5, 0.25], rotation: 0.5, scale: [2.0, 3.0] }
            )),
            roughness: 0.75,
            metallic: 0.25,
            metallic_roughness_texture: Some(r(1, 1, nearest_mip, id)),
            // Scene textures are numbered in the order the loader meets them: the
            // texture infos of the core material first, then normal and occlusion.
            normal_texture: Some(r(3, 1, clamp_nearest, UvTransform { scale: [4.0, 4.0], ..id })),
            normal_scale: 0.5,
            occlusion_texture: Some(r(4, 0, nearest_mip, id)),
            occlusion_strength: 0.8,
            emissive: [1.0, 0.5, 0.25],
            emissive_strength: 6.0,
            emissive_texture: Some(r(2, 0, clamp_nearest, id)),
            ..Material::default()
        }
    );
    let names: Vec<&str> = scene.textures.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["img0", "img1", "img4", "img2", "img3"]);
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.uvs1, vec![[1.0, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]], "TEXCOORD_1 is read");
    assert_eq!(mesh.tangents, vec![[1.0, 0.0, 0.0, 1.0]; 4], "the file's tangents are kept");
}

#[test]
fn tangents_are_generated_and_unused_attributes_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = quad_prim(&mut bin, false);
    let (images, textures) = images_and_textures(1);
    let mut prims = Vec::new();
    // Material 0: a normal map on set 0 and no tangents in the file; material 1: nothing.
    for material in [0, 1] {
        prims.push(json!({"attributes": prim["attributes"], "indices": prim["indices"], "material": material}));
    }
    let root = bin.document(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": prims}],
        "images": images,
        "textures": textures,
        "samplers": [{}],
        "materials": [{"normalTexture": {"index": 0}}, {}],
    }));
    let path = write_glb(dir.path(), "generated", root, &bin.data);
    let scene = load_gltf(&path, 0.1).unwrap();
    // u runs along +x, v (images run down) along -y: tangent +x, bitangent -y, so w = -1.
    for t in &scene.meshes[0].tangents {
        assert!((t[0] - 1.0).abs() < 1e-5 && t[1].abs() < 1e-5 && t[3] == -1.0, "{t:?}");
    }
    assert_eq!(scene.meshes[0].tangents.len(), 4);
    assert!(scene.meshes[0].uvs1.is_empty(), "no texture reads set 1");
    assert!(scene.meshes[1].tangents.is_empty(), "no normal map: no tangents");
}

/// The quad of `quad_prim` stored quantised (`KHR_mesh_quantization`): positions as
/// normalised shorts, normals and tangents as normalised bytes, set 0 as plain unsigned
/// bytes (scaled by a texture transform, as quantisers do), set 1 as normalised unsigned
/// shorts; and its float twin holding the dequantised values.
#[test]
fn quantized_mesh_equals_its_float_twin() {
    let dir = tempfile::tempdir().unwrap();
    let positions: [[i16; 3]; 4] = [[-32767, -32767, 0], [32767, -32767, 0], [32767, 16384, 0], [-32767, 16384, 0]];
    let normal: [i8; 3] = [0, 0, 127];
    let tangent: [i8; 4] = [127, 0, 0, 127];
    let uv0: [[u8; 2]; 4] = [[0, 4], [4, 4], [4, 0], [0, 0]];
    let uv1: [[u16; 2]; 4] = [[65535, 65535], [0, 65535], [0, 0], [65535, 0]];
    let le16 = |v: i16| v.to_le_bytes();
    let mut q = Bin::default();
    // Shorts padded to 4-byte elements (glTF's vertex attribute alignment).
    let pos_bytes: Vec<u8> =
        positions.iter().flat_map(|p| [le16(p[0]), le16(p[1]), le16(p[2]), [0, 0]].concat()).collect();
    let minmax = Some((json!([-32767, -32767, 0]), json!([32767, 16384, 0])));
    let pos_acc = q.raw(&pos_bytes, (I16, true), 4, "VEC3", minmax);
    q.views[q.accessors[pos_acc]["bufferView"].as_u64().unwrap() as usize]["byteStride"] = json!(8);
    let nrm_bytes: Vec<u8> = (0..4).flat_map(|_| [normal[0] as u8, normal[1] as u8, normal[2] as u8, 0]).collect();
    let n = q.raw(&nrm_bytes, (I8, true), 4, "VEC3", None);
    q.views[q.accessors[n]["bufferView"].as_u64().unwrap() as usize]["byteStride"] = json!(4);
    let tan_bytes: Vec<u8> = (0..4).flat_map(|_| tangent.map(|c| c as u8)).collect();
    let t = q.raw(&tan_bytes, (I8, true), 4, "VEC4", None);
    let uv0_bytes: Vec<u8> = uv0.iter().flat_map(|u| [u[0], u[1], 0, 0]).collect();
    let u0 = q.raw(&uv0_bytes, (U8, false), 4, "VEC2", None);
    q.views[q.accessors[u0]["bufferView"].as_u64().unwrap() as usize]["byteStride"] = json!(4);
    let uv1_bytes: Vec<u8> = uv1.iter().flat_map(|u| [u[0].to_le_bytes(), u[1].to_le_bytes()].concat()).collect();
    let u1 = q.raw(&uv1_bytes, (5123, true), 4, "VEC2", None);
    let i = q.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let attributes = json!({"POSITION": pos_acc, "NORMAL": n, "TANGENT": t, "TEXCOORD_0": u0, "TEXCOORD_1": u1});

    // The float twin: the specification's dequantisation, in f32.
    let mut f = Bin::default();
    let fpos: Vec<f32> = positions.iter().flat_map(|p| p.map(|c| (f32::from(c) / 32767.0).max(-1.0))).collect();
    let fp = f.floats(&fpos, "VEC3");
    let fnrm: Vec<f32> = (0..4).flat_map(|_| normal.map(|c| (f32::from(c) / 127.0).max(-1.0))).collect();
    let fnn = f.floats(&fnrm, "VEC3");
    let ftan: Vec<f32> = (0..4).flat_map(|_| tangent.map(|c| (f32::from(c) / 127.0).max(-1.0))).collect();
    let ftan_bytes: Vec<u8> = ftan.iter().flat_map(|v| v.to_le_bytes()).collect();
    let ft = f.raw(&ftan_bytes, (F32, false), 4, "VEC4", None);
    let fu0: Vec<f32> = uv0.iter().flat_map(|u| u.map(f32::from)).collect();
    let fu0 = f.floats(&fu0, "VEC2");
    let fu1: Vec<f32> = uv1.iter().flat_map(|u| u.map(|c| f32::from(c) / 65535.0)).collect();
    let fu1 = f.floats(&fu1, "VEC2");
    let fi = f.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let f_attributes = json!({"POSITION": fp, "NORMAL": fnn, "TANGENT": ft, "TEXCOORD_0": fu0, "TEXCOORD_1": fu1});

    let (images, textures) = images_and_textures(2);
    let extra = |attributes: Value, indices: usize, quantized: bool| {
        let mut root = one_mesh_scene(
            json!({"attributes": attributes, "indices": indices, "material": 0}),
            json!({
                "images": images,
                "textures": textures,
                "samplers": [{}, {}],
                "materials": [{
                    "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions":
                        {"KHR_texture_transform": {"scale": [0.25, 0.25]}}}},
                    "normalTexture": {"index": 1, "texCoord": 1}
                }],
            }),
        );
        if quantized {
            root["extensionsUsed"] = json!(["KHR_mesh_quantization", "KHR_texture_transform"]);
            root["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
        }
        root
    };
    let qpath = write_gltf(dir.path(), "quantized", q.document(extra(attributes, i, true)), &q.data);
    let fpath = write_gltf(dir.path(), "float", f.document(extra(f_attributes, fi, false)), &f.data);
    let quantized = load_gltf(&qpath, 0.1).unwrap();
    let float = load_gltf(&fpath, 0.1).unwrap();
    assert_eq!(quantized.meshes, float.meshes, "dequantised attributes equal the float twin's exactly");
    assert_eq!(quantized.materials, float.materials);
    assert_eq!(quantized.meshes[0].positions[0], [-1.0, -1.0, 0.0]);
    assert_eq!(quantized.meshes[0].uvs[1], [4.0, 4.0], "plain integers keep their value");
    assert_eq!(quantized.meshes[0].tangents[0], [1.0, 0.0, 0.0, 1.0]);
}

#[test]
fn bad_material_attributes_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let tri = bin.triangle();
    let (images, textures) = images_and_textures(1);
    let with_material = |material: Value| {
        bin.document(one_mesh_scene(
            json!({"attributes": tri["attributes"], "indices": tri["indices"], "material": 0}),
            json!({"images": images, "textures": textures, "samplers": [{}], "materials": [material]}),
        ))
    };
    let path = write_gltf(
        dir.path(),
        "set2",
        with_material(json!({"emissiveTexture": {"index": 0, "texCoord": 2}})),
        &bin.data,
    );
    assert_fails(&path, load_gltf(&path, 0.1), &["material 0", "emissive texture", "TEXCOORD_2"]);
    let path = write_gltf(
        dir.path(),
        "noset1",
        with_material(json!({"occlusionTexture": {"index": 0, "texCoord": 1}})),
        &bin.data,
    );
    assert_fails(&path, load_gltf(&path, 0.1), &["mesh 0 'tri' primitive 0", "TEXCOORD_1"]);
    let path = write_gltf(
        dir.path(),
        "badtransform",
        with_material(
            json!({"normalTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": "big"}}}}),
        ),
        &bin.data,
    );
    assert_fails(&path, load_gltf(&path, 0.1), &["normal texture", "malformed KHR_texture_transform"]);
    // Normals as unsigned bytes are neither core glTF nor KHR_mesh_quantization.
    let mut b2 = Bin::default();
    let p = b2.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let n = b2.raw(&[0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255, 0], (U8, true), 3, "VEC3", None);
    b2.views[b2.accessors[n]["bufferView"].as_u64().unwrap() as usize]["byteStride"] = json!(4);
    let root = b2.document(one_mesh_scene(json!({"attributes": {"POSITION": p, "NORMAL": n}}), json!({})));
    let path = write_gltf(dir.path(), "u8normals", root, &b2.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["NORMAL", "normalized component type U8, which is not supported"]);
}

mod hostile;
