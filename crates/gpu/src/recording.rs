//! What one pass of a frame records into ([`Recording`]): the frame's command encoder, its
//! GPU timer, the camera's view slot and the scene. A pass's `record` takes it and, beside
//! it, only the handles and settings that are that pass's own, so its signature says what
//! it reads and writes (`crate::handles`). The frame crate's recorder (`tiledlight_frame::
//! handles::Rec`) holds one for every step of a frame. Depends on the crate's timer, view
//! and scene modules.

use crate::scene_gpu::SceneGpu;
use crate::timer::GpuTimer;
use crate::view::Views;

/// The encoder, timer, view and scene every pass of one frame records with.
pub struct Recording<'a> {
    /// The frame's command encoder.
    pub encoder: &'a mut wgpu::CommandEncoder,
    /// The GPU timer (one query pair a pass).
    pub timer: &'a GpuTimer,
    /// The views' buffers and the camera's slot among them.
    pub view: (&'a Views, u32),
    /// The scene's buffers and draws.
    pub scene: &'a SceneGpu,
}
