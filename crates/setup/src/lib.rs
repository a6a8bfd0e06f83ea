//! tiledlight-setup: a run of tiledlight without a command line. From plain
//! [`Settings`] (their flags, one a row of the run settings' table [`table`], are clap
//! arguments only behind the `clap` feature, which the app enables) it checks the input,
//! builds the scene, its lights and the camera on the CPU ([`SceneCpu`]), creates or takes
//! a GPU context, uploads everything and builds the chosen renderer ([`Prepared`]). A
//! change of settings is planned as a value ([`rebuild_plan`] -> [`Rebuild`]) and carried
//! out by [`Prepared::reconfigure`], so the viewer and the measurement lab rebuild only
//! what a change needs. [`culling_stats`] reads a frame's per-tile light counts back
//! for reports and tests. Shadow-casting lights are settings too (how many of each kind,
//! the atlas tile size, filter and format), uploaded with the lights; so is alpha-blended
//! geometry (transparent grid objects of the default scene, and the blend mode: sorted or
//! weighted blended OIT), with [`blended_stats`] on its own light grid.
//!
//! Modules:
//! - [`settings`]: [`Settings`], [`Method`], [`SceneSource`], validation, what the
//!   renderers take, report text (pure data);
//! - [`table`]: the run settings' table ([`table::SETTINGS`]: one row a setting, from
//!   which the flags, axes, script keys, range checks and rebuilds come; pure data);
//! - [`validate`]: [`Settings::validate`], the checks that relate settings (pure data);
//! - [`rebuild`]: [`rebuild_plan`], [`Rebuild`], [`Reload`] (pure data);
//! - [`camera`]: [`choose_camera`], [`camera_from_desc`], [`frame_bounds`] (no GPU);
//! - [`load`]: [`SceneCpu`], [`LightSummary`] (files and CPU work, no GPU);
//! - [`prepared`]: [`Prepared`] (the GPU side);
//! - [`stats`]: [`CullingStats`], [`culling_stats`], [`BlendedStats`], [`blended_stats`],
//!   [`group_digits`], [`shadow_atlas_description`];
//! - [`animate`]: [`LightAnimator`], the lights circling the scene (the viewer's animation,
//!   `bench --move-lights`);
//! - [`export`]: the scene, its lights and camera as one glTF file for other engines
//!   (`tiledlight export`; intensity units and what else is written in its docs);
//! - [`bookmark`]: the camera bookmark file format (`--camera FILE`, the viewer's "save
//!   camera"), read and written (files, no GPU).
//! - [`camera_rig`]: an interactive fly/orbit camera (the viewer's), pure logic.
//!
//! Layering: depends on tiledlight-cull, tiledlight-scene, tiledlight-gpu,
//! tiledlight-frame (the renderer), tiledlight-deferred (its workgroup budget),
//! tiledlight-visibility (the compute raster's checks) and tiledlight-gltf-writer (and
//! wgpu, glam, anyhow, serde_json; clap with the `clap` feature); the app
//! (`tiledlight`) and the GPU tests depend on it, never the other way round. Errors are
//! `anyhow` errors whose text is meant for the user as it is: settings errors name the
//! app's flag (`--width 0: ...`).

pub mod animate;
pub mod bookmark;
pub mod camera;
pub mod camera_rig;
pub mod demo;
pub mod export;
pub mod load;
pub mod prepared;
pub mod rebuild;
pub mod settings;
pub mod stats;
pub mod table;
pub mod validate;

pub use animate::LightAnimator;
pub use camera::{camera_from_desc, choose_camera, frame_bounds};
pub use demo::Demo;
pub use load::{BoundsFit, FittedLights, LightSummary, SceneCpu, SpotPlacement, SurfacePlacement};
pub use prepared::Prepared;
pub use rebuild::{rebuild_plan, Rebuild, Reload};
pub use settings::{
    surface_exposure, CameraBookmark, CasterChoice, ComputeRasterOptions, DrawOrderMode, Knobs, LargeRaster,
    LightPlacement, Method, PeerScene, Raster, SceneSource, Settings, DEFAULT_LIGHTS_PER_POINT, DEFAULT_POINT_LIGHTS,
    MILLION_LIGHTS,
};
pub use stats::{blended_stats, culling_stats, group_digits, shadow_atlas_description, BlendedStats, CullingStats};
pub use table::{Assign, GridLayout, Setting, SETTINGS};
