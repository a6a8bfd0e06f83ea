//! A scene on the GPU: merged vertex and index buffers, per-instance transforms, materials,
//! base-colour textures (only when some material has one), and the draw list grouped into
//! instanced draws per pipeline kind (opaque/alpha-masked x single/double-sided). Builds the
//! scene bind groups (group 1: instances and materials; group 2: a material's texture).
//! Depends on wgpu, tiledlight-scene and tiledlight-cull (layouts).

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4};
use tiledlight_scene::{AlphaMode, Scene};

use crate::bindings::{create_layout, Binding, Cond, PassGroup};
use crate::error::GpuError;
use crate::memory::MemoryReport;
use crate::util::buffer_init;

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
    /// Padding to 16 bytes.
    pub _pad: [u32; 3],
}

/// Material factors.
///
/// Keep in sync with `shaders/common/scene.wgsl` (`Material`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Perceptual roughness.
    pub roughness: f32,
    /// Metalness.
    pub metallic: f32,
    /// Alpha below which masked materials discard (unused for others).
    pub alpha_cutoff: f32,
    /// 1 when the base colour is multiplied by a texture.
    pub has_texture: u32,
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
}

/// Vertex buffer layouts: positions (location 0), normals (1), uvs (2), one buffer each so
/// the depth pre-pass reads positions only.
pub const VERTEX_LAYOUTS: [Option<wgpu::VertexBufferLayout<'static>>; 3] = [
    Some(wgpu::VertexBufferLayout {
        array_stride: 12,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3],
    }),
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
];

/// Group 1 of the scene's raster passes: instances (0) and materials (1)
/// (`shaders/common/scene.wgsl`).
pub const SCENE_BINDINGS: &[Binding] = &[
    Binding::storage(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
    Binding::storage(1, wgpu::ShaderStages::VERTEX_FRAGMENT),
];

/// Group 2 of the scene's raster passes, for scenes with textures: a material's
/// base-colour texture (0) and its sampler (1).
pub const TEXTURE_BINDINGS: &[Binding] = &[
    Binding::texture(0, wgpu::ShaderStages::FRAGMENT, wgpu::TextureSampleType::Float { filterable: true }),
    Binding::sampler(1, wgpu::ShaderStages::FRAGMENT, wgpu::SamplerBindingType::Filtering),
];

/// Groups 0 to 2 of a raster pass drawing the scene with `shaders/common/scene.wgsl`: the
/// view, [`SCENE_BINDINGS`] and, when the shader is compiled with `TEXTURES`,
/// [`TEXTURE_BINDINGS`].
pub const SCENE_GROUPS: [PassGroup; 3] = [
    PassGroup::new(0, crate::view::BINDINGS),
    PassGroup::new(1, SCENE_BINDINGS),
    PassGroup::new(2, TEXTURE_BINDINGS).when(Cond::Defined("TEXTURES")),
];

/// Base-colour textures: group 2, one bind group per material.
pub struct SceneTextures {
    /// Layout of group 2.
    pub layout: wgpu::BindGroupLayout,
    /// Per material (materials without a texture get a 1x1 white one).
    pub bind_groups: Vec<wgpu::BindGroup>,
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
    /// Merged index buffer (u32).
    pub indices: wgpu::Buffer,
    /// Layout of group 1.
    pub layout: wgpu::BindGroupLayout,
    /// Group 1: instances and materials.
    pub bind_group: wgpu::BindGroup,
    /// Group 2, present only when a material has a texture.
    pub textures: Option<SceneTextures>,
    /// Draws sorted by kind.
    pub draws: Vec<Draw>,
    /// Triangles drawn per frame.
    pub triangles: u64,
    /// World-space bounds of each instance (min, max), in the order of the instance buffer
    /// (what the draws' instance ranges index): shadow faces cull instances with them and
    /// place their near plane just short of the nearest one.
    pub instance_bounds: Vec<(glam::Vec3, glam::Vec3)>,
    /// Bytes allocated.
    pub memory: MemoryReport,
}

fn normal_matrix(m: &Mat4) -> [[f32; 4]; 3] {
    let n = Mat3::from_mat4(*m).inverse().transpose();
    [n.x_axis.extend(0.0).to_array(), n.y_axis.extend(0.0).to_array(), n.z_axis.extend(0.0).to_array()]
}

impl SceneGpu {
    /// Uploads `scene` (validated first).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) -> Result<Self, GpuError> {
        scene.validate().map_err(|e| GpuError::Config(e.to_string()))?;
        let mut memory = MemoryReport::default();
        // Merge meshes.
        let (mut pos, mut nrm, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut mesh_ranges = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            let base_vertex = pos.len() as i32;
            let first = idx.len() as u32;
            pos.extend_from_slice(&m.positions);
            nrm.extend_from_slice(&m.normals);
            uv.extend_from_slice(&m.uvs);
            idx.extend_from_slice(&m.indices);
            mesh_ranges.push((first..idx.len() as u32, base_vertex));
        }
        let vertex_usage = wgpu::BufferUsages::VERTEX;
        let positions = buffer_init(device, "scene.positions", bytemuck::cast_slice(&pos), vertex_usage);
        let normals = buffer_init(device, "scene.normals", bytemuck::cast_slice(&nrm), vertex_usage);
        let uvs = buffer_init(device, "scene.uvs", bytemuck::cast_slice(&uv), vertex_usage);
        let indices = buffer_init(device, "scene.indices", bytemuck::cast_slice(&idx), wgpu::BufferUsages::INDEX);
        memory.add("scene.vertices", (pos.len() * 12 + nrm.len() * 12 + uv.len() * 8) as u64);
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
        for (slot, &i) in order.iter().enumerate() {
            let inst = &scene.instances[i];
            gpu_instances.push(GpuInstance {
                model: inst.transform.to_cols_array_2d(),
                normal_matrix: normal_matrix(&inst.transform),
                material: inst.material as u32,
                _pad: [0; 3],
            });
            let (range, base_vertex) = mesh_ranges[inst.mesh].clone();
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
        let gpu_materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                base_color: m.base_color,
                roughness: m.roughness,
                metallic: m.metallic,
                alpha_cutoff: match m.alpha_mode {
                    AlphaMode::Mask { cutoff } => cutoff,
                    _ => 0.0,
                },
                has_texture: m.base_color_texture.is_some() as u32,
            })
            .collect();
        let storage = wgpu::BufferUsages::STORAGE;
        let instance_buf = buffer_init(device, "scene.instances", bytemuck::cast_slice(&gpu_instances), storage);
        let material_buf = buffer_init(device, "scene.materials", bytemuck::cast_slice(&gpu_materials), storage);
        memory.add("scene.instances+materials", (gpu_instances.len() * 128 + gpu_materials.len() * 32) as u64);
        let layout = create_layout(device, "scene.layout", SCENE_BINDINGS, &[]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene.bind_group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: instance_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: material_buf.as_entire_binding() },
            ],
        });
        let textures = if scene.materials.iter().any(|m| m.base_color_texture.is_some()) {
            Some(upload_textures(device, queue, scene, &mut memory))
        } else {
            None
        };
        Ok(Self {
            positions,
            normals,
            uvs,
            indices,
            layout,
            bind_group,
            textures,
            draws,
            triangles,
            instance_bounds,
            memory,
        })
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

    /// Draws instance `slot` of draw `draw` alone (the blended path's sorted order); binds
    /// its material texture (group 2) when the scene has textures.
    pub fn record_instance(&self, pass: &mut wgpu::RenderPass<'_>, slot: u32, draw: usize) {
        let d = &self.draws[draw];
        if let Some(t) = &self.textures {
            pass.set_bind_group(2, &t.bind_groups[d.material], &[]);
        }
        pass.draw_indexed(d.indices.clone(), d.base_vertex, slot..slot + 1);
    }

    /// Binds the vertex and index buffers every scene draw reads.
    pub fn bind_geometry(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.positions.slice(..));
        pass.set_vertex_buffer(1, self.normals.slice(..));
        pass.set_vertex_buffer(2, self.uvs.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }

    /// True when some draw is alpha-masked.
    pub fn has_alpha_mask(&self) -> bool {
        self.draws.iter().any(|d| d.kind.masked)
    }

    /// Binds vertex/index buffers (`with_attributes`: normals and uvs too) and records the
    /// draws of `kind`, switching texture bind groups (group 2) when `bind_textures`.
    pub fn record_draws(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        kind: DrawKind,
        with_attributes: bool,
        bind_textures: bool,
    ) {
        self.record_draws_of(pass, kind, (with_attributes, bind_textures), None);
    }

    /// As [`Self::record_draws`], drawing only the instances whose slot (instance-buffer
    /// index) is set in `visible`, in runs of consecutive slots (all when None).
    pub fn record_draws_of(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        kind: DrawKind,
        (with_attributes, bind_textures): (bool, bool),
        visible: Option<&[bool]>,
    ) {
        pass.set_vertex_buffer(0, self.positions.slice(..));
        if with_attributes {
            pass.set_vertex_buffer(1, self.normals.slice(..));
            pass.set_vertex_buffer(2, self.uvs.slice(..));
        }
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        for d in self.draws.iter().filter(|d| d.kind == kind) {
            let runs = match visible {
                None => vec![d.instances.clone()],
                Some(v) => visible_runs(d.instances.clone(), v),
            };
            if runs.is_empty() {
                continue;
            }
            if bind_textures {
                if let Some(t) = &self.textures {
                    pass.set_bind_group(2, &t.bind_groups[d.material], &[]);
                }
            }
            for r in runs {
                pass.draw_indexed(d.indices.clone(), d.base_vertex, r);
            }
        }
    }
}

/// The runs of consecutive slots of `slots` set in `visible`.
fn visible_runs(slots: Range<u32>, visible: &[bool]) -> Vec<Range<u32>> {
    let mut runs: Vec<Range<u32>> = Vec::new();
    for s in slots {
        if !visible[s as usize] {
            continue;
        }
        match runs.last_mut() {
            Some(r) if r.end == s => r.end += 1,
            _ => runs.push(s..s + 1),
        }
    }
    runs
}

fn mip_chain(width: u32, height: u32, rgba: &[u8]) -> Vec<(u32, u32, Vec<u8>)> {
    let mut levels = vec![(width, height, rgba.to_vec())];
    let mut img = image::RgbaImage::from_raw(width, height, rgba.to_vec()).expect("validated size");
    let (mut w, mut h) = (width, height);
    while w > 1 || h > 1 {
        w = (w / 2).max(1);
        h = (h / 2).max(1);
        img = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
        levels.push((w, h, img.as_raw().clone()));
    }
    levels
}

fn upload_textures(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    memory: &mut MemoryReport,
) -> SceneTextures {
    let layout = create_layout(device, "scene.texture_layout", TEXTURE_BINDINGS, &[]);
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("scene.sampler"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        anisotropy_clamp: 1,
        ..Default::default()
    });
    let make = |label: &str, w: u32, h: u32, rgba: &[u8], memory: &mut MemoryReport| {
        let levels = mip_chain(w, h, rgba);
        let tex = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: levels.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (level, (lw, lh, data)) in levels.iter().enumerate() {
            memory.add("scene.textures", data.len() as u64);
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &tex,
                    mip_level: level as u32,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                data,
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(lw * 4), rows_per_image: Some(*lh) },
                wgpu::Extent3d { width: *lw, height: *lh, depth_or_array_layers: 1 },
            );
        }
        tex
    };
    let mut textures: Vec<wgpu::Texture> = scene
        .textures
        .iter()
        .map(|t| make(&format!("scene.texture.{}", t.name), t.width, t.height, &t.rgba8, memory))
        .collect();
    let white_index = textures.len();
    textures.push(make("scene.texture.white", 1, 1, &[255; 4], memory));
    let views: Vec<wgpu::TextureView> = textures.iter().map(|t| t.create_view(&Default::default())).collect();
    let bind_groups = scene
        .materials
        .iter()
        .map(|m| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(&format!("scene.material.{}", m.name)),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(
                            &views[m.base_color_texture.unwrap_or(white_index)],
                        ),
                    },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&sampler) },
                ],
            })
        })
        .collect();
    SceneTextures { layout, bind_groups, _textures: textures }
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![
        tiledlight_cull::struct_layout!(GpuInstance, "Instance", "common/scene.wgsl", [model, normal_matrix, material]),
        tiledlight_cull::struct_layout!(
            GpuMaterial,
            "Material",
            "common/scene.wgsl",
            [base_color, roughness, metallic, alpha_cutoff, has_texture]
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::visible_runs;

    #[test]
    fn runs_of_visible_slots() {
        let v = [true, true, false, true, false, false, true];
        assert_eq!(visible_runs(0..7, &v), vec![0..2, 3..4, 6..7]);
        assert_eq!(visible_runs(2..3, &v), vec![]);
        assert_eq!(visible_runs(1..4, &v), vec![1..2, 3..4]);
    }
}
