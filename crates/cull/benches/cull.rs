//! The CPU reference culler at 1920x1080 with 16x16 tiles (8160 tiles), 1024 and 16384
//! random point lights in a 36 x 13 x 16 m room (x, y up, z): planes only, planes + AABB,
//! and planes after a 64 px coarse pass (two-level culling). The depth buffer is the
//! room's floor, ceiling and walls, intersected analytically per pixel for a camera
//! standing inside it, so every tile has geometry (the costliest case). Slow by design (it is the reference, not the kernel):
//! `sample_size(10)`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use tiledlight_cull::light::{order_points_first, pack_lights, PackedLights};
use tiledlight_cull::reference::stats;
use tiledlight_cull::tiles::{pixel_to_ndc_x, pixel_to_ndc_y};
use tiledlight_cull::{cull_tiles, Camera, CullConfig, Light};

const W: u32 = 1920;
const H: u32 = 1080;
/// The room: x in [-18, 18], y in [0, 13], z in [-8, 8].
const ROOM_MIN: Vec3 = Vec3::new(-18.0, 0.0, -8.0);
const ROOM_MAX: Vec3 = Vec3::new(18.0, 13.0, 8.0);

fn camera() -> Camera {
    let eye = Vec3::new(-15.0, 1.7, 5.0);
    Camera::perspective(eye, Vec3::new(10.0, 3.0, -4.0), Vec3::Y, 60f32.to_radians(), W as f32 / H as f32, 0.1, None)
        .expect("valid camera")
}

/// Reversed-Z depth of the room's inside seen from `cam`: per pixel, the nearest of the six
/// planes along the pixel's ray (the eye is inside, so exactly one exit point).
fn room_depth(cam: &Camera) -> Vec<f32> {
    let to_world = cam.view().inverse();
    let eye = cam.eye();
    let dp = cam.depth_params();
    let mut depth = Vec::with_capacity((W * H) as usize);
    for y in 0..H {
        for x in 0..W {
            // The view point at distance 1 along -Z: its world offset from the eye is the
            // ray direction scaled so that the ray parameter t is the view distance.
            let p = cam.view_point_at(pixel_to_ndc_x(x as f32 + 0.5, W), pixel_to_ndc_y(y as f32 + 0.5, H), 1.0);
            let dir = to_world.transform_vector3(p);
            let t_exit = (0..3)
                .map(|a| {
                    let bound = if dir[a] > 0.0 { ROOM_MAX[a] } else { ROOM_MIN[a] };
                    if dir[a] == 0.0 {
                        f32::INFINITY
                    } else {
                        (bound - eye[a]) / dir[a]
                    }
                })
                .fold(f32::INFINITY, f32::min);
            depth.push(dp.depth(t_exit).clamp(0.0, 1.0));
        }
    }
    depth
}

/// `n` point lights uniformly in the room, radius 1 to 3.2 m (intensity 1..10 at
/// threshold 1).
fn lights(n: usize) -> PackedLights {
    let mut rng = Pcg64::seed_from_u64(n as u64);
    let lights: Vec<Light> = (0..n)
        .map(|_| {
            let t = Vec3::new(rng.random(), rng.random(), rng.random());
            let pos = ROOM_MIN + (ROOM_MAX - ROOM_MIN) * t;
            let colour = Vec3::new(1.0, rng.random(), rng.random());
            Light::point(pos, colour, rng.random_range(1.0..10.0), 1.0).expect("valid light")
        })
        .collect();
    pack_lights(&order_points_first(&lights))
}

fn bench(c: &mut Criterion) {
    let cam = camera();
    let depth = room_depth(&cam);
    let mut group = c.benchmark_group("cull_tiles_1080p_16px");
    group.sample_size(10);
    for n in [1024, 16384] {
        let packed = lights(n);
        // Two-level culling (64 px cells first) is the app's default: measured as well.
        for (name, aabb, coarse) in
            [("planes", false, false), ("planes+aabb", true, false), ("coarse+planes", false, true)]
        {
            let config = CullConfig { tile_size: 16, aabb, coarse, capacity: 2048, ..CullConfig::default() };
            // Printed once per input, so the timings can be read against the list sizes.
            let s = stats(&cull_tiles(&depth, W, H, &cam, &packed, &config).expect("valid input"));
            eprintln!(
                "{name} {n} lights: {} tiles with geometry, {:.1} lights per tile on average, {} at most",
                s.tiles_with_geometry, s.mean_per_list, s.max_per_list
            );
            group.bench_with_input(BenchmarkId::new(name, n), &packed, |b, packed| {
                b.iter(|| cull_tiles(black_box(&depth), W, H, &cam, black_box(packed), &config).expect("valid input"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
