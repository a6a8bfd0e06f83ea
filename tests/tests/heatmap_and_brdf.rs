//! The heat map shows the CPU reference's light counts, and the GPU BRDF matches its CPU
//! twin (`tiledlight_cull::brdf`) pixel by pixel.

use glam::{Vec3, Vec4};
use tiledlight_cull::brdf::{brdf_cos, spot_falloff, windowed_attenuation, Surface, LIGHT_SIZE_SQ};
use tiledlight_cull::light::spot_scale_offset;
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::{cull_tiles, Light, LightKind};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::heatmap::{heatmap_palette, heatmap_t, HEATMAP_ALPHA, HEATMAP_OVERFLOW};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_tests::images::{documented_heat_colour, linear_to_srgb, srgb_to_linear};
use tiledlight_tests::{gpu, scenes};

/// Every tile's colour in the heat map is the documented blend for the CPU reference's
/// count of that tile, within 2/255 (8-bit sRGB rounding of two images). Checked at the
/// tile's centre pixel against the same frame rendered without the heat map.
///
/// A fixed light-grid budget below the frame's pairs makes some lists lose lights (magenta);
/// which ones depends on the order tiles allocate in, so their lit pixels differ from run to
/// run on a parallel GPU (measured on the H200 with the old per-list cap: one channel 47,
/// 33, 54 in three runs) and the plain image is no fixed background for them. A tile that
/// lost lights in either frame is checked exactly at a pixel that is sky in both frames
/// (black under any light list), and elsewhere only for lying in the range the blend can
/// reach from any background; the test requires exactly-checked such tiles to exist, and
/// tiles past the workgroup capacity (red, complete) too.
#[test]
fn heatmap_shows_reference_counts() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let (w, h) = (320, 180);
    let camera = scenes::courtyard_camera(&scene, w, h);
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 2048, 0, 9)).unwrap();
    // A small workgroup list so some tiles pass it (red), and a grid budget of about a
    // quarter of the frame's ~25,000 pairs so most tiles, sky ones among them, lose lights
    // (magenta) while some keep all of theirs.
    let cull = CullOptions { capacity: 48, grid_pairs: Some(6_000), ..Default::default() };
    let mut timer = GpuTimer::new(ctx).unwrap();
    let mut plain =
        FrameRenderer::new(ctx, &scene_gpu, &lights, w, h, FrameSettings { cull, ..Default::default() }).unwrap();
    plain.render_once(ctx, &mut timer, &scene_gpu, &camera).unwrap();
    let base = plain.read_ldr(ctx).unwrap();
    let depth = plain.read_depth(ctx).unwrap();
    let mut heat =
        FrameRenderer::new(ctx, &scene_gpu, &lights, w, h, FrameSettings { cull, heatmap: true, ..Default::default() })
            .unwrap();
    heat.render_once(ctx, &mut timer, &scene_gpu, &camera).unwrap();
    let img = heat.read_ldr(ctx).unwrap();
    assert_eq!(heat.read_depth(ctx).unwrap(), depth, "the same frame: the same depth");

    let cpu = cull_tiles(&depth, w, h, &camera, &lights.packed, &cull.to_config(false)).unwrap();
    // Lists that lost lights in either frame (they are allocated in a different order).
    let truncated = |r: &FrameRenderer| {
        let l = r.read_lists(ctx).unwrap();
        l.lists.iter().zip(&l.counts).map(|(s, &c)| s.len() < c as usize).collect::<Vec<bool>>()
    };
    let (lost_plain, lost_heat) = (truncated(&plain), truncated(&heat));
    let mut past_capacity = 0;
    let g = cpu.grid;
    let linear = |px: &[u8]| Vec3::from_array(std::array::from_fn(|c| srgb_to_linear(px[c] as f32 / 255.0)));
    let (mut overflowing, mut overflow_exact, mut coloured, mut empty) = (0, 0, 0, 0);
    for ty in 0..g.tiles_y {
        for tx in 0..g.tiles_x {
            let count = cpu.lists[(ty * g.tiles_x + tx) as usize].len() as u32;
            let (x0, x1, y0, y1) = g.tile_pixels(tx, ty);
            let mut at = ((x0 + x1) / 2, (y0 + y1) / 2);
            let t = (ty * g.tiles_x + tx) as usize;
            let dropped = lost_heat[t];
            let overflow = dropped || lost_plain[t];
            past_capacity += usize::from(!overflow && count > cull.capacity);
            if overflow {
                overflowing += 1;
                let sky = (y0..y1)
                    .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                    .find(|&(x, y)| depth[(y * w + x) as usize] == 0.0);
                match sky {
                    Some(p) => {
                        at = p;
                        overflow_exact += 1;
                    }
                    None => {
                        // Any background in [0, 1]: each channel within the blend's reach.
                        let i = ((at.1 * w + at.0) * 4) as usize;
                        let (colour, alpha) = documented_heat_colour(count, cull.capacity, dropped).unwrap();
                        for c in 0..3 {
                            let lo = linear_to_srgb(colour[c] * alpha) * 255.0 - 2.0;
                            let hi = linear_to_srgb(colour[c] * alpha + 1.0 - alpha) * 255.0 + 2.0;
                            let got = img[i + c] as f32;
                            assert!(
                                (lo..=hi).contains(&got),
                                "overflowing tile ({tx}, {ty}): channel {c} is {got}, not in [{lo:.1}, {hi:.1}]"
                            );
                        }
                        continue;
                    }
                }
            }
            let i = ((at.1 * w + at.0) * 4) as usize;
            let under = linear(&base[i..i + 3]);
            let expected = match documented_heat_colour(count, cull.capacity, dropped) {
                None => {
                    empty += 1;
                    under
                }
                Some((colour, alpha)) => {
                    coloured += !overflow as usize;
                    colour * alpha + under * (1.0 - alpha)
                }
            };
            for c in 0..3 {
                let want = linear_to_srgb(expected[c]) * 255.0;
                let got = img[i + c] as f32;
                assert!(
                    (want - got).abs() <= 2.0,
                    "tile ({tx}, {ty}) count {count}: channel {c} is {got}, expected {want:.1}"
                );
            }
        }
    }
    eprintln!(
        "heat map: {coloured} coloured tiles ({past_capacity} past the workgroup list), {overflowing} that lost \
         lights ({overflow_exact} checked at a sky pixel), {empty} without lights"
    );
    assert!(
        coloured > 0 && past_capacity > 0 && overflow_exact > 0 && empty > 0,
        "the frame must show every kind of tile"
    );
}

/// The production palette (`tiledlight_gpu::tonemap`, which the CLI's legend draws) is
/// the documented one.
#[test]
fn heatmap_palette_is_the_documented_one() {
    for capacity in [8u32, 48, 2048] {
        for count in (1..=capacity).chain([capacity + 1, 10 * capacity]) {
            for dropped in [false, true] {
                let (colour, alpha) = documented_heat_colour(count, capacity, dropped).unwrap();
                let (prod, prod_alpha) = if dropped {
                    (Vec3::from(HEATMAP_OVERFLOW), HEATMAP_ALPHA.1)
                } else {
                    (Vec3::from(heatmap_palette(heatmap_t(count, capacity))), HEATMAP_ALPHA.0)
                };
                assert!(
                    (colour - prod).abs().max_element() < 1e-5 && alpha == prod_alpha,
                    "count {count} of {capacity} (dropped {dropped}): palette {prod} alpha {prod_alpha}, \
                     documented {colour} alpha {alpha}"
                );
            }
        }
    }
}

/// Brute-force pixels of a lit floor against the CPU BRDF evaluated at the pixel's
/// position (reconstructed from depth). Tolerance 3e-3 relative (floor 1e-3): the f16
/// target rounds to 2^-11 relative, and the GPU interpolates the world position while the
/// CPU unprojects it from depth (about 1e-5 relative apart). A third light hangs 4 mm
/// above the floor at the middle pixel's surface point, nearer than the emitter's 1 cm:
/// there the inverse-square falloff must stop at `1 / LIGHT_SIZE_SQ` (the shading loop
/// takes it from the direction's inverse square root, issue 49), not grow as `1 / d^2`.
#[test]
fn gpu_brdf_matches_cpu_twin() {
    let ctx = gpu();
    let (w, h) = (96, 64);
    let camera = tiledlight_tests::scenes::floor_camera(w, h);
    let ambient = Vec3::splat(0.02);
    let point = Light::point(Vec3::new(-1.0, 1.5, 0.5), Vec3::new(1.0, 0.8, 0.6), 4.0, 0.05).unwrap();
    let spot = Light::spot(
        Vec3::new(1.5, 2.0, 0.0),
        Vec3::new(-0.3, -1.0, 0.1),
        Vec3::new(0.4, 0.7, 1.0),
        6.0,
        0.3,
        0.5,
        0.05,
    )
    .unwrap();
    // The middle pixel's ray meets the floor (y = 0) at `under`.
    let ndc = ((w / 2) as f32 + 0.5) / w as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - ((h / 2) as f32 + 0.5) / h as f32 * 2.0;
    let along = (camera.view().inverse() * camera.view_point_at(ndc, ndc_y, 1.0).extend(1.0)).truncate() - camera.eye();
    let under = camera.eye() + along * (-camera.eye().y / along.y);
    let near = Light::point(under + Vec3::Y * 0.004, Vec3::ONE, 1e-3, 4e-3).unwrap();
    for (roughness, metallic) in [(0.9, 0.0), (0.3, 0.0), (0.2, 1.0)] {
        let scene = scenes::floor_scene(roughness, metallic, vec![point, spot, near]);
        let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let lights = LightBuffers::new(&ctx.device, &scene.lights).unwrap();
        let mut r = FrameRenderer::new(
            ctx,
            &scene_gpu,
            &lights,
            w,
            h,
            FrameSettings { method: Method::BruteForce { cutoff: true }, ambient, ..Default::default() },
        )
        .unwrap();
        let mut timer = GpuTimer::new(ctx).unwrap();
        r.render_once(ctx, &mut timer, &scene_gpu, &camera).unwrap();
        let hdr = r.read_hdr(ctx).unwrap();
        let depth = r.read_depth(ctx).unwrap();
        let inv_view = camera.view().inverse();
        let albedo = Vec3::new(0.8, 0.6, 0.4);
        let s = Surface { albedo, roughness, metallic };
        let mut checked = 0;
        let mut worst = 0.0f32;
        let mut clamped = 0;
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let Some(pv) = pixel_view_position(&camera, w, h, x, y, depth[i]) else { continue };
                let p = (inv_view * Vec4::from((pv, 1.0))).truncate();
                let n = Vec3::Y;
                let v = (camera.eye() - p).normalize();
                let mut want = ambient * albedo;
                for l in &scene.lights {
                    let to = l.position - p;
                    let d2 = to.length_squared();
                    if d2 >= l.radius * l.radius {
                        continue;
                    }
                    let dir = to / d2.sqrt();
                    clamped += usize::from(d2 < LIGHT_SIZE_SQ);
                    let mut att = windowed_attenuation(d2, l.radius);
                    if let LightKind::Spot { direction, inner_angle, outer_angle } = l.kind {
                        let (scale, offset) = spot_scale_offset(inner_angle, outer_angle);
                        att *= spot_falloff((-dir).dot(direction), scale, offset);
                    }
                    want += l.color * l.intensity * att * brdf_cos(n, v, dir, &s);
                }
                for c in 0..3 {
                    let err = (hdr[i][c] - want[c]).abs() / want[c].abs().max(1e-3);
                    worst = worst.max(err);
                    assert!(
                        err <= 3e-3,
                        "roughness {roughness} metallic {metallic}: pixel ({x}, {y}) channel {c}: GPU {} CPU {}",
                        hdr[i][c],
                        want[c]
                    );
                }
                checked += 1;
            }
        }
        eprintln!(
            "roughness {roughness} metallic {metallic}: {checked} pixels ({clamped} nearer a light than 1 cm), worst \
             relative error {worst:.2e}"
        );
        assert!(checked > (w * h / 3) as usize, "the floor must cover the frame");
        assert!(clamped > 0, "a pixel must lie nearer the third light than the emitter's size");
    }
}

/// `brdf_cos` and `ggx_ndf` of `shaders/common/brdf.wgsl`, run in a compute kernel, against
/// their CPU twins over random directions (the eye behind the surface in half of them) and
/// mirrored pairs whose half vector lies within 0.3 rad of `n` (the NDF's peak) or of `-n`
/// (its former singularity), at roughness from below the clamp to 1; and every GPU value
/// at or below the physical bound (`ggx_peak`, `brdf_cos_bound`): the WGSL had the
/// singularity as well as the twin, so the bound is asserted on both sides.
///
/// Tolerance 2e-4 relative plus 1e-6 of the bound: the two sides normalise `h`, take
/// square roots and the fifth power in different orders (a few ulps each), and near the
/// peak the NDF's `1/dd^2` doubles a relative error in `dd`.
#[test]
fn wgsl_brdf_equals_its_twin_and_stays_under_the_ggx_peak() {
    use tiledlight_cull::brdf::{brdf_cos_bound, ggx_ndf, ggx_peak, MIN_ROUGHNESS};
    use tiledlight_tests::kernels::{run_cases, Rng};
    let src = r#"
#include "common/brdf.wgsl"
struct Case { n: vec4<f32>, v: vec4<f32>, l: vec4<f32>, albedo: vec4<f32> }
@group(0) @binding(0) var<storage, read> cases: array<Case>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&cases)) { return; }
    let c = cases[id.x];
    let s = Surface(c.albedo.xyz, c.n.w, c.v.w);
    let rough = clamp(c.n.w, MIN_ROUGHNESS, 1.0);
    let h = normalize(c.v.xyz + c.l.xyz);
    out[id.x] = vec4<f32>(brdf_cos(c.n.xyz, c.v.xyz, c.l.xyz, s), ggx_ndf(c.n.xyz, h, rough * rough * rough * rough));
}
"#;
    let mut rng = Rng(0x5eed_b2df);
    let dir = |rng: &mut Rng| loop {
        let d = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        if let Some(d) = d.try_normalize() {
            break d;
        }
    };
    // (n, v, l, roughness, metallic, albedo)
    let mut cases: Vec<(Vec3, Vec3, Vec3, f32, f32, Vec3)> = Vec::new();
    let roughness = [0.0, MIN_ROUGHNESS, 0.1, 0.35, 0.7, 1.0];
    for i in 0..3000 {
        let n = dir(&mut rng);
        let r = roughness[i % roughness.len()];
        let metallic = [0.0, 1.0, 0.5][i % 3];
        let albedo = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0));
        if i % 2 == 0 {
            cases.push((n, dir(&mut rng), dir(&mut rng), r, metallic, albedo));
            continue;
        }
        // A mirrored pair: h within 0.3 rad of -n (every other one) or n, l above the horizon.
        let Some(side) = dir(&mut rng).cross(n).try_normalize() else { continue };
        let axis = if i % 4 == 1 { -n } else { n };
        let angle = rng.range(0.0, 0.3);
        let h = (axis * angle.cos() + side * angle.sin()).normalize();
        let lift = rng.log(1e-4, 1.0);
        let l = (side * (1.0 - lift * lift).sqrt() + n * lift).normalize();
        let v = (2.0 * l.dot(h) * h - l).normalize();
        cases.push((n, v, l, r, metallic, albedo));
    }
    let words: Vec<f32> = cases
        .iter()
        .flat_map(|&(n, v, l, r, m, a)| [n.x, n.y, n.z, r, v.x, v.y, v.z, m, l.x, l.y, l.z, 0.0, a.x, a.y, a.z, 0.0])
        .collect();
    let got = run_cases(
        gpu(),
        "test_brdf_bound.wgsl",
        src,
        bytemuck::cast_slice(&words),
        cases.len() as u32,
        cases.len() as u64 * 16,
    );
    let (mut behind, mut near_minus_n, mut lit) = (0, 0, 0);
    for (i, &(n, v, l, r, metallic, albedo)) in cases.iter().enumerate() {
        let s = Surface { albedo, roughness: r, metallic };
        let want = brdf_cos(n, v, l, &s);
        let rc = r.clamp(MIN_ROUGHNESS, 1.0);
        let a2 = rc * rc * rc * rc;
        let h = (v + l).normalize();
        let want_d = ggx_ndf(n, h, a2);
        let gpu_value = Vec3::new(got[4 * i], got[4 * i + 1], got[4 * i + 2]);
        let gpu_d = got[4 * i + 3];
        let bound = brdf_cos_bound(r);
        let at = format!("case {i}: n {n} v {v} l {l} roughness {r} metallic {metallic}");
        assert!(gpu_value.is_finite() && gpu_d.is_finite(), "{at}: GPU {gpu_value} D {gpu_d}");
        assert!(
            gpu_value.max_element() <= bound * (1.0 + 1e-5),
            "{at}: GPU brdf_cos {gpu_value} above the bound {bound}"
        );
        assert!(gpu_d <= ggx_peak(a2) * (1.0 + 1e-5), "{at}: GPU D {gpu_d} above the peak {}", ggx_peak(a2));
        let tol = 2e-4 * want.max_element() + 1e-6 * bound;
        assert!((gpu_value - want).abs().max_element() <= tol, "{at}: GPU {gpu_value} CPU {want}");
        assert!((gpu_d - want_d).abs() <= 2e-4 * want_d + 1e-6 * ggx_peak(a2), "{at}: GPU D {gpu_d} CPU {want_d}");
        behind += (n.dot(v) < 0.0 && n.dot(l) > 0.0) as u32;
        near_minus_n += (n.dot(h) < -0.95 && n.dot(l) > 0.0) as u32;
        lit += (want.max_element() > 0.0) as u32;
    }
    eprintln!(
        "{} cases: {behind} with the eye behind the surface, {near_minus_n} with h near -n, {lit} lit",
        cases.len()
    );
    assert!(behind > 500 && near_minus_n > 300 && lit > 1000, "the cases must reach the singularity's configuration");
}
