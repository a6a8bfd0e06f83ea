//! tiledlight-gpu: the wgpu layer shared by both renderers.
//!
//! Device creation with adapter selection by name ([`context`]), WGSL loading with includes
//! and variants ([`shader`], shaders embedded from `shaders/`), bind group layouts declared
//! once as data and checked against the WGSL ([`bindings`]), GPU timers ([`timer`]),
//! readback ([`readback`]), scene and light buffers ([`scene_gpu`], [`light_buffers`]; material
//! textures in a few arrays, [`texture_arrays`]), and the
//! passes both methods share: the depth pre-pass ([`depth_prepass`]) and the order it and
//! the G-buffer draw in ([`draw_order`]), light culling by
//! technique ([`culling`]: tile gather, light-centric scatter, clusters) into the light grid
//! ([`light_grid`]), the shadow atlas ([`shadow_atlas`]), the blended-geometry path ([`blended`]), tonemapping ([`tonemap`]), the traced
//! reference's BVH ([`bvh`]) and each light's contribution to a frame ([`contribution`],
//! which picks shadow casters by what they light). The method types are [`method`]; the table
//! of pass settings, each declared once with its flag, axis, check and viewer control, is
//! [`knobs`](mod@knobs). Depends on wgpu, tiledlight-cull and
//! tiledlight-scene; never on a renderer crate.

/// The draw order of the depth pre-pass and the G-buffer: CPU logic, in tiledlight-cull.
pub use tiledlight_cull::draw_order;

pub mod bindings;
pub mod blended;
pub mod blit;
pub mod bvh;
pub mod context;
pub mod contribution;
pub mod culling;
pub mod define;
pub mod depth_prepass;
pub mod edge_samples;
pub mod error;
pub mod exposure;
pub mod features;
pub mod handles;
pub mod heatmap;
pub mod knobs;
pub mod light_buffers;
pub mod light_grid;
pub mod lights_group;
pub mod memory;
pub mod method;
pub mod readback;
pub mod recording;
pub mod scene_gpu;
pub mod scene_raster;
pub mod shader;
pub mod shadow_atlas;
pub mod targets;
pub mod texture_arrays;
pub mod timer;
pub mod tonemap;
pub mod util;
pub mod variants;
pub mod view;

pub use context::{skip_display_gpu_probe, ContextOptions, GpuContext};
pub use error::GpuError;
pub use wgpu;

/// Every pass binding declaration of this crate, for `cargo xtask validate-shaders`
/// (listed here, not in [`bindings`], which the passes import).
pub fn binding_declarations() -> Vec<bindings::PassBindings> {
    vec![
        depth_prepass::DEPTH_PREPASS_BINDINGS,
        culling::tile::CULL_BINDINGS,
        culling::tile::CULL_COARSE_BINDINGS,
        culling::scatter::TILE_DEPTH_BINDINGS,
        culling::scatter::ASSIGN_BINDINGS,
        tonemap::TONEMAP_BINDINGS,
        heatmap::HEATMAP_BINDINGS,
        exposure::EXPOSURE_BINDINGS,
        blended::BLENDED_BINDINGS,
        blended::BLENDED_BRUTE_FORCE_BINDINGS,
        blended::COMPOSITE_BINDINGS,
        bvh::TRACE_RAYS_BINDINGS,
        contribution::CONTRIBUTION_BINDINGS,
        edge_samples::RESOLVE_BINDINGS,
        blit::BLIT_BINDINGS,
    ]
}

/// Every Rust struct shared with WGSL in this crate, for `cargo xtask validate-shaders`.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    let mut v = view::layouts();
    v.extend(scene_gpu::layouts());
    v.extend(light_grid::layouts());
    v.extend(light_buffers::layouts());
    v.extend(tonemap::layouts());
    v.extend(shadow_atlas::layouts());
    v.extend(bvh::layouts());
    v
}
