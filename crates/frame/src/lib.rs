//! tiledlight-frame: one frame of any method. The frame owns the steps every method shares
//! and builds and records them once ([`shared`]: shadows, VPLs and their culling, blended
//! geometry, exposure and tonemap, heat map); each method is one frame function
//! ([`forward_plus`]: Forward+ and the brute-force reference; [`tiled_deferred`];
//! [`visibility`]: the visibility buffer) that
//! contributes its middle steps and passes typed handles ([`handles`]: depth, HDR, light
//! lists) between them. One [`FrameSettings`] for every method, one [`Method`], one
//! [`FrameRenderer`] behind the small [`Renderer`] trait (recording and named outputs);
//! read-backs and statistics are [`diagnostics`]; shadow casters chosen by their
//! contribution to a frame are [`caster_rank`] (a setup step that renders one).
//!
//! The whole frame, in [`FrameRenderer::record`]:
//!
//! ```text
//! shared   ShadowMaps, Vpl                          (only with shadows / --vpl)
//! method   head -> Depth; culling -> Lists; [VplCull, shared]; shading -> Hdr
//! shared   Blended* (Depth, Hdr, Lists)             (only with blended geometry)
//!          Tonemap (Hdr -> Ldr), Heatmap (Lists -> Ldr)
//! ```
//!
//! The order is the frame plan's ([`plan`]): every build checks every frame
//! against it. Each method is registered once ([`registry::METHODS`]): the plan and the
//! renderer read its registration. Depends on tiledlight-gpu, tiledlight-vpl, tiledlight-forward,
//! tiledlight-deferred and tiledlight-visibility (their passes); nothing below depends on it.

pub mod caster_rank;
pub mod diagnostics;
pub mod forward_plus;
pub mod handles;
pub mod method;
pub mod methods;
pub mod plan;
pub mod registry;
pub mod renderer;
pub mod settings;
pub mod shared;
pub mod tiled_deferred;
pub mod visibility;

pub use diagnostics::Diagnostics;
pub use forward_plus::ForwardFrame;
pub use method::MethodFrame;
pub use methods::Method;
pub use renderer::{BetweenFrames, FrameRenderer, Outputs, Renderer};
pub use settings::{FrameSettings, TestHooks};
pub use tiled_deferred::DeferredFrame;
pub use visibility::VisibilityFrame;
