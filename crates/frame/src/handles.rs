//! [`Rec`], what every step of a frame records into (the typed handles a step's
//! constructor and `record` take are `tiledlight_gpu::handles`'s, so the passes of every
//! crate take them too; `docs/ARCHITECTURE.md` has the table). [`Rec`] and checks (in every build: one comparison a step) that
//! the steps come in the order of the frame plan. Depends on tiledlight-gpu.

use std::cell::Cell;

use crate::plan::{FramePlan, Step};
use tiledlight_gpu::draw_order::DrawOrder;
use tiledlight_gpu::recording::Recording;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::view::Views;

/// What every step of one frame records into: the encoder, the timer, the main view and
/// the scene (its [`Recording`], which it derefs to, so a pass's `record` takes `rec`
/// itself), and the order the head step draws in; [`Rec::step`] names each step as it is
/// recorded.
pub struct Rec<'a> {
    /// The encoder, timer, view and scene every pass records with.
    pub recording: Recording<'a>,
    /// The order the head step (depth pre-pass or G-buffer) draws the scene in; None:
    /// the instance buffer's ([`Knobs::draw_order`](tiledlight_gpu::knobs::Knobs::draw_order)).
    pub order: Option<&'a DrawOrder>,
    plan: &'a FramePlan,
    next: Cell<usize>,
}

impl<'a> std::ops::Deref for Rec<'a> {
    type Target = Recording<'a>;
    fn deref(&self) -> &Recording<'a> {
        &self.recording
    }
}

impl<'a> std::ops::DerefMut for Rec<'a> {
    fn deref_mut(&mut self) -> &mut Recording<'a> {
        &mut self.recording
    }
}

impl<'a> Rec<'a> {
    /// A recorder of one frame of `plan`.
    pub fn new(
        encoder: &'a mut wgpu::CommandEncoder,
        timer: &'a GpuTimer,
        view: (&'a Views, u32),
        (scene, order): (&'a SceneGpu, Option<&'a DrawOrder>),
        plan: &'a FramePlan,
    ) -> Self {
        Self { recording: Recording { encoder, timer, view, scene }, order, plan, next: Cell::new(0) }
    }

    /// Marks `step` as recorded next, checking in every build that it is the plan's next
    /// step: the frame functions and the plan can never disagree unnoticed, in a release
    /// binary either (a disagreement is a bug of this crate, never of its input).
    pub fn step(&self, step: Step) {
        let i = self.next.get();
        assert_eq!(
            self.plan.steps().get(i),
            Some(&step),
            "step {i} of the frame recorded {step:?}; the plan says {:?}",
            self.plan.steps()
        );
        self.next.set(i + 1);
    }

    /// Checks (every build) that every step of the plan was recorded.
    pub fn finish(self) {
        assert_eq!(self.next.get(), self.plan.steps().len(), "the frame skipped steps of {:?}", self.plan.steps());
    }
}
