//! tiledlight-gltf-writer: writing glTF 2.0 files piece by piece. Used by the glTF loader's
//! tests (tiledlight-scene), the GPU material tests (tiledlight-tests, which also write the
//! README's normal-mapped asset with it) and `tiledlight export` (tiledlight-setup's
//! `export`, a scene with its lights and camera for other engines).
//!
//! A [`Buffer`] collects binary data, its buffer views and accessors; [`Buffer::document`]
//! makes the JSON root around them; [`save_gltf`] (external `.bin` beside the file) and
//! [`save_glb`] (binary container) write it to a path and return I/O errors; the test
//! helpers [`write_gltf`], [`write_embedded`] (base64 data URI) and [`write_glb`] write
//! `name.gltf`/`name.glb` into a folder and panic on I/O errors. [`png`] encodes an RGBA8
//! image (for an image data URI, [`png_data_uri`], or a buffer view). Nothing is checked:
//! tests write broken files on purpose, and callers validate what they export.
//!
//! Depends on serde_json and image only (no tiledlight crate, so any of them may use it
//! as a dev-dependency).

use std::fs;
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

/// glTF component type: signed byte.
pub const I8: u32 = 5120;
/// glTF component type: unsigned byte.
pub const U8: u32 = 5121;
/// glTF component type: signed short.
pub const I16: u32 = 5122;
/// glTF component type: unsigned short.
pub const U16: u32 = 5123;
/// glTF component type: unsigned int.
pub const U32: u32 = 5125;
/// glTF component type: float.
pub const F32: u32 = 5126;
/// glTF sampler filter: nearest.
pub const NEAREST: u32 = 9728;
/// glTF sampler filter: linear.
pub const LINEAR: u32 = 9729;
/// glTF sampler wrap: repeat.
pub const REPEAT: u32 = 10497;
/// glTF sampler wrap: clamp to edge.
pub const CLAMP: u32 = 33071;
/// glTF sampler wrap: mirrored repeat.
pub const MIRROR: u32 = 33648;

/// A binary buffer with its buffer views and accessors, built up piece by piece (each
/// piece starts 4-byte aligned).
#[derive(Debug, Default)]
pub struct Buffer {
    /// The buffer's bytes.
    pub data: Vec<u8>,
    /// Its buffer views (JSON).
    pub views: Vec<Value>,
    /// Its accessors (JSON).
    pub accessors: Vec<Value>,
}

impl Buffer {
    /// Appends `bytes` as a buffer view (no stride); returns its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        self.views.push(json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()}));
        self.data.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// An accessor over `bytes` in a view of its own with `byteStride` `stride`: `count`
    /// elements of `ty` ("SCALAR", "VEC2"...) of `component` (normalized when asked).
    pub fn accessor(
        &mut self,
        bytes: &[u8],
        (component, normalized): (u32, bool),
        (count, ty, stride): (usize, &str, usize),
    ) -> usize {
        let view = self.view(bytes);
        self.views[view]["byteStride"] = json!(stride);
        let mut a = json!({"bufferView": view, "componentType": component, "count": count, "type": ty});
        if normalized {
            a["normalized"] = json!(true);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// An accessor over `bytes` in a view of its own (no stride): `count` elements of `ty`
    /// of `component` (normalized when asked), with min/max when given (POSITION needs
    /// them).
    pub fn raw(
        &mut self,
        bytes: &[u8],
        (component, normalized): (u32, bool),
        count: usize,
        ty: &str,
        minmax: Option<(Value, Value)>,
    ) -> usize {
        let view = self.view(bytes);
        let mut acc = json!({"bufferView": view, "componentType": component, "count": count, "type": ty});
        if normalized {
            acc["normalized"] = json!(true);
        }
        if let Some((min, max)) = minmax {
            acc["min"] = min;
            acc["max"] = max;
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A float accessor of `ty` ("SCALAR", "VEC2", "VEC3", "VEC4") over `values`, tightly
    /// packed; VEC3 accessors carry min/max (POSITION needs them; NaNs are skipped).
    pub fn floats(&mut self, values: &[f32], ty: &str) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let comps = match ty {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 1,
        };
        let mut acc = json!({"bufferView": view, "componentType": F32, "count": values.len() / comps, "type": ty});
        if ty == "VEC3" {
            let (mut min, mut max) = ([f32::MAX; 3], [f32::MIN; 3]);
            for v in values.chunks_exact(3) {
                for c in 0..3 {
                    min[c] = min[c].min(v[c]);
                    max[c] = max[c].max(v[c]);
                }
            }
            acc["min"] = json!(min);
            acc["max"] = json!(max);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A u16 index accessor.
    pub fn indices_u16(&mut self, values: &[u16]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({"bufferView": view, "componentType": U16, "count": values.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    /// A u32 index accessor.
    pub fn indices_u32(&mut self, values: &[u32]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({"bufferView": view, "componentType": U32, "count": values.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    /// A unit right triangle in the XY plane facing +Z, with normals, UVs and indices: the
    /// primitive's JSON.
    pub fn triangle(&mut self) -> Value {
        let p = self.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
        let n = self.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
        let t = self.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC2");
        let i = self.indices_u16(&[0, 1, 2]);
        json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t}, "indices": i})
    }

    /// The document: asset, buffer (no URI yet), views and accessors, plus `extra`'s
    /// top-level keys.
    pub fn document(&self, extra: Value) -> Value {
        let mut root = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": self.data.len()}],
            "bufferViews": self.views,
            "accessors": self.accessors,
        });
        if let Value::Object(map) = extra {
            for (k, v) in map {
                root[k] = v;
            }
        }
        root
    }
}

/// Standard base64 with padding.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            out.push(if k <= chunk.len() { ALPHABET[((n >> (18 - 6 * k)) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

/// A `width` x `height` RGBA8 image encoded as PNG.
pub fn png(width: u32, height: u32, rgba: &[u8]) -> Vec<u8> {
    let img = image::RgbaImage::from_raw(width, height, rgba.to_vec()).expect("png: rgba is width * height * 4 bytes");
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).expect("encoding a PNG");
    bytes
}

/// A PNG image's data URI.
pub fn png_data_uri(png: &[u8]) -> String {
    format!("data:image/png;base64,{}", base64(png))
}

/// Writes `name.gltf` with its buffer in `name.bin` (pretty JSON). Panics on I/O errors
/// (test support; [`save_gltf`] returns them).
pub fn write_gltf(dir: &Path, name: &str, mut root: Value, bin: &[u8]) -> PathBuf {
    root["buffers"][0]["uri"] = json!(format!("{name}.bin"));
    fs::write(dir.join(format!("{name}.bin")), bin).unwrap();
    let path = dir.join(format!("{name}.gltf"));
    fs::write(&path, serde_json::to_vec_pretty(&root).unwrap()).unwrap();
    path
}

/// Writes `name.gltf` with its buffer embedded as a base64 data URI.
pub fn write_embedded(dir: &Path, name: &str, mut root: Value, bin: &[u8]) -> PathBuf {
    root["buffers"][0]["uri"] = json!(format!("data:application/octet-stream;base64,{}", base64(bin)));
    let path = dir.join(format!("{name}.gltf"));
    fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
    path
}

/// Writes `name.glb`: header, JSON chunk (space-padded), BIN chunk (zero-padded). Panics
/// on I/O errors (test support; [`save_glb`] returns them).
pub fn write_glb(dir: &Path, name: &str, root: Value, bin: &[u8]) -> PathBuf {
    let path = dir.join(format!("{name}.glb"));
    fs::write(&path, glb_bytes(&root, bin)).unwrap();
    path
}

/// The bytes of a `.glb` file: 12-byte header, JSON chunk (padded with spaces to 4
/// bytes), BIN chunk (padded with zeros).
pub fn glb_bytes(root: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json_bytes = serde_json::to_vec(root).expect("a serde_json Value always serialises");
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Writes `path` (a `.gltf`, compact JSON) with its buffer in a `.bin` file of the same
/// stem beside it, which the JSON names by its file name (so the pair can be moved
/// together). Returns the `.bin` file's path. An empty buffer gets no file and no URI.
pub fn save_gltf(path: &Path, mut root: Value, bin: &[u8]) -> std::io::Result<PathBuf> {
    let bin_path = path.with_extension("bin");
    if !bin.is_empty() {
        let name = bin_path.file_name().and_then(|n| n.to_str()).ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{}: not a UTF-8 file name", path.display()))
        })?;
        // A URI: characters outside the unreserved set would need percent-encoding.
        root["buffers"][0]["uri"] = json!(uri_escape(name));
        fs::write(&bin_path, bin)?;
    }
    fs::write(path, serde_json::to_vec(&root).expect("a serde_json Value always serialises"))?;
    Ok(bin_path)
}

/// Writes `path` as a binary glTF ([`glb_bytes`]).
pub fn save_glb(path: &Path, root: &Value, bin: &[u8]) -> std::io::Result<()> {
    fs::write(path, glb_bytes(root, bin))
}

/// Percent-encodes what a relative URI may not hold as it is (RFC 3986 unreserved
/// characters stay).
fn uri_escape(name: &str) -> String {
    let mut out = String::new();
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_the_rfc_examples() {
        // RFC 4648, section 10.
        for (plain, coded) in
            [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foob", "Zm9vYg=="), ("foobar", "Zm9vYmFy")]
        {
            assert_eq!(base64(plain.as_bytes()), coded);
        }
    }

    #[test]
    fn pieces_are_aligned_and_counted() {
        let mut b = Buffer::default();
        b.indices_u16(&[0, 1, 2]);
        let f = b.floats(&[1.0, -2.0, 3.0, 4.0, 5.0, -6.0], "VEC3");
        assert_eq!(b.views[1]["byteOffset"], json!(8), "6 bytes of indices, padded to 8");
        assert_eq!(
            (b.accessors[f]["count"].clone(), b.accessors[f]["min"].clone()),
            (json!(2), json!([1.0, -2.0, -6.0]))
        );
        let a = b.accessor(&[1, 2, 3, 4], (I8, true), (1, "VEC3", 4));
        assert_eq!(b.views[2]["byteStride"], json!(4));
        assert_eq!(b.accessors[a]["normalized"], json!(true));
        let root = b.document(json!({"scene": 0}));
        assert_eq!((root["buffers"][0]["byteLength"].clone(), root["scene"].clone()), (json!(b.data.len()), json!(0)));
    }

    #[test]
    fn glb_chunks_are_padded() {
        let dir = std::env::temp_dir().join(format!("gltf-writer-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = write_glb(&dir, "t", json!({"asset": {"version": "2.0"}}), &[1, 2, 3]);
        let bytes = fs::read(&path).unwrap();
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize, bytes.len());
        assert_eq!(bytes.len() % 4, 0);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn saved_gltf_names_its_bin_and_errors_come_back() {
        let dir = std::env::temp_dir().join(format!("gltf-writer-save-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let mut b = Buffer::default();
        b.indices_u16(&[0, 1, 2]);
        let root = b.document(json!({}));
        let bin = save_gltf(&dir.join("a b.gltf"), root.clone(), &b.data).unwrap();
        assert_eq!(fs::read(&bin).unwrap(), b.data);
        let written: Value = serde_json::from_slice(&fs::read(dir.join("a b.gltf")).unwrap()).unwrap();
        assert_eq!(written["buffers"][0]["uri"], json!("a%20b.bin"));
        assert!(save_gltf(&dir.join("missing/x.gltf"), root.clone(), &b.data).is_err());
        assert!(save_glb(&dir.join("missing/x.glb"), &root, &b.data).is_err());
        fs::remove_dir_all(&dir).unwrap();
    }
}
