//! tiledlight-deferred: the Tiled Deferred renderer of TiledLighting11. A G-buffer pass
//! ([`gbuffer`]) writes what the shared BRDF needs; one compute pass ([`shading`]) culls
//! each tile's lights with the same WGSL as Forward+ and shades the tile's pixels from that
//! list; the stress knob adds 1 to 3 extra G-buffer targets whose bandwidth is real.
//! Depends on tiledlight-gpu (passes, buffers, targets) and tiledlight-cull.

pub mod gbuffer;
pub mod renderer;
pub mod shading;

pub use renderer::{DeferredRenderer, DeferredSettings};
pub use shading::EdgeTest;
