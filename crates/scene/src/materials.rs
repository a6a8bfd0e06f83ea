//! The many-material scene (`--scene materials`, issue 46): a floor and a fixed 24 x 24 grid
//! of boxes whose materials are `count` distinct textured materials (box `i` takes material
//! `i % count`), so the screen's coverage is the same at 2 materials as at 512 and only
//! the material count changes. What the scene exercises, by material index `m`:
//!
//! 1. every material its own base-colour image, of one of seven sizes (32 to 256 texels;
//!    100 x 60 and 48 x 48 are not powers of two);
//! 2. every fourth (`m % 4 == 1`) a normal map of its own (with tangents on the boxes);
//! 3. every sixth (`m % 6 == 5`) alpha-masked (holes in its base colour's alpha, cutoff 0.5);
//! 4. every fifth (`m % 5 == 2`) its base colour read through the second UV set;
//! 5. every third (`m % 3 == 0`) a texture transform (rotated and scaled);
//! 6. every seventh (`m % 7 == 3`) a metallic-roughness image, every ninth (`m % 9 == 4`)
//!    an occlusion image, every eleventh (`m % 11 == 6`) an emissive image and factor;
//! 7. wrap modes cycling through repeat, mirrored repeat and clamp on each axis, and every
//!    eighth sampler nearest without mipmaps.
//!
//! The camera looks down on the grid from its front edge. Depends on this crate's model and
//! geometry, and glam.

use glam::{Mat4, Vec2, Vec3};

use crate::error::SceneError;
use crate::geometry::{add_box, add_grid, MeshBuilder};
use crate::model::{
    Aabb, AlphaMode, CameraDesc, Filter, Instance, Material, Mesh, Sampler, Scene, Texture, TextureRef, UvTransform,
    Wrap,
};

/// Materials of `--scene materials` unless `--materials` says otherwise.
pub const DEFAULT_MATERIALS: u32 = 144;
/// The most materials the scene takes (`--materials`).
pub const MAX_MATERIALS: u32 = 4096;
/// Boxes along each side of the grid.
const GRID: u32 = 24;
/// Distance between box centres, metres.
const SPACING: f32 = 1.6;
/// A box's side, metres.
const BOX: f32 = 1.1;
/// The base-colour image sizes, cycled by material.
const SIZES: [(u32, u32); 7] = [(64, 64), (128, 128), (32, 32), (128, 64), (100, 60), (256, 256), (48, 48)];

/// A small deterministic hash of `(m, x, y, salt)` to 0..=255.
fn noise(m: u32, x: u32, y: u32, salt: u32) -> u8 {
    let mut h = m.wrapping_mul(0x9e37_79b9) ^ x.wrapping_mul(0x85eb_ca6b) ^ y.wrapping_mul(0xc2b2_ae35) ^ salt;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    (h & 0xff) as u8
}

/// An image of `w` x `h` from `texel(x, y)`.
fn image(name: String, (w, h): (u32, u32), texel: impl Fn(u32, u32) -> [u8; 4]) -> Texture {
    let rgba8 = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).flat_map(|(x, y)| texel(x, y)).collect();
    Texture { name, width: w, height: h, rgba8 }
}

/// Material `m`'s hue as an sRGB byte triple.
fn hue(m: u32) -> [u8; 3] {
    let t = (m as f32 * 0.618_034).fract() * 6.0;
    let c = |k: f32| {
        let v = ((t + k) % 6.0 - 3.0).abs() - 1.0;
        (60.0 + 180.0 * v.clamp(0.0, 1.0)) as u8
    };
    [c(0.0), c(4.0), c(2.0)]
}

/// The sampler of material `m` (step 7).
fn sampler(m: u32) -> Sampler {
    const WRAPS: [Wrap; 3] = [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge];
    if m % 8 == 7 {
        return Sampler {
            wrap_u: WRAPS[(m as usize / 8) % 3],
            wrap_v: Wrap::Repeat,
            mag: Filter::Nearest,
            min: Filter::Nearest,
            mipmap: None,
        };
    }
    Sampler { wrap_u: WRAPS[m as usize % 3], wrap_v: WRAPS[(m as usize / 3) % 3], ..Sampler::default() }
}

/// A box of side [`BOX`] on the floor with tangents along each face's u edge and a second
/// UV set (half the first, offset).
fn box_mesh() -> Mesh {
    let mut b = MeshBuilder::new();
    let h = 0.5 * BOX;
    add_box(&mut b, Vec3::new(-h, 0.0, -h), Vec3::new(h, BOX, h), BOX);
    let mut mesh = b.build("box");
    // add_box's faces are add_grid quads of 4 vertices: u runs along the first edge.
    mesh.tangents = mesh
        .positions
        .chunks_exact(4)
        .flat_map(|q| {
            let t = (Vec3::from(q[1]) - Vec3::from(q[0])).normalize_or_zero();
            [[t.x, t.y, t.z, 1.0]; 4]
        })
        .collect();
    mesh.uvs1 = mesh.uvs.iter().map(|uv| [uv[0] * 0.5 + 0.25, uv[1] * 0.5 + 0.25]).collect();
    mesh
}

/// The floor under the grid, its texture every 2 m.
fn floor_mesh(half: f32) -> Mesh {
    let mut b = MeshBuilder::new();
    add_grid(
        &mut b,
        Vec3::new(-half, 0.0, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        8,
        8,
        2.0,
    );
    let mut mesh = b.build("floor");
    mesh.tangents = vec![[1.0, 0.0, 0.0, 1.0]; mesh.positions.len()];
    mesh.uvs1 = mesh.uvs.clone();
    mesh
}

/// Material `m` and the images it adds to `textures` (module doc, steps 1 to 7).
fn material(m: u32, textures: &mut Vec<Texture>) -> Material {
    let mut add = |t: Texture| {
        textures.push(t);
        textures.len() - 1
    };
    let size = SIZES[m as usize % SIZES.len()];
    let [r, g, b] = hue(m);
    let masked = m % 6 == 5;
    let cell = 4 + m % 5;
    let base = add(image(format!("m{m}.base"), size, |x, y| {
        let light = ((x / cell) + (y / cell)).is_multiple_of(2);
        let n = noise(m, x, y, 1) / 8;
        let k = if light { 255 } else { 150 };
        let a = if masked && (x / cell) % 3 == 1 && (y / cell) % 3 == 1 { 0 } else { 255 };
        [(r as u32 * k / 255) as u8 + n / 2, (g as u32 * k / 255) as u8 + n / 2, (b as u32 * k / 255) as u8, a]
    }));
    let transform = if m.is_multiple_of(3) {
        UvTransform { offset: [0.1, 0.2], rotation: 0.3 + 0.01 * m as f32, scale: [1.5, 2.0] }
    } else {
        UvTransform::default()
    };
    let tex = |texture, tex_coord| TextureRef { texture, tex_coord, sampler: sampler(m), transform };
    let mut mat = Material {
        name: format!("material {m}"),
        base_color: [1.0; 4],
        base_color_texture: Some(tex(base, u32::from(m % 5 == 2))),
        roughness: 0.3 + 0.6 * ((m * 7) % 10) as f32 / 10.0,
        metallic: if m % 10 == 3 { 0.9 } else { 0.0 },
        alpha_mode: if masked { AlphaMode::Mask { cutoff: 0.5 } } else { AlphaMode::Opaque },
        ..Material::default()
    };
    if m % 4 == 1 {
        let normal = add(image(format!("m{m}.normal"), (64, 64), |x, y| {
            // Bumps: a tilted normal near each cell's edges.
            let dx = if x % 16 < 3 {
                90
            } else if x % 16 > 12 {
                166
            } else {
                128
            };
            let dy = if y % 16 < 3 {
                90
            } else if y % 16 > 12 {
                166
            } else {
                128
            };
            [dx, dy, 230, 255]
        }));
        mat.normal_texture = Some(tex(normal, 0));
        mat.normal_scale = 1.0;
    }
    if m % 7 == 3 {
        let mr = add(image(format!("m{m}.mr"), (32, 32), |x, y| {
            [0, 64 + noise(m, x, y, 2) / 2, 255 * ((x / 8) % 2) as u8, 255]
        }));
        mat.metallic_roughness_texture = Some(tex(mr, 0));
        mat.metallic = 1.0;
        mat.roughness = 1.0;
    }
    if m % 9 == 4 {
        let ao = add(image(format!("m{m}.occlusion"), (32, 32), |x, y| {
            let v = 120 + (x.min(31 - x).min(y).min(31 - y) * 16).min(135) as u8;
            [v, v, v, 255]
        }));
        mat.occlusion_texture = Some(tex(ao, 0));
        mat.occlusion_strength = 1.0;
    }
    if m % 11 == 6 {
        let e = add(image(format!("m{m}.emissive"), (64, 32), |x, y| {
            if (x / 4 + y / 4) % 5 == 0 {
                [255, 220, 160, 255]
            } else {
                [0, 0, 0, 255]
            }
        }));
        mat.emissive_texture = Some(tex(e, 0));
        mat.emissive = [1.0, 0.8, 0.5];
        mat.emissive_strength = 2.0;
    }
    mat
}

/// The many-material scene with `count` materials (module doc). Fails, naming the limit,
/// for 0 or more than [`MAX_MATERIALS`].
pub fn materials_scene(count: u32) -> Result<Scene, SceneError> {
    if count == 0 || count > MAX_MATERIALS {
        return Err(SceneError::InvalidArgument(format!(
            "--materials {count}: the materials scene takes 1 to {MAX_MATERIALS} materials"
        )));
    }
    let mut textures = Vec::new();
    let materials: Vec<Material> = (0..count).map(|m| material(m, &mut textures)).collect();
    let half = 0.5 * SPACING * GRID as f32 + 1.0;
    let meshes = vec![floor_mesh(half), box_mesh()];
    let mut instances = vec![Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }];
    for i in 0..GRID * GRID {
        let (x, z) = ((i % GRID) as f32, (i / GRID) as f32);
        let at = Vec2::new(x - 0.5 * (GRID - 1) as f32, z - 0.5 * (GRID - 1) as f32) * SPACING;
        let turn = Mat4::from_rotation_y(0.2 * (i % 7) as f32);
        instances.push(Instance {
            mesh: 1,
            material: (i % count) as usize,
            transform: Mat4::from_translation(Vec3::new(at.x, 0.0, at.y)) * turn,
        });
    }
    let mut scene = Scene {
        name: format!("materials ({count})"),
        meshes,
        materials,
        textures,
        instances,
        lights: Vec::new(),
        camera: Some(CameraDesc {
            eye: Vec3::new(0.0, 16.0, half + 6.0),
            target: Vec3::new(0.0, 0.0, -2.0),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: None,
        }),
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate()?;
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_feature_the_doc_names_is_in_the_scene() {
        let s = materials_scene(DEFAULT_MATERIALS).unwrap();
        assert_eq!(s.materials.len(), 144);
        assert_eq!(s.instances.len() as u32, 1 + GRID * GRID);
        let m = &s.materials;
        let sizes: std::collections::BTreeSet<(u32, u32)> = m
            .iter()
            .map(|m| &s.textures[m.base_color_texture.as_ref().unwrap().texture])
            .map(|t| (t.width, t.height))
            .collect();
        assert_eq!(sizes.len(), SIZES.len());
        assert!(sizes.iter().any(|(w, h)| !w.is_power_of_two() || !h.is_power_of_two()));
        assert_eq!(m.iter().filter(|m| m.normal_texture.is_some()).count(), 36);
        assert!(m.iter().any(|m| matches!(m.alpha_mode, AlphaMode::Mask { .. })));
        assert!(m.iter().any(|m| m.uses_uv1()));
        assert!(m.iter().any(|m| m.base_color_texture.as_ref().unwrap().transform != UvTransform::default()));
        assert!(m.iter().any(|m| m.metallic_roughness_texture.is_some()));
        assert!(m.iter().any(|m| m.occlusion_texture.is_some()));
        assert!(m.iter().any(|m| m.emissive_texture.is_some() && m.is_emissive()));
        let wraps: std::collections::BTreeSet<String> = m
            .iter()
            .map(|m| m.base_color_texture.as_ref().unwrap().sampler)
            .flat_map(|s| [format!("{:?}", s.wrap_u), format!("{:?}", s.wrap_v)])
            .collect();
        assert_eq!(wraps.len(), 3);
        assert!(m.iter().any(|m| m.base_color_texture.as_ref().unwrap().sampler.mipmap.is_none()));
        // Every material is drawn (144 < 576 boxes), and the box count does not change.
        let drawn: std::collections::BTreeSet<usize> = s.instances.iter().map(|i| i.material).collect();
        assert_eq!(drawn.len(), 144);
        let two = materials_scene(2).unwrap();
        assert_eq!(two.instances.len(), s.instances.len());
        assert_eq!(two.materials.len(), 2);
    }

    #[test]
    fn counts_outside_the_range_are_refused_by_name() {
        for n in [0, MAX_MATERIALS + 1] {
            let e = materials_scene(n).unwrap_err().to_string();
            assert!(e.contains("--materials") && e.contains("4096"), "{e}");
        }
    }
}
