//! A run's scene, lights and camera written as one glTF 2.0 file another engine reads
//! (`tiledlight export`; the peer benchmark renders it with Bevy, `peers/bevy/`).
//!
//! What is written ([`gltf_document`]):
//! - geometry: one glTF mesh per (scene mesh, material) pair that an instance uses, each
//!   instance a node with its matrix. Positions, normals, both UV sets and tangents as the
//!   scene has them, u32 indices. A mirrored instance (negative determinant) gets its
//!   mesh's triangles with the winding reversed: glTF readers (tiledlight's loader
//!   included) flip such triangles themselves, and the scene's copy is already flipped;
//! - materials: glTF metallic-roughness with every factor and texture the scene model has
//!   (base colour, metallic-roughness, normal with its scale, occlusion with its strength,
//!   emissive with `KHR_materials_emissive_strength`, `KHR_texture_transform`, the UV set,
//!   alpha mode and cutoff, double-sidedness); textures as PNG images in the buffer, with
//!   their samplers. Nothing of the scene model is left out;
//! - lights: `KHR_lights_punctual` point and spot lights, one node each, in the run's
//!   order (the scene file's lights first, then the random ones). `range` is tiledlight's
//!   radius. **Intensity**: a tiledlight light delivers `color * intensity / d^2` at
//!   distance `d` (before the range window), and a `KHR_lights_punctual` point or spot
//!   light of `intensity` candela delivers `color * intensity / d^2` lux: the same law, so
//!   the intensity is written 1:1 as candela (tiledlight's loader reads it back 1:1).
//!   Spot directions are exact: a spot's node matrix has the light's `-direction` as its
//!   third column, so the reader's `-Z` is the direction bit for bit;
//! - the camera: a perspective camera node (`yfov`, `znear`, `zfar` or none for an
//!   infinite far plane, `aspectRatio` = width / height) whose matrix is the inverse of
//!   the view. What glTF has no field for and a renderer needs to draw tiledlight's frame
//!   goes in the camera node's `extras.tiledlight`: `width`, `height`, `exposure` (the
//!   fixed exposure, or null with `auto_exposure: true`) and `ambient` (radiance times
//!   base colour).
//!
//! Reading the file back with the same flags (`--scene FILE`) gives the same lights
//! exactly, the same geometry and materials, and the camera within float rounding
//! (tests/tests/export.rs renders both). Orthographic cameras are refused (no scene or
//! bookmark makes one). Bad input (a NaN anywhere, an unknown extension, a path that
//! cannot be written) is an error naming it.
//!
//! Depends on tiledlight-scene (the model), tiledlight-cull (lights, camera),
//! tiledlight-gltf-writer (buffers and file layout), serde_json and [`crate::load`] /
//! [`crate::settings`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};
use glam::{Mat4, Vec3};
use serde_json::{json, Value};
use tiledlight_cull::camera::Projection;
use tiledlight_cull::{Camera, Light, LightKind};
use tiledlight_gltf_writer::{self as writer, Buffer};
use tiledlight_scene::{AlphaMode, Filter, Material, Sampler, Scene, TextureRef, Wrap};

use crate::load::SceneCpu;
use crate::settings::Settings;

/// The two glTF containers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// JSON `.gltf` with its buffer in a `.bin` file beside it.
    Gltf,
    /// Binary `.glb`, one file.
    Glb,
}

impl ExportFormat {
    /// The format a path's extension names (case-insensitive); an error for any other.
    pub fn of_path(path: &Path) -> Result<Self> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("gltf") => Ok(Self::Gltf),
            Some("glb") => Ok(Self::Glb),
            _ => bail!("--out {}: only .gltf and .glb files can be exported", path.display()),
        }
    }
}

/// What the renderer draws besides the glTF data: the frame's size, exposure and ambient
/// light (written to the camera node's `extras.tiledlight`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameExtras {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The fixed exposure, or `None` when each frame computes its own.
    pub exposure: Option<f32>,
    /// Ambient radiance (times base colour).
    pub ambient: Vec3,
}

impl FrameExtras {
    /// The frame `settings` draw.
    pub fn of(settings: &Settings) -> Self {
        Self {
            width: settings.width,
            height: settings.height,
            exposure: (!settings.auto_exposure).then_some(settings.exposure),
            ambient: settings.frame_settings(false).ambient,
        }
    }
}

/// What an export wrote, for the report.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportSummary {
    /// The files written (the `.gltf` and its `.bin`, or the `.glb`).
    pub files: Vec<PathBuf>,
    /// Bytes written in all.
    pub bytes: u64,
    /// glTF meshes (scene mesh x material pairs).
    pub meshes: usize,
    /// Materials.
    pub materials: usize,
    /// Images (PNG).
    pub images: usize,
    /// Mesh nodes.
    pub instances: usize,
    /// Point lights.
    pub point_lights: usize,
    /// Spot lights.
    pub spot_lights: usize,
}

/// Writes `cpu`'s scene, lights and camera, and the frame `settings` draw, to `path`
/// (`.gltf` + `.bin`, or `.glb`), creating its folder.
pub fn export(cpu: &SceneCpu, settings: &Settings, path: &Path) -> Result<ExportSummary> {
    let format = ExportFormat::of_path(path)?;
    let (root, bin) = gltf_document(&cpu.scene, &cpu.lights, &cpu.camera, &FrameExtras::of(settings))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating directory {}", dir.display()))?;
    }
    let files = match format {
        ExportFormat::Gltf => {
            let bin_path =
                writer::save_gltf(path, root.clone(), &bin).with_context(|| format!("writing {}", path.display()))?;
            vec![path.to_path_buf(), bin_path]
        }
        ExportFormat::Glb => {
            writer::save_glb(path, &root, &bin).with_context(|| format!("writing {}", path.display()))?;
            vec![path.to_path_buf()]
        }
    };
    let bytes = files.iter().filter_map(|f| std::fs::metadata(f).ok()).map(|m| m.len()).sum();
    let count = |key: &str| root[key].as_array().map_or(0, Vec::len);
    let spots = cpu.lights.iter().filter(|l| l.is_spot()).count();
    Ok(ExportSummary {
        files,
        bytes,
        meshes: count("meshes"),
        materials: count("materials"),
        images: count("images"),
        instances: cpu.scene.instances.len(),
        point_lights: cpu.lights.len() - spots,
        spot_lights: spots,
    })
}

/// Checks that every number of a light is finite and in range; the error names the light.
fn check_light(i: usize, l: &Light) -> Result<()> {
    let mut ok = l.position.is_finite() && l.color.is_finite() && l.intensity.is_finite() && l.radius.is_finite();
    ok &= l.intensity >= 0.0 && l.radius > 0.0 && l.color.min_element() >= 0.0;
    if let LightKind::Spot { direction, inner_angle, outer_angle } = l.kind {
        ok &= direction.is_finite() && inner_angle.is_finite() && outer_angle.is_finite();
    }
    ensure!(ok, "light {i} cannot be exported: a value is not finite or out of range ({l:?})");
    Ok(())
}

/// The glTF JSON (its buffer without a URI) and the binary buffer of a scene, its lights
/// and its camera, with the frame's extras. The scene is validated first; a NaN or
/// infinity anywhere is an error naming where.
pub fn gltf_document(
    scene: &Scene,
    lights: &[Light],
    camera: &Camera,
    frame: &FrameExtras,
) -> Result<(Value, Vec<u8>)> {
    scene.validate().context("the scene cannot be exported")?;
    for (i, l) in lights.iter().enumerate() {
        check_light(i, l)?;
    }
    ensure!(
        frame.exposure.is_none_or(|e| e.is_finite() && e > 0.0) && frame.ambient.is_finite(),
        "the exposure ({:?}) and ambient light ({}) must be finite",
        frame.exposure,
        frame.ambient
    );
    let mut b = Buffer::default();
    let mut used = Extensions::default();

    // Images and textures: one glTF texture per (image, sampler) pair a material uses.
    let mut images = Vec::new();
    for t in &scene.textures {
        let png = writer::png(t.width, t.height, &t.rgba8);
        let view = b.view(&png);
        images.push(json!({"name": t.name, "bufferView": view, "mimeType": "image/png"}));
    }
    let mut samplers: Vec<Value> = Vec::new();
    let mut sampler_index: HashMap<Sampler, usize> = HashMap::new();
    let mut textures: Vec<Value> = Vec::new();
    let mut texture_index: HashMap<(usize, Sampler), usize> = HashMap::new();
    let mut texture_info = |r: &TextureRef, used: &mut Extensions| -> Value {
        let s = *sampler_index.entry(r.sampler).or_insert_with(|| {
            samplers.push(sampler_json(&r.sampler));
            samplers.len() - 1
        });
        let t = *texture_index.entry((r.texture, r.sampler)).or_insert_with(|| {
            textures.push(json!({"source": r.texture, "sampler": s}));
            textures.len() - 1
        });
        let mut info = json!({"index": t, "texCoord": r.tex_coord});
        if !r.transform.is_identity() {
            used.texture_transform = true;
            let tr = &r.transform;
            info["extensions"] = json!({"KHR_texture_transform": {
                "offset": tr.offset, "rotation": tr.rotation, "scale": tr.scale
            }});
        }
        info
    };
    let materials: Vec<Value> =
        scene.materials.iter().map(|m| material_json(m, &mut texture_info, &mut used)).collect();

    // Geometry: each scene mesh's attributes once, its indices once per winding used.
    let mut attributes: HashMap<usize, Value> = HashMap::new();
    let mut index_accessors: HashMap<(usize, bool), usize> = HashMap::new();
    let mut meshes: Vec<Value> = Vec::new();
    let mut mesh_index: HashMap<(usize, usize, bool), usize> = HashMap::new();
    let mut nodes: Vec<Value> = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        let mirrored = inst.transform.determinant() < 0.0;
        let key = (inst.mesh, inst.material, mirrored);
        let gltf_mesh = match mesh_index.get(&key) {
            Some(&m) => m,
            None => {
                let mesh = &scene.meshes[inst.mesh];
                let attrs = attributes
                    .entry(inst.mesh)
                    .or_insert_with(|| {
                        let mut a = json!({"POSITION": b.floats(mesh.positions.as_flattened(), "VEC3")});
                        if !mesh.normals.is_empty() {
                            a["NORMAL"] = json!(b.floats(mesh.normals.as_flattened(), "VEC3"));
                        }
                        if !mesh.uvs.is_empty() {
                            a["TEXCOORD_0"] = json!(b.floats(mesh.uvs.as_flattened(), "VEC2"));
                        }
                        if !mesh.uvs1.is_empty() {
                            a["TEXCOORD_1"] = json!(b.floats(mesh.uvs1.as_flattened(), "VEC2"));
                        }
                        if !mesh.tangents.is_empty() {
                            a["TANGENT"] = json!(b.floats(mesh.tangents.as_flattened(), "VEC4"));
                        }
                        a
                    })
                    .clone();
                let indices = *index_accessors.entry((inst.mesh, mirrored)).or_insert_with(|| {
                    if mirrored {
                        let flipped: Vec<u32> = mesh.indices.chunks_exact(3).flat_map(|t| [t[0], t[2], t[1]]).collect();
                        b.indices_u32(&flipped)
                    } else {
                        b.indices_u32(&mesh.indices)
                    }
                });
                let name = if mirrored { format!("{} (mirrored)", mesh.name) } else { mesh.name.clone() };
                meshes.push(json!({
                    "name": name,
                    "primitives": [{"attributes": attrs, "indices": indices, "material": inst.material}]
                }));
                mesh_index.insert(key, meshes.len() - 1);
                meshes.len() - 1
            }
        };
        nodes.push(json!({"name": format!("instance {i}"), "mesh": gltf_mesh, "matrix": matrix(&inst.transform)}));
    }

    // Lights, in the run's order.
    let mut gltf_lights = Vec::with_capacity(lights.len());
    for (i, l) in lights.iter().enumerate() {
        let c = l.color.to_array();
        let mut light = json!({"color": c, "intensity": l.intensity, "range": l.radius});
        let mut node = json!({"name": format!("light {i}"), "extensions": {"KHR_lights_punctual": {"light": i}}});
        match l.kind {
            LightKind::Point => {
                light["type"] = json!("point");
                node["translation"] = json!(l.position.to_array());
            }
            LightKind::Spot { direction, inner_angle, outer_angle } => {
                light["type"] = json!("spot");
                light["spot"] = json!({"innerConeAngle": inner_angle, "outerConeAngle": outer_angle});
                node["matrix"] = matrix(&spot_matrix(l.position, direction));
            }
        }
        gltf_lights.push(light);
        nodes.push(node);
    }

    // The camera.
    let Projection::Perspective { fov_y, aspect, near, far } = camera.projection() else {
        bail!("only perspective cameras can be exported (this one is orthographic)");
    };
    let mut perspective = json!({"yfov": fov_y, "znear": near, "aspectRatio": aspect});
    if let Some(f) = far {
        perspective["zfar"] = json!(f);
    }
    nodes.push(json!({
        "name": "camera",
        "camera": 0,
        "matrix": matrix(&camera.view().inverse()),
        "extras": {"tiledlight": {
            "width": frame.width,
            "height": frame.height,
            "exposure": frame.exposure,
            "auto_exposure": frame.exposure.is_none(),
            "ambient": frame.ambient.to_array(),
        }},
    }));

    let mut extensions_used = vec!["KHR_lights_punctual"];
    if used.emissive_strength {
        extensions_used.push("KHR_materials_emissive_strength");
    }
    if used.texture_transform {
        extensions_used.push("KHR_texture_transform");
    }
    let node_ids: Vec<usize> = (0..nodes.len()).collect();
    let mut root = b.document(json!({
        "asset": {"version": "2.0", "generator": concat!("tiledlight export ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"name": scene.name, "nodes": node_ids}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{"name": "camera", "type": "perspective", "perspective": perspective}],
        "extensionsUsed": extensions_used,
        "extensions": {"KHR_lights_punctual": {"lights": gltf_lights}},
    }));
    if !images.is_empty() {
        root["images"] = json!(images);
        root["textures"] = json!(textures);
        root["samplers"] = json!(samplers);
    }
    if let Some(path) = null_number(&root) {
        // serde_json writes a NaN or infinite f32 as null: every number was checked above,
        // so this is a bug of this module, not of the input.
        bail!("internal: the exported glTF has a null at {path} (a number that is not finite)");
    }
    Ok((root, b.data))
}

/// Which optional extensions the materials use.
#[derive(Default)]
struct Extensions {
    emissive_strength: bool,
    texture_transform: bool,
}

fn material_json(
    m: &Material,
    texture_info: &mut impl FnMut(&TextureRef, &mut Extensions) -> Value,
    used: &mut Extensions,
) -> Value {
    let mut pbr =
        json!({"baseColorFactor": m.base_color, "metallicFactor": m.metallic, "roughnessFactor": m.roughness});
    if let Some(t) = &m.base_color_texture {
        pbr["baseColorTexture"] = texture_info(t, used);
    }
    if let Some(t) = &m.metallic_roughness_texture {
        pbr["metallicRoughnessTexture"] = texture_info(t, used);
    }
    let mut out = json!({"name": m.name, "pbrMetallicRoughness": pbr, "doubleSided": m.double_sided});
    if let Some(t) = &m.normal_texture {
        out["normalTexture"] = texture_info(t, used);
        out["normalTexture"]["scale"] = json!(m.normal_scale);
    }
    if let Some(t) = &m.occlusion_texture {
        out["occlusionTexture"] = texture_info(t, used);
        out["occlusionTexture"]["strength"] = json!(m.occlusion_strength);
    }
    if let Some(t) = &m.emissive_texture {
        out["emissiveTexture"] = texture_info(t, used);
    }
    if m.emissive != [0.0; 3] || m.emissive_texture.is_some() {
        out["emissiveFactor"] = json!(m.emissive);
        if m.emissive_strength != 1.0 {
            used.emissive_strength = true;
            out["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": m.emissive_strength}});
        }
    }
    match m.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask { cutoff } => {
            out["alphaMode"] = json!("MASK");
            out["alphaCutoff"] = json!(cutoff);
        }
        AlphaMode::Blend => out["alphaMode"] = json!("BLEND"),
    }
    out
}

fn sampler_json(s: &Sampler) -> Value {
    let wrap = |w: Wrap| match w {
        Wrap::Repeat => writer::REPEAT,
        Wrap::ClampToEdge => writer::CLAMP,
        Wrap::MirroredRepeat => writer::MIRROR,
    };
    let filter = |f: Filter| match f {
        Filter::Nearest => writer::NEAREST,
        Filter::Linear => writer::LINEAR,
    };
    // glTF's mipmapped minification filters: 9984 + 2 * (mipmap linear) + (min linear).
    let min = match s.mipmap {
        None => filter(s.min),
        Some(mip) => 9984 + 2 * u32::from(mip == Filter::Linear) + u32::from(s.min == Filter::Linear),
    };
    json!({"magFilter": filter(s.mag), "minFilter": min, "wrapS": wrap(s.wrap_u), "wrapT": wrap(s.wrap_v)})
}

/// A matrix as glTF's column-major array.
fn matrix(m: &Mat4) -> Value {
    json!(m.to_cols_array())
}

/// A spot light's node matrix: rotation with `-direction` as its third column (so the
/// reader's `-Z` is `direction` exactly), translation `position`.
fn spot_matrix(position: Vec3, direction: Vec3) -> Mat4 {
    let back = -direction;
    let helper = if back.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
    let x = helper.cross(back).normalize();
    let y = back.cross(x);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), back.extend(0.0), position.extend(1.0))
}

/// The JSON path of the first null, if any: the only way a non-finite f32 shows up
/// (serde_json writes NaN and infinity as null). `exposure` is null on purpose when the
/// exposure is automatic. The path is built on the way back, only when there is a null.
fn null_number(v: &Value) -> Option<String> {
    match v {
        Value::Null => Some(String::new()),
        Value::Array(a) => a.iter().enumerate().find_map(|(i, x)| null_number(x).map(|p| format!("[{i}]{p}"))),
        Value::Object(o) => o
            .iter()
            .filter(|(k, _)| k.as_str() != "exposure")
            .find_map(|(k, x)| null_number(x).map(|p| format!(".{k}{p}"))),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_scene::{load_gltf_bytes, DefaultSceneOptions, LoadOptions};

    fn frame() -> FrameExtras {
        FrameExtras { width: 64, height: 36, exposure: Some(1.5), ambient: Vec3::splat(0.02) }
    }

    fn camera() -> Camera {
        Camera::perspective(Vec3::new(1.0, 2.0, 9.0), Vec3::new(0.5, 1.0, 0.0), Vec3::Y, 0.9, 16.0 / 9.0, 0.1, None)
            .unwrap()
    }

    /// Exact, but spot directions within 1e-6: the loader re-normalises the direction it
    /// reads (exact here), which can move an already unit vector by one ulp.
    pub(crate) fn assert_same_lights(back: &[Light], lights: &[Light]) {
        assert_eq!(back.len(), lights.len());
        for (i, (b, l)) in back.iter().zip(lights).enumerate() {
            match (b.kind, l.kind) {
                (
                    LightKind::Spot { direction: db, inner_angle: ib, outer_angle: ob },
                    LightKind::Spot { direction: dl, inner_angle: il, outer_angle: ol },
                ) => {
                    assert!((db - dl).abs().max_element() <= 1e-6, "light {i}: direction {db} vs {dl}");
                    assert_eq!((ib, ob), (il, ol), "light {i}: cone angles");
                    assert_eq!(Light { kind: l.kind, ..*b }, *l, "light {i}");
                }
                _ => assert_eq!(b, l, "light {i}"),
            }
        }
    }

    #[test]
    fn extensions_pick_the_format() {
        assert_eq!(ExportFormat::of_path(Path::new("a/b.GLTF")).unwrap(), ExportFormat::Gltf);
        assert_eq!(ExportFormat::of_path(Path::new("b.glb")).unwrap(), ExportFormat::Glb);
        let e = format!("{:#}", ExportFormat::of_path(Path::new("b.obj")).unwrap_err());
        assert_eq!(e, "--out b.obj: only .gltf and .glb files can be exported");
        assert!(ExportFormat::of_path(Path::new("gltf")).is_err());
    }

    #[test]
    fn spot_matrices_carry_the_direction_exactly() {
        for d in [Vec3::NEG_Y, Vec3::Y, Vec3::new(0.3, -0.8, 0.2).normalize(), Vec3::X] {
            let m = spot_matrix(Vec3::new(1.0, 2.0, 3.0), d);
            assert_eq!(m.transform_vector3(Vec3::NEG_Z), d);
            assert!((m.determinant() - 1.0).abs() < 1e-5, "a rotation: {}", m.determinant());
        }
    }

    #[test]
    fn nulls_are_found_with_their_path() {
        assert_eq!(null_number(&json!({"a": [1, {"b": null}]})), Some(".a[1].b".to_owned()));
        assert_eq!(null_number(&json!({"exposure": null, "c": [1.5]})), None);
    }

    #[test]
    fn mipmapped_samplers_get_gltfs_codes() {
        let s = |min, mipmap| sampler_json(&Sampler { min, mipmap, ..Sampler::default() })["minFilter"].clone();
        assert_eq!(s(Filter::Nearest, Some(Filter::Nearest)), json!(9984));
        assert_eq!(s(Filter::Linear, Some(Filter::Nearest)), json!(9985));
        assert_eq!(s(Filter::Nearest, Some(Filter::Linear)), json!(9986));
        assert_eq!(s(Filter::Linear, Some(Filter::Linear)), json!(9987));
        assert_eq!(s(Filter::Linear, None), json!(writer::LINEAR));
    }

    #[test]
    fn nan_and_bad_lights_are_named() {
        let mut scene = tiledlight_scene::default_scene(&DefaultSceneOptions::default()).unwrap();
        let good = Light::point(Vec3::ONE, Vec3::ONE, 1.0, 0.1).unwrap();
        let nan = Light { intensity: f32::NAN, ..good };
        let e = format!("{:#}", gltf_document(&scene, &[good, nan], &camera(), &frame()).unwrap_err());
        assert!(e.starts_with("light 1 cannot be exported"), "{e}");
        let e = format!(
            "{:#}",
            gltf_document(&scene, &[good], &camera(), &FrameExtras { exposure: Some(f32::NAN), ..frame() })
                .unwrap_err()
        );
        assert!(e.contains("exposure"), "{e}");
        scene.meshes[0].positions[0][1] = f32::NAN;
        let e = format!("{:#}", gltf_document(&scene, &[good], &camera(), &frame()).unwrap_err());
        assert!(e.starts_with("the scene cannot be exported"), "{e}");
        let ortho = Camera::orthographic(Vec3::Z, Vec3::ZERO, Vec3::Y, 1.0, 1.0, 0.0, 10.0).unwrap();
        scene.meshes[0].positions[0][1] = 0.0;
        let e = format!("{:#}", gltf_document(&scene, &[good], &ortho, &frame()).unwrap_err());
        assert!(e.contains("orthographic"), "{e}");
    }

    #[test]
    fn the_courtyard_comes_back_with_its_lights_materials_and_camera() {
        let opts = DefaultSceneOptions {
            grid_objects: 6,
            transparent_objects: 2,
            emissive_banners: true,
            ..Default::default()
        };
        let mut scene = tiledlight_scene::default_scene(&opts).unwrap();
        // A mirrored instance: its mesh must come back with the same winding.
        let mut mirrored = scene.instances[0].clone();
        mirrored.transform = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * mirrored.transform;
        scene.meshes.push({
            let mut m = scene.meshes[mirrored.mesh].clone();
            m.indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
            m
        });
        mirrored.mesh = scene.meshes.len() - 1;
        scene.instances.push(mirrored);
        let lights = tiledlight_scene::random_lights(
            &scene.bounds,
            &tiledlight_scene::LightOptions { num_point: 20, num_spot: 7, ..Default::default() },
        )
        .unwrap();
        let (root, bin) = gltf_document(&scene, &lights, &camera(), &frame()).unwrap();
        let bytes = writer::glb_bytes(&root, &bin);
        let loaded = load_gltf_bytes(&bytes, Path::new("export.glb"), &LoadOptions::new(0.1)).unwrap();
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let back = loaded.scene;
        assert_same_lights(&back.lights, &lights);
        // Geometry and materials: every instance draws the same triangles with the same
        // material values (the loader names meshes after the glTF mesh, and re-normalises
        // normals: within 1e-6).
        assert_eq!(back.instances.len(), scene.instances.len());
        for (a, b) in scene.instances.iter().zip(&back.instances) {
            assert_eq!(a.transform, b.transform);
            let (ma, mb) = (&scene.meshes[a.mesh], &back.meshes[b.mesh]);
            assert!(ma.positions == mb.positions, "positions of {}", ma.name);
            assert!(ma.indices == mb.indices, "indices of {}", ma.name);
            let dn =
                ma.normals.iter().zip(&mb.normals).map(|(x, y)| (Vec3::from(*x) - Vec3::from(*y)).abs().max_element());
            assert!(dn.fold(0f32, f32::max) <= 1e-6, "normals of {}", ma.name);
            let (pa, pb) = (&scene.materials[a.material], &back.materials[b.material]);
            assert_eq!(Material { name: String::new(), ..pa.clone() }, Material { name: String::new(), ..pb.clone() });
        }
        assert_eq!(
            back.textures.iter().map(|t| &t.rgba8).collect::<Vec<_>>(),
            scene.textures.iter().map(|t| &t.rgba8).collect::<Vec<_>>()
        );
        let cam = back.camera.expect("the camera comes back");
        let c = camera();
        assert!((cam.eye - c.eye()).length() < 1e-5, "{} vs {}", cam.eye, c.eye());
        let back_view =
            Camera::perspective(cam.eye, cam.target, cam.up, cam.fov_y, 16.0 / 9.0, cam.near, cam.far).unwrap();
        let d = (back_view.view_proj() - c.view_proj()).to_cols_array().iter().fold(0f32, |m, x| m.max(x.abs()));
        assert!(d < 1e-5, "view-projection differs by {d}");
        assert_eq!((cam.fov_y, cam.near, cam.far), (0.9, 0.1, None));
        let extras = &root["nodes"].as_array().unwrap().last().unwrap()["extras"]["tiledlight"];
        assert_eq!(extras["exposure"], json!(1.5));
        assert_eq!(extras["width"], json!(64));
    }
}

#[cfg(test)]
mod materials_scene_tests {
    use super::*;
    use tiledlight_scene::{load_gltf_bytes, LoadOptions, Material};

    /// The many-material scene (`--scene materials`) written and read back: every
    /// material's values, samplers, transforms and UV sets, and every image's texels, come
    /// back, so tests and peers can load the file in its place.
    #[test]
    fn the_materials_scene_comes_back_from_its_file() {
        let scene = tiledlight_scene::materials::materials_scene(24).unwrap();
        let camera =
            Camera::perspective(Vec3::new(0.0, 5.0, 10.0), Vec3::ZERO, Vec3::Y, 0.9, 16.0 / 9.0, 0.1, None).unwrap();
        let frame = FrameExtras { exposure: None, width: 64, height: 36, ambient: Vec3::splat(0.02) };
        let (root, bin) = gltf_document(&scene, &[], &camera, &frame).unwrap();
        let bytes = writer::glb_bytes(&root, &bin);
        let loaded = load_gltf_bytes(&bytes, Path::new("materials.glb"), &LoadOptions::new(0.1)).unwrap();
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let back = loaded.scene;
        assert_eq!(back.instances.len(), scene.instances.len());
        // A material's values and texture references; its images by their texels (the file
        // numbers images in the order slots name them).
        let texels = |s: &tiledlight_scene::Scene, m: &Material| {
            let refs = [&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture];
            let more = [&m.occlusion_texture, &m.emissive_texture];
            refs.into_iter()
                .chain(more)
                .map(|r| r.as_ref().map(|r| s.textures[r.texture].rgba8.clone()))
                .collect::<Vec<_>>()
        };
        let unnumbered = |m: &Material| {
            let mut m = Material { name: String::new(), ..m.clone() };
            for r in [
                &mut m.base_color_texture,
                &mut m.metallic_roughness_texture,
                &mut m.normal_texture,
                &mut m.occlusion_texture,
                &mut m.emissive_texture,
            ]
            .into_iter()
            .flatten()
            {
                r.texture = 0;
            }
            m
        };
        for (a, b) in scene.instances.iter().zip(&back.instances) {
            let (pa, pb) = (&scene.materials[a.material], &back.materials[b.material]);
            assert_eq!(unnumbered(pa), unnumbered(pb));
            assert!(texels(&scene, pa) == texels(&back, pb), "the images of {}", pa.name);
        }
        assert!(back.meshes.iter().any(|m| !m.uvs1.is_empty()), "the boxes' second UV set comes back");
        assert_eq!(back.textures.len(), scene.textures.len());
    }
}
