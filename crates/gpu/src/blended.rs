//! Alpha-blended geometry, the same passes for both methods (TiledLighting11's
//! "Alpha-Blended Geometry"; Tiled Deferred uses this forward path after its compute
//! shading, as the sample does). Exists only when the scene has blended materials
//! ([`Features::blended`]): no blended depth, grid, pipeline or layer otherwise.
//!
//! The steps (the frame plan's `BlendedDepth`, `BlendedCull`, `BlendedShade`, in
//! tiledlight-frame, which calls `record_depth`, `record_cull` and `record_shade`):
//! 1. **Depth.** The blended draws, depth-only, into a depth buffer of their own cleared to
//!    0 (`blended.depth`): per sample, the nearest blended surface. It is tested against the
//!    opaque depth where the culling kernel reads both buffers (a blended sample counts
//!    only in front of the opaque one), which needs no copy of the opaque buffer (a
//!    multisampled depth buffer cannot be copied).
//! 2. **Culling** (tiled methods): `LightCulling::blended` into a light grid of its own, one
//!    list per tile: the range runs from the nearest blended depth to the farthest opaque
//!    depth behind a blended sample (infinitely far over the sky); a tile without blended
//!    samples gets an empty list. CPU twin: `tiledlight_cull::cull_tiles_blended`.
//! 3. **Shading** (`blended.wgsl`): each blended instance drawn alone, back to front by the
//!    view depth of its bounds' centre (sorted on the CPU each frame; triangles within an
//!    instance and intersecting instances are not sorted), lit from both sides with the
//!    shared BRDF over its tile's blended list (brute force: every light), written with
//!    premultiplied alpha ("over") into a transparent layer cleared to 0, depth-tested
//!    against the opaque depth without writing. With MSAA the layer is multisampled and
//!    resolved.
//! 4. **Composite** (`blended_composite.wgsl`): `hdr = layer.rgb + (1 - layer.a) hdr`.
//!
//! With clusters of the whole frustum as the frame's light grid
//! ([`Features::frustum_clusters`]) steps 1 and 2 do not exist: a cluster lists every light
//! reaching its part of the frustum, surface or not, so step 3 reads the frame's own grid
//! at the blended fragment's depth slice (Olsson et al.'s point that clusters serve
//! transparency).
//!
//! With [`BlendMode::WeightedOit`] step 3 draws in instance order into an accumulation
//! target (the layer: premultiplied colour and coverage times a depth weight, added) and
//! a revealage target (multiplied by `1 - alpha`), and step 4 composites their ratio:
//! McGuire and Bavoil's approximation of "over" without a sort.
//!    Without MSAA this equals drawing each surface over the opaque image; with MSAA the
//!    layer's samples are averaged before compositing, which differs from per-sample
//!    compositing only where the opaque colour varies inside a pixel.
//!
//! Depends on [`crate::depth_prepass`], [`crate::culling`], [`crate::scene_gpu`],
//! [`crate::shadow_atlas`], [`crate::features`], [`crate::view`].

use crate::define::Define;
use crate::handles::{Depth, Hdr};
use crate::recording::Recording;
use std::sync::Mutex;

use glam::{Mat4, Vec3};
use tiledlight_cull::TileGrid;

use crate::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use crate::culling::{CullOptions, LightCulling};
use crate::depth_prepass::{DepthPrepass, DepthTarget, DEPTH_FORMAT};
use crate::error::GpuError;
use crate::features::{BlendMode, Features};
use crate::light_buffers::LightBuffers;
use crate::light_grid::{GridStatus, LightGrid};
use crate::lights_group::{LightsGroup, LIGHTS_GROUP};
use crate::memory::MemoryReport;
use crate::scene_gpu::{DrawKind, SceneGpu, SCENE_GROUPS};
use crate::scene_raster::{begin_pass, cleared, DepthUse, RasterTargets, SceneRaster};
use crate::shadow_atlas::ShadowAtlas;
use crate::timer::GpuTimer;
use crate::tonemap::HDR_FORMAT;
use crate::util::{keyed_module, pipeline_layout, texture_2d_msaa};
use crate::variants::{BlendedKey, CompositeKey, LightLoopKey, MaterialKey, ShaderKey};
use crate::view::Views;

const FS: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT;

/// The bindings of the blended shading pass (`shaders/blended.wgsl`, over lists): the
/// scene's groups, then group 3 as Forward+'s shading pass binds it ([`LIGHTS_GROUP`]):
/// shading lights, the lighting uniform, spots, unless `BRUTE_FORCE` the blended light grid
/// and its indices (with `CLUSTERED` the frame's clustered grid), with `SHADOWS` the atlas.
pub const BLENDED_BINDINGS: PassBindings = PassBindings {
    entry: "blended.wgsl",
    source: file!(),
    groups: &[SCENE_GROUPS[0], SCENE_GROUPS[1], SCENE_GROUPS[2], PassGroup::new(3, LIGHTS_GROUP)],
};

/// [`BLENDED_BINDINGS`] for the entry over every light (`shaders/blended_brute_force.wgsl`).
pub const BLENDED_BRUTE_FORCE_BINDINGS: PassBindings =
    PassBindings { entry: "blended_brute_force.wgsl", ..BLENDED_BINDINGS };

/// The bindings of the composite (`shaders/blended_composite.wgsl`): the layer (0), and
/// with `WBOIT` the revealage (1).
pub const COMPOSITE_BINDINGS: PassBindings = PassBindings {
    entry: "blended_composite.wgsl",
    source: file!(),
    groups: &[PassGroup::new(
        0,
        &[
            Binding::texture(0, FS, wgpu::TextureSampleType::Float { filterable: false }),
            Binding::texture(1, FS, wgpu::TextureSampleType::Float { filterable: false })
                .when(Cond::Defined(Define::Wboit)),
        ],
    )],
};

/// Format of the weighted blended OIT's revealage target (the product of `1 - alpha`).
pub const REVEALAGE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

/// The blended path's passes and resources.
pub struct BlendedPath {
    /// The blended depth (none when frustum clusters serve the blended geometry).
    pub depth: Option<BlendedDepth>,
    /// The blended geometry's culling and light grid (tiled methods, unless frustum
    /// clusters serve it).
    pub culling: Option<LightCulling>,
    /// The blended shading reads the frame's clustered grid (rebound when it grows).
    reads_frame_grid: bool,
    /// The shading's pipelines per blended draw kind and the scene's groups.
    raster: SceneRaster,
    lights_group: LightsGroup,
    /// The transparent layer (resolved), premultiplied; with weighted blended OIT, its
    /// accumulation target.
    pub layer: wgpu::Texture,
    layer_view: wgpu::TextureView,
    layer_msaa: Option<(wgpu::Texture, wgpu::TextureView)>,
    /// Weighted blended OIT's revealage target (resolved, and multisampled with MSAA).
    revealage: Option<(wgpu::TextureView, Option<wgpu::TextureView>)>,
    mode: BlendMode,
    composite: wgpu::RenderPipeline,
    composite_group: wgpu::BindGroup,
    /// Per blended instance: slot, draw index, world centre of its bounds.
    instances: Vec<(u32, usize, Vec3)>,
    /// Scratch of the per-frame sort (view depth, index into `instances`), kept to avoid a
    /// per-frame allocation.
    order: Mutex<Vec<(f32, usize)>>,
    /// Bytes allocated (blended depth, layer; the grid's).
    pub memory: MemoryReport,
    /// The blended grid's header last read by [`Self::grow_if_dropped`], until taken
    /// ([`Self::take_status`]): what a frame loop reports as dropped blended lights.
    polled: Option<GridStatus>,
}

/// The blended geometry's own depth buffer and the pass drawing it (step 1).
pub struct BlendedDepth {
    /// The blended depth buffer (tests read it back).
    pub texture: wgpu::Texture,
    /// The nearest blended depth per sample (0 where none).
    pub view: wgpu::TextureView,
    pass: DepthPrepass,
}

/// What the blended path reads from the frame.
pub struct BlendedInputs<'a> {
    /// The views (group 0).
    pub views: &'a Views,
    /// The scene.
    pub scene: &'a SceneGpu,
    /// Lights and the `Lighting` uniform.
    pub lights: (&'a LightBuffers, &'a wgpu::Buffer),
    /// What the frame models.
    pub features: &'a Features,
    /// The tiling and culling options (tiled methods cull blended geometry with them).
    pub cull: (TileGrid, CullOptions),
    /// The opaque depth buffer.
    pub opaque_depth: Depth<'a>,
    /// The shadow atlas, when lights cast shadows.
    pub shadows: Option<&'a ShadowAtlas>,
    /// The frame's light grid, read instead of lists of its own when it is frustum
    /// clusters ([`Features::frustum_clusters`]).
    pub frame_grid: Option<&'a LightGrid>,
}

impl BlendedPath {
    /// Grows the blended light grid when its last finished frame dropped lights (the grid
    /// was full): between frames, without waiting (`wait`: read the last frame's header,
    /// stalling, as single renders and tests do). Returns true when it grew.
    pub fn grow_if_dropped(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        wait: bool,
    ) -> Result<bool, GpuError> {
        let Some(c) = &mut self.culling else { return Ok(false) };
        let status = if wait { Some(c.grid.status(device, queue)?) } else { c.grid.poll_status() };
        let Some(status) = status else { return Ok(false) };
        self.polled = Some(status);
        match c.grid.growth(status.needed()) {
            Some(capacity) if !status.complete() => {
                c.grid.grow(device, queue, capacity);
                self.lights_group.rebind(device, &c.grid);
                for (category, bytes) in c.grid.memory().entries {
                    self.memory.set(&category, bytes);
                }
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// Rebinds the frame's clustered grid after it grew (nothing when the path has lists of
    /// its own).
    pub fn frame_grid_grew(&mut self, device: &wgpu::Device, grid: &LightGrid) {
        if self.reads_frame_grid {
            self.lights_group.rebind(device, grid);
        }
    }

    /// Builds the blended path for `inp` (the features must have blended kinds).
    pub fn new(device: &wgpu::Device, inp: BlendedInputs<'_>) -> Result<Self, GpuError> {
        let BlendedInputs { views, scene, lights, features, cull: (grid, options), opaque_depth, shadows, frame_grid } =
            inp;
        let frame_grid = match (features.frustum_clusters, frame_grid) {
            (false, _) => None,
            (true, Some(g)) => Some(g),
            (true, None) => {
                return Err(GpuError::Config("blended geometry over frustum clusters needs the frame's grid".into()))
            }
        };
        if !features.blended() {
            return Err(GpuError::Config("the blended path needs blended geometry".into()));
        }
        let samples = features.msaa;
        let size = (grid.width, grid.height);
        use wgpu::TextureUsages as U;
        // COPY_SRC (single-sampled only: a multisampled texture cannot be copied): tests read
        // it back.
        let copy = if samples == 1 { U::COPY_SRC } else { U::empty() };
        let depth = match frame_grid {
            Some(_) => None,
            None => {
                let texture = texture_2d_msaa(
                    device,
                    "blended.depth",
                    size,
                    DEPTH_FORMAT,
                    samples,
                    U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | copy,
                );
                let view = texture.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("blended.depth.view"),
                    ..Default::default()
                });
                let target = DepthTarget { label: "blended.depth", format: DEPTH_FORMAT, samples };
                let pass = DepthPrepass::for_kinds(device, views, scene, (features, &features.blended_kinds), target)?;
                Some(BlendedDepth { texture, view, pass })
            }
        };
        let culling = match &depth {
            Some(d) if features.method.tiled => {
                Some(LightCulling::blended(device, views, (opaque_depth.view, &d.view), lights, grid, options)?)
            }
            _ => None,
        };
        // Shading pipelines.
        let wboit = features.blend_mode == BlendMode::WeightedOit;
        let lights_key = match (features.method.is_reference(), frame_grid) {
            // The references' blended surfaces: every light, with the cutoff or none (the
            // traced reference's unshadowed: its rays are traced for the opaque surface
            // only; docs/ACCURACY.md).
            (true, _) => LightLoopKey::Every { cutoff: features.method.cutoff },
            (false, Some(_)) => LightLoopKey::Clusters,
            (false, None) => LightLoopKey::TileLists { half_z: false },
        };
        if matches!(lights_key, LightLoopKey::Every { .. }) {
            let n = lights.0.packed.len();
            let what = format!("the reference's blended surfaces, every one of {n} lights");
            crate::error::check_cpu_loop_limit(device, n as u64, &what)?;
        }
        let key = BlendedKey {
            spots: features.spot_lights,
            shadows: features.shadows.is_some(),
            materials: MaterialKey::of(&features.materials),
            lights: lights_key,
            wboit,
        };
        let defines = key.defines();
        let lights_layout = create_layout(device, "blended.lights_layout", BLENDED_BINDINGS.group(3), &defines);
        let grid = culling.as_ref().map(|c| &c.grid).or(frame_grid).map(|g| (g, false));
        let lights_group = LightsGroup::new(
            device,
            (lights_layout, "blended.lights"),
            lights,
            features.spot_lights,
            shadows,
            grid,
            None,
        );
        let module = keyed_module(device, &key)?;
        // Premultiplied "over": dst = src + (1 - src.a) dst, for colour and coverage alike.
        let over = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        };
        // Weighted blended OIT: accumulation adds, revealage multiplies by (1 - alpha).
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let reveal = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::Zero,
            dst_factor: wgpu::BlendFactor::OneMinusSrc,
            operation: wgpu::BlendOperation::Add,
        };
        let target_over = [Some(wgpu::ColorTargetState {
            format: HDR_FORMAT,
            blend: Some(wgpu::BlendState { color: over, alpha: over }),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let target_oit = [
            Some(wgpu::ColorTargetState {
                format: HDR_FORMAT,
                blend: Some(wgpu::BlendState { color: add, alpha: add }),
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: REVEALAGE_FORMAT,
                blend: Some(wgpu::BlendState { color: reveal, alpha: reveal }),
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
        let target: &[Option<wgpu::ColorTargetState>] = if wboit { &target_oit } else { &target_over };
        // One shader for every kind (its alpha is blended, not tested).
        let raster = SceneRaster::materials(
            device,
            "blended.shade",
            (views, scene),
            &[lights_group.layout()],
            &features.blended_kinds,
            |_| Ok(module.clone()),
            &RasterTargets {
                depth: DepthUse::Test,
                depth_format: DEPTH_FORMAT,
                samples,
                fragment: ("fs_main", target),
                constants: &features.light_constants(),
            },
        )?;
        // The layer.
        let layer =
            texture_2d_msaa(device, "blended.layer", size, HDR_FORMAT, 1, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let layer_view =
            layer.create_view(&wgpu::TextureViewDescriptor { label: Some("blended.layer.view"), ..Default::default() });
        let layer_msaa = (samples > 1).then(|| {
            let t = texture_2d_msaa(device, "blended.layer_msaa", size, HDR_FORMAT, samples, U::RENDER_ATTACHMENT);
            let v = t.create_view(&wgpu::TextureViewDescriptor {
                label: Some("blended.layer_msaa.view"),
                ..Default::default()
            });
            (t, v)
        });
        let revealage = wboit.then(|| {
            let usage = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING;
            let t = texture_2d_msaa(device, "blended.revealage", size, REVEALAGE_FORMAT, 1, usage);
            let v = t.create_view(&wgpu::TextureViewDescriptor {
                label: Some("blended.revealage.view"),
                ..Default::default()
            });
            let ms = (samples > 1).then(|| {
                let t = texture_2d_msaa(
                    device,
                    "blended.revealage_msaa",
                    size,
                    REVEALAGE_FORMAT,
                    samples,
                    U::RENDER_ATTACHMENT,
                );
                t.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("blended.revealage_msaa.view"),
                    ..Default::default()
                })
            });
            (v, ms)
        });
        let (composite, composite_group) = composite_pipeline(device, &layer_view, revealage.as_ref().map(|r| &r.0))?;
        let instances = scene
            .blended_instances()
            .into_iter()
            .map(|(slot, draw)| {
                let (lo, hi) = scene.instance_bounds[slot as usize];
                (slot, draw, (lo + hi) * 0.5)
            })
            .collect::<Vec<_>>();
        let mut memory = MemoryReport::default();
        let px = size.0 as u64 * size.1 as u64;
        if depth.is_some() {
            memory.add("blended.depth", px * samples as u64 * 4);
        }
        let with_msaa = if samples > 1 { 1 + samples as u64 } else { 1 };
        memory.add("blended.layer", px * 8 * with_msaa);
        if wboit {
            memory.add("blended.revealage", px * 2 * with_msaa);
        }
        if let Some(c) = &culling {
            memory.extend(&c.memory);
        }
        let order = Mutex::new(Vec::with_capacity(instances.len()));
        Ok(Self {
            reads_frame_grid: frame_grid.is_some(),
            depth,
            culling,
            raster,
            lights_group,
            layer,
            layer_view,
            layer_msaa,
            revealage,
            mode: features.blend_mode,
            composite,
            composite_group,
            instances,
            order,
            memory,
            polled: None,
        })
    }

    /// The blended light grid's header that [`Self::grow_if_dropped`] read last (a finished
    /// frame's, before any growth), once: None when none was read since the last call.
    pub fn take_status(&mut self) -> Option<GridStatus> {
        self.polled.take()
    }

    /// Step 1: the blended depth of view slot `view` (nothing when frustum clusters serve
    /// the blended geometry: the plan has no such step then).
    pub fn record_depth(&self, r: &mut Recording<'_>) {
        let (encoder, timer, view, scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let Some(depth) = &self.depth else { return };
        let t = timer.begin("blended.depth", encoder);
        {
            let target = (&depth.view, wgpu::LoadOp::Clear(0.0));
            let mut pass = begin_pass(encoder, "blended.depth", &[], target, t.render_writes());
            depth.pass.draw(&mut pass, view, scene, None, None);
        }
        timer.end(encoder, t);
    }

    /// Step 2: the blended lists (tiled methods).
    pub fn record_cull(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, view: (&Views, u32)) {
        if let Some(c) = &self.culling {
            c.record(encoder, timer, view, "blended.cull");
        }
    }

    /// Steps 3 and 4: the blended instances back to front as seen by `world_to_view` into
    /// the layer (depth-tested against `opaque_depth`), then the layer over `hdr`.
    pub fn record_shade(&self, r: &mut Recording<'_>, world_to_view: &Mat4, opaque_depth: Depth<'_>, hdr: Hdr<'_>) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let (opaque_depth, hdr) = (opaque_depth.view, hdr.view);
        let mut order = self.order.lock().expect("blended sort scratch");
        order.clear();
        // View space looks down -Z: the view depth is -z; farthest first. Weighted blended
        // OIT needs no order: instance order.
        order.extend(self.instances.iter().enumerate().map(|(i, (_, _, c))| (world_to_view.transform_point3(*c).z, i)));
        if self.mode == BlendMode::Sorted {
            order.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let t = timer.begin("blended.shade", encoder);
        {
            let layer = match &self.layer_msaa {
                Some((_, v)) => cleared(v, Some(&self.layer_view), wgpu::Color::TRANSPARENT),
                None => cleared(&self.layer_view, None, wgpu::Color::TRANSPARENT),
            };
            // Revealage starts at 1: nothing covers the opaque image yet.
            let reveal = self.revealage.as_ref().map(|(v, ms)| match ms {
                Some(m) => cleared(m, Some(v), wgpu::Color::WHITE),
                None => cleared(v, None, wgpu::Color::WHITE),
            });
            let colors = [layer, reveal.flatten()];
            let n = if self.revealage.is_some() { 2 } else { 1 };
            let target = (opaque_depth, wgpu::LoadOp::Load);
            let mut pass = begin_pass(encoder, "blended.shade", &colors[..n], target, t.render_writes());
            self.raster.bind(&mut pass, Some((views, view)), scene);
            pass.set_bind_group(3, &self.lights_group.group, &[]);
            scene.bind_geometry(&mut pass);
            scene.bind_textures(&mut pass);
            let mut current: Option<DrawKind> = None;
            for &(_, i) in order.iter() {
                let (slot, draw, _) = self.instances[i];
                let kind = scene.draws[draw].kind;
                if current != Some(kind) {
                    if let Some(p) = self.raster.pipeline(kind) {
                        pass.set_pipeline(p);
                    }
                    current = Some(kind);
                }
                scene.record_instance(&mut pass, slot, draw);
            }
        }
        timer.end(encoder, t);
        let t = timer.begin("blended.composite", encoder);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("blended.composite"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: hdr,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: t.render_writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.composite);
            pass.set_bind_group(0, &self.composite_group, &[]);
            pass.draw(0..3, 0..1);
        }
        timer.end(encoder, t);
    }

    /// Blended instances (drawn one by one each frame).
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// The pipeline constants the blended shading's pipelines were built with (tests: a
    /// setting that must not change the image, the early-outs' ablation, took effect).
    pub fn constants(&self) -> &[(String, f64)] {
        self.raster.constants()
    }

    /// How the layer is composited (the renderer's settings' `blend`).
    pub fn mode(&self) -> BlendMode {
        self.mode
    }
}

/// The composite pipeline and its bind group over `layer` (and, for weighted blended OIT,
/// `revealage`).
fn composite_pipeline(
    device: &wgpu::Device,
    layer: &wgpu::TextureView,
    revealage: Option<&wgpu::TextureView>,
) -> Result<(wgpu::RenderPipeline, wgpu::BindGroup), GpuError> {
    let key = CompositeKey { wboit: revealage.is_some() };
    let layout = create_layout(device, "blended.composite.layout", COMPOSITE_BINDINGS.group(0), &key.defines());
    let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(layer) }];
    if let Some(r) = revealage {
        entries.push(wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(r) });
    }
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("blended.composite"),
        layout: &layout,
        entries: &entries,
    });
    let module = keyed_module(device, &key)?;
    let pl = pipeline_layout(device, "blended.composite.pipeline_layout", &[&layout]);
    // hdr.rgb = layer.rgb + (1 - layer.a) hdr.rgb; the HDR image's alpha is kept.
    let blend = wgpu::BlendState {
        color: wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        },
        alpha: wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::Zero,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        },
    };
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("blended.composite"),
        layout: Some(&pl),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: HDR_FORMAT,
                blend: Some(blend),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    Ok((pipeline, group))
}
