//! Test scenes, cameras and lights: the built-in courtyard, a small hand-made scene that
//! exercises every material path (texture, alpha mask, double-sided, metal), and seeded
//! random lights, plus cameras at the extremes DESIGN.md lists; the shadow tests' scenes (a
//! table to put a light under, a floating alpha-masked screen) and the alpha test the CPU
//! ray cast applies to masked surfaces ([`alpha_blocks`]).

use glam::{Mat4, Vec3};
use tiledlight_cull::{Camera, Light};
use tiledlight_scene::{
    default_scene, random_lights, Aabb, AlphaMode, DefaultSceneOptions, Filter, LightOptions, Material, Mesh, Sampler,
    Scene, Texture, TextureRef, Wrap,
};

/// The built-in courtyard (no grid objects).
pub fn courtyard() -> Scene {
    default_scene(&DefaultSceneOptions::default()).expect("default scene")
}

/// The courtyard's own camera for a `w` x `h` screen.
pub fn courtyard_camera(scene: &Scene, w: u32, h: u32) -> Camera {
    let c = scene.camera.expect("default scene has a camera");
    Camera::perspective(c.eye, c.target, c.up, c.fov_y, w as f32 / h as f32, c.near, c.far).expect("camera")
}

/// `n_point` point and `n_spot` spot lights, seeded, inside `scene`'s bounds.
pub fn lights(scene: &Scene, n_point: u32, n_spot: u32, seed: u64) -> Vec<Light> {
    random_lights(&scene.bounds, &LightOptions { num_point: n_point, num_spot: n_spot, seed, ..Default::default() })
        .expect("lights")
}

/// Lights in the slab between heights `y0` and `y1` over `scene`'s footprint. Above the
/// mixed scene's geometry (which ends at 3.1 m) none comes within 0.4 m of a surface, so
/// shading varies smoothly across a pixel: no sub-pixel hot spot (a light's 1 cm core
/// touching a surface) for MSAA's one-sample-per-triangle and per-sample shading to
/// resolve differently.
pub fn lights_in_slab(scene: &Scene, y0: f32, y1: f32, n_point: u32, n_spot: u32, seed: u64) -> Vec<Light> {
    let b = &scene.bounds;
    let slab = Aabb::new(Vec3::new(b.min.x, y0, b.min.z), Vec3::new(b.max.x, y1, b.max.z));
    random_lights(&slab, &LightOptions { num_point: n_point, num_spot: n_spot, seed, ..Default::default() })
        .expect("lights")
}

/// A `size` x `size` quad in the XZ plane, centred, facing +Y.
pub fn quad(name: &str, size: f32) -> Mesh {
    let s = size * 0.5;
    Mesh {
        name: name.into(),
        positions: vec![[-s, 0.0, -s], [-s, 0.0, s], [s, 0.0, s], [s, 0.0, -s]],
        normals: vec![[0.0, 1.0, 0.0]; 4],
        uvs: vec![[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Mesh::default()
    }
}

/// A unit cube, centred, faces wound counter-clockwise seen from outside.
pub fn cube(name: &str) -> Mesh {
    let mut m = Mesh { name: name.into(), ..Mesh::default() };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // u x v = n, so (u, v) corners in this order wind counter-clockwise seen from outside.
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let base = m.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.positions.push((n * 0.5 + u * 0.5 * a + v * 0.5 * b).to_array());
                m.normals.push(n.to_array());
                m.uvs.push([(a + 1.0) * 0.5, (b + 1.0) * 0.5]);
            }
            m.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    m
}

/// An opaque, single-sided material without texture.
pub fn material(name: &str, color: [f32; 4], roughness: f32, metallic: f32) -> Material {
    Material {
        name: name.into(),
        base_color: color,
        roughness,
        metallic,
        alpha_mode: AlphaMode::Opaque,
        ..Material::default()
    }
}

/// A 20 m square room: floor, boxes, a metal box, a textured alpha-masked double-sided
/// screen (a checker with holes) and a double-sided plain panel. Every material path.
pub fn mixed_scene() -> Scene {
    let mut tex = vec![0u8; 16 * 16 * 4];
    for y in 0..16 {
        for x in 0..16 {
            let on = (x / 4 + y / 4) % 2 == 0;
            let i = (y * 16 + x) * 4;
            tex[i..i + 4].copy_from_slice(if on { &[230, 200, 120, 255] } else { &[40, 90, 200, 0] });
        }
    }
    let mut masked = material("screen", [1.0; 4], 0.6, 0.0);
    masked.base_color_texture = Some(TextureRef::new(0));
    masked.alpha_mode = AlphaMode::Mask { cutoff: 0.5 };
    masked.double_sided = true;
    let mut panel = material("panel", [0.3, 0.8, 0.4, 1.0], 0.4, 0.0);
    panel.double_sided = true;
    let materials = vec![
        material("floor", [0.7, 0.7, 0.7, 1.0], 0.8, 0.0),
        material("box", [0.8, 0.3, 0.25, 1.0], 0.5, 0.0),
        material("metal", [0.95, 0.9, 0.8, 1.0], 0.25, 1.0),
        masked,
        panel,
    ];
    let meshes = vec![quad("floor", 20.0), cube("cube"), quad("screen", 3.0)];
    let inst = |mesh, material, t: Mat4| tiledlight_scene::Instance { mesh, material, transform: t };
    let mut instances = vec![inst(0, 0, Mat4::IDENTITY)];
    for i in 0..6 {
        let x = -6.0 + 2.4 * i as f32;
        let t = Mat4::from_translation(Vec3::new(x, 0.75, -3.0 + (i % 2) as f32 * 2.0))
            * Mat4::from_scale(Vec3::new(1.2, 1.5, 1.2));
        instances.push(inst(1, if i == 3 { 2 } else { 1 }, t));
    }
    // Standing screens: the quad rotated upright.
    let upright = Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
    instances.push(inst(2, 3, Mat4::from_translation(Vec3::new(-2.0, 1.6, 1.0)) * upright));
    instances.push(inst(2, 4, Mat4::from_translation(Vec3::new(3.0, 1.6, 2.0)) * Mat4::from_rotation_y(0.6) * upright));
    let mut scene = Scene {
        name: "mixed".into(),
        meshes,
        materials,
        textures: vec![Texture { name: "checker".into(), width: 16, height: 16, rgba8: tex }],
        instances,
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    // Lights live above the floor too.
    scene.bounds.max.y = scene.bounds.max.y.max(4.0);
    scene.validate().expect("mixed scene is valid");
    scene
}

/// A camera looking at the mixed scene from a corner.
pub fn mixed_camera(w: u32, h: u32) -> Camera {
    Camera::perspective(
        Vec3::new(7.0, 4.5, 9.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::Y,
        55f32.to_radians(),
        w as f32 / h as f32,
        0.1,
        None,
    )
    .expect("camera")
}

/// A 20 m square floor (y = 0) of one material, albedo (0.8, 0.6, 0.4), lit by `lights`: the
/// scene the BRDF tests evaluate pixel by pixel on the CPU.
pub fn floor_scene(roughness: f32, metallic: f32, lights: Vec<Light>) -> Scene {
    let floor = Mesh {
        name: "floor".into(),
        positions: vec![[-10.0, 0.0, -10.0], [-10.0, 0.0, 10.0], [10.0, 0.0, 10.0], [10.0, 0.0, -10.0]],
        normals: vec![[0.0, 1.0, 0.0]; 4],
        uvs: vec![[0.0, 0.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Mesh::default()
    };
    let mat =
        Material { name: "m".into(), base_color: [0.8, 0.6, 0.4, 1.0], roughness, metallic, ..Material::default() };
    Scene {
        name: "floor".into(),
        meshes: vec![floor],
        materials: vec![mat],
        textures: vec![],
        instances: vec![tiledlight_scene::Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }],
        lights,
        camera: None,
        bounds: Aabb::new(Vec3::new(-10.0, 0.0, -10.0), Vec3::new(10.0, 5.0, 10.0)),
    }
}

/// The camera of [`floor_scene`]'s tests: 3 m up, 6 m back, looking at the origin, 60 degrees.
pub fn floor_camera(w: u32, h: u32) -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 3.0, 6.0),
        Vec3::ZERO,
        Vec3::Y,
        60f32.to_radians(),
        w as f32 / h as f32,
        0.1,
        None,
    )
    .expect("camera")
}

/// Cubes (each a unit [`cube`] placed by its transform) merged into one mesh.
fn cubes(name: &str, transforms: &[Mat4]) -> Mesh {
    let unit = cube("cube");
    let mut m = Mesh { name: name.into(), ..Mesh::default() };
    for t in transforms {
        let base = m.positions.len() as u32;
        m.positions.extend(unit.positions.iter().map(|p| t.transform_point3(Vec3::from_array(*p)).to_array()));
        m.normals.extend(unit.normals.iter().map(|n| t.transform_vector3(Vec3::from_array(*n)).normalize().to_array()));
        m.uvs.extend(&unit.uvs);
        m.indices.extend(unit.indices.iter().map(|i| base + i));
    }
    m
}

/// A 20 m floor and a table over its centre, the table ONE instance (one mesh): a 3 x 0.2 x
/// 3 m top at 1.8 to 2.0 m on four 0.3 m legs at x, z = +-1.2 m. A light under the top lies
/// inside the table instance's bounds, not enclosed: the legs shadow the floor around it.
pub fn table_scene() -> Scene {
    let leg =
        |x: f32, z: f32| Mat4::from_translation(Vec3::new(x, 0.9, z)) * Mat4::from_scale(Vec3::new(0.3, 1.8, 0.3));
    let top = Mat4::from_translation(Vec3::new(0.0, 1.9, 0.0)) * Mat4::from_scale(Vec3::new(3.0, 0.2, 3.0));
    let table = cubes("table", &[top, leg(-1.2, -1.2), leg(1.2, -1.2), leg(-1.2, 1.2), leg(1.2, 1.2)]);
    let inst = |mesh, material| tiledlight_scene::Instance { mesh, material, transform: Mat4::IDENTITY };
    let mut scene = Scene {
        name: "table".into(),
        meshes: vec![quad("floor", 20.0), table],
        materials: vec![
            material("floor", [0.7, 0.7, 0.7, 1.0], 0.8, 0.0),
            material("wood", [0.6, 0.4, 0.2, 1.0], 0.6, 0.0),
        ],
        textures: vec![],
        instances: vec![inst(0, 0), inst(1, 1)],
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.bounds.max.y = scene.bounds.max.y.max(6.0);
    scene.validate().expect("table scene is valid");
    scene
}

/// A 20 m floor and a 4 m square horizontal screen 2 m over it, alpha-masked (cutoff 0.5)
/// with a 4 x 4 checker of opaque cells and holes (1 m each), sampled NEAREST without
/// mipmaps so the mask's edges are exactly the cells' (the CPU ray cast's
/// [`alpha_blocks`] gives the GPU's alpha test exactly). Double-sided, so the screen
/// shadows from either side.
pub fn masked_screen_scene() -> Scene {
    let mut tex = vec![0u8; 4 * 4 * 4];
    for y in 0..4 {
        for x in 0..4 {
            let i = (y * 4 + x) * 4;
            tex[i..i + 4].copy_from_slice(if (x + y) % 2 == 0 { &[220, 200, 150, 255] } else { &[0, 0, 0, 0] });
        }
    }
    let mut screen = material("screen", [1.0; 4], 0.6, 0.0);
    let sampler = Sampler {
        wrap_u: Wrap::ClampToEdge,
        wrap_v: Wrap::ClampToEdge,
        mag: Filter::Nearest,
        min: Filter::Nearest,
        mipmap: None,
    };
    screen.base_color_texture = Some(TextureRef { sampler, ..TextureRef::new(0) });
    screen.alpha_mode = AlphaMode::Mask { cutoff: 0.5 };
    screen.double_sided = true;
    let mut screen_mesh = quad("screen", 4.0);
    screen_mesh.uvs = vec![[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
    let inst = |mesh, material, t| tiledlight_scene::Instance { mesh, material, transform: t };
    let mut scene = Scene {
        name: "masked screen".into(),
        meshes: vec![quad("floor", 20.0), screen_mesh],
        materials: vec![material("floor", [0.7, 0.7, 0.7, 1.0], 0.8, 0.0), screen],
        textures: vec![Texture { name: "holes".into(), width: 4, height: 4, rgba8: tex }],
        instances: vec![inst(0, 0, Mat4::IDENTITY), inst(1, 1, Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)))],
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.bounds.max.y = scene.bounds.max.y.max(6.0);
    scene.validate().expect("masked screen scene is valid");
    scene
}

/// The alpha test of `scene`'s masked materials, for the CPU ray cast
/// (`Triangles::occluded_where` over `scene.world_triangles()`): whether world triangle
/// `index` (in `world_triangles` order) blocks light at barycentrics `(u, v)`. Opaque and
/// blended materials always block (as `world_triangles` counts them); a masked one blocks
/// where base colour alpha times the base colour texture's alpha at the interpolated
/// texture coordinates (its set, `KHR_texture_transform` and wrap) is at least the
/// cutoff, as the depth and shadow passes' `discard` decides. The texture is read at mip 0:
/// exactly (nearest texel) for a NEAREST sampler without mipmaps, bilinearly otherwise,
/// where the GPU may read a coarser mip level (an approximation near the mask's edges).
pub fn alpha_blocks(scene: &Scene) -> impl Fn(usize, f32, f32) -> bool + '_ {
    // Per world triangle: (instance, first index of the triangle in its mesh).
    let mut tris = Vec::new();
    for (k, inst) in scene.instances.iter().enumerate() {
        let Some(mesh) = scene.meshes.get(inst.mesh) else { continue };
        let n = mesh.positions.len() as u32;
        for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
            if tri.iter().all(|&i| i < n) {
                tris.push((k, t * 3));
            }
        }
    }
    move |index, u, v| {
        let Some(&(k, first)) = tris.get(index) else { return true };
        let inst = &scene.instances[k];
        let (Some(mesh), Some(mat)) = (scene.meshes.get(inst.mesh), scene.materials.get(inst.material)) else {
            return true;
        };
        let AlphaMode::Mask { cutoff } = mat.alpha_mode else { return true };
        let mut alpha = mat.base_color[3];
        if let Some(tr) = &mat.base_color_texture {
            let set = mesh.uv_set(tr.tex_coord);
            let idx = &mesh.indices[first..first + 3];
            let uv = |i: u32| glam::Vec2::from_array(set.get(i as usize).copied().unwrap_or([0.0, 0.0]));
            let (a, b, c) = (uv(idx[0]), uv(idx[1]), uv(idx[2]));
            let at = tr.transform.apply((a + (b - a) * u + (c - a) * v).to_array());
            if let Some(tex) = scene.textures.get(tr.texture) {
                alpha *= texture_alpha(tex, &tr.sampler, at);
            }
        }
        alpha >= cutoff
    }
}

/// Alpha of `tex` at texture coordinates `uv` read with `sampler` at mip 0.
fn texture_alpha(tex: &Texture, sampler: &Sampler, uv: [f32; 2]) -> f32 {
    let (w, h) = (tex.width as i64, tex.height as i64);
    let wrap = |i: i64, n: i64, mode: Wrap| -> i64 {
        match mode {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }
    };
    let texel = |x: i64, y: i64| -> f32 {
        let (x, y) = (wrap(x, w, sampler.wrap_u), wrap(y, h, sampler.wrap_v));
        f32::from(tex.rgba8[((y * w + x) * 4 + 3) as usize]) / 255.0
    };
    let (fx, fy) = (uv[0] * w as f32, uv[1] * h as f32);
    if sampler.mag == Filter::Nearest && sampler.min == Filter::Nearest && sampler.mipmap.is_none() {
        return texel(fx.floor() as i64, fy.floor() as i64);
    }
    let (x, y) = (fx - 0.5, fy - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let top = texel(x0, y0) * (1.0 - tx) + texel(x0 + 1, y0) * tx;
    let bottom = texel(x0, y0 + 1) * (1.0 - tx) + texel(x0 + 1, y0 + 1) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// A scene of the given parts, its bounds computed and validated (`name` in the message
/// when it is not valid): the common tail of a test's hand-built scene.
pub fn assemble(
    name: &str,
    meshes: Vec<Mesh>,
    (materials, textures): (Vec<tiledlight_scene::Material>, Vec<tiledlight_scene::Texture>),
    instances: Vec<tiledlight_scene::Instance>,
) -> Scene {
    let mut scene = Scene {
        name: name.into(),
        meshes,
        materials,
        textures,
        instances,
        lights: vec![],
        camera: None,
        bounds: tiledlight_scene::Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
    scene
}
