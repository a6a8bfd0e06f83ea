//! One helper for every raster pass that draws the scene: the depth pre-pass and shadow
//! atlas (`depth_prepass.rs`), Forward+ shading (`tiledlight-forward`), the G-buffer
//! (`tiledlight-deferred`), the reflective shadow maps (`tiledlight-vpl`) and the blended
//! path (`blended.rs`). They differ only in their shader, targets and depth use; what they
//! share is here, once:
//!
//! 1. a render pipeline per draw kind the pass draws ([`scene_pipeline`]: reversed-Z
//!    depth, back faces culled unless double-sided), built by [`SceneRaster::materials`]
//!    for passes that read the full vertex stream and the material textures (group 2), or
//!    handed in ready ([`SceneRaster::from_pipelines`], the depth pre-pass, whose layouts
//!    differ per kind);
//! 2. the scene's groups: 0 the view slot, 1 instances and materials, 2 the material
//!    textures, or an empty group where the scene has none (a pass's layout then declares
//!    the group empty: [`SceneRaster::bind`]);
//! 3. a render pass over colour targets and a depth target ([`begin_pass`]);
//! 4. the draws of each kind with its pipeline ([`SceneRaster::draw`]), or one instance at a
//!    time with [`SceneRaster::pipeline`] (the sorted blended path).
//!
//! A pass's own groups (the lights at group 3) are set by the pass after [`SceneRaster::bind`].
//! Depends on wgpu, [`crate::scene_gpu`], [`crate::view`] and [`crate::util`].

use crate::error::GpuError;
use crate::scene_gpu::{DrawCount, DrawKind, SceneGpu};
use crate::util::pipeline_layout;
use crate::view::Views;
use tiledlight_cull::draw_order::DrawOrder;

/// Primitive state for a draw kind: back faces culled unless double-sided.
pub fn primitive_state(kind: DrawKind) -> wgpu::PrimitiveState {
    wgpu::PrimitiveState {
        topology: wgpu::PrimitiveTopology::TriangleList,
        front_face: wgpu::FrontFace::Ccw,
        cull_mode: if kind.double_sided { None } else { Some(wgpu::Face::Back) },
        ..Default::default()
    }
}

/// How a scene pass uses the depth buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthUse {
    /// Writes depth, compare GreaterEqual (pre-pass, G-buffer, shadow faces).
    Write,
    /// Tests Equal against the pre-pass without writing (Forward+ shading: each pixel once).
    Equal,
    /// Tests GreaterEqual without writing (blended geometry in front of the opaque depth).
    Test,
    /// No depth attachment (the compute raster's hardware half resolves depth itself).
    None,
}

/// How a pass draws the scene's geometry: what [`scene_pipeline`] needs besides the draw kind.
pub struct SceneDraw<'a> {
    /// Pipeline label.
    pub label: &'a str,
    /// Pipeline layout.
    pub layout: &'a wgpu::PipelineLayout,
    /// The shader module holding both stages.
    pub module: &'a wgpu::ShaderModule,
    /// Vertex entry point and the vertex buffers it reads.
    pub vertex: (&'a str, &'a [Option<wgpu::VertexBufferLayout<'a>>]),
    /// How the pass uses depth.
    pub depth: DepthUse,
    /// MSAA samples.
    pub samples: u32,
    /// Fragment entry point and colour targets (None: depth only).
    pub fragment: Option<(&'a str, &'a [Option<wgpu::ColorTargetState>])>,
    /// Depth format ([`crate::depth_prepass::DEPTH_FORMAT`] except for shadow maps).
    pub depth_format: wgpu::TextureFormat,
    /// Pipeline-overridable constants (`override` in the WGSL).
    pub constants: &'a [(&'a str, f64)],
}

/// A render pipeline drawing the scene's `kind` of draws into `d.depth_format` (reversed-Z).
pub fn scene_pipeline(device: &wgpu::Device, kind: DrawKind, d: &SceneDraw<'_>) -> wgpu::RenderPipeline {
    // Writing passes keep the last of several fragments at exactly the same depth
    // (GreaterEqual), as the Equal-tested shading pass after a pre-pass does (every such
    // fragment passes Equal and the last one's colour stays). With Greater the G-buffer kept
    // the first: where two surfaces meet at exactly the pixel centre's depth (measured on
    // the H200: one pixel of the courtyard at 320x180) Tiled Deferred then shaded another
    // surface than Forward+ and brute force.
    let compare = match d.depth {
        DepthUse::Write | DepthUse::Test | DepthUse::None => wgpu::CompareFunction::GreaterEqual,
        DepthUse::Equal => wgpu::CompareFunction::Equal,
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(d.label),
        layout: Some(d.layout),
        vertex: wgpu::VertexState {
            module: d.module,
            entry_point: Some(d.vertex.0),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: d.constants,
                zero_initialize_workgroup_memory: false,
            },
            buffers: d.vertex.1,
        },
        primitive: primitive_state(kind),
        depth_stencil: (d.depth != DepthUse::None).then(|| wgpu::DepthStencilState {
            format: d.depth_format,
            depth_write_enabled: Some(d.depth == DepthUse::Write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: wgpu::MultisampleState { count: d.samples, ..Default::default() },
        fragment: d.fragment.map(|(fs, targets)| wgpu::FragmentState {
            module: d.module,
            entry_point: Some(fs),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: d.constants,
                zero_initialize_workgroup_memory: false,
            },
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// What a pass's pipelines share besides the shader: its depth use and format, samples,
/// fragment stage and constants (the vertex stage is always `vs_main` over the scene's
/// full vertex stream).
pub struct RasterTargets<'a> {
    /// How the pass uses depth.
    pub depth: DepthUse,
    /// Depth format.
    pub depth_format: wgpu::TextureFormat,
    /// MSAA samples.
    pub samples: u32,
    /// Fragment entry point and colour targets.
    pub fragment: (&'a str, &'a [Option<wgpu::ColorTargetState>]),
    /// Pipeline-overridable constants.
    pub constants: &'a [(&'a str, f64)],
}

/// Which vertex streams and textures a pass's draws bind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneInputs {
    /// Positions, the other attributes and the material textures for every kind.
    Materials,
    /// Positions only; attributes and textures for masked kinds (their alpha test).
    DepthOnly,
}

/// A raster pass's pipelines per draw kind and its scene groups (see the module doc).
pub struct SceneRaster {
    pipelines: Vec<(DrawKind, wgpu::RenderPipeline)>,
    /// Group 2 for a scene without textures (the pass's layout declares it empty).
    empty_group: Option<wgpu::BindGroup>,
    inputs: SceneInputs,
    /// The pipeline constants every pipeline was built with ([`Self::constants`]).
    constants: Vec<(String, f64)>,
}

impl SceneRaster {
    /// The pipelines of a pass drawing `kinds` of `scene` with its materials: layout
    /// `[views, scene, textures (or empty), extra...]`, vertex stage `vs_main` over the full
    /// vertex stream, the shader of each kind from `module(kind)`. Labels start with `label`.
    pub fn materials(
        device: &wgpu::Device,
        label: &str,
        (views, scene): (&Views, &SceneGpu),
        extra: &[&wgpu::BindGroupLayout],
        kinds: &[DrawKind],
        mut module: impl FnMut(DrawKind) -> Result<wgpu::ShaderModule, GpuError>,
        targets: &RasterTargets<'_>,
    ) -> Result<Self, GpuError> {
        let empty = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(&format!("{label}.empty_layout")),
            entries: &[],
        });
        let mut groups = vec![&views.layout, &scene.layout, scene.textures.as_ref().map_or(&empty, |t| &t.layout)];
        groups.extend_from_slice(extra);
        let layout = pipeline_layout(device, &format!("{label}.layout"), &groups);
        let vertex = scene.vertex_layouts();
        let pipelines = kinds
            .iter()
            .map(|&kind| {
                let module = module(kind)?;
                let draw = SceneDraw {
                    label,
                    layout: &layout,
                    module: &module,
                    vertex: ("vs_main", &vertex),
                    depth: targets.depth,
                    samples: targets.samples,
                    fragment: Some(targets.fragment),
                    depth_format: targets.depth_format,
                    constants: targets.constants,
                };
                Ok((kind, scene_pipeline(device, kind, &draw)))
            })
            .collect::<Result<Vec<_>, GpuError>>()?;
        let empty_group = scene.textures.is_none().then(|| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(&format!("{label}.empty")),
                layout: &empty,
                entries: &[],
            })
        });
        let constants = targets.constants.iter().map(|&(k, v)| (k.to_string(), v)).collect();
        Ok(Self { pipelines, empty_group, inputs: SceneInputs::Materials, constants })
    }

    /// A pass whose pipelines the caller built (one per kind; their layouts have no group 2
    /// or the scene's textures), drawing with `inputs`.
    pub fn from_pipelines(pipelines: Vec<(DrawKind, wgpu::RenderPipeline)>, inputs: SceneInputs) -> Self {
        Self { pipelines, empty_group: None, inputs, constants: Vec::new() }
    }

    /// The pipeline constants [`Self::materials`] built every pipeline with (empty for
    /// [`Self::from_pipelines`]). Tests read it to see that a setting which must not change
    /// the image (the early-outs' ablation) reached the pipelines.
    pub fn constants(&self) -> &[(String, f64)] {
        &self.constants
    }

    /// Sets group 0 to view slot `view` (None: the caller sets it, e.g. per face), group 1
    /// to the scene and, for a scene without textures, group 2 to the empty group.
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>, view: Option<(&Views, u32)>, scene: &SceneGpu) {
        if let Some((views, slot)) = view {
            pass.set_bind_group(0, views.bind_group(), &views.offsets(slot));
        }
        pass.set_bind_group(1, &scene.bind_group, &[]);
        if let Some(g) = &self.empty_group {
            pass.set_bind_group(2, g, &[]);
        }
    }

    /// Records the draws of every kind with its pipeline, only the instances set in
    /// `visible` (by instance slot) or all, each kind in `order` (the instance buffer's
    /// when None); returns what it recorded.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        scene: &SceneGpu,
        visible: Option<&[bool]>,
        order: Option<&DrawOrder>,
    ) -> DrawCount {
        let mut drawn = DrawCount::default();
        for (kind, pipeline) in &self.pipelines {
            pass.set_pipeline(pipeline);
            let inputs = match self.inputs {
                SceneInputs::Materials => (true, true),
                SceneInputs::DepthOnly => (kind.masked, kind.masked),
            };
            drawn += scene.record_draws_of(pass, *kind, inputs, visible, order);
        }
        drawn
    }

    /// The pipeline of draw kind `kind`, if the pass draws it.
    pub fn pipeline(&self, kind: DrawKind) -> Option<&wgpu::RenderPipeline> {
        self.pipelines.iter().find(|(k, _)| *k == kind).map(|(_, p)| p)
    }
}

/// Begins render pass `label` over `colors` and the depth target `depth`, loaded or
/// cleared as its `LoadOp` says and stored, with the pass timer's `timestamps`.
pub fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth: (&wgpu::TextureView, wgpu::LoadOp<f32>),
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: colors,
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth.0,
            depth_ops: Some(wgpu::Operations { load: depth.1, store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        }),
        timestamp_writes: timestamps,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A colour attachment cleared to `clear`; with a `resolve` target (MSAA) the samples are
/// resolved into it and discarded.
pub fn cleared<'a>(
    view: &'a wgpu::TextureView,
    resolve: Option<&'a wgpu::TextureView>,
    clear: wgpu::Color,
) -> Option<wgpu::RenderPassColorAttachment<'a>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: resolve,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(clear),
            store: if resolve.is_some() { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
        },
    })
}
