//! The rasterisers' fill and tie rules at their exact boundary (issue 43, class 8): pixel
//! centres lying exactly on triangle edges, where only the top-left rule decides, and
//! coplanar triangles at exactly equal depth, where only the tie rule decides. The
//! triangles are laid out in window coordinates through an orthographic camera whose
//! matrices are powers of two (one world unit is one pixel), so every vertex snaps exactly
//! onto a pixel centre in the compute raster, its CPU twin and the hardware:
//!
//! - a sheet of quads on a 4-pixel grid, each split along a diagonal (horizontal, vertical
//!   and 45-degree shared edges through pixel centres);
//! - two fans of triangles around a pixel centre (8 spokes at 45 degrees, 12 spokes at
//!   slopes 0, 1/2, 2 and infinite), every spoke through a row of pixel centres;
//! - a full-screen pair split along the screen's 45-degree diagonal;
//! - coplanar triangles at exactly the same depth: one drawn twice under two IDs, and one
//!   overlapping it.
//!
//! Checked: (1) per pixel, how many triangles of each group cover it, on the GPU (the
//! one-thread fill `raster_triangle`, whose small triangles take its i32 path and the
//! full-screen pair its i64 path, and the large triangles' fill tile by tile,
//! `raster_tile_open` and `raster_fill_tile`) equals the CPU twin's count, is never 2 (drawn twice) and, for each group's
//! convex union, is the top-left rule applied to the union as one polygon (never missed
//! inside it); (2) the ID the compute raster keeps (both kernels, and large triangles by
//! the hardware) equals the twin's and the hardware raster's, exactly; (3) at equal depth
//! the larger ID wins in the compute raster and the twin (`tiledlight_cull::raster`, rule 7)
//! and the later draw in the hardware (depth compare `GreaterEqual`), which within one mesh
//! is the larger ID too. A failure means a pixel on a shared edge drawn twice or by
//! neither triangle, a fill rule other than top-left (or other than the hardware's), or a
//! tie resolved the other way. Needs `SHADER_INT64` and `SHADER_INT64_ATOMIC_MIN_MAX`.

use glam::{Mat4, Vec3, Vec4};
use tiledlight_cull::camera::Projection;
use tiledlight_cull::raster::{rasterize, unpack, Cull, Raster};
use tiledlight_cull::visibility::NO_TRIANGLE;
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::{FrameRenderer, FrameSettings, Method, VisibilityFrame};
use tiledlight_gpu::features::Raster as RasterPath;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::{Aabb, Instance, Mesh, Scene};
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::gpu;
use tiledlight_tests::kernels::run_cases;
use tiledlight_visibility::compute_raster::{ComputeRasterOptions, LargeRaster};

/// The target: square, so the screen's diagonal is at 45 degrees and passes through the
/// pixel centres (k + 1/2, k + 1/2); a power of two, so window coordinates are exact.
const W: u32 = 64;
const H: u32 = 64;

/// The groups of triangles whose coverage is counted separately.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Group {
    Sheet,
    Fan8,
    Fan12,
    Screen,
    Tie,
}

const GROUPS: [Group; 5] = [Group::Sheet, Group::Fan8, Group::Fan12, Group::Screen, Group::Tie];

/// One triangle: window-space vertices (pixels, y down), its world depth plane and group.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v: [(f32, f32); 3],
    z: f32,
    group: Group,
}

/// The camera: identity view, orthographic with the screen's half-size as half-height, near
/// 0, far 2. Its matrix is x / 32, y / 32, z / 2 + 1: world (x, y) = window (x - 32, 32 - y)
/// lands exactly where meant, and a plane at z = -0.5, -1, -1.5 has depth 0.75, 0.5, 0.25.
fn camera() -> Camera {
    let p = Projection::Orthographic { half_height: H as f32 / 2.0, aspect: W as f32 / H as f32, near: 0.0, far: 2.0 };
    Camera::from_view(Mat4::IDENTITY, p).expect("camera")
}

fn world((x, y): (f32, f32), z: f32) -> Vec3 {
    Vec3::new(x - W as f32 / 2.0, H as f32 / 2.0 - y, z)
}

/// Every triangle, in mesh order (the triangle index is the ID: one instance).
fn triangles() -> Vec<Tri> {
    let mut t = Vec::new();
    // The sheet: a 4 x 3 grid of 4-pixel quads with corners at pixel centres, split along
    // alternating diagonals; nearest (depth 0.75) so nothing hides it.
    for j in 0..3 {
        for i in 0..4 {
            let (x0, y0) = (4.5 + 4.0 * i as f32, 4.5 + 4.0 * j as f32);
            let (a, b, c, d) = ((x0, y0), (x0 + 4.0, y0), (x0 + 4.0, y0 + 4.0), (x0, y0 + 4.0));
            let [p, q] = if (i + j) % 2 == 0 { [[a, b, c], [a, c, d]] } else { [[a, b, d], [b, c, d]] };
            t.push(Tri { v: p, z: -0.5, group: Group::Sheet });
            t.push(Tri { v: q, z: -0.5, group: Group::Sheet });
        }
    }
    // Fans around a pixel centre: consecutive spokes make the triangles, each spoke a
    // shared edge through a row of pixel centres.
    let mut fan = |c: (f32, f32), spokes: &[(f32, f32)], group| {
        for k in 0..spokes.len() {
            let (a, b) = (spokes[k], spokes[(k + 1) % spokes.len()]);
            t.push(Tri { v: [c, (c.0 + a.0, c.1 + a.1), (c.0 + b.0, c.1 + b.1)], z: -0.5, group });
        }
    };
    let s8 = [(6.0, 0.0), (6.0, 6.0), (0.0, 6.0), (-6.0, 6.0), (-6.0, 0.0), (-6.0, -6.0), (0.0, -6.0), (6.0, -6.0)];
    fan((44.5, 12.5), &s8, Group::Fan8);
    let s12 = [
        (6.0, 0.0),
        (6.0, 3.0),
        (3.0, 6.0),
        (0.0, 6.0),
        (-3.0, 6.0),
        (-6.0, 3.0),
        (-6.0, 0.0),
        (-6.0, -3.0),
        (-3.0, -6.0),
        (0.0, -6.0),
        (3.0, -6.0),
        (6.0, -3.0),
    ];
    fan((20.5, 36.5), &s12, Group::Fan12);
    // The full-screen pair, split along the diagonal (0, 0)-(64, 64); farthest (depth 0.25).
    let (w, h) = (W as f32, H as f32);
    t.push(Tri { v: [(0.0, 0.0), (w, 0.0), (w, h)], z: -1.5, group: Group::Screen });
    t.push(Tri { v: [(0.0, 0.0), (w, h), (0.0, h)], z: -1.5, group: Group::Screen });
    // Coplanar ties at depth 0.5 (in front of the screen pair, apart from the rest): right
    // triangles with 8-pixel legs, whose snapped area is a power of two, so the twin's and
    // the compute raster's interpolated depth is exactly 0.5 (asserted below). `a` is drawn,
    // then `b` overlapping it, then `a` again: the duplicate wins over both where it covers.
    let a = [(44.5, 40.5), (52.5, 40.5), (44.5, 48.5)];
    let b = [(46.5, 40.5), (54.5, 40.5), (46.5, 48.5)];
    for v in [a, b, a] {
        t.push(Tri { v, z: -1.0, group: Group::Tie });
    }
    t
}

fn clip(cam: &Camera, t: &Tri) -> [Vec4; 3] {
    t.v.map(|p| cam.view_proj() * world(p, t.z).extend(1.0))
}

// ---- Coverage counts: the kernels on the GPU, the twin, the rule on each union ----

const COUNT_SHADER: &str = r#"
#include "common/compute_raster.wgsl"

struct Tri {
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    // width, height, group, kernel (0: raster_triangle; 1: the large triangles' fill, the
    // tiles raster_tile_open lets through filled by raster_fill_tile)
    info: vec4<u32>,
}

@group(0) @binding(0) var<storage, read> tris: array<Tri>;
// Per group, per pixel: how many triangles covered it.
@group(0) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

var<private> p_base: u32;
var<private> p_width: u32;

fn raster_emit(x: u32, y: u32, texel: u64) {
    atomicAdd(&counts[p_base + y * p_width + x], 1u);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let kernel = tris[0].info.w;
    let k = gid.x;
    if k >= arrayLength(&tris) {
        return;
    }
    let t = tris[k];
    p_width = t.info.x;
    p_base = t.info.z * t.info.x * t.info.y;
    if kernel == 0u {
        raster_triangle(t.c0, t.c1, t.c2, t.info.xy, false, k);
    } else {
        let s = raster_setup_inside(t.c0, t.c1, t.c2, t.info.xy, false);
        let f = raster_prepare(s.a, s.b, s.c, t.info.xy);
        if f.drawn && all(f.lo <= f.hi) {
            for (var ty = f.lo.y / RASTER_TILE; ty <= f.hi.y / RASTER_TILE; ty++) {
                for (var tx = f.lo.x / RASTER_TILE; tx <= f.hi.x / RASTER_TILE; tx++) {
                    if raster_tile_open(f, vec2<i64>(tx, ty)) {
                        raster_fill_tile(f, vec2<i64>(tx, ty), k);
                    }
                }
            }
        }
    }
}
"#;

/// Per group, per pixel, how many triangles the GPU covered it with: by one thread each
/// (`kernel` 0) or tile by tile (`kernel` 1, the large triangles' fill).
fn gpu_counts(tris: &[Tri], cam: &Camera, kernel: u32) -> Vec<u32> {
    let ctx = gpu();
    let mut input: Vec<u8> = Vec::new();
    for t in tris {
        for v in clip(cam, t) {
            input.extend_from_slice(bytemuck::cast_slice(&v.to_array()));
        }
        let g = GROUPS.iter().position(|&g| g == t.group).unwrap() as u32;
        input.extend_from_slice(bytemuck::cast_slice(&[W, H, g, kernel]));
    }
    let cases = tris.len() as u32;
    let bytes = GROUPS.len() as u64 * u64::from(W * H) * 4;
    let out = run_cases(ctx, "raster_rules_count", COUNT_SHADER, &input, cases, bytes);
    bytemuck::cast_slice(&out).to_vec()
}

/// The same counts from the CPU twin's fragments.
fn twin_counts(tris: &[Tri], cam: &Camera) -> Vec<u32> {
    let mut counts = vec![0u32; GROUPS.len() * (W * H) as usize];
    for t in tris {
        let base = GROUPS.iter().position(|&g| g == t.group).unwrap() * (W * H) as usize;
        rasterize(clip(cam, t), (W, H), Cull::None, |f| counts[base + (f.y * W + f.x) as usize] += 1);
    }
    counts
}

/// Whether the top-left rule, applied to convex polygon `poly` (window pixels, either
/// orientation) as one shape, covers the centre of pixel (x, y): strictly inside every
/// edge, or on an edge that is a top edge (horizontal, interior below) or a left edge
/// (interior to its right). Written here in exact integers (1/256 px) from the rule's
/// statement, not from the rasterisers' code: the coverage a watertight triangulation of
/// the polygon must add up to.
fn rule_covers(poly: &[(f32, f32)], (x, y): (u32, u32)) -> bool {
    let s = |v: f32| (v * 256.0) as i64;
    let mut p: Vec<(i64, i64)> = poly.iter().map(|&(a, b)| (s(a), s(b))).collect();
    let area: i64 = (0..p.len()).map(|i| p[i].0 * p[(i + 1) % p.len()].1 - p[(i + 1) % p.len()].0 * p[i].1).sum();
    if area < 0 {
        p.reverse();
    }
    let (px, py) = (x as i64 * 256 + 128, y as i64 * 256 + 128);
    (0..p.len()).all(|i| {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        // Positive area in window coordinates (y down): the interior is where e > 0.
        let e = (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        e > 0 || (e == 0 && ((dy == 0 && dx > 0) || dy < 0))
    })
}

/// Each counted group's union as one convex polygon (the tie group overlaps itself and is
/// checked by the twin only).
fn union_of(group: Group) -> Option<Vec<(f32, f32)>> {
    let ring = |c: (f32, f32), r: &[(f32, f32)]| r.iter().map(|d| (c.0 + d.0, c.1 + d.1)).collect();
    match group {
        Group::Sheet => Some(vec![(4.5, 4.5), (20.5, 4.5), (20.5, 16.5), (4.5, 16.5)]),
        Group::Fan8 => Some(ring(
            (44.5, 12.5),
            &[(6.0, 0.0), (6.0, 6.0), (0.0, 6.0), (-6.0, 6.0), (-6.0, 0.0), (-6.0, -6.0), (0.0, -6.0), (6.0, -6.0)],
        )),
        Group::Fan12 => Some(ring(
            (20.5, 36.5),
            &[
                (6.0, 0.0),
                (6.0, 3.0),
                (3.0, 6.0),
                (0.0, 6.0),
                (-3.0, 6.0),
                (-6.0, 3.0),
                (-6.0, 0.0),
                (-6.0, -3.0),
                (-3.0, -6.0),
                (0.0, -6.0),
                (3.0, -6.0),
                (6.0, -3.0),
            ],
        )),
        Group::Screen => Some(vec![(0.0, 0.0), (W as f32, 0.0), (W as f32, H as f32), (0.0, H as f32)]),
        Group::Tie => None,
    }
}

/// Checks counts against the twin's and each union's rule: the first difference, named.
fn check_counts(got: &[u32], twin: &[u32]) -> Result<(), String> {
    for (gi, &group) in GROUPS.iter().enumerate() {
        let union = union_of(group);
        for y in 0..H {
            for x in 0..W {
                let i = gi * (W * H) as usize + (y * W + x) as usize;
                if got[i] != twin[i] {
                    return Err(format!("{group:?} pixel ({x}, {y}): covered {} times, the twin {}", got[i], twin[i]));
                }
                if let Some(u) = &union {
                    let want = u32::from(rule_covers(u, (x, y)));
                    if got[i] != want {
                        return Err(format!(
                            "{group:?} pixel ({x}, {y}): covered {} times; the union as one polygon covers it {want} \
                             times",
                            got[i]
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// How many pixel centres lie exactly on an edge of some triangle of the counted groups:
/// the cases this file exists for.
fn centres_on_edges(tris: &[Tri]) -> usize {
    let on = |t: &Tri, x: u32, y: u32| {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        (0..3).any(|k| {
            let (a, b) = (t.v[k], t.v[(k + 1) % 3]);
            let e = (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0);
            let within = px >= a.0.min(b.0) && px <= a.0.max(b.0) && py >= a.1.min(b.1) && py <= a.1.max(b.1);
            e == 0.0 && within
        })
    };
    (0..W * H).filter(|&p| tris.iter().any(|t| t.group != Group::Tie && on(t, p % W, p / W))).count()
}

fn need_int64() {
    let ctx = gpu();
    let need = wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX;
    assert!(
        ctx.device.features().contains(need),
        "the compute rasteriser needs SHADER_INT64 and SHADER_INT64_ATOMIC_MIN_MAX, which {} lacks",
        ctx.info.name
    );
}

/// No pixel drawn twice or missed on shared edges through pixel centres, by either fill
/// kernel: counts equal the twin's and the top-left rule on each group's union.
#[test]
fn shared_edges_through_pixel_centres_are_drawn_exactly_once() {
    need_int64();
    let (cam, tris) = (camera(), triangles());
    let on_edges = centres_on_edges(&tris);
    eprintln!("{on_edges} pixel centres lie exactly on an edge");
    assert!(on_edges > 300, "the scene must put many pixel centres on edges: {on_edges}");
    let twin = twin_counts(&tris, &cam);
    // The twin itself: never twice, never missed inside a union (its own rule, checked
    // against the one-polygon rule written above).
    check_counts(&twin, &twin).unwrap_or_else(|e| panic!("the CPU twin: {e}"));
    for (what, kernel) in [("one thread a triangle (raster_triangle)", 0), ("tile by tile (raster_fill_tile)", 1)] {
        let got = gpu_counts(&tris, &cam, kernel);
        check_counts(&got, &twin).unwrap_or_else(|e| panic!("{what}: {e}"));
    }
    // The check's teeth: a pixel on a shared edge counted twice, and one missed, fail.
    let sheet_edge = (8 * W + 8) as usize; // the centre (8.5, 8.5): a grid vertex of the sheet
    let mut twice = twin.clone();
    twice[sheet_edge] += 1;
    assert!(check_counts(&twice, &twin).is_err(), "a pixel drawn twice must fail");
    let mut missed = twin.clone();
    missed[sheet_edge] = 0;
    assert!(check_counts(&missed, &twin).is_err() && twin[sheet_edge] == 1, "a missed pixel must fail");
    // A rule flipped to bottom-right on the union (an independent statement disagreeing
    // with the rasterisers) must fail too: the rule check is not vacuous on the boundary.
    let flipped: Vec<u32> = (0..twin.len())
        .map(|i| {
            let (g, p) = (i / (W * H) as usize, (i % (W * H) as usize) as u32);
            match union_of(GROUPS[g]) {
                Some(u) => {
                    let mirrored: Vec<(f32, f32)> = u.iter().map(|&(x, y)| (W as f32 - x, H as f32 - y)).collect();
                    u32::from(rule_covers(&mirrored, (W - 1 - p % W, H - 1 - p / W)))
                }
                None => twin[i],
            }
        })
        .collect();
    assert!(check_counts(&flipped, &twin).is_err(), "the bottom-right rule must fail");
}

// ---- The whole raster pass: IDs of the compute raster, its twin and the hardware ----

fn scene(tris: &[Tri]) -> Scene {
    let mut mesh = Mesh { name: "boundaries".into(), ..Mesh::default() };
    for t in tris {
        for &p in &t.v {
            mesh.indices.push(mesh.positions.len() as u32);
            mesh.positions.push(world(p, t.z).to_array());
            mesh.normals.push([0.0, 0.0, 1.0]);
            mesh.uvs.push([0.0, 0.0]);
        }
    }
    let mut m = tiledlight_tests::scenes::material("m", [0.8, 0.8, 0.8, 1.0], 0.5, 0.0);
    // Both windings drawn: the fill rule, not back-face culling, decides coverage.
    m.double_sided = true;
    let (hw, hh) = (W as f32 / 2.0, H as f32 / 2.0);
    Scene {
        name: "raster rules".into(),
        meshes: vec![mesh],
        materials: vec![m],
        textures: vec![],
        instances: vec![Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }],
        lights: vec![],
        camera: None,
        bounds: Aabb::new(Vec3::new(-hw, -hh, -2.0), Vec3::new(hw, hh, 0.0)),
    }
}

/// The IDs the visibility buffer's raster keeps with `raster` and `options`.
fn raster_ids(
    (sg, lights, cam): (&SceneGpu, &LightBuffers, &Camera),
    raster: RasterPath,
    options: ComputeRasterOptions,
) -> Vec<u32> {
    let ctx = gpu();
    let knobs = Knobs { raster, raster_large_px: options.large_px, raster_large: options.large, ..Knobs::default() };
    let s = FrameSettings { method: Method::Visibility, knobs, ..Default::default() };
    let mut r = FrameRenderer::new(ctx, sg, lights, W, H, s).unwrap_or_else(|e| panic!("{raster:?}: {e}"));
    render_frame(ctx, &mut r, sg, cam);
    r.passes::<VisibilityFrame>().unwrap().raster().read_ids(&ctx.device, &ctx.queue).unwrap()
}

/// The IDs kept per pixel: the compute raster with every triangle by one thread, with every
/// triangle large (a workgroup each), with large triangles by the hardware, and the hardware
/// raster, all equal to the twin's, exactly; and at the coplanar ties the larger ID.
#[test]
fn every_raster_keeps_the_twins_ids_and_the_larger_id_at_a_tie() {
    need_int64();
    let (cam, tris) = (camera(), triangles());
    let mut twin = Raster::new(W, H);
    // Per pixel, the tie group's IDs covering it and their depths.
    let mut ties: Vec<Vec<(u32, f32)>> = vec![Vec::new(); (W * H) as usize];
    for (i, t) in tris.iter().enumerate() {
        twin.draw(clip(&cam, t), i as u32, Cull::None);
        if t.group == Group::Tie {
            rasterize(clip(&cam, t), (W, H), Cull::None, |f| ties[(f.y * W + f.x) as usize].push((i as u32, f.depth)));
        }
    }
    // The ties are exact: every fragment of the coplanar triangles is at depth 0.5, and the
    // pixels where all three (or two) overlap are many.
    assert!(ties.iter().flatten().all(|&(_, d)| d == 0.5), "the tie group's depth must be exactly 0.5");
    let overlapped = ties.iter().filter(|t| t.len() >= 3).count();
    assert!(overlapped >= 16, "too few pixels where three coplanar triangles tie: {overlapped}");
    let twin_ids: Vec<u32> = twin.texels.iter().map(|&t| unpack(t).1).collect();
    for (p, t) in ties.iter().enumerate() {
        if let Some(max) = t.iter().map(|&(id, _)| id).max() {
            assert_eq!(twin_ids[p], max, "the twin keeps the larger ID at a tie (pixel {p})");
        }
    }
    assert!(!twin_ids.contains(&NO_TRIANGLE), "the full-screen pair covers every pixel");

    let ctx = gpu();
    let sc = scene(&tris);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &sc).unwrap();
    let light = Light::point(Vec3::new(0.0, 0.0, 1.0), Vec3::ONE, 1.0, 100.0).unwrap();
    let lights = LightBuffers::new(&ctx.device, &[light]).unwrap();
    let inputs = (&sg, &lights, &cam);
    let opts = |large_px, large| ComputeRasterOptions { large_px, large };
    let runs = [
        ("compute, every triangle by one thread", RasterPath::Compute, opts(u32::MAX, LargeRaster::Compute)),
        ("compute, every triangle by a workgroup", RasterPath::Compute, opts(0, LargeRaster::Compute)),
        ("compute, large triangles by the hardware", RasterPath::Compute, opts(0, LargeRaster::Hardware)),
        ("hardware raster", RasterPath::Hardware, ComputeRasterOptions::default()),
    ];
    for (what, raster, options) in runs {
        let ids = raster_ids(inputs, raster, options);
        let differ: Vec<(u32, u32, u32, u32)> = (0..(W * H) as usize)
            .filter(|&p| ids[p] != twin_ids[p])
            .map(|p| (p as u32 % W, p as u32 / W, ids[p], twin_ids[p]))
            .collect();
        eprintln!("{what}: {} pixels differ from the twin", differ.len());
        assert!(
            differ.is_empty(),
            "{what}: pixels (x, y, GPU ID, twin ID) differ: {:?}",
            &differ[..differ.len().min(12)]
        );
    }
}
