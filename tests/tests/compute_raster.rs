//! The visibility buffer's compute rasteriser on the GPU (issue 29, step 2): the WGSL of
//! `shaders/common/compute_raster.wgsl` (`raster_triangle`, resolved with a 64-bit
//! `atomicMax`) against its CPU twin (`tiledlight_cull::raster::Raster::draw`, whose rules
//! `crates/cull/tests/raster.rs` checks against the exact triangle), pixel by pixel, over
//! triangles drawn into one target: ordinary, slivers, sub-pixel, crossing the near plane or
//! the eye plane, and reaching past the guard band.
//!
//! The two perform the same operations in the same order, edges in exact integers, so
//! coverage is equal; the GPU may contract a multiply-add where the CPU rounds twice, and
//! Vulkan lets its `1 / area` be 2.5 ulps off, so a depth may differ in its last bits. Each
//! of the three terms `(e_i / area) d_i` rounds at most four times on each side (the edge
//! to f32, the reciprocal, two products) and the sum twice, all terms positive and at most
//! the depth: 2 x (4 x 0.5 + 2.5) + 2 x 1 < 12, so at most 16 ulps (measured: 0 on lavapipe,
//! 9 at one pixel on the H200); where two triangles' depths at a pixel are that close the
//! ID may differ (the tie went the other way). Counted and bounded; anything else fails. Needs wgpu's `SHADER_INT64` and
//! `SHADER_INT64_ATOMIC_MIN_MAX` (Vulkan `shaderInt64`, `shaderBufferInt64Atomics`): lavapipe
//! and the H200 have both, and the test fails, naming them, on an adapter without them.
//!
//! The large triangles' tiles (issue 49): the tiles `raster_tile_open` lets through, per
//! piece of each triangle's clipped fan, equal the twin's `large_tiles` bit for bit (exact
//! integers on both sides), and filling only those tiles (`raster_fill_tile`) draws what
//! the twin draws. On a scene, the listed tiles and the fallback past the list's capacity.

use glam::{DVec3, Mat4, Vec3, Vec4};
use tiledlight_cull::raster::{large_tiles, pack, rasterize, unpack, Cull, Raster, CLEAR, LARGE_TILE};
use tiledlight_cull::visibility::{IdLayout, NO_TRIANGLE};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method, VisibilityFrame};
use tiledlight_gpu::features::Raster as RasterPath;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::AlphaMode;
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::gpu;
use tiledlight_tests::kernels::{run_cases, Rng};
use tiledlight_visibility::compute_raster::{ComputeRasterOptions, LargeRaster, LargeTiles};

const W: u32 = 97;
const H: u32 = 61;

/// `n` triangles of mixed kinds (clip space), seen by a reversed-Z camera with an infinite
/// far plane, and whether each is back-face culled.
fn triangles(n: usize, seed: u32) -> Vec<([Vec4; 3], bool)> {
    let mut r = Rng(seed);
    let near = 0.05;
    let proj = Mat4::perspective_infinite_reverse_rh(60f32.to_radians(), W as f32 / H as f32, near);
    let half = 30f32.to_radians().tan();
    let aspect = W as f32 / H as f32;
    let at = |x: f32, y: f32, d: f32| Vec3::new(x * half * aspect * d, y * half * d, -d);
    (0..n)
        .map(|i| {
            let d = 0.2 + 20.0 * r.unit() * r.unit();
            let (x, y) = (r.range(-1.2, 1.2), r.range(-1.2, 1.2));
            let view = match i % 6 {
                // Ordinary.
                0 | 1 => [
                    at(x, y, d),
                    at(x + r.range(-0.6, 0.6), y + r.range(-0.6, 0.6), d * r.range(0.7, 1.4)),
                    at(x + r.range(-0.6, 0.6), y + r.range(-0.6, 0.6), d * r.range(0.7, 1.4)),
                ],
                // Sliver.
                2 => {
                    let (a, b) = (at(x, y, d), at(x + r.range(-1.0, 1.0), y + r.range(-1.0, 1.0), d));
                    [a, b, a.lerp(b, r.unit()) + Vec3::new(0.0, 1e-3 * d * r.unit(), 0.0)]
                }
                // Sub-pixel.
                3 => {
                    let c = at(x, y, d);
                    let s = 2.0 * half * d / H as f32 * r.range(0.05, 1.5);
                    [c, c + Vec3::new(s, 0.0, 0.0), c + Vec3::new(r.range(-s, s), s, 0.0)]
                }
                // Crossing the near plane or the eye plane.
                4 => {
                    let mut v = [at(x, y, d), at(x + r.range(-0.6, 0.6), y, d), at(x, y + r.range(-0.6, 0.6), d)];
                    v[0].z = if r.unit() < 0.5 { -near * r.unit() } else { r.range(0.0, d) };
                    v
                }
                // Past the guard band.
                _ => [at(x, y, d), at(x + r.range(-150.0, 150.0), y, d), at(x, y + r.range(-150.0, 150.0), d)],
            };
            (view.map(|p| proj * p.extend(1.0)), r.unit() < 0.5)
        })
        .collect()
}

/// The tests' shader, one thread a triangle: `raster_triangle` into the texels, or with
/// `info.w` bit 1 (TILES) the tiles `raster_tile_open` lets through filled one at a time
/// (`raster_fill_tile`), and after the target's texels one mask of open tiles per piece of
/// its fan (bit ty * tiles_x + tx; 8 words a triangle).
const SHADER: &str = r#"
#include "common/compute_raster.wgsl"

struct Tri {
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    // width, height, ID, flags (bit 0: cull back faces; bit 1: by tiles)
    info: vec4<u32>,
}

@group(0) @binding(0) var<storage, read> tris: array<Tri>;
@group(0) @binding(1) var<storage, read_write> texels: array<atomic<u64>>;

var<private> p_width: u32;

fn raster_emit(x: u32, y: u32, texel: u64) {
    atomicMax(&texels[y * p_width + x], texel);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= arrayLength(&tris) {
        return;
    }
    let t = tris[gid.x];
    p_width = t.info.x;
    let cull = (t.info.w & 1u) != 0u;
    if (t.info.w & 2u) == 0u {
        raster_triangle(t.c0, t.c1, t.c2, t.info.xy, cull, t.info.z);
        return;
    }
    let s = raster_setup(t.c0, t.c1, t.c2, t.info.xy, cull);
    let tiles_x = (t.info.x + 15u) / 16u;
    for (var i = 1u; i + 1u < s.n; i++) {
        let f = raster_prepare(s.s[0], s.s[i], s.s[i + 1u], t.info.xy);
        if !f.drawn || any(f.hi < f.lo) {
            continue;
        }
        var mask = 0u;
        for (var ty = f.lo.y / RASTER_TILE; ty <= f.hi.y / RASTER_TILE; ty++) {
            for (var tx = f.lo.x / RASTER_TILE; tx <= f.hi.x / RASTER_TILE; tx++) {
                if raster_tile_open(f, vec2<i64>(tx, ty)) {
                    mask |= 1u << (u32(ty) * tiles_x + u32(tx));
                    raster_fill_tile(f, vec2<i64>(tx, ty), t.info.z);
                }
            }
        }
        atomicMax(&texels[t.info.x * t.info.y + gid.x * 8u + i - 1u], u64(mask));
    }
}
"#;

/// The GPU's open tiles equal the twin's `large_tiles`, piece by piece, and filling only
/// them draws the twin's texels (the module doc's comparison); the comparison rejects a
/// tile list with one tile dropped.
#[test]
fn gpu_large_tiles_equal_the_cpu_twin() {
    let ctx = gpu();
    let tris = triangles(600, 0x5851_f42d);
    let tiles_x = W.div_ceil(LARGE_TILE);
    assert!(tiles_x * H.div_ceil(LARGE_TILE) <= 32, "a piece's tiles must fit one mask word");
    let pixels = (W * H) as usize;
    let bytes = (pixels + tris.len() * 8) as u64 * 8;
    let out = run_cases(ctx, "compute_raster.tiles", SHADER, &tri_input(&tris, true), tris.len() as u32, bytes);
    let words: Vec<u64> = bytemuck::cast_slice(&out).to_vec();
    let (gpu_texels, gpu_masks) = words.split_at(pixels);
    let gpu_masks: Vec<u32> = gpu_masks.iter().map(|&m| m as u32).collect();
    let mut cpu_masks = vec![0u32; tris.len() * 8];
    for (i, (c, cull)) in tris.iter().enumerate() {
        for [piece, tx, ty] in large_tiles(*c, (W, H), if *cull { Cull::Back } else { Cull::None }) {
            cpu_masks[i * 8 + piece as usize] |= 1 << (ty * tiles_x + tx);
        }
    }
    let listed: u32 = cpu_masks.iter().map(|m| m.count_ones()).sum();
    let pieces = cpu_masks.chunks(8).filter(|m| m[1] != 0).count();
    eprintln!("{listed} tiles listed; {pieces} triangles with a second piece");
    assert!(listed > 600 && pieces > 10, "the triangles must list tiles and clipped fans to test: {listed}, {pieces}");
    let differ = |a: &[u32], b: &[u32]| a.iter().zip(b).position(|(x, y)| x != y);
    assert_eq!(differ(&gpu_masks, &cpu_masks), None, "open tiles differ (triangle * 8 + piece)");
    let mut dropped = cpu_masks.clone();
    let k = dropped.iter().position(|&m| m != 0).unwrap();
    dropped[k] &= dropped[k] - 1;
    assert!(differ(&gpu_masks, &dropped).is_some(), "a dropped tile must be caught");
    // Filled tile by tile: the twin's texels.
    let (cpu, at) = twin(&tris);
    let (covered, depth_off, ties) = compare(gpu_texels, &cpu.texels, &at).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("tile by tile: {covered} pixels covered; {depth_off} depths a few ulps off, {ties} ties");
    assert!(covered > (W * H / 2) as usize, "the triangles cover too little to test: {covered}");
}

/// The tests' triangles as the shader's `Tri` records (ID = index), drawn by tiles or not.
fn tri_input(tris: &[([Vec4; 3], bool)], by_tiles: bool) -> Vec<u8> {
    let mut input: Vec<u8> = Vec::new();
    for (i, (c, cull)) in tris.iter().enumerate() {
        for v in c {
            input.extend_from_slice(bytemuck::cast_slice(&v.to_array()));
        }
        input.extend_from_slice(bytemuck::cast_slice(&[W, H, i as u32, u32::from(*cull) | u32::from(by_tiles) << 1]));
    }
    input
}

/// The twin's target with every triangle drawn, and per pixel every triangle's depth
/// there (for ties).
fn twin(tris: &[([Vec4; 3], bool)]) -> (Raster, Vec<Vec<(f32, u32)>>) {
    let mut cpu = Raster::new(W, H);
    let mut at: Vec<Vec<(f32, u32)>> = vec![Vec::new(); (W * H) as usize];
    for (i, (c, cull)) in tris.iter().enumerate() {
        let cull = if *cull { Cull::Back } else { Cull::None };
        cpu.draw(*c, i as u32, cull);
        rasterize(*c, (W, H), cull, |f| at[(f.y * W + f.x) as usize].push((f.depth, i as u32)));
    }
    (cpu, at)
}

/// The largest depth difference between the GPU and the twin, in ulps (module doc).
const MAX_ULPS: u32 = 16;

/// A depth's distance in ulps from another (both non-negative).
fn ulps(a: f32, b: f32) -> u32 {
    a.to_bits().abs_diff(b.to_bits())
}

#[test]
fn gpu_raster_equals_the_cpu_twin() {
    let ctx = gpu();
    let need = wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX;
    assert!(
        ctx.device.features().contains(need),
        "the compute rasteriser needs SHADER_INT64 and SHADER_INT64_ATOMIC_MIN_MAX, which {} lacks",
        ctx.info.name
    );
    let tris = triangles(600, 0x9e37_79b9);
    let out =
        run_cases(ctx, "compute_raster", SHADER, &tri_input(&tris, false), tris.len() as u32, u64::from(W * H) * 8);
    let gpu_texels: Vec<u64> = bytemuck::cast_slice(&out).to_vec();
    let (cpu, at) = twin(&tris);
    let (covered, depth_off, ties) = compare(&gpu_texels, &cpu.texels, &at).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("{covered} pixels covered; {depth_off} with a depth a few ulps off, {ties} ties resolved otherwise");
    assert!(covered > (W * H / 2) as usize, "the triangles cover too little to test: {covered}");
    // How many differ in their last bits is the arithmetic's business, not a verdict
    // (measured: none on lavapipe; 2,270 of 5,917 on the H200, all within MAX_ULPS, coverage
    // identical everywhere).
    // The comparison's teeth: the twin without one triangle the GPU drew somewhere, or with
    // one pixel's ID replaced, is rejected.
    let drawn = gpu_texels.iter().find(|&&t| t != 0).map(|&t| unpack(t).1).expect("something drawn");
    let mut missing = Raster::new(W, H);
    for (i, (c, cull)) in tris.iter().enumerate().filter(|&(i, _)| i as u32 != drawn) {
        missing.draw(*c, i as u32, if *cull { Cull::Back } else { Cull::None });
    }
    assert!(compare(&gpu_texels, &missing.texels, &at).is_err(), "a missing triangle must be caught");
    let mut wrong = cpu.texels.clone();
    let p = wrong.iter().position(|&t| t != CLEAR).unwrap();
    wrong[p] = pack(unpack(wrong[p]).0, unpack(wrong[p]).1 ^ 1);
    assert!(compare(&gpu_texels, &wrong, &at).is_err(), "a wrong ID must be caught");
}

/// Compares the GPU's texels with the twin's, pixel by pixel (the module doc's rules):
/// the pixels covered, those whose depth differs in its last bits, and the ties resolved
/// the other way; an error naming the first pixel otherwise.
fn compare(gpu: &[u64], cpu: &[u64], at: &[Vec<(f32, u32)>]) -> Result<(usize, usize, usize), String> {
    let (mut covered, mut depth_off, mut ties) = (0, 0, 0);
    for (p, (&g, &c)) in gpu.iter().zip(cpu).enumerate() {
        // The GPU's buffer starts at zero, the twin's at CLEAR: both mean nothing drawn.
        let c = if c == CLEAR { 0 } else { c };
        if c != 0 {
            covered += 1;
        }
        if g == c {
            continue;
        }
        let (x, y) = (p as u32 % W, p as u32 / W);
        if g == 0 || c == 0 {
            return Err(format!("pixel ({x}, {y}): GPU {g:#x}, CPU {c:#x}: coverage differs"));
        }
        let ((gd, gi), (cd, ci)) = (unpack(g), unpack(c));
        if ulps(gd, cd) > MAX_ULPS {
            return Err(format!("pixel ({x}, {y}): depth {gd} vs {cd} ({} ulps)", ulps(gd, cd)));
        }
        if gi == ci {
            depth_off += 1;
        } else {
            // A tie: both triangles cover the pixel there, as near within MAX_ULPS.
            let near = |id: u32| at[p].iter().any(|&(d, i)| i == id && ulps(d, cd) <= MAX_ULPS);
            if !(near(gi) && near(ci)) {
                return Err(format!(
                    "pixel ({x}, {y}): GPU kept triangle {gi} at {gd}, the twin {ci} at {cd}, not a tie"
                ));
            }
            ties += 1;
        }
    }
    Ok((covered, depth_off, ties))
}

// ---- The whole raster pass on a scene ----

/// Per triangle of the GPU scene (instance slot, triangle within its mesh),
/// its clip-space vertices as the vertex stage computes them (`world_to_clip * (model * p)`),
/// whether its back faces are culled, and the ID it is drawn with.
struct SceneTriangles {
    tris: Vec<([Vec4; 3], Cull, u32)>,
}

impl SceneTriangles {
    fn new(scene: &tiledlight_scene::Scene, sg: &SceneGpu, camera: &tiledlight_cull::Camera) -> Self {
        let layout = IdLayout::for_scene(sg.instance_order.len() as u32, sg.max_triangles).unwrap();
        let vp = camera.view_proj();
        let mut tris = Vec::new();
        for (slot, &i) in sg.instance_order.iter().enumerate() {
            let inst = &scene.instances[i];
            let material = &scene.materials[inst.material];
            if !matches!(material.alpha_mode, AlphaMode::Opaque) {
                continue;
            }
            let mesh = &scene.meshes[inst.mesh];
            let cull = if material.double_sided { Cull::None } else { Cull::Back };
            for (t, idx) in mesh.indices.chunks_exact(3).enumerate() {
                let clip =
                    [0, 1, 2].map(|k| vp * (inst.transform * Vec3::from(mesh.positions[idx[k] as usize]).extend(1.0)));
                tris.push((clip, cull, layout.pack(slot as u32, t as u32)));
            }
        }
        Self { tris }
    }

    /// The twin's texels of every triangle, and per pixel every fragment (depth, ID).
    fn twin(&self, (w, h): (u32, u32)) -> (Vec<u64>, Vec<Vec<(f32, u32)>>) {
        let mut r = Raster::new(w, h);
        let mut at = vec![Vec::new(); (w * h) as usize];
        for &(clip, cull, id) in &self.tris {
            r.draw(clip, id, cull);
            rasterize(clip, (w, h), cull, |f| at[(f.y * w + f.x) as usize].push((f.depth, id)));
        }
        (r.texels, at)
    }

    /// Whether the centre of pixel `(x, y)` lies within `eps` pixels of an edge of
    /// triangle `id`, or the pixel is near a place where it crosses the eye plane (its
    /// coverage there is decided by arithmetic, not geometry): the edge functions in f64,
    /// in homogeneous 2D (Olano and Greer), at the centre shifted by `eps` each way.
    fn near_edge(&self, id: u32, (x, y): (u32, u32), (w, h): (u32, u32), eps: f64) -> bool {
        let Some(&(clip, _, _)) = self.tris.iter().find(|t| t.2 == id) else { return false };
        let v = clip.map(|c| DVec3::new(c.x as f64, c.y as f64, c.w as f64));
        let det = v[0].dot(v[1].cross(v[2]));
        let inside = |px: f64, py: f64| {
            let p = DVec3::new(px / w as f64 * 2.0 - 1.0, 1.0 - py / h as f64 * 2.0, 1.0);
            let e = [v[1].cross(v[2]).dot(p), v[2].cross(v[0]).dot(p), v[0].cross(v[1]).dot(p)];
            e.iter().all(|&e| e * det.signum() > 0.0)
        };
        let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
        let c = inside(cx, cy);
        [(eps, 0.0), (-eps, 0.0), (0.0, eps), (0.0, -eps)].iter().any(|&(dx, dy)| inside(cx + dx, cy + dy) != c)
    }
}

impl SceneTriangles {
    /// How far triangle `id`'s interpolated depth may move when its vertices move by `eps`
    /// pixels (the snap step a rounding difference in the vertex transform can cost): its
    /// screen-space depth gradient's length times `3 eps` (each vertex's move shifts the
    /// interpolated plane by at most its barycentric share, at most one, of `eps` along the
    /// gradient), in f64 from the projected vertices. A triangle crossing the eye plane has
    /// no such plane on screen: 1e-4 of its depth.
    fn depth_slack(&self, id: u32, depth: f32, (w, h): (u32, u32), eps: f64) -> f64 {
        let Some(&(clip, _, _)) = self.tris.iter().find(|t| t.2 == id) else { return 0.0 };
        if clip.iter().any(|c| c.w <= 0.0) {
            return 1e-4 * depth as f64;
        }
        let p = clip.map(|c| {
            let (x, y, z, cw) = (c.x as f64, c.y as f64, c.z as f64, c.w as f64);
            DVec3::new((x / cw + 1.0) * 0.5 * w as f64, (1.0 - y / cw) * 0.5 * h as f64, z / cw)
        });
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let n = e1.cross(e2);
        if n.z.abs() < 1e-12 {
            return 1e-4 * depth as f64;
        }
        // The plane z = z0 + gx (x - x0) + gy (y - y0): (gx, gy) = -(n.x, n.y) / n.z.
        let g = (n.x * n.x + n.y * n.y).sqrt() / n.z.abs();
        3.0 * eps * g
    }
}

/// How two rasters' (depth, ID) differ pixel by pixel.
#[derive(Debug, Default)]
struct Differences {
    /// Pixels with something drawn (in the first).
    covered: usize,
    /// Same triangle, depth within MAX_ULPS or within what a snap step moves it
    /// ([`SceneTriangles::depth_slack`]).
    depth_off: usize,
    /// Different triangles, both there within MAX_ULPS (or the two slacks) of each other.
    ties: usize,
    /// Different coverage where the pixel centre lies within the snap quantum of an edge of
    /// one of the two triangles.
    edges: usize,
}

/// Compares rasters `a` and `b` (depth, ID per pixel) with the scene's triangles and the
/// twin's fragments `at`; `eps` (pixels): how near an edge a coverage difference may be.
fn compare_scene(
    a: (&[f32], &[u32]),
    b: (&[f32], &[u32]),
    (tris, at): (&SceneTriangles, &[Vec<(f32, u32)>]),
    size: (u32, u32),
    eps: f64,
) -> Result<Differences, String> {
    let mut d = Differences::default();
    for (p, frags) in at.iter().enumerate().take(a.0.len()) {
        let (x, y) = (p as u32 % size.0, p as u32 / size.0);
        let ((ad, ai), (bd, bi)) = ((a.0[p], a.1[p]), (b.0[p], b.1[p]));
        if ai != NO_TRIANGLE {
            d.covered += 1;
        }
        if ai == bi {
            let slack = if ai == NO_TRIANGLE { 0.0 } else { tris.depth_slack(ai, ad, size, eps) };
            if ulps(ad, bd) > MAX_ULPS && ((ad - bd).abs() as f64) > slack {
                return Err(format!(
                    "pixel ({x}, {y}): triangle {ai:#x} at depth {ad} vs {bd} ({} ulps)",
                    ulps(ad, bd)
                ));
            }
            d.depth_off += usize::from(ad != bd);
            continue;
        }
        let frag = |id: u32| frags.iter().find(|f| f.1 == id).map(|f| f.0);
        let close = |x: f32, y: f32, slack: f64| ulps(x, y) <= MAX_ULPS || ((x - y).abs() as f64) <= slack;
        let tie = match (frag(ai), frag(bi)) {
            (Some(da), Some(db)) => {
                let slack = tris.depth_slack(ai, ad, size, eps) + tris.depth_slack(bi, bd, size, eps);
                close(da, db, slack) && close(ad, bd, slack)
            }
            _ => false,
        };
        if tie {
            d.ties += 1;
        } else if [ai, bi].iter().any(|&id| id != NO_TRIANGLE && tris.near_edge(id, (x, y), size, eps)) {
            d.edges += 1;
        } else {
            return Err(format!(
                "pixel ({x}, {y}): triangle {ai:#x} at {ad} vs {bi:#x} at {bd}: not a tie, not at an edge"
            ));
        }
    }
    Ok(d)
}

const SW: u32 = 320;
const SH: u32 = 180;

/// The courtyard drawn by the visibility buffer with `raster` (and the compute raster's
/// `large_px`): its (depth, ID) per pixel, and with the large triangles by compute the
/// tiles they listed, how many, and the list's capacity.
fn scene_raster(
    ctx: &tiledlight_gpu::GpuContext,
    (sg, lights, camera): (&SceneGpu, &LightBuffers, &tiledlight_cull::Camera),
    raster: RasterPath,
    compute_raster: ComputeRasterOptions,
) -> (Vec<f32>, Vec<u32>, Option<LargeTiles>) {
    let knobs = Knobs {
        raster,
        raster_large_px: compute_raster.large_px,
        raster_large: compute_raster.large,
        ..Knobs::default()
    };
    let s = FrameSettings { method: Method::Visibility, knobs, ..Default::default() };
    let mut r = FrameRenderer::new(ctx, sg, lights, SW, SH, s).unwrap_or_else(|e| panic!("{raster:?}: {e}"));
    assert_eq!(r.settings().knobs.raster, raster);
    render_frame(ctx, &mut r, sg, camera);
    let vis = r.passes::<VisibilityFrame>().unwrap().raster();
    let ids = vis.read_ids(&ctx.device, &ctx.queue).unwrap();
    let tiles = vis.compute().and_then(|c| c.read_large_tiles(&ctx.device, &ctx.queue).unwrap());
    (r.read_depth(ctx).unwrap(), ids, tiles)
}

/// The compute raster on a whole scene (the courtyard, 320x180), pixel by pixel:
/// - every triangle by one thread (`large_px` past the screen), and the default (large
///   triangles by a workgroup each), against the CPU twin drawing the same triangles:
///   equal but for depths within MAX_ULPS or a snap step's slack, ties, and coverage at
///   pixels whose centre lies within 1/128 px of an edge (the GPU's vertex transform may
///   contract a multiply-add the CPU rounds twice, moving a vertex by a snap step);
/// - large triangles by the hardware, and the hardware raster, against the default: the
///   same, the hardware snapping its vertices from its own viewport arithmetic;
/// - every triangle wider than a pixel large (`large_px` 1), its tiles past the tile
///   list's capacity (the lanes that list them fill the rest), against the twin: the same.
///
/// The default's tile list holds tiles of listed triangles only, each once; with
/// `large_px` 1 the list is full and more were listed.
///
/// Each count is printed; edge pixels must stay under 0.5% of the covered ones.
#[test]
fn compute_raster_matches_twin_and_hardware_on_a_scene() {
    let ctx = gpu();
    let scene = tiledlight_tests::scenes::courtyard();
    let camera = tiledlight_tests::scenes::courtyard_camera(&scene, SW, SH);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &tiledlight_tests::scenes::lights(&scene, 16, 0, 1)).unwrap();
    let tris = SceneTriangles::new(&scene, &sg, &camera);
    let (twin, at) = tris.twin((SW, SH));
    let twin_depth: Vec<f32> = twin.iter().map(|&t| unpack(t).0).collect();
    let twin_ids: Vec<u32> = twin.iter().map(|&t| unpack(t).1).collect();
    let inputs = (&sg, &lights, &camera);
    let options = |large_px, large| ComputeRasterOptions { large_px, large };
    let all_compute = scene_raster(ctx, inputs, RasterPath::Compute, options(u32::MAX, LargeRaster::Compute));
    let split = scene_raster(ctx, inputs, RasterPath::Compute, ComputeRasterOptions::default());
    let split_hw = scene_raster(ctx, inputs, RasterPath::Compute, options(32, LargeRaster::Hardware));
    let hardware = scene_raster(ctx, inputs, RasterPath::Hardware, ComputeRasterOptions::default());
    let overflow = scene_raster(ctx, inputs, RasterPath::Compute, options(1, LargeRaster::Compute));
    let LargeTiles { tiles, listed, capacity } = split.2.clone().expect("the default draws large triangles by compute");
    eprintln!("default: {listed} tiles listed of {capacity}");
    assert!(listed > 0 && listed as usize == tiles.len(), "the courtyard's large triangles list {listed} tiles");
    let mut unique = tiles.clone();
    unique.dedup();
    assert_eq!(unique.len(), tiles.len(), "a tile listed twice for one piece");
    let LargeTiles { listed, capacity, .. } = overflow.2.clone().unwrap();
    eprintln!("large_px 1: {listed} tiles listed, {capacity} kept");
    assert!(listed > capacity, "large_px 1 must pass the tile list's capacity to test the fallback");
    assert!(split_hw.2.is_none(), "tiles listed with the large triangles by the hardware");
    let none = all_compute.2.as_ref().map(|t| t.listed);
    assert_eq!(none, Some(0), "tiles listed with no triangle large");
    let eps = 2.0 / 256.0;
    let pairs = [
        ("all-compute vs twin", (&all_compute.0[..], &all_compute.1[..]), (&twin_depth[..], &twin_ids[..])),
        ("large by compute vs twin", (&split.0[..], &split.1[..]), (&twin_depth[..], &twin_ids[..])),
        ("large by hardware vs large by compute", (&split_hw.0[..], &split_hw.1[..]), (&split.0[..], &split.1[..])),
        ("hardware vs large by compute", (&hardware.0[..], &hardware.1[..]), (&split.0[..], &split.1[..])),
        (
            "large_px 1, the tile list full, vs twin",
            (&overflow.0[..], &overflow.1[..]),
            (&twin_depth[..], &twin_ids[..]),
        ),
    ];
    for (what, a, b) in pairs {
        let d = compare_scene(a, b, (&tris, &at), (SW, SH), eps).unwrap_or_else(|e| panic!("{what}: {e}"));
        eprintln!("{what}: {d:?}");
        assert!(d.covered > (SW * SH / 2) as usize, "{what}: too little drawn to test");
        assert!(d.edges * 200 < d.covered, "{what}: {} edge pixels differ, more than 0.5%", d.edges);
    }
    // The comparison's teeth: one pixel given another triangle far from its edges fails.
    let mut wrong = all_compute.1.clone();
    let p = (SH / 2 * SW + SW / 2) as usize;
    wrong[p] = tris.tris.iter().map(|t| t.2).find(|&id| id != wrong[p] && at[p].iter().all(|f| f.1 != id)).unwrap();
    assert!(
        compare_scene((&all_compute.0, &wrong), (&twin_depth, &twin_ids), (&tris, &at), (SW, SH), eps).is_err(),
        "a wrong triangle in the middle of the screen must be caught"
    );
}

/// A single-sided surface seen from behind and crossing the near plane (a lid 0.5 m below
/// the eye of the floor scene's camera, facing down, reaching behind the eye) is culled by
/// the compute raster as by the twin, and drawn when its material is double-sided: the
/// clusters' kernel hands triangles that need clipping to the large kernels with their
/// culling flag (issue 49). Compared with the twin pixel by pixel as the courtyard is.
#[test]
fn a_clipped_back_face_is_culled_and_a_double_sided_one_drawn() {
    let ctx = gpu();
    let camera = tiledlight_tests::scenes::floor_camera(SW, SH);
    for double_sided in [false, true] {
        let light = tiledlight_cull::Light::point(Vec3::new(0.0, 1.0, 0.0), Vec3::ONE, 1.0, 0.01).unwrap();
        let mut scene = tiledlight_tests::scenes::floor_scene(0.5, 0.0, vec![light]);
        let mut lid = scene.meshes[0].clone();
        lid.name = "lid".into();
        for p in &mut lid.positions {
            p[1] = 2.5;
        }
        lid.normals = vec![[0.0, -1.0, 0.0]; 4];
        lid.indices = vec![0, 2, 1, 0, 3, 2];
        scene.meshes.push(lid);
        let mut material = scene.materials[0].clone();
        material.double_sided = double_sided;
        scene.materials.push(material);
        scene.instances.push(tiledlight_scene::Instance { mesh: 1, material: 1, transform: glam::Mat4::IDENTITY });
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let lights = LightBuffers::new(&ctx.device, &scene.lights).unwrap();
        let tris = SceneTriangles::new(&scene, &sg, &camera);
        let layout = IdLayout::for_scene(sg.instance_order.len() as u32, sg.max_triangles).unwrap();
        let slot = sg.instance_order.iter().position(|&i| i == 1).unwrap() as u32;
        let lid_ids = [layout.pack(slot, 0), layout.pack(slot, 1)];
        let crosses = |id: u32| tris.tris.iter().any(|t| t.2 == id && t.0.iter().any(|c| c.z > c.w));
        assert!(lid_ids.iter().all(|&id| crosses(id)), "the lid must cross the near plane to test clipping");
        let (twin, at) = tris.twin((SW, SH));
        let twin_depth: Vec<f32> = twin.iter().map(|&t| unpack(t).0).collect();
        let twin_ids: Vec<u32> = twin.iter().map(|&t| unpack(t).1).collect();
        let (depth, ids, _) =
            scene_raster(ctx, (&sg, &lights, &camera), RasterPath::Compute, ComputeRasterOptions::default());
        let d = compare_scene((&depth, &ids), (&twin_depth, &twin_ids), (&tris, &at), (SW, SH), 2.0 / 256.0)
            .unwrap_or_else(|e| panic!("double-sided {double_sided}: {e}"));
        let lid = ids.iter().filter(|id| lid_ids.contains(id)).count();
        eprintln!("double-sided {double_sided}: {d:?}, {lid} lid pixels");
        assert!(d.edges * 200 < d.covered, "{} edge pixels differ, more than 0.5%", d.edges);
        if double_sided {
            assert!(lid > (SW * SH / 2) as usize, "the double-sided lid must cover the view: {lid} pixels");
        } else {
            assert_eq!(lid, 0, "the single-sided lid is seen from behind: culled");
        }
    }
}

/// Every frame starts clean: the finalize kernel resets the texels and empties the large
/// list and its tiles for the next frame (no clear pass runs). A renderer that drew the courtyard from
/// one camera and then from another gives, for the second, the depth and IDs of a fresh
/// renderer drawing only the second, bit for bit (the same kernels on the same inputs).
#[test]
fn each_frame_forgets_the_last() {
    let ctx = gpu();
    let scene = tiledlight_tests::scenes::courtyard();
    let first = tiledlight_tests::scenes::courtyard_camera(&scene, SW, SH);
    let second = tiledlight_cull::Camera::from_view(
        glam::Mat4::look_at_rh(Vec3::new(0.0, 3.0, 8.0), Vec3::new(0.0, 2.0, 0.0), Vec3::Y),
        first.projection(),
    )
    .unwrap();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &tiledlight_tests::scenes::lights(&scene, 16, 0, 1)).unwrap();
    let knobs = Knobs { raster: RasterPath::Compute, ..Knobs::default() };
    let s = FrameSettings { method: Method::Visibility, knobs, ..Default::default() };
    let read = |r: &FrameRenderer| {
        let ids = r.passes::<VisibilityFrame>().unwrap().raster().read_ids(&ctx.device, &ctx.queue).unwrap();
        (r.read_depth(ctx).unwrap(), ids)
    };
    let mut twice = FrameRenderer::new(ctx, &sg, &lights, SW, SH, s).unwrap();
    render_frame(ctx, &mut twice, &sg, &first);
    let after_first = read(&twice);
    render_frame(ctx, &mut twice, &sg, &second);
    let mut fresh = FrameRenderer::new(ctx, &sg, &lights, SW, SH, s).unwrap();
    render_frame(ctx, &mut fresh, &sg, &second);
    let (a, b) = (read(&twice), read(&fresh));
    // The large triangles' tile list restarts too: the same tiles listed, none past the list.
    let tiles = |r: &FrameRenderer| {
        let vis = r.passes::<VisibilityFrame>().unwrap().raster();
        vis.compute().unwrap().read_large_tiles(&ctx.device, &ctx.queue).unwrap().unwrap()
    };
    let (t_twice, t_fresh) = (tiles(&twice), tiles(&fresh));
    assert!(t_fresh.listed > 0, "the second view must list large triangles' tiles to test this");
    assert_eq!(t_twice, t_fresh, "the tile list kept the frame before's");
    assert_ne!(after_first.1, b.1, "the two cameras must see different triangles for this to test anything");
    let differ = a.1.iter().zip(&b.1).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{differ} pixels keep IDs of the frame before");
    assert!(a.0.iter().zip(&b.0).all(|(x, y)| x.to_bits() == y.to_bits()), "depths differ");
}
