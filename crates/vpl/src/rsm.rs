//! Reflective shadow maps (RSMs; Dachsbacher and Stamminger 2005): every face of the
//! shadow atlas (a spot caster's one face, a point caster's six) drawn again from the
//! light, into tiles of `rsm_size` texels (32 by default, as TiledLighting11) of three
//! atlases: depth (`Depth32Float`, reversed-Z, the texel's world position), albedo +
//! metallic (8-bit linear: [`RSM_ALBEDO_FORMAT`] says why) and normal + roughness, written
//! by the G-buffer's own shader
//! (`shaders/gbuffer.wgsl`, `fs_rsm`: the material sample unpacked, the scene's material paths and draw kinds), so
//! an RSM texel is exactly what Tiled Deferred's G-buffer would hold seen from the light.
//!
//! Each face is drawn through its own view slot ([`rsm_view_proj`]): the shadow face's view
//! with the face proper's field of view (a cube face's 90 degrees, a spot's outer cone),
//! not the atlas's, which is widened for the filter's border. Through the widened one a
//! point light's six faces overlapped at the cube's seams and counted that flux twice.
//!
//! One 2D texture per target, faces in a grid of tiles (`RsmLayout`): at 32 texels an
//! 8192-texel texture holds 65,536 faces, so no array layers are needed. The faces buffer
//! (`GpuRsmFace`: clip-to-world, the light, the face's solid-angle scale) is what the
//! generation pass reads ([`crate::generate`]); `tiledlight_cull::vpl` is the CPU twin of
//! both. The RSM is drawn only after the casters moved ([`Rsm::update`]), as the shadow
//! faces are, and each face draws only the instances inside its shadow face's frustum
//! (which holds the RSM face's: the shadow atlas's per-face test,
//! `ShadowAtlas::faces_in_view`; [`Rsm::drawn_last`] counts them). Depends on
//! tiledlight-gpu (views, scene, shadow atlas) and tiledlight-cull.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use glam::{Mat4, Vec3};
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::vpl::{GpuRsmFace, RsmFace, RsmLight, RsmTexel, VplConfig};
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::{f16_to_f32, read_texture};
use tiledlight_gpu::scene_gpu::{DrawCount, SceneGpu};
use tiledlight_gpu::scene_raster::{begin_pass, cleared, DepthUse, RasterTargets, SceneRaster};
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::{buffer_zeroed, keyed_module, texture_2d};
use tiledlight_gpu::variants::{GBufferKey, MaterialKey};
use tiledlight_gpu::view::{ViewUniforms, Views};
use tiledlight_gpu::GpuError;

/// Depth format of the RSM (world positions are rebuilt from it: 32-bit float).
pub const RSM_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Albedo + metallic: 8-bit *linear*, unlike the G-buffer's sRGB target 0. Both devices
/// decode unorm exactly (`c / 255`), while sRGB decoding differs between GPUs (lavapipe's
/// was 0.4% off the formula at 0.05), which would keep the GPU's VPLs from equalling the
/// twin's. Indirect light is low-frequency: the coarser dark steps cost nothing visible.
pub const RSM_ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Normal + roughness, as the G-buffer's target 1.
pub const RSM_NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Where the RSM faces lie: a grid of `size`-texel tiles, `per_row` to a row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RsmLayout {
    /// Texels per tile side.
    pub size: u32,
    /// Faces.
    pub faces: u32,
    /// Tiles per row.
    pub per_row: u32,
    /// Rows.
    pub rows: u32,
}

impl RsmLayout {
    /// `faces` tiles of `size` texels in a texture of at most `max_side` texels a side.
    pub fn new(size: u32, faces: u32, max_side: u32) -> Result<Self, GpuError> {
        let fit = (max_side / size.max(1)).max(1);
        let per_row = faces.clamp(1, fit);
        let rows = faces.div_ceil(per_row).max(1);
        if rows > fit || size > max_side {
            return Err(GpuError::Limit {
                what: format!("{faces} reflective shadow map faces of {size}x{size} texels"),
                name: "max_texture_dimension_2d",
                limit: max_side.into(),
                asked: format!("{} texels", rows as u64 * size as u64),
            });
        }
        Ok(Self { size, faces, per_row, rows })
    }
    /// Texture width.
    pub fn width(&self) -> u32 {
        self.per_row * self.size
    }
    /// Texture height.
    pub fn height(&self) -> u32 {
        self.rows * self.size
    }
    /// Top-left texel of face `face`.
    pub fn origin(&self, face: u32) -> [u32; 2] {
        [(face % self.per_row) * self.size, (face / self.per_row) * self.size]
    }
}

/// The index in `lights` of the light behind shadow face `face` of an atlas with `points`
/// point casters (six faces each, first), the spot casters' one face each after them.
pub fn face_light_index(lights: &PackedLights, points: u32, face: u32) -> usize {
    if face < 6 * points {
        (face / 6) as usize
    } else {
        (lights.num_point + face - 6 * points) as usize
    }
}

/// The view and projection an RSM face is drawn through: the shadow face's `view`, and its
/// `proj` narrowed back from the atlas's widened field of view to the face proper (a cube
/// face's 90 degrees; a spot's outer cone), with the same near plane.
///
/// The shadow atlas widens each face so that its filter's border ring holds real depth
/// (`tiledlight_cull::shadow::widened_tan`). An RSM drawn through that projection sees
/// beyond its face: a point light's six faces overlap at the cube's seams, and the flux of
/// the overlap was counted twice (+2.65% of a point light's reflected flux at shadow tile
/// 256, +5.36% at 128, with the 5x5 filter). Through the face proper the six faces tile
/// the sphere of directions exactly, and every RSM texel of a spot is inside its face.
pub fn rsm_view_proj(lights: &PackedLights, points: u32, face: u32, (view, proj): (Mat4, Mat4)) -> (Mat4, Mat4) {
    let index = face_light_index(lights, points, face);
    let tan_half = if index >= lights.num_point as usize {
        let s = &lights.spots[index - lights.num_point as usize];
        s.sin_outer / s.cos_outer
    } else {
        1.0
    };
    // The atlas's projection: reversed-Z, infinite far plane, square; w_axis.z is the near plane.
    (view, Mat4::perspective_infinite_reverse_rh(2.0 * tan_half.atan(), 1.0, proj.w_axis.z))
}

/// The light behind shadow face `face` of an atlas with `points` point casters, as the RSM
/// sees it through the face's RSM `view` and `proj` ([`rsm_view_proj`]): its index in
/// `lights` and the twin's [`RsmLight`].
pub fn face_light(
    lights: &PackedLights,
    points: u32,
    face: u32,
    (view, proj): (Mat4, Mat4),
    cfg: &VplConfig,
) -> (usize, RsmLight) {
    let index = face_light_index(lights, points, face);
    let sh = &lights.shading[index];
    let spot = (index >= lights.num_point as usize).then(|| {
        let s = &lights.spots[index - lights.num_point as usize];
        (Vec3::from(s.direction), s.angle_scale, s.angle_offset)
    });
    // The projection is square with an infinite far plane: x_axis.x = 1 / tan(half field).
    let tan_w = 1.0 / proj.x_axis.x;
    let texel = 2.0 * tan_w / cfg.rsm_size as f32;
    let axis = -Vec3::new(view.x_axis.z, view.y_axis.z, view.z_axis.z);
    let light = RsmLight {
        position: sh.position.into(),
        radius: sh.radius,
        radiance: sh.radiance.into(),
        axis: axis.normalize(),
        texel_sq: texel * texel,
        vpl_radius: sh.radius * cfg.radius_fraction,
        spot,
    };
    (index, light)
}

/// The reflective shadow maps and the pass that draws them.
pub struct Rsm {
    /// Where the faces lie.
    pub layout: RsmLayout,
    /// The settings it was built with.
    pub config: VplConfig,
    depth: wgpu::Texture,
    albedo: wgpu::Texture,
    normal: wgpu::Texture,
    /// Depth as the generation reads it (`texture_depth_2d`).
    pub depth_view: wgpu::TextureView,
    /// Albedo + metallic.
    pub albedo_view: wgpu::TextureView,
    /// Normal + roughness.
    pub normal_view: wgpu::TextureView,
    /// The faces (`array<RsmFace>`).
    pub faces: wgpu::Buffer,
    /// One view slot per face: the face's own projection ([`rsm_view_proj`]), not the
    /// shadow atlas's widened one.
    views: Views,
    /// Pipelines per draw kind and the scene's groups (the G-buffer's shaders).
    raster: SceneRaster,
    shadow_points: u32,
    /// Set by [`Self::update`], cleared by [`Self::record`].
    dirty: AtomicBool,
    /// Per face, the instances inside its frustum (the shadow atlas's test, taken by
    /// [`Self::update`]): a face draws only these.
    in_view: Mutex<Vec<Vec<bool>>>,
    /// What the last [`Self::record`] that drew recorded.
    drawn: Mutex<DrawCount>,
    /// Texture and face-buffer bytes.
    pub memory: MemoryReport,
}

impl Rsm {
    /// The RSM of every face of `atlas`, drawn from view slots of its own (one per face,
    /// [`rsm_view_proj`]). Draws nothing until [`Self::update`].
    pub fn new(
        device: &wgpu::Device,
        scene: &SceneGpu,
        atlas: &ShadowAtlas,
        config: &VplConfig,
    ) -> Result<Self, GpuError> {
        config.validate()?;
        let faces_n = atlas.layout.faces();
        let layout = RsmLayout::new(config.rsm_size, faces_n, device.limits().max_texture_dimension_2d)?;
        let size = (layout.width(), layout.height());
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            // COPY_SRC: tests read the RSM back ([`Self::read_faces`]).
            | wgpu::TextureUsages::COPY_SRC;
        let depth = texture_2d(device, "vpl.rsm.depth", size, RSM_DEPTH_FORMAT, usage);
        let albedo = texture_2d(device, "vpl.rsm.albedo", size, RSM_ALBEDO_FORMAT, usage);
        let normal = texture_2d(device, "vpl.rsm.normal", size, RSM_NORMAL_FORMAT, usage);
        let view = |t: &wgpu::Texture, label: &str| {
            t.create_view(&wgpu::TextureViewDescriptor { label: Some(label), ..Default::default() })
        };
        let faces = buffer_zeroed(
            device,
            "vpl.rsm.faces",
            faces_n.max(1) as u64 * std::mem::size_of::<GpuRsmFace>() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let views = Views::new(device, faces_n);

        // The G-buffer's pipelines, for the RSM's targets (two, no emission: a VPL reflects
        // the light it receives, not what the surface emits).
        let targets = [
            Some(wgpu::ColorTargetState { format: RSM_ALBEDO_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
            Some(wgpu::ColorTargetState { format: RSM_NORMAL_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
        ];
        let materials = MaterialKey::of(&scene.material_features);
        let raster = SceneRaster::materials(
            device,
            "vpl.rsm",
            (&views, scene),
            &[],
            &scene.opaque_kinds(),
            |kind| {
                let key = GBufferKey { alpha_mask: kind.masked, materials, emission: false, extra_test_values: false };
                keyed_module(device, &key)
            },
            &RasterTargets {
                depth: DepthUse::Write,
                depth_format: RSM_DEPTH_FORMAT,
                samples: 1,
                fragment: ("fs_rsm", &targets),
                constants: &[],
            },
        )?;
        let mut memory = MemoryReport::default();
        let texels = size.0 as u64 * size.1 as u64;
        memory.add("vpl.rsm (depth+albedo+normal)", texels * (4 + 4 + 8));
        memory.add("vpl.rsm.faces", faces.size());
        memory.add("vpl.rsm.views", views.slots() as u64 * std::mem::size_of::<ViewUniforms>() as u64);
        Ok(Self {
            layout,
            config: *config,
            depth_view: view(&depth, "vpl.rsm.depth.view"),
            albedo_view: view(&albedo, "vpl.rsm.albedo.view"),
            normal_view: view(&normal, "vpl.rsm.normal.view"),
            depth,
            albedo,
            normal,
            faces,
            views,
            raster,
            shadow_points: atlas.layout.points,
            dirty: AtomicBool::new(false),
            in_view: Mutex::new(Vec::new()),
            drawn: Mutex::new(DrawCount::default()),
            memory,
        })
    }

    /// The lights behind the faces, as last computed by `atlas` (call after the atlas's
    /// own `update`): per face, the light's index, the twin's [`RsmLight`] and the face's
    /// RSM view and projection ([`rsm_view_proj`]).
    pub fn face_lights(&self, atlas: &ShadowAtlas, lights: &PackedLights) -> Vec<(usize, RsmLight, (Mat4, Mat4))> {
        (0..self.layout.faces)
            .map(|f| {
                let vp = rsm_view_proj(lights, self.shadow_points, f, atlas.face_view_proj(f));
                let (i, l) = face_light(lights, self.shadow_points, f, vp, &self.config);
                (i, l, vp)
            })
            .collect()
    }

    /// Takes the casters' current faces from `atlas` (after its own `update` with the same
    /// `lights`): writes the faces buffer and the faces' views; the next [`Self::record`]
    /// redraws the RSM.
    pub fn update(&self, queue: &wgpu::Queue, atlas: &ShadowAtlas, lights: &PackedLights) {
        let s = self.layout.size;
        let faces: Vec<GpuRsmFace> = self
            .face_lights(atlas, lights)
            .iter()
            .enumerate()
            .map(|(f, (_, light, (view, proj)))| {
                self.views.write(queue, f as u32, &ViewUniforms::from_matrices(*view, *proj, proj.w_axis.z, (s, s)));
                GpuRsmFace::new(light, &(*proj * *view), self.layout.origin(f as u32))
            })
            .collect();
        if !faces.is_empty() {
            queue.write_buffer(&self.faces, 0, bytemuck::cast_slice(&faces));
        }
        *self.in_view.lock().expect("rsm visibility") = atlas.faces_in_view();
        self.dirty.store(true, Ordering::Relaxed);
    }

    /// Draw calls and instances the last drawing [`Self::record`] recorded, over every
    /// face (each face draws only the instances inside its frustum).
    pub fn drawn_last(&self) -> DrawCount {
        *self.drawn.lock().expect("rsm draw count")
    }

    /// True when the next [`Self::record`] draws (the casters moved since the last one).
    pub fn is_dirty(&self) -> bool {
        self.dirty.load(Ordering::Relaxed)
    }

    /// Draws every face from its view slot into its tile (`vpl.rsm`), when the casters
    /// moved since the last call: per face only the instances inside its shadow face's
    /// frustum (the shadow atlas's per-face test, as the shadow pass culls; that frustum
    /// holds the RSM face's narrower one, so the texels are those of drawing all).
    /// Returns whether it drew.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, scene: &SceneGpu) -> bool {
        if !self.dirty.swap(false, Ordering::Relaxed) {
            return false;
        }
        let clear = |view| cleared(view, None, wgpu::Color::TRANSPARENT);
        let t = timer.begin("vpl.rsm", encoder);
        {
            let colors = [clear(&self.albedo_view), clear(&self.normal_view)];
            let depth = (&self.depth_view, wgpu::LoadOp::Clear(0.0));
            let mut pass = begin_pass(encoder, "vpl.rsm", &colors, depth, t.render_writes());
            // Group 0 is set per face below.
            self.raster.bind(&mut pass, None, scene);
            let s = self.layout.size;
            let in_view = self.in_view.lock().expect("rsm visibility");
            let mut drawn = DrawCount::default();
            for f in 0..self.layout.faces {
                // Faces not yet updated (never, once `update` ran) draw everything.
                let visible = in_view.get(f as usize).filter(|v| !v.is_empty()).map(Vec::as_slice);
                if visible.is_some_and(|v| !v.contains(&true)) {
                    continue;
                }
                let [x, y] = self.layout.origin(f);
                pass.set_viewport(x as f32, y as f32, s as f32, s as f32, 0.0, 1.0);
                pass.set_scissor_rect(x, y, s, s);
                pass.set_bind_group(0, self.views.bind_group(), &self.views.offsets(f));
                drawn += self.raster.draw(&mut pass, scene, visible, None);
            }
            *self.drawn.lock().expect("rsm draw count") = drawn;
        }
        timer.end(encoder, t);
        true
    }

    /// Reads the RSM back as the CPU twin's faces (texel positions rebuilt from depth
    /// through each face's clip-to-world, albedo `base x (1 - metallic)`). A debug path for tests: it waits for the GPU.
    pub fn read_faces(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        atlas: &ShadowAtlas,
        lights: &PackedLights,
    ) -> Result<Vec<RsmFace>, GpuError> {
        let depth: Vec<f32> =
            bytemuck::pod_collect_to_vec(&read_texture(device, queue, &self.depth, wgpu::TextureAspect::DepthOnly, 4)?);
        let albedo = read_texture(device, queue, &self.albedo, wgpu::TextureAspect::All, 4)?;
        let normal: Vec<u16> =
            bytemuck::pod_collect_to_vec(&read_texture(device, queue, &self.normal, wgpu::TextureAspect::All, 8)?);
        let w = self.layout.width() as usize;
        let s = self.layout.size;
        let unorm = |c: u8| c as f32 / 255.0;
        Ok(self
            .face_lights(atlas, lights)
            .into_iter()
            .enumerate()
            .map(|(f, (_, light, (view, proj)))| {
                let inv = (proj * view).inverse();
                let [ox, oy] = self.layout.origin(f as u32);
                let mut texels = Vec::with_capacity((s * s) as usize);
                for ty in 0..s {
                    for tx in 0..s {
                        let i = (oy + ty) as usize * w + (ox + tx) as usize;
                        let d = depth[i];
                        texels.push((d > 0.0).then(|| {
                            let a = &albedo[4 * i..4 * i + 4];
                            let metallic = a[3] as f32 / 255.0;
                            let n = &normal[4 * i..4 * i + 3];
                            RsmTexel {
                                position: tiledlight_cull::vpl::texel_position(&inv, s, (tx, ty), d),
                                normal: Vec3::new(f16_to_f32(n[0]), f16_to_f32(n[1]), f16_to_f32(n[2])),
                                albedo: Vec3::new(unorm(a[0]), unorm(a[1]), unorm(a[2])) * (1.0 - metallic),
                            }
                        }));
                    }
                }
                RsmFace { size: s, light, texels }
            })
            .collect())
    }
}
