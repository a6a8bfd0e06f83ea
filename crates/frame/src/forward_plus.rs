//! The frame of Forward+ and of the brute-force reference: their middle steps, between the
//! shared ones ([`crate::shared`]), with the handles each reads and writes.
//!
//! ```text
//! DepthPrepass  scene                        -> Depth
//! Cull          Depth, lights                -> Lists (Forward+ only)
//! [VplCull]     Depth, VPLs                  -> VPL Lists (shared step, Forward+ with VPLs)
//! Shade         Depth, Lists, VPL Lists,     -> Hdr (with MSAA: drawn multisampled and
//!               shadow atlas                          resolved into Hdr)
//! ```
//!
//! Brute force has no culling: its shading loops over every light (with or without the
//! radius cutoff). Depends on tiledlight-gpu (depth pre-pass, culling) and
//! tiledlight-forward (the shading pass).

use std::any::Any;

use crate::methods::Method;
use crate::plan::Step;
use tiledlight_forward::shading::{LightLoop, ShadingPass};
use tiledlight_gpu::culling::LightCulling;
use tiledlight_gpu::depth_prepass::{DepthPrepass, DEPTH_FORMAT};
use tiledlight_gpu::features::Features;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::light_grid::LightGrid;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::texture_2d_msaa;
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::{GpuContext, GpuError};

use crate::handles::Rec;
use crate::method::{tiled_steps, MethodFrame, Registration};
use crate::settings::FrameSettings;
use crate::shared::{SharedSteps, TargetNeeds};
use tiledlight_gpu::handles::{Depth, Lists};
use tiledlight_gpu::targets::target_handles;

/// The display targets Forward+ needs: depth and HDR drawn multisampled by render passes.
pub fn targets(_: &Features) -> TargetNeeds {
    TargetNeeds {
        prefix: "forward",
        msaa_formats: vec![DEPTH_FORMAT, HDR_FORMAT],
        hdr_usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        depth: None,
    }
}

/// Forward+: depth pre-pass, culling, the VPLs' culling (with VPLs), forward shading.
pub const FORWARD_PLUS: Registration = Registration {
    renders: |m| m == Method::ForwardPlus,
    building: "building the Forward+ renderer",
    steps: |f| tiled_steps(f, &[Step::DepthPrepass, Step::Cull], Step::ForwardShade, None),
    targets,
    build: |c, sh, sl, st, m| Ok(Box::new(ForwardFrame::new(c, sh, sl, st, m)?)),
};

/// The brute-force reference (with or without the cutoff): depth pre-pass, every light for
/// every pixel. Forward+'s frame without its culling.
pub const BRUTE_FORCE: Registration = Registration {
    renders: |m| matches!(m, Method::BruteForce { .. }),
    building: "building the brute-force reference",
    steps: |_| vec![Step::DepthPrepass, Step::BruteForceShade],
    targets,
    build: FORWARD_PLUS.build,
};

/// Forward+'s (or brute force's) passes.
pub struct ForwardFrame {
    prepass: DepthPrepass,
    /// Forward+ only.
    culling: Option<LightCulling>,
    shading: ShadingPass,
    /// The multisampled HDR target the shading pass draws into and resolves (MSAA only).
    hdr_msaa: Option<(wgpu::Texture, wgpu::TextureView)>,
    /// The frame's HDR image (its handle at construction), which the shading pass draws
    /// into or resolves to.
    hdr: wgpu::TextureView,
}

impl ForwardFrame {
    /// Builds the passes over the shared steps' views, targets, shadows and VPLs.
    pub fn new(
        ctx: &GpuContext,
        shared: &SharedSteps,
        (scene, lights): (&SceneGpu, &LightBuffers),
        settings: &FrameSettings,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let (features, views, targets) = (&shared.features, &shared.views, &shared.targets);
        let hdr_msaa = (features.msaa > 1).then(|| {
            let t = texture_2d_msaa(
                device,
                "forward.hdr_msaa",
                (targets.hdr.width(), targets.hdr.height()),
                HDR_FORMAT,
                features.msaa,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            );
            let v = t.create_view(&wgpu::TextureViewDescriptor {
                label: Some("forward.hdr_msaa.view"),
                ..Default::default()
            });
            memory.add("forward.hdr_msaa", t.width() as u64 * t.height() as u64 * features.msaa as u64 * 8);
            (t, v)
        });
        let prepass = DepthPrepass::new(device, views, scene, features)?;
        let culling = shared
            .plan
            .has(Step::Cull)
            .then(|| {
                LightCulling::with_drop_light(
                    device,
                    views,
                    target_handles(targets).0,
                    (lights, &shared.lighting),
                    shared.grid,
                    settings.cull,
                    shared.hooks.drop_light,
                )
            })
            .transpose()?;
        if let Some(c) = &culling {
            memory.extend(&c.memory);
        }
        let light_loop = match settings.method {
            Method::BruteForce { cutoff } => LightLoop::All { cutoff },
            _ => LightLoop::Tiled { half_z: features.half_z },
        };
        let inputs = shared.lighting_inputs(device, views, lights, features);
        let shading = ShadingPass::new(&inputs, scene, culling.as_ref(), light_loop)?;
        Ok(Self { prepass, culling, shading, hdr_msaa, hdr: target_handles(targets).1.view.clone() })
    }

    /// The culling pass (Forward+ only).
    pub fn culling(&self) -> Option<&LightCulling> {
        self.culling.as_ref()
    }

    /// The depth pre-pass.
    pub fn prepass(&self) -> &DepthPrepass {
        &self.prepass
    }

    /// The shading pass (forward or brute force).
    pub fn shading(&self) -> &ShadingPass {
        &self.shading
    }

    /// Records the frame's head alone, outside a frame plan: the depth pre-pass into
    /// `depth` and (Forward+) the culling, for a step that reads only the depth and the
    /// lists (the caster ranking, [`crate::caster_rank`]).
    pub fn record_head(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &tiledlight_gpu::timer::GpuTimer,
        view: (&tiledlight_gpu::view::Views, u32),
        (scene, depth): (&SceneGpu, Depth<'_>),
    ) {
        let depth = depth.view;
        let mut r = tiledlight_gpu::recording::Recording { encoder, timer, view, scene };
        // The instance buffer's order: the ranking runs once, its cost is not measured.
        self.prepass.record(&mut r, None, depth);
        if let Some(cull) = &self.culling {
            cull.record(r.encoder, timer, view, "forward.cull");
        }
    }
}

impl MethodFrame for ForwardFrame {
    fn record(&self, rec: &mut Rec<'_>, shared: &SharedSteps, depth: Depth<'_>) {
        rec.step(Step::DepthPrepass);
        let order = rec.order;
        self.prepass.record(rec, order, depth.view);
        if let Some(cull) = &self.culling {
            rec.step(Step::Cull);
            let r = &mut rec.recording;
            cull.record(r.encoder, r.timer, r.view, "forward.cull");
        }
        shared.record_vpl_cull(rec);
        rec.step(if self.culling.is_some() { Step::ForwardShade } else { Step::BruteForceShade });
        // With MSAA the pass draws the multisampled target and resolves it into the HDR image.
        let (target, resolve) = match &self.hdr_msaa {
            Some((_, v)) => (v, Some(&self.hdr)),
            None => (&self.hdr, None),
        };
        self.shading.record(rec, target, resolve, depth.view);
    }

    fn lists(&self) -> Option<Lists<'_>> {
        self.culling.as_ref().map(|c| Lists { grid: &c.grid })
    }

    fn grow_lists(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, capacity: u32) -> Option<&LightGrid> {
        let c = self.culling.as_mut()?;
        c.grid.grow(device, queue, capacity);
        self.shading.rebind(device, &c.grid);
        Some(&c.grid)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}
