//! MSAA in every method (the visibility buffer in `check_visibility_msaa`): culling over every depth sample against the CPU reference,
//! Tiled Deferred's edge-test MSAA against Forward+'s hardware MSAA and the brute-force
//! reference (both at 4x), MSAA 1x vs 4x differing only at geometric edges, the edge test's
//! edge-pixel fraction and its independence of the scene's scale, both methods against
//! brute force in HDR at every sample count the adapter has (a refusal there fails), and
//! clear errors for sample counts the adapter lacks. lavapipe multisamples only 4x (WebGPU's
//! guaranteed count): there 2x and 8x are checked for the clear error only, and the test
//! prints that it did not render them; the H200 run (scripts/device-gpu-tests.sh) renders
//! and compares them.

use glam::{Mat4, Vec3};
use tiledlight_cull::Camera;
use tiledlight_deferred::EdgeTest;
use tiledlight_frame::{DeferredFrame, Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;
use tiledlight_scene::Scene;
use tiledlight_tests::compare::{
    assert_matches_reference_frame, assert_matches_reference_msaa, bound_by_design, msaa_by_design, render_frame,
    DEFERRED_VS_REFERENCE, FORWARD_VS_REFERENCE,
};
use tiledlight_tests::images::{assert_flip, max_relative_error, save_png, FlipThresholds};
use tiledlight_tests::lists::{assert_lists_match, CulledFrame};
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

fn render(ctx: &GpuContext, r: &mut FrameRenderer, scene: &SceneGpu, camera: &Camera) -> Vec<u8> {
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, scene, camera).unwrap();
    r.read_ldr(ctx).unwrap()
}

fn forward(ctx: &GpuContext, sg: &SceneGpu, l: &LightBuffers, (w, h): (u32, u32), s: FrameSettings) -> FrameRenderer {
    FrameRenderer::new(ctx, sg, l, w, h, s).unwrap()
}

fn deferred(ctx: &GpuContext, sg: &SceneGpu, l: &LightBuffers, (w, h): (u32, u32), s: FrameSettings) -> FrameRenderer {
    FrameRenderer::new(ctx, sg, l, w, h, s).unwrap()
}

/// The GPU lists of a 4x frame equal the CPU reference run on the same depth samples, list
/// for list as sets (shared float-borderline acceptance, `tiledlight_tests::lists`), for
/// both Forward+'s culling pass and the lists Tiled Deferred shades with (the light grid
/// it writes). Catches a kernel that bounds only sample 0 (the CPU reads every sample) and a
/// deferred pass shading with the right number of wrong lights.
#[test]
fn msaa_culling_matches_cpu_reference() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let (w, h) = (327, 183);
    let camera = scenes::courtyard_camera(&scene, w, h);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 600, 100, 9)).unwrap();
    for cull in [
        CullOptions::default(),
        CullOptions { tile_size: 32, half_z: true, aabb: true, spot_cone: true, coarse: false, ..Default::default() },
        CullOptions { tile_size: 8, half_z: true, ..Default::default() },
    ] {
        let mut f = forward(ctx, &sg, &lights, (w, h), FrameSettings { cull, msaa: 4, ..Default::default() });
        render(ctx, &mut f, &sg, &camera);
        let depth = f.read_depth(ctx).unwrap();
        assert_eq!(depth.len(), (w * h * 4) as usize, "4 depth samples a pixel");
        // The samples of an edge pixel differ: the readback really is per sample.
        assert!(depth.chunks_exact(4).any(|s| s[0] != s[3]), "some pixel's samples differ");
        let opts = CullOptions { samples: 4, ..cull };
        let config = opts.to_config(true);
        let gpu_lists = f.read_lists(ctx).unwrap();
        let frame = CulledFrame { depth: &depth, width: w, height: h, camera: &camera, lights: &lights.packed };
        let c = assert_lists_match(&format!("forward+ {opts:?}"), &frame, &gpu_lists, &config);
        assert!(c.pairs > 0, "lights reach the tiles");

        let settings = FrameSettings { method: Method::TiledDeferred, cull, msaa: 4, ..Default::default() };
        let mut d = deferred(ctx, &sg, &lights, (w, h), settings);
        render(ctx, &mut d, &sg, &camera);
        let depth = d.read_depth(ctx).unwrap();
        assert_eq!(depth.len(), (w * h * 4) as usize, "4 depth samples a pixel");
        let gpu_lists = d.read_lists(ctx).unwrap();
        let frame = CulledFrame { depth: &depth, ..frame };
        let c = assert_lists_match(&format!("deferred {opts:?}"), &frame, &gpu_lists, &config);
        assert!(c.pairs > 0, "lights reach the tiles");
    }
}

/// Pixels where the 4x depth samples do not lie on one plane (a silhouette, a crease, or
/// sky next to a surface), grown by `grow` pixels: an independent, depth-only edge
/// detector (`compare::coplanar`: reversed-Z depth is affine in screen space across a
/// plane, so samples 0-2 at the standard positions predict the others).
fn depth_edges(depth: &[f32], (w, h): (u32, u32), grow: i32) -> Vec<bool> {
    let mut edge = vec![false; (w * h) as usize];
    for (i, s) in depth.chunks_exact(4).enumerate() {
        let sky = s.iter().filter(|&&d| d <= 0.0).count();
        edge[i] = if sky > 0 { sky < 4 } else { !tiledlight_tests::compare::coplanar(s) };
    }
    grow_mask(&edge, (w, h), grow)
}

/// `mask` dilated by `grow` pixels (a square).
fn grow_mask(mask: &[bool], (w, h): (u32, u32), grow: i32) -> Vec<bool> {
    let mut grown = mask.to_vec();
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            if !mask[(y * w as i32 + x) as usize] {
                continue;
            }
            for dy in -grow..=grow {
                for dx in -grow..=grow {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < w as i32 && ny < h as i32 {
                        grown[(ny * w as i32 + nx) as usize] = true;
                    }
                }
            }
        }
    }
    grown
}

/// Tiled Deferred's edge pixels of its last frame as a mask.
fn deferred_edges(ctx: &GpuContext, d: &FrameRenderer, (w, h): (u32, u32)) -> Vec<bool> {
    let mut mask = vec![false; (w * h) as usize];
    for (x, y) in
        d.passes::<DeferredFrame>().expect("Tiled Deferred").shading().read_edge_list(&ctx.device, &ctx.queue).unwrap()
    {
        mask[(y * w + x) as usize] = true;
    }
    mask
}

/// Mean over `pixels` of the largest relative channel error of `b` against `a` (HDR).
fn mean_relative_error(a: &[[f32; 4]], b: &[[f32; 4]], pixels: &[usize]) -> f64 {
    let sum: f64 = pixels
        .iter()
        .map(|&i| (0..3).map(|c| ((a[i][c] - b[i][c]).abs() / a[i][c].abs().max(1e-2)) as f64).fold(0.0, f64::max))
        .sum();
    sum / pixels.len().max(1) as f64
}

/// Tiled Deferred 4x against Forward+ 4x and the brute-force reference at 4x on the mixed
/// scene (spots, masked and double-sided materials, half-z, AABB and cone tests, 8 px
/// tiles), lit from above (tests/src/scenes.rs `lights_in_slab`: shading smooth within a
/// pixel). Forward+ culls exactly, so its image is the reference's (FLIP mean < 1e-3).
/// Deferred keeps the no-MSAA bound of tests/deferred.rs (FLIP mean 0.015, p99 0.05; the
/// 8-bit sRGB albedo gives ~0.01): hardware MSAA shades an edge pixel's triangles once
/// each at their centroids, deferred each sample where it lies, and with smooth shading
/// the two averages agree to well under that.
#[test]
fn deferred_msaa_matches_forward_msaa() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let camera = scenes::mixed_camera(W, H);
    let cull = CullOptions { tile_size: 8, half_z: true, aabb: true, spot_cone: true, ..Default::default() };
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights_in_slab(&scene, 3.5, 4.0, 300, 100, 21)).unwrap();
    let bf = FrameSettings { method: Method::BruteForce { cutoff: true }, msaa: 4, ..Default::default() };
    let reference = render(ctx, &mut forward(ctx, &sg, &lights, (W, H), bf), &sg, &camera);
    let mut f = forward(ctx, &sg, &lights, (W, H), FrameSettings { cull, msaa: 4, ..Default::default() });
    let fwd = render(ctx, &mut f, &sg, &camera);
    let mut d = deferred(
        ctx,
        &sg,
        &lights,
        (W, H),
        FrameSettings { method: Method::TiledDeferred, cull, msaa: 4, ..Default::default() },
    );
    let def = render(ctx, &mut d, &sg, &camera);
    assert!(d.edge_pixels(ctx).unwrap().is_some_and(|n| n > 0), "the frame has edge pixels");
    let exact = FlipThresholds { mean: 1e-3, percentile: (0.99, 1e-2) };
    assert_flip("msaa-mixed-forward-vs-reference", W, H, &reference, &fwd, exact);
    let flip = FlipThresholds { mean: 0.015, percentile: (0.99, 0.05) };
    assert_flip("msaa-mixed-deferred-vs-reference", W, H, &reference, &def, flip);
    assert_flip("msaa-mixed-deferred-vs-forward", W, H, &fwd, &def, flip);
}

/// The courtyard with 1024 random lights, some of whose 1 cm cores sit on surfaces: within
/// one pixel's footprint the light then varies many times over, and hardware MSAA and Tiled
/// Deferred resolve such pixels differently (at 320x180 the two images are FLIP mean 0.031
/// apart; every pixel shaded once agrees as in the smooth case). Neither is the reference
/// at an edge pixel: 4x supersampling is (brute force at 640x360, 2x2 box filtered, not the
/// same sample positions, so neither matches it exactly). Over the edge pixels deferred's
/// per-sample shading must be at least as close to it as hardware MSAA's one sample per
/// triangle (measured mean relative error 0.28 vs 0.31).
#[test]
fn deferred_msaa_parts_match_their_references() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 1024, 0, 21)).unwrap();
    let hdr = |r: &mut FrameRenderer, camera: &Camera| {
        render(ctx, r, &sg, camera);
        r.read_hdr(ctx).unwrap()
    };
    let bf = FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() };
    let fwd = hdr(&mut forward(ctx, &sg, &lights, (W, H), FrameSettings { msaa: 4, ..Default::default() }), &camera);
    let mut d = deferred(
        ctx,
        &sg,
        &lights,
        (W, H),
        FrameSettings { method: Method::TiledDeferred, msaa: 4, ..Default::default() },
    );
    let def = hdr(&mut d, &camera);

    let edges = deferred_edges(ctx, &d, (W, H));
    let (edge_px, flat_px): (Vec<usize>, Vec<usize>) = (0..(W * H) as usize).partition(|&i| edges[i]);
    assert!(!edge_px.is_empty() && flat_px.len() > edge_px.len(), "{} edge pixels", edge_px.len());
    let big = hdr(&mut forward(ctx, &sg, &lights, (2 * W, 2 * H), bf), &scenes::courtyard_camera(&scene, 2 * W, 2 * H));
    let ssaa: Vec<[f32; 4]> = (0..(W * H) as usize)
        .map(|i| {
            let (x, y) = (2 * (i as u32 % W), 2 * (i as u32 / W));
            let mut s = [0.0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let q = big[((y + dy) * 2 * W + x + dx) as usize];
                for c in 0..4 {
                    s[c] += 0.25 * q[c];
                }
            }
            s
        })
        .collect();
    // Pixels the edge test did not flag are shaded once, at the pixel centre on sample 0's
    // plane, with sample 0's G-buffer attributes. Where one triangle covers the whole pixel
    // that is exactly what a 1x render shades. Where two triangles of one surface meet in
    // the pixel, sample 0 may hold the other triangle's material or smooth normal than the
    // centre (the courtyard's checkered floor tiles and round columns: measured 15.7% of
    // these pixels beyond 3e-2 of the 1x image, on lavapipe and the H200), as hardware MSAA
    // stores one fragment per triangle: no error, another sampling of the pixel. So: the
    // median pixel equals the 1x reference up to the 8-bit sRGB albedo's rounding (under
    // 1.5e-2, tests/deferred.rs; measured 7.3e-3), and at least 75% (measured 84.3%) lie
    // within tests/deferred.rs's 3e-2. A pass that
    // left them unwritten, shaded them with another tile's list, at the wrong depth, or
    // without a light fails. The exact check, without coplanar triangles of different
    // materials, is msaa_changes_only_edge_pixels.
    let one_x = hdr(&mut forward(ctx, &sg, &lights, (W, H), bf), &camera);
    let mut errors: Vec<f32> =
        flat_px.iter().map(|&i| max_relative_error(&one_x[i..=i], &def[i..=i], 1e-2).0).collect();
    errors.sort_by(f32::total_cmp);
    let median = errors[errors.len() / 2];
    let within = errors.partition_point(|&e| e <= 3e-2) as f64 / errors.len() as f64;
    eprintln!(
        "{} pixels shaded once: median relative error {median:.2e} against the 1x reference, {:.1}% within 3e-2",
        flat_px.len(),
        100.0 * within
    );
    assert!(median < 1.5e-2, "pixels shaded once: median relative error {median} against 1x");
    assert!(within >= 0.75, "only {:.1}% of the pixels shaded once within 3e-2 of 1x", 100.0 * within);
    let e_def = mean_relative_error(&ssaa, &def, &edge_px);
    let e_fwd = mean_relative_error(&ssaa, &fwd, &edge_px);
    eprintln!(
        "{} edge pixels; mean relative error against 4x supersampling: deferred {e_def:.4}, Forward+ MSAA {e_fwd:.4}",
        edge_px.len()
    );
    assert!(e_def <= e_fwd, "deferred edge pixels further from supersampling ({e_def}) than MSAA's ({e_fwd})");
}

/// MSAA changes pixels only at geometric edges: 1x and 4x images of each method agree
/// (within 3/255 per channel: 8-bit rounding of a resolved average, and two coplanar
/// triangles meeting inside a pixel, stay below it) everywhere except within a pixel of an
/// edge, and do differ somewhere (edges really are antialiased). Edges are the depth-only
/// detector's, for both methods. Lit from above
/// (`lights_in_slab`): with a light's core on a surface, hardware MSAA would also change
/// pixels where two triangles of one surface meet, shading each at its own centroid.
/// Untextured materials only (see below).
#[test]
fn msaa_changes_only_edge_pixels() {
    let ctx = gpu();
    let mut scene = scenes::mixed_scene();
    // Without the textured screen: where its two triangles meet inside a pixel, hardware
    // MSAA samples the 16x16 checker at each triangle's centroid, another texel than the
    // centre's (a texture edge, not a geometric one; measured up to 49/255 along the diagonal).
    scene.instances.retain(|i| scene.materials[i.material].base_color_texture.is_none());
    let camera = scenes::mixed_camera(W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights_in_slab(&scene, 3.5, 4.0, 200, 50, 5)).unwrap();
    let f1 = render(ctx, &mut forward(ctx, &sg, &lights, (W, H), FrameSettings::default()), &sg, &camera);
    let mut f = forward(ctx, &sg, &lights, (W, H), FrameSettings { msaa: 4, ..Default::default() });
    let f4 = render(ctx, &mut f, &sg, &camera);
    let d1 =
        render(ctx, &mut deferred(ctx, &sg, &lights, (W, H), FrameSettings::of(Method::TiledDeferred)), &sg, &camera);
    let mut d = deferred(
        ctx,
        &sg,
        &lights,
        (W, H),
        FrameSettings { method: Method::TiledDeferred, msaa: 4, ..Default::default() },
    );
    let d4 = render(ctx, &mut d, &sg, &camera);
    // Both methods against the independent depth-only detector (never the edge test's own
    // list: a deferred pass that blurred or re-shaded flat pixels it had itself flagged
    // would pass against that).
    let geometric = depth_edges(&f.read_depth(ctx).unwrap(), (W, H), 1);
    let deferred_geometric = depth_edges(&d.read_depth(ctx).unwrap(), (W, H), 1);
    for (name, one, four, near_edge) in [("forward", &f1, &f4, &geometric), ("deferred", &d1, &d4, &deferred_geometric)]
    {
        let mut changed = 0;
        let mut away = Vec::new();
        let mut map = vec![0u8; (W * H * 4) as usize];
        for (i, (a, b)) in one.chunks_exact(4).zip(four.chunks_exact(4)).enumerate() {
            let diff = a.iter().zip(b).take(3).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
            map[i * 4..i * 4 + 4].copy_from_slice(&[if near_edge[i] { 90 } else { 0 }, 0, 0, 255]);
            if diff > 3 {
                changed += 1;
                map[i * 4 + 1] = 255;
                if !near_edge[i] {
                    away.push((i as u32 % W, i as u32 / W, diff));
                }
            }
        }
        if !away.is_empty() {
            // Artefacts: both images, and a map (red: near an edge, green: changed).
            let dir = tiledlight_tests::output_dir();
            save_png(&dir.join(format!("msaa-edges-{name}-1x.png")), W, H, one);
            save_png(&dir.join(format!("msaa-edges-{name}-4x.png")), W, H, four);
            save_png(&dir.join(format!("msaa-edges-{name}-map.png")), W, H, &map);
            panic!(
                "{name}: {} pixels changed away from any edge (x, y, diff/255): {:?}",
                away.len(),
                &away[..away.len().min(10)]
            );
        }
        let near = near_edge.iter().filter(|&&e| e).count();
        eprintln!("{name}: {changed} pixels changed by MSAA; {near} pixels within 1 px of an edge");
        assert!(changed > 50, "{name}: MSAA changed only {changed} pixels: edges not antialiased");
    }
}

/// `scene` with every instance scaled by `k` about the origin.
fn scaled(scene: &Scene, k: f32) -> Scene {
    let mut s = scene.clone();
    for inst in &mut s.instances {
        inst.transform = Mat4::from_scale(Vec3::splat(k)) * inst.transform;
    }
    s.bounds = s.compute_bounds();
    s
}

/// Tiled Deferred 4x's edge-pixel count of a frame, and its depth samples.
fn edge_pixels(ctx: &GpuContext, scene: &Scene, camera: &Camera, edge: EdgeTest) -> (u32, Vec<f32>) {
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(scene, 16, 0, 2)).unwrap();
    let mut d = deferred(
        ctx,
        &sg,
        &lights,
        (W, H),
        FrameSettings {
            method: Method::TiledDeferred,
            msaa: 4,
            knobs: Knobs { edge_distance: edge.distance, edge_normal_deg: edge.normal_deg, ..Knobs::default() },
            ..Default::default()
        },
    );
    render(ctx, &mut d, &sg, camera);
    (d.edge_pixels(ctx).unwrap().expect("MSAA deferred counts edges"), d.read_depth(ctx).unwrap())
}

/// The edge test is scale-independent: the mixed scene and its camera scaled by 1e-3 and
/// 1e3 give the same edge pixels as at scale 1 (within 1%: depth rounding differs per
/// scale). Its edge pixels are the geometric edges: their number is within 25% of the
/// pixels whose depth samples leave one plane (the depth-only detector above; the normal
/// test adds smooth-shaded creases, the relative tolerance drops steps under 0.2% of the
/// distance). A tilted floor filling the screen has no edge but the horizon: the
/// tangent-plane test does not flag slopes, where a fixed depth threshold would. Looser
/// thresholds flag no more pixels.
#[test]
fn edge_test_is_scale_independent() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let camera = scenes::mixed_camera(W, H);
    let (base, depth) = edge_pixels(ctx, &scene, &camera, EdgeTest::default());
    let geometric = depth_edges(&depth, (W, H), 0).iter().filter(|&&e| e).count() as f64;
    eprintln!(
        "mixed scene: {base} edge pixels ({:.2}%), {geometric} pixels whose depth samples leave one plane",
        100.0 * base as f64 / (W * H) as f64
    );
    assert!((base as f64 - geometric).abs() <= 0.25 * geometric, "{base} edge pixels vs {geometric} geometric");
    for k in [1e-3f32, 1e3] {
        // scenes::mixed_camera, scaled.
        let (eye, target) = (Vec3::new(7.0, 4.5, 9.0) * k, Vec3::new(0.0, 0.5, 0.0) * k);
        let aspect = W as f32 / H as f32;
        let camera = Camera::perspective(eye, target, Vec3::Y, 55f32.to_radians(), aspect, 0.1 * k, None).unwrap();
        let (n, _) = edge_pixels(ctx, &scaled(&scene, k), &camera, EdgeTest::default());
        eprintln!("scale {k}: {n} edge pixels");
        assert!(
            (n as f64 - base as f64).abs() <= 0.01 * base as f64,
            "scale {k}: {n} edge pixels vs {base} at scale 1"
        );
    }
    // Monotone in the thresholds: zero tolerance flags every pixel whose samples are not
    // bit-exactly coplanar; a loose one keeps only the silhouettes and sharp creases.
    let (tight, _) = edge_pixels(ctx, &scene, &camera, EdgeTest { distance: 0.0, normal_deg: 0.0 });
    let (loose, _) = edge_pixels(ctx, &scene, &camera, EdgeTest { distance: 0.05, normal_deg: 45.0 });
    eprintln!("edge pixels: {tight} with zero tolerance, {loose} with 5% and 45 deg");
    assert!(tight > base && base >= loose, "edge pixels not monotone in the thresholds: {tight}, {base}, {loose}");

    // Only the floor, seen at a grazing angle: a slope everywhere, an edge only where the
    // floor meets the sky (at most two rows of pixels).
    let mut floor = scene.clone();
    floor.instances.truncate(1);
    let grazing = Camera::perspective(
        Vec3::new(0.0, 0.4, 9.5),
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::Y,
        60f32.to_radians(),
        W as f32 / H as f32,
        0.1,
        None,
    )
    .unwrap();
    let (n, _) = edge_pixels(ctx, &floor, &grazing, EdgeTest::default());
    eprintln!("grazing floor: {n} edge pixels");
    assert!(n > 0 && n <= 2 * W, "grazing floor: {n} edge pixels, expected only the horizon's");
}

/// At every sample count the adapter has (lavapipe: 1x and 4x; the H200 run,
/// scripts/device-gpu-tests.sh, adds 2x and 8x), both methods must build (a refusal fails)
/// and match brute force at the same count in linear HDR and FLIP with compare.rs's
/// tolerances, as the 1x tests do: Forward+ with FORWARD_VS_REFERENCE (hardware MSAA in
/// both, the same fragments; summation order only), Tiled Deferred with
/// DEFERRED_VS_REFERENCE and the normal allowance (its 8-bit albedo and packed normal),
/// except that where the two sample a pixel differently by design only FLIP applies
/// (`compare::msaa_by_design`: silhouettes, where hardware MSAA shades a partly covered
/// triangle at the pixel centre, outside it, and deferred's per-sample edge pixels;
/// 4x supersampling decides between them in `deferred_msaa_parts_match_their_references`).
/// Their number is printed and must stay under 10% of the frame; and with MSAA, pixels
/// where coplanar triangles meet are allowed as stated in the test. Also, on the full mixed
/// scene, brute force's and deferred's depth samples must be identical. The mixed scene lit from above (`lights_in_slab`: shading smooth within a pixel), so an
/// edge pixel's per-sample shading (deferred) and per-triangle shading (hardware MSAA)
/// agree within those bounds; a missing light or an edge resolved from the wrong samples
/// does not. With more than one sample, Tiled Deferred's edge test must find edge pixels.
#[test]
fn every_sample_count_matches_brute_force_in_hdr() {
    let ctx = gpu();
    let full = scenes::mixed_scene();
    // Without the textured screen for the images (as msaa_changes_only_edge_pixels): where
    // its two triangles meet inside a pixel, Tiled Deferred shades the pixel once with
    // sample 0's texel and hardware MSAA averages both triangles' (measured 23% at one 4x
    // pixel); the depth check below keeps it.
    let mut scene = full.clone();
    scene.instances.retain(|i| scene.materials[i.material].base_color_texture.is_none());
    let camera = scenes::mixed_camera(W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let full_sg = SceneGpu::new(&ctx.device, &ctx.queue, &full).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights_in_slab(&scene, 3.5, 4.0, 100, 20, 1)).unwrap();
    let counts = tiledlight_tests::adapter_sample_counts(ctx);
    assert!(counts.contains(&1) && counts.contains(&4), "WebGPU guarantees 1x and 4x: {counts:?}");
    let bf = FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() };
    // One depth per pixel for the f16-normal allowance.
    let mut one = forward(ctx, &sg, &lights, (W, H), bf);
    render(ctx, &mut one, &sg, &camera);
    let depth = one.read_depth(ctx).unwrap();
    for msaa in counts {
        // The full scene's depth samples, alpha-masked screen included: brute force's depth
        // pre-pass and Tiled Deferred's G-buffer pass must cover the same samples at the same
        // depths (invariant positions; both alpha-test at the centroid of the covered
        // samples: the pre-pass once tested at the pixel centre, outside a partly covered
        // triangle, and left 4x samples empty that deferred filled).
        let mut b = forward(ctx, &full_sg, &lights, (W, H), FrameSettings { msaa, ..bf });
        render(ctx, &mut b, &full_sg, &camera);
        let d = FrameRenderer::new(
            ctx,
            &full_sg,
            &lights,
            W,
            H,
            FrameSettings { method: Method::TiledDeferred, msaa, ..Default::default() },
        );
        let mut d = d.unwrap_or_else(|e| panic!("Tiled Deferred refused {msaa}x, which the adapter has: {e}"));
        render(ctx, &mut d, &full_sg, &camera);
        let (bd, dd) = (b.read_depth(ctx).unwrap(), d.read_depth(ctx).unwrap());
        let differ = bd.iter().zip(&dd).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        eprintln!("{msaa}x: {differ} of {} depth samples differ between brute force and Tiled Deferred", bd.len());
        assert_eq!(differ, 0, "{msaa}x: brute force and Tiled Deferred cover different depth samples");

        let mut b = forward(ctx, &sg, &lights, (W, H), FrameSettings { msaa, ..bf });
        let reference = render_frame(ctx, &mut b, &sg, &camera);
        let f = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings { msaa, ..Default::default() });
        let mut f = f.unwrap_or_else(|e| panic!("Forward+ refused {msaa}x, which the adapter has: {e}"));
        let fwd = render_frame(ctx, &mut f, &sg, &camera);
        let name = format!("msaa{msaa}-forward-vs-reference");
        assert_matches_reference_frame(&name, W, &reference, &fwd, FORWARD_VS_REFERENCE);
        let d = FrameRenderer::new(
            ctx,
            &sg,
            &lights,
            W,
            H,
            FrameSettings { method: Method::TiledDeferred, msaa, ..Default::default() },
        );
        let mut d = d.unwrap_or_else(|e| panic!("Tiled Deferred refused {msaa}x, which the adapter has: {e}"));
        let def = render_frame(ctx, &mut d, &sg, &camera);
        let reference = reference.allow_gbuffer_normals(&depth, W, &camera, &lights.packed);
        let edges = if msaa > 1 {
            d.passes::<DeferredFrame>()
                .expect("Tiled Deferred")
                .shading()
                .read_edge_list(&ctx.device, &ctx.queue)
                .unwrap()
        } else {
            Vec::new()
        };
        let depths = (&b.read_depth(ctx).unwrap()[..], &d.read_depth(ctx).unwrap()[..]);
        let (reference, forgiven) = reference.forgive_hdr(&msaa_by_design(W, depths, msaa, &edges));
        eprintln!("{msaa}x: {forgiven} pixels compared by FLIP only ({} deferred edge pixels)", edges.len());
        assert!(forgiven * 10 < (W * H) as usize, "{msaa}x: {forgiven} pixels forgiven: the HDR check sees too little");
        let name = format!("msaa{msaa}-deferred-vs-reference");
        if msaa == 1 {
            assert_matches_reference_frame(&name, W, &reference, &def, DEFERRED_VS_REFERENCE);
        } else {
            // Where two coplanar triangles (a quad's diagonal) share a pixel, hardware MSAA
            // shades each at the centroid of its own samples, and deferred the whole pixel at
            // its centre: the depth cannot show those pixels (one plane), and a light whose
            // shading varies within the pixel makes them differ (measured at 4x on lavapipe:
            // 16 of the 56,838 pixels compared, worst 6.7e-2): compare::assert_matches_reference_msaa.
            assert_matches_reference_msaa(&name, W, &reference, &def, DEFERRED_VS_REFERENCE);
        }
        if msaa > 1 {
            assert!(!edges.is_empty(), "{msaa}x: Tiled Deferred found no edge pixels");
        }
        check_visibility_msaa(ctx, (&sg, &full_sg), &lights, &camera, (msaa, &b, &depth), false);
    }
}

/// The visibility buffer at `msaa` samples against brute force's frame `b` at the same count
/// (see `every_sample_count_matches_brute_force_in_hdr`): its raster covers the same depth
/// samples as the pre-pass (the full scene, masked screen included); the image matches at
/// Forward+'s limits except where the two sample a pixel differently by design
/// (`msaa_by_design` with the pixels whose samples hold different IDs, shaded per sample or
/// once by the surface rule, where hardware MSAA shades each triangle once at the pixel
/// centre). With `textured_edges` those pixels are bounded by their neighbourhood instead of
/// FLIP (the scene's edges lie on high-contrast textures; see the body).
fn check_visibility_msaa(
    ctx: &GpuContext,
    (sg, full_sg): (&SceneGpu, &SceneGpu),
    lights: &LightBuffers,
    camera: &Camera,
    (msaa, b, depth): (u32, &FrameRenderer, &[f32]),
    textured_edges: bool,
) {
    use tiledlight_frame::VisibilityFrame;
    use tiledlight_tests::compare::{assert_visibility_matches, RASTER_POSITION_ERROR_PX, VISIBILITY_VS_REFERENCE};
    // The hardware raster, named: the depth samples are the pre-pass's bit for bit only
    // there (`Raster::Auto` picks the compute raster at 1x on a discrete GPU, whose depths
    // tests/tests/compute_raster.rs bounds against the hardware's).
    let raster = tiledlight_gpu::features::Raster::Hardware;
    let s = FrameSettings {
        method: Method::Visibility,
        msaa,
        knobs: Knobs { raster, ..Knobs::default() },
        ..Default::default()
    };
    let v = FrameRenderer::new(ctx, full_sg, lights, W, H, s);
    let mut v = v.unwrap_or_else(|e| panic!("the visibility buffer refused {msaa}x, which the adapter has: {e}"));
    render(ctx, &mut v, full_sg, camera);
    let bs = FrameSettings { method: Method::BruteForce { cutoff: true }, msaa, ..Default::default() };
    let mut bfull = forward(ctx, full_sg, lights, (W, H), bs);
    render(ctx, &mut bfull, full_sg, camera);
    let (bd, vd) = (bfull.read_depth(ctx).unwrap(), v.read_depth(ctx).unwrap());
    let differ = bd.iter().zip(&vd).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
    assert_eq!(differ, 0, "{msaa}x: brute force and the visibility buffer cover different depth samples");

    let mut b2 = forward(ctx, sg, lights, (W, H), bs);
    let reference = render_frame(ctx, &mut b2, sg, camera).allow_position_error(
        depth,
        W,
        (camera, &lights.packed),
        RASTER_POSITION_ERROR_PX,
    );
    let mut v = FrameRenderer::new(ctx, sg, lights, W, H, s).unwrap();
    let vis = render_frame(ctx, &mut v, sg, camera);
    let edge_list = |v: &FrameRenderer| {
        let vf = v.passes::<VisibilityFrame>().expect("visibility buffer");
        vf.shading().read_edge_list(&ctx.device, &ctx.queue).unwrap()
    };
    let edges = edge_list(&v);
    // The pixels whose samples hold different IDs: the edge list of the ID rule
    // (`surface-edges` off; tests/tests/edge_mask.rs checks both rules exactly). Hardware
    // MSAA shades each of their triangles once at the centre; the visibility buffer shades
    // them per sample or, where the surface rule finds one surface, once with sample 0's
    // triangle: both differ from the reference by design there, as Tiled Deferred's
    // non-edge pixels do.
    let by_id = FrameSettings { knobs: Knobs { surface_edges: false, ..s.knobs }, ..s };
    let mut v_ids = FrameRenderer::new(ctx, sg, lights, W, H, by_id).unwrap();
    render_frame(ctx, &mut v_ids, sg, camera);
    let id_edges = edge_list(&v_ids);
    assert!(edges.iter().all(|e| id_edges.contains(e)), "{msaa}x: a surface edge that holds one ID");
    let depths = (&b.read_depth(ctx).unwrap()[..], &v.read_depth(ctx).unwrap()[..]);
    let mask = msaa_by_design(W, depths, msaa, &id_edges);
    let vis = if textured_edges {
        bound_by_design(&format!("{msaa}x visibility"), W, (&reference, vis), &mask, VISIBILITY_VS_REFERENCE)
    } else {
        vis
    };
    let (reference, forgiven) = reference.forgive_hdr(&mask);
    eprintln!(
        "{msaa}x visibility: {forgiven} pixels compared by FLIP only ({} pixels hold two IDs, {} of them edges by \
         surface)",
        id_edges.len(),
        edges.len()
    );
    assert!(forgiven * 10 < (W * H) as usize, "{msaa}x: {forgiven} pixels forgiven: the HDR check sees too little");
    assert_visibility_matches(&format!("msaa{msaa}-visibility-vs-reference"), W, (&reference, &vis), msaa > 1);
    if msaa > 1 {
        assert!(!edges.is_empty(), "{msaa}x: the visibility buffer found no edge pixels");
    }
}

/// Sample counts: 3 is refused by name; a count the adapter lacks (lavapipe: 2x and 8x) is
/// refused by both methods with a message naming the count, the format and what the
/// adapter supports, and the skip is printed; a count it has must build in both
/// (`every_sample_count_matches_brute_force_in_hdr` renders it).
#[test]
fn unsupported_sample_counts_are_refused_clearly() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights_in_slab(&scene, 3.5, 4.0, 100, 20, 1)).unwrap();
    let e = FrameRenderer::new(
        ctx,
        &sg,
        &lights,
        W,
        H,
        FrameSettings { method: Method::TiledDeferred, msaa: 3, ..Default::default() },
    )
    .err()
    .expect("3 samples refused");
    assert!(e.to_string().contains("must be 1, 2, 4 or 8"), "{e}");
    let has = tiledlight_tests::adapter_sample_counts(ctx);
    for msaa in [2, 4, 8] {
        let f = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings { msaa, ..Default::default() });
        let d = FrameRenderer::new(
            ctx,
            &sg,
            &lights,
            W,
            H,
            FrameSettings { method: Method::TiledDeferred, msaa, ..Default::default() },
        );
        if has.contains(&msaa) {
            // The adapter has the count: a refusal is a failure, never a skip.
            if let Err(e) = f {
                panic!("Forward+ refused {msaa}x, which the adapter has: {e}");
            }
            if let Err(e) = d {
                panic!("Tiled Deferred refused {msaa}x, which the adapter has: {e}");
            }
            continue;
        }
        eprintln!("MSAA {msaa}x: checking the refusal only (the adapter lacks it)");
        for e in [f.err(), d.err()] {
            let msg = e.unwrap_or_else(|| panic!("{msaa}x built, but the adapter lacks it")).to_string();
            eprintln!("{msg}");
            assert!(msg.contains(&format!("MSAA {msaa}x is not supported by")), "{msg}");
            assert!(msg.contains("it supports: 1x"), "{msg}");
        }
    }
}

/// Issue 46's must-hold at 4x: on the many-material scene (16 materials, every map and
/// sampler, 577 instances) the visibility buffer matches brute force as on the mixed scene
/// (`check_visibility_msaa`: same depth samples, the HDR limits away from the pixels whose
/// samples hold two IDs, those bounded by their neighbourhood). The view looks down on the
/// boxes so that most pixels are textured and many lie next to a triangle edge, where a 2x2
/// quad straddles two triangles: with the raster passes' attributes at the centroid, brute
/// force's texture gradients there were differences of centroids and 2,791 pixels differed
/// by over 1% (common/scene.wgsl). The lights hang 0.4-1.0 m above the highest box, as
/// the mixed scene's do: a light's core on a surface varies within a pixel, which per-sample
/// and per-triangle shading average differently.
#[test]
fn the_many_material_scene_at_4x_matches_brute_force() {
    let ctx = gpu();
    let scene = tiledlight_scene::materials::materials_scene(16).expect("materials scene");
    let c = scene.bounds.center();
    let camera = Camera::perspective(c + Vec3::new(0.6, 2.6, 1.0), c, Vec3::Y, 1.0, W as f32 / H as f32, 0.05, None)
        .expect("camera");
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let top = scene.bounds.max.y;
    let lights =
        LightBuffers::new(&ctx.device, &scenes::lights_in_slab(&scene, top + 0.4, top + 1.0, 400, 32, 5)).unwrap();
    let bf = FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() };
    let mut one = forward(ctx, &sg, &lights, (W, H), bf);
    render(ctx, &mut one, &sg, &camera);
    let depth = one.read_depth(ctx).unwrap();
    let mut b = forward(ctx, &sg, &lights, (W, H), FrameSettings { msaa: 4, ..bf });
    render(ctx, &mut b, &sg, &camera);
    check_visibility_msaa(ctx, (&sg, &sg), &lights, &camera, (4, &b, &depth), true);

    // Tiled Deferred at 4x against the same reference, with the allowances of its 1x test
    // (`materials::the_many_material_scene_agrees_with_brute_force`): the packed normal's and
    // the whole packed surface's rounding. The surface is read from a 1x G-buffer: with every
    // attribute at the pixel centre a fully covered pixel's G-buffer texel is the 1x one,
    // and the pixels that are not are the by-design ones.
    let deferred = |msaa| FrameSettings { method: Method::TiledDeferred, msaa, ..Default::default() };
    let mut d1 = FrameRenderer::new(ctx, &sg, &lights, W, H, deferred(1)).unwrap();
    render(ctx, &mut d1, &sg, &camera);
    let gbuffer = tiledlight_tests::gbuffer::read_gbuffer(ctx, &d1, (W, H));
    let surface = tiledlight_tests::gbuffer::surface_allowance(&gbuffer, &depth, W, &camera, &lights.packed);
    let mut d4 = FrameRenderer::new(ctx, &sg, &lights, W, H, deferred(4)).unwrap();
    let def = render_frame(ctx, &mut d4, &sg, &camera);
    let mut b4 = forward(ctx, &sg, &lights, (W, H), FrameSettings { msaa: 4, ..bf });
    let reference = render_frame(ctx, &mut b4, &sg, &camera)
        .allow_gbuffer_normals(&depth, W, &camera, &lights.packed)
        .with_allowance(&surface);
    let edges = d4.passes::<DeferredFrame>().expect("Tiled Deferred").shading().read_edge_list(&ctx.device, &ctx.queue);
    let depths = (&b.read_depth(ctx).unwrap()[..], &d4.read_depth(ctx).unwrap()[..]);
    let mask = msaa_by_design(W, depths, 4, &edges.unwrap());
    let def = bound_by_design("4x deferred", W, (&reference, def), &mask, DEFERRED_VS_REFERENCE);
    let (reference, forgiven) = reference.forgive_hdr(&mask);
    assert!(forgiven * 10 < (W * H) as usize, "{forgiven} pixels forgiven: the HDR check sees too little");
    assert_matches_reference_msaa("materials-msaa4-deferred-vs-reference", W, &reference, &def, DEFERRED_VS_REFERENCE);
}
