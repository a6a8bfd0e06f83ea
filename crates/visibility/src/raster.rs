//! The visibility buffer's raster pass: the scene's opaque and masked draws into the
//! frame's depth and an `R32Uint` ID target of the same samples, each ID `(instance <<
//! triangle_bits) | triangle`. The split is [`tiledlight_cull::visibility::IdLayout`],
//! chosen from the scene's instance count and its largest mesh; a scene past 32 bits is
//! refused with the bits it needs. Two paths ([`Raster`]): the hardware raster, the depth
//! pre-pass's pipelines with a fragment stage writing the ID (`shaders/depth_prepass.wgsl`
//! with `IDS`), or the compute raster ([`crate::compute_raster`]), which writes the same
//! IDs and an `R32Float` depth (in a scene with blended geometry copied into the
//! `Depth32Float` attachment the blended passes test against). Depends on tiledlight-gpu.

use tiledlight_cull::visibility::IdLayout;
use tiledlight_gpu::bindings::{create_layout, Binding, PassBindings, PassGroup};
use tiledlight_gpu::depth_prepass::{DepthPrepass, DEPTH_FORMAT, ID_FORMAT};
use tiledlight_gpu::features::{Features, Raster};
use tiledlight_gpu::handles::Depth;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::read_texture;
use tiledlight_gpu::recording::Recording;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::texture_2d_msaa;
use tiledlight_gpu::util::{buffer_init, pipeline_layout, shader_module, texture_2d, view_entry};
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

use crate::compute_raster::{ComputeRaster, ComputeRasterOptions, COMPUTE_DEPTH_FORMAT};

/// The depth copy's bindings (`shaders/visibility_depth_copy.wgsl`): the compute raster's
/// depth at group 0 binding 0.
pub const DEPTH_COPY_BINDINGS: PassBindings = PassBindings {
    entry: "visibility_depth_copy.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[Binding::texture(0, wgpu::ShaderStages::FRAGMENT, wgpu::TextureSampleType::Float { filterable: false })],
    )],
};

/// The compute raster's `R32Float` depth copied into the `Depth32Float` attachment
/// (scenes with blended geometry only).
struct DepthCopy {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    /// What the compute raster writes (its texture is kept alive by the view).
    view: wgpu::TextureView,
}

/// How the raster is drawn.
enum Path {
    Hardware(DepthPrepass),
    Compute(Box<ComputeRaster>, Option<DepthCopy>),
}

/// The raster pass and its ID target.
pub struct VisibilityRaster {
    path: Path,
    ids: wgpu::Texture,
    /// Test-only: a pixel and a buffer holding the wrong ID copied onto it after the pass.
    wrong_id: Option<((u32, u32), wgpu::Buffer)>,
    /// The ID target (multisampled with MSAA), read by [`crate::shading`].
    pub ids_view: wgpu::TextureView,
    /// How IDs split into instance and triangle.
    pub layout: IdLayout,
}

/// The depth format of the frame's depth target with raster `raster` ([`Raster::Hardware`]
/// or [`Raster::Compute`]) in a scene with (`blended`) or without blended geometry, and the
/// usage it needs beyond sampling: the compute raster writes `R32Float` from compute
/// unless blended passes need a depth attachment.
pub fn depth_target(raster: Raster, blended: bool) -> Option<(wgpu::TextureFormat, wgpu::TextureUsages)> {
    (raster == Raster::Compute && !blended).then_some((COMPUTE_DEPTH_FORMAT, wgpu::TextureUsages::STORAGE_BINDING))
}

impl VisibilityRaster {
    /// The pass for `scene` on a `size` screen with the features' samples, drawn by
    /// `raster` ([`Raster::Hardware`] or [`Raster::Compute`] with `options`) into the
    /// frame's `depth` target (made by [`depth_target`]). `wrong_id` (tests only, one
    /// sample a pixel): that pixel's ID is overwritten after the pass with instance 0's
    /// triangle 0, a valid but wrong triangle.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        (size, wrong_id): ((u32, u32), Option<(u32, u32)>),
        (raster, options, depth): (Raster, ComputeRasterOptions, Depth<'_>),
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        if depth.samples != features.msaa {
            return Err(GpuError::Config(format!(
                "the visibility raster: a depth buffer of {} samples a pixel, features of {}",
                depth.samples, features.msaa
            )));
        }
        let depth = depth.view;
        if let Some((x, y)) = wrong_id {
            if features.msaa > 1 || x >= size.0 || y >= size.1 {
                return Err(GpuError::Config(format!(
                    "the wrong-ID test hook needs one sample a pixel and a pixel on the {}x{} screen, got ({x}, {y})",
                    size.0, size.1
                )));
            }
        }
        let instances = scene.instance_bounds.len() as u32;
        let layout = IdLayout::for_scene(instances.max(1), scene.max_triangles.max(1))?;
        let compute = match raster {
            Raster::Hardware => false,
            Raster::Compute => true,
            Raster::Auto => {
                return Err(GpuError::Config("the raster path must be chosen (Raster::pick) before building".into()))
            }
        };
        use wgpu::TextureUsages as U;
        let ids = texture_2d_msaa(
            device,
            "visibility.ids",
            size,
            ID_FORMAT,
            features.msaa,
            // COPY_SRC: tests read the IDs back (single-sampled). STORAGE_BINDING: the
            // compute raster's finalize kernel writes them.
            U::RENDER_ATTACHMENT
                | U::TEXTURE_BINDING
                | U::COPY_SRC
                | if wrong_id.is_some() { U::COPY_DST } else { U::empty() }
                | if compute { U::STORAGE_BINDING } else { U::empty() },
        );
        // A row of a texture copy is 256-byte aligned: one row of 64 IDs, the first used.
        let wrong_id = wrong_id.map(|p| {
            let mut row = [0u32; 64];
            row[0] = layout.pack(0, 0);
            (
                p,
                buffer_init(
                    device,
                    "visibility.test_wrong_id",
                    bytemuck::cast_slice(&row),
                    wgpu::BufferUsages::COPY_SRC,
                ),
            )
        });
        memory.add("visibility.ids", size.0 as u64 * size.1 as u64 * features.msaa as u64 * 4);
        let ids_view =
            ids.create_view(&wgpu::TextureViewDescriptor { label: Some("visibility.ids.view"), ..Default::default() });
        let path = if compute {
            let copy = features.blended().then(|| depth_copy(device, size, memory)).transpose()?;
            let raster_depth = copy.as_ref().map_or(depth, |c| &c.view);
            let raster = ComputeRaster::new(
                device,
                views,
                scene,
                features,
                (size, layout, options),
                (raster_depth, &ids_view),
                memory,
            )?;
            Path::Compute(Box::new(raster), copy)
        } else {
            Path::Hardware(DepthPrepass::with_ids(device, views, scene, features, layout.triangle_bits)?)
        };
        Ok(Self { path, ids, wrong_id, ids_view, layout })
    }

    /// The compute raster (with [`Raster::Compute`]).
    pub fn compute(&self) -> Option<&ComputeRaster> {
        match &self.path {
            Path::Compute(c, _) => Some(c),
            Path::Hardware(_) => None,
        }
    }

    /// The last frame's IDs, row-major (one sample a pixel only; stalls the GPU).
    pub fn read_ids(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<u32>, GpuError> {
        if self.ids.sample_count() > 1 {
            return Err(GpuError::Config("multisampled IDs cannot be read back".into()));
        }
        let bytes = read_texture(device, queue, &self.ids, wgpu::TextureAspect::All, 4)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Clears and draws depth and IDs.
    pub fn record(&self, r: &mut Recording<'_>, depth: &wgpu::TextureView) {
        match &self.path {
            Path::Hardware(pass) => pass.record_with_ids(r, (depth, &self.ids_view)),
            Path::Compute(raster, copy) => {
                let (encoder, timer, view, scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
                raster.record(encoder, timer, view, scene, &self.ids_view);
                if let Some(c) = copy {
                    let t = timer.begin("visibility.raster.depth_copy", encoder);
                    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("visibility.raster.depth_copy"),
                        color_attachments: &[],
                        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                            view: depth,
                            depth_ops: Some(wgpu::Operations {
                                load: wgpu::LoadOp::Clear(0.0),
                                store: wgpu::StoreOp::Store,
                            }),
                            stencil_ops: None,
                        }),
                        timestamp_writes: t.render_writes(),
                        occlusion_query_set: None,
                        multiview_mask: None,
                    });
                    pass.set_pipeline(&c.pipeline);
                    pass.set_bind_group(0, &c.group, &[]);
                    pass.draw(0..3, 0..1);
                    drop(pass);
                    timer.end(encoder, t);
                }
            }
        }
        if let Some(((x, y), buffer)) = &self.wrong_id {
            r.encoder.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(256), rows_per_image: None },
                },
                wgpu::TexelCopyTextureInfo {
                    texture: &self.ids,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: *x, y: *y, z: 0 },
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            );
        }
    }
}

/// The depth copy: its texture (the compute raster's `R32Float` depth), view and pipeline.
fn depth_copy(device: &wgpu::Device, size: (u32, u32), memory: &mut MemoryReport) -> Result<DepthCopy, GpuError> {
    use wgpu::TextureUsages as U;
    let depth = texture_2d(
        device,
        "visibility.compute_depth",
        size,
        COMPUTE_DEPTH_FORMAT,
        U::STORAGE_BINDING | U::TEXTURE_BINDING,
    );
    memory.add("visibility.compute_depth", size.0 as u64 * size.1 as u64 * 4);
    let view = depth.create_view(&wgpu::TextureViewDescriptor {
        label: Some("visibility.compute_depth.view"),
        ..Default::default()
    });
    let layout = create_layout(device, "visibility.depth_copy.layout", DEPTH_COPY_BINDINGS.groups[0].bindings, &[]);
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("visibility.depth_copy.group"),
        layout: &layout,
        entries: &[view_entry(0, &view)],
    });
    let module = shader_module(device, DEPTH_COPY_BINDINGS.entry, &[])?;
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("visibility.depth_copy"),
        layout: Some(&pipeline_layout(device, "visibility.depth_copy.pipeline_layout", &[&layout])),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[],
        }),
        multiview_mask: None,
        cache: None,
    });
    Ok(DepthCopy { pipeline, group, view })
}
