//! Hostile and broken input: which files a glTF may name, transforms out of range,
//! extensions, missing textures (warnings and strict loading), memory limits. Every
//! error and warning text is asserted. Uses the builders of the parent test module.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use super::{assert_fails, base64, one_mesh_scene, png, write_embedded, write_gltf, Bin};
use crate::error::SceneError;
use crate::loader::{load_gltf, load_gltf_with, LoadLimits, LoadOptions, Loaded, DETAIL};
use crate::model::Scene;

fn lenient() -> LoadOptions {
    LoadOptions::new(0.1)
}

fn any_path() -> LoadOptions {
    LoadOptions { allow_any_path: true, ..lenient() }
}

fn strict() -> LoadOptions {
    LoadOptions { strict: true, ..lenient() }
}

fn scene_of(r: Result<Loaded, SceneError>) -> Result<Scene, SceneError> {
    r.map(|l| l.scene)
}

/// A one-triangle document whose buffer 0 has the URI `uri` (and the triangle's length).
fn with_buffer_uri(bin: &Bin, prim: &Value, uri: &str) -> Value {
    let mut root = bin.document(one_mesh_scene(prim.clone(), json!({})));
    root["buffers"][0]["uri"] = json!(uri);
    root
}

fn write_json(path: &Path, root: &Value) {
    fs::write(path, serde_json::to_vec(root).unwrap()).unwrap();
}

// ---- files a glTF may name ----

#[test]
fn devices_are_never_read() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let path = dir.path().join("dev.gltf");
    for uri in ["/dev/zero", "file:///dev/urandom"] {
        let device = uri.trim_start_matches("file://");
        write_json(&path, &with_buffer_uri(&bin, &prim, uri));
        // Before: read without end (8 GB in 20 s). Now refused at once, outside the folder...
        let start = Instant::now();
        let msg = assert_fails(
            &path,
            scene_of(load_gltf_with(&path, &lenient())),
            &["buffer 0", &format!("URI '{uri}' names '{device}'"), "outside the model's folder", "--allow-any-path"],
        );
        assert!(msg.contains(&dir.path().display().to_string()), "names the folder: {msg}");
        // ...and, when any path is allowed, because it is not a regular file.
        assert_fails(
            &path,
            scene_of(load_gltf_with(&path, &any_path())),
            &["buffer 0", &format!("URI '{uri}' names '{device}', which is not a regular file")],
        );
        // Generous: on a loaded 2-core machine this takes milliseconds.
        assert!(start.elapsed() < Duration::from_secs(5), "{uri}: {:?}", start.elapsed());
    }
    // The model itself.
    let e = load_gltf_with(Path::new("/dev/zero"), &any_path()).err().unwrap().to_string();
    assert_eq!(e, "/dev/zero: is not a regular file");
}

#[test]
fn paths_outside_the_model_folder_are_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let models = dir.path().join("models");
    fs::create_dir_all(models.join("sub")).unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    fs::write(dir.path().join("secret.bin"), &bin.data).unwrap();
    fs::write(models.join("sub/inside.bin"), &bin.data).unwrap();
    let path = models.join("scene.gltf");
    let secret = dir.path().join("secret.bin");
    let secret_abs = secret.display().to_string();

    // Inside the folder, also through a subfolder and back.
    for uri in ["sub/inside.bin", "sub/../sub/./inside.bin"] {
        write_json(&path, &with_buffer_uri(&bin, &prim, uri));
        assert_eq!(load_gltf(&path, 0.1).unwrap().instances.len(), 1, "{uri}");
    }
    for uri in ["../secret.bin", "sub/../../secret.bin", secret_abs.as_str(), &format!("file://{secret_abs}")] {
        write_json(&path, &with_buffer_uri(&bin, &prim, uri));
        assert_fails(
            &path,
            scene_of(load_gltf_with(&path, &lenient())),
            &["buffer 0", &format!("URI '{uri}' names"), "secret.bin", "outside the model's folder", "not read"],
        );
        let loaded = load_gltf_with(&path, &any_path()).unwrap_or_else(|e| panic!("{uri}: {e}"));
        assert!(loaded.warnings.is_empty());
    }

    // A symbolic link inside the folder leading out counts as outside.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&secret, models.join("link.bin")).unwrap();
        write_json(&path, &with_buffer_uri(&bin, &prim, "link.bin"));
        let canonical = secret.canonicalize().unwrap();
        assert_fails(
            &path,
            scene_of(load_gltf_with(&path, &lenient())),
            &[
                "buffer 0",
                "URI 'link.bin' names",
                &format!("(which leads to '{}')", canonical.display()),
                "outside the model's folder",
            ],
        );
        load_gltf_with(&path, &any_path()).unwrap();
        // A link that stays inside is fine.
        std::os::unix::fs::symlink(models.join("sub/inside.bin"), models.join("inner.bin")).unwrap();
        write_json(&path, &with_buffer_uri(&bin, &prim, "inner.bin"));
        load_gltf(&path, 0.1).unwrap();
    }

    // An image outside the folder is refused too: an error even when textures may be
    // left out with a warning, since it is the file's rules, not the image, at fault.
    let (png_bytes, _) = png(2, 2);
    fs::write(dir.path().join("outside.png"), png_bytes).unwrap();
    let mut prim = prim;
    prim["material"] = json!(0);
    let root = bin.document(one_mesh_scene(
        prim,
        json!({
            "images": [{"uri": "../outside.png"}],
            "textures": [{"source": 0}],
            "materials": [{"name": "wall", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        }),
    ));
    let path = write_gltf(&models, "image", root, &bin.data);
    assert_fails(
        &path,
        scene_of(load_gltf_with(&path, &lenient())),
        &["material 0 'wall'", "base colour texture", "image 0 ('../outside.png')", "outside the model's folder"],
    );
    let loaded = load_gltf_with(&path, &any_path()).unwrap();
    assert_eq!(loaded.scene.textures.len(), 1);
}

#[test]
fn buffers_read_only_their_byte_length() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    // The file holds a megabyte more than the buffer says: only byteLength is kept.
    let mut long = bin.data.clone();
    long.resize(bin.data.len() + (1 << 20), 0xAB);
    let path = write_gltf(dir.path(), "long", bin.document(one_mesh_scene(prim.clone(), json!({}))), &long);
    let scene = load_gltf(&path, 0.1).unwrap();
    assert_eq!(scene.meshes[0].indices, vec![0, 1, 2]);

    // A data URI's size is checked against the limit before it is decoded (images); a
    // buffer's data URI holding less than byteLength is too short.
    let mut root = bin.document(one_mesh_scene(prim, json!({})));
    root["buffers"][0]["byteLength"] = json!(1u64 << 40);
    let path = write_embedded(dir.path(), "huge", root, &bin.data);
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &[&format!(
            "buffer 0 is too short: byteLength is {} but its data URI holds {} bytes",
            1u64 << 40,
            bin.data.len()
        )],
    );
}

// ---- transforms ----

#[test]
fn transforms_out_of_range_name_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let cases: [(&str, Value, &[&str]); 6] = [
        (
            // 1e39 does not fit an f32: the JSON number becomes infinity.
            "inf_translation",
            json!([{"name": "far", "mesh": 0, "translation": [1e39, 0.0, 0.0]}]),
            &["node 0 'far': its transform is not finite: translation [inf, 0.0, 0.0]"],
        ),
        (
            "inf_matrix",
            json!([{"name": "m", "mesh": 0, "matrix": [1e39, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]}]),
            &["node 0 'm': its matrix is not finite: [[inf, 0.0, 0.0, 0.0]"],
        ),
        (
            // Each scale is finite; their product is not.
            "overflow",
            json!([
                {"name": "big", "scale": [1e30, 1e30, 1e30], "children": [1]},
                {"name": "bigger", "scale": [1e30, 1e30, 1e30], "mesh": 0}
            ]),
            &["node 1 'bigger': its world transform (its parents' times its own) overflows to infinity"],
        ),
        (
            // Finite everywhere, but the mesh lands beyond what squared distances hold.
            "huge_scale",
            json!([{"name": "giant", "mesh": 0, "scale": [1e20, 1.0, 1.0]}]),
            &["node 0 'giant': its transform takes mesh 0 'tri' to", "beyond the +-1e18 m a scene may span"],
        ),
        (
            "far_light",
            json!([{"mesh": 0}, {"name": "sun", "translation": [0.0, 1e19, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}]),
            &["node 1 'sun': light 0 'lamp' is at [0, 10000000000000000000, 0], beyond the +-1e18 m"],
        ),
        (
            "far_camera",
            json!([{"mesh": 0}, {"name": "eye", "translation": [0.0, 0.0, -1e19], "camera": 0}]),
            &["node 1 'eye': camera 0 is at [0, 0, -10000000000000000000], beyond the +-1e18 m"],
        ),
    ];
    for (name, nodes, needles) in cases {
        let roots: Vec<usize> =
            (0..nodes.as_array().unwrap().len()).filter(|&i| !(name == "overflow" && i == 1)).collect();
        let root = bin.document(json!({
            "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "name": "lamp", "intensity": 1.0}]}},
            "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
            "scenes": [{"nodes": roots}],
            "nodes": nodes,
            "meshes": [{"name": "tri", "primitives": [prim.clone()]}],
        }));
        let path = write_embedded(dir.path(), name, root, &bin.data);
        let msg = assert_fails(&path, load_gltf(&path, 0.1), needles);
        assert!(!msg.contains("camera has"), "{name}: the node is blamed, not the camera: {msg}");
    }
}

#[test]
fn cyclic_and_shared_node_graphs_fail_without_hanging() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    for (name, nodes, needle) in [
        ("self", json!([{"mesh": 0, "children": [0]}]), "node 0 is reached twice"),
        (
            "loop",
            json!([{"mesh": 0, "children": [1]}, {"children": [2]}, {"children": [0]}]),
            "node 0 is reached twice",
        ),
        (
            "shared",
            json!([{"children": [1, 2]}, {"children": [3]}, {"children": [3]}, {"mesh": 0}]),
            "node 3 is reached twice",
        ),
    ] {
        let root = bin
            .document(json!({"scenes": [{"nodes": [0]}], "nodes": nodes, "meshes": [{"primitives": [prim.clone()]}]}));
        let path = write_embedded(dir.path(), name, root, &bin.data);
        assert_fails(&path, load_gltf(&path, 0.1), &[needle, "the node hierarchy is not a tree"]);
    }
    // Without scenes every root is shown; a pure cycle has no root, so nothing to draw.
    let root = bin.document(
        json!({"nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}], "meshes": [{"primitives": [prim]}]}),
    );
    let path = write_embedded(dir.path(), "rootless", root, &bin.data);
    assert_fails(&path, load_gltf(&path, 0.1), &["no instances"]);
}

// ---- extensions ----

#[test]
fn required_extensions_that_cannot_be_read_fail_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let mut root = bin.document(one_mesh_scene(prim.clone(), json!({})));
    root["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_draco_mesh_compression", "EXT_meshopt_compression"]);
    root["extensionsRequired"] =
        json!(["KHR_draco_mesh_compression", "KHR_lights_punctual", "EXT_meshopt_compression"]);
    let path = write_embedded(dir.path(), "draco", root, &bin.data);
    let msg = assert_fails(
        &path,
        scene_of(load_gltf_with(&path, &lenient())),
        &["requires the glTF extensions 'KHR_draco_mesh_compression', 'EXT_meshopt_compression' (extensionsRequired), which tiledlight cannot read: it cannot be drawn without them (supported: KHR_lights_punctual, KHR_materials_emissive_strength, KHR_mesh_quantization, KHR_texture_transform)"],
    );
    assert!(!msg.contains("does not validate"), "one clear error, not the gltf crate's: {msg}");

    // A supported extension may be required.
    let mut root = bin.document(one_mesh_scene(prim, json!({})));
    root["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    root["extensionsRequired"] = json!(["KHR_lights_punctual"]);
    let path = write_embedded(dir.path(), "lights", root, &bin.data);
    assert!(load_gltf_with(&path, &strict()).unwrap().warnings.is_empty());
}

#[test]
fn used_extensions_that_cannot_be_read_warn() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let mut root = bin.document(one_mesh_scene(prim, json!({})));
    root["extensionsUsed"] = json!(["KHR_materials_clearcoat", "KHR_lights_punctual"]);
    let path = write_embedded(dir.path(), "clearcoat", root, &bin.data);
    let loaded = load_gltf_with(&path, &lenient()).unwrap();
    assert_eq!(loaded.scene.instances.len(), 1, "drawn without it");
    assert_eq!(
        loaded.warnings,
        vec![format!(
            "{}: uses the glTF extension 'KHR_materials_clearcoat' (extensionsUsed), which tiledlight does not read: drawn without it, so the image may differ from the model's (supported: KHR_lights_punctual, KHR_materials_emissive_strength, KHR_mesh_quantization, KHR_texture_transform)",
            path.display()
        )]
    );
    assert_fails(
        &path,
        scene_of(load_gltf_with(&path, &strict())),
        &["strict loading turns warnings into errors: uses the glTF extension 'KHR_materials_clearcoat'"],
    );
}

// ---- missing and broken textures ----

#[test]
fn missing_and_broken_textures_warn_and_fall_back_to_the_factor() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let mut p0 = prim.clone();
    p0["material"] = json!(0);
    let mut p1 = prim.clone();
    p1["material"] = json!(1);
    let mut p2 = prim;
    p2["material"] = json!(2);
    let (good, _) = png(2, 2);
    fs::write(dir.path().join("broken.png"), b"\x89PNG not really").unwrap();
    let root = bin.document(json!({
        "images": [{"uri": "gone.png"}, {"uri": "broken.png", "name": "bricks"}, {"uri": format!("data:image/png;base64,{}", base64(&good))}],
        "textures": [{"source": 0}, {"source": 1}, {"source": 2}],
        "materials": [
            {"name": "paint", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [0.5, 0.25, 1.0, 1.0]}},
            {"name": "wall", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
            {"name": "trim", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
        ],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [p0, p1, p2]}],
    }));
    let path = write_gltf(dir.path(), "textures", root, &bin.data);
    let loaded = load_gltf_with(&path, &lenient()).unwrap();
    let file = path.display();
    let gone = dir.path().join("gone.png");
    // One line per image, naming every material slot drawn without it, then the count.
    assert_eq!(
        loaded.warnings,
        vec![
            format!(
                "{file}: image 0 ('gone.png'): cannot read '{}' (URI 'gone.png'): No such file or directory (os error 2); 2 material slots drawn with the base colour factor alone, as if the texture were white: material 0 'paint' (base colour), material 2 'trim' (base colour).",
                gone.display()
            ),
            format!(
                "{file}: image 1 'bricks': cannot decode image: {}; 1 material slot drawn with the base colour factor alone, as if the texture were white: material 1 'wall' (base colour).",
                image::load_from_memory(b"\x89PNG not really").err().unwrap()
            ),
            format!("{file}: 2 images cannot be used (listed above); 3 material slots are drawn without theirs."),
        ]
    );
    let m = &loaded.scene.materials;
    assert_eq!((m[0].base_color_texture, m[0].base_color), (None, [0.5, 0.25, 1.0, 1.0]), "factor kept");
    assert_eq!(m[1].base_color_texture, None);
    assert_eq!(m[2].base_color_texture, None);
    assert!(loaded.scene.textures.is_empty(), "the good image is not used by any material");

    // Strict: the same problems are one error listing them all.
    assert_fails(
        &path,
        scene_of(load_gltf_with(&path, &strict())),
        &[
            "strict loading turns warnings into errors: image 0 ('gone.png')",
            "material 0 'paint' (base colour)",
            "material 1 'wall' (base colour)",
            "material 2 'trim' (base colour)",
        ],
    );
}

/// A model downloaded without its textures (issue 47: FlightHelmet's 15 images gave 16
/// lines of 530-600 characters): 15 images missing from one folder are one line naming the
/// folder, the count of the file's images, two examples and what is drawn instead, each
/// image's line a detail after it ([`DETAIL`]), then the count of slots; the lines that
/// are not details stay under 1,500 characters. Two missing images keep a line each.
#[test]
fn missing_images_of_one_folder_are_one_warning_with_details() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    let slots = ["baseColorTexture", "metallicRoughnessTexture"];
    let mut images = Vec::new();
    let mut materials = Vec::new();
    let mut prims = Vec::new();
    for m in 0..5 {
        let name = format!("FlightHelmet_Materials_Part{m}Mat");
        let mut pbr = serde_json::Map::new();
        for (k, slot) in slots.iter().enumerate() {
            pbr.insert(slot.to_string(), json!({"index": 3 * m + k}));
        }
        materials.push(json!({"name": name, "pbrMetallicRoughness": pbr, "normalTexture": {"index": 3 * m + 2}}));
        for kind in ["BaseColor", "OcclusionRoughMetal", "Normal"] {
            images.push(json!({"uri": format!("{name}_{kind}.png")}));
        }
        let mut p = prim.clone();
        p["material"] = json!(m);
        prims.push(p);
    }
    let textures: Vec<_> = (0..15).map(|i| json!({"source": i})).collect();
    let root = bin.document(json!({
        "images": images, "textures": textures, "materials": materials,
        "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}], "meshes": [{"primitives": prims}],
    }));
    let path = write_gltf(dir.path(), "helmet", root, &bin.data);
    let w = load_gltf_with(&path, &lenient()).unwrap().warnings;
    let (details, lines): (Vec<&String>, Vec<&String>) = w.iter().partition(|l| l.starts_with(DETAIL));
    assert_eq!((lines.len(), details.len()), (2, 15), "{w:#?}");
    let folder = dir.path().display();
    assert!(
        lines[0].starts_with(&format!(
            "{}: 15 of the file's 15 images are missing from {folder}/ (e.g. 'FlightHelmet_Materials_Part0Mat_BaseColor.png', \
             'FlightHelmet_Materials_Part0Mat_OcclusionRoughMetal.png'); 15 material slots are drawn without them: 5 base colour slots",
            path.display()
        )),
        "{}",
        lines[0]
    );
    assert!(details[0].contains("FlightHelmet_Materials_Part0Mat_BaseColor.png: material 0"), "{}", details[0]);
    assert!(lines[1].ends_with("15 images cannot be used (listed above); 15 material slots are drawn without theirs."));
    let chars: usize = lines.iter().map(|l| l.len()).sum();
    assert!(chars < 1500, "{chars} characters of warnings without the details");
    assert!(details.iter().all(|d| !d.contains(&path.display().to_string())), "details do not repeat the file");
}

// ---- memory limits ----

/// One image wanted by a base colour and a normal slot: one warning naming both slots and
/// both fallbacks; an image only a normal slot wants: the factors-alone wording.
#[test]
fn an_unusable_image_warns_once_for_every_slot_that_wants_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let mut prim = bin.triangle();
    prim["material"] = json!(0);
    let mut p1 = prim.clone();
    p1["material"] = json!(1);
    let root = bin.document(json!({
        "images": [{"uri": "shared.png"}, {"uri": "bumps.png"}],
        "textures": [{"source": 0}, {"source": 1}],
        "materials": [
            {"name": "a", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "normalTexture": {"index": 0}},
            {"name": "b", "normalTexture": {"index": 1}}
        ],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [prim, p1]}],
    }));
    let path = write_gltf(dir.path(), "slots", root, &bin.data);
    let w = load_gltf_with(&path, &lenient()).unwrap().warnings;
    assert_eq!(w.len(), 3, "{w:#?}");
    assert!(w[0].contains("image 0 ('shared.png')"), "{}", w[0]);
    assert!(
        w[0].ends_with(
            "2 material slots drawn without it (the factors alone; a base colour as if the texture were white): \
             material 0 'a' (base colour), material 0 'a' (normal)."
        ),
        "{}",
        w[0]
    );
    assert!(
        w[1].contains("image 1 ('bumps.png')")
            && w[1].ends_with("1 material slot drawn without it (the factors alone): material 1 'b' (normal)."),
        "{}",
        w[1]
    );
    assert!(w[2].ends_with("2 images cannot be used (listed above); 3 material slots are drawn without theirs."));
}

#[test]
fn images_beyond_the_limits_are_dropped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let mut prim = bin.triangle();
    prim["material"] = json!(0);
    let (bytes, _) = png(4, 4);
    fs::write(dir.path().join("t.png"), &bytes).unwrap();
    let materials = json!([{"name": "m", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    let file_image = json!({"images": [{"uri": "t.png"}], "textures": [{"source": 0}], "materials": materials.clone()});
    let path = write_gltf(dir.path(), "file", bin.document(one_mesh_scene(prim.clone(), file_image)), &bin.data);
    let data_image = json!({
        "images": [{"uri": format!("data:image/png;base64,{}", base64(&bytes))}],
        "textures": [{"source": 0}],
        "materials": materials,
    });
    let data_path = write_gltf(dir.path(), "data", bin.document(one_mesh_scene(prim, data_image)), &bin.data);

    let small_file = LoadOptions { limits: LoadLimits { image_bytes: 40, ..LoadLimits::default() }, ..lenient() };
    let w = load_gltf_with(&path, &small_file).unwrap().warnings;
    assert_eq!(w.len(), 1);
    let expected = format!(
        "image 0 ('t.png'): '{}' (URI 't.png') is {} bytes, more than the 40 bytes allowed; 1 material slot drawn",
        dir.path().join("t.png").display(),
        bytes.len()
    );
    assert!(w[0].contains(&expected), "{w:?}");
    let w = load_gltf_with(&data_path, &small_file).unwrap().warnings;
    assert!(
        w[0].contains(&format!("image 0: data URI holds {} bytes, more than the 40 bytes allowed", bytes.len())),
        "{w:?}"
    );

    // 4 x 4 RGBA8 takes 64 bytes.
    let small_texture = LoadOptions { limits: LoadLimits { texture_bytes: 63, ..LoadLimits::default() }, ..lenient() };
    let w = load_gltf_with(&path, &small_texture).unwrap().warnings;
    assert!(
        w[0].contains("image 0 ('t.png'): the image is larger than the 63 bytes a decoded texture may take"),
        "{w:?}"
    );
    let fits = LoadOptions { limits: LoadLimits { texture_bytes: 64, ..LoadLimits::default() }, ..lenient() };
    let loaded = load_gltf_with(&path, &fits).unwrap();
    assert!(loaded.warnings.is_empty() && loaded.scene.textures.len() == 1);
}

#[test]
fn the_scene_memory_limit_bounds_what_a_small_file_can_ask_for() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Bin::default();
    let prim = bin.triangle();
    // 2000 primitives naming the same small accessors: each becomes a mesh of its own.
    let many: Vec<Value> = (0..2000).map(|_| prim.clone()).collect();
    let root =
        bin.document(json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}], "meshes": [{"primitives": many}]}));
    let path = write_embedded(dir.path(), "many", root, &bin.data);
    // One triangle: 3 vertices of 32 bytes and 3 indices of 4: 108 bytes a mesh.
    let limit = LoadOptions { limits: LoadLimits { scene_bytes: 108 * 1000, ..LoadLimits::default() }, ..lenient() };
    assert_fails(
        &path,
        scene_of(load_gltf_with(&path, &limit)),
        &[
            "mesh 0 '' primitive 1000",
            "more than the 0 bytes left of the scene's memory limit (LoadLimits::scene_bytes)",
        ],
    );
    assert_eq!(load_gltf(&path, 0.1).unwrap().meshes.len(), 2000, "the default limit is far above this");

    // An accessor without a buffer view is zeros: its count alone costs nothing to write.
    let mut bin = Bin::default();
    let i = bin.indices_u16(&[0, 1, 2]);
    let sparse_index = bin.view(&0u16.to_le_bytes());
    let sparse_value = bin.view(&[0u8; 12]);
    bin.accessors.push(json!({"componentType": 5126, "count": 1 << 22, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0],
        "sparse": {"count": 1, "indices": {"bufferView": sparse_index, "componentType": 5123}, "values": {"bufferView": sparse_value}}}));
    let p = bin.accessors.len() - 1;
    let root = bin.document(one_mesh_scene(json!({"attributes": {"POSITION": p}, "indices": i}), json!({})));
    let path = write_embedded(dir.path(), "viewless", root, &bin.data);
    let limit = LoadOptions { limits: LoadLimits { scene_bytes: 1 << 20, ..LoadLimits::default() }, ..lenient() };
    assert_fails(
        &path,
        scene_of(load_gltf_with(&path, &limit)),
        &["POSITION: accessor 1: 4194304 elements take 50331648 bytes, more than the 1048576 bytes left of the scene's memory limit"],
    );
    let mut root = bin.document(one_mesh_scene(json!({"attributes": {"POSITION": p}, "indices": i}), json!({})));
    root["accessors"][p]["count"] = json!((1u64 << 24) + 1);
    let path = write_embedded(dir.path(), "viewless_huge", root, &bin.data);
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &["accessor 1 has no buffer view and 16777217 elements (at most 16777216 are accepted)"],
    );
}

#[test]
fn a_position_naming_a_missing_accessor_is_an_error_not_a_panic() {
    // gltf-json 1.4.1's validation indexes the accessors unchecked for POSITION.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("noacc.gltf");
    let root = json!({
        "asset": {"version": "2.0"},
        "meshes": [{"primitives": [{"attributes": {"POSITION": 5}}]}],
        "nodes": [{"mesh": 0}],
    });
    write_json(&path, &root);
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &["glTF does not validate", "meshes[0].primitives[0].attributes[\"POSITION\"]: Index out of bounds"],
    );
}

#[test]
fn a_glb_header_shorter_than_itself_is_an_error_not_a_panic() {
    // gltf 1.4.1 subtracts 12 from the header's length unchecked.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.glb");
    let mut bytes = b"glTF".to_vec();
    bytes.extend_from_slice(&2u32.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&[0; 16]);
    fs::write(&path, bytes).unwrap();
    assert_fails(
        &path,
        load_gltf(&path, 0.1),
        &["malformed GLB container: its header gives a total length of 0 bytes, less than the 12-byte header"],
    );
}
