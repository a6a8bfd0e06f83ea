//! A scene on the GPU: merged vertex and index buffers (tangents and the second UV set only
//! when a material needs them), per-instance transforms, materials, material textures (only
//! the slots some material uses: [`MaterialFeatures`]), and the draw list grouped into
//! instanced draws per pipeline kind (opaque/alpha-masked x single/double-sided). Builds the
//! scene bind groups (group 1: instances and materials; group 2: every material's textures
//! in the texture arrays of [`crate::texture_arrays`], one group for the whole scene).
//! Depends on wgpu, tiledlight-scene and tiledlight-cull (layouts, mip chains).

use crate::define::Define;
use std::ops::Range;

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4};
use tiledlight_scene::clusters::{cluster_scene, Cluster};
use tiledlight_scene::{AlphaMode, Material, Scene, TextureRef};

use crate::bindings::{create_layout, Binding, Cond, PassGroup};
use crate::error::GpuError;
use crate::memory::MemoryReport;
use crate::texture_arrays::{ArrayPlan, GpuTextureSlot, ImageUse, MATERIAL_ARRAYS};
use crate::util::{buffer_init, check_storage_binding};
use crate::variants::{MaterialKey, TextureMaps};
use tiledlight_cull::draw_order::DrawOrder;

/// One instance's transforms and material.
///
/// Keep in sync with `shaders/common/scene.wgsl` (`Instance`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    /// Object to world.
    pub model: [[f32; 4]; 4],
    /// Inverse-transpose of the model's 3x3 part, columns padded to vec4.
    pub normal_matrix: [[f32; 4]; 3],
    /// Index into the material buffer.
    pub material: u32,
    /// +1, or -1 when `model` mirrors (negative determinant): normal maps flip the
    /// bitangent with it.
    pub det_sign: f32,
    /// Its mesh's first index in the merged index buffer (the visibility buffer's compute
    /// pass fetches triangles with it).
    pub first_index: u32,
    /// Added to its mesh's indices (the merged vertex buffers).
    pub base_vertex: i32,
}

/// Texture slots of a material, in the order of [`GpuMaterial::uv_rows`],
/// [`GpuMaterial::slots`] and the bits of [`GpuMaterial::textures`]. Keep in step with
/// `shaders/common/scene.wgsl` (`SLOT_*`).
pub const TEXTURE_SLOTS: [&str; 5] = ["base colour", "metallic-roughness", "normal", "occlusion", "emissive"];

/// Material factors, texture flags, texture transforms and where each slot's texture lives
/// (304 bytes).
///
/// Keep in sync with `shaders/common/scene.wgsl` (`Material`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Linear emitted radiance: the emissive factor times its strength.
    pub emissive: [f32; 3],
    /// Perceptual roughness.
    pub roughness: f32,
    /// Metalness.
    pub metallic: f32,
    /// Alpha below which masked materials discard (unused for others).
    pub alpha_cutoff: f32,
    /// glTF `normalTexture.scale`.
    pub normal_scale: f32,
    /// glTF `occlusionTexture.strength`.
    pub occlusion_strength: f32,
    /// Bit k: the material has a texture in slot k ([`TEXTURE_SLOTS`]).
    pub textures: u32,
    /// Bit k: slot k reads texture coordinate set 1.
    pub uv1_sets: u32,
    /// Padding to 16 bytes.
    pub _pad: [u32; 2],
    /// Per slot, its texture transform as two rows of a 2x3 matrix (w unused): identity
    /// for slots without one.
    pub uv_rows: [[f32; 4]; 10],
    /// Per slot, its texture's array, layer, size and sampler (zeros for slots without one).
    pub slots: [GpuTextureSlot; 5],
}

impl GpuMaterial {
    /// The GPU form of `m`, its slots' textures not yet placed ([`GpuMaterial::slots`]
    /// zero: [`SceneGpu::new`] fills them in once the texture arrays are planned).
    pub fn new(m: &Material) -> Self {
        let slots = material_slots(m);
        let mut uv_rows = [[0.0; 4]; 10];
        let (mut textures, mut uv1_sets) = (0, 0);
        for (k, slot) in slots.iter().enumerate() {
            let rows = slot.map(|t| t.transform.rows()).unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
            uv_rows[2 * k] = [rows[0][0], rows[0][1], rows[0][2], 0.0];
            uv_rows[2 * k + 1] = [rows[1][0], rows[1][1], rows[1][2], 0.0];
            if let Some(t) = slot {
                textures |= 1 << k;
                uv1_sets |= u32::from(t.tex_coord == 1) << k;
            }
        }
        let e = m.emissive_strength;
        Self {
            base_color: m.base_color,
            emissive: [m.emissive[0] * e, m.emissive[1] * e, m.emissive[2] * e],
            roughness: m.roughness,
            metallic: m.metallic,
            alpha_cutoff: match m.alpha_mode {
                AlphaMode::Mask { cutoff } => cutoff,
                _ => 0.0,
            },
            normal_scale: m.normal_scale,
            occlusion_strength: m.occlusion_strength,
            textures,
            uv1_sets,
            _pad: [0; 2],
            uv_rows,
            slots: [GpuTextureSlot::default(); 5],
        }
    }
}

/// A material's texture per slot of [`TEXTURE_SLOTS`].
fn material_slots(m: &Material) -> [Option<&TextureRef>; 5] {
    [
        m.base_color_texture.as_ref(),
        m.metallic_roughness_texture.as_ref(),
        m.normal_texture.as_ref(),
        m.occlusion_texture.as_ref(),
        m.emissive_texture.as_ref(),
    ]
}

/// Which material paths the scene's drawn materials need: textures, normal maps and the
/// second UV set are shader defines (`shaders/common/scene.wgsl`) with the bindings and
/// vertex buffers that come with them; the other maps and emission are per-material data
/// (the same kernel shades every mix) that decide the G-buffer's targets. Nothing here is
/// set for a material no instance draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaterialFeatures {
    /// Some material has a texture (`TEXTURES`: group 2, the texture arrays, and the
    /// texture transforms).
    pub textures: bool,
    /// Some material has a metallic-roughness texture.
    pub metallic_roughness: bool,
    /// Some material has a normal map (`NORMAL_MAP`: the tangent vertex buffer).
    pub normal_map: bool,
    /// Some material has an occlusion texture (Tiled Deferred's emission target).
    pub occlusion: bool,
    /// Some material emits (Tiled Deferred's emission target).
    pub emissive: bool,
    /// Some texture reads texture coordinate set 1 (`UV1`: the second UV vertex buffer).
    pub uv1: bool,
}

/// The scene's material paths as the shader key's (`MaterialKey` is pure data in
/// [`crate::variants`]; the conversion lives here so that module imports nothing of this one).
impl MaterialKey {
    /// The key of the scene's material features (maps only with textures).
    pub fn of(f: &MaterialFeatures) -> Self {
        Self { textures: f.textures.then_some(TextureMaps { normal_map: f.normal_map, uv1: f.uv1 }) }
    }
}

impl MaterialFeatures {
    /// The features of the materials `scene`'s instances draw with.
    pub fn of(scene: &Scene) -> Self {
        let mut f = Self::default();
        let mut used = vec![false; scene.materials.len()];
        for inst in &scene.instances {
            if let Some(u) = used.get_mut(inst.material) {
                *u = true;
            }
        }
        for (m, _) in scene.materials.iter().zip(used).filter(|(_, u)| *u) {
            f.textures |= m.texture_refs().next().is_some();
            f.metallic_roughness |= m.metallic_roughness_texture.is_some();
            f.normal_map |= m.normal_texture.is_some();
            f.occlusion |= m.occlusion_texture.is_some();
            f.emissive |= m.is_emissive();
            f.uv1 |= m.uses_uv1();
        }
        f
    }

    /// The shader defines of these features, in `shaders/common/scene.wgsl`'s order.
    pub fn defines(&self) -> Vec<&'static str> {
        [(self.textures, Define::Textures), (self.normal_map, Define::NormalMap), (self.uv1, Define::Uv1)]
            .into_iter()
            .filter_map(|(on, d)| on.then_some(d.name()))
            .collect()
    }

    /// Whether Tiled Deferred's G-buffer needs its emission target (emission and occlusion
    /// reach the deferred shading only through it).
    pub fn emission_target(&self) -> bool {
        self.emissive || self.occlusion
    }

    /// The names of the features that are on, e.g. "normal maps, emission".
    pub fn describe(&self) -> Vec<&'static str> {
        [
            (self.textures, "textures"),
            (self.metallic_roughness, "metallic-roughness maps"),
            (self.normal_map, "normal maps"),
            (self.occlusion, "occlusion maps"),
            (self.emissive, "emission"),
            (self.uv1, "2 UV sets"),
        ]
        .into_iter()
        .filter_map(|(on, d)| on.then_some(d))
        .collect()
    }
}

/// The pipeline kind a draw needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DrawKind {
    /// Alpha-masked (discards in the depth pre-pass).
    pub masked: bool,
    /// No back-face culling.
    pub double_sided: bool,
    /// Alpha-blended: drawn only by the blended path ([`crate::blended`]), never by the
    /// opaque passes or into shadow maps.
    pub blended: bool,
}

/// One instanced indexed draw.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Draw {
    /// Range in the merged index buffer.
    pub indices: Range<u32>,
    /// Added to each index.
    pub base_vertex: i32,
    /// Range in the instance buffer.
    pub instances: Range<u32>,
    /// Material index (selects the texture bind group).
    pub material: usize,
    /// Pipeline kind.
    pub kind: DrawKind,
    /// Its mesh's clusters in [`SceneGpu::clusters`].
    pub clusters: Range<u32>,
}

const POSITIONS: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: 12,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &wgpu::vertex_attr_array![0 => Float32x3],
};

/// Vertex buffer layouts: positions (location 0), normals (1), uvs (2), with
/// [`MaterialFeatures::normal_map`] tangents (3), with [`MaterialFeatures::uv1`] the second
/// uvs (4): one buffer (slot) each, so the depth pre-pass reads positions only and scenes
/// without the optional attributes have no buffer for them (their slots are `None`).
pub fn vertex_layouts(m: &MaterialFeatures) -> [Option<wgpu::VertexBufferLayout<'static>>; 5] {
    [
        Some(POSITIONS),
        Some(wgpu::VertexBufferLayout {
            array_stride: 12,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![1 => Float32x3],
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: 8,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![2 => Float32x2],
        }),
        m.normal_map.then_some(wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![3 => Float32x4],
        }),
        m.uv1.then_some(wgpu::VertexBufferLayout {
            array_stride: 8,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![4 => Float32x2],
        }),
    ]
}

/// The positions-only vertex layout of depth-only draws.
pub const POSITION_LAYOUT: [Option<wgpu::VertexBufferLayout<'static>>; 1] = [Some(POSITIONS)];

/// Group 1 of the scene's raster passes: instances (0) and materials (1)
/// (`shaders/common/scene.wgsl`).
pub const SCENE_BINDINGS: &[Binding] = &[
    Binding::storage(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
    Binding::storage(1, wgpu::ShaderStages::VERTEX_FRAGMENT),
];

/// Group 2 of the scene's raster passes and the visibility buffer's material pass, for
/// scenes with textures (`TEXTURES`): the [`MATERIAL_ARRAYS`] texture arrays
/// (`shaders/common/material_textures.wgsl`), read by fragment and compute stages.
pub const TEXTURE_BINDINGS: &[Binding] = &[
    Binding::texture_array(0, FS),
    Binding::texture_array(1, FS),
    Binding::texture_array(2, FS),
    Binding::texture_array(3, FS),
    Binding::texture_array(4, FS),
    Binding::texture_array(5, FS),
    Binding::texture_array(6, FS),
    Binding::texture_array(7, FS),
];

/// Fragment stages read the textures, and the visibility buffer's compute pass.
const FS: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT.union(wgpu::ShaderStages::COMPUTE);

/// Groups 0 to 2 of a raster pass drawing the scene with `shaders/common/scene.wgsl`: the
/// view, [`SCENE_BINDINGS`] and, when the shader is compiled with `TEXTURES`,
/// [`TEXTURE_BINDINGS`].
pub const SCENE_GROUPS: [PassGroup; 3] = [
    PassGroup::new(0, crate::view::BINDINGS),
    PassGroup::new(1, SCENE_BINDINGS),
    PassGroup::new(2, TEXTURE_BINDINGS).when(Cond::Defined(Define::Textures)),
];

/// Material textures: group 2, one bind group for every material of the scene.
pub struct SceneTextures {
    /// Layout of group 2.
    pub layout: wgpu::BindGroupLayout,
    /// The bind group: the texture arrays (1x1 ones for bindings the scene does not need).
    pub bind_group: wgpu::BindGroup,
    /// Where each image went.
    pub plan: ArrayPlan,
    _textures: Vec<wgpu::Texture>,
}

/// A scene uploaded to the GPU.
pub struct SceneGpu {
    /// Vertex positions.
    pub positions: wgpu::Buffer,
    /// Vertex normals.
    pub normals: wgpu::Buffer,
    /// Vertex uvs.
    pub uvs: wgpu::Buffer,
    /// Vertex tangents, only with [`MaterialFeatures::normal_map`] (meshes without a normal
    /// map hold zeros there: nothing reads them).
    pub tangents: Option<wgpu::Buffer>,
    /// The second uv set, only with [`MaterialFeatures::uv1`] (zeros for meshes without one).
    pub uvs1: Option<wgpu::Buffer>,
    /// The material paths the scene needs.
    pub material_features: MaterialFeatures,
    /// Merged index buffer (u32).
    pub indices: wgpu::Buffer,
    /// Layout of group 1.
    pub layout: wgpu::BindGroupLayout,
    /// Group 1: instances and materials.
    pub bind_group: wgpu::BindGroup,
    /// Group 2, present only when a drawn material has a texture.
    pub textures: Option<SceneTextures>,
    /// Draws sorted by kind.
    pub draws: Vec<Draw>,
    /// Triangles drawn per frame.
    pub triangles: u64,
    /// Triangles of the largest mesh an instance draws (the visibility buffer's ID split).
    pub max_triangles: u32,
    /// Every mesh's clusters of at most `CLUSTER_TRIANGLES` (128) triangles, in mesh order
    /// ([`tiledlight_scene::clusters::cluster_scene`]; [`Draw::clusters`] ranges into it;
    /// `first_triangle` counts slots of [`Self::cluster_triangles`] from the mesh's first
    /// triangle). CPU only: the compute raster uploads what it culls.
    pub clusters: Vec<Cluster>,
    /// Per triangle of the merged index buffer (first index / 3 onwards per mesh), in
    /// cluster order: the triangle's index within its mesh. The index buffer keeps each
    /// mesh's own order, so a triangle's ID is the same in the hardware and the compute
    /// raster. CPU only.
    pub cluster_triangles: Vec<u32>,
    /// The scene's instance index at each slot of the instance buffer (sorted by draw).
    pub instance_order: Vec<usize>,
    /// The instance buffer (group 1, binding 0).
    pub instances: wgpu::Buffer,
    /// The material buffer (group 1, binding 1).
    pub materials: wgpu::Buffer,
    /// Per material: whether it emits or is occlusion-mapped, i.e. writes Tiled Deferred's
    /// emission target (every other material leaves it at its clear value).
    pub material_unlit: Vec<bool>,
    /// World-space bounds of each instance (min, max), in the order of the instance buffer
    /// (what the draws' instance ranges index): shadow faces cull instances with them and
    /// place their near plane just short of the nearest one.
    pub instance_bounds: Vec<(glam::Vec3, glam::Vec3)>,
    /// The instance buffer's own draw order ([`DrawOrder::submission`]): what a pass
    /// draws in when it is given no other order.
    pub submission: DrawOrder,
    /// The casting geometry's BVH for the traced reference's shadow rays: built only by
    /// [`SceneGpu::add_trace`] (a second a million triangles on the CPU), None otherwise.
    pub trace: Option<crate::bvh::GpuBvh>,
    /// Bytes allocated.
    pub memory: MemoryReport,
}

fn normal_matrix(m: &Mat4) -> [[f32; 4]; 3] {
    let n = Mat3::from_mat4(*m).inverse().transpose();
    [n.x_axis.extend(0.0).to_array(), n.y_axis.extend(0.0).to_array(), n.z_axis.extend(0.0).to_array()]
}

impl SceneGpu {
    /// Builds and uploads the BVH of `scene` (the scene this was uploaded from) for the
    /// traced reference, unless it is there already; its bytes join [`Self::memory`].
    pub fn add_trace(&mut self, device: &wgpu::Device, scene: &Scene) -> Result<(), GpuError> {
        if self.trace.is_none() {
            let bvh = crate::bvh::GpuBvh::of_scene(device, scene)?;
            self.memory.extend(&bvh.memory);
            self.trace = Some(bvh);
        }
        Ok(())
    }

    /// Uploads `scene` (validated first).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) -> Result<Self, GpuError> {
        scene.validate().map_err(|e| GpuError::Config(e.to_string()))?;
        let mut memory = MemoryReport::default();
        let material_features = MaterialFeatures::of(scene);
        // Merge meshes.
        let (mut pos, mut nrm, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut tan, mut uv1) = (Vec::<[f32; 4]>::new(), Vec::<[f32; 2]>::new());
        let mut mesh_ranges = Vec::with_capacity(scene.meshes.len());
        let mut mesh_clusters = Vec::with_capacity(scene.meshes.len());
        let mut clusters = Vec::new();
        let mut cluster_triangles = Vec::new();
        for (m, c) in scene.meshes.iter().zip(cluster_scene(scene)) {
            let base_vertex = pos.len() as i32;
            let first = idx.len() as u32;
            pos.extend_from_slice(&m.positions);
            nrm.extend_from_slice(&m.normals);
            uv.extend_from_slice(&m.uvs);
            if material_features.normal_map {
                match m.tangents.is_empty() {
                    true => tan.resize(pos.len(), [0.0; 4]),
                    false => tan.extend_from_slice(&m.tangents),
                }
            }
            if material_features.uv1 {
                match m.uvs1.is_empty() {
                    true => uv1.resize(pos.len(), [0.0; 2]),
                    false => uv1.extend_from_slice(&m.uvs1),
                }
            }
            let start = clusters.len() as u32;
            clusters.extend_from_slice(&c.clusters);
            mesh_clusters.push(start..clusters.len() as u32);
            // The mesh's own order (the hardware's vertex reuse); the clusters name their
            // triangles through the order (measured on the H200: indices in cluster order
            // cost Forward+'s pre-pass 6% on the Figure 9 scene).
            cluster_triangles.extend_from_slice(&c.order);
            idx.extend_from_slice(&m.indices);
            mesh_ranges.push((first..idx.len() as u32, base_vertex));
        }
        // Every one of these is bound as storage (the visibility buffer fetches triangles
        // from them): a scene past the device's binding size is refused by name here, not
        // by a validation error when a pass binds it. Instances share their mesh's
        // vertices, so only the meshes' own sizes count.
        let limits = device.limits();
        let mesh_bytes = [
            ("positions", pos.len() * 12),
            ("normals", nrm.len() * 12),
            ("uvs", uv.len() * 8),
            ("tangents", tan.len() * 16),
            ("second uvs", uv1.len() * 8),
            ("indices", idx.len() * 4),
        ];
        for (what, bytes) in mesh_bytes {
            check_storage_binding(&limits, bytes as u64, || {
                format!(
                    "the scene's {what} ({} vertices, {} triangles in {} meshes)",
                    pos.len(),
                    idx.len() / 3,
                    scene.meshes.len()
                )
            })?;
        }
        // STORAGE too: the visibility buffer's compute pass fetches triangles from them.
        let vertex_usage = wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE;
        let positions = buffer_init(device, "scene.positions", bytemuck::cast_slice(&pos), vertex_usage);
        let normals = buffer_init(device, "scene.normals", bytemuck::cast_slice(&nrm), vertex_usage);
        let uvs = buffer_init(device, "scene.uvs", bytemuck::cast_slice(&uv), vertex_usage);
        let tangents = material_features
            .normal_map
            .then(|| buffer_init(device, "scene.tangents", bytemuck::cast_slice(&tan), vertex_usage));
        let uvs1 =
            material_features.uv1.then(|| buffer_init(device, "scene.uvs1", bytemuck::cast_slice(&uv1), vertex_usage));
        let indices = buffer_init(
            device,
            "scene.indices",
            bytemuck::cast_slice(&idx),
            wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
        );
        memory.add("scene.vertices", (pos.len() * 12 + nrm.len() * 12 + uv.len() * 8) as u64);
        if !tan.is_empty() || !uv1.is_empty() {
            memory.add("scene.vertices.tangents+uv1", (tan.len() * 16 + uv1.len() * 8) as u64);
        }
        memory.add("scene.indices", (idx.len() * 4) as u64);

        let kind_of = |mat: usize| {
            let m = &scene.materials[mat];
            DrawKind {
                masked: matches!(m.alpha_mode, AlphaMode::Mask { .. }),
                double_sided: m.double_sided,
                blended: matches!(m.alpha_mode, AlphaMode::Blend),
            }
        };
        // Sort instances so equal (kind, material, mesh) are consecutive: one instanced draw each.
        let mut order: Vec<usize> = (0..scene.instances.len()).collect();
        order.sort_by_key(|&i| {
            (kind_of(scene.instances[i].material), scene.instances[i].material, scene.instances[i].mesh)
        });
        let mut gpu_instances = Vec::with_capacity(order.len());
        let mut draws: Vec<Draw> = Vec::new();
        let mut triangles = 0u64;
        let mut max_triangles = 0u32;
        for (slot, &i) in order.iter().enumerate() {
            let inst = &scene.instances[i];
            gpu_instances.push(GpuInstance {
                model: inst.transform.to_cols_array_2d(),
                normal_matrix: normal_matrix(&inst.transform),
                material: inst.material as u32,
                det_sign: if inst.transform.determinant() < 0.0 { -1.0 } else { 1.0 },
                first_index: mesh_ranges[inst.mesh].0.start,
                base_vertex: mesh_ranges[inst.mesh].1,
            });
            let (range, base_vertex) = mesh_ranges[inst.mesh].clone();
            max_triangles = max_triangles.max((range.len() / 3) as u32);
            triangles += (range.len() / 3) as u64;
            let slot = slot as u32;
            match draws.last_mut() {
                Some(d)
                    if d.material == inst.material
                        && d.indices == range
                        && d.base_vertex == base_vertex
                        && d.instances.end == slot =>
                {
                    d.instances.end += 1
                }
                _ => draws.push(Draw {
                    indices: range,
                    base_vertex,
                    instances: slot..slot + 1,
                    material: inst.material,
                    kind: kind_of(inst.material),
                    clusters: mesh_clusters[inst.mesh].clone(),
                }),
            }
        }
        // In instance-buffer order (the draws' instance ranges index it).
        let instance_bounds = order
            .iter()
            .map(|&i| {
                let inst = &scene.instances[i];
                let b = scene.meshes[inst.mesh].bounds().transformed(&inst.transform);
                (b.min, b.max)
            })
            .collect();
        let mut gpu_materials: Vec<GpuMaterial> = scene.materials.iter().map(GpuMaterial::new).collect();
        let textures = if material_features.textures {
            let max_layers = device.limits().max_texture_array_layers;
            Some(upload_textures(device, queue, scene, &mut gpu_materials, max_layers, &mut memory)?)
        } else {
            None
        };
        let storage = wgpu::BufferUsages::STORAGE;
        check_storage_binding(&limits, (gpu_instances.len() * size_of::<GpuInstance>()) as u64, || {
            format!("the scene's {} instances", gpu_instances.len())
        })?;
        check_storage_binding(&limits, (gpu_materials.len() * size_of::<GpuMaterial>()) as u64, || {
            format!("the scene's {} materials", gpu_materials.len())
        })?;
        let instance_buf = buffer_init(device, "scene.instances", bytemuck::cast_slice(&gpu_instances), storage);
        let material_buf = buffer_init(device, "scene.materials", bytemuck::cast_slice(&gpu_materials), storage);
        memory.add(
            "scene.instances+materials",
            (gpu_instances.len() * size_of::<GpuInstance>() + gpu_materials.len() * size_of::<GpuMaterial>()) as u64,
        );
        let layout = create_layout(device, "scene.layout", SCENE_BINDINGS, &[]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: instance_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: material_buf.as_entire_binding() },
            ],
        });
        let submission = DrawOrder::submission(&slot_ranges(&draws));
        Ok(Self {
            positions,
            normals,
            uvs,
            tangents,
            uvs1,
            material_features,
            indices,
            layout,
            bind_group,
            textures,
            draws,
            triangles,
            max_triangles,
            clusters,
            cluster_triangles,
            instance_order: order,
            instances: instance_buf,
            materials: material_buf,
            material_unlit: scene.materials.iter().map(|m| m.is_emissive() || m.occlusion_texture.is_some()).collect(),
            submission,
            instance_bounds,
            trace: None,
            memory,
        })
    }

    /// The order that draws the instances nearest `eye` first ([`DrawOrder::front_to_back`]).
    pub fn front_to_back(&self, eye: glam::Vec3) -> DrawOrder {
        DrawOrder::front_to_back(&slot_ranges(&self.draws), &self.instance_bounds, eye)
    }

    /// The pipeline kinds this scene's draws need (blended ones last).
    pub fn kinds(&self) -> Vec<DrawKind> {
        let mut k: Vec<DrawKind> = self.draws.iter().map(|d| d.kind).collect();
        k.dedup();
        k
    }

    /// The opaque and masked kinds: what the pre-pass, G-buffer, shading and shadow passes draw.
    pub fn opaque_kinds(&self) -> Vec<DrawKind> {
        self.kinds().into_iter().filter(|k| !k.blended).collect()
    }

    /// The blended instances as (instance slot, draw index), in slot order: what the
    /// blended path sorts and draws one by one.
    pub fn blended_instances(&self) -> Vec<(u32, usize)> {
        self.draws
            .iter()
            .enumerate()
            .filter(|(_, d)| d.kind.blended)
            .flat_map(|(i, d)| d.instances.clone().map(move |slot| (slot, i)))
            .collect()
    }

    /// Draws instance `slot` of draw `draw` alone (the blended path's sorted order); the
    /// caller binds the textures once ([`Self::bind_textures`]).
    pub fn record_instance(&self, pass: &mut wgpu::RenderPass<'_>, slot: u32, draw: usize) {
        let d = &self.draws[draw];
        pass.draw_indexed(d.indices.clone(), d.base_vertex, slot..slot + 1);
    }

    /// Binds the material textures (group 2) when the scene has textures: one group for
    /// every draw.
    pub fn bind_textures(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let Some(t) = &self.textures {
            pass.set_bind_group(2, &t.bind_group, &[]);
        }
    }

    /// Binds the vertex and index buffers every scene draw reads.
    pub fn bind_geometry(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.positions.slice(..));
        self.bind_attributes(pass);
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }

    /// Binds the vertex buffers past the positions: normals, uvs and, when the scene has
    /// them, tangents and the second uvs (the slots of [`vertex_layouts`]).
    fn bind_attributes(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(1, self.normals.slice(..));
        pass.set_vertex_buffer(2, self.uvs.slice(..));
        if let Some(t) = &self.tangents {
            pass.set_vertex_buffer(3, t.slice(..));
        }
        if let Some(u) = &self.uvs1 {
            pass.set_vertex_buffer(4, u.slice(..));
        }
    }

    /// The vertex buffer layouts of this scene's shading draws ([`vertex_layouts`]).
    pub fn vertex_layouts(&self) -> [Option<wgpu::VertexBufferLayout<'static>>; 5] {
        vertex_layouts(&self.material_features)
    }

    /// True when some draw is alpha-masked.
    pub fn has_alpha_mask(&self) -> bool {
        self.draws.iter().any(|d| d.kind.masked)
    }

    /// Binds vertex/index buffers (`with_attributes`: normals and uvs too) and records the
    /// draws of `kind`, binding the material textures (group 2) first when `bind_textures`.
    pub fn record_draws(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        kind: DrawKind,
        with_attributes: bool,
        bind_textures: bool,
    ) {
        self.record_draws_of(pass, kind, (with_attributes, bind_textures), None, None);
    }

    /// As [`Self::record_draws`], in `order` (the instance buffer's, [`Self::submission`],
    /// when None), drawing only the instances whose slot (instance-buffer index) is set in
    /// `visible` (all when None), in runs of consecutive slots ([`DrawOrder::runs`]).
    /// Returns what it recorded.
    pub fn record_draws_of(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        kind: DrawKind,
        (with_attributes, bind_textures): (bool, bool),
        visible: Option<&[bool]>,
        order: Option<&DrawOrder>,
    ) -> DrawCount {
        let order = order.unwrap_or(&self.submission);
        let mut count = DrawCount::default();
        pass.set_vertex_buffer(0, self.positions.slice(..));
        if with_attributes {
            self.bind_attributes(pass);
        }
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        if bind_textures {
            self.bind_textures(pass);
        }
        for d in order.draws().iter().map(|&d| &self.draws[d as usize]).filter(|d| d.kind == kind) {
            let runs = order.runs(d.instances.clone(), visible);
            if runs.is_empty() {
                continue;
            }
            for r in runs {
                count.calls += 1;
                count.instances += r.len() as u32;
                pass.draw_indexed(d.indices.clone(), d.base_vertex, r);
            }
        }
        count
    }
}

/// Each draw's instance slot range, in draw order (what a [`DrawOrder`] is made over).
fn slot_ranges(draws: &[Draw]) -> Vec<Range<u32>> {
    draws.iter().map(|d| d.instances.clone()).collect()
}

/// What [`SceneGpu::record_draws_of`] recorded: draw calls and the instances they draw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DrawCount {
    /// `draw_indexed` calls (one per run of consecutive visible instance slots).
    pub calls: u32,
    /// Instances drawn.
    pub instances: u32,
}

impl std::ops::AddAssign for DrawCount {
    fn add_assign(&mut self, o: Self) {
        self.calls += o.calls;
        self.instances += o.instances;
    }
}

/// A glTF sampler as the shaders' texture sampling reads it (the sampler part of
/// [`GpuTextureSlot::sampling`]; tests compare the GPU with the CPU twin through it).
pub fn texture_sampling(s: &tiledlight_scene::Sampler) -> tiledlight_cull::texture::Sampling {
    use tiledlight_cull::texture as t;
    use tiledlight_scene::{Filter, Wrap};
    let wrap = |w| match w {
        Wrap::Repeat => t::WRAP_REPEAT,
        Wrap::MirroredRepeat => t::WRAP_MIRROR,
        Wrap::ClampToEdge => t::WRAP_CLAMP,
    };
    t::Sampling {
        wrap: [wrap(s.wrap_u), wrap(s.wrap_v)],
        mag_linear: s.mag == Filter::Linear,
        min_linear: s.min == Filter::Linear,
        mipmap: match s.mipmap {
            None => t::MIPMAP_NONE,
            Some(Filter::Nearest) => t::MIPMAP_NEAREST,
            Some(Filter::Linear) => t::MIPMAP_LINEAR,
        },
    }
}

/// Plans and uploads the texture arrays of every (image, colour space) the materials read
/// (colour slots, base colour and emissive, sRGB; data slots linear), and fills in each
/// material's slots.
fn upload_textures(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    materials: &mut [GpuMaterial],
    max_layers: u32,
    memory: &mut MemoryReport,
) -> Result<SceneTextures, GpuError> {
    let srgb_slot = |k: usize| k == 0 || k == 4;
    let mut uses: Vec<ImageUse> = Vec::new();
    let mut use_image: Vec<usize> = Vec::new();
    let mut by_image: HashMap<(usize, bool), usize> = HashMap::new();
    let mut slot_use: Vec<[Option<usize>; 5]> = Vec::with_capacity(scene.materials.len());
    for m in &scene.materials {
        let mut slots = [None; 5];
        for (k, slot) in material_slots(m).into_iter().enumerate() {
            let Some(t) = slot else { continue };
            let srgb = srgb_slot(k);
            let u = *by_image.entry((t.texture, srgb)).or_insert_with(|| {
                let img = &scene.textures[t.texture];
                uses.push(ImageUse { srgb, width: img.width, height: img.height });
                use_image.push(t.texture);
                uses.len() - 1
            });
            slots[k] = Some(u);
        }
        slot_use.push(slots);
    }
    let plan = ArrayPlan::new(&uses, MATERIAL_ARRAYS, max_layers)?;
    for ((gm, m), slots) in materials.iter_mut().zip(&scene.materials).zip(&slot_use) {
        for (k, (u, t)) in slots.iter().zip(material_slots(m)).enumerate() {
            if let (Some(u), Some(t)) = (u, t) {
                let use_ = uses[*u];
                gm.slots[k] =
                    GpuTextureSlot::new(plan.placements[*u], use_.width, use_.height, &texture_sampling(&t.sampler));
            }
        }
    }
    let (textures, views) = crate::texture_arrays::upload(
        device,
        queue,
        &plan,
        &uses,
        |i| scene.textures[use_image[i]].rgba8.as_slice(),
        memory,
    );
    let layout = create_layout(device, "scene.texture_layout", TEXTURE_BINDINGS, &[]);
    let entries: Vec<wgpu::BindGroupEntry<'_>> = views
        .iter()
        .enumerate()
        .map(|(k, v)| wgpu::BindGroupEntry { binding: k as u32, resource: wgpu::BindingResource::TextureView(v) })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("scene.textures"),
        layout: &layout,
        entries: &entries,
    });
    Ok(SceneTextures { layout, bind_group, plan, _textures: textures })
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![
        tiledlight_cull::struct_layout!(
            GpuInstance,
            "Instance",
            "common/scene.wgsl",
            [model, normal_matrix, material, det_sign, first_index, base_vertex]
        ),
        tiledlight_cull::struct_layout!(
            GpuMaterial,
            "Material",
            "common/scene.wgsl",
            [
                base_color,
                emissive,
                roughness,
                metallic,
                alpha_cutoff,
                normal_scale,
                occlusion_strength,
                textures,
                uv1_sets,
                uv_rows,
                slots
            ]
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::{DrawOrder, MaterialFeatures};

    #[test]
    fn material_key_follows_the_features() {
        let f = MaterialFeatures { textures: true, normal_map: true, emissive: true, ..Default::default() };
        assert_eq!(crate::variants::MaterialKey::of(&f).defines(), f.defines());
        assert_eq!(crate::variants::MaterialKey::of(&MaterialFeatures::default()).defines(), Vec::<&str>::new());
    }

    #[test]
    fn runs_of_visible_slots() {
        let v = [true, true, false, true, false, false, true];
        let one_draw = vec![std::ops::Range { start: 0, end: 7 }];
        let o = DrawOrder::submission(&one_draw);
        assert_eq!(o.runs(0..7, Some(&v)), vec![0..2, 3..4, 6..7]);
        assert_eq!(o.runs(2..3, Some(&v)), vec![]);
        assert_eq!(o.runs(1..4, Some(&v)), vec![1..2, 3..4]);
    }
}
