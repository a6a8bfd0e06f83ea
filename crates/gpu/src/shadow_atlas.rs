//! The shadow atlas of shadow-casting point and spot lights, shared by both methods and the
//! brute-force reference: one depth `texture_depth_2d_array` whose tiles hold each point
//! caster's six cube faces (one row) and each spot caster's one face
//! (`tiledlight_cull::shadow`, whose module doc numbers the steps), the faces' matrices
//! for the lookup (`shaders/common/shadow.wgsl`), a comparison sampler, and the pass that
//! renders the faces.
//!
//! Each face is a view of the frame ([`crate::view::Views`], slot `first_slot + face`)
//! drawn by the depth pre-pass's shaders and scene bind groups into the atlas format
//! ([`DepthPrepass::for_target`]), with the viewport and scissor on its tile. Only what
//! moved is drawn: a face is re-rendered when its light's position, radius, direction or
//! cone changed since it was last drawn ([`ShadowAtlas::update`]); the scene's geometry
//! is static for a renderer's life (a new scene builds a new renderer), so a still frame
//! renders no face. The atlas exists only when some light casts a shadow
//! ([`crate::features::Features::shadows`]). Depends on [`crate::depth_prepass`],
//! [`crate::view`], [`crate::features`], tiledlight-cull's `shadow` module.

use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::shadow::{self, AtlasLayout, ShadowFormat, ShadowOptions};

use crate::depth_prepass::{DepthPrepass, DepthTarget};
use crate::error::GpuError;
use crate::features::Features;
use crate::memory::MemoryReport;
use crate::readback::read_texture_layer;
use crate::scene_gpu::SceneGpu;
use crate::scene_raster::begin_pass;
use crate::timer::GpuTimer;
use crate::util::{buffer_zeroed, shader_module};
use crate::view::{ViewUniforms, Views};

/// The wgpu format of `format`.
pub fn wgpu_format(format: ShadowFormat) -> wgpu::TextureFormat {
    match format {
        ShadowFormat::Depth16 => wgpu::TextureFormat::Depth16Unorm,
        ShadowFormat::Depth32 => wgpu::TextureFormat::Depth32Float,
    }
}

/// One shadow face as the lookup reads it. 80 bytes.
///
/// Keep in sync with `shaders/common/lights.wgsl` (`ShadowFace`); `cargo xtask validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShadowFace {
    /// World to clip (reversed-Z, infinite far, widened field of view).
    pub world_to_clip: [[f32; 4]; 4],
    /// Atlas coordinates (0..1) of the tile's top-left corner.
    pub uv_origin: [f32; 2],
    /// Atlas layer.
    pub layer: u32,
    /// World size of one texel per unit of view depth.
    pub texel: f32,
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(
        GpuShadowFace,
        "ShadowFace",
        "common/lights.wgsl",
        [world_to_clip, uv_origin, layer, texel]
    )]
}

/// What a caster's faces were last drawn for: its position, radius and (spots) direction
/// and cone, bit for bit.
type CasterKey = [u32; 8];

fn caster_key(lights: &PackedLights, i: usize) -> CasterKey {
    let s = &lights.shading[i];
    let spot = (i >= lights.num_point as usize).then(|| lights.spots[i - lights.num_point as usize]);
    let (d, c, si) = spot.map_or(([0.0; 3], 0.0, 0.0), |sp| (sp.direction, sp.cos_outer, sp.sin_outer));
    let b = |x: f32| x.to_bits();
    [b(s.position[0]), b(s.position[1]), b(s.position[2]), b(s.radius), b(d[0]), b(d[1]), b(d[2]), b(c) ^ b(si)]
}

/// What [`ShadowAtlas::update`] left to draw, and what the last recorded frame drew.
struct AtlasState {
    /// Per face, the view and projection it was last computed with.
    matrices: Vec<(glam::Mat4, glam::Mat4)>,
    /// Per face, the instances (by instance slot) it draws: inside its frustum and, unless
    /// the frame has no radius cutoff, within the light's radius.
    visible: Vec<Vec<bool>>,
    /// Per face, the instances inside its frustum, whatever their distance (what the VPLs'
    /// reflective shadow maps draw: [`ShadowAtlas::faces_in_view`]).
    in_view: Vec<Vec<bool>>,
    /// Per caster (points, then spots), the key its faces were computed for.
    keys: Vec<Option<CasterKey>>,
    /// Faces to draw in the next recorded frame.
    dirty: Vec<bool>,
    /// Faces drawn by the last recorded frame.
    drawn_last: u32,
}

/// The atlas, its faces and the pass that draws them.
pub struct ShadowAtlas {
    /// Where the faces lie.
    pub layout: AtlasLayout,
    /// Tile size, filter and format.
    pub options: ShadowOptions,
    texture: wgpu::Texture,
    /// The whole atlas, as the lookup samples it (`texture_depth_2d_array`).
    pub sample_view: wgpu::TextureView,
    /// One view per layer, as a render pass writes it.
    layer_views: Vec<wgpu::TextureView>,
    /// The comparison sampler of the lookup (linear: a hardware 2x2 comparison per tap).
    pub sampler: wgpu::Sampler,
    /// The faces (`array<ShadowFace>`).
    pub faces: wgpu::Buffer,
    depth: DepthPrepass,
    clear: wgpu::RenderPipeline,
    /// World bounds of the scene's instances by instance slot (faces cull them; near planes
    /// stop short of them).
    bounds: Vec<(Vec3, Vec3)>,
    /// Cull instances beyond the light's radius (false for the no-cutoff reference, whose
    /// lights reach past it).
    radius_cull: bool,
    /// View slot of face 0.
    first_slot: u32,
    state: Mutex<AtlasState>,
    /// Atlas and face buffer bytes.
    pub memory: MemoryReport,
}

impl ShadowAtlas {
    /// The atlas for `layout` casters with `options`, drawing with `views` slots from
    /// `first_slot` on. Draws nothing yet: [`Self::update`] marks the faces to draw.
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        layout: AtlasLayout,
        options: ShadowOptions,
        first_slot: u32,
    ) -> Result<Self, GpuError> {
        if first_slot + layout.faces() > views.slots() {
            return Err(GpuError::Config(format!(
                "{} shadow faces need view slots {first_slot}.. but the frame has {}",
                layout.faces(),
                views.slots()
            )));
        }
        let format = wgpu_format(options.format);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow.atlas"),
            size: wgpu::Extent3d {
                width: layout.width(),
                height: layout.height(),
                depth_or_array_layers: layout.layers,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            // COPY_SRC: tests read faces back ([`Self::read_layer`]).
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let sample_view = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("shadow.atlas.sample_view"),
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layer_views = (0..layout.layers)
            .map(|l| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    label: Some(&format!("shadow.atlas.layer{l}")),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: l,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow.sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            // Reversed-Z: lit where the receiver's depth is at least the stored one.
            compare: Some(wgpu::CompareFunction::GreaterEqual),
            ..Default::default()
        });
        let faces = buffer_zeroed(
            device,
            "shadow.faces",
            layout.faces() as u64 * std::mem::size_of::<GpuShadowFace>() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let depth = DepthPrepass::for_target(
            device,
            views,
            scene,
            features,
            DepthTarget { label: "shadow.atlas", format, samples: 1 },
        )?;
        let module = shader_module(device, "shadow_clear.wgsl", &[])?;
        let clear = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow.clear"),
            layout: Some(&crate::util::pipeline_layout(device, "shadow.clear.layout", &[])),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let mut memory = MemoryReport::default();
        memory.add("shadow.atlas", layout.bytes(options.format.bytes()));
        memory.add("shadow.faces", faces.size());
        let casters = (layout.points + layout.spots) as usize;
        let faces_n = layout.faces() as usize;
        let state = AtlasState {
            matrices: vec![(glam::Mat4::IDENTITY, glam::Mat4::IDENTITY); faces_n],
            visible: vec![Vec::new(); faces_n],
            in_view: vec![Vec::new(); faces_n],
            keys: vec![None; casters],
            dirty: vec![false; faces_n],
            drawn_last: 0,
        };
        Ok(Self {
            layout,
            options,
            texture,
            sample_view,
            layer_views,
            sampler,
            faces,
            depth,
            clear,
            bounds: scene.instance_bounds.clone(),
            radius_cull: features.method.cutoff,
            first_slot,
            state: Mutex::new(state),
            memory,
        })
    }

    /// Atlas coordinates of one texel and of one tile.
    pub fn texel_and_tile_uv(&self) -> ([f32; 2], [f32; 2]) {
        let (w, h) = (self.layout.width() as f32, self.layout.height() as f32);
        let t = self.layout.tile as f32;
        ([1.0 / w, 1.0 / h], [t / w, t / h])
    }

    /// Takes the casters' current positions and directions from `lights` (the lights as
    /// uploaded, casters first in each kind): every caster that moved (or was never drawn)
    /// gets new face matrices and view uniforms, and its faces are drawn by the next
    /// recorded frame. Errors if `lights` has other casters than the atlas was built for.
    pub fn update(&self, queue: &wgpu::Queue, views: &Views, lights: &PackedLights) -> Result<(), GpuError> {
        let l = &self.layout;
        if (lights.shadow_points, lights.shadow_spots) != (l.points, l.spots) {
            return Err(GpuError::Config(format!(
                "the lights have {} point + {} spot casters; the shadow atlas was built for {} + {}",
                lights.shadow_points, lights.shadow_spots, l.points, l.spots
            )));
        }
        let (tile, filter) = (l.tile, self.options.filter);
        let (w, h) = (l.width() as f32, l.height() as f32);
        let mut state = self.state.lock().expect("shadow atlas state");
        let casters = (0..l.points as usize).chain((0..l.spots as usize).map(|s| lights.num_point as usize + s));
        for (c, i) in casters.enumerate() {
            let key = caster_key(lights, i);
            if state.keys[c] == Some(key) {
                continue;
            }
            state.keys[c] = Some(key);
            let sh = &lights.shading[i];
            let pos = Vec3::from(sh.position);
            let nearest = shadow::nearest_bounds(pos, &self.bounds);
            let mut faces = Vec::new();
            if c < l.points as usize {
                let tan_w = shadow::widened_tan(1.0, tile, filter);
                let near = shadow::shadow_near(sh.radius, nearest, tan_w);
                let texel = shadow::texel_per_depth(tan_w, tile);
                for f in 0..6 {
                    let (view, proj) = shadow::point_face_view_proj(pos, near, f, tile, filter);
                    faces.push((l.point_face(c as u32, f), view, proj, texel));
                }
            } else {
                let sp = &lights.spots[i - lights.num_point as usize];
                let sc = (sp.sin_outer, sp.cos_outer);
                let tan_w = shadow::widened_tan(sc.0 / sc.1, tile, filter);
                let near = shadow::shadow_near(sh.radius, nearest, tan_w);
                let (view, proj) = shadow::spot_view_proj(pos, Vec3::from(sp.direction), near, sc, tile, filter)?;
                let texel = shadow::texel_per_depth(tan_w, tile);
                faces.push((l.spot_face((c - l.points as usize) as u32), view, proj, texel));
            }
            for (face, view, proj, texel) in faces {
                let near = proj.w_axis.z;
                let r = l.rect(face);
                let g = GpuShadowFace {
                    world_to_clip: (proj * view).to_cols_array_2d(),
                    uv_origin: [r.x as f32 / w, r.y as f32 / h],
                    layer: r.layer,
                    texel,
                };
                let at = face as u64 * std::mem::size_of::<GpuShadowFace>() as u64;
                queue.write_buffer(&self.faces, at, bytemuck::bytes_of(&g));
                views.write(
                    queue,
                    self.first_slot + face,
                    &ViewUniforms::from_matrices(view, proj, near, (tile, tile)),
                );
                state.matrices[face as usize] = (view, proj);
                let m = proj * view;
                let (radius, radius_cull) = (sh.radius, self.radius_cull);
                let in_view: Vec<bool> = self.bounds.iter().map(|&b| shadow::box_in_face(&m, b)).collect();
                state.visible[face as usize] = self
                    .bounds
                    .iter()
                    .zip(&in_view)
                    .map(|(&(lo, hi), &seen)| seen && (!radius_cull || (pos.clamp(lo, hi) - pos).length() <= radius))
                    .collect();
                state.in_view[face as usize] = in_view;
                state.dirty[face as usize] = true;
            }
        }
        Ok(())
    }

    /// Per face, the instances (by instance slot) inside its frustum as last computed by
    /// [`Self::update`], at any distance from the light (the shadow pass itself also leaves
    /// out those beyond the light's radius). The VPLs' reflective shadow maps draw these:
    /// an instance out of a face's frustum writes no texel of it, so leaving it out changes
    /// no texel, while one beyond the radius may still show (unlit) where nothing nearer
    /// is, and such texels weigh in their VPL block's position and normal.
    pub fn faces_in_view(&self) -> Vec<Vec<bool>> {
        self.state.lock().expect("shadow atlas state").in_view.clone()
    }

    /// Face `face`'s world-to-view and view-to-clip matrices as last computed (tests
    /// project with them; the lookup reads their product from the faces buffer).
    pub fn face_view_proj(&self, face: u32) -> (glam::Mat4, glam::Mat4) {
        self.state.lock().expect("shadow atlas state").matrices[face as usize]
    }

    /// Faces drawn by the last recorded frame (0 for a still frame after the first).
    pub fn faces_drawn_last_frame(&self) -> u32 {
        self.state.lock().expect("shadow atlas state").drawn_last
    }

    /// Draws the faces marked by [`Self::update`], one render pass per atlas layer that has
    /// any (`shadow.atlas` for layer 0, `shadow.atlas.layerN` after): each face's tile is
    /// cleared (a layer whose every face is redrawn is cleared by the pass), then the scene
    /// is drawn from the face's view. Records nothing when no face moved.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, views: &Views, scene: &SceneGpu) {
        let mut state = self.state.lock().expect("shadow atlas state");
        let l = &self.layout;
        let mut drawn = 0;
        for (layer, target) in self.layer_views.iter().enumerate() {
            let faces: Vec<u32> =
                (0..l.faces()).filter(|&f| state.dirty[f as usize] && l.rect(f).layer == layer as u32).collect();
            if faces.is_empty() {
                continue;
            }
            let all = (0..l.faces()).filter(|&f| l.rect(f).layer == layer as u32).count() == faces.len();
            let label = if layer == 0 { "shadow.atlas".to_string() } else { format!("shadow.atlas.layer{layer}") };
            let t = timer.begin(&label, encoder);
            {
                let load = if all { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load };
                let mut pass = begin_pass(encoder, &label, &[], (target, load), t.render_writes());
                for &f in &faces {
                    let r = l.rect(f);
                    pass.set_viewport(r.x as f32, r.y as f32, r.size as f32, r.size as f32, 0.0, 1.0);
                    pass.set_scissor_rect(r.x, r.y, r.size, r.size);
                    if !all {
                        pass.set_pipeline(&self.clear);
                        pass.draw(0..3, 0..1);
                    }
                    self.depth.draw(
                        &mut pass,
                        (views, self.first_slot + f),
                        scene,
                        Some(&state.visible[f as usize]),
                        None,
                    );
                    state.dirty[f as usize] = false;
                }
            }
            timer.end(encoder, t);
            drawn += faces.len() as u32;
        }
        state.drawn_last = drawn;
    }

    /// The atlas texture.
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// Reads layer `layer` back as depth values in [0, 1], row-major (tests compare it
    /// with a ray-cast depth per texel; a debug path, it waits for the GPU).
    pub fn read_layer(&self, device: &wgpu::Device, queue: &wgpu::Queue, layer: u32) -> Result<Vec<f32>, GpuError> {
        let aspect = wgpu::TextureAspect::DepthOnly;
        let bytes = self.options.format.bytes();
        let raw = read_texture_layer(device, queue, (&self.texture, layer), aspect, bytes)?;
        Ok(match self.options.format {
            ShadowFormat::Depth16 => {
                raw.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0).collect()
            }
            ShadowFormat::Depth32 => bytemuck::pod_collect_to_vec(&raw),
        })
    }
}
