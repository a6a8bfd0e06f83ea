//! The crate's error type. Every message says where the problem is (the file, when the
//! data came from one, and the mesh, material, instance or light) and what is wrong.
//! Depends on thiserror only.

use std::path::PathBuf;

/// Everything that can go wrong when building, loading or validating a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be opened or read.
    #[error("{}: cannot read file: {source}", path.display())]
    Io {
        /// The file that could not be read.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A glTF file (or a buffer or image it refers to) is malformed or uses something
    /// this loader does not support.
    #[error("{}: {message}", path.display())]
    Gltf {
        /// The glTF file being loaded.
        path: PathBuf,
        /// What is wrong, naming the mesh, accessor, buffer, image or node.
        message: String,
    },
    /// The scene's data is inconsistent; reported by [`Scene::validate`](crate::Scene::validate).
    #[error("scene '{scene}': {problem}")]
    InvalidScene {
        /// The scene's name.
        scene: String,
        /// What is wrong, naming the mesh, material, texture, instance or light.
        problem: String,
    },
    /// More grid objects were asked for than the default scene has room for.
    #[error("grid_objects {requested} is out of range: the default scene holds at most {max}")]
    TooManyGridObjects {
        /// The number asked for.
        requested: u32,
        /// The largest accepted number.
        max: u32,
    },
    /// More transparent grid objects were asked for than there are grid objects.
    #[error(
        "transparent_objects {requested} exceeds grid_objects {grid_objects}: only grid objects can be transparent"
    )]
    TooManyTransparentObjects {
        /// The number of transparent objects asked for.
        requested: u32,
        /// The number of grid objects asked for.
        grid_objects: u32,
    },
    /// More lights were asked for than any renderer here supports.
    #[error("{requested} lights requested: at most {limit} (point and spot together) can be generated")]
    TooManyLights {
        /// Point plus spot lights asked for.
        requested: u64,
        /// The largest accepted total.
        limit: u64,
    },
    /// A generator or loader argument is NaN, infinite or out of range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}
