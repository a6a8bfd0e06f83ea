//! tiledlight-forward: the Forward+ renderer (depth pre-pass, tiled light culling, forward
//! shading of each tile's list), the brute-force reference renderer (every light for every
//! pixel, with or without the radius cutoff) and the heat-map view of lights per tile.
//! Depends on tiledlight-gpu (passes, buffers) and tiledlight-cull (camera, grid).

pub mod renderer;
pub mod shading;

pub use renderer::{ForwardRenderer, ForwardSettings, Method};
