//! Scenes of other engines' benchmarks, rebuilt so that tiledlight and the engine render
//! the same thing (`tiledlight export` writes them for the peer; `--scene NAME` renders
//! them here).
//!
//! [`bevy_many_lights`] is Bevy 0.19's `examples/stress_tests/many_lights.rs` (read from
//! the 0.19.1 crate; no code of it is used here):
//! 1. an icosphere of radius 50 m (Bevy's `Sphere::new(50).mesh().ico(9)`: each of the
//!    icosahedron's 20 faces cut into 10 x 10 triangles, 2,000 in all), white, turned
//!    inside out (Bevy scales it by -1: normals point to the centre);
//! 2. a deep-pink 5 m cube centred at (0, 50, 0), on the sphere's top;
//! 3. 100,000 point lights of range 0.3 m and 1,000 lm (Bevy's unit; 1000 / 4 pi cd here,
//!    which is what Bevy renders: it divides lumens by 4 pi) on a Fibonacci spiral over
//!    the sphere of radius 50 (the example's spiral, epsilon 0.36), each of a fully
//!    saturated hue (`Color::hsl(h, 1, 0.5)`, an sRGB colour, made linear here; random in
//!    Bevy, from a fixed random stream here so the scene is the same every run);
//! 4. Bevy's default camera: at the origin looking down -Z, 45 degree vertical field of
//!    view, near 0.1 m (the example turns it slowly; the benchmark holds it still).
//!
//! What that makes the scene measure: the lights sit on the true sphere, and the
//! icosphere's flat faces lie inside it (up to 15 cm at a face's centre, within the
//! lights' 0.3 m range), facing the
//! centre, so every light is behind the surface it reaches. No light adds anything to
//! the picture (ambient light alone draws it), in Bevy as here; what is measured is the
//! cost of managing 100,000 small lights: building the lists and walking them.
//!
//! Depends on this crate's model and geometry, tiledlight-cull (lights) and glam.

use glam::{Mat4, Vec3};
use rand::Rng;
use tiledlight_cull::gbuffer::srgb_to_linear;

use crate::geometry::{add_box, MeshBuilder};
use crate::lights::{hue_color, stream_rng};
use crate::model::{Aabb, CameraDesc, Instance, Material, Mesh, Scene};
use crate::{Light, LightKind};

/// The sphere's radius, metres.
pub const MANY_LIGHTS_RADIUS: f32 = 50.0;
/// Lights in Bevy's many_lights.
pub const MANY_LIGHTS_COUNT: usize = 100_000;
/// Each light's range, metres.
pub const MANY_LIGHTS_RANGE: f32 = 0.3;
/// Each light's intensity in Bevy's unit, lumens (1000 lm = 1000 / 4 pi cd).
pub const MANY_LIGHTS_LUMENS: f32 = 1000.0;
/// Triangles along each icosahedron edge (Bevy's `ico(9)`: 9 subdivisions, 10 segments).
const ICO_SEGMENTS: u32 = 10;
/// The example's Fibonacci-spiral offset.
const SPIRAL_EPSILON: f64 = 0.36;
/// The random stream of the lights' hues.
const HUE_STREAM: u64 = 0x6d61_6e79_6875_6573;

/// Bevy 0.19's `many_lights` stress test (module docs): 2,012 triangles, 100,000 lights
/// and its camera.
pub fn bevy_many_lights() -> Scene {
    let meshes = vec![inward_icosphere(MANY_LIGHTS_RADIUS, ICO_SEGMENTS), unit_cube()];
    let white = Material {
        name: "white".into(),
        base_color: [1.0; 4],
        // Bevy's StandardMaterial: perceptual roughness 0.5, dielectric.
        roughness: 0.5,
        metallic: 0.0,
        ..Material::default()
    };
    // CSS deep pink, sRGB (255, 20, 147), as linear.
    let pink = Material {
        name: "deep pink".into(),
        base_color: [1.0, srgb_to_linear(20.0 / 255.0), srgb_to_linear(147.0 / 255.0), 1.0],
        ..white.clone()
    };
    let instances = vec![
        Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY },
        Instance {
            mesh: 1,
            material: 1,
            transform: Mat4::from_scale_rotation_translation(
                Vec3::splat(5.0),
                glam::Quat::IDENTITY,
                Vec3::new(0.0, MANY_LIGHTS_RADIUS, 0.0),
            ),
        },
    ];
    let mut scene = Scene {
        name: "bevy-many-lights".into(),
        meshes,
        materials: vec![white, pink],
        textures: Vec::new(),
        instances,
        lights: many_lights_lights(),
        camera: Some(CameraDesc {
            eye: Vec3::ZERO,
            target: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: std::f32::consts::FRAC_PI_4,
            near: 0.1,
            far: None,
        }),
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene
}

/// Bevy's `Cuboid::default()`: a 1 m cube at the origin, one cell per face.
fn unit_cube() -> Mesh {
    let mut b = MeshBuilder::new();
    add_box(&mut b, Vec3::splat(-0.5), Vec3::splat(0.5), 1.0);
    b.build("cube")
}

/// The example's lights (module docs, step 3).
fn many_lights_lights() -> Vec<Light> {
    let golden_ratio = 0.5 * (1.0 + 5f64.sqrt());
    let n = MANY_LIGHTS_COUNT;
    let candela = MANY_LIGHTS_LUMENS / (4.0 * std::f32::consts::PI);
    let mut rng = stream_rng(0, HUE_STREAM);
    (0..n)
        .map(|i| {
            let theta = std::f64::consts::TAU * (i as f64 / golden_ratio);
            let phi = (1.0 - 2.0 * (i as f64 + SPIRAL_EPSILON) / (n as f64 - 1.0 + 2.0 * SPIRAL_EPSILON)).acos();
            let (st, ct) = theta.sin_cos();
            let (sp, cp) = phi.sin_cos();
            let p = Vec3::new((ct * sp) as f32, (st * sp) as f32, cp as f32) * MANY_LIGHTS_RADIUS;
            // HSL with saturation 1 and lightness 0.5 is HSV with saturation and value 1.
            let color = hue_color(rng.random::<f32>()).map(srgb_to_linear);
            Light::with_radius(p, color, candela, MANY_LIGHTS_RANGE, LightKind::Point)
                .expect("the many_lights lights are finite, positive and in range")
        })
        .collect()
}

/// The icosahedron's 12 corners (unit length) and 20 faces, wound counter-clockwise seen
/// from outside.
fn icosahedron() -> ([Vec3; 12], [[usize; 3]; 20]) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let v = [
        Vec3::new(-1.0, t, 0.0),
        Vec3::new(1.0, t, 0.0),
        Vec3::new(-1.0, -t, 0.0),
        Vec3::new(1.0, -t, 0.0),
        Vec3::new(0.0, -1.0, t),
        Vec3::new(0.0, 1.0, t),
        Vec3::new(0.0, -1.0, -t),
        Vec3::new(0.0, 1.0, -t),
        Vec3::new(t, 0.0, -1.0),
        Vec3::new(t, 0.0, 1.0),
        Vec3::new(-t, 0.0, -1.0),
        Vec3::new(-t, 0.0, 1.0),
    ]
    .map(Vec3::normalize);
    let f = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (v, f)
}

/// A sphere of `radius` whose faces and normals point to its centre: each icosahedron
/// face cut into `segments`^2 triangles, every vertex pushed onto the sphere. A point
/// shared by two faces (an edge or a corner) is computed from its corners in index order,
/// so both faces get the same bits and the surface has no cracks.
pub(crate) fn inward_icosphere(radius: f32, segments: u32) -> Mesh {
    let (corners, faces) = icosahedron();
    let mut b = MeshBuilder::new();
    let n = segments;
    for face in faces {
        // Vertex (i, j) of this face: weights (n - i - j, i, j) on the face's corners.
        let mut ids = Vec::new();
        for j in 0..=n {
            for i in 0..=n - j {
                let mut w = [(face[0], n - i - j), (face[1], i), (face[2], j)];
                w.sort_by_key(|&(c, _)| c);
                let sum = w.iter().fold(Vec3::ZERO, |acc, &(c, k)| acc + corners[c] * k as f32);
                let dir = sum.normalize();
                ids.push(b.vertex(dir * radius, -dir, glam::Vec2::ZERO));
            }
        }
        let at = |i: u32, j: u32| -> u32 {
            // Row j starts after rows 0..j, of n + 1, n, ... entries.
            let row_start: u32 = (0..j).map(|r| n + 1 - r).sum();
            ids[(row_start + i) as usize]
        };
        for j in 0..n {
            for i in 0..n - j {
                // Outward counter-clockwise is (a, b, c); inward reverses it.
                let (a, bb, c) = (at(i, j), at(i + 1, j), at(i, j + 1));
                b.triangle(a, c, bb);
                if i + j + 1 < n {
                    let d = at(i + 1, j + 1);
                    b.triangle(bb, c, d);
                }
            }
        }
    }
    b.build("inward icosphere")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_is_valid_and_has_bevys_counts() {
        let s = bevy_many_lights();
        s.validate().unwrap();
        assert_eq!(s.lights.len(), 100_000);
        assert_eq!(s.meshes[0].triangle_count(), 2000, "Bevy's ico(9) has 20 x 10 x 10 triangles");
        assert_eq!(s.triangle_count(), 2012);
        for l in &s.lights {
            assert!((l.position.length() - MANY_LIGHTS_RADIUS).abs() < 1e-3);
            assert_eq!(l.radius, MANY_LIGHTS_RANGE);
            assert!((l.intensity - 1000.0 / (4.0 * std::f32::consts::PI)).abs() < 1e-3);
        }
    }

    #[test]
    fn the_sphere_faces_its_centre_and_has_no_cracks() {
        let m = inward_icosphere(50.0, ICO_SEGMENTS);
        let p = |i: u32| Vec3::from_array(m.positions[i as usize]);
        for t in m.indices.chunks_exact(3) {
            let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
            let geometric = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            assert!(geometric.dot(-centroid) > 0.0, "a triangle faces outward");
            // Every vertex's normal points to the centre.
            for &i in t {
                let n = Vec3::from_array(m.normals[i as usize]);
                assert!((n + p(i).normalize()).length() < 1e-5);
            }
        }
        // Watertight: every edge is used exactly twice, once each way, when vertices
        // are identified by their exact bits.
        let key = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut edges = std::collections::HashMap::new();
        for t in m.indices.chunks_exact(3) {
            for k in 0..3 {
                let (a, b) = (key(p(t[k])), key(p(t[(k + 1) % 3])));
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        for (&(a, b), &count) in &edges {
            assert_eq!(count, 1, "an edge is used twice the same way");
            assert_eq!(edges.get(&(b, a)), Some(&1), "an edge has no twin: a crack");
        }
    }

    #[test]
    fn every_light_is_behind_the_surface_it_reaches() {
        // The property the module docs state: the faces lie inside the lights' sphere,
        // so a light reaching a face (within its range) is on the face's back side.
        let s = bevy_many_lights();
        let m = &s.meshes[0];
        let p = |i: u32| Vec3::from_array(m.positions[i as usize]);
        let mut sag = 0f32;
        for t in m.indices.chunks_exact(3) {
            let c = (p(t[0]) + p(t[1]) + p(t[2])) / 3.0;
            sag = sag.max(MANY_LIGHTS_RADIUS - c.length());
        }
        // Inside (so behind), and nearer than the lights' range (so the lights do reach
        // the faces and land in their lists): 0.145 m.
        assert!(sag > 0.0 && sag < MANY_LIGHTS_RANGE, "the faces lie up to {sag} m inside the sphere");
    }

    #[test]
    fn hues_are_saturated_and_spread() {
        let s = bevy_many_lights();
        let mut reds = 0;
        for l in s.lights.iter().take(3000) {
            let c = l.color;
            assert!(c.max_element() > 0.999 && c.min_element() < 1e-6, "{c}: not fully saturated");
            if c.x > 0.999 {
                reds += 1;
            }
        }
        // Red is the largest channel for a third of the hues (330..30 degrees and so on).
        assert!((800..1200).contains(&reds), "{reds} of 3000 lights lead with red");
    }
}
