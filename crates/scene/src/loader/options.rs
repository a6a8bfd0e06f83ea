//! What the caller of the glTF loader chooses ([`LoadOptions`], with the memory bounds of
//! [`LoadLimits`]) and what it gets back ([`Loaded`]: the scene and its warnings).
//! Depends on this crate's model only.

use crate::lights::DEFAULT_LIGHT_THRESHOLD;
use crate::model::Scene;

/// Largest image file (or data URI, or buffer view) read for one texture, in bytes:
/// 256 MiB, beyond any real texture file (an 8k x 8k PNG is ~100-200 MiB).
pub const MAX_IMAGE_BYTES: u64 = 256 << 20;

/// Largest decoded texture, in bytes of RGBA8: 1 GiB, a 16384 x 16384 image (the largest
/// texture side GPUs offer). A small PNG or JPEG header can claim far more than that.
pub const MAX_TEXTURE_BYTES: u64 = 1 << 30;

/// Largest total of decoded mesh data (positions, normals, UVs, indices) and decoded
/// textures a scene may hold, in bytes: 16 GiB. A small file can name the same large
/// accessor from thousands of primitives; this bounds what that costs.
pub const MAX_SCENE_BYTES: u64 = 16 << 30;

/// Memory bounds of one load. The defaults are the named constants; tests and the fuzz
/// target set them lower to check that they hold.
///
/// With these limits, loading a file allocates at most about the file itself, its
/// buffers (each at most its `byteLength`, read from regular files only), the parsed
/// JSON, `2 * scene_bytes` (a primitive's accessors are read before its mesh is built)
/// and `2 * texture_bytes` (a decoded image is converted to RGBA8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadLimits {
    /// Largest encoded image read for one texture ([`MAX_IMAGE_BYTES`]).
    pub image_bytes: u64,
    /// Largest decoded texture in RGBA8 bytes ([`MAX_TEXTURE_BYTES`]).
    pub texture_bytes: u64,
    /// Largest total of decoded meshes and textures ([`MAX_SCENE_BYTES`]).
    pub scene_bytes: u64,
}

impl Default for LoadLimits {
    fn default() -> Self {
        Self { image_bytes: MAX_IMAGE_BYTES, texture_bytes: MAX_TEXTURE_BYTES, scene_bytes: MAX_SCENE_BYTES }
    }
}

/// How a glTF file is loaded ([`load_gltf_with`](crate::load_gltf_with)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadOptions {
    /// Intensity threshold that sets the radius of the file's lights without a `range`:
    /// r = sqrt(intensity / threshold).
    pub threshold: f32,
    /// Every warning (a missing or broken texture, an unknown extension...) becomes an
    /// error: the load fails instead of drawing a scene that differs from the file.
    pub strict: bool,
    /// Read buffers and images wherever the file's URIs point (absolute paths, `../`
    /// paths, symbolic links leading out). Off: only files inside the model's folder are
    /// read, since a file from elsewhere may name any file on the machine.
    pub allow_any_path: bool,
    /// Memory bounds.
    pub limits: LoadLimits,
}

impl LoadOptions {
    /// Options with this light threshold; not strict, files confined to the model's
    /// folder, the default limits.
    pub fn new(threshold: f32) -> Self {
        Self { threshold, strict: false, allow_any_path: false, limits: LoadLimits::default() }
    }
}

impl Default for LoadOptions {
    /// [`LoadOptions::new`] with [`DEFAULT_LIGHT_THRESHOLD`].
    fn default() -> Self {
        Self::new(DEFAULT_LIGHT_THRESHOLD)
    }
}

/// A loaded glTF file: the validated scene and what the loader had to leave out or
/// change to draw it.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The scene, validated ([`Scene::validate`]).
    pub scene: Scene,
    /// One complete sentence per problem the scene was drawn despite (a missing texture,
    /// an extension it was drawn without...), each naming the file. Empty when the scene
    /// is what the file describes; always empty after a strict load (that fails instead).
    /// A line starting with [`crate::DETAIL`] does not name the file: it is a detail
    /// of the warning before it (a grouped warning's per-image list).
    pub warnings: Vec<String>,
}
