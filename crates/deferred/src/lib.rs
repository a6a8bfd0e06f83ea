//! tiledlight-deferred: the passes of TiledLighting11's Tiled Deferred (its frame is
//! `tiledlight_frame::tiled_deferred`). A G-buffer pass
//! ([`gbuffer`]) writes what the shared BRDF needs; one compute pass ([`shading`]) culls
//! each tile's lights with the same WGSL as Forward+ and shades the tile's pixels from that
//! list; the stress knob adds 1 to 3 extra G-buffer targets whose bandwidth is real.
//! Depends on tiledlight-gpu (passes, buffers, targets) and tiledlight-cull.

pub mod gbuffer;
pub mod shading;

pub use tiledlight_gpu::edge_samples::EdgeTest;
