//! Integration tests of the `tiledlight` command line: runs the built binary at tiny sizes
//! (64x36, a few lights) on the adapter `WGPU_ADAPTER_NAME` names (lavapipe in CI) and
//! checks the files it writes and its error handling. Bad input must fail before any GPU
//! work, with exit code != 0 and one `error:` line naming the problem.

mod common;

use std::path::{Path, PathBuf};

use common::{fails, gpu_run, scratch, stdout, tiledlight};
use serde_json::Value;

const TINY: [&str; 6] = ["--width", "64", "--height", "36", "--lights", "16"];

fn with_tiny<'a>(cmd: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![cmd];
    v.extend_from_slice(&TINY);
    v.extend_from_slice(rest);
    v
}

#[test]
fn render_writes_a_png_of_the_requested_size() {
    let dir = scratch("render");
    let png = dir.join("a.png");
    let out = gpu_run(&with_tiny("render", &["--out", png.to_str().unwrap()]));
    let img = image::open(&png).expect("a readable PNG");
    assert_eq!((img.width(), img.height()), (64, 36));
    // Even 16 lights light part of the courtyard (the rest is near-black ambient).
    let rgb = img.to_rgb8();
    let lit = rgb.pixels().filter(|p| p.0.iter().any(|&c| c > 20)).count();
    assert!(lit > 50, "only {lit} lit pixels");
    let text = stdout(&out);
    for needle in ["adapter:", "scene:", "16 point, 0 spot", "64x36", "culling:", "GPU memory", "wrote"] {
        assert!(text.contains(needle), "no {needle:?} in:\n{text}");
    }
}

#[test]
fn render_heatmap_and_brute_force() {
    let dir = scratch("heatmap");
    let png = dir.join("h.png");
    let out = gpu_run(&with_tiny("render", &["--heatmap", "--tile-size", "8", "--out", png.to_str().unwrap()]));
    let img = image::open(&png).expect("a readable PNG");
    assert_eq!((img.width(), img.height()), (64, 36));
    assert!(stdout(&out).contains("heat map"), "{}", stdout(&out));

    let png = dir.join("b.png");
    let out = gpu_run(&with_tiny("render", &["--method", "brute-force-no-cutoff", "--out", png.to_str().unwrap()]));
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36));
    assert!(stdout(&out).contains("brute_force.shade"), "{}", stdout(&out));
}

#[test]
fn bench_writes_json_with_every_pass() {
    let dir = scratch("bench");
    let json = dir.join("nested/b.json");
    let out = gpu_run(&with_tiny("bench", &["--frames", "3", "--warmup", "1", "--json", json.to_str().unwrap()]));
    let text = stdout(&out);
    assert!(text.contains("total GPU") || text.contains("not available"), "{text}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("valid JSON");
    let config = &v["config"];
    assert_eq!(config["resolution"], "64x36");
    assert_eq!(config["width"], 64);
    assert_eq!(config["height"], 36);
    assert_eq!(config["method"], "forward-plus");
    assert_eq!(config["tile_size"], 16);
    assert_eq!(config["point_lights"], 16);
    assert!(config["adapter"].as_str().is_some_and(|s| !s.is_empty()));
    assert!(config["commit"].as_str().is_some_and(|s| !s.is_empty()));
    assert_eq!(v["frames"], 3);
    assert_eq!(v["cpu_frame"]["frames"], 3);
    if v["timestamps"] == Value::Bool(true) {
        let passes = v["passes"].as_array().expect("passes");
        for name in ["depth_prepass", "forward.cull", "forward.shade", "tonemap"] {
            let p = passes.iter().find(|p| p["pass"] == name).unwrap_or_else(|| panic!("no pass {name} in {v}"));
            let ms = p["median_ms"].as_f64().unwrap();
            assert!(ms.is_finite() && ms >= 0.0, "{name}: {ms}");
            assert!(p["frames"].as_u64().unwrap() >= 1, "{name}");
        }
        assert!(v["total_gpu_median_ms"].as_f64().unwrap().is_finite());
        // The frame's first-to-last span holds every pass, each frame: at least the
        // longest pass's median (the same frames' medians).
        let span = &v["frame_gpu_first_to_last"];
        assert!(span["frames"].as_u64().unwrap() >= 1, "{v}");
        let longest = passes.iter().map(|p| p["median_ms"].as_f64().unwrap()).fold(0.0, f64::max);
        assert!(span["median_ms"].as_f64().unwrap() >= longest, "{span} vs the longest pass {longest}");
        assert!(text.contains("GPU frame"), "{text}");
    }
    // No light casts a shadow: no shadow numbers, and no shadow line in the report.
    assert!(v["shadow_faces_per_frame"].is_null() && v["shadow_atlas_bytes"].is_null(), "{v}");
    assert_eq!(v["move_lights"], false);
    assert!(!text.contains("shadow"), "{text}");
    // No blended geometry: null, and no line about it.
    assert!(v["blended_instances"].is_null() && v["blend_mode"].is_null(), "{v}");
    assert_eq!(v["config"]["transparent_objects"], 0);
    assert!(!text.contains("blend"), "{text}");
    // No compute raster: no large triangles' tiles.
    assert!(v["large_tiles"].is_null() && !text.contains("large triangles"), "{v}");
}

/// The visibility buffer's compute raster reports the screen tiles its large triangles
/// listed (what `scripts/perf-summary.py` prices `visibility.raster.large` by): with every
/// triangle wider than a pixel large, some, in the JSON and the printout.
#[test]
fn bench_reports_the_large_triangles_tiles() {
    let dir = scratch("bench-large");
    let json = dir.join("l.json");
    let args = ["--method", "visibility", "--raster", "compute", "--raster-large-px", "1", "--frames", "2"];
    let mut bench = with_tiny("bench", &args);
    bench.extend(["--warmup", "1", "--json", json.to_str().unwrap()]);
    let out = gpu_run(&bench);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let tiles = v["large_tiles"].as_u64().unwrap_or_else(|| panic!("no large_tiles in {v}"));
    assert!(tiles > 0, "{v}");
    assert!(stdout(&out).contains(&format!("large triangles: {tiles} screen tiles")), "{}", stdout(&out));
}

/// Transparent grid objects: `render` names them and reports the blended path (instances,
/// mode, its own light lists, memory) and times its passes; `bench` writes the blended
/// instances and the blend mode to its JSON.
#[test]
fn transparent_objects_render_and_bench_report_the_blended_geometry() {
    let dir = scratch("blended");
    let glass = ["--grid-objects", "24", "--transparent-objects", "6"];
    for mode in ["sorted", "wboit"] {
        let png = dir.join(format!("{mode}.png"));
        let mut render = with_tiny("render", &["--blend-mode", mode, "--out", png.to_str().unwrap()]);
        render.extend(glass);
        let text = stdout(&gpu_run(&render));
        for needle in [
            "blended:    6 transparent grid objects (glass), ".to_string(),
            "blend path: 6 instances, ".to_string(),
            format!("--blend-mode {mode}; lists: "),
            "lights per tile over ".to_string(),
            "tiles with blended geometry".to_string(),
            "blended.layer".to_string(),
        ] {
            assert!(text.contains(&needle), "no {needle:?} in:\n{text}");
        }
        assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36));
        if mode == "sorted" {
            // The heat map of the blended lists (tests/tests/blended.rs checks its tiles).
            let heat = dir.join("heat.png");
            let mut render = with_tiny("render", &["--heatmap", "blended", "--out", heat.to_str().unwrap()]);
            render.extend(glass);
            let text = stdout(&gpu_run(&render));
            assert!(text.contains("(heat map of the blended lists, with legend)"), "{text}");
            assert_eq!(image::image_dimensions(&heat).unwrap(), (64, 36));
            // Without glass there are no blended lists: one clear error line, after the
            // scene is loaded (a glTF's BLEND materials are known only then).
            let _guard = common::gpu_lock();
            let line = fails(&with_tiny("render", &["--heatmap", "blended", "--out", heat.to_str().unwrap()]));
            assert!(line.contains("--heatmap blended") && line.contains("no blended geometry"), "{line}");
        }

        let json = dir.join(format!("{mode}.json"));
        let mut bench = with_tiny("bench", &["--frames", "2", "--warmup", "1", "--blend-mode", mode]);
        bench.extend(["--json", json.to_str().unwrap()]);
        bench.extend(glass);
        let text = stdout(&gpu_run(&bench));
        assert!(
            text.contains(&format!(
                "blend path: 6 instances, {}",
                if mode == "sorted" { "sorted" } else { "weighted" }
            )),
            "{text}"
        );
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!((&v["blended_instances"], &v["blend_mode"]), (&Value::from(6), &Value::from(mode)), "{v}");
        assert_eq!(v["config"]["transparent_objects"], 6);
        if v["timestamps"] == Value::Bool(true) {
            let passes = v["passes"].as_array().unwrap();
            for name in ["blended.depth", "blended.cull", "blended.shade", "blended.composite"] {
                assert!(passes.iter().any(|p| p["pass"] == name), "no pass {name} in {v}");
            }
        }
    }
}

/// Shadow-casting lights: `render` reports the atlas and the faces its last frame drew (0:
/// the lights stand still, their faces were drawn by the first frame), `bench` the faces
/// per measured frame, 0 with still lights and every face with `--move-lights`.
#[test]
fn shadows_render_and_bench_report_their_faces() {
    let dir = scratch("shadows");
    let png = dir.join("s.png");
    let shadows = ["--spot-lights", "4", "--shadow-point-lights", "2", "--shadow-spot-lights", "1"];
    let mut render = with_tiny("render", &["--out", png.to_str().unwrap()]);
    render.extend(shadows);
    let text = stdout(&gpu_run(&render));
    for needle in [
        "shadows:    2 point + 1 spot casters (the brightest of each kind), 256 px tiles, 5x5 PCF, d16",
        "shadow map: 0 faces drawn by the last frame",
        // Two point casters' rows and one row of spots: 3 rows of 256 texels.
        "atlas 1536x768 x1 layer, 256 px tiles, 5x5 PCF, d16; 13 faces; ",
        "shadow.atlas",
    ] {
        assert!(text.contains(needle), "no {needle:?} in:\n{text}");
    }
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36));

    for (moving, faces) in [(false, 0), (true, 13)] {
        let json = dir.join(format!("b{moving}.json"));
        let mut bench = with_tiny("bench", &["--frames", "3", "--warmup", "1", "--json", json.to_str().unwrap()]);
        bench.extend(shadows);
        if moving {
            bench.push("--move-lights");
        }
        let text = stdout(&gpu_run(&bench));
        let motion = if moving { "lights moved before every frame (--move-lights)" } else { "lights still" };
        assert!(text.contains(motion), "{text}");
        assert!(text.contains(&format!("shadows:    {faces} shadow faces drawn per measured frame")), "{text}");
        assert!(text.contains("shadow map: atlas 1536x768"), "{text}");
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(v["shadow_faces_per_frame"]["min"], faces, "{v}");
        assert_eq!(v["shadow_faces_per_frame"]["max"], faces, "{v}");
        assert_eq!(v["move_lights"], moving);
        // 1536x768 16-bit texels and 13 faces of 80 bytes.
        assert_eq!(v["shadow_atlas_bytes"], 1536 * 768 * 2 + 13 * 80, "{v}");
        assert_eq!(v["config"]["shadow_spot_lights"], 1);
        assert_eq!(v["config"]["shadow_format"], "d16");
        if moving && v["timestamps"] == Value::Bool(true) {
            let passes = v["passes"].as_array().unwrap();
            assert!(passes.iter().any(|p| p["pass"] == "shadow.atlas"), "{v}");
        }
    }
}

/// A 10 m quad with one KHR point light and no camera, written next to its buffer.
fn write_gltf(dir: &Path) -> PathBuf {
    let mut bin = Vec::new();
    let positions: [[f32; 3]; 4] = [[-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]];
    for p in positions {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for _ in 0..4 {
        for c in [0.0f32, 1.0, 0.0] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 2, 1, 0, 3, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("quad.bin"), &bin).unwrap();
    let gltf = r#"{
      "asset": {"version": "2.0"},
      "extensionsUsed": ["KHR_lights_punctual"],
      "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 0.5, 0.2], "intensity": 5, "range": 6}]}},
      "scene": 0,
      "scenes": [{"nodes": [0, 1]}],
      "nodes": [
        {"mesh": 0},
        {"translation": [0, 1, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}}
      ],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
      "buffers": [{"uri": "quad.bin", "byteLength": 108}],
      "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 48},
        {"buffer": 0, "byteOffset": 48, "byteLength": 48},
        {"buffer": 0, "byteOffset": 96, "byteLength": 12}
      ],
      "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-5, 0, -5], "max": [5, 0, 5]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
      ]
    }"#;
    let path = dir.join("quad.gltf");
    std::fs::write(&path, gltf).unwrap();
    path
}

#[test]
fn render_gltf_with_its_own_and_random_lights() {
    let dir = scratch("gltf");
    let scene = write_gltf(&dir);
    let png = dir.join("q.png");
    let base = [
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "36",
        "--out",
        png.to_str().unwrap(),
    ];
    let out = gpu_run(&base);
    let text = stdout(&out);
    assert!(text.contains("1 point, 0 spot (all 1 from the glTF file)"), "{text}");
    assert!(text.contains("framing the scene bounds"), "{text}");
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36));

    let mut more = base.to_vec();
    more.extend(["--lights", "3", "--spot-lights", "2", "--lights-in-bounds"]);
    let text = stdout(&gpu_run(&more));
    assert!(text.contains("4 point, 2 spot (1 from the glTF file + 5 random"), "{text}");

    // By default a loaded scene's random lights fit it: on its surfaces (the 10 m quad:
    // 100 m^2), one radius from its area and the count, r = sqrt(8 A / (pi N (1 - f^2)))
    // = 2.61 m for 40 lights (f = 0.25), not the courtyard's 1.5-4 m anywhere in the box.
    let mut fit = base.to_vec();
    fit.extend(["--lights", "40"]);
    let text = stdout(&gpu_run(&fit));
    let lights = text.lines().find(|l| l.starts_with("lights:")).expect("a lights line");
    assert!(lights.contains("40 on the surfaces (100 m^2"), "{lights}");
    let r: f32 =
        lights.split("radius ").nth(1).and_then(|t| t.split(' ').next()).and_then(|v| v.parse().ok()).expect("radius");
    assert!((r - 2.606).abs() < 0.01, "radius {r} m: {lights}");

    // The file's lights are counted when it loads: more casters than it has is an upload
    // error naming the flags and both numbers.
    let mut casters = base.to_vec();
    casters.extend(["--shadow-point-lights", "2"]);
    let line = fails(&casters);
    assert!(
        line.contains("--shadow-point-lights 2 --shadow-spot-lights 0")
            && line.contains("2 shadow-casting point lights requested; the scene has 1"),
        "{line}"
    );
}

/// A missing texture is a `warning:` line and the render goes on; `--strict` makes it an
/// error. A buffer outside the model's folder is refused unless `--allow-any-path`.
#[test]
fn gltf_warnings_strict_and_file_confinement() {
    let dir = scratch("gltf_warnings");
    let models = dir.join("models");
    std::fs::create_dir_all(&models).unwrap();
    let quad = write_gltf(&models);
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&quad).unwrap()).unwrap();
    doc["images"] = serde_json::json!([{"uri": "gone.png"}]);
    doc["textures"] = serde_json::json!([{"source": 0}]);
    doc["materials"] =
        serde_json::json!([{"name": "paint", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
    let scene = models.join("textured.gltf");
    std::fs::write(&scene, serde_json::to_vec(&doc).unwrap()).unwrap();
    let png = dir.join("w.png");
    let args = [
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "36",
        "--out",
        png.to_str().unwrap(),
    ];

    let out = gpu_run(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning: ")).collect();
    let expected = format!(
        "warning: {}: image 0 ('gone.png'): cannot read '{}' (URI 'gone.png'): No such file or directory (os error 2); 1 material slot drawn with the base colour factor alone, as if the texture were white: material 0 'paint' (base colour).",
        scene.display(),
        models.join("gone.png").display()
    );
    assert_eq!(warnings, [expected.as_str()], "stderr:\n{err}");
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36), "the render goes on");

    // The warning is a field of bench's JSON and a column of sweep's CSV too.
    let json = dir.join("w.json");
    let bench = ["bench", "--scene", scene.to_str().unwrap(), "--width", "64", "--height", "36"];
    let mut b = bench.to_vec();
    b.extend(["--frames", "2", "--warmup", "0", "--json", json.to_str().unwrap()]);
    gpu_run(&b);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let text = expected.strip_prefix("warning: ").unwrap();
    assert_eq!(v["load_warnings"], serde_json::json!([text]), "{v}");
    let csv_path = dir.join("w.csv");
    let mut sweep = bench.to_vec();
    sweep[0] = "sweep";
    sweep.extend(["--axis", "lights=2", "--frames", "2", "--warmup", "0", "--out", csv_path.to_str().unwrap()]);
    gpu_run(&sweep);
    let mut r = csv::Reader::from_path(&csv_path).unwrap();
    let col = r.headers().unwrap().iter().position(|h| h == "load_warnings").expect("a load_warnings column");
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert!(!rows.is_empty() && rows.iter().all(|row| &row[col] == text), "{rows:?}");

    let mut strict = args.to_vec();
    strict.push("--strict");
    let line = fails(&strict);
    assert!(line.contains("strict loading turns warnings into errors: image 0 ('gone.png')"), "{line}");
    assert!(line.contains("material 0 'paint' (base colour)"), "{line}");
    assert!(line.contains("textured.gltf") && line.contains("gone.png"), "{line}");

    // The buffer one folder up: refused, naming the URI; read with --allow-any-path.
    std::fs::rename(models.join("quad.bin"), dir.join("quad.bin")).unwrap();
    doc["buffers"][0]["uri"] = serde_json::json!("../quad.bin");
    doc.as_object_mut().unwrap().remove("materials");
    doc["meshes"][0]["primitives"][0].as_object_mut().unwrap().remove("material");
    std::fs::write(&scene, serde_json::to_vec(&doc).unwrap()).unwrap();
    let line = fails(&args);
    assert!(
        line.contains("buffer 0: URI '../quad.bin' names") && line.contains("outside the model's folder"),
        "{line}"
    );
    assert!(line.contains("--allow-any-path"), "{line}");
    let mut allowed = args.to_vec();
    allowed.push("--allow-any-path");
    let out = gpu_run(&allowed);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning:"), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Tiled Deferred renders and benches through the same flags, with its own passes.
#[test]
fn deferred_renders_and_benches() {
    let dir = scratch("deferred");
    let png = dir.join("d.png");
    let args = ["--method", "deferred", "--gbuffer-rts", "5", "--spot-lights", "8", "--width", "64", "--height", "36"];
    let mut render = vec!["render", "--out", png.to_str().unwrap()];
    render.extend(args);
    let text = stdout(&gpu_run(&render));
    assert!(text.contains("deferred (16 px tiles") && text.contains("5 G-buffer targets"), "{text}");
    assert!(text.contains("deferred.gbuffer"), "{text}");
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36));
    let json = dir.join("d.json");
    let mut bench = vec!["bench", "--frames", "3", "--warmup", "1", "--json", json.to_str().unwrap()];
    bench.extend(args);
    gpu_run(&bench);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let passes: Vec<&str> = v["passes"].as_array().unwrap().iter().map(|p| p["pass"].as_str().unwrap()).collect();
    // The command line's exposure is automatic: its pass runs before the tonemap.
    assert_eq!(passes, ["deferred.gbuffer", "deferred.cull_cells", "deferred.shade", "exposure", "tonemap"]);
}

/// Zero lights is a valid frame (ambient only), not an error.
#[test]
fn zero_lights_render_ambient_only() {
    let dir = scratch("zero");
    let png = dir.join("z.png");
    let out = gpu_run(&["render", "--lights", "0", "--width", "64", "--height", "36", "--out", png.to_str().unwrap()]);
    assert!(stdout(&out).contains("0 point, 0 spot"), "{}", stdout(&out));
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 36));
}

#[test]
fn bad_input_gives_one_clear_error_line() {
    let cases: &[(&[&str], &str)] = &[
        (&["render", "--scene", "/nonexistent.gltf"], "/nonexistent.gltf"),
        (&["render", "--scene", "scene.obj"], "--scene"),
        (&["render", "--scene", "scene.obj"], "'bevy-many-lights'"),
        (&["render", "--scene", "/tmp"], "--scene /tmp: is a folder"),
        (&["render", "--width", "0"], "--width 0"),
        (&["render", "--height", "100000"], "--height 100000"),
        (&["render", "--lights", "99999999"], "--lights 99999999"),
        (&["render", "--lights", "1048576", "--spot-lights", "1"], "at most 1048576"),
        (&["render", "--tile-size", "7"], "--tile-size 7"),
        (&["render", "--method", "deferred", "--gbuffer-rts", "6"], "--gbuffer-rts 6"),
        (&["render", "--capacity", "0"], "--capacity 0"),
        (&["render", "--threshold", "-1"], "--threshold -1"),
        (&["render", "--exposure", "nan"], "--exposure"),
        (&["render", "--grid-objects", "281"], "--grid-objects 281"),
        (&["render", "--out", "x.jpg"], ".png"),
        (&["render", "--heatmap", "--method", "brute-force"], "--heatmap"),
        (&["render", "--density", "extreme"], "extreme"),
        (&["render", "--lights", "many"], "many"),
        (&["render", "--no-such-flag"], "--no-such-flag"),
        (&["bench", "--frames", "0"], "--frames 0"),
        (&["bench", "--tile-size", "64"], "--tile-size 64"),
        (&["render", "--shadow-size", "100"], "--shadow-size 100"),
        (&["render", "--shadow-filter", "4"], "'4' for '--shadow-filter"),
        (&["render", "--shadow-format", "d24"], "d24"),
        (&["render", "--grid-objects", "4", "--transparent-objects", "5"], "--transparent-objects 5"),
        (&["render", "--blend-mode", "additive"], "additive"),
        (&["render", "--lights", "2", "--shadow-point-lights", "3"], "--shadow-point-lights 3"),
        (&["bench", "--shadow-spot-lights", "1"], "--shadow-spot-lights 1"),
        (&["frobnicate"], "frobnicate"),
        (&["render", "--camera", "/nonexistent/cam.txt"], "--camera /nonexistent/cam.txt"),
        (&["view", "--script", "zoom=3"], "unknown key 'zoom'"),
        (&["view", "--screenshot", "a.png"], "need --frames"),
        (&["view", "--frames", "1", "--screenshot", "a.jpg"], ".png"),
    ];
    for (args, needle) in cases {
        let line = fails(args);
        assert!(line.contains(needle), "tiledlight {args:?}: {line:?} does not name {needle:?}");
    }
}

/// Every output path is checked before any GPU work (issue 47): a path nothing can be
/// written to fails at once with one error line naming the flag and the path. The runs ask
/// for an adapter that does not exist, so a command that reached the GPU first would fail
/// naming the adapter instead; /proc takes no new files even from root (file permissions
/// would not stop a root CI run). A path that can be written leaves no file behind the
/// check (render's image appears only after the frame).
#[test]
fn output_paths_are_checked_before_any_gpu_work() {
    if !Path::new("/proc/self").exists() {
        panic!("this test needs Linux's /proc (a folder nobody can write a file in)");
    }
    let dir = scratch("output-checks");
    let csv = dir.join("ok.csv");
    let csv = csv.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["render", "--out", "/proc/tiledlight/x.png"], "--out /proc/tiledlight/x.png"),
        (&["render", "--out", "/proc/x.png", "--lights", "4096"], "--out /proc/x.png"),
        (&["bench", "--json", "/proc/b.json"], "--json /proc/b.json"),
        (&["sweep", "--axis", "tile-size=8,16", "--out", "/proc/s.csv"], "--out /proc/s.csv"),
        (&["sweep", "--axis", "tile-size=8,16", "--out", csv, "--chart", "/proc/s.png"], "--chart /proc/s.png"),
        (&["accuracy", "--out", "/proc/a.csv"], "--out /proc/a.csv"),
        (&["accuracy", "--out", csv, "--diff-dir", "/proc/flip"], "--diff-dir /proc/flip"),
        (&["shadow-accuracy", "--out", "/proc/sa.json"], "--out /proc/sa.json"),
        (&["tune", "--target-flip", "0.05", "--out", "/proc/t.csv"], "--out /proc/t.csv"),
        (&["export", "--out", "/proc/e.glb"], "--out /proc/e.glb"),
        (&["view", "--frames", "1", "--screenshot", "/proc/v.png"], "--screenshot /proc/v.png"),
    ];
    for (args, needle) in cases {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_tiledlight"))
            .args(*args)
            .env("WGPU_ADAPTER_NAME", "no-such-adapter-anywhere")
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        assert!(!out.status.success(), "tiledlight {args:?} succeeded");
        assert_eq!(lines.len(), 1, "tiledlight {args:?}: one error line, got:\n{err}");
        assert!(lines[0].starts_with(&format!("error: {needle}: ")), "tiledlight {args:?}: {:?}", lines[0]);
        assert!(!lines[0].contains("adapter"), "tiledlight {args:?} reached the GPU first: {:?}", lines[0]);
        assert!(stdout(&out).is_empty(), "tiledlight {args:?} printed a report before failing: {}", stdout(&out));
    }
    assert!(!Path::new(csv).exists(), "the checks made no output file");
}

/// The README's first screen (its first 50 lines) says how to get the `tiledlight` command
/// and shows the four methods (issue 47); each of its `tiledlight render --method` lines
/// runs as written (at a tiny size, into a scratch folder).
#[test]
fn the_readme_first_screen_gets_the_command_and_runs_the_four_methods() {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md")).unwrap();
    let first: Vec<&str> = readme.lines().take(50).collect();
    assert!(first.iter().any(|l| l.contains("cargo install --locked --path crates/app")), "how to get the command");
    let runs: Vec<&str> = first
        .iter()
        .filter_map(|l| l.strip_prefix("tiledlight render --method "))
        .map(|l| l.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(runs, ["forward-plus", "deferred", "visibility", "brute-force"], "the four methods");
    let dir = scratch("readme-methods");
    for m in runs {
        let out = dir.join(format!("{m}.png"));
        gpu_run(&with_tiny("render", &["--method", m, "--out", out.to_str().unwrap()]));
        assert!(out.exists(), "{m}: no image");
    }
}

/// Long commands show a progress bar of their frames on a terminal (issue 47), not on a
/// pipe, and not with `--quiet`. The terminal is `script`'s pseudo-terminal (util-linux's
/// bsdutils, essential on Debian).
#[test]
fn progress_shows_on_a_terminal_only_and_quiet_hides_it() {
    let bin = env!("CARGO_BIN_EXE_tiledlight");
    let bench = format!("{bin} bench --width 64 --height 36 --lights 16 --frames 200 --warmup 0");
    let _guard = common::gpu_lock();
    let on_tty = |cmd: &str| {
        let out = std::process::Command::new("script")
            .args(["-qec", cmd, "/dev/null"])
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .output()
            .expect("util-linux's script (bsdutils) runs the command on a pseudo-terminal");
        assert!(out.status.success(), "{cmd}: {}", String::from_utf8_lossy(&out.stdout));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    // The bar moves: some frame after the first is drawn (indicatif draws up to 20 times a
    // second; 200 frames take over a second on lavapipe).
    let shown = on_tty(&bench);
    let moved = (1..=200).any(|n| shown.contains(&format!(" {n}/200 frames")));
    assert!(moved, "no moving progress bar on a terminal: {shown}");
    assert!(!on_tty(&format!("{bench} --quiet")).contains("frames,"), "--quiet shows a bar");
    let piped = tiledlight(&["bench", "--width", "64", "--height", "36", "--lights", "16", "--frames", "40"]);
    assert!(piped.status.success());
    assert!(piped.stderr.is_empty(), "a pipe gets a bar: {}", String::from_utf8_lossy(&piped.stderr));
    // The traced reference's bands are a bar too: a pipe gets no band lines.
    let out = scratch("progress-traced").join("traced.png");
    let traced = tiledlight(&with_tiny("render", &["--method", "traced-reference", "--out", out.to_str().unwrap()]));
    assert!(traced.status.success(), "{}", String::from_utf8_lossy(&traced.stderr));
    let err = String::from_utf8_lossy(&traced.stderr);
    assert!(!err.contains("band") && !err.contains('\r'), "a pipe gets the traced reference's band lines: {err}");
}

/// A model downloaded without its 15 textures (issue 47: FlightHelmet printed 7,500
/// characters of warnings): at most 1,500 characters of warning lines, one of them naming
/// the folder and two examples; `--verbose` adds each image's line.
#[test]
fn missing_textures_are_one_grouped_warning_and_verbose_lists_them() {
    let dir = scratch("missing-textures");
    let quad = write_gltf(&dir);
    let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&quad).unwrap()).unwrap();
    let prim = doc["meshes"][0]["primitives"][0].clone();
    let (mut images, mut materials, mut prims) = (vec![], vec![], vec![]);
    for m in 0..5 {
        let name = format!("FlightHelmet_Materials_Part{m}Mat");
        for kind in ["BaseColor", "OcclusionRoughMetal", "Normal"] {
            images.push(serde_json::json!({"uri": format!("{name}_{kind}.png")}));
        }
        materials.push(serde_json::json!({
            "name": name,
            "pbrMetallicRoughness": {"baseColorTexture": {"index": 3 * m}, "metallicRoughnessTexture": {"index": 3 * m + 1}},
            "normalTexture": {"index": 3 * m + 2}
        }));
        let mut p = prim.clone();
        p["material"] = serde_json::json!(m);
        prims.push(p);
    }
    doc["images"] = Value::from(images);
    doc["textures"] = Value::from((0..15).map(|i| serde_json::json!({"source": i})).collect::<Vec<_>>());
    doc["materials"] = Value::from(materials);
    doc["meshes"][0]["primitives"] = Value::from(prims);
    let path = dir.join("helmet.gltf");
    std::fs::write(&path, serde_json::to_string(&doc).unwrap()).unwrap();
    let out = dir.join("helmet.png");
    let run = |verbose: bool| {
        let mut args = with_tiny("render", &["--scene", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        if verbose {
            args.push("--verbose");
        }
        String::from_utf8_lossy(&gpu_run(&args).stderr).into_owned()
    };
    let short = run(false);
    let warnings: Vec<&str> = short.lines().filter(|l| l.starts_with("warning: ")).collect();
    let chars: usize = warnings.iter().map(|l| l.len()).sum();
    assert!(chars <= 1500, "{chars} characters of warnings:\n{short}");
    assert!(warnings.iter().any(|l| l.contains("15 of the file's 15 images are missing from")), "{short}");
    assert!(!short.contains("Part4Mat_Normal.png"), "a detail without --verbose:\n{short}");
    let long = run(true);
    for m in 0..5 {
        assert!(long.contains(&format!("Part{m}Mat_Normal.png: material {m}")), "--verbose lacks image {m}:\n{long}");
    }
}

/// A camera bookmark (as the viewer's "save camera" writes it) pins the view of `render`;
/// a malformed one names the file and line before any GPU work.
#[test]
fn render_from_a_camera_bookmark() {
    let dir = scratch("bookmark");
    let cam = dir.join("cam.txt");
    std::fs::write(
        &cam,
        "# saved by the viewer\neye 0 3 12\ntarget 0 2 0\nup 0 1 0\nfov_y_deg 50\nnear 0.05\nfar inf\n",
    )
    .unwrap();
    let png = dir.join("b.png");
    let out = gpu_run(&with_tiny("render", &["--camera", cam.to_str().unwrap(), "--out", png.to_str().unwrap()]));
    let text = stdout(&out);
    assert!(text.contains(&format!("camera: bookmark {}", cam.display())), "{text}");
    assert!(png.exists());
    std::fs::write(&cam, "eye 0 3 12\ntarget 0 NaN 0\n").unwrap();
    let line = fails(&["render", "--camera", cam.to_str().unwrap()]);
    assert!(line.contains(&format!("{}:2: 'NaN' must be a finite number", cam.display())), "{line}");
}

#[test]
fn help_and_version_succeed() {
    for args in [&["--help"][..], &["render", "--help"], &["bench", "--help"], &["view", "--help"], &["--version"]] {
        let out = tiledlight(args);
        assert!(out.status.success(), "{args:?}");
        assert!(!out.stdout.is_empty(), "{args:?}");
    }
    let help = stdout(&tiledlight(&["render", "--help"]));
    for flag in
        ["--scene", "--lights", "--spot-lights", "--tile-size", "--heatmap", "--half-z", "--aabb", "--spot-cone"]
    {
        assert!(help.contains(flag), "render --help lacks {flag}");
    }
    // Issue 47: the flags under headings; -h at most 60 lines, naming every group and how
    // to see them all; the summary names every method.
    let headings = [
        "Scene:",
        "Lights:",
        "Method and image:",
        "Culling:",
        "Shadows:",
        "VPLs:",
        "Blended geometry:",
        "Pass settings:",
        "Input checks:",
        "Output:",
    ];
    for h in headings {
        assert!(help.lines().any(|l| l == h), "render --help lacks the heading {h}");
    }
    for cmd in ["render", "bench", "sweep", "accuracy", "tune", "shadow-accuracy", "export", "view"] {
        let short = stdout(&tiledlight(&[cmd, "-h"]));
        let n = short.lines().count();
        assert!(n <= 60, "{cmd} -h: {n} lines");
        assert!(short.contains("--help shows every flag, grouped: scene, lights,"), "{cmd} -h names no groups");
        assert!(!short.contains("--cluster-slices"), "{cmd} -h lists a flag --help keeps");
    }
    let top = stdout(&tiledlight(&["-h"]));
    for m in ["Forward+", "Tiled Deferred", "visibility buffer", "brute-force", "traced"] {
        assert!(top.lines().next().unwrap().contains(m), "the summary does not name {m}: {top}");
    }
}

/// The culling flags reach the renderer, each seen in what `render` reports of the frame
/// (not in the settings line it echoes): the AABB test and the spot-cone test list
/// strictly fewer (tile, light) pairs than planes alone, half-z reports per-half lists
/// and other pairs, and `--flat-cull` leaves the 64x64-cell level (its lists) out of the
/// frame with the same pairs. A flag parsed but never passed to the renderer fails here.
#[test]
fn culling_flags_change_the_frame() {
    let dir = scratch("cull-flags");
    let run = |extra: &[&str]| {
        let png = dir.join("c.png");
        let mut args =
            vec!["render", "--width", "160", "--height", "90", "--lights", "400", "--spot-lights", "200", "--out"];
        args.push(png.to_str().unwrap());
        args.extend_from_slice(extra);
        let text = stdout(&gpu_run(&args));
        let culling = text.lines().find(|l| l.starts_with("culling:")).unwrap_or_else(|| panic!("{text}")).to_owned();
        let pairs: u64 = culling
            .rsplit(';')
            .next()
            .and_then(|s| s.trim().strip_suffix(" tile-light pairs"))
            .map(|s| s.replace(',', "").parse().unwrap())
            .unwrap_or_else(|| panic!("no pair count in {culling:?}"));
        (text, culling, pairs)
    };
    let (text, _, planes) = run(&[]);
    // Forward+ times both levels as one pass: the cell lists in the memory report show
    // the first level exists.
    assert!(text.contains("cull.cell_lists"), "two-level culling by default: {text}");
    assert!(planes > 0, "lights reach the tiles");
    let (_, _, aabb) = run(&["--aabb"]);
    assert!(aabb < planes, "--aabb: {aabb} pairs, planes alone {planes}");
    let (_, _, cone) = run(&["--spot-cone"]);
    assert!(cone < planes, "--spot-cone: {cone} pairs, planes alone {planes}");
    let (_, culling, half) = run(&["--half-z"]);
    assert!(culling.contains("per list (half-z)") && half != planes, "--half-z: {culling}");
    let (text, _, flat) = run(&["--flat-cull"]);
    assert!(!text.contains("cull.cell_lists"), "--flat-cull still builds the cell lists: {text}");
    assert_eq!(flat, planes, "--flat-cull finds the same lists");
}

/// Two shadow-casting spots with VPLs and a cap of 10: 32x32 reflective shadow maps and
/// 2x2 blocks give up to 512 candidates, so the cap refuses some (the lit floor and walls
/// fill most blocks).
const VPLS_CAPPED: [&str; 7] = ["--spot-lights", "2", "--shadow-spot-lights", "2", "--vpl", "--vpl-cap", "10"];

/// `bench --vpl` reports the VPLs the last frame made and those the cap refused (a line, a
/// `warning:` and JSON fields); without `--vpl` the fields are null.
#[test]
fn bench_reports_vpls_made_and_refused() {
    let dir = scratch("bench-vpl");
    let json = dir.join("v.json");
    let mut args = VPLS_CAPPED.to_vec();
    args.extend(["--frames", "2", "--warmup", "1", "--json", json.to_str().unwrap()]);
    let out = gpu_run(&with_tiny("bench", &args));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("valid JSON");
    assert_eq!(v["vpls_kept"], 10, "{v}");
    let refused = v["vpls_refused"].as_u64().expect("a refused count");
    assert!(refused > 0, "{v}");
    assert!(
        stdout(&out).contains(&format!("VPLs: 10 made in the last frame, {refused} refused by the cap")),
        "{}",
        stdout(&out)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("refused {refused} of {} VPLs", 10 + refused)), "{err}");

    let plain = dir.join("p.json");
    gpu_run(&with_tiny("bench", &["--frames", "2", "--warmup", "1", "--json", plain.to_str().unwrap()]));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&plain).unwrap()).expect("valid JSON");
    assert!(v["vpls_kept"].is_null() && v["vpls_refused"].is_null(), "{v}");
}

/// VPL lists past the VPL grid's fixed budget (1,024 indices a tile: 12,288 for the 12
/// tiles of 64x36) are dropped VPLs, reported as dropped lights are: bench's JSON
/// `vpl_dropped_lights`/`vpl_dropped_lists`, the times marked as of incomplete frames and a
/// `warning:` naming the VPL lists and what lowers them; `render` warns of its image too.
/// Eight spots' 128x128 RSMs at block 1 make about 47,000 VPLs in the courtyard, over
/// 60,000 (tile, VPL) pairs in those 12 tiles (two spots' 64x64 RSMs stayed within it). A
/// cap of 10 (at most 10 a tile) drops nothing and says nothing of VPL lists.
#[test]
fn overflowing_vpl_lists_are_reported_as_dropped() {
    let dir = scratch("vpl-dropped");
    let dense =
        ["--spot-lights", "8", "--shadow-spot-lights", "8", "--vpl", "--vpl-rsm-size", "128", "--vpl-block", "1"];
    let json = dir.join("d.json");
    let mut args = dense.to_vec();
    args.extend(["--frames", "3", "--warmup", "1", "--json", json.to_str().unwrap()]);
    let out = gpu_run(&with_tiny("bench", &args));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("valid JSON");
    let dropped = v["vpl_dropped_lights"].as_u64().expect("a VPL drop count");
    assert!(dropped > 0 && v["vpl_dropped_lists"].as_u64().unwrap() > 0, "{v}");
    assert!(v["dropped_frames"].as_u64().unwrap() > 0, "{v}");
    assert_eq!(v["dropped_lights"], 0, "the lights' grid grows and lost nothing: {v}");
    let err = String::from_utf8_lossy(&out.stderr);
    let w = err.lines().find(|l| l.starts_with("warning:") && l.contains("the VPL lists: "));
    let w = w.unwrap_or_else(|| panic!("no VPL-list warning:\n{err}"));
    assert!(w.contains("(list, VPL) pairs") && w.contains("at most 1,024 VPLs a tile"), "{w}");
    assert!(w.contains("a larger --vpl-block"), "{w}");
    assert!(stdout(&out).contains("INCOMPLETE"), "{}", stdout(&out));

    let png = dir.join("d.png");
    let mut args = dense.to_vec();
    args.extend(["--out", png.to_str().unwrap()]);
    let out = gpu_run(&with_tiny("render", &args));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.lines().any(|l| l.starts_with("warning: the image") && l.contains("the VPL lists: ")), "{err}");

    let json = dir.join("c.json");
    let mut args = VPLS_CAPPED.to_vec();
    args.extend(["--frames", "2", "--warmup", "1", "--json", json.to_str().unwrap()]);
    let out = gpu_run(&with_tiny("bench", &args));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("valid JSON");
    assert_eq!((v["vpl_dropped_lights"].as_u64(), v["vpl_dropped_lists"].as_u64()), (Some(0), Some(0)), "{v}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("VPL lists") && !err.contains("DROPPED"), "{err}");
}

/// A sweep point whose VPLs the cap refused gets a `warning:` line naming them, as a point
/// that dropped lights does.
#[test]
fn sweep_warns_of_refused_vpls() {
    let dir = scratch("sweep-vpl");
    let csv_path = dir.join("s.csv");
    let mut args = VPLS_CAPPED.to_vec();
    args.extend(["--axis", "lights=2", "--frames", "2", "--warmup", "0", "--out", csv_path.to_str().unwrap()]);
    let out = gpu_run(&with_tiny("sweep", &args));
    let err = String::from_utf8_lossy(&out.stderr);
    let line = err.lines().find(|l| l.starts_with("warning:") && l.contains("the VPL cap (--vpl-cap 10) refused "));
    assert!(line.is_some(), "no refused-VPL warning:\n{err}");
    // And the CSV's vpls_refused column holds the count on every row of the point.
    let mut r = csv::Reader::from_path(&csv_path).unwrap();
    let col = r.headers().unwrap().iter().position(|h| h == "vpls_refused").expect("a vpls_refused column");
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert!(!rows.is_empty() && rows.iter().all(|row| row[col].parse::<u32>().is_ok_and(|n| n > 0)), "{rows:?}");
}

#[test]
fn export_writes_gltf_and_glb_with_the_lights_and_camera() {
    let dir = scratch("export");
    let gltf = dir.join("sub/court.gltf");
    // No GPU work: the scene, lights and camera are built on the CPU.
    let out =
        tiledlight(&with_tiny("export", &["--spot-lights", "3", "--exposure", "2", "--out", gltf.to_str().unwrap()]));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = stdout(&out);
    assert!(text.contains("16 point + 3 spot") && text.contains("wrote"), "{text}");
    let root: Value = serde_json::from_slice(&std::fs::read(&gltf).unwrap()).unwrap();
    assert_eq!(root["buffers"][0]["uri"], "court.bin");
    assert!(dir.join("sub/court.bin").is_file());
    let lights = root["extensions"]["KHR_lights_punctual"]["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 19);
    assert_eq!(lights.iter().filter(|l| l["type"] == "spot").count(), 3);
    assert!(lights.iter().all(|l| l["range"].as_f64().unwrap() > 0.0));
    let cam = root["nodes"].as_array().unwrap().iter().find(|n| n.get("camera").is_some()).unwrap();
    assert_eq!(cam["extras"]["tiledlight"]["width"], 64);
    assert_eq!(cam["extras"]["tiledlight"]["exposure"], 2.0);
    assert_eq!(root["cameras"][0]["perspective"]["aspectRatio"].as_f64().unwrap() as f32, 64.0 / 36.0);

    let glb = dir.join("court.glb");
    let out = tiledlight(&with_tiny("export", &["--out", glb.to_str().unwrap()]));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout(&out).contains("automatic"), "no fixed exposure given: {}", stdout(&out));
    let bytes = std::fs::read(&glb).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
}

#[test]
fn export_bad_input_gives_one_clear_error_line() {
    let dir = scratch("export-bad");
    let line = fails(&["export", "--out", dir.join("a.obj").to_str().unwrap()]);
    assert!(line.contains("only .gltf and .glb"), "{line}");
    // A folder that cannot be made: its parent is a file.
    std::fs::write(dir.join("file"), b"x").unwrap();
    let line = fails(&with_tiny("export", &["--out", dir.join("file/a.gltf").to_str().unwrap()]));
    assert!(line.contains("file/a.gltf") || line.contains("creating directory"), "{line}");
    let line = fails(&with_tiny("export", &["--exposure", "NaN", "--out", dir.join("a.gltf").to_str().unwrap()]));
    assert!(line.contains("--exposure"), "{line}");
    assert!(!dir.join("a.gltf").exists(), "nothing written on bad input");
}

/// A peer benchmark result folder as `scripts/peer-bench.sh` (`PHASE=final`) leaves it,
/// small: two scenes, three repeats of each configuration (the median is the middle one),
/// every run's JSON with the keys the report reads, the first repeat's 32x18 frames, and
/// the script's clocks.csv.
fn write_peer_results(dir: &Path, broken: Option<&str>) {
    let bevy = |method: &str, ms: f64, timed: f64, measured: u32| {
        serde_json::json!({
            "renderer": "bevy", "method": method,
            "adapter": "Test GPU", "bevy_version": "0.19.1", "frames": 50, "gpu_frames_measured": measured,
            "gpu_frame_ms_median": timed, "frame_gpu_first_to_last": {"median_ms": ms},
            "prepare_cpu": {"median_ms": 4.5}, "cpu_frame_ms_median": ms + 6.0,
            "passes": {"clustering": {"median_ms": 0.5, "frames": measured}, "main_opaque_pass_3d": {"median_ms": timed - 0.5, "frames": measured}},
        })
    };
    let tl = |method: &str, early_outs: bool, ms: f64, dropped: u32| {
        serde_json::json!({
            "config": {"adapter": "Test GPU", "resolution": "32x18", "commit": "abc123", "method": method, "early_outs": early_outs},
            "total_gpu_median_ms": ms - 0.01, "frame_gpu_first_to_last": {"median_ms": ms}, "dropped_frames": dropped,
            "cpu_frame": {"median_ms": ms + 1.0},
            "passes": [{"pass": "deferred.shade", "median_ms": ms / 4.0}, {"pass": "tonemap", "median_ms": 0.02}],
        })
    };
    // (configuration, ms on court-1000, ms on court-10000); Bevy's deferred frame holds an
    // untimed pass: its timed spans are a quarter of its frame.
    let runs = [
        ("bevy-fwd-default", 40.0, 200.0),
        ("bevy-fwd-tuned", 18.0, 50.0),
        ("bevy-def-tuned", 12.0, 30.0),
        ("tl-fp", 9.0, 20.0),
        ("tl-fp-2.5d", 9.5, 16.0),
        ("tl-td", 2.0, 2.5),
        ("tl-fp-noeo", 13.5, 40.0),
        ("tl-td-noeo", 2.2, 3.0),
    ];
    // Frames: a gradient; Bevy's is the same gradient darker (another tone curve), and
    // on court-10000 tiledlight's deferred frame has a bright square the others lack.
    let frame = |gain: f32, square: bool| {
        image::RgbImage::from_fn(32, 18, |x, y| {
            let v = ((x * 8 + y * 4) as f32 * gain) as u8;
            if square && (8..16).contains(&x) && (4..12).contains(&y) {
                image::Rgb([255, 255, 255])
            } else {
                image::Rgb([v, v / 2, 255 - v])
            }
        })
    };
    for (scene, col) in [("court-1000", 1), ("court-10000", 2)] {
        for (config, a, b) in runs {
            let base = if col == 1 { a } else { b };
            for (k, scale) in [(1, 1.0), (2, 1.02), (3, 0.97)] {
                let ms = base * scale;
                let json = if config.starts_with("bevy") {
                    let deferred = config == "bevy-def-tuned";
                    let (method, timed) = if deferred { ("deferred", ms / 4.0) } else { ("forward", ms - 0.5) };
                    // Bevy's tuned forward run on court-10000, repeat 2, measured 40 of 50 frames.
                    bevy(method, ms, timed, if config == "bevy-fwd-tuned" && col == 2 && k == 2 { 40 } else { 50 })
                } else {
                    let method = if config.starts_with("tl-td") { "deferred" } else { "forward-plus" };
                    // tiledlight's Forward+ on court-10000, repeat 1, dropped lights in 3 frames.
                    tl(
                        method,
                        !config.ends_with("noeo"),
                        ms,
                        if config == "tl-fp" && col == 2 && k == 1 { 3 } else { 0 },
                    )
                };
                let name = format!("{scene}.{config}.r{k}");
                let text = if broken == Some(name.as_str()) { "{ not json".to_string() } else { json.to_string() };
                std::fs::write(dir.join(format!("{name}.json")), text).unwrap();
            }
            if !config.ends_with("noeo") {
                let img = if config.starts_with("bevy") {
                    frame(0.7, false)
                } else {
                    frame(1.0, col == 2 && config == "tl-td")
                };
                img.save(dir.join(format!("{scene}.{config}.png"))).unwrap();
            }
        }
    }
    std::fs::write(
        dir.join("clocks.csv"),
        "run,when,sm_mhz,mem_mhz,temp_c,power_w\nx,before,1500,3201,38,80\nx,after,1980,3201,40,200\ny,after,1200,3201,39,90\n",
    )
    .unwrap();
}

#[test]
fn peer_report_tabulates_ratios_charts_and_compares_frames() {
    let dir = scratch("peer-report");
    write_peer_results(&dir, None);
    // The script's summary: a Bevy run whose clusters grew while measured, a failed image.
    std::fs::write(
        dir.join("summary.txt"),
        "court-1000: --lights 1000, exposure 1\n  warning: court-1000.bevy-fwd-default.r1: Bevy resized its cluster \
         lists inside the measured frames (some missed lights)\n   FAILED (court-10000.tl-td.r3-png): exit 124\n   \
         FAILED (court-10000.export): exit 1\n",
    )
    .unwrap();
    let out_dir = dir.join("report");
    let out = tiledlight(&["peer-report", dir.to_str().unwrap(), "--out", out_dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}{}", stdout(&out), String::from_utf8_lossy(&out.stderr));
    let md = std::fs::read_to_string(out_dir.join("peer-report.md")).expect("the report");
    assert_eq!(stdout(&out).lines().next(), md.lines().next(), "the report is also printed");
    let rows = |scene: &str| -> Vec<&str> { md.lines().filter(|l| l.starts_with(&format!("| {scene} |"))).collect() };
    // Frame times: the median of the three repeats with their spread.
    let times = rows("court-1000")[0];
    assert!(times.contains("| 18.00 [17.46 - 18.36] |"), "{times}");
    // Ratios on court-1000: Bevy forward best 18 / Forward+ best 9 = 2.00x; Bevy deferred
    // 12 / Tiled Deferred 2 = 6.00x; Forward+ without / with early-outs 13.5 / 9 = 1.50x;
    // Bevy forward / Forward+ without them 18 / 13.5 = 1.33x; Tiled Deferred without / with
    // 2.2 / 2 = 1.10x; Bevy's default grid / tuned 40 / 18 = 2.22x. court-10000: 50 / 16 =
    // 3.12x (3.125), 30 / 2.5 = 12.00x, 40 / 20 = 2.00x, 50 / 40 = 1.25x, 3 / 2.5 = 1.20x,
    // 200 / 50 = 4.00x.
    assert_eq!(rows("court-1000")[1], "| court-1000 | 2.00x | 6.00x | 1.50x | 1.33x | 1.10x | 2.22x |", "{md}");
    assert_eq!(rows("court-10000")[1], "| court-10000 | 3.12x | 12.00x | 2.00x | 1.25x | 1.20x | 4.00x |", "{md}");
    // The deferred breakdown: Bevy's frame 12, its timed spans 3, untimed 9; tiledlight's
    // deferred.shade 2 / 4.
    assert_eq!(rows("court-1000")[2], "| court-1000 | Bevy deferred, tuned grid | 12.00 | 3.000 | 9.000 | 0.500 |");
    // Bevy on the CPU.
    assert_eq!(rows("court-1000")[3], "| court-1000 | Bevy forward, default grid | 40.00 | 4.500 | 46.00 |");
    // The starred runs and their footnotes.
    let times10 = rows("court-10000")[0];
    assert!(times10.contains("50.00 [48.50 - 51.00] *"), "{times10}");
    assert!(md.contains("Bevy forward, tuned grid on court-10000: repeat 2: GPU times of 40 of 50 frames"), "{md}");
    assert!(md.contains("tiledlight Forward+ on court-10000: repeat 1: 3 frames dropped lights"), "{md}");
    assert!(md.contains("repeat 1: Bevy resized its cluster lists inside the measured frames"), "{md}");
    assert!(md.contains("repeat 3: failed: exit 124 (summary.txt)"), "{md}");
    // The clocks.
    assert!(md.contains("SM clock 1200 - 1980 MHz (1 of 2 readings after a run below the highest)"), "{md}");
    for needle in ["adapter: Test GPU", "tiledlight commit: abc123", "Bevy: 0.19.1", "main_opaque_pass_3d 39.00"] {
        assert!(md.contains(needle), "no {needle:?} in:\n{md}");
    }
    // Mean luma: Bevy's test frames are the same gradient at 0.7 of the values.
    let luma = md
        .lines()
        .skip_while(|l| !l.starts_with("Mean luma"))
        .find(|l| l.starts_with("| court-1000 |"))
        .expect("a luma row");
    let cells: Vec<f64> =
        luma.split('|').map(str::trim).skip(2).filter(|c| !c.is_empty()).map(|c| c.parse().unwrap()).collect();
    assert_eq!(cells.len(), 6, "{luma}");
    assert!(cells[0] < 0.8 * cells[3] && cells[0] > 0.6 * cells[3], "{luma}");
    // The chart.
    let chart = out_dir.join("peer-frame-time.png");
    assert_eq!(image::image_dimensions(&chart).expect("a chart PNG"), (1280, 800));
    // FLIP against tiledlight's Forward+: Bevy's frame is darker, less so once the tone
    // curves are matched; the square only tiledlight's deferred frame has on court-10000
    // stays after matching.
    let flip = |scene: &str, what: &str| -> (f64, f64) {
        let l = md
            .lines()
            .find(|l| l.starts_with(&format!("| {scene} | tiledlight Forward+ vs {what} |")))
            .unwrap_or_else(|| panic!("no FLIP row {scene} {what}:\n{md}"));
        let cells: Vec<&str> = l.split('|').map(str::trim).collect();
        (cells[3].parse().unwrap(), cells[5].parse().unwrap())
    };
    for bevy in ["Bevy forward, default grid", "Bevy forward, tuned grid", "Bevy deferred, tuned grid"] {
        let (raw, matched) = flip("court-1000", bevy);
        assert!(raw > 0.02 && matched < raw, "{bevy}: raw {raw}, tone-matched {matched}");
    }
    assert_eq!(flip("court-1000", "tiledlight Tiled Deferred"), (0.0, 0.0));
    let (_, square) = flip("court-10000", "tiledlight Tiled Deferred");
    assert!(square > 0.01, "the square's error {square}");
    let heat = out_dir.join("flip-court-1000-tl-fp-vs-bevy-fwd-tuned.png");
    assert_eq!(image::image_dimensions(&heat).expect("a heat map"), (16, 9), "heat maps at half size");
}

#[test]
fn peer_report_bad_input_gives_one_clear_error_line() {
    let dir = scratch("peer-report-bad");
    let line = fails(&["peer-report", dir.join("missing").to_str().unwrap()]);
    assert!(line.contains("missing") && line.contains("no such folder"), "{line}");
    let line = fails(&["peer-report", dir.to_str().unwrap()]);
    assert!(line.contains("no peer benchmark results"), "{line}");
    write_peer_results(&dir, Some("court-10000.bevy-def-tuned.r2"));
    let line = fails(&["peer-report", dir.to_str().unwrap()]);
    assert!(line.contains("court-10000.bevy-def-tuned.r2.json") && line.contains("not JSON"), "{line}");
    // A run of a method the report does not compare, and runs of one configuration that
    // disagree on what they are.
    write_peer_results(&dir, None);
    let json = |method: &str| {
        serde_json::json!({"config": {"method": method}, "frame_gpu_first_to_last": {"median_ms": 2.0},
            "total_gpu_median_ms": 2.0, "passes": []})
        .to_string()
    };
    std::fs::write(dir.join("court-1000.tl-td.r2.json"), json("visibility")).unwrap();
    let line = fails(&["peer-report", dir.to_str().unwrap()]);
    assert!(line.contains("court-1000.tl-td.r2.json") && line.contains("\"visibility\""), "{line}");
    std::fs::write(dir.join("court-1000.tl-td.r2.json"), json("forward-plus")).unwrap();
    let line = fails(&["peer-report", dir.to_str().unwrap()]);
    assert!(line.contains("court-1000.tl-td.r2.json") && line.contains("the other runs of tl-td"), "{line}");
    // A JSON from before the frame timer.
    write_peer_results(&dir, None);
    std::fs::write(
        dir.join("court-1000.tl-td.r2.json"),
        r#"{"config": {"method": "deferred"}, "total_gpu_median_ms": 2.0, "passes": []}"#,
    )
    .unwrap();
    let line = fails(&["peer-report", dir.to_str().unwrap()]);
    assert!(line.contains("court-1000.tl-td.r2.json") && line.contains("frame_gpu_first_to_last"), "{line}");
    // Frames of two sizes.
    write_peer_results(&dir, None);
    image::RgbImage::new(8, 8).save(dir.join("court-1000.bevy-fwd-tuned.png")).unwrap();
    let line = fails(&["peer-report", dir.to_str().unwrap()]);
    assert!(line.contains("court-1000.bevy-fwd-tuned.png") && line.contains("one size"), "{line}");
}
