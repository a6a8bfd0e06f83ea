//! glTF 2.0 loading (.gltf with external or embedded buffers, and .glb) into a
//! [`Scene`]: triangle meshes (strips and fans converted, `KHR_mesh_quantization`
//! attributes dequantised), the node hierarchy's transforms, metallic-roughness materials
//! in full (base colour, metallic-roughness, normal, occlusion and emissive textures as
//! PNG/JPEG, their samplers, texture coordinate sets 0 and 1, `KHR_texture_transform`,
//! `KHR_materials_emissive_strength`; tangents from the file or MikkTSpace),
//! KHR_lights_punctual point and spot lights, and the first perspective camera.
//!
//! Hostile files are expected: every problem becomes a [`SceneError`] naming the file
//! and what is wrong, and nothing in a malformed file may panic, hang or allocate beyond
//! [`LoadLimits`]. Only regular files inside the model's folder are read (unless
//! [`LoadOptions::allow_any_path`]), each at most its stated size. Problems the scene can
//! be drawn despite (a missing texture, an unknown optional extension) are warnings,
//! returned in [`Loaded::warnings`] (`Loader::warn` is the one place they are made);
//! [`LoadOptions::strict`] turns them into errors.
//!
//! Depends on the gltf and image crates, glam, tiledlight-cull and this crate's model and
//! error modules.

mod accessor;
mod data;
mod extensions;
mod options;
mod validate;

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::Path;

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

use data::{bytes_text, load_buffers, resolve_uri, Files, Larger, ReadError, UriTarget};
pub use extensions::SUPPORTED_EXTENSIONS;
pub use options::{LoadLimits, LoadOptions, Loaded, MAX_IMAGE_BYTES, MAX_SCENE_BYTES, MAX_TEXTURE_BYTES};

/// Largest magnitude of a world-space coordinate (metres) a loaded scene may have: 1e18.
/// Renderers square distances in f32, which overflows to infinity above ~1.8e19
/// (differences of two coordinates double them); a file whose transforms or positions go
/// beyond this fails, naming the node.
pub const MAX_WORLD_COORDINATE: f32 = 1e18;

/// How many images missing from one folder make one grouped warning instead of a line each.
pub const GROUP_MISSING: usize = 3;

/// The start of a detail line among the warnings: it belongs to the warning before it (the
/// per-image list of a grouped warning); the command line prints it only with `--verbose`.
pub const DETAIL: &str = "  - ";

/// Loads a glTF 2.0 file (`.gltf` or `.glb`) into a validated [`Scene`], strictly: every
/// problem, including those [`load_gltf_with`] only warns about (a missing texture, an
/// unknown extension), is an error, so nothing the file describes is silently left out.
/// Files are confined to the model's folder, with the default [`LoadLimits`].
///
/// `threshold` sets the radius of lights without a `range` (see
/// [`tiledlight_cull::light::radius_from_threshold`]); lights with a `range` use it as
/// their radius. See [`load_gltf_with`] for what is read.
pub fn load_gltf(path: &Path, threshold: f32) -> Result<Scene, SceneError> {
    let options = LoadOptions { strict: true, ..LoadOptions::new(threshold) };
    load_gltf_with(path, &options).map(|loaded| loaded.scene)
}

/// Loads a glTF 2.0 file (`.gltf` or `.glb`) into a validated [`Scene`], with the problems
/// it was drawn despite as warnings (see [`LoadOptions`]).
///
/// The default scene (or the first, or else every root node) is instantiated; each
/// primitive becomes a [`Mesh`] (mirrored instances get a copy with flipped winding).
/// Missing normals are computed flat (as glTF requires), missing UVs are zero,
/// non-indexed primitives get indices. Directional lights and lights that emit nothing are
/// skipped: a tiled renderer has no use for them. Only TEXCOORD_0 is read, and texture
/// samplers and transforms are ignored.
///
/// Errors name the file and the problem: unreadable files, malformed JSON or GLB, required
/// extensions not in [`SUPPORTED_EXTENSIONS`], buffer or image files outside the model's
/// folder (unless allowed) or not regular files, missing or short buffers, unsupported
/// primitive modes, out-of-range indices, NaN data, transforms or positions beyond
/// [`MAX_WORLD_COORDINATE`] (naming the node), data beyond [`LoadLimits`], and scenes that
/// fail [`Scene::validate`]. Warnings (errors when strict): a texture that is missing or
/// cannot be decoded (dropped: the material's factors alone are drawn), extensions used
/// but not supported (drawn without them).
pub fn load_gltf_with(path: &Path, options: &LoadOptions) -> Result<Loaded, SceneError> {
    check_threshold(path, options.threshold)?;
    let io = |source| SceneError::Io { path: path.to_owned(), source };
    // A device or pipe named as the model would be read without end.
    if !std::fs::metadata(path).map_err(io)?.is_file() {
        return Err(SceneError::Gltf { path: path.to_owned(), message: "is not a regular file".to_owned() });
    }
    let bytes = std::fs::read(path).map_err(io)?;
    load_gltf_bytes(&bytes, path, options)
}

/// Loads a glTF 2.0 file already in memory (`bytes`, JSON or GLB) as [`load_gltf_with`]
/// does; `path` is where it came from: it names the file in messages, and the URIs it
/// holds are resolved against (and confined to) its folder. The fuzz target's entry point.
pub fn load_gltf_bytes(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Loaded, SceneError> {
    check_threshold(path, options.threshold)?;
    let fail = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    check_glb_header(bytes).map_err(fail)?;
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| fail(describe_gltf_error(e)))?;
    // Before validation: the gltf crate's own list of required extensions is not ours.
    extensions::check_required(document.as_json()).map_err(fail)?;
    validate::validate(&document).map_err(|e| fail(describe_gltf_error(e)))?;
    let files = Files::new(path.parent().unwrap_or(Path::new(".")), options.allow_any_path);
    let buffers = load_buffers(&document, &files, blob).map_err(fail)?;
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let mut loader = Loader {
        doc: &document,
        files,
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
        threshold: options.threshold,
        limits: options.limits,
        budget: options.limits.scene_bytes,
        warnings: Vec::new(),
        mesh_cache: HashMap::new(),
        material_cache: HashMap::new(),
        texture_cache: HashMap::new(),
        unusable_images: Vec::new(),
    };
    if let Some(w) = extensions::used_warning(document.as_json()) {
        loader.warn(w);
    }
    loader.load_nodes().map_err(fail)?;
    loader.unusable_image_warnings();
    let mut scene = loader.scene;
    scene.bounds = scene.compute_bounds();
    scene.validate().map_err(|e| match e {
        SceneError::InvalidScene { problem, .. } => fail(problem),
        other => other,
    })?;
    let warnings = loader.warnings;
    if options.strict && !warnings.is_empty() {
        // Each warning is a sentence of its own.
        return Err(fail(format!("strict loading turns warnings into errors: {}", warnings.join(" "))));
    }
    // Each warning names the file once; a detail line belongs to the line before it.
    let warnings = warnings
        .into_iter()
        .map(|w| if w.starts_with(DETAIL) { w } else { format!("{}: {w}", path.display()) })
        .collect();
    Ok(Loaded { scene, warnings })
}

fn check_threshold(path: &Path, threshold: f32) -> Result<(), SceneError> {
    if !threshold.is_finite() || threshold <= 0.0 {
        return Err(SceneError::InvalidArgument(format!(
            "{}: light threshold {threshold} must be finite and positive",
            path.display()
        )));
    }
    Ok(())
}

/// Rejects a GLB header whose total length is shorter than the header itself: gltf 1.4.1
/// subtracts the header size from it unchecked (a panic in builds with overflow checks,
/// found by the mutation test).
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if let Some(length) = bytes.strip_prefix(b"glTF").and_then(|rest| rest.get(4..8)) {
        let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]);
        if length < 12 {
            return Err(format!("malformed GLB container: its header gives a total length of {length} bytes, less than the 12-byte header"));
        }
    }
    Ok(())
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
    /// Which files the glTF may name.
    files: Files,
    buffers: Vec<Vec<u8>>,
    scene: Scene,
    threshold: f32,
    limits: LoadLimits,
    /// Bytes of decoded meshes and textures still allowed (`LoadLimits::scene_bytes`).
    budget: u64,
    /// See [`Loader::warn`]; without the file's name, which the caller puts in front.
    warnings: Vec<String>,
    mesh_cache: HashMap<PrimitiveKey, usize>,
    /// glTF material index (None = the default material) to scene material.
    material_cache: HashMap<Option<usize>, usize>,
    /// glTF image index to scene texture, or why it cannot be used.
    texture_cache: HashMap<usize, Result<usize, ReadError>>,
    /// The images that cannot be used, in the order first met: why, and each material
    /// slot that wanted it ("material 0 'paint' (base colour)"). One warning each, made
    /// at the end ([`Loader::unusable_image_warnings`]): a model with its texture folder
    /// missing says so once a file, not once a material and slot.
    unusable_images: Vec<UnusableImage>,
}

/// An image no material can use, and who wanted it.
struct UnusableImage {
    /// The glTF image index.
    index: usize,
    /// What is wrong, naming the image ([`ReadError::Failed`]'s message).
    problem: String,
    /// The file, when it does not exist ([`ReadError::Missing`]).
    missing: Option<std::path::PathBuf>,
    /// Each material ("material 0 'paint'") and slot ("base colour") that uses it, in the
    /// order met.
    users: Vec<(String, String)>,
}

fn node_label(node: &gltf::Node<'_>) -> String {
    match node.name() {
        Some(n) => format!("node {} '{n}'", node.index()),
        None => format!("node {}", node.index()),
    }
}

impl Loader<'_> {
    /// Records a problem the scene is drawn despite. `message` is a complete sentence
    /// without the file's name (the caller puts it in front): what is wrong, naming the
    /// material, texture, image, node or extension, and what is drawn instead. Strict
    /// loading turns every warning into an error. Every such problem goes through here.
    fn warn(&mut self, message: String) {
        self.warnings.push(message);
    }

    /// One warning per unusable image, naming every material and slot drawn without
    /// it, then (with more than one) their count. Images missing from one folder, at least
    /// [`GROUP_MISSING`] of them (a downloaded model without its textures), are one line for
    /// the folder instead: how many of the file's images, two example names, how many slots
    /// are drawn without them and how; their per-image lines follow as details
    /// ([`DETAIL`]: the command line prints them with `--verbose`).
    fn unusable_image_warnings(&mut self) {
        let images = std::mem::take(&mut self.unusable_images);
        let mut folders: Vec<(std::path::PathBuf, Vec<&UnusableImage>)> = Vec::new();
        for i in &images {
            let Some(dir) = i.missing.as_ref().and_then(|p| p.parent()) else { continue };
            match folders.iter_mut().find(|(d, _)| d == dir) {
                Some((_, g)) => g.push(i),
                None => folders.push((dir.to_path_buf(), vec![i])),
            }
        }
        folders.retain(|(_, g)| g.len() >= GROUP_MISSING);
        let grouped = |i: &UnusableImage| folders.iter().any(|(_, g)| g.iter().any(|x| x.index == i.index));
        let total = self.doc.images().len();
        for (dir, group) in &folders {
            let name = |i: &UnusableImage| {
                i.missing
                    .as_ref()
                    .and_then(|p| p.file_name())
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
            };
            let examples: Vec<String> = group.iter().take(2).map(|i| format!("'{}'", name(i))).collect();
            let slots: usize = group.iter().map(|i| i.users.len()).sum();
            let colour = group.iter().flat_map(|i| &i.users).filter(|(_, s)| s == "base colour").count();
            self.warn(format!(
                "{} of the file's {total} images are missing from {}/ (e.g. {}); {slots} material slots are drawn \
                 without them: {colour} base colour slots with the base colour factor alone (as if the texture were \
                 white), {} other slots with their factors alone (--verbose lists each image).",
                group.len(),
                dir.display(),
                examples.join(", "),
                slots - colour
            ));
            for i in group {
                let named: Vec<String> =
                    i.users.iter().map(|(material, slot)| format!("{material} ({slot})")).collect();
                self.warn(format!("{DETAIL}{}: {}.", name(i), named.join(", ")));
            }
        }
        for i in images.iter().filter(|i| !grouped(i)) {
            let base_colour = i.users.iter().any(|(_, slot)| slot == "base colour");
            let other = i.users.iter().any(|(_, slot)| slot != "base colour");
            let drawn = match (base_colour, other) {
                (true, false) => "drawn with the base colour factor alone, as if the texture were white",
                (false, true) => "drawn without it (the factors alone)",
                _ => "drawn without it (the factors alone; a base colour as if the texture were white)",
            };
            let n = i.users.len();
            let users = if n == 1 { "1 material slot".to_string() } else { format!("{n} material slots") };
            let named: Vec<String> = i.users.iter().map(|(material, slot)| format!("{material} ({slot})")).collect();
            self.warn(format!("{}; {users} {drawn}: {}.", i.problem, named.join(", ")));
        }
        if images.len() > 1 {
            let slots: usize = images.iter().map(|i| i.users.len()).sum();
            self.warn(format!(
                "{} images cannot be used (listed above); {slots} material slots are drawn without theirs.",
                images.len()
            ));
        }
    }

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
            let world = world_transform(&node, parent).map_err(|e| format!("{label}: {e}"))?;
            if let Some(mesh) = node.mesh() {
                self.add_mesh_instances(&mesh, world).map_err(|e| format!("{label}: {e}"))?;
            }
            if let Some(light) = node.light() {
                self.add_light(&light, world).map_err(|e| format!("{label}: {e}"))?;
            }
            if let Some(camera) = node.camera() {
                self.add_camera(&camera, world).map_err(|e| format!("{label}: {e}"))?;
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
                    self.budget = self.budget.saturating_sub(mesh_bytes(&m));
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
            let placed = self.scene.meshes[mesh_index].bounds().transformed(&world);
            if !in_world_range(placed.min) || !in_world_range(placed.max) {
                return Err(format!(
                    "its transform takes mesh {} '{}' to {} .. {} in world space, beyond the +-{MAX_WORLD_COORDINATE:e} m a scene may span (the f32 squares of such distances overflow): check its scales and translations and its parents'",
                    mesh.index(),
                    mesh.name().unwrap_or(""),
                    placed.min,
                    placed.max
                ));
            }
            self.scene.instances.push(Instance { mesh: mesh_index, material, transform: world });
        }
        Ok(())
    }

    /// Loads one primitive with the attributes its scene material `material` reads. Its
    /// accessors are charged to a copy of the scene's memory budget, and the mesh built
    /// from them must fit the budget itself (the caller takes the mesh's bytes from it).
    fn load_primitive(&self, prim: &gltf::Primitive<'_>, name: String, material: usize) -> Result<Mesh, String> {
        let mut budget = self.budget;
        let pos_acc = prim.get(&Semantic::Positions).ok_or("has no POSITION attribute")?;
        let flat = accessor::read_f32(&pos_acc, &self.buffers, Dimensions::Vec3, Attr::Position, &mut budget)
            .map_err(|e| format!("POSITION: {e}"))?;
        let positions: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let n = positions.len();
        if let Some(v) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(format!("POSITION {v} is not finite ({:?})", positions[v]));
        }
        let normals = match prim.get(&Semantic::Normals) {
            Some(acc) => {
                let flat = accessor::read_f32(&acc, &self.buffers, Dimensions::Vec3, Attr::Direction, &mut budget)
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
        let uvs = self.read_uvs(prim, 0, n, &mut budget)?.unwrap_or_else(|| vec![[0.0, 0.0]; n]);
        let uvs1 = if mat.uses_uv1() {
            self.read_uvs(prim, 1, n, &mut budget)?.ok_or("its material reads TEXCOORD_1, which it does not have")?
        } else {
            Vec::new()
        };
        // Tangents only for a normal map, and only with the normals they belong to: with
        // flat normals (no NORMAL) the file's tangents would not match, so they are
        // generated after the normals.
        let file_tangents = match (&mat.normal_texture, prim.get(&Semantic::Tangents), &normals) {
            (Some(_), Some(acc), Some(_)) => Some(self.read_tangents(&acc, n, &mut budget)?),
            _ => None,
        };
        let normal_map_set = mat.normal_texture.map(|t| t.tex_coord);
        let raw_indices = match prim.indices() {
            Some(acc) => {
                accessor::read_indices(&acc, &self.buffers, &mut budget).map_err(|e| format!("indices: {e}"))?
            }
            None => (0..n as u32).collect(),
        };
        if let Some(k) = raw_indices.iter().position(|&i| i as usize >= n) {
            return Err(format!("index {k} is {} but there are only {n} vertices (out of range)", raw_indices[k]));
        }
        // What the finished mesh will hold, checked before it is built: strips and fans
        // triple their index count, flat normals give every index its own vertex.
        let out_indices = match prim.mode() {
            Mode::TriangleStrip | Mode::TriangleFan => 3 * raw_indices.len().saturating_sub(2),
            _ => raw_indices.len(),
        } as u64;
        let out_vertices = if normals.is_some() { n as u64 } else { out_indices };
        let out_bytes = out_vertices * VERTEX_BYTES + out_indices * 4;
        if out_bytes > self.budget {
            return Err(format!(
                "the mesh takes {} for {out_vertices} vertices and {out_indices} indices, more than the {} left of the scene's memory limit (LoadLimits::scene_bytes)",
                bytes_text(out_bytes),
                bytes_text(self.budget)
            ));
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
    fn read_uvs(
        &self,
        prim: &gltf::Primitive<'_>,
        set: u32,
        n: usize,
        budget: &mut u64,
    ) -> Result<Option<Vec<[f32; 2]>>, String> {
        let Some(acc) = prim.get(&Semantic::TexCoords(set)) else {
            return Ok(None);
        };
        let what = format!("TEXCOORD_{set}");
        let flat = accessor::read_f32(&acc, &self.buffers, Dimensions::Vec2, Attr::TexCoord, budget)
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
    fn read_tangents(&self, acc: &gltf::Accessor<'_>, n: usize, budget: &mut u64) -> Result<Vec<[f32; 4]>, String> {
        let flat = accessor::read_f32(acc, &self.buffers, Dimensions::Vec4, Attr::Direction, budget)
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
        // A texture whose image is missing or broken is dropped with a warning (the
        // material's factors alone are drawn); anything else wrong with it is an error.
        let info_ref = |this: &mut Self, info: Option<gltf::texture::Info<'_>>, slot: &str| match info {
            Some(info) => {
                let transform = info.texture_transform().map(|t| {
                    (UvTransform { offset: t.offset(), rotation: t.rotation(), scale: t.scale() }, t.tex_coord())
                });
                this.texture_ref((&label, slot), &info.texture(), info.tex_coord(), transform)
            }
            None => Ok(None),
        };
        let base_color_texture = info_ref(self, pbr.base_color_texture(), "base colour")?;
        let metallic_roughness_texture = info_ref(self, pbr.metallic_roughness_texture(), "metallic-roughness")?;
        let emissive_texture = info_ref(self, mat.emissive_texture(), "emissive")?;
        let (normal_texture, normal_scale) = match mat.normal_texture() {
            Some(t) => {
                let transform = raw_texture_transform(t.extension_value("KHR_texture_transform"))
                    .map_err(|e| with_label(format!("normal texture: {e}")))?;
                (self.texture_ref((&label, "normal"), &t.texture(), t.tex_coord(), transform)?, t.scale())
            }
            None => (None, 1.0),
        };
        let (occlusion_texture, occlusion_strength) = match mat.occlusion_texture() {
            Some(t) => {
                let transform = raw_texture_transform(t.extension_value("KHR_texture_transform"))
                    .map_err(|e| with_label(format!("occlusion texture: {e}")))?;
                (self.texture_ref((&label, "occlusion"), &t.texture(), t.tex_coord(), transform)?, t.strength())
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
    /// `KHR_texture_transform` (its transform and optional set override) says otherwise;
    /// None (with a warning) when its image is missing or cannot be decoded. Errors name
    /// `material` and `slot`.
    fn texture_ref(
        &mut self,
        (material, slot): (&str, &str),
        texture: &gltf::texture::Texture<'_>,
        tex_coord: u32,
        transform: Option<(UvTransform, Option<u32>)>,
    ) -> Result<Option<TextureRef>, String> {
        let (transform, set) = match transform {
            Some((t, set)) => (t, set.unwrap_or(tex_coord)),
            None => (UvTransform::default(), tex_coord),
        };
        if set > 1 {
            return Err(format!(
                "{material}: {slot} texture: reads TEXCOORD_{set}; only TEXCOORD_0 and TEXCOORD_1 are supported"
            ));
        }
        let Some(image) = self.material_texture(material, slot, &texture.source())? else {
            return Ok(None);
        };
        Ok(Some(TextureRef { texture: image, tex_coord: set, sampler: sampler(&texture.sampler()), transform }))
    }

    /// The scene texture for `material`'s `slot` ("base colour", "normal"...), or None when
    /// its image is missing or cannot be decoded: then the material and slot join the
    /// image's one warning, which names the image, why, and what is drawn instead
    /// ([`Self::unusable_image_warnings`]). A file the rules refuse to read (outside the
    /// model's folder, not a regular file) stays an error.
    fn material_texture(
        &mut self,
        material: &str,
        slot: &str,
        image: &gltf::Image<'_>,
    ) -> Result<Option<usize>, String> {
        match self.texture(image) {
            Ok(t) => Ok(Some(t)),
            Err(ReadError::Refused(m)) => Err(format!("{material}: {slot} texture: {m}")),
            Err(e @ (ReadError::Failed(_) | ReadError::Missing(..))) => {
                let index = image.index();
                let missing = match &e {
                    ReadError::Missing(_, p) => Some(p.clone()),
                    _ => None,
                };
                let problem = e.message();
                let at = match self.unusable_images.iter().position(|i| i.index == index) {
                    Some(at) => at,
                    None => {
                        self.unusable_images.push(UnusableImage { index, problem, missing, users: vec![] });
                        self.unusable_images.len() - 1
                    }
                };
                self.unusable_images[at].users.push((material.to_string(), slot.to_string()));
                Ok(None)
            }
        }
    }

    /// The scene texture of glTF image `image`, decoded once (failures too).
    fn texture(&mut self, image: &gltf::Image<'_>) -> Result<usize, ReadError> {
        let index = image.index();
        if let Some(t) = self.texture_cache.get(&index) {
            return t.clone();
        }
        let t = self.load_texture(index);
        self.texture_cache.insert(index, t.clone());
        t
    }

    fn load_texture(&mut self, index: usize) -> Result<usize, ReadError> {
        let failed = ReadError::Failed;
        // Read the JSON directly: the gltf crate's `Image::source` unwraps fields that
        // a malformed file may lack.
        let json =
            self.doc.as_json().images.get(index).ok_or_else(|| failed(format!("image {index} does not exist")))?;
        let label = match (&json.name, &json.uri) {
            (Some(n), _) => format!("image {index} '{n}'"),
            (None, Some(uri)) if !uri.starts_with("data:") => format!("image {index} ('{uri}')"),
            _ => format!("image {index}"),
        };
        let max = self.limits.image_bytes;
        let (bytes, name): (Cow<'_, [u8]>, String) = match (&json.uri, json.buffer_view) {
            (Some(uri), _) => {
                let name = json.name.clone().unwrap_or_else(|| {
                    if uri.starts_with("data:") {
                        label.clone()
                    } else {
                        uri.clone()
                    }
                });
                match resolve_uri(self.files.base(), uri, max).map_err(|e| failed(format!("{label}: {e}")))? {
                    UriTarget::Data(d) => (Cow::Owned(d), name),
                    UriTarget::File(p) => {
                        let d = self.files.read(uri, &p, max, Larger::Fail).map_err(|e| match e {
                            ReadError::Refused(m) => ReadError::Refused(format!("{label}: {m}")),
                            ReadError::Failed(m) => failed(format!("{label}: {m}")),
                            ReadError::Missing(m, p) => ReadError::Missing(format!("{label}: {m}"), p),
                        })?;
                        (Cow::Owned(d), name)
                    }
                }
            }
            (None, Some(view_index)) => {
                let view = self
                    .doc
                    .views()
                    .nth(view_index.value())
                    .ok_or_else(|| failed(format!("{label}: buffer view {} does not exist", view_index.value())))?;
                let buffer = self
                    .buffers
                    .get(view.buffer().index())
                    .ok_or_else(|| failed(format!("{label}: missing buffer")))?;
                let bytes = view.offset().checked_add(view.length()).and_then(|end| buffer.get(view.offset()..end));
                let bytes = bytes.ok_or_else(|| {
                    failed(format!("{label}: buffer view {} runs past the end of its buffer", view.index()))
                })?;
                if bytes.len() as u64 > max {
                    return Err(failed(format!(
                        "{label}: buffer view {} holds {} bytes, more than the {} an image may have",
                        view.index(),
                        bytes.len(),
                        bytes_text(max)
                    )));
                }
                (Cow::Borrowed(bytes), json.name.clone().unwrap_or_else(|| label.clone()))
            }
            (None, None) => return Err(failed(format!("{label} has neither a uri nor a bufferView"))),
        };
        let max_decoded = self.limits.texture_bytes.min(self.budget);
        let rgba = decode_image(&bytes, max_decoded).map_err(|e| failed(format!("{label}: {e}")))?;
        drop(bytes);
        self.budget -= rgba.len() as u64;
        self.scene.textures.push(Texture { name, width: rgba.width(), height: rgba.height(), rgba8: rgba.into_raw() });
        Ok(self.scene.textures.len() - 1)
    }

    fn add_light(&mut self, light: &gltf::khr_lights_punctual::Light<'_>, world: Mat4) -> Result<(), String> {
        use gltf::khr_lights_punctual::Kind;
        let label = match light.name() {
            Some(n) => format!("light {} '{n}'", light.index()),
            None => format!("light {}", light.index()),
        };
        let position = world.transform_point3(Vec3::ZERO);
        if !in_world_range(position) {
            return Err(format!("{label} is at {position}, beyond the +-{MAX_WORLD_COORDINATE:e} m a scene may span"));
        }
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

    fn add_camera(&mut self, camera: &gltf::Camera<'_>, world: Mat4) -> Result<(), String> {
        if self.scene.camera.is_some() {
            return Ok(());
        }
        if let gltf::camera::Projection::Perspective(p) = camera.projection() {
            let eye = world.transform_point3(Vec3::ZERO);
            if !in_world_range(eye) {
                return Err(format!(
                    "camera {} is at {eye}, beyond the +-{MAX_WORLD_COORDINATE:e} m a scene may span",
                    camera.index()
                ));
            }
            let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
            let up = world.transform_vector3(Vec3::Y).normalize_or(Vec3::Y);
            self.scene.camera =
                Some(CameraDesc { eye, target: eye + forward, up, fov_y: p.yfov(), near: p.znear(), far: p.zfar() });
        }
        Ok(())
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

/// Decodes a PNG or JPEG image into RGBA8 taking at most `max_bytes` (the decoder is told
/// the bound before it allocates: a small header can claim a huge image).
fn decode_image(bytes: &[u8], max_bytes: u64) -> Result<image::RgbaImage, String> {
    let too_large = || format!("the image is larger than the {} a decoded texture may take", bytes_text(max_bytes));
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot decode image: {e}"))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_bytes);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| match e {
        image::ImageError::Limits(_) => too_large(),
        e => format!("cannot decode image: {e}"),
    })?;
    // The decoder's own format may be smaller than RGBA8 (grey, RGB): check the result.
    let rgba_bytes = u64::from(decoded.width()) * u64::from(decoded.height()) * 4;
    if rgba_bytes > max_bytes {
        return Err(too_large());
    }
    Ok(decoded.into_rgba8())
}

/// `parent * local` for `node`, or an error saying whether the node's own transform or
/// its composition with its parents' is not finite.
fn world_transform(node: &gltf::Node<'_>, parent: Mat4) -> Result<Mat4, String> {
    let local = Mat4::from_cols_array_2d(&node.transform().matrix());
    if !local.is_finite() {
        return Err(match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => format!("its matrix is not finite: {matrix:?}"),
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => format!(
                "its transform is not finite: translation {translation:?}, rotation {rotation:?}, scale {scale:?}"
            ),
        });
    }
    let world = parent * local;
    if !world.is_finite() {
        return Err("its world transform (its parents' times its own) overflows to infinity: the scales or translations along the hierarchy multiply beyond f32".to_owned());
    }
    Ok(world)
}

/// True when `p` is finite and within [`MAX_WORLD_COORDINATE`] on every axis.
fn in_world_range(p: Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= MAX_WORLD_COORDINATE
}

/// Bytes a mesh vertex always takes (position, normal, UV).
const VERTEX_BYTES: u64 = 12 + 12 + 8;

/// Bytes `mesh`'s vertices (with the second UV set and tangents when it has them) and
/// indices take.
fn mesh_bytes(mesh: &Mesh) -> u64 {
    mesh.positions.len() as u64 * VERTEX_BYTES
        + mesh.uvs1.len() as u64 * 8
        + mesh.tangents.len() as u64 * 16
        + mesh.indices.len() as u64 * 4
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
