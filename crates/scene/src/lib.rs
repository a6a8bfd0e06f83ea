//! tiledlight-scene: the scene model every renderer draws, and where scenes come from.
//!
//! - [`Scene`] and its parts ([`Mesh`], [`Material`], [`Texture`], [`Instance`],
//!   [`CameraDesc`], [`Aabb`]), with [`Scene::validate`] to check one before upload and
//!   [`Scene::world_triangles`] for the CPU ray-cast shadow reference;
//! - [`default_scene`]: a procedural Sponza-like courtyard (about 250k triangles) plus
//!   TiledLighting11's grid objects, some of them alpha-blended glass;
//! - [`shadow_box_scene`]: a cube on or above a floor, for the shadow tests;
//! - [`materials`]: a floor and 576 boxes with N distinct textured materials (images of
//!   several sizes, normal maps, masks, UV1, texture transforms), `--scene materials`;
//! - [`peer`]: other engines' benchmark scenes rebuilt (Bevy's `many_lights`), for the
//!   peer benchmark;
//! - [`random_lights`]: deterministic random point and spot lights, the courtyard's radii
//!   or radii fitted to a box and the count ([`fitted_intensity_range`]);
//! - [`SurfaceSampler`]: point lights on the scene's surfaces, their radius following
//!   the count ([`surface_light_radius`]), for the million-light preset and loaded scenes;
//!   spot lights near the surfaces aimed at them ([`SurfaceSampler::spot_lights`]);
//! - [`load_gltf_with`] (and the strict [`load_gltf`], and [`load_gltf_bytes`] for bytes in
//!   memory): glTF 2.0 files (.gltf/.glb) with KHR_lights_punctual, metallic-roughness
//!   materials in full (base colour, metallic-roughness, normal, occlusion and emissive
//!   textures, KHR_materials_emissive_strength, KHR_texture_transform, two UV sets,
//!   samplers) and KHR_mesh_quantization, read as untrusted input (files confined to the
//!   model's folder, [`LoadLimits`]), returning [`Loaded`] with the warnings the scene was
//!   drawn despite.
//!
//! - [`trace`]: the geometry the traced reference's shadow rays see (casting instances in a
//!   BVH, flattened for the GPU, with the masked materials' alpha masks).
//! - [`clusters`]: a mesh's triangles reordered into clusters of at most 128 with their
//!   bounds (Morton order of centroids), for the compute rasteriser's per-cluster culling.
//!
//! Conventions (see the workspace's DESIGN.md): right-handed, Y up, metres, front faces
//! counter-clockwise. Depends on tiledlight-cull (for [`Light`]), glam, gltf, image,
//! bevy_mikktspace (tangents), rand and thiserror; no GPU dependency.

pub mod clusters;
mod error;
mod geometry;
mod lights;
mod loader;
pub mod materials;
mod model;
pub mod peer;
mod procedural;
mod surface_lights;
pub mod trace;

pub use error::SceneError;
pub use lights::{
    bounds_light_radius, fitted_intensity_range, hue_color, mean_cube_radius, random_lights, LightOptions,
    DEFAULT_INTENSITY_RANGE, DEFAULT_LIGHT_THRESHOLD, MAX_LIGHTS,
};
pub use loader::{
    load_gltf, load_gltf_bytes, load_gltf_with, LoadLimits, LoadOptions, Loaded, DETAIL, GROUP_MISSING,
    MAX_IMAGE_BYTES, MAX_SCENE_BYTES, MAX_TEXTURE_BYTES, MAX_WORLD_COORDINATE, SUPPORTED_EXTENSIONS,
};
pub use model::{
    Aabb, AlphaMode, CameraDesc, Filter, Instance, Material, Mesh, Sampler, Scene, Texture, TextureRef, UvTransform,
    Wrap,
};
pub use procedural::{default_scene, shadow_box_scene, DefaultSceneOptions, GridDensity, MAX_GRID_OBJECTS};
pub use surface_lights::{
    surface_irradiance_factor, surface_light_radius, surface_spot_radius, SurfaceLightOptions, SurfaceLights,
    SurfaceSampler, DEFAULT_SPOT_OFFSET, DEFAULT_SURFACE_OFFSET,
};
pub use tiledlight_cull::{Light, LightKind};
