//! tiledlight-forward: the forward shading pass of Forward+ (each fragment's tile list) and
//! of the brute-force reference (every light for every fragment, with or without the
//! radius cutoff). Its frame (depth pre-pass, culling, this pass) is
//! `tiledlight_frame::forward_plus`. Depends on tiledlight-gpu (passes, buffers),
//! tiledlight-vpl's bindings and tiledlight-cull.

pub mod shading;
