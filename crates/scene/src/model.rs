//! The scene model every renderer consumes: meshes, materials, textures, instances,
//! lights, an optional camera and world bounds, plus the checks that a scene is
//! internally consistent before it reaches the GPU. Depends on glam, tiledlight-cull
//! (for [`Light`]) and this crate's error type.

use glam::{Mat4, Vec3};
use tiledlight_cull::Light;

use crate::error::SceneError;

/// An indexed triangle list. Front faces wind counter-clockwise; normals are unit
/// length; `normals` and `uvs` have one entry per position; `uvs1` and `tangents` have
/// one entry per position or none (only meshes whose material needs them carry them).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Name, for error messages and debugging.
    pub name: String,
    /// Object-space positions (metres).
    pub positions: Vec<[f32; 3]>,
    /// Object-space unit normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates (glTF TEXCOORD_0), one per position.
    pub uvs: Vec<[f32; 2]>,
    /// The second texture coordinate set (glTF TEXCOORD_1): one per position, or empty
    /// when no texture of the mesh's material reads set 1.
    pub uvs1: Vec<[f32; 2]>,
    /// Object-space tangents (xyz unit, w = +1 or -1: the bitangent is
    /// `w * cross(normal, tangent)`, glTF's convention): one per position, or empty when the
    /// mesh's material has no normal map. Loaded from the file or generated with
    /// MikkTSpace ([`Mesh::generate_tangents`]).
    pub tangents: Vec<[f32; 4]>,
    /// Three indices per triangle, each below `positions.len()`.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Number of triangles (`indices.len() / 3`).
    pub fn triangle_count(&self) -> u64 {
        (self.indices.len() / 3) as u64
    }

    /// The texture coordinates of set `set` (0 or 1; set 1 may be empty).
    pub fn uv_set(&self, set: u32) -> &[[f32; 2]] {
        if set == 1 {
            &self.uvs1
        } else {
            &self.uvs
        }
    }

    /// Fills [`Mesh::tangents`] with MikkTSpace tangents (the algorithm glTF names for
    /// files without tangents, through the bevy_mikktspace crate) for texture coordinate
    /// set `set`, the set the normal map is read with. Vertices the algorithm leaves
    /// without a tangent (degenerate triangles with no neighbour to borrow from) get any
    /// unit vector perpendicular to their normal. Errors when set `set` is missing.
    pub fn generate_tangents(&mut self, set: u32) -> Result<(), String> {
        let n = self.positions.len();
        if self.uv_set(set).len() != n {
            return Err(format!(
                "mesh '{}': tangents need texture coordinate set {set}, which it does not have",
                self.name
            ));
        }
        struct Geo<'m> {
            mesh: &'m Mesh,
            set: u32,
            out: Vec<Option<[f32; 4]>>,
        }
        impl Geo<'_> {
            fn vertex(&self, face: usize, vert: usize) -> usize {
                self.mesh.indices[face * 3 + vert] as usize
            }
        }
        impl bevy_mikktspace::Geometry for Geo<'_> {
            fn num_faces(&self) -> usize {
                self.mesh.indices.len() / 3
            }
            fn num_vertices_of_face(&self, _face: usize) -> usize {
                3
            }
            fn position(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.positions[self.vertex(face, vert)]
            }
            fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.normals[self.vertex(face, vert)]
            }
            fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
                self.mesh.uv_set(self.set)[self.vertex(face, vert)]
            }
            fn set_tangent(&mut self, t: Option<bevy_mikktspace::TangentSpace>, face: usize, vert: usize) {
                let v = self.vertex(face, vert);
                // Welded vertices get the same value from every face; an indexed vertex
                // shared by faces with different tangent spaces keeps the first.
                if self.out[v].is_none() {
                    self.out[v] = t.map(|t| t.tangent_encoded());
                }
            }
        }
        let mut geo = Geo { mesh: self, set, out: vec![None; n] };
        bevy_mikktspace::generate_tangents(&mut geo)
            .map_err(|e| format!("mesh '{}': MikkTSpace failed: {e:?}", self.name))?;
        let out = geo.out;
        self.tangents = out
            .into_iter()
            .zip(&self.normals)
            .map(|(t, nrm)| match t {
                Some(t) if t.iter().all(|c| c.is_finite()) && Vec3::new(t[0], t[1], t[2]).length() > 0.5 => t,
                _ => {
                    let nrm = Vec3::from_array(*nrm);
                    nrm.any_orthonormal_vector().extend(1.0).to_array()
                }
            })
            .collect();
        Ok(())
    }

    /// Object-space bounds of the positions (empty for a mesh without vertices).
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::empty();
        for p in &self.positions {
            b.extend(Vec3::from_array(*p));
        }
        b
    }
}

/// How a material's alpha is interpreted (glTF's `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored.
    Opaque,
    /// Fragments with alpha below `cutoff` are discarded; the rest are opaque.
    Mask {
        /// Alpha threshold in [0, 1].
        cutoff: f32,
    },
    /// Alpha-blended (drawn after opaque geometry, back to front, with its own light lists).
    Blend,
}

/// How texture coordinates outside [0, 1] are wrapped (glTF sampler `wrapS`/`wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// Tiles the texture (glTF's default).
    #[default]
    Repeat,
    /// Tiles it, every other copy mirrored.
    MirroredRepeat,
    /// Repeats the edge texels.
    ClampToEdge,
}

/// A texture filter (glTF sampler `magFilter`/`minFilter`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filter {
    /// The nearest texel.
    Nearest,
    /// Bilinear.
    #[default]
    Linear,
}

/// How a texture is sampled (a glTF sampler). The default is what glTF leaves to the
/// implementation when a texture has no sampler: repeat, trilinear.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Sampler {
    /// Wrap along u (glTF `wrapS`).
    pub wrap_u: Wrap,
    /// Wrap along v (glTF `wrapT`).
    pub wrap_v: Wrap,
    /// Magnification filter.
    pub mag: Filter,
    /// Minification filter within a mip level.
    pub min: Filter,
    /// Filter between mip levels; `None` reads mip 0 only (glTF's `NEAREST`/`LINEAR`
    /// minification filters, which have no mipmapping).
    pub mipmap: Option<Filter>,
}

impl Default for Sampler {
    fn default() -> Self {
        Self {
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Repeat,
            mag: Filter::Linear,
            min: Filter::Linear,
            mipmap: Some(Filter::Linear),
        }
    }
}

/// A texture-coordinate transform (`KHR_texture_transform`): `uv' = T(offset) R(rotation)
/// S(scale) uv`, with the extension's rotation direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Added after rotation and scale.
    pub offset: [f32; 2],
    /// Radians, as the extension's matrix applies them (its README's GLSL).
    pub rotation: f32,
    /// Multiplies u and v first.
    pub scale: [f32; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        Self { offset: [0.0; 2], rotation: 0.0, scale: [1.0; 2] }
    }
}

impl UvTransform {
    /// The transform as two rows of a 2x3 matrix: `u' = r0 . (u, v, 1)`,
    /// `v' = r1 . (u, v, 1)` (the extension's `translation * rotation * scale`).
    pub fn rows(&self) -> [[f32; 3]; 2] {
        let (s, c) = self.rotation.sin_cos();
        let [sx, sy] = self.scale;
        let [ox, oy] = self.offset;
        // The extension's GLSL `mat3(cos, sin, 0, -sin, cos, 0, 0, 0, 1)` is column-major:
        // u' = cos u - sin v, v' = sin u + cos v.
        [[c * sx, -s * sy, ox], [s * sx, c * sy, oy]]
    }

    /// Applies the transform to `uv`.
    pub fn apply(&self, uv: [f32; 2]) -> [f32; 2] {
        let [r0, r1] = self.rows();
        [r0[0] * uv[0] + r0[1] * uv[1] + r0[2], r1[0] * uv[0] + r1[1] * uv[1] + r1[2]]
    }

    /// True for the identity.
    pub fn is_identity(&self) -> bool {
        *self == Self::default()
    }
}

/// A material's use of a texture: which image, read how and with which coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub texture: usize,
    /// Texture coordinate set: 0 (`Mesh::uvs`) or 1 (`Mesh::uvs1`).
    pub tex_coord: u32,
    /// Wrap and filter modes.
    pub sampler: Sampler,
    /// `KHR_texture_transform` (identity without it).
    pub transform: UvTransform,
}

impl TextureRef {
    /// Texture `texture` read with set 0, the default sampler and no transform.
    pub fn new(texture: usize) -> Self {
        Self { texture, tex_coord: 0, sampler: Sampler::default(), transform: UvTransform::default() }
    }
}

/// A metallic-roughness material (glTF's core material with `KHR_materials_emissive_strength`
/// and `KHR_texture_transform`). Each texture multiplies its factor; colour textures
/// (base colour, emissive) are sRGB, data textures (metallic-roughness, normal,
/// occlusion) linear.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name, for error messages and debugging.
    pub name: String,
    /// Linear RGBA base colour factor (multiplies the texture when there is one).
    pub base_color: [f32; 4],
    /// The sRGB base-colour texture, if any.
    pub base_color_texture: Option<TextureRef>,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Linear metallic-roughness texture: roughness in green, metalness in blue,
    /// multiplying the factors.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Linear tangent-space normal map (needs [`Mesh::tangents`] on every mesh drawn
    /// with this material).
    pub normal_texture: Option<TextureRef>,
    /// Scales the normal map's x and y (glTF `normalTexture.scale`).
    pub normal_scale: f32,
    /// Linear occlusion texture (red channel), applied to the ambient term only.
    pub occlusion_texture: Option<TextureRef>,
    /// `1 + strength * (texel - 1)`: 0 turns the occlusion off, 1 applies it fully.
    pub occlusion_strength: f32,
    /// Linear emitted radiance factor (glTF `emissiveFactor`, each in [0, 1]).
    pub emissive: [f32; 3],
    /// Multiplies `emissive` (`KHR_materials_emissive_strength`; 1 without it).
    pub emissive_strength: f32,
    /// sRGB emissive texture, multiplying the factor.
    pub emissive_texture: Option<TextureRef>,
    /// How alpha is used.
    pub alpha_mode: AlphaMode,
    /// Whether back faces are drawn (and lit with the flipped normal).
    pub double_sided: bool,
}

impl Default for Material {
    /// glTF's default material: white, fully metallic and rough, no textures, no
    /// emission, opaque, single-sided.
    fn default() -> Self {
        Self {
            name: "default".to_owned(),
            base_color: [1.0; 4],
            base_color_texture: None,
            roughness: 1.0,
            metallic: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive: [0.0; 3],
            emissive_strength: 1.0,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
        }
    }
}

impl Material {
    /// The material's textures with their slot names, in a fixed order (base colour,
    /// metallic-roughness, normal, occlusion, emissive).
    pub fn texture_refs(&self) -> impl Iterator<Item = (&'static str, &TextureRef)> + '_ {
        [
            ("base colour", &self.base_color_texture),
            ("metallic-roughness", &self.metallic_roughness_texture),
            ("normal", &self.normal_texture),
            ("occlusion", &self.occlusion_texture),
            ("emissive", &self.emissive_texture),
        ]
        .into_iter()
        .filter_map(|(name, t)| t.as_ref().map(|t| (name, t)))
    }

    /// True when the material emits light (a non-zero emissive factor and strength).
    pub fn is_emissive(&self) -> bool {
        self.emissive_strength > 0.0 && self.emissive.iter().any(|&e| e > 0.0)
    }

    /// True when some texture reads texture coordinate set 1.
    pub fn uses_uv1(&self) -> bool {
        self.texture_refs().any(|(_, t)| t.tex_coord == 1)
    }
}

/// A decoded texture image.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Name, for error messages and debugging.
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGBA8 texels as stored in the image, row-major, `width * height * 4` bytes: sRGB for
    /// the colour textures that use them, linear for the data textures (the material slot
    /// decides, see [`Material`]).
    pub rgba8: Vec<u8>,
}

/// One placement of a mesh with a material.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Object-to-world transform. Normals need its inverse transpose; a negative
    /// determinant mirrors the mesh (loaders flip the winding of such meshes so front
    /// faces stay counter-clockwise in world space).
    pub transform: Mat4,
}

/// A perspective camera as a scene suggests it (the viewer may move it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDesc {
    /// Eye position, world space.
    pub eye: Vec3,
    /// A point the camera looks at.
    pub target: Vec3,
    /// World-space up hint.
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Near plane distance (positive).
    pub near: f32,
    /// Far plane distance; `None` for an infinite far plane.
    pub far: Option<f32>,
}

/// An axis-aligned bounding box. The empty box has `min = +inf` and `max = -inf`, so
/// extending it with any point gives that point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::empty()
    }
}

impl Aabb {
    /// A box from its corners (not checked: see [`Aabb::is_valid`]).
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The empty box, the identity of [`Aabb::union`].
    pub fn empty() -> Self {
        Self { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY }
    }

    /// The smallest box containing all `points` (empty for none).
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::empty();
        for p in points {
            b.extend(p);
        }
        b
    }

    /// Grows the box to contain `p`.
    pub fn extend(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Centre point (meaningless for an empty box).
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Extent along each axis (negative for an empty box).
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// True when the corners are finite and `min <= max` on every axis.
    pub fn is_valid(&self) -> bool {
        self.min.is_finite() && self.max.is_finite() && self.min.cmple(self.max).all()
    }

    /// True when `p` lies inside or on the box.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The box around this box's eight corners after `m` (empty stays empty).
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        if !self.is_valid() {
            return Aabb::empty();
        }
        let mut out = Aabb::empty();
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            out.extend(m.transform_point3(corner));
        }
        out
    }
}

/// A complete scene: geometry, materials, lights, and a suggested camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Name (for a loaded scene, the file name), used in error messages.
    pub name: String,
    /// Meshes, referenced by [`Instance::mesh`].
    pub meshes: Vec<Mesh>,
    /// Materials, referenced by [`Instance::material`].
    pub materials: Vec<Material>,
    /// Textures, referenced by [`Material::base_color_texture`].
    pub textures: Vec<Texture>,
    /// What is drawn.
    pub instances: Vec<Instance>,
    /// Lights (the default scene has none: generate them with [`crate::random_lights`]).
    pub lights: Vec<Light>,
    /// A suggested camera, if the scene has one.
    pub camera: Option<CameraDesc>,
    /// World-space bounds of all instances (see [`Scene::compute_bounds`]).
    pub bounds: Aabb,
}

/// Normals are accepted this far from unit length: generated and loaded normals are
/// normalised in f32, far tighter than this.
const NORMAL_LENGTH_TOLERANCE: f32 = 1e-3;

fn finite3(v: &[f32; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

impl Scene {
    fn invalid(&self, problem: String) -> SceneError {
        SceneError::InvalidScene { scene: self.name.clone(), problem }
    }

    /// Checks that the scene is consistent: no NaN or infinity anywhere, every index in
    /// range, texture sizes matching their data, whole triangles, unit normals, at least
    /// one instance. The error names the offending mesh, material, texture, instance,
    /// light or camera.
    pub fn validate(&self) -> Result<(), SceneError> {
        if self.instances.is_empty() {
            return Err(self.invalid("the scene has no instances (nothing to draw)".to_owned()));
        }
        for (i, mesh) in self.meshes.iter().enumerate() {
            self.validate_mesh(i, mesh)?;
        }
        for (i, t) in self.textures.iter().enumerate() {
            let expected = u64::from(t.width) * u64::from(t.height) * 4;
            if t.width == 0 || t.height == 0 {
                return Err(self.invalid(format!("texture {i} '{}' has size {}x{}", t.name, t.width, t.height)));
            }
            if t.rgba8.len() as u64 != expected {
                return Err(self.invalid(format!(
                    "texture {i} '{}' is {}x{} so needs {expected} bytes of RGBA8, but has {}",
                    t.name,
                    t.width,
                    t.height,
                    t.rgba8.len()
                )));
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            self.validate_material(i, m)?;
        }
        for (i, inst) in self.instances.iter().enumerate() {
            if inst.mesh >= self.meshes.len() {
                return Err(self.invalid(format!(
                    "instance {i} uses mesh {} but there are {} meshes",
                    inst.mesh,
                    self.meshes.len()
                )));
            }
            if inst.material >= self.materials.len() {
                return Err(self.invalid(format!(
                    "instance {i} uses material {} but there are {} materials",
                    inst.material,
                    self.materials.len()
                )));
            }
            if !inst.transform.is_finite() {
                return Err(self.invalid(format!(
                    "instance {i} (mesh {} '{}') has a non-finite transform",
                    inst.mesh, self.meshes[inst.mesh].name
                )));
            }
            self.validate_instance_attributes(i, inst)?;
        }
        // The same checks as every upload (`LightBuffers::new` runs them too), so a scene
        // that validates never fails there.
        tiledlight_cull::light::validate_lights(&self.lights).map_err(|e| self.invalid(e.to_string()))?;
        if let Some(c) = &self.camera {
            self.validate_camera(c)?;
        }
        Ok(())
    }

    fn validate_mesh(&self, i: usize, mesh: &Mesh) -> Result<(), SceneError> {
        let name = &mesh.name;
        let n = mesh.positions.len();
        if n == 0 || mesh.indices.is_empty() {
            return Err(self.invalid(format!("mesh {i} '{name}' has no triangles")));
        }
        if mesh.normals.len() != n || mesh.uvs.len() != n {
            return Err(self.invalid(format!(
                "mesh {i} '{name}' has {n} positions but {} normals and {} uvs",
                mesh.normals.len(),
                mesh.uvs.len()
            )));
        }
        if let Some(v) = mesh.positions.iter().position(|p| !finite3(p)) {
            return Err(
                self.invalid(format!("mesh {i} '{name}': position {v} is not finite ({:?})", mesh.positions[v]))
            );
        }
        for (v, nrm) in mesh.normals.iter().enumerate() {
            if !finite3(nrm) {
                return Err(self.invalid(format!("mesh {i} '{name}': normal {v} is not finite ({nrm:?})")));
            }
            let len = Vec3::from_array(*nrm).length();
            if (len - 1.0).abs() > NORMAL_LENGTH_TOLERANCE {
                return Err(self.invalid(format!("mesh {i} '{name}': normal {v} has length {len}, not 1")));
            }
        }
        if let Some(v) = mesh.uvs.iter().position(|uv| !uv.iter().all(|c| c.is_finite())) {
            return Err(self.invalid(format!("mesh {i} '{name}': uv {v} is not finite ({:?})", mesh.uvs[v])));
        }
        if !mesh.uvs1.is_empty() && mesh.uvs1.len() != n {
            return Err(
                self.invalid(format!("mesh {i} '{name}' has {n} positions but {} uvs of set 1", mesh.uvs1.len()))
            );
        }
        if let Some(v) = mesh.uvs1.iter().position(|uv| !uv.iter().all(|c| c.is_finite())) {
            return Err(self.invalid(format!("mesh {i} '{name}': uv1 {v} is not finite ({:?})", mesh.uvs1[v])));
        }
        if !mesh.tangents.is_empty() && mesh.tangents.len() != n {
            return Err(
                self.invalid(format!("mesh {i} '{name}' has {n} positions but {} tangents", mesh.tangents.len()))
            );
        }
        for (v, t) in mesh.tangents.iter().enumerate() {
            let len = Vec3::new(t[0], t[1], t[2]).length();
            if !t.iter().all(|c| c.is_finite()) || (len - 1.0).abs() > NORMAL_LENGTH_TOLERANCE || t[3].abs() != 1.0 {
                return Err(self
                    .invalid(format!("mesh {i} '{name}': tangent {v} is {t:?}, not a unit vector with w = +1 or -1")));
            }
        }
        if !mesh.indices.len().is_multiple_of(3) {
            return Err(self.invalid(format!(
                "mesh {i} '{name}' has {} indices, not a multiple of 3 (triangle lists only)",
                mesh.indices.len()
            )));
        }
        if let Some(k) = mesh.indices.iter().position(|&ix| ix as usize >= n) {
            return Err(self.invalid(format!(
                "mesh {i} '{name}': index {k} is {} but the mesh has {n} vertices",
                mesh.indices[k]
            )));
        }
        Ok(())
    }

    fn validate_material(&self, i: usize, m: &Material) -> Result<(), SceneError> {
        let name = &m.name;
        let factors_finite =
            m.base_color.iter().all(|c| c.is_finite()) && m.roughness.is_finite() && m.metallic.is_finite();
        if !factors_finite {
            return Err(self.invalid(format!(
                "material {i} '{name}' has a non-finite factor (base colour {:?}, roughness {}, metallic {})",
                m.base_color, m.roughness, m.metallic
            )));
        }
        let in_unit = |x: f32| (0.0..=1.0).contains(&x);
        if !m.base_color.iter().all(|&c| in_unit(c)) || !in_unit(m.roughness) || !in_unit(m.metallic) {
            return Err(self.invalid(format!(
                "material {i} '{name}' has a factor outside [0, 1] (base colour {:?}, roughness {}, metallic {})",
                m.base_color, m.roughness, m.metallic
            )));
        }
        if let AlphaMode::Mask { cutoff } = m.alpha_mode {
            if !cutoff.is_finite() || !in_unit(cutoff) {
                return Err(self.invalid(format!("material {i} '{name}' has alpha cutoff {cutoff}, not in [0, 1]")));
            }
        }
        let extra_finite = m.normal_scale.is_finite()
            && m.occlusion_strength.is_finite()
            && m.emissive_strength.is_finite()
            && m.emissive.iter().all(|c| c.is_finite());
        if !extra_finite {
            return Err(self.invalid(format!(
                "material {i} '{name}' has a non-finite factor (normal scale {}, occlusion strength {}, \
                 emissive {:?}, emissive strength {})",
                m.normal_scale, m.occlusion_strength, m.emissive, m.emissive_strength
            )));
        }
        if !m.emissive.iter().all(|&c| in_unit(c)) || !in_unit(m.occlusion_strength) || m.emissive_strength < 0.0 {
            return Err(self.invalid(format!(
                "material {i} '{name}' has emissive {:?} (each in [0, 1]), emissive strength {} (>= 0) or \
                 occlusion strength {} (in [0, 1]) out of range",
                m.emissive, m.emissive_strength, m.occlusion_strength
            )));
        }
        for (slot, t) in m.texture_refs() {
            if t.texture >= self.textures.len() {
                return Err(self.invalid(format!(
                    "material {i} '{name}' uses texture {} ({slot}) but there are {} textures",
                    t.texture,
                    self.textures.len()
                )));
            }
            if t.tex_coord > 1 {
                return Err(self.invalid(format!(
                    "material {i} '{name}': the {slot} texture reads texture coordinate set {}, \
                     but only sets 0 and 1 are supported",
                    t.tex_coord
                )));
            }
            let x = &t.transform;
            if !(x.offset.iter().chain(&x.scale).all(|c| c.is_finite()) && x.rotation.is_finite()) {
                return Err(self.invalid(format!(
                    "material {i} '{name}': the {slot} texture has a non-finite texture transform {x:?}"
                )));
            }
        }
        Ok(())
    }

    /// Checks that every instance's mesh has what its material reads: texture
    /// coordinate set 1 when a texture uses it, tangents with a normal map.
    fn validate_instance_attributes(&self, i: usize, inst: &Instance) -> Result<(), SceneError> {
        let (mesh, m) = (&self.meshes[inst.mesh], &self.materials[inst.material]);
        if m.uses_uv1() && mesh.uvs1.is_empty() {
            return Err(self.invalid(format!(
                "instance {i}: material '{}' reads texture coordinate set 1 but mesh '{}' has none",
                m.name, mesh.name
            )));
        }
        if m.normal_texture.is_some() && mesh.tangents.is_empty() {
            return Err(self.invalid(format!(
                "instance {i}: material '{}' has a normal map but mesh '{}' has no tangents \
                 (Mesh::generate_tangents makes them)",
                m.name, mesh.name
            )));
        }
        Ok(())
    }

    fn validate_camera(&self, c: &CameraDesc) -> Result<(), SceneError> {
        let finite =
            c.eye.is_finite() && c.target.is_finite() && c.up.is_finite() && c.fov_y.is_finite() && c.near.is_finite();
        if !finite || c.far.is_some_and(|f| !f.is_finite()) {
            return Err(self.invalid(format!("camera has a non-finite parameter: {c:?}")));
        }
        let forward = c.target - c.eye;
        if forward.length_squared() < 1e-12 || forward.cross(c.up).length_squared() < 1e-12 {
            return Err(self.invalid(format!(
                "camera eye {} and target {} coincide or the view direction is parallel to up {}",
                c.eye, c.target, c.up
            )));
        }
        if !(c.fov_y > 0.0 && c.fov_y < std::f32::consts::PI) {
            return Err(self.invalid(format!("camera fov_y {} is not in (0, pi)", c.fov_y)));
        }
        if c.near <= 0.0 || c.far.is_some_and(|f| f <= c.near) {
            return Err(self.invalid(format!("camera near {} must be positive and below far {:?}", c.near, c.far)));
        }
        Ok(())
    }

    /// Triangles drawn: each instance's mesh counted once per instance.
    pub fn triangle_count(&self) -> u64 {
        self.instances.iter().filter_map(|inst| self.meshes.get(inst.mesh)).map(Mesh::triangle_count).sum()
    }

    /// Every drawn triangle in world space: each instance's mesh triangles with their
    /// positions transformed by the instance's transform, instance by instance, in index
    /// order. What the shadow tests' ray-cast reference
    /// ([`tiledlight_cull::raycast::Triangles`]) is built from.
    ///
    /// Every instance is included whatever its material: alpha-masked (and alpha-blended)
    /// materials count as opaque, since the texture's alpha is not sampled here, so
    /// cut-out holes cast shadows in this list. Winding is kept as stored (a mirrored
    /// transform reverses it; the ray cast is two-sided). Instances with an out-of-range
    /// mesh and triangles with an out-of-range index are skipped, as in
    /// [`Scene::triangle_count`] ([`Scene::validate`] reports both).
    pub fn world_triangles(&self) -> Vec<[Vec3; 3]> {
        let mut out = Vec::with_capacity(usize::try_from(self.triangle_count()).unwrap_or(0));
        for inst in &self.instances {
            let Some(mesh) = self.meshes.get(inst.mesh) else {
                continue;
            };
            // Transform each vertex once, not once per triangle using it.
            let world: Vec<Vec3> =
                mesh.positions.iter().map(|p| inst.transform.transform_point3(Vec3::from_array(*p))).collect();
            for tri in mesh.indices.chunks_exact(3) {
                if let (Some(a), Some(b), Some(c)) =
                    (world.get(tri[0] as usize), world.get(tri[1] as usize), world.get(tri[2] as usize))
                {
                    out.push([*a, *b, *c]);
                }
            }
        }
        out
    }

    /// World-space bounds of all instances (each mesh's box transformed by its
    /// instance). Instances with an out-of-range mesh are skipped; empty if none is left.
    pub fn compute_bounds(&self) -> Aabb {
        let local: Vec<Aabb> = self.meshes.iter().map(Mesh::bounds).collect();
        self.instances
            .iter()
            .filter_map(|inst| local.get(inst.mesh).map(|b| b.transformed(&inst.transform)))
            .fold(Aabb::empty(), |acc, b| acc.union(&b))
    }

    /// True when at least one light is a spot light.
    pub fn has_spot_lights(&self) -> bool {
        self.lights.iter().any(Light::is_spot)
    }

    /// True when some instance is drawn with an alpha-masked material.
    pub fn has_alpha_mask(&self) -> bool {
        self.instance_materials().any(|m| matches!(m.alpha_mode, AlphaMode::Mask { .. }))
    }

    /// True when some instance is drawn with an alpha-blended material.
    pub fn has_blend(&self) -> bool {
        self.instance_materials().any(|m| m.alpha_mode == AlphaMode::Blend)
    }

    fn instance_materials(&self) -> impl Iterator<Item = &Material> + '_ {
        self.instances.iter().filter_map(|inst| self.materials.get(inst.material))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_cull::LightKind;

    fn triangle_scene() -> Scene {
        let mesh = Mesh {
            name: "tri".into(),
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            normals: vec![[0.0, 0.0, 1.0]; 3],
            uvs: vec![[0.0, 0.0]; 3],
            indices: vec![0, 1, 2],
            ..Mesh::default()
        };
        let mut scene = Scene {
            name: "test".into(),
            meshes: vec![mesh],
            materials: vec![Material::default()],
            textures: vec![Texture { name: "t".into(), width: 2, height: 1, rgba8: vec![255; 8] }],
            instances: vec![Instance {
                mesh: 0,
                material: 0,
                transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)),
            }],
            lights: vec![Light::point(Vec3::ONE, Vec3::ONE, 1.0, 0.01).unwrap()],
            camera: Some(CameraDesc {
                eye: Vec3::ZERO,
                target: Vec3::NEG_Z,
                up: Vec3::Y,
                fov_y: 1.0,
                near: 0.1,
                far: None,
            }),
            bounds: Aabb::empty(),
        };
        scene.bounds = scene.compute_bounds();
        scene
    }

    /// Asserts that `f`'s corruption is caught and the message contains `needle`.
    fn rejects(f: impl FnOnce(&mut Scene), needle: &str) {
        let mut s = triangle_scene();
        f(&mut s);
        let err = s.validate().expect_err(needle).to_string();
        assert!(err.contains(needle), "message {err:?} should contain {needle:?}");
        assert!(err.contains("scene 'test'"), "message {err:?} should name the scene");
    }

    #[test]
    fn valid_scene_passes() {
        let s = triangle_scene();
        s.validate().unwrap();
        assert_eq!(s.triangle_count(), 1);
        assert_eq!(s.bounds, Aabb::new(Vec3::new(0.0, 0.0, -5.0), Vec3::new(1.0, 1.0, -5.0)));
        assert!(!s.has_spot_lights() && !s.has_alpha_mask() && !s.has_blend());
    }

    #[test]
    fn validate_catches_bad_data() {
        rejects(|s| s.instances.clear(), "no instances");
        rejects(|s| s.meshes[0].positions[1][0] = f32::NAN, "mesh 0 'tri': position 1 is not finite");
        rejects(|s| s.meshes[0].positions[2][2] = f32::INFINITY, "position 2 is not finite");
        rejects(|s| s.meshes[0].normals[0][1] = f32::NAN, "mesh 0 'tri': normal 0 is not finite");
        rejects(|s| s.meshes[0].normals[0] = [0.0, 0.0, 2.0], "normal 0 has length 2");
        rejects(|s| s.meshes[0].uvs[2][0] = f32::NAN, "mesh 0 'tri': uv 2 is not finite");
        rejects(
            |s| {
                s.meshes[0].uvs.pop();
            },
            "3 positions but 3 normals and 2 uvs",
        );
        rejects(|s| s.meshes[0].indices[1] = 3, "mesh 0 'tri': index 1 is 3 but the mesh has 3 vertices");
        rejects(|s| s.meshes[0].indices.push(0), "4 indices, not a multiple of 3");
        rejects(|s| s.meshes[0].indices.clear(), "mesh 0 'tri' has no triangles");
        rejects(|s| s.instances[0].mesh = 1, "instance 0 uses mesh 1 but there are 1 meshes");
        rejects(|s| s.instances[0].material = 7, "instance 0 uses material 7");
        rejects(
            |s| s.instances[0].transform.w_axis.x = f32::NAN,
            "instance 0 (mesh 0 'tri') has a non-finite transform",
        );
        rejects(|s| s.materials[0].roughness = f32::NAN, "material 0 'default' has a non-finite factor");
        rejects(|s| s.materials[0].base_color[3] = f32::INFINITY, "material 0 'default' has a non-finite factor");
        rejects(|s| s.materials[0].metallic = 1.5, "material 0 'default' has a factor outside [0, 1]");
        rejects(|s| s.materials[0].alpha_mode = AlphaMode::Mask { cutoff: f32::NAN }, "alpha cutoff NaN");
        rejects(
            |s| s.materials[0].base_color_texture = Some(TextureRef::new(1)),
            "material 0 'default' uses texture 1 (base colour) but there are 1 textures",
        );
        rejects(
            |s| s.materials[0].emissive_texture = Some(TextureRef { tex_coord: 2, ..TextureRef::new(0) }),
            "the emissive texture reads texture coordinate set 2",
        );
        rejects(
            |s| {
                let mut t = TextureRef::new(0);
                t.transform.rotation = f32::NAN;
                s.materials[0].occlusion_texture = Some(t);
            },
            "the occlusion texture has a non-finite texture transform",
        );
        rejects(|s| s.materials[0].emissive = [2.0, 0.0, 0.0], "has emissive [2.0, 0.0, 0.0]");
        rejects(|s| s.materials[0].emissive_strength = f32::INFINITY, "non-finite factor (normal scale");
        rejects(
            |s| s.materials[0].normal_texture = Some(TextureRef::new(0)),
            "instance 0: material 'default' has a normal map but mesh 'tri' has no tangents",
        );
        rejects(
            |s| s.materials[0].base_color_texture = Some(TextureRef { tex_coord: 1, ..TextureRef::new(0) }),
            "instance 0: material 'default' reads texture coordinate set 1 but mesh 'tri' has none",
        );
        rejects(|s| s.meshes[0].uvs1 = vec![[0.0; 2]; 2], "3 positions but 2 uvs of set 1");
        rejects(|s| s.meshes[0].tangents = vec![[1.0, 0.0, 0.0, 0.5]; 3], "tangent 0 is [1.0, 0.0, 0.0, 0.5]");
        rejects(
            |s| {
                s.textures[0].rgba8.pop();
            },
            "texture 0 't' is 2x1 so needs 8 bytes of RGBA8, but has 7",
        );
        rejects(|s| s.textures[0].width = 0, "texture 0 't' has size 0x1");
        rejects(|s| s.lights[0].position.x = f32::NAN, "light 0: position");
        rejects(|s| s.lights[0].intensity = f32::INFINITY, "light 0: intensity inf");
        rejects(|s| s.lights[0].radius = 0.0, "light 0: radius 0");
        rejects(
            |s| {
                s.lights[0].kind =
                    LightKind::Spot { direction: Vec3::new(f32::NAN, 0.0, 0.0), inner_angle: 0.1, outer_angle: 0.2 }
            },
            "light 0: spot direction [NaN, 0, 0] is not a finite non-zero vector",
        );
        rejects(
            |s| s.lights[0].kind = LightKind::Spot { direction: Vec3::Y, inner_angle: 0.3, outer_angle: 0.2 },
            "light 0: spot inner angle 0.3",
        );
        rejects(|s| s.camera.as_mut().unwrap().fov_y = f32::NAN, "camera has a non-finite parameter");
        rejects(|s| s.camera.as_mut().unwrap().target = Vec3::ZERO, "camera eye");
        rejects(|s| s.camera.as_mut().unwrap().far = Some(0.05), "camera near 0.1 must be positive and below far");
    }

    #[test]
    fn world_triangles_apply_instance_transforms() {
        let mut s = triangle_scene();
        let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
        assert_eq!(s.world_triangles(), vec![[-5.0 * z, x - 5.0 * z, y - 5.0 * z]]);
        // A second instance, rotated a quarter turn about +Y, scaled and moved, with an
        // alpha-masked material (still included); and one with a bad mesh (skipped).
        s.materials.push(Material { alpha_mode: AlphaMode::Mask { cutoff: 0.5 }, ..Material::default() });
        let m = Mat4::from_scale_rotation_translation(
            Vec3::splat(2.0),
            glam::Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
            Vec3::new(10.0, 0.0, 0.0),
        );
        s.instances.push(Instance { mesh: 0, material: 1, transform: m });
        s.instances.push(Instance { mesh: 7, material: 0, transform: Mat4::IDENTITY });
        let w = s.world_triangles();
        assert_eq!(w.len(), 2);
        // +X turns to -Z; +Y stays.
        let expected = [Vec3::new(10.0, 0.0, 0.0), Vec3::new(10.0, 0.0, -2.0), Vec3::new(10.0, 2.0, 0.0)];
        for (got, want) in w[1].iter().zip(expected) {
            assert!(got.abs_diff_eq(want, 1e-5), "{got} vs {want}");
        }
        // Out-of-range indices drop only their triangle.
        s.meshes[0].indices.extend_from_slice(&[0, 1, 9]);
        assert_eq!(s.world_triangles().len(), 2);
    }

    #[test]
    fn aabb_helpers() {
        let e = Aabb::empty();
        assert!(!e.is_valid());
        let mut b = e;
        b.extend(Vec3::new(1.0, 2.0, 3.0));
        b.extend(Vec3::new(-1.0, 0.0, 5.0));
        assert!(b.is_valid());
        assert_eq!(b.center(), Vec3::new(0.0, 1.0, 4.0));
        assert_eq!(b.size(), Vec3::new(2.0, 2.0, 2.0));
        assert_eq!(e.union(&b), b);
        assert!(b.contains(Vec3::new(0.0, 1.0, 4.0)) && !b.contains(Vec3::ZERO));
        let moved = b.transformed(&Mat4::from_translation(Vec3::X));
        assert_eq!(moved.min, Vec3::new(0.0, 0.0, 3.0));
        assert!(!e.transformed(&Mat4::IDENTITY).is_valid());
        assert!(!Aabb::new(Vec3::NAN, Vec3::ONE).is_valid());
    }

    fn quad_mesh(uv_of: impl Fn([f32; 3]) -> [f32; 2]) -> Mesh {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        Mesh {
            name: "quad".into(),
            uvs: positions.iter().map(|&p| uv_of(p)).collect(),
            positions,
            normals: vec![[0.0, 0.0, 1.0]; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Mesh::default()
        }
    }

    #[test]
    fn mikktspace_tangents_follow_the_uvs() {
        // u along +x, v along +y: tangent +x, bitangent +y = cross(n, t), so w = +1.
        let mut m = quad_mesh(|p| [p[0], p[1]]);
        m.generate_tangents(0).unwrap();
        for t in &m.tangents {
            assert!((Vec3::new(t[0], t[1], t[2]) - Vec3::X).length() < 1e-5 && t[3] == 1.0, "{t:?}");
        }
        // v flipped (glTF images run down): the bitangent is -y, so w = -1.
        let mut m = quad_mesh(|p| [p[0], 1.0 - p[1]]);
        m.generate_tangents(0).unwrap();
        assert!(m.tangents.iter().all(|t| (t[0] - 1.0).abs() < 1e-5 && t[3] == -1.0), "{:?}", m.tangents);
        // u along -y (set 1): tangent -y.
        let mut m = quad_mesh(|p| [p[0], p[1]]);
        m.uvs1 = m.positions.iter().map(|p| [-p[1], p[0]]).collect();
        m.generate_tangents(1).unwrap();
        assert!(m.tangents.iter().all(|t| (t[1] + 1.0).abs() < 1e-5), "{:?}", m.tangents);
        // Degenerate uvs leave no tangent space: any unit vector perpendicular to n.
        let mut m = quad_mesh(|_| [0.5, 0.5]);
        m.generate_tangents(0).unwrap();
        for t in &m.tangents {
            let t3 = Vec3::new(t[0], t[1], t[2]);
            assert!((t3.length() - 1.0).abs() < 1e-5 && t3.z.abs() < 1e-5, "{t:?}");
        }
        let mut m = quad_mesh(|p| [p[0], p[1]]);
        assert!(m.generate_tangents(1).unwrap_err().contains("texture coordinate set 1"));
    }

    #[test]
    fn uv_transform_is_the_extensions_matrix() {
        let t = UvTransform { offset: [0.5, 0.25], rotation: std::f32::consts::FRAC_PI_2, scale: [2.0, 3.0] };
        // Scale (1, 0) -> (2, 0); rotate: u' = cos u - sin v = 0, v' = sin u + cos v = 2; offset.
        let [u, v] = t.apply([1.0, 0.0]);
        assert!((u - 0.5).abs() < 1e-6 && (v - 2.25).abs() < 1e-6, "{u} {v}");
        // (0, 1) -> (0, 3) -> (-3, 0) -> (-2.5, 0.25).
        let [u, v] = t.apply([0.0, 1.0]);
        assert!((u + 2.5).abs() < 1e-6 && (v - 0.25).abs() < 1e-6, "{u} {v}");
        assert!(UvTransform::default().is_identity() && !t.is_identity());
        assert_eq!(UvTransform::default().apply([0.3, 0.7]), [0.3, 0.7]);
    }

    #[test]
    fn helpers_see_spots_and_alpha() {
        let mut s = triangle_scene();
        s.lights.push(Light::spot(Vec3::ZERO, Vec3::NEG_Y, Vec3::ONE, 1.0, 0.1, 0.2, 0.01).unwrap());
        s.materials.push(Material { alpha_mode: AlphaMode::Blend, ..Material::default() });
        assert!(s.has_spot_lights());
        assert!(!s.has_blend(), "an unused blended material draws nothing");
        s.instances[0].material = 1;
        assert!(s.has_blend());
        s.materials[1].alpha_mode = AlphaMode::Mask { cutoff: 0.5 };
        assert!(s.has_alpha_mask());
    }
}
