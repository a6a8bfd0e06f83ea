//! Bounded mutation test of the glTF loader: a few thousand small glTF and GLB files,
//! mutated from three valid ones by a seeded RNG (hostile numbers in any JSON field, huge
//! counts, bad offsets and strides, huge byteLength, cyclic node graphs, transforms out of
//! range, hostile URIs, corrupted index and image bytes, byte flips, truncation, broken
//! GLB headers), each loaded through `load_gltf_bytes`. Asserted for every file:
//!
//! - no panic (`catch_unwind`);
//! - no hang: each load finishes within [`TIME_LIMIT`] (it runs on a worker thread);
//! - no allocation beyond [`PEAK_LIMIT`] above what was allocated before the load (the
//!   counting global allocator of this test binary tracks the peak), with the loader's
//!   memory limits set to [`LIMITS`]; that bound follows from `LoadLimits`' documented one
//!   (twice the scene budget plus twice the texture budget plus the small input).
//!
//! The outcome mix (loaded, failed) is asserted too, so the mutations keep reaching past
//! the JSON parser. This binary holds one test so that no other test allocates while a
//! peak is measured.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use peak_alloc::PeakAlloc;
use serde_json::{json, Value};
use tiledlight_scene::{load_gltf_bytes, LoadLimits, LoadOptions};

// Counts live heap bytes and their peak (a wrapper over the system allocator; the
// workspace forbids `unsafe`, so the wrapper comes from the peak_alloc crate).
#[global_allocator]
static ALLOCATOR: PeakAlloc = PeakAlloc;

/// Mutated files loaded.
const CASES: usize = 3000;
/// Longest a single load may take. Loads of these files take well under a millisecond;
/// 5 s leaves room for a loaded 2-core machine and still catches an endless loop or read.
const TIME_LIMIT: Duration = Duration::from_secs(5);
/// The loader's memory limits in this test: small, so that a file asking for more is
/// refused long before the bound below.
const LIMITS: LoadLimits = LoadLimits { image_bytes: 1 << 20, texture_bytes: 4 << 20, scene_bytes: 8 << 20 };
/// Most bytes a load may allocate beyond what was live before it: 2 x 8 MiB (scene) + 2 x
/// 4 MiB (texture) = 24 MiB by `LoadLimits`' bound, plus the parsed JSON and buffers of
/// these < 64 KiB files; 64 MiB leaves headroom for allocator rounding and the decoders'
/// own tables without hiding a real breach (an unbounded load asks for gigabytes).
const PEAK_LIMIT: usize = 64 << 20;
/// The RNG's seed; `TILEDLIGHT_MUTATION_SEED` (a number) explores others, and
/// `TILEDLIGHT_MUTATION_CASES` runs more or fewer files.
const SEED: u64 = 0x7469_6c65_646c_6967;

fn env_number(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// xorshift64*: small, seeded, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n =
            (u32::from(c[0]) << 16) | (u32::from(*c.get(1).unwrap_or(&0)) << 8) | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            out.push(if k <= c.len() { A[((n >> (18 - 6 * k)) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

fn png_bytes() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(4, 4, |x, y| image::Rgba([(x * 60) as u8, (y * 60) as u8, 128, 255]));
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    out
}

/// A valid scene using most of what the loader reads: indexed triangles, a non-indexed
/// strip without normals, a sparse accessor, a hierarchy with TRS and matrix transforms,
/// point and spot lights, a camera, a textured and an alpha-masked material. The image
/// is in the binary buffer when `image_in_buffer`, else a data URI.
fn base_document(image_in_buffer: bool) -> (Value, Vec<u8>) {
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8]| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let quad = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let pos = view(&mut bin, &f32s(&quad));
    let nrm = view(&mut bin, &f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    let uv = view(&mut bin, &f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0]));
    let idx = view(&mut bin, &[0u16, 1, 2, 2, 1, 3].iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<u8>>());
    let sp_idx = view(&mut bin, &[3u8]);
    let sp_val = view(&mut bin, &f32s(&[1.0, 2.0, 0.0]));
    let img = png_bytes();
    let mut image = json!({"uri": format!("data:image/png;base64,{}", base64(&img))});
    if image_in_buffer {
        let v = view(&mut bin, &img);
        image = json!({"bufferView": v, "mimeType": "image/png"});
    }
    let mm = json!({"min": [0.0, 0.0, 0.0], "max": [1.0, 2.0, 0.0]});
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 10.0},
            {"type": "spot", "intensity": 4.0, "range": 5.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}
        ]}},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": pos, "componentType": 5126, "count": 4, "type": "VEC3", "min": mm["min"], "max": [1.0, 1.0, 0.0]},
            {"bufferView": nrm, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": uv, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": idx, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": pos, "componentType": 5126, "count": 4, "type": "VEC3", "min": mm["min"], "max": mm["max"],
             "sparse": {"count": 1, "indices": {"bufferView": sp_idx, "componentType": 5121}, "values": {"bufferView": sp_val}}}
        ],
        "images": [image],
        "samplers": [{}],
        "textures": [{"source": 0, "sampler": 0}],
        "materials": [
            {"name": "painted", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}},
            {"name": "cutout", "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": true}
        ],
        "meshes": [{"name": "quad", "primitives": [
            {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0},
            {"attributes": {"POSITION": 4}, "mode": 5, "material": 1}
        ]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100.0}}],
        "nodes": [
            {"name": "root", "children": [1, 2, 3], "scale": [2.0, 2.0, 2.0]},
            {"name": "mesh", "mesh": 0, "translation": [1.0, 0.0, 0.0], "rotation": [0.0, 0.0, 0.0, 1.0], "children": [4]},
            {"name": "lamp", "translation": [0.0, 3.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "cam", "camera": 0, "translation": [0.0, 1.0, 6.0]},
            {"name": "spot", "matrix": [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 4.0, 0.0, 1.0],
             "mesh": 0, "extensions": {"KHR_lights_punctual": {"light": 1}}}
        ],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    (doc, bin)
}

fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut j = json.to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + j.len() + 8 + b.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

const HOSTILE_NUMBERS: &[f64] = &[
    0.0,
    1.0,
    -1.0,
    3.0,
    255.0,
    65535.0,
    2147483647.0,
    4294967295.0,
    4294967296.0,
    9007199254740993.0,
    1e18,
    1e30,
    1e38,
    1e39,
    -1e39,
    0.5,
    1e-45,
    5126.0,
    5121.0,
    5125.0,
];

const HOSTILE_URIS: &[&str] = &[
    "/dev/zero",
    "file:///dev/urandom",
    "../outside.bin",
    "/nonexistent/x.bin",
    "sub/../model.bin",
    "model.bin",
    "%zz",
    "%ff%fe",
    "http://example.com/x.bin",
    "data:application/octet-stream;base64,!!!!",
    "data:image/png;base64,iVBORw0KGgo=",
    "data:text/plain,hello",
    "",
    ".",
    "image.png",
];

fn hostile_value(rng: &mut Rng) -> Value {
    match rng.below(10) {
        0..=5 => json!(*rng.pick(HOSTILE_NUMBERS)),
        6 => json!(*rng.pick(HOSTILE_URIS)),
        7 => Value::Null,
        8 => json!([]),
        _ => json!({}),
    }
}

/// Paths (object keys and array indices) to every value in `v`.
fn all_paths(v: &Value, prefix: &mut Vec<PathStep>, out: &mut Vec<Vec<PathStep>>) {
    out.push(prefix.clone());
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                prefix.push(PathStep::Key(k.clone()));
                all_paths(c, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                prefix.push(PathStep::Index(i));
                all_paths(c, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

#[derive(Clone, Debug)]
enum PathStep {
    Key(String),
    Index(usize),
}

/// The value at `path`, if the (possibly already mutated) document still has it.
fn slot<'v>(v: &'v mut Value, path: &[PathStep]) -> Option<&'v mut Value> {
    path.iter().try_fold(v, |v, s| match s {
        PathStep::Key(k) => v.get_mut(k.as_str()),
        PathStep::Index(i) => v.get_mut(*i),
    })
}

/// Sets `key` of the object at `path`, if there is one there. Returns what it did.
fn set(doc: &mut Value, path: &[PathStep], key: &str, value: Value) -> String {
    let what = format!("{path:?}.{key} = {value}");
    match slot(doc, path).and_then(Value::as_object_mut) {
        Some(m) => {
            m.insert(key.to_owned(), value);
            what
        }
        None => format!("({what}: no object there)"),
    }
}

fn key(k: &str) -> PathStep {
    PathStep::Key(k.to_owned())
}

/// A random element index of the top-level array `name`.
fn random_element(rng: &mut Rng, doc: &Value, name: &str) -> Option<usize> {
    let n = doc.get(name).and_then(Value::as_array).map_or(0, Vec::len);
    (n > 0).then(|| rng.below(n))
}

/// One structural mutation of the JSON; returns what it did.
fn mutate_json(rng: &mut Rng, doc: &mut Value) -> String {
    let mut paths = Vec::new();
    all_paths(doc, &mut Vec::new(), &mut paths);
    let any_path = paths[1 + rng.below(paths.len() - 1)].clone();
    match rng.below(10) {
        0 | 1 => {
            let value = hostile_value(rng);
            let what = format!("{any_path:?} = {value}");
            if let Some(v) = slot(doc, &any_path) {
                *v = value;
            }
            what
        }
        2 => {
            let Some(n) = random_element(rng, doc, "nodes") else { return "no nodes".into() };
            let count = doc["nodes"].as_array().map_or(0, Vec::len);
            let children: Vec<usize> = (0..1 + rng.below(3)).map(|_| rng.below(count + 1)).collect();
            set(doc, &[key("nodes"), PathStep::Index(n)], "children", json!(children))
        }
        3 => {
            let Some(n) = random_element(rng, doc, "nodes") else { return "no nodes".into() };
            let big = *rng.pick(&[1e19, 1e30, 1e38, 1e39, -1e39, 3.4e38]);
            let field = *rng.pick(&["translation", "scale", "rotation"]);
            let node = [key("nodes"), PathStep::Index(n)];
            if let Some(m) = slot(doc, &node).and_then(Value::as_object_mut) {
                m.remove("matrix");
            }
            let value = if field == "rotation" { json!([big, 0.0, 0.0, 1.0]) } else { json!([big, big, 1.0]) };
            set(doc, &node, field, value)
        }
        4 => {
            let Some(a) = random_element(rng, doc, "accessors") else { return "no accessors".into() };
            let count =
                *rng.pick(&[0u64, 1, 5, 7, 1 << 20, 1 << 24, (1 << 24) + 1, 1 << 31, u64::from(u32::MAX), 1 << 40]);
            set(doc, &[key("accessors"), PathStep::Index(a)], "count", json!(count))
        }
        5 => {
            let Some(v) = random_element(rng, doc, "bufferViews") else { return "no views".into() };
            let field = *rng.pick(&["byteOffset", "byteLength", "byteStride"]);
            let value = *rng.pick(&[0u64, 1, 3, 4, 6, 252, 256, 1 << 20, u64::from(u32::MAX), 1 << 40]);
            set(doc, &[key("bufferViews"), PathStep::Index(v)], field, json!(value))
        }
        6 => {
            let value = *rng.pick(&[0u64, 1, 100, 1 << 20, 1 << 32, 1 << 40, 1 << 53]);
            set(doc, &[key("buffers"), PathStep::Index(0)], "byteLength", json!(value))
        }
        7 => {
            let uri = *rng.pick(HOSTILE_URIS);
            if rng.below(2) == 0 {
                set(doc, &[key("buffers"), PathStep::Index(0)], "uri", json!(uri))
            } else {
                let what = format!("images[0] = {{uri: {uri}}}");
                if let Some(v) = slot(doc, &[key("images"), PathStep::Index(0)]) {
                    *v = json!({"uri": uri});
                }
                what
            }
        }
        8 => {
            // An accessor made of zeros and sparse values: only its count says how much.
            let Some(a) = random_element(rng, doc, "accessors") else { return "no accessors".into() };
            let count = *rng.pick(&[1u64 << 16, 1 << 19, 1 << 21, 1 << 23]);
            viewless(doc, a, count)
        }
        _ => {
            let (last, parent) = any_path.split_last().unwrap();
            match (slot(doc, parent), last) {
                (Some(Value::Object(m)), PathStep::Key(k)) => {
                    m.remove(k);
                }
                (Some(Value::Array(a)), PathStep::Index(i)) if *i < a.len() => {
                    a.remove(*i);
                }
                _ => {}
            }
            format!("removed {any_path:?}")
        }
    }
}

/// Makes accessor `a` view-less with `count` elements.
fn viewless(doc: &mut Value, a: usize, count: u64) -> String {
    let path = [key("accessors"), PathStep::Index(a)];
    if let Some(m) = slot(doc, &path).and_then(Value::as_object_mut) {
        m.remove("bufferView");
    }
    set(doc, &path, "count", json!(count))
}

/// One byte-level mutation of the serialized file.
fn mutate_bytes(rng: &mut Rng, bytes: &mut Vec<u8>) -> String {
    if bytes.is_empty() {
        return "empty".into();
    }
    match rng.below(4) {
        0 => {
            let n = 1 + rng.below(16);
            for _ in 0..n {
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
            format!("{n} bit flips")
        }
        1 => {
            let len = rng.below(bytes.len());
            bytes.truncate(len);
            format!("truncated to {len}")
        }
        2 => {
            // GLB header and chunk length fields, or any 4 bytes.
            let anywhere = rng.below(bytes.len());
            let i = *rng.pick(&[8usize, 12, 16, anywhere]);
            let v = *rng.pick(&[0u32, 1, 0x7fff_ffff, u32::MAX, bytes.len() as u32 + 4]);
            if i + 4 <= bytes.len() {
                bytes[i..i + 4].copy_from_slice(&v.to_le_bytes());
            }
            format!("u32 at {i} = {v}")
        }
        _ => {
            let i = rng.below(bytes.len());
            let junk: Vec<u8> = (0..1 + rng.below(8)).map(|_| rng.next() as u8).collect();
            bytes.splice(i..i, junk);
            format!("inserted bytes at {i}")
        }
    }
}

/// One file to load: its bytes, the path it is loaded as, and how it was made.
struct Case {
    bytes: Vec<u8>,
    path: PathBuf,
    allow_any_path: bool,
    what: String,
}

fn make_case(rng: &mut Rng, dir: &Path, k: usize) -> Case {
    let flavour = rng.below(3);
    let (mut doc, mut bin) = base_document(flavour == 1);
    let mut what = vec![["gltf+data", "glb", "gltf+file"][flavour].to_owned()];
    // Corrupt the binary data itself (indices, image, floats) now and then.
    if rng.below(4) == 0 {
        for _ in 0..1 + rng.below(8) {
            let i = rng.below(bin.len());
            let random = rng.next() as u8;
            bin[i] = *rng.pick(&[0xff, 0x00, 0x7f, 0x80, random]);
        }
        what.push("binary data corrupted".into());
    }
    for _ in 0..1 + rng.below(2) {
        what.push(mutate_json(rng, &mut doc));
    }
    let path;
    let mut bytes = match flavour {
        0 => {
            let buffer = [key("buffers"), PathStep::Index(0)];
            if slot(&mut doc, &buffer).and_then(|b| b.get("uri")).is_none() {
                set(&mut doc, &buffer, "uri", json!(format!("data:;base64,{}", base64(&bin))));
            }
            path = dir.join("model.gltf");
            serde_json::to_vec(&doc).unwrap()
        }
        1 => {
            path = dir.join("model.glb");
            glb(&serde_json::to_vec(&doc).unwrap(), &bin)
        }
        _ => {
            // The external buffer lives in its own folder per case (it may be corrupted).
            let sub = dir.join(format!("case{k}"));
            std::fs::create_dir_all(&sub).unwrap();
            std::fs::write(sub.join("model.bin"), &bin).unwrap();
            std::fs::write(sub.join("image.png"), png_bytes()).unwrap();
            let buffer = [key("buffers"), PathStep::Index(0)];
            if slot(&mut doc, &buffer).and_then(|b| b.get("uri")).is_none() {
                set(&mut doc, &buffer, "uri", json!("model.bin"));
            }
            path = sub.join("model.gltf");
            serde_json::to_vec(&doc).unwrap()
        }
    };
    if rng.below(5) == 0 {
        what.push(mutate_bytes(rng, &mut bytes));
    }
    Case { bytes, path, allow_any_path: rng.below(4) == 0, what: what.join("; ") }
}

#[test]
fn mutated_gltf_files_neither_panic_hang_nor_allocate_without_bound() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("outside.bin"), [0u8; 64]).unwrap();
    let models = dir.path().join("models");
    std::fs::create_dir_all(&models).unwrap();

    // The unmutated bases load, warning-free: the mutations start from valid files.
    let options = |allow_any_path| LoadOptions { allow_any_path, limits: LIMITS, ..LoadOptions::new(0.01) };
    for (flavour, (doc, bin)) in [base_document(false), base_document(true)].into_iter().enumerate() {
        let mut doc = doc;
        let bytes = if flavour == 0 {
            doc["buffers"][0]["uri"] = json!(format!("data:;base64,{}", base64(&bin)));
            serde_json::to_vec(&doc).unwrap()
        } else {
            glb(&serde_json::to_vec(&doc).unwrap(), &bin)
        };
        let loaded = load_gltf_bytes(&bytes, &models.join("base.gltf"), &options(false)).unwrap();
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        assert_eq!((loaded.scene.instances.len(), loaded.scene.lights.len()), (4, 2));
        assert_eq!(loaded.scene.textures.len(), 1);
    }

    // The counter sees the loader's allocations: 2^19 zero positions (6 MiB) are read
    // before the strip they feed is refused for its size (flat normals would give it
    // 3 x 2^19 vertices, 56 MiB, beyond the 8 MiB scene limit).
    let (mut doc, bin) = base_document(false);
    viewless(&mut doc, 4, 1 << 19);
    doc["buffers"][0]["uri"] = json!(format!("data:;base64,{}", base64(&bin)));
    let bytes = serde_json::to_vec(&doc).unwrap();
    ALLOCATOR.reset_peak_usage();
    let baseline = ALLOCATOR.current_usage();
    let e = load_gltf_bytes(&bytes, &models.join("big.gltf"), &options(false)).err().unwrap().to_string();
    let peak = ALLOCATOR.peak_usage() - baseline;
    assert!(
        e.contains("the mesh takes 56622888 bytes (53 MiB) for 1572858 vertices and 1572858 indices, more than the"),
        "{e}"
    );
    assert!((6 << 20..PEAK_LIMIT).contains(&peak), "peak {peak}");

    let seed = env_number("TILEDLIGHT_MUTATION_SEED", SEED);
    let cases_n = env_number("TILEDLIGHT_MUTATION_CASES", CASES as u64) as usize;
    // xorshift needs a non-zero state.
    let mut rng = Rng(seed.max(1));
    let (to_worker, cases) = mpsc::channel::<Case>();
    let (to_main, results) = mpsc::channel::<(Result<Outcome, String>, usize)>();
    let worker = std::thread::spawn(move || {
        for case in cases {
            let opts = options(case.allow_any_path);
            ALLOCATOR.reset_peak_usage();
            let baseline = ALLOCATOR.current_usage();
            let outcome =
                catch_unwind(AssertUnwindSafe(|| outcome_of(load_gltf_bytes(&case.bytes, &case.path, &opts))));
            let peak = ALLOCATOR.peak_usage().saturating_sub(baseline);
            let outcome = outcome.map_err(|p| {
                p.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                    .unwrap_or_default()
            });
            if to_main.send((outcome, peak)).is_err() {
                return;
            }
        }
    });

    let (mut counts, mut max_peak, mut slowest) = ([0usize; 3], 0, Duration::ZERO);
    for k in 0..cases_n {
        let case = make_case(&mut rng, &models, k);
        let what =
            format!("seed {seed}, case {k} ({}, {} bytes): {}", case.path.display(), case.bytes.len(), case.what);
        let start = Instant::now();
        to_worker.send(case).unwrap();
        let (outcome, peak) = results
            .recv_timeout(TIME_LIMIT)
            .unwrap_or_else(|_| panic!("{what}: the load did not finish within {TIME_LIMIT:?} (a hang)"));
        slowest = slowest.max(start.elapsed());
        match outcome {
            Ok(o) => counts[o as usize] += 1,
            Err(p) => panic!("{what}: the loader panicked: {p}"),
        }
        assert!(peak < PEAK_LIMIT, "{what}: the load allocated {peak} bytes at its peak (bound {PEAK_LIMIT})");
        max_peak = max_peak.max(peak);
    }
    drop(to_worker);
    worker.join().unwrap();
    let [loaded, early, late] = counts;
    println!(
        "{cases_n} mutated files (seed {seed}): {loaded} loaded, {early} failed parsing or validation, {late} failed later in the loader; largest peak allocation {max_peak} bytes; slowest load {slowest:?}"
    );
    // The mutations must reach past the parser: a set that only broke the JSON would test
    // the gltf crate alone.
    assert!(loaded >= cases_n / 20, "only {loaded} of {cases_n} mutated files loaded");
    assert!(late >= cases_n / 10, "only {late} of {cases_n} mutated files failed past parsing and validation");
}

/// How a load ended.
#[derive(Clone, Copy, Debug)]
enum Outcome {
    Loaded,
    /// Failed in the gltf crate's parsing or validation.
    FailedEarly,
    /// Failed in tiledlight's own checks (files, accessors, transforms, limits...).
    FailedLate,
}

fn outcome_of<T>(r: Result<T, tiledlight_scene::SceneError>) -> Outcome {
    match r {
        Ok(_) => Outcome::Loaded,
        Err(e) => {
            let m = e.to_string();
            if m.contains("malformed glTF JSON") || m.contains("malformed GLB") || m.contains("does not validate") {
                Outcome::FailedEarly
            } else {
                Outcome::FailedLate
            }
        }
    }
}
