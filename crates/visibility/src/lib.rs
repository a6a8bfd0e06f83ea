//! tiledlight-visibility: the third method, the visibility buffer (Burns and Hunt 2013; its
//! frame is `tiledlight_frame::visibility`). The raster pass ([`raster`]) writes depth and
//! one 32-bit ID per sample naming an instance and a triangle; one compute pass
//! ([`shading`]) rebuilds each sample's surface from the ID (the triangle's vertices,
//! perspective-correct barycentrics with analytic derivatives, the full glTF material with
//! textures sampled by explicit gradients) and lights it with the same light grid, BRDF,
//! shadows and VPLs as the other methods. No G-buffer and no forward shading pipeline
//! exist for it. The raster has two paths: the hardware's and a compute raster
//! ([`compute_raster`], issue 29). The fourth method, stochastic (issue 48), is the traced
//! reference's pass with a sampler's light loop and a history ([`stochastic`]) and its
//! denoiser ([`denoise`]). Depends on tiledlight-gpu (passes, buffers, the culling, and
//! the MSAA edge machinery it shares with Tiled Deferred, `tiledlight_gpu::edge_samples`).

pub mod compute_raster;
pub mod denoise;
pub mod raster;
pub mod shading;
pub mod stochastic;
