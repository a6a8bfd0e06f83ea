//! GPU images against answers computed independently on the CPU, not against another GPU
//! path or an image the project stored itself:
//!
//! - materials (texture, alpha mask, double-sided seen from both sides, a plain material):
//!   a CPU ray caster of a tiny scene, shaded with the CPU BRDF twin, against brute force,
//!   Forward+ and Tiled Deferred;
//! - the no-cutoff reference (`Method::BruteForce { cutoff: false }`, the accuracy lab's
//!   ground truth) against `tiledlight_cull::brdf::unwindowed_attenuation`, including pixels
//!   beyond the lights' radius where it must differ from the cutoff;
//! - the adapter's 4x MSAA sample positions, measured from depth samples of tilted planes,
//!   against the standard positions of the Vulkan specification.

use glam::{Mat4, Vec3, Vec4, Vec4Swizzles};
use tiledlight_cull::brdf::{brdf_cos, spot_falloff, unwindowed_attenuation, windowed_attenuation, Surface};
use tiledlight_cull::light::spot_scale_offset;
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::tiles::{pixel_to_ndc_x, pixel_to_ndc_y};
use tiledlight_cull::{Camera, Light, LightKind};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::{Aabb, AlphaMode, Instance, Material, Mesh, Scene, Texture, TextureRef};
use tiledlight_tests::compare::render_frame;
use tiledlight_tests::gpu;
use tiledlight_tests::images::{linear_to_srgb, srgb_to_linear};

const AMBIENT: Vec3 = Vec3::splat(0.02);

/// A 2 x 2 quad in the XY plane facing +Z (counter-clockwise seen from +Z, the front face),
/// uv (0, 0) at its top-left corner (-1, 1) and (1, 1) at its bottom-right.
fn quad_xy() -> Mesh {
    Mesh {
        name: "quad".into(),
        positions: vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]],
        normals: vec![[0.0, 0.0, 1.0]; 4],
        uvs: vec![[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Mesh::default()
    }
}

fn plain_material(name: &str, color: [f32; 4], roughness: f32, double_sided: bool) -> Material {
    Material {
        name: name.into(),
        base_color: color,
        roughness,
        metallic: 0.0,
        alpha_mode: AlphaMode::Opaque,
        double_sided,
        ..Material::default()
    }
}

// ---------------------------------------------------------------------------------------
// Materials against a CPU ray caster.

/// Texels a side of the test texture: 2 x 2 blocks of BLOCK x BLOCK texels, each block one
/// colour and alpha (sRGB bytes).
const TEXELS: u32 = 8;
const BLOCK: u32 = 4;
/// Blocks in row-major order (block row 0 is the top of the image, uv v = 0): an opaque
/// block, one with alpha 0 and two either side of the 0.5 cutoff (140/255 = 0.549 kept,
/// 110/255 = 0.431 discarded), so the mask's comparison is tested close to the cutoff.
const BLOCKS: [[u8; 4]; 4] = [[230, 60, 40, 255], [40, 200, 90, 0], [50, 90, 220, 140], [240, 220, 60, 110]];
const CUTOFF: f32 = 0.5;
/// Texture coordinates this far (in texels) inside a block's sample-safe region count as
/// unambiguous: bilinear filtering at texel coordinate t reads texels floor(t - 0.5) and the
/// next, so inside a block of constant texels the sample is exactly the block's colour for
/// block-local coordinates in [0.5, BLOCK - 0.5]. The margin covers the sampler's
/// sub-texel precision (Vulkan guarantees 4 bits: 1/16 texel) and the difference between
/// the CPU's ray-cast uv and the rasteriser's interpolated uv (~1e-4 texel).
const TEXEL_MARGIN: f32 = 0.15;

/// The scene: a plain single-sided backdrop, and the textured alpha-masked double-sided quad
/// twice, once facing the camera and once turned away (seen from behind).
fn material_scene(lights: Vec<Light>) -> Scene {
    let mut rgba = vec![0u8; (TEXELS * TEXELS * 4) as usize];
    for y in 0..TEXELS {
        for x in 0..TEXELS {
            let i = ((y * TEXELS + x) * 4) as usize;
            rgba[i..i + 4].copy_from_slice(&BLOCKS[((y / BLOCK) * 2 + x / BLOCK) as usize]);
        }
    }
    let mut masked = plain_material("masked", [0.9, 1.0, 0.8, 1.0], 0.5, true);
    masked.base_color_texture = Some(TextureRef::new(0));
    masked.alpha_mode = AlphaMode::Mask { cutoff: CUTOFF };
    let turn = 0.35f32;
    let instances = vec![
        Instance {
            mesh: 0,
            material: 0,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -1.5)) * Mat4::from_scale(Vec3::splat(4.0)),
        },
        Instance {
            mesh: 0,
            material: 1,
            transform: Mat4::from_translation(Vec3::new(-1.15, 0.0, 0.0))
                * Mat4::from_rotation_y(turn)
                * Mat4::from_scale(Vec3::splat(0.9)),
        },
        Instance {
            mesh: 0,
            material: 1,
            transform: Mat4::from_translation(Vec3::new(1.15, 0.0, 0.0))
                * Mat4::from_rotation_y(std::f32::consts::PI - turn)
                * Mat4::from_scale(Vec3::splat(0.9)),
        },
    ];
    let mut scene = Scene {
        name: "materials".into(),
        meshes: vec![quad_xy()],
        materials: vec![plain_material("backdrop", [0.55, 0.5, 0.45, 1.0], 0.7, false), masked],
        textures: vec![Texture { name: "blocks".into(), width: TEXELS, height: TEXELS, rgba8: rgba }],
        instances,
        lights,
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate().expect("material scene is valid");
    scene
}

/// What the pixel-centre ray sees, by the CPU.
#[derive(Clone, Copy)]
struct Hit {
    /// World position.
    p: Vec3,
    /// Unit normal facing the viewer (flipped for a double-sided surface seen from behind).
    n: Vec3,
    /// Linear albedo (texture x factor) and roughness.
    surface: Surface,
    /// The albedo's lowest and highest value a conforming GPU may decode: a texel's sRGB
    /// byte b anywhere in [b - 0.5, b + 0.5] (see `materials_match_cpu_ray_cast`).
    albedo_range: (Vec3, Vec3),
    /// Instance hit, and for the masked quads the texture block (4 + block for a block the
    /// mask discarded, the ray then going on to the backdrop).
    what: (usize, Option<usize>),
}

/// Where the ray `o + t d` crosses instance `inst`'s quad: (t, local x, local y).
fn hit_quad(inst: &Instance, o: Vec3, d: Vec3) -> Option<(f32, f32, f32)> {
    let inv = inst.transform.inverse();
    let lo = (inv * o.extend(1.0)).xyz();
    let ld = (inv * d.extend(0.0)).xyz();
    if ld.z.abs() < 1e-9 {
        return None;
    }
    let t = -lo.z / ld.z;
    let l = lo + ld * t;
    (t > 0.0 && l.x.abs() <= 1.0 && l.y.abs() <= 1.0).then_some((t, l.x, l.y))
}

/// The block of the masked texture at uv, and whether the sample is unambiguous.
fn texture_block(u: f32, v: f32) -> (usize, bool) {
    let (tu, tv) = (u * TEXELS as f32, v * TEXELS as f32);
    let safe = |t: f32| {
        let q = t - (t / BLOCK as f32).floor() * BLOCK as f32;
        (0.5 + TEXEL_MARGIN..=BLOCK as f32 - 0.5 - TEXEL_MARGIN).contains(&q)
    };
    let bx = ((tu as u32) / BLOCK).min(1);
    let by = ((tv as u32) / BLOCK).min(1);
    ((by * 2 + bx) as usize, safe(tu) && safe(tv))
}

/// Casts the ray through screen point (`sx`, `sy`) (pixels) and returns what it sees and
/// whether that is unambiguous (no texel-block border under the sample).
fn cast(scene: &Scene, camera: &Camera, w: u32, h: u32, sx: f32, sy: f32) -> (Option<Hit>, bool, Vec<usize>) {
    let inv_view = camera.view().inverse();
    let dir_view = camera.view_point_at(pixel_to_ndc_x(sx, w), pixel_to_ndc_y(sy, h), 1.0);
    let d = (inv_view * dir_view.extend(0.0)).xyz().normalize();
    let o = camera.eye();
    let mut hits: Vec<(f32, usize, f32, f32)> = scene
        .instances
        .iter()
        .enumerate()
        .filter_map(|(i, inst)| hit_quad(inst, o, d).map(|(t, x, y)| (t, i, x, y)))
        .collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    let crossed: Vec<usize> = hits.iter().map(|h| h.1).collect();
    let mut unambiguous = true;
    for (t, i, lx, ly) in hits {
        let inst = &scene.instances[i];
        let m = &scene.materials[inst.material];
        let n_geo = (inst.transform * Vec4::Z).xyz().normalize();
        let front = n_geo.dot(d) < 0.0;
        if !front && !m.double_sided {
            continue; // back face culled
        }
        let mut albedo = Vec3::from_slice(&m.base_color[..3]);
        let mut albedo_range = (albedo, albedo);
        let mut block = None;
        if m.base_color_texture.is_some() {
            let (b, safe) = texture_block((lx + 1.0) * 0.5, (1.0 - ly) * 0.5);
            unambiguous &= safe;
            let texel = BLOCKS[b];
            let alpha = texel[3] as f32 / 255.0 * m.base_color[3];
            if alpha < CUTOFF {
                continue; // discarded: the ray goes on
            }
            block = Some(b);
            let decode = |offset: f32| {
                Vec3::from_array(
                    [0, 1, 2].map(|c| srgb_to_linear((texel[c] as f32 + offset).clamp(0.0, 255.0) / 255.0)),
                )
            };
            albedo_range = (albedo * decode(-0.5), albedo * decode(0.5));
            albedo *= decode(0.0);
        }
        let hit = Hit {
            p: o + d * t,
            n: if front { n_geo } else { -n_geo },
            surface: Surface { albedo, roughness: m.roughness, metallic: m.metallic },
            albedo_range,
            what: (i, block),
        };
        return (Some(hit), unambiguous, crossed);
    }
    (None, unambiguous, crossed)
}

/// Linear HDR of `hit` lit by `lights` (windowed falloff, as every renderer with the cutoff).
fn shade(hit: &Hit, eye: Vec3, lights: &[Light]) -> Vec3 {
    let v = (eye - hit.p).normalize();
    let mut c = AMBIENT * hit.surface.albedo;
    for l in lights {
        let to = l.position - hit.p;
        let d2 = to.length_squared();
        if d2 >= l.radius * l.radius {
            continue;
        }
        c += l.color
            * l.intensity
            * windowed_attenuation(d2, l.radius)
            * brdf_cos(hit.n, v, to / d2.sqrt(), &hit.surface);
    }
    c
}

/// The range of albedos Tiled Deferred may shade with for albedos in `(lo, hi)`: its packed
/// G-buffer stores the 8-bit sRGB code (`tiledlight_cull::gbuffer`), the code below `lo` to
/// the code above `hi` (rounding either way), and decodes it through the texture unit (an
/// `Rgba8UnormSrgb` table), which may read a code as anything from code - 0.5 to code + 0.5,
/// as for the material textures.
fn gbuffer_albedo_range((lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
    let code = |c: f32, round: fn(f32) -> f32, half: f32| {
        srgb_to_linear(((round(linear_to_srgb(c) * 255.0) + half) / 255.0).clamp(0.0, 1.0))
    };
    (lo.to_array().map(|c| code(c, f32::floor, -0.5)).into(), hi.to_array().map(|c| code(c, f32::ceil, 0.5)).into())
}

/// Textured, alpha-masked, double-sided (front and back) and plain materials: brute force,
/// Forward+ and Tiled Deferred against a CPU ray cast of the pixel centres, shaded with the
/// CPU BRDF twin. Only unambiguous pixels are compared: not within a texel-block border
/// (where the bilinear sample mixes two blocks, see TEXEL_MARGIN) and not where a corner
/// ray of the pixel crosses other quads than the centre ray (a geometric edge, where the
/// rasteriser's coverage of a centre lying within float error of the edge may go either
/// way).
///
/// Colour conversions are checked as ranges, since conforming GPUs convert approximately:
/// a texel's sRGB byte b may decode to anything between the linear values of b - 0.5 and
/// b + 0.5 (llvmpipe decodes sRGB 40 0.5% low and 90 0.6% high, about a tenth of a step),
/// and Tiled Deferred's 8-bit sRGB albedo target may round to the code either side. Shading
/// with metallic 0 grows with the albedo in every channel, so the GPU value must lie between
/// the CPU values at the two ends of that range, give or take a tolerance relative to
/// max(value, floor): brute force and Forward+ 3e-3 (floor 1e-3), as heatmap_and_brdf.rs's
/// BRDF test: the f16 target rounds to 2^-11 relative, and the GPU interpolates position,
/// normal and uv where the CPU intersects the ray exactly (~1e-5 apart); measured 9.7e-4 on
/// lavapipe. Tiled Deferred 5e-3 (floor 1e-3): also the packed G-buffer normal (up to ~7e-4
/// rad off) and the position rebuilt from depth; measured 2.4e-3 on lavapipe.
///
/// Catches: texture not applied or sampled at the wrong uv (v flipped: the kept blocks swap
/// rows, and their colours differ), sRGB decode missing (sRGB 230/255 is 0.79 linear, not
/// 0.90), base colour factor not multiplied, the alpha mask ignored (the alpha-0 block would
/// hide the backdrop) or its comparison reversed (the 140 block discarded, the 110 one
/// kept), a double-sided surface seen from behind not flipping its normal (the lights are
/// on the camera's side: it would get ambient only), and back faces of a double-sided
/// material culled (the turned quad would vanish).
#[test]
fn materials_match_cpu_ray_cast() {
    let ctx = gpu();
    let (w, h) = (64u32, 48u32);
    let camera = Camera::perspective(
        Vec3::new(0.0, 0.3, 4.5),
        Vec3::ZERO,
        Vec3::Y,
        45f32.to_radians(),
        w as f32 / h as f32,
        0.1,
        None,
    )
    .unwrap();
    let lights = vec![
        Light::point(Vec3::new(-0.4, 0.9, 1.6), Vec3::new(1.0, 0.9, 0.8), 2.5, 0.02).unwrap(),
        Light::point(Vec3::new(1.3, -0.7, 1.9), Vec3::new(0.6, 0.8, 1.0), 3.0, 0.02).unwrap(),
    ];
    let scene = material_scene(lights.clone());
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();

    // The CPU image and which pixels are unambiguous.
    let mut expected = vec![None; (w * h) as usize];
    let mut kinds = std::collections::BTreeMap::<(usize, Option<usize>), usize>::new();
    for y in 0..h {
        for x in 0..w {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let (hit, unambiguous, crossed) = cast(&scene, &camera, w, h, cx, cy);
            let same_geometry = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)]
                .iter()
                .all(|(dx, dy)| cast(&scene, &camera, w, h, cx + dx, cy + dy).2 == crossed);
            let hit = hit.expect("the backdrop fills the screen");
            if unambiguous && same_geometry {
                *kinds.entry(hit.what).or_default() += 1;
                expected[(y * w + x) as usize] = Some(hit);
            }
        }
    }
    // Every case must be present: each kept block on each masked quad, and the backdrop
    // (plain, and seen through the discarded blocks, which the key does not separate).
    eprintln!("unambiguous pixels per (instance, block): {kinds:?}");
    for quad in [1, 2] {
        for block in [0, 2] {
            let n = kinds.get(&(quad, Some(block))).copied().unwrap_or(0);
            assert!(n >= 8, "instance {quad} block {block}: only {n} unambiguous pixels");
        }
    }
    assert!(kinds.get(&(0, None)).copied().unwrap_or(0) >= 100, "backdrop pixels");
    // The discarded blocks: rays through them go on to the backdrop.
    let through = (0..(w * h) as usize)
        .filter(|&i| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let (_, _, crossed) = cast(&scene, &camera, w, h, x as f32 + 0.5, y as f32 + 0.5);
            crossed.len() > 1 && expected[i].as_ref().is_some_and(|h| h.what.0 == 0)
        })
        .count();
    assert!(through >= 30, "only {through} unambiguous pixels see the backdrop through a discarded block");

    // The GPU value must lie in the range the albedo range gives (shading with metallic 0
    // grows with the albedo in every channel: diffuse and ambient scale with it, F0 is
    // 0.04), widened by `tol` relative to max(value, floor).
    let check = |name: &str, hdr: &[[f32; 4]], gbuffer: bool, tol: f32, floor: f32| {
        let mut worst = (0.0f32, 0usize);
        for (i, e) in expected.iter().enumerate() {
            let Some(hit) = e else { continue };
            let range = if gbuffer { gbuffer_albedo_range(hit.albedo_range) } else { hit.albedo_range };
            let with = |albedo: Vec3| {
                shade(&Hit { surface: Surface { albedo, ..hit.surface }, ..*hit }, camera.eye(), &lights)
            };
            let (lo, hi) = (with(range.0), with(range.1));
            for c in 0..3 {
                let outside = (lo[c] - hdr[i][c]).max(hdr[i][c] - hi[c]).max(0.0);
                let err = outside / lo[c].abs().max(floor);
                let err = if err.is_nan() { f32::INFINITY } else { err };
                if err >= worst.0 {
                    worst = (err, i);
                }
                assert!(
                    err <= tol,
                    "{name}: pixel ({}, {}) ({:?}) channel {c}: GPU {} outside the CPU's [{}, {}] by {err:.2e} relative (limit {tol})",
                    i as u32 % w,
                    i as u32 / w,
                    hit.what,
                    hdr[i][c],
                    lo[c],
                    hi[c]
                );
            }
        }
        eprintln!("{name}: worst relative excess {:.2e} at ({}, {})", worst.0, worst.1 as u32 % w, worst.1 as u32 / w);
    };
    let mut brute = FrameRenderer::new(
        ctx,
        &sg,
        &lb,
        w,
        h,
        FrameSettings { method: Method::BruteForce { cutoff: true }, ambient: AMBIENT, ..Default::default() },
    )
    .unwrap();
    check("brute force", &render_frame(ctx, &mut brute, &sg, &camera).hdr, false, 3e-3, 1e-3);
    let mut fwd =
        FrameRenderer::new(ctx, &sg, &lb, w, h, FrameSettings { ambient: AMBIENT, ..Default::default() }).unwrap();
    check("forward+", &render_frame(ctx, &mut fwd, &sg, &camera).hdr, false, 3e-3, 1e-3);
    let mut def = FrameRenderer::new(
        ctx,
        &sg,
        &lb,
        w,
        h,
        FrameSettings { method: Method::TiledDeferred, ambient: AMBIENT, ..Default::default() },
    )
    .unwrap();
    check("deferred", &render_frame(ctx, &mut def, &sg, &camera).hdr, true, 5e-3, 1e-3);
}

// ---------------------------------------------------------------------------------------
// The no-cutoff reference against unwindowed_attenuation.

/// Brute force without the cutoff (`cutoff: false`) against the CPU twin with
/// `unwindowed_attenuation` (and the spot falloff), at every floor pixel, including those
/// beyond both lights' radius (small radii: intensity threshold 0.5). Tolerance 3e-3
/// relative (floor 1e-3), as the windowed BRDF test: f16 output and interpolated vs
/// unprojected positions. Beyond both radii the cutoff image must hold ambient only (3e-3),
/// and wherever the CPU says the unwindowed lights add at least 10% to ambient, the
/// no-cutoff image must be at least 9% above the cutoff one (a large share of the frame).
///
/// Catches: the no-cutoff variant still windowing (pixels beyond the radius would be
/// ambient only), the window applied with the radius test dropped (71% of the energy inside
/// the radius), another falloff exponent or emitter size, the spot falloff skipped, and a
/// cutoff reference that leaks light past the radius.
#[test]
fn no_cutoff_matches_unwindowed_cpu_twin() {
    let ctx = gpu();
    let (w, h) = (96u32, 64u32);
    let camera = tiledlight_tests::scenes::floor_camera(w, h);
    let point = Light::point(Vec3::new(-1.0, 1.5, 0.5), Vec3::new(1.0, 0.8, 0.6), 4.0, 0.5).unwrap();
    let spot =
        Light::spot(Vec3::new(1.5, 2.0, 0.0), Vec3::new(-0.3, -1.0, 0.1), Vec3::new(0.4, 0.7, 1.0), 6.0, 0.3, 0.5, 0.5)
            .unwrap();
    let lights = vec![point, spot];
    eprintln!("radii: point {:.2} m, spot {:.2} m", point.radius, spot.radius);
    let scene = tiledlight_tests::scenes::floor_scene(0.4, 0.0, lights.clone());
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();
    let render = |cutoff: bool| {
        let mut r = FrameRenderer::new(
            ctx,
            &sg,
            &lb,
            w,
            h,
            FrameSettings { method: Method::BruteForce { cutoff }, ambient: AMBIENT, ..Default::default() },
        )
        .unwrap();
        let f = render_frame(ctx, &mut r, &sg, &camera);
        (f.hdr, r.read_depth(ctx).unwrap())
    };
    let (unwindowed, depth) = render(false);
    let (windowed, _) = render(true);
    let inv_view = camera.view().inverse();
    let s = Surface { albedo: Vec3::new(0.8, 0.6, 0.4), roughness: 0.4, metallic: 0.0 };
    let ambient = AMBIENT * s.albedo;
    let (mut checked, mut beyond, mut differ, mut worst, mut least_gain) = (0, 0, 0, 0.0f32, f32::INFINITY);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let Some(pv) = pixel_view_position(&camera, w, h, x, y, depth[i]) else { continue };
            let p = (inv_view * pv.extend(1.0)).xyz();
            let v = (camera.eye() - p).normalize();
            let mut want = ambient;
            let mut outside_all = true;
            for l in &lights {
                let to = l.position - p;
                let d2 = to.length_squared();
                outside_all &= d2 >= l.radius * l.radius;
                let dir = to / d2.sqrt();
                let mut att = unwindowed_attenuation(d2);
                if let LightKind::Spot { direction, inner_angle, outer_angle } = l.kind {
                    let (scale, offset) = spot_scale_offset(inner_angle, outer_angle);
                    att *= spot_falloff((-dir).dot(direction), scale, offset);
                }
                want += l.color * l.intensity * att * brdf_cos(Vec3::Y, v, dir, &s);
            }
            for c in 0..3 {
                let err = (unwindowed[i][c] - want[c]).abs() / want[c].abs().max(1e-3);
                worst = worst.max(err);
                assert!(err <= 3e-3, "pixel ({x}, {y}) channel {c}: GPU {} CPU {}", unwindowed[i][c], want[c]);
            }
            checked += 1;
            if outside_all {
                beyond += 1;
                for c in 0..3 {
                    let err = (windowed[i][c] - ambient[c]).abs() / ambient[c];
                    assert!(
                        err <= 3e-3,
                        "pixel ({x}, {y}) beyond the radii: cutoff image {} is not ambient {}",
                        windowed[i][c],
                        ambient[c]
                    );
                }
                // Where the CPU says the unwindowed lights add at least 10% to ambient, the
                // two references must differ by that much (elsewhere a spot's cone or a
                // grazing angle leaves too little light to tell them apart).
                let added = want.element_sum() / ambient.element_sum();
                let gain = (unwindowed[i][0] + unwindowed[i][1] + unwindowed[i][2]) / ambient.element_sum();
                if added >= 1.1 {
                    differ += 1;
                    least_gain = least_gain.min(gain);
                    assert!(
                        gain >= 1.09,
                        "pixel ({x}, {y}) beyond the radii: no-cutoff {:?} too close to the cutoff's ambient",
                        unwindowed[i]
                    );
                }
            }
        }
    }
    eprintln!(
        "{checked} floor pixels, worst relative error {worst:.2e}; {beyond} beyond both radii, {differ} of them \
         lit >= 10% above ambient, where no-cutoff / cutoff >= {least_gain:.3}"
    );
    assert!(checked > (w * h / 3) as usize, "the floor must cover the frame");
    assert!(beyond > (w * h / 10) as usize, "only {beyond} pixels beyond both radii");
    assert!(differ > (w * h / 20) as usize, "only {differ} pixels beyond both radii visibly lit without the cutoff");
}

// ---------------------------------------------------------------------------------------
// The adapter's 4x sample positions.

/// The standard sample locations for 4 samples, from the Vulkan specification ("Standard
/// sample locations", VK_SAMPLE_COUNT_4_BIT), in pixel units from the pixel's top-left
/// corner; D3D and Metal use the same pattern. WebGPU requires them for 4x.
const VULKAN_4X: [(f64, f64); 4] = [(0.375, 0.125), (0.875, 0.375), (0.125, 0.625), (0.625, 0.875)];

/// A quad tilted so that z = a x + b y, spanning x, y in [-1.5, 1.5] (beyond the screen).
fn tilted_plane(a: f32, b: f32) -> Scene {
    let c = [(-1.5f32, -1.5f32), (1.5, -1.5), (1.5, 1.5), (-1.5, 1.5)];
    let mesh = Mesh {
        name: "tilted".into(),
        positions: c.iter().map(|&(x, y)| [x, y, a * x + b * y]).collect(),
        normals: vec![Vec3::new(-a, -b, 1.0).normalize().to_array(); 4],
        uvs: vec![[0.0, 0.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Mesh::default()
    };
    Scene {
        name: "tilted".into(),
        meshes: vec![mesh],
        materials: vec![plain_material("plane", [0.5, 0.5, 0.5, 1.0], 0.5, true)],
        textures: vec![],
        instances: vec![Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }],
        lights: vec![],
        camera: None,
        bounds: Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0)),
    }
}

/// Measures the adapter's 4x sample positions and checks them against the Vulkan standard
/// locations, so tests that quote that table (msaa.rs's depth-only edge detector, the
/// deferred shader's `sample_position`) rest on a measured fact.
///
/// An orthographic camera looks down -Z at planes z = a x + b y; its reversed-Z depth is
/// then affine in screen position, `depth = 0.5 + (a x + b y) / 10` for world x = (px - 32)
/// / 32, y = (32 - py) / 32 on a 64 x 64 screen (the view volume is x, y in [-1, 1],
/// distances 5 to 15 from the eye at z = 10). The quad's corners project to whole pixels
/// (-16 and 80), so the rasteriser's vertex snapping changes nothing. For each sample,
/// depth minus the plane's depth at the pixel's corner is `B ox + C oy`; two planes with
/// independent slopes give (ox, oy) per pixel and sample.
///
/// Tolerance 1/64 pixel: a sixteenth of the 1/4-pixel spacing of the standard positions,
/// and far above the ~1e-4 px that f32 depth (6e-8 at 0.5, over a slope of 1.6e-3 per
/// pixel) resolves. Catches a different pattern (another vendor's or a custom one), samples
/// in another order, and y measured upwards.
#[test]
fn msaa_4x_sample_positions_are_vulkan_standard() {
    let ctx = gpu();
    let (w, h) = (64u32, 64u32);
    let camera = Camera::orthographic(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y, 1.0, 1.0, 5.0, 15.0).unwrap();
    let light = Light::point(Vec3::new(0.0, 0.0, 3.0), Vec3::ONE, 1.0, 0.1).unwrap();
    let lb = LightBuffers::new(&ctx.device, &[light]).unwrap();
    // depth(px, py) = A + B px + C py for each plane.
    let planes = [(0.5f32, 0.2f32), (-0.2, 0.5)];
    let mut residuals = Vec::new();
    for &(a, b) in &planes {
        let scene = tilted_plane(a, b);
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let mut r = FrameRenderer::new(
            ctx,
            &sg,
            &lb,
            w,
            h,
            FrameSettings { method: Method::BruteForce { cutoff: true }, msaa: 4, ..Default::default() },
        )
        .unwrap();
        render_frame(ctx, &mut r, &sg, &camera);
        let depth = r.read_depth(ctx).unwrap();
        assert_eq!(depth.len(), (w * h * 4) as usize, "4 depth samples a pixel");
        let (a, b) = (a as f64, b as f64);
        let plane = |px: f64, py: f64| 0.5 + (a * (px - 32.0) / 32.0 + b * (32.0 - py) / 32.0) / 10.0;
        residuals.push(
            (0..(w * h) as usize)
                .map(|i| {
                    let (px, py) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
                    let corner = plane(px, py);
                    [0, 1, 2, 3].map(|s| depth[i * 4 + s] as f64 - corner)
                })
                .collect::<Vec<_>>(),
        );
    }
    // Per plane, B = a / 320 and C = -b / 320 (depth per pixel along x and y).
    let (b1, c1) = (planes[0].0 as f64 / 320.0, -planes[0].1 as f64 / 320.0);
    let (b2, c2) = (planes[1].0 as f64 / 320.0, -planes[1].1 as f64 / 320.0);
    let det = b1 * c2 - b2 * c1;
    let mut worst = [0.0f64; 4];
    let mut mean = [(0.0f64, 0.0f64); 4];
    for (r1, r2) in residuals[0].iter().zip(&residuals[1]) {
        for s in 0..4 {
            let ox = (r1[s] * c2 - r2[s] * c1) / det;
            let oy = (b1 * r2[s] - b2 * r1[s]) / det;
            mean[s].0 += ox / (w * h) as f64;
            mean[s].1 += oy / (w * h) as f64;
            let err = (ox - VULKAN_4X[s].0).abs().max((oy - VULKAN_4X[s].1).abs());
            worst[s] = worst[s].max(err);
        }
    }
    for s in 0..4 {
        eprintln!(
            "sample {s}: measured ({:.5}, {:.5}), standard {:?}, worst pixel off by {:.2e} px",
            mean[s].0, mean[s].1, VULKAN_4X[s], worst[s]
        );
        assert!(
            worst[s] <= 1.0 / 64.0,
            "sample {s}: measured mean ({:.4}, {:.4}) vs the standard {:?}; worst pixel {:.4} px off",
            mean[s].0,
            mean[s].1,
            VULKAN_4X[s],
            worst[s]
        );
    }
}
