//! glTF 2.0 loading (.gltf with external or embedded buffers, and .glb) into a
//! [`Scene`]: triangle meshes (strips and fans converted, `KHR_mesh_quantization`
//! attributes dequantised), the node hierarchy's transforms, metallic-roughness materials
//! in full (base colour, metallic-roughness, normal, occlusion and emissive textures as
//! PNG/JPEG, their samplers, texture coordinate sets 0 and 1, `KHR_texture_transform`,
//! `KHR_materials_emissive_strength`; tangents from the file or MikkTSpace),
//! KHR_lights_punctual point and spot lights, and the first perspective camera.
//! Every problem becomes a [`SceneError`] naming the file and what is wrong; nothing in
//! a malformed file may panic. Depends on the gltf and image crates, glam,
//! tiledlight-cull and this crate's model and error modules.

mod accessor;
mod data;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use gltf::accessor::Dimensions;
use gltf::mesh::{Mode, Semantic};
use tiledlight_cull::Light;

use crate::error::SceneError;
use crate::model::{
    Aabb, AlphaMode, CameraDesc, Filter, Instance, Material, Mesh, Sampler, Scene, Texture, TextureRef, UvTransform,
    Wrap,
};
use accessor::Attr;
use data::{load_buffers, resolve_uri, UriTarget};

/// Extensions this loader reads beyond those the gltf crate validates (the crate
/// rejects a file that lists one of these in `extensionsRequired`).
pub const LOADER_EXTENSIONS: &[&str] = &["KHR_mesh_quantization"];

/// Loads a glTF 2.0 file (`.gltf` or `.glb`) into a validated [`Scene`].
///
/// `threshold` sets the radius of lights without a `range` (see
/// [`tiledlight_cull::light::radius_from_threshold`]); lights with a `range` use it as
/// their radius. The default scene (or the first, or else every root node) is
/// instantiated; each primitive becomes a [`Mesh`] (mirrored instances get a copy with
/// flipped winding). Missing normals are computed flat (as glTF requires), missing UVs
/// are zero, non-indexed primitives get indices. Directional lights and lights that
/// emit nothing are skipped: a tiled renderer has no use for them. TEXCOORD_1 is read
/// when a texture of the primitive's material uses it, TANGENT when the material has a
/// normal map (generated with MikkTSpace when the file has none).
///
/// Errors name the file and the problem: unreadable files, malformed JSON or GLB,
/// missing or short buffers, unsupported primitive modes, out-of-range indices, NaN
/// data, undecodable or missing images, and scenes that fail [`Scene::validate`].
pub fn load_gltf(path: &Path, threshold: f32) -> Result<Scene, SceneError> {
    if !threshold.is_finite() || threshold <= 0.0 {
        return Err(SceneError::InvalidArgument(format!(
            "{}: light threshold {threshold} must be finite and positive",
            path.display()
        )));
    }
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io { path: path.to_owned(), source })?;
    let fail = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    let gltf = parse(&bytes).map_err(|e| fail(describe_gltf_error(e)))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&gltf.document, base, gltf.blob.clone()).map_err(fail)?;
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let mut loader = Loader {
        doc: &gltf.document,
        base: base.to_owned(),
        buffers,
        scene: Scene {
            name,
            meshes: Vec::new(),
            materials: Vec::new(),
            textures: Vec::new(),
            instances: Vec::new(),
            lights: Vec::new(),
            camera: None,
            bounds: Aabb::empty(),
        },
        threshold,
        mesh_cache: HashMap::new(),
        material_cache: HashMap::new(),
        texture_cache: HashMap::new(),
    };
    loader.load_nodes().map_err(fail)?;
    let mut scene = loader.scene;
    scene.bounds = scene.compute_bounds();
    scene.validate().map_err(|e| match e {
        SceneError::InvalidScene { problem, .. } => fail(problem),
        other => other,
    })?;
    Ok(scene)
}

/// Parses and validates as `gltf::Gltf::from_slice` does, except that the extensions of
/// [`LOADER_EXTENSIONS`] may be required.
fn parse(bytes: &[u8]) -> Result<gltf::Gltf, gltf::Error> {
    let mut g = gltf::Gltf::from_slice_without_validation(bytes)?;
    let mut json = g.document.as_json().clone();
    json.extensions_required.retain(|e| !LOADER_EXTENSIONS.contains(&e.as_str()));
    g.document = gltf::Document::from_json(json)?;
    Ok(g)
}

fn describe_gltf_error(e: gltf::Error) -> String {
    match e {
        gltf::Error::Deserialize(e) => format!("malformed glTF JSON: {e}"),
        gltf::Error::Binary(e) => format!("malformed GLB container: {e}"),
        gltf::Error::Validation(_) => format!("glTF does not validate: {e}"),
        other => format!("cannot parse glTF: {other}"),
    }
}

/// Key of a loaded primitive: (mesh, primitive, mirrored).
type PrimitiveKey = (usize, usize, bool);

struct Loader<'a> {
    doc: &'a gltf::Document,
    base: PathBuf,
    buffers: Vec<Vec<u8>>,
    scene: Scene,
    threshold: f32,
    mesh_cache: HashMap<PrimitiveKey, usize>,
    /// glTF material index (None = the default material) to scene material.
    material_cache: HashMap<Option<usize>, usize>,
    /// glTF image index to scene texture.
    texture_cache: HashMap<usize, usize>,
}

fn node_label(node: &gltf::Node<'_>) -> String {
    match node.name() {
        Some(n) => format!("node {} '{n}'", node.index()),
        None => format!("node {}", node.index()),
    }
}

impl Loader<'_> {
    /// Walks the chosen scene depth-first in document order, composing transforms.
    fn load_nodes(&mut self) -> Result<(), String> {
        let doc = self.doc;
        let roots: Vec<gltf::Node<'_>> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                // A file without scenes is a library of nodes: show every root.
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                doc.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        let mut visited = vec![false; doc.nodes().len()];
        let mut stack: Vec<(gltf::Node<'_>, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            let label = node_label(&node);
            // A node reached twice would be a cycle (endless) or a shared child; both
            // are invalid glTF, and a cycle must not hang the loader.
            if std::mem::replace(&mut visited[node.index()], true) {
                return Err(format!("{label} is reached twice: the node hierarchy is not a tree"));
            }
            let local = Mat4::from_cols_array_2d(&node.transform().matrix());
            let world = parent * local;
            if !world.is_finite() {
                return Err(format!("{label} has a non-finite world transform"));
            }
            if let Some(mesh) = node.mesh() {
                self.add_mesh_instances(&mesh, world).map_err(|e| format!("{label}: {e}"))?;
            }
            if let Some(light) = node.light() {
                self.add_light(&light, world).map_err(|e| format!("{label}: {e}"))?;
            }
            if let Some(camera) = node.camera() {
                self.add_camera(&camera, world);
            }
            let children: Vec<gltf::Node<'_>> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok(())
    }

    fn add_mesh_instances(&mut self, mesh: &gltf::Mesh<'_>, world: Mat4) -> Result<(), String> {
        let mirrored = world.determinant() < 0.0;
        let primitive_count = mesh.primitives().len();
        for prim in mesh.primitives() {
            let material = self.material(&prim.material())?;
            let key = (mesh.index(), prim.index(), mirrored);
            let mesh_index = match self.mesh_cache.get(&key) {
                Some(&i) => i,
                None => {
                    let mut name = mesh.name().map_or_else(|| format!("mesh {}", mesh.index()), str::to_owned);
                    if primitive_count > 1 {
                        name = format!("{name} primitive {}", prim.index());
                    }
                    let mut m = self.load_primitive(&prim, name.clone(), material).map_err(|e| {
                        format!("mesh {} '{}' primitive {}: {e}", mesh.index(), mesh.name().unwrap_or(""), prim.index())
                    })?;
                    if mirrored {
                        // A mirroring transform turns counter-clockwise triangles
                        // clockwise; flip them so front faces survive culling.
                        for t in m.indices.chunks_exact_mut(3) {
                            t.swap(1, 2);
                        }
                        m.name = format!("{name} (mirrored)");
                    }
                    self.scene.meshes.push(m);
                    let i = self.scene.meshes.len() - 1;
                    self.mesh_cache.insert(key, i);
                    i
                }
            };
            self.scene.instances.push(Instance { mesh: mesh_index, material, transform: world });
        }
        Ok(())
    }

    /// Loads one primitive with the attributes its scene material `material` reads.
    fn load_primitive(&self, prim: &gltf::Primitive<'_>, name: String, material: usize) -> Result<Mesh, String> {
        let pos_acc = prim.get(&Semantic::Positions).ok_or("has no POSITION attribute")?;
        let flat = accessor::read_f32(&pos_acc, &self.buffers, Dimensions::Vec3, Attr::Position)
            .map_err(|e| format!("POSITION: {e}"))?;
        let positions: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let n = positions.len();
        if let Some(v) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(format!("POSITION {v} is not finite ({:?})", positions[v]));
        }
        let normals = match prim.get(&Semantic::Normals) {
            Some(acc) => {
                let flat = accessor::read_f32(&acc, &self.buffers, Dimensions::Vec3, Attr::Direction)
                    .map_err(|e| format!("NORMAL: {e}"))?;
                if flat.len() != 3 * n {
                    return Err(format!("NORMAL has {} elements but POSITION has {n}", flat.len() / 3));
                }
                let mut normals = Vec::with_capacity(n);
                for (v, c) in flat.chunks_exact(3).enumerate() {
                    let nrm = Vec3::new(c[0], c[1], c[2]);
                    if !nrm.is_finite() {
                        return Err(format!("NORMAL {v} is not finite ({nrm})"));
                    }
                    // Exporters write zero normals for degenerate vertices; any unit
                    // vector serves there.
                    normals.push(nrm.normalize_or(Vec3::Y).to_array());
                }
                Some(normals)
            }
            None => None,
        };
        let mat = &self.scene.materials[material];
        let uvs = self.read_uvs(prim, 0, n)?.unwrap_or_else(|| vec![[0.0, 0.0]; n]);
        let uvs1 = if mat.uses_uv1() {
            self.read_uvs(prim, 1, n)?.ok_or("its material reads TEXCOORD_1, which it does not have")?
        } else {
            Vec::new()
        };
        // Tangents only for a normal map, and only with the normals they belong to: with
        // flat normals (no NORMAL) the file's tangents would not match, so they are
        // generated after the normals.
        let file_tangents = match (&mat.normal_texture, prim.get(&Semantic::Tangents), &normals) {
            (Some(_), Some(acc), Some(_)) => Some(self.read_tangents(&acc, n)?),
            _ => None,
        };
        let normal_map_set = mat.normal_texture.map(|t| t.tex_coord);
        let raw_indices = match prim.indices() {
            Some(acc) => accessor::read_indices(&acc, &self.buffers).map_err(|e| format!("indices: {e}"))?,
            None => (0..n as u32).collect(),
        };
        if let Some(k) = raw_indices.iter().position(|&i| i as usize >= n) {
            return Err(format!("index {k} is {} but there are only {n} vertices (out of range)", raw_indices[k]));
        }
        let indices = triangulate(prim.mode(), &raw_indices)?;
        let mut mesh = Mesh { name, positions, uvs, uvs1, indices, ..Mesh::default() };
        match normals {
            Some(normals) => mesh.normals = normals,
            None => flat_normals(&mut mesh),
        }
        match (file_tangents, normal_map_set) {
            (Some(t), _) => mesh.tangents = t,
            (None, Some(set)) => mesh.generate_tangents(set)?,
            (None, None) => {}
        }
        Ok(mesh)
    }

    /// TEXCOORD_`set` as `n` finite pairs, or None when the primitive has no such set.
    fn read_uvs(&self, prim: &gltf::Primitive<'_>, set: u32, n: usize) -> Result<Option<Vec<[f32; 2]>>, String> {
        let Some(acc) = prim.get(&Semantic::TexCoords(set)) else {
            return Ok(None);
        };
        let what = format!("TEXCOORD_{set}");
        let flat = accessor::read_f32(&acc, &self.buffers, Dimensions::Vec2, Attr::TexCoord)
            .map_err(|e| format!("{what}: {e}"))?;
        if flat.len() != 2 * n {
            return Err(format!("{what} has {} elements but POSITION has {n}", flat.len() / 2));
        }
        if let Some(v) = flat.iter().position(|c| !c.is_finite()) {
            return Err(format!("{what} {} is not finite", v / 2));
        }
        Ok(Some(flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect()))
    }

    /// TANGENT as `n` unit xyz vectors with w = +1 or -1 (normalised here: quantised and
    /// exported tangents are only approximately unit; a zero one gets +x).
    fn read_tangents(&self, acc: &gltf::Accessor<'_>, n: usize) -> Result<Vec<[f32; 4]>, String> {
        let flat = accessor::read_f32(acc, &self.buffers, Dimensions::Vec4, Attr::Direction)
            .map_err(|e| format!("TANGENT: {e}"))?;
        if flat.len() != 4 * n {
            return Err(format!("TANGENT has {} elements but POSITION has {n}", flat.len() / 4));
        }
        let mut out = Vec::with_capacity(n);
        for (v, c) in flat.chunks_exact(4).enumerate() {
            if !c.iter().all(|x| x.is_finite()) {
                return Err(format!("TANGENT {v} is not finite ({c:?})"));
            }
            let t = Vec3::new(c[0], c[1], c[2]).normalize_or(Vec3::X);
            out.push([t.x, t.y, t.z, if c[3] < 0.0 { -1.0 } else { 1.0 }]);
        }
        Ok(out)
    }

    fn material(&mut self, mat: &gltf::Material<'_>) -> Result<usize, String> {
        if let Some(&i) = self.material_cache.get(&mat.index()) {
            return Ok(i);
        }
        let label = match (mat.index(), mat.name()) {
            (Some(i), Some(n)) => format!("material {i} '{n}'"),
            (Some(i), None) => format!("material {i}"),
            (None, _) => "the default material".to_owned(),
        };
        let pbr = mat.pbr_metallic_roughness();
        let with_label = |e: String| format!("{label}: {e}");
        let info_ref = |this: &mut Self, info: Option<gltf::texture::Info<'_>>, slot: &str| match info {
            Some(info) => {
                let transform = info.texture_transform().map(|t| {
                    (UvTransform { offset: t.offset(), rotation: t.rotation(), scale: t.scale() }, t.tex_coord())
                });
                this.texture_ref(&info.texture(), info.tex_coord(), transform)
                    .map(Some)
                    .map_err(|e| format!("{slot} texture: {e}"))
            }
            None => Ok(None),
        };
        let base_color_texture = info_ref(self, pbr.base_color_texture(), "base colour").map_err(with_label)?;
        let metallic_roughness_texture =
            info_ref(self, pbr.metallic_roughness_texture(), "metallic-roughness").map_err(with_label)?;
        let emissive_texture = info_ref(self, mat.emissive_texture(), "emissive").map_err(with_label)?;
        let (normal_texture, normal_scale) = match mat.normal_texture() {
            Some(t) => {
                let transform = raw_texture_transform(t.extension_value("KHR_texture_transform"))
                    .map_err(|e| with_label(format!("normal texture: {e}")))?;
                let r = self
                    .texture_ref(&t.texture(), t.tex_coord(), transform)
                    .map_err(|e| with_label(format!("normal texture: {e}")))?;
                (Some(r), t.scale())
            }
            None => (None, 1.0),
        };
        let (occlusion_texture, occlusion_strength) = match mat.occlusion_texture() {
            Some(t) => {
                let transform = raw_texture_transform(t.extension_value("KHR_texture_transform"))
                    .map_err(|e| with_label(format!("occlusion texture: {e}")))?;
                let r = self
                    .texture_ref(&t.texture(), t.tex_coord(), transform)
                    .map_err(|e| with_label(format!("occlusion texture: {e}")))?;
                (Some(r), t.strength())
            }
            None => (None, 1.0),
        };
        let alpha_mode = match mat.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: mat.alpha_cutoff().unwrap_or(0.5) },
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        let name = match (mat.name(), mat.index()) {
            (Some(n), _) => n.to_owned(),
            (None, Some(i)) => format!("material {i}"),
            (None, None) => "default".to_owned(),
        };
        self.scene.materials.push(Material {
            name,
            base_color: pbr.base_color_factor(),
            base_color_texture,
            roughness: pbr.roughness_factor(),
            metallic: pbr.metallic_factor(),
            metallic_roughness_texture,
            normal_texture,
            normal_scale,
            occlusion_texture,
            occlusion_strength,
            emissive: mat.emissive_factor(),
            emissive_strength: mat.emissive_strength().unwrap_or(1.0),
            emissive_texture,
            alpha_mode,
            double_sided: mat.double_sided(),
        });
        let i = self.scene.materials.len() - 1;
        self.material_cache.insert(mat.index(), i);
        Ok(i)
    }

    /// A material's reference to `texture` read with set `tex_coord`, unless a
    /// `KHR_texture_transform` (its transform and optional set override) says otherwise.
    fn texture_ref(
        &mut self,
        texture: &gltf::texture::Texture<'_>,
        tex_coord: u32,
        transform: Option<(UvTransform, Option<u32>)>,
    ) -> Result<TextureRef, String> {
        let image = self.texture(&texture.source())?;
        let (transform, set) = match transform {
            Some((t, set)) => (t, set.unwrap_or(tex_coord)),
            None => (UvTransform::default(), tex_coord),
        };
        if set > 1 {
            return Err(format!("reads TEXCOORD_{set}; only TEXCOORD_0 and TEXCOORD_1 are supported"));
        }
        Ok(TextureRef { texture: image, tex_coord: set, sampler: sampler(&texture.sampler()), transform })
    }

    fn texture(&mut self, image: &gltf::Image<'_>) -> Result<usize, String> {
        let index = image.index();
        if let Some(&t) = self.texture_cache.get(&index) {
            return Ok(t);
        }
        // Read the JSON directly: the gltf crate's `Image::source` unwraps fields that
        // a malformed file may lack.
        let json = self.doc.as_json().images.get(index).ok_or_else(|| format!("image {index} does not exist"))?;
        let label = match &json.name {
            Some(n) => format!("image {index} '{n}'"),
            None => format!("image {index}"),
        };
        let (bytes, name) = match (&json.uri, json.buffer_view) {
            (Some(uri), _) => {
                let name = json.name.clone().unwrap_or_else(|| {
                    if uri.starts_with("data:") {
                        label.clone()
                    } else {
                        uri.clone()
                    }
                });
                match resolve_uri(&self.base, uri).map_err(|e| format!("{label}: {e}"))? {
                    UriTarget::Data(d) => (d, name),
                    UriTarget::File(p) => {
                        let d = std::fs::read(&p)
                            .map_err(|e| format!("{label}: cannot read image file '{}': {e}", p.display()))?;
                        (d, name)
                    }
                }
            }
            (None, Some(view_index)) => {
                let view = self
                    .doc
                    .views()
                    .nth(view_index.value())
                    .ok_or_else(|| format!("{label}: buffer view {} does not exist", view_index.value()))?;
                let buffer =
                    self.buffers.get(view.buffer().index()).ok_or_else(|| format!("{label}: missing buffer"))?;
                let bytes = view
                    .offset()
                    .checked_add(view.length())
                    .and_then(|end| buffer.get(view.offset()..end))
                    .ok_or_else(|| format!("{label}: buffer view {} runs past the end of its buffer", view.index()))?;
                (bytes.to_vec(), json.name.clone().unwrap_or_else(|| label.clone()))
            }
            (None, None) => return Err(format!("{label} has neither a uri nor a bufferView")),
        };
        let decoded = image::load_from_memory(&bytes).map_err(|e| format!("{label}: cannot decode image: {e}"))?;
        let rgba = decoded.to_rgba8();
        self.scene.textures.push(Texture { name, width: rgba.width(), height: rgba.height(), rgba8: rgba.into_raw() });
        let t = self.scene.textures.len() - 1;
        self.texture_cache.insert(index, t);
        Ok(t)
    }

    fn add_light(&mut self, light: &gltf::khr_lights_punctual::Light<'_>, world: Mat4) -> Result<(), String> {
        use gltf::khr_lights_punctual::Kind;
        let label = match light.name() {
            Some(n) => format!("light {} '{n}'", light.index()),
            None => format!("light {}", light.index()),
        };
        let position = world.transform_point3(Vec3::ZERO);
        let color = Vec3::from_array(light.color());
        let intensity = light.intensity();
        let kind = match light.kind() {
            Kind::Directional => return Ok(()),
            Kind::Point => tiledlight_cull::LightKind::Point,
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                let direction = world.transform_vector3(Vec3::NEG_Z);
                Light::spot_kind(direction, inner_cone_angle, outer_cone_angle).map_err(|e| format!("{label}: {e}"))?
            }
        };
        if intensity == 0.0 || color.max_element() == 0.0 {
            return Ok(());
        }
        let built = match light.range() {
            Some(range) => Light::with_radius(position, color, intensity, range, kind),
            None => match kind {
                tiledlight_cull::LightKind::Point => Light::point(position, color, intensity, self.threshold),
                tiledlight_cull::LightKind::Spot { direction, inner_angle, outer_angle } => {
                    Light::spot(position, direction, color, intensity, inner_angle, outer_angle, self.threshold)
                }
            },
        };
        self.scene.lights.push(built.map_err(|e| format!("{label}: {e}"))?);
        Ok(())
    }

    fn add_camera(&mut self, camera: &gltf::Camera<'_>, world: Mat4) {
        if self.scene.camera.is_some() {
            return;
        }
        if let gltf::camera::Projection::Perspective(p) = camera.projection() {
            let eye = world.transform_point3(Vec3::ZERO);
            let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
            let up = world.transform_vector3(Vec3::Y).normalize_or(Vec3::Y);
            self.scene.camera =
                Some(CameraDesc { eye, target: eye + forward, up, fov_y: p.yfov(), near: p.znear(), far: p.zfar() });
        }
    }
}

/// The scene sampler of a glTF sampler (the default sampler when the texture has none:
/// repeat, trilinear).
fn sampler(s: &gltf::texture::Sampler<'_>) -> Sampler {
    use gltf::texture::{MagFilter, MinFilter, WrappingMode};
    let wrap = |w| match w {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    };
    let mag = match s.mag_filter() {
        Some(MagFilter::Nearest) => Filter::Nearest,
        _ => Filter::Linear,
    };
    let (min, mipmap) = match s.min_filter() {
        Some(MinFilter::Nearest) => (Filter::Nearest, None),
        Some(MinFilter::Linear) => (Filter::Linear, None),
        Some(MinFilter::NearestMipmapNearest) => (Filter::Nearest, Some(Filter::Nearest)),
        Some(MinFilter::LinearMipmapNearest) => (Filter::Linear, Some(Filter::Nearest)),
        Some(MinFilter::NearestMipmapLinear) => (Filter::Nearest, Some(Filter::Linear)),
        Some(MinFilter::LinearMipmapLinear) | None => (Filter::Linear, Some(Filter::Linear)),
    };
    Sampler { wrap_u: wrap(s.wrap_s()), wrap_v: wrap(s.wrap_t()), mag, min, mipmap }
}

/// A `KHR_texture_transform` given as raw JSON (normal and occlusion texture infos,
/// which the gltf crate does not type): its transform and optional set override.
fn raw_texture_transform(value: Option<&gltf::json::Value>) -> Result<Option<(UvTransform, Option<u32>)>, String> {
    let Some(v) = value else {
        return Ok(None);
    };
    let t: gltf::json::extensions::texture::TextureTransform =
        gltf::json::deserialize::from_value(v.clone()).map_err(|e| format!("malformed KHR_texture_transform: {e}"))?;
    Ok(Some((UvTransform { offset: t.offset.0, rotation: t.rotation.0, scale: t.scale.0 }, t.tex_coord)))
}

/// Converts `indices` of a primitive drawn with `mode` into a triangle list.
/// Strips alternate their winding so every triangle keeps the first one's orientation;
/// degenerate strip triangles (used to stitch strips) are dropped.
fn triangulate(mode: Mode, indices: &[u32]) -> Result<Vec<u32>, String> {
    match mode {
        Mode::Triangles => {
            if !indices.len().is_multiple_of(3) {
                return Err(format!("TRIANGLES primitive has {} indices, not a multiple of 3", indices.len()));
            }
            Ok(indices.to_vec())
        }
        Mode::TriangleStrip => {
            let mut out = Vec::with_capacity(indices.len().saturating_sub(2) * 3);
            for i in 0..indices.len().saturating_sub(2) {
                let (a, b, c) = if i % 2 == 0 {
                    (indices[i], indices[i + 1], indices[i + 2])
                } else {
                    (indices[i + 1], indices[i], indices[i + 2])
                };
                if a != b && b != c && a != c {
                    out.extend_from_slice(&[a, b, c]);
                }
            }
            Ok(out)
        }
        Mode::TriangleFan => {
            let mut out = Vec::with_capacity(indices.len().saturating_sub(2) * 3);
            for i in 1..indices.len().saturating_sub(1) {
                out.extend_from_slice(&[indices[0], indices[i], indices[i + 1]]);
            }
            Ok(out)
        }
        other => Err(format!("primitive mode {other:?} is not supported (only triangles, strips and fans)")),
    }
}

/// Gives every triangle its own three vertices with the face normal (glTF: "when
/// normals are not specified, client implementations must calculate flat normals").
fn flat_normals(mesh: &mut Mesh) {
    let mut positions = Vec::with_capacity(mesh.indices.len());
    let mut normals = Vec::with_capacity(mesh.indices.len());
    let mut uvs = Vec::with_capacity(mesh.indices.len());
    let mut uvs1 = Vec::with_capacity(if mesh.uvs1.is_empty() { 0 } else { mesh.indices.len() });
    for t in mesh.indices.chunks_exact(3) {
        let p = [t[0], t[1], t[2]].map(|i| Vec3::from_array(mesh.positions[i as usize]));
        // Degenerate triangles have no normal; they draw nothing, so any unit vector does.
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or(Vec3::Y);
        for &i in t {
            positions.push(mesh.positions[i as usize]);
            normals.push(n.to_array());
            uvs.push(mesh.uvs[i as usize]);
            if let Some(uv) = mesh.uvs1.get(i as usize) {
                uvs1.push(*uv);
            }
        }
    }
    mesh.indices = (0..positions.len() as u32).collect();
    mesh.positions = positions;
    mesh.normals = normals;
    mesh.uvs = uvs;
    mesh.uvs1 = uvs1;
}

#[cfg(test)]
mod tests;
