//! Materials on transformed, mipmapped and wrapped geometry (issue 43, classes 1-3): the
//! cases where a shader that forgets a transform, a sign, a gradient or a wrap mode still
//! passed every other test, because every other scene had identity model matrices,
//! textures without mipmaps and masks clamped inside [0, 1].
//!
//! - *Transforms*: normal-mapped quads that are rotated, non-uniformly scaled and mirrored
//!   (negative determinant), lit so the map moves the lighting. Brute force is checked
//!   against an independent CPU evaluation (a CPU ray cast of the pixel centres, the map's
//!   texel decoded on the CPU, the instance transform applied to tangent, bitangent and
//!   normal as the glTF specification defines them: `tiledlight_tests::textured`), then
//!   Forward+, Tiled Deferred, the visibility buffer (both rasters) and the traced
//!   reference against brute force; the RSM of a transformed normal-mapped wall is checked
//!   texel by texel against the same CPU frame, and its VPLs against the CPU twin
//!   (`tiledlight_cull::vpl`). A failure means a surface-reconstruction path carries a
//!   tangent, bitangent sign or normal through the model matrix otherwise than the glTF
//!   convention (which image and pixel say where).
//! - *Mipmaps*: minified, mipmapped textures on both texture coordinate sets, each with a
//!   `KHR_texture_transform` (scale and rotation), on a floor seen at a grazing angle; the
//!   visibility buffer's explicit gradients (`textureSampleGrad`) and the traced reference
//!   against the hardware's implicit ones (brute force), and brute force against a twin
//!   scene whose vertex coordinates carry the transform (no transform for the shader to
//!   apply to the gradients). A failure means some path picks another mip level.
//! - *Wrap modes*: alpha masks read with every wrap mode on each axis (u's mode != v's)
//!   at coordinates outside [0, 1], in the raster paths, the shadow atlas and the traced
//!   reference's mask lookups, against the CPU's own wrap of the mask
//!   (`tiledlight_tests::scenes::alpha_blocks`). A failure means a path wraps an axis the
//!   wrong way.

use glam::{Mat4, Vec2, Vec3, Vec4};
use tiledlight_cull::brdf::{brdf_cos, windowed_attenuation, Surface};
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::{Aabb, Filter, Instance, Material, Sampler, Scene, Texture, TextureRef, Wrap};
use tiledlight_tests::compare::{
    assert_matches_reference_frame, assert_matches_with_outliers, assert_visibility_matches, render_frame,
    visibility_frames, visibility_outliers, Frame, Outliers, DEFERRED_VS_REFERENCE, FORWARD_VS_REFERENCE,
    RASTER_POSITION_ERROR_PX, VISIBILITY_VS_REFERENCE,
};
use tiledlight_tests::gpu;
use tiledlight_tests::textured::{
    cast_quads, mapped_normal, mapped_quad, pixel_ray, quad_uv, tangent_frame, QUAD_TANGENT,
};

// ---------------------------------------------------------------------------------------
// Class 1: rotated, non-uniformly scaled and mirrored normal-mapped instances.

const TW: u32 = 128;
const TH: u32 = 80;
const AMBIENT: Vec3 = Vec3::splat(0.02);

/// Texels a side of the normal map: 2 x 2 blocks of 2 x 2 texels.
const MAP: u32 = 4;

/// The tangent-space normal of each 2 x 2 block (row-major, row 0 at the top of the image):
/// leaning along +x, +y (the bitangent), -y and (-x, +y), 0.6 each, so a tangent, a
/// bitangent or a sign gone wrong turns the lighting of some block.
const LEANS: [[f32; 2]; 4] = [[0.6, 0.0], [0.0, 0.6], [0.0, -0.6], [-0.45, 0.45]];

/// The map's RGBA8 texels (linear: glTF's normal maps are data) and the value the GPU
/// decodes each to (byte / 255).
fn normal_map() -> Vec<u8> {
    let mut rgba = Vec::new();
    for y in 0..MAP {
        for x in 0..MAP {
            let [lx, ly] = LEANS[((y / 2) * 2 + x / 2) as usize];
            let n = Vec3::new(lx, ly, (1.0 - lx * lx - ly * ly).sqrt());
            let byte = |v: f32| ((v * 0.5 + 0.5) * 255.0).round() as u8;
            rgba.extend([byte(n.x), byte(n.y), byte(n.z), 255]);
        }
    }
    rgba
}

fn nearest_no_mips(wrap_u: Wrap, wrap_v: Wrap) -> Sampler {
    Sampler { wrap_u, wrap_v, mag: Filter::Nearest, min: Filter::Nearest, mipmap: None }
}

/// The three normal-mapped instances: rotated about three axes; rotated then scaled
/// (1.7, 1, 0.55) (non-uniform: the inverse transpose tilts the normal ~35 degrees away
/// from where the model matrix would put it); mirrored in x (and rotated), drawing the
/// mirrored copy of the mesh as the glTF loader makes it.
fn transforms() -> [Mat4; 3] {
    [
        // 0.2 m in front of the second and 0.15 m further left (the third stands in front
        // too, below): at (-1.5, 0.35, 0) the second quad's shadow from the second light
        // falls on this one's right edge, and the traced comparison needs none.
        Mat4::from_translation(Vec3::new(-1.65, 0.35, 0.2))
            * Mat4::from_rotation_y(0.45)
            * Mat4::from_rotation_x(-0.35)
            * Mat4::from_rotation_z(0.6)
            * Mat4::from_scale(Vec3::splat(0.6)),
        Mat4::from_translation(Vec3::new(0.0, -0.15, 0.0))
            * Mat4::from_scale(Vec3::new(1.7, 1.0, 0.55))
            * Mat4::from_rotation_y(-0.55)
            * Mat4::from_rotation_x(0.3)
            * Mat4::from_scale(Vec3::splat(0.5)),
        // 0.35 m in front of the second: at z = 0, the second quad's shadow from the first
        // light falls on this one's left edge (the traced reference draws it, brute force
        // does not).
        Mat4::from_translation(Vec3::new(1.5, 0.3, 0.35))
            * Mat4::from_rotation_y(-0.4)
            * Mat4::from_rotation_x(0.3)
            * Mat4::from_scale(Vec3::new(-0.6, 0.6, 0.6)),
    ]
}

fn mapped_material() -> Material {
    Material {
        name: "mapped".into(),
        base_color: [0.8, 0.75, 0.7, 1.0],
        roughness: 0.45,
        metallic: 0.0,
        normal_texture: Some(TextureRef {
            sampler: nearest_no_mips(Wrap::ClampToEdge, Wrap::ClampToEdge),
            ..TextureRef::new(0)
        }),
        normal_scale: 1.0,
        ..Material::default()
    }
}

fn transformed_scene() -> Scene {
    let [a, b, c] = transforms();
    let mut scene = Scene {
        name: "transformed normal maps".into(),
        meshes: vec![mapped_quad(false), mapped_quad(true)],
        materials: vec![mapped_material()],
        textures: vec![Texture { name: "leans".into(), width: MAP, height: MAP, rgba8: normal_map() }],
        instances: vec![
            Instance { mesh: 0, material: 0, transform: a },
            Instance { mesh: 0, material: 0, transform: b },
            Instance { mesh: 1, material: 0, transform: c },
        ],
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    assert!(c.determinant() < 0.0 && a.determinant() > 0.0 && b.determinant() > 0.0);
    scene.bounds = scene.compute_bounds();
    scene.validate().expect("transformed scene is valid");
    scene
}

fn transformed_lights() -> Vec<Light> {
    vec![
        Light::point(Vec3::new(-0.8, 1.3, 1.6), Vec3::new(1.0, 0.9, 0.8), 3.0, 0.01).unwrap(),
        Light::point(Vec3::new(1.6, -1.0, 1.4), Vec3::new(0.7, 0.8, 1.0), 3.0, 0.01).unwrap(),
    ]
}

fn transformed_camera() -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 0.0, 4.2),
        Vec3::ZERO,
        Vec3::Y,
        45f32.to_radians(),
        TW as f32 / TH as f32,
        0.1,
        None,
    )
    .unwrap()
}

/// A way of building the world tangent frame from a model matrix: the glTF convention
/// ([`tangent_frame`]) or one of the realistic bugs the GPU must not have (each used only
/// to prove that the scene and the comparison see it).
#[derive(Clone, Copy, Debug, PartialEq)]
enum FrameRule {
    Gltf,
    /// The bitangent is `cross(n, t) * w`, the determinant's sign ignored.
    NoMirrorFlip,
    /// The normal through the model matrix, not its inverse transpose.
    NormalByModel,
    /// The tangent left in object space.
    TangentInObjectSpace,
}

fn frame_by(rule: FrameRule, m: Mat4) -> (Vec3, Vec3, Vec3) {
    let (t, b, n) = tangent_frame(m, Vec3::Z, QUAD_TANGENT);
    let ortho = |n: Vec3, t: Vec3, sign: f32| {
        let t = (t - n * n.dot(t)).normalize();
        (t, n.cross(t) * sign, n)
    };
    match rule {
        FrameRule::Gltf => (t, b, n),
        FrameRule::NoMirrorFlip => ortho(n, t, QUAD_TANGENT.w),
        FrameRule::NormalByModel => {
            let nm = m.transform_vector3(Vec3::Z).normalize();
            ortho(nm, t, if m.determinant() < 0.0 { -1.0 } else { 1.0 })
        }
        FrameRule::TangentInObjectSpace => ortho(n, Vec3::X, if m.determinant() < 0.0 { -1.0 } else { 1.0 }),
    }
}

/// The CPU's expected linear HDR per pixel (None where not compared) of the transformed
/// scene, with the frame built by `rule`. A pixel is compared where its centre ray and its
/// four corner rays hit the same instance (no geometric edge under it) and its texture
/// coordinates lie over 3% of a texel from a texel edge (the map is sampled nearest; the
/// rasteriser's interpolated coordinates and the ray cast's differ by ~1e-4 texel).
fn transformed_expectation(scene: &Scene, lights: &[Light], camera: &Camera, rule: FrameRule) -> Vec<Option<Vec3>> {
    let map = &scene.textures[0];
    let m = &scene.materials[0];
    let surface =
        Surface { albedo: Vec3::from_slice(&m.base_color[..3]), roughness: m.roughness, metallic: m.metallic };
    let eye = camera.eye();
    let mut out = vec![None; (TW * TH) as usize];
    for y in 0..TH {
        for x in 0..TW {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let Some(hit) = cast_quads(&scene.instances, eye, pixel_ray(camera, (TW, TH), cx, cy)) else { continue };
            let same = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)].iter().all(|(dx, dy)| {
                cast_quads(&scene.instances, eye, pixel_ray(camera, (TW, TH), cx + dx, cy + dy))
                    .is_some_and(|h| h.instance == hit.instance)
            });
            let uv = quad_uv(hit.local) * MAP as f32;
            let inside = |c: f32| (0.03..=0.97).contains(&(c - c.floor()));
            if !same || !inside(uv.x) || !inside(uv.y) {
                continue;
            }
            let (tx, ty) = ((uv.x as u32).min(MAP - 1), (uv.y as u32).min(MAP - 1));
            let i = ((ty * MAP + tx) * 4) as usize;
            let texel = Vec3::from_array([0, 1, 2].map(|k| f32::from(map.rgba8[i + k]) / 255.0));
            let transform = scene.instances[hit.instance].transform;
            let n = mapped_normal(frame_by(rule, transform), texel);
            let p = eye + pixel_ray(camera, (TW, TH), cx, cy) * hit.t;
            let v = (eye - p).normalize();
            let mut c = AMBIENT * surface.albedo;
            for l in lights {
                let to = l.position - p;
                let d2 = to.length_squared();
                if d2 < l.radius * l.radius {
                    c += l.color
                        * l.intensity
                        * windowed_attenuation(d2, l.radius)
                        * brdf_cos(n, v, to / d2.sqrt(), &surface);
                }
            }
            out[(y * TW + x) as usize] = Some(c);
        }
    }
    out
}

/// Brute force against a CPU expectation: the compared pixels whose channels differ by
/// more than 3e-3 relative (floor 1e-3), and the worst such error. The limit is
/// `materials.rs`'s and `independent.rs`'s: the f16 HDR target rounds to 2^-11 relative,
/// and the GPU interpolates position and normal where the CPU intersects the ray exactly
/// (~1e-5 apart); the map is read nearest, so both read the same texel.
fn cpu_mismatches(hdr: &[[f32; 4]], expected: &[Option<Vec3>]) -> (Vec<usize>, f32) {
    let mut bad = Vec::new();
    let mut worst = 0.0f32;
    for (i, e) in expected.iter().enumerate() {
        let Some(e) = e else { continue };
        let err = (0..3).map(|c| (hdr[i][c] - e[c]).abs() / e[c].abs().max(1e-3)).fold(0.0, f32::max);
        let err = if err.is_nan() { f32::INFINITY } else { err };
        worst = worst.max(err);
        if err > 3e-3 {
            bad.push(i);
        }
    }
    (bad, worst)
}

/// The first quad of `instances` other than `own` (either face: shadow rays see both)
/// that crosses the segment from `p` to `light`.
fn quad_between(instances: &[Instance], own: usize, p: Vec3, light: Vec3) -> Option<usize> {
    instances.iter().enumerate().position(|(k, inst)| {
        let inv = inst.transform.inverse();
        let (a, b) = (inv.transform_point3(p), inv.transform_point3(light));
        if k == own || (a.z > 0.0) == (b.z > 0.0) {
            return false;
        }
        let x = a + (b - a) * (a.z / (a.z - b.z));
        x.x.abs() <= 1.0 && x.y.abs() <= 1.0
    })
}

/// Rotated, non-uniformly scaled and mirrored normal-mapped quads: brute force equals the
/// independent CPU evaluation (glTF's tangent frame), and the same comparison rejects the
/// GPU image against each wrong frame (mirror sign ignored, normal by the model matrix,
/// tangent left in object space) on many pixels, which proves the scene exercises each
/// (the comparison's negative test). Then Forward+, Tiled Deferred, the visibility buffer
/// (hardware and compute rasters) and the traced reference against brute force under the
/// suite's tolerances (`tiledlight_tests::compare`, reasons stated there).
#[test]
fn normal_maps_on_rotated_scaled_and_mirrored_instances_match_the_cpu_in_every_method() {
    let ctx = gpu();
    let scene = transformed_scene();
    let lights = transformed_lights();
    let camera = transformed_camera();
    let mut sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    sg.add_trace(&ctx.device, &scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();
    let fs = |method| FrameSettings { method, ambient: AMBIENT, ..Default::default() };
    let mut bf = FrameRenderer::new(ctx, &sg, &lb, TW, TH, fs(Method::BruteForce { cutoff: true })).unwrap();
    let brute = render_frame(ctx, &mut bf, &sg, &camera);
    let depth = bf.read_depth(ctx).unwrap();

    let expected = transformed_expectation(&scene, &lights, &camera, FrameRule::Gltf);
    let compared = expected.iter().filter(|e| e.is_some()).count();
    // Every instance and every block of the map on it is compared.
    let mut seen = std::collections::BTreeSet::new();
    for y in 0..TH {
        for x in 0..TW {
            if expected[(y * TW + x) as usize].is_none() {
                continue;
            }
            let d = pixel_ray(&camera, (TW, TH), x as f32 + 0.5, y as f32 + 0.5);
            let hit = cast_quads(&scene.instances, camera.eye(), d).unwrap();
            let uv = quad_uv(hit.local);
            seen.insert((hit.instance, (uv.x >= 0.5) as u32 + 2 * (uv.y >= 0.5) as u32));
        }
    }
    assert_eq!(seen.len(), 12, "every block of the map on every instance is compared: {seen:?}");
    let (bad, worst) = cpu_mismatches(&brute.hdr, &expected);
    eprintln!("brute force vs CPU: {compared} pixels, worst relative error {worst:.2e}");
    assert!(
        bad.is_empty(),
        "brute force differs from the CPU at {} pixels, e.g. ({}, {})",
        bad.len(),
        bad[0] % TW as usize,
        bad[0] / TW as usize
    );
    // The normal map moves the lighting, and each wrong frame is seen.
    let flat = {
        let mut s = scene.clone();
        s.materials[0].normal_texture = None;
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &s).unwrap();
        let mut r = FrameRenderer::new(ctx, &sg, &lb, TW, TH, fs(Method::BruteForce { cutoff: true })).unwrap();
        render_frame(ctx, &mut r, &sg, &camera)
    };
    let moved = cpu_mismatches(&flat.hdr, &expected).0.len();
    eprintln!("the flat surface differs from the mapped one at {moved} of {compared} pixels");
    assert!(moved * 2 > compared, "the normal map must move the lighting of most pixels ({moved} of {compared})");
    for rule in [FrameRule::NoMirrorFlip, FrameRule::NormalByModel, FrameRule::TangentInObjectSpace] {
        let wrong = transformed_expectation(&scene, &lights, &camera, rule);
        let (rejected, _) = cpu_mismatches(&brute.hdr, &wrong);
        eprintln!("{rule:?}: rejected at {} pixels", rejected.len());
        assert!(rejected.len() >= 40, "{rule:?} must be rejected on many pixels, got {}", rejected.len());
    }

    let mut fwd = FrameRenderer::new(ctx, &sg, &lb, TW, TH, fs(Method::ForwardPlus)).unwrap();
    let forward = render_frame(ctx, &mut fwd, &sg, &camera);
    assert_matches_reference_frame("transformed-forward", TW, &brute, &forward, FORWARD_VS_REFERENCE);
    let mut dr = FrameRenderer::new(ctx, &sg, &lb, TW, TH, fs(Method::TiledDeferred)).unwrap();
    let deferred = render_frame(ctx, &mut dr, &sg, &camera);
    let reference = brute.clone().allow_gbuffer_normals(&depth, TW, &camera, &lb.packed);
    assert_matches_reference_frame("transformed-deferred", TW, &reference, &deferred, DEFERRED_VS_REFERENCE);
    let shifted = brute.clone().allow_position_error(&depth, TW, (&camera, &lb.packed), RASTER_POSITION_ERROR_PX);
    for (raster, visibility, ties) in visibility_frames(ctx, (&sg, &lb, &camera), (TW, TH), fs(Method::Visibility)) {
        let reference = shifted.clone().forgive_hdr(&ties).0;
        assert_visibility_matches(
            &format!("transformed-visibility-{}", raster.name()),
            TW,
            (&reference, &visibility),
            false,
        );
    }
    // The traced reference has no cutoff: against brute force without it. Nothing
    // shadows here (asserted: no quad stands between a compared pixel's point and a
    // light), so only the surface differs.
    let occluded: Vec<(u32, usize, usize, usize)> = (0..TH * TW)
        .filter(|&p| expected[p as usize].is_some())
        .flat_map(|p| {
            let d = pixel_ray(&camera, (TW, TH), (p % TW) as f32 + 0.5, (p / TW) as f32 + 0.5);
            let hit = cast_quads(&scene.instances, camera.eye(), d).unwrap();
            let point = camera.eye() + d * hit.t;
            let instances = &scene.instances;
            lights.iter().enumerate().filter_map(move |(i, l)| {
                quad_between(instances, hit.instance, point, l.position).map(|k| (p, hit.instance, i, k))
            })
        })
        .collect();
    assert!(
        occluded.is_empty(),
        "the traced comparison needs a scene without shadows: (pixel, instance, light, occluder) {:?}",
        &occluded[..occluded.len().min(8)]
    );
    let mut nb = FrameRenderer::new(ctx, &sg, &lb, TW, TH, fs(Method::BruteForce { cutoff: false })).unwrap();
    let uncut = render_frame(ctx, &mut nb, &sg, &camera);
    let uncut =
        uncut.allow_position_error(&nb.read_depth(ctx).unwrap(), TW, (&camera, &lb.packed), RASTER_POSITION_ERROR_PX);
    let mut tr = FrameRenderer::new(ctx, &sg, &lb, TW, TH, fs(Method::TRUTH)).unwrap();
    let traced: Frame = render_frame(ctx, &mut tr, &sg, &camera);
    assert_visibility_matches("transformed-traced", TW, (&uncut, &traced), false);
    let _ = Vec2::ZERO;
    let _ = Vec4::ZERO;
}

// ---------------------------------------------------------------------------------------
// Class 1 in the RSM: a transformed normal-mapped wall seen by a spot caster.

/// The wall: the mirrored quad mesh under a mirroring, non-uniformly scaling and rotating
/// matrix (determinant < 0), 2.4 x 1.7 m, facing the spot at +z.
fn rsm_wall() -> Mat4 {
    Mat4::from_rotation_x(0.25) * Mat4::from_scale(Vec3::new(-1.2, 0.85, 0.6)) * Mat4::from_rotation_y(0.35)
}

fn rsm_spot() -> Light {
    let pos = Vec3::new(0.4, 0.6, 4.0);
    // The wall lies well inside the inner cone (about 20 degrees off the axis at most), so
    // no VPL sits at the rim where its tint is within float error of zero.
    Light::spot(pos, -pos, Vec3::ONE, 40.0, 35f32.to_radians(), 45f32.to_radians(), 0.01).expect("spot")
}

/// The RSM of a transformed normal-mapped wall (mirrored, non-uniformly scaled, rotated)
/// holds, at every texel on the wall, the normal the CPU's glTF frame gives for the map's
/// texel there: each component within 1e-3 (the normal target is `Rgba16Float`, which
/// rounds a unit vector's components to 2^-11 = 4.9e-4; the position the CPU reads the map
/// at is rebuilt from the RSM's f32 depth, ~1e-5 m; texels within 3% of a map texel's edge
/// are skipped). The RSM's fragment stage shares the raster passes' vertex transform, so
/// this is the RSM's own check of it. Then the GPU's VPLs from that RSM equal the CPU
/// twin's (`tiledlight_cull::vpl::generate` over the same faces; no thresholds), compared
/// as sets under `vpl.rs`'s tolerances (position 1e-4 m, normal 1e-4, flux 1e-4 relative
/// plus 1e-6 of the largest).
#[test]
fn the_rsm_of_a_transformed_normal_mapped_wall_holds_the_cpu_normals_and_its_vpls_the_twins() {
    use tiledlight_cull::shadow::{AtlasLayout, ShadowOptions};
    use tiledlight_cull::vpl::{self, VplConfig};
    use tiledlight_gpu::culling::CullOptions;
    use tiledlight_gpu::features::Features;
    use tiledlight_gpu::shadow_atlas::ShadowAtlas;
    use tiledlight_gpu::timer::GpuTimer;
    use tiledlight_gpu::view::Views;
    use tiledlight_vpl::VplPath;

    let ctx = gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let wall = rsm_wall();
    assert!(wall.determinant() < 0.0, "the wall mirrors");
    let mut scene = transformed_scene();
    scene.instances = vec![Instance { mesh: 1, material: 0, transform: wall }];
    scene.bounds = scene.compute_bounds();
    let light = rsm_spot();
    let sg = SceneGpu::new(device, queue, &scene).expect("scene");
    let lights = LightBuffers::with_casters(device, &[light], (0, 1)).expect("lights");
    let shadow = ShadowOptions::default();
    let features = Features::new(
        &sg,
        &lights,
        tiledlight_frame::Method::ForwardPlus.traits(),
        &CullOptions::default(),
        (1, Default::default()),
        (shadow, false),
    );
    let limits = device.limits();
    let layout =
        AtlasLayout::new(shadow.tile_size, 0, 1, limits.max_texture_dimension_2d, limits.max_texture_array_layers)
            .expect("layout");
    let views = Views::new(device, 1 + layout.faces());
    let atlas = ShadowAtlas::new(device, &views, &sg, &features, layout, shadow, 1).expect("atlas");
    atlas.update(queue, &views, &lights.packed).expect("atlas update");
    // 128 texels a side (the default 32 puts only ~50 on the wall, 4 m from the light in a
    // 90-degree face): hundreds of wall texels over every 2x2 block of the map.
    let cfg = VplConfig { rsm_size: 128, colour_threshold: 0.0, brightness_threshold: 0.0, ..VplConfig::default() };
    let path = VplPath::new(device, queue, &sg, &atlas, &lights.packed, &cfg).expect("vpl path");
    let mut timer = GpuTimer::new(ctx).expect("timer");
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("test.rsm") });
    atlas.record(&mut encoder, &timer, &views, &sg);
    assert!(path.record(&mut encoder, &timer, &sg), "a fresh path draws its RSM");
    timer.resolve(&mut encoder);
    queue.submit([encoder.finish()]);
    timer.end_frame().expect("timer");
    let faces = path.rsm.read_faces(device, queue, &atlas, &lights.packed).expect("rsm readback");
    assert_eq!(faces.len(), 1);

    // Every wall texel's normal against the CPU's.
    let map = &scene.textures[0];
    let inv = wall.inverse();
    let frame = tangent_frame(wall, Vec3::Z, QUAD_TANGENT);
    let (mut checked, mut worst, mut blocks) = (0, 0.0f32, std::collections::BTreeSet::new());
    for t in faces[0].texels.iter().flatten() {
        let local = inv.transform_point3(t.position);
        assert!(
            local.z.abs() < 1e-3 && local.x.abs() <= 1.001 && local.y.abs() <= 1.001,
            "a texel off the wall: {t:?}"
        );
        let uv = quad_uv(local.truncate()) * MAP as f32;
        let inside = |c: f32| (0.03..=0.97).contains(&(c - c.floor()));
        if !inside(uv.x) || !inside(uv.y) {
            continue;
        }
        let (tx, ty) = ((uv.x as u32).min(MAP - 1), (uv.y as u32).min(MAP - 1));
        let i = ((ty * MAP + tx) * 4) as usize;
        let texel = Vec3::from_array([0, 1, 2].map(|k| f32::from(map.rgba8[i + k]) / 255.0));
        let expected = mapped_normal(frame, texel);
        let err = (t.normal - expected).abs().max_element();
        worst = worst.max(err);
        assert!(err <= 1e-3, "RSM normal {} at {} (map texel {tx}, {ty}); the CPU's {expected}", t.normal, t.position);
        blocks.insert((tx / 2, ty / 2));
        checked += 1;
    }
    eprintln!("RSM: {checked} wall texels, worst normal component error {worst:.2e}");
    assert!(checked > 300 && blocks.len() == 4, "{checked} texels over blocks {blocks:?}");

    // The VPLs against the twin's.
    let gpu_vpls = path.buffers.read_vpls(device, queue).expect("vpls");
    let cpu = vpl::generate(&faces, &cfg).expect("twin");
    let max_flux = cpu.vpls.iter().map(|v| v.flux.max_element()).fold(0.0, f32::max);
    let mut used = vec![false; cpu.vpls.len()];
    for g in &gpu_vpls {
        let g = g.to_vpl();
        let found = cpu.vpls.iter().enumerate().position(|(i, c)| {
            !used[i]
                && (c.position - g.position).length() < 1e-4
                && (c.normal - g.normal).length() < 1e-4
                && (c.flux - g.flux).abs().max_element() <= 1e-4 * c.flux.max_element() + 1e-6 * max_flux
        });
        let i = found.unwrap_or_else(|| panic!("GPU VPL {g:?} matches no CPU VPL"));
        used[i] = true;
    }
    assert_eq!(gpu_vpls.len(), cpu.vpls.len(), "every CPU VPL has its GPU twin");
    // The map bends the VPL normals: they are not all the wall's flat normal.
    let flat = frame.2;
    let bent = cpu.vpls.iter().filter(|v| v.normal.dot(flat) < 0.95).count();
    eprintln!("{} VPLs, {bent} bent off the wall's normal by the map", cpu.vpls.len());
    assert!(cpu.vpls.len() > 50 && bent * 4 > cpu.vpls.len(), "{bent} of {}", cpu.vpls.len());
}

// ---------------------------------------------------------------------------------------
// Class 3: every wrap mode on each axis, outside [0, 1], in masks.

/// Texels a side of the mask.
const MASK: usize = 4;
/// A mask texel is kept (alpha 1) where its column's COL differs from its row's ROW, so a
/// wrong texel index on either axis changes what is kept somewhere. Over the screen's
/// texel coordinates (u from -3 to 7 texels, v from -2 to 6) each pair of modes gives a
/// different column or row somewhere: u at -2 (repeat 2, mirror 1, clamp 0), -3 and 5, 6;
/// v at -2 (repeat 2, mirror 1, clamp 0) and 5 (repeat 1, mirror 2, clamp 3).
const COL: [bool; MASK] = [true, true, false, true];
const ROW: [bool; MASK] = [true, false, true, true];
/// The screen's texture coordinates at its corners: u from -0.75 to 1.75 along +x, v from
/// -0.5 to 1.5 along +z (both sides of [0, 1] on both axes).
const U_RANGE: (f32, f32) = (-0.75, 1.75);
const V_RANGE: (f32, f32) = (-0.5, 1.5);
/// The screen: 3 m square, horizontal at this height, facing up.
const SCREEN_HALF: f32 = 1.5;
const SCREEN_Y: f32 = 3.5;

fn wrap_index(i: i64, n: i64, mode: Wrap) -> usize {
    (match mode {
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
    }) as usize
}

/// Whether the mask keeps the screen at its local point (x, z) with wrap modes `wrap`
/// (u, v), by the CPU (nearest texel of mip 0, Vulkan's wrap of texel indices); None
/// within 3% of a texel edge, where the GPU's interpolated coordinates and the CPU's
/// (~1e-5 texel apart) may pick different texels.
fn mask_keeps(x: f32, z: f32, wrap: (Wrap, Wrap)) -> Option<bool> {
    let t = |c: f32, (lo, hi): (f32, f32)| lo + (c + SCREEN_HALF) / (2.0 * SCREEN_HALF) * (hi - lo);
    let (u, v) = (t(x, U_RANGE) * MASK as f32, t(z, V_RANGE) * MASK as f32);
    let safe = |c: f32| (0.03..=0.97).contains(&(c - c.floor()));
    if !safe(u) || !safe(v) {
        return None;
    }
    let n = MASK as i64;
    Some(COL[wrap_index(u.floor() as i64, n, wrap.0)] != ROW[wrap_index(v.floor() as i64, n, wrap.1)])
}

/// A 20 m grey floor and the masked screen (double-sided, nearest without mipmaps, its
/// sampler wrapping u and v by `wrap`): kept texels red, dropped ones blue with alpha 0.
fn wrap_scene(wrap: (Wrap, Wrap)) -> Scene {
    let mut tex = Vec::with_capacity(MASK * MASK * 4);
    for row in &ROW[..MASK] {
        for col in &COL[..MASK] {
            tex.extend(if col != row { [220, 40, 40, 255] } else { [40, 40, 220, 0] });
        }
    }
    let mut screen = tiledlight_tests::scenes::material("screen", [1.0; 4], 0.6, 0.0);
    screen.base_color_texture = Some(TextureRef { sampler: nearest_no_mips(wrap.0, wrap.1), ..TextureRef::new(0) });
    screen.alpha_mode = tiledlight_scene::AlphaMode::Mask { cutoff: 0.5 };
    screen.double_sided = true;
    let mut mesh = tiledlight_tests::scenes::quad("screen", 2.0 * SCREEN_HALF);
    let (u, v) = (U_RANGE, V_RANGE);
    // Corners (-x, -z), (-x, +z), (+x, +z), (+x, -z).
    mesh.uvs = vec![[u.0, v.0], [u.0, v.1], [u.1, v.1], [u.1, v.0]];
    let inst = |mesh, material, transform| Instance { mesh, material, transform };
    let mut scene = Scene {
        name: "wrapped mask".into(),
        meshes: vec![tiledlight_tests::scenes::quad("floor", 20.0), mesh],
        materials: vec![tiledlight_tests::scenes::material("floor", [0.5, 0.5, 0.5, 1.0], 0.8, 0.0), screen],
        textures: vec![Texture { name: "mask".into(), width: MASK as u32, height: MASK as u32, rgba8: tex }],
        instances: vec![inst(0, 0, Mat4::IDENTITY), inst(1, 1, Mat4::from_translation(Vec3::new(0.0, SCREEN_Y, 0.0)))],
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.bounds.max.y = scene.bounds.max.y.max(8.0);
    scene.validate().expect("wrap scene is valid");
    scene
}

const WRAP_CASES: [(Wrap, Wrap); 3] = [
    (Wrap::Repeat, Wrap::MirroredRepeat),
    (Wrap::MirroredRepeat, Wrap::ClampToEdge),
    (Wrap::ClampToEdge, Wrap::Repeat),
];
const ALL_WRAPS: [Wrap; 3] = [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge];

const CW: u32 = 160;
const CH: u32 = 120;

/// The camera looking down on the screen, the floor seen through its holes and around it.
fn coverage_camera() -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 9.0, 3.0),
        Vec3::new(0.0, SCREEN_Y, 0.0),
        Vec3::Y,
        45f32.to_radians(),
        CW as f32 / CH as f32,
        0.1,
        None,
    )
    .unwrap()
}

/// Per pixel of the coverage camera: Some(true) where the CPU sees a kept texel of the
/// screen, Some(false) where it sees the floor (around the screen or through a dropped
/// texel), None where that is ambiguous (a screen edge under one of the pixel's corner
/// rays, or a texel edge: [`mask_keeps`]).
fn expected_coverage(wrap: (Wrap, Wrap)) -> Vec<Option<bool>> {
    let camera = coverage_camera();
    let eye = camera.eye();
    let on_screen = |sx: f32, sy: f32| {
        let d = pixel_ray(&camera, (CW, CH), sx, sy);
        let t = (SCREEN_Y - eye.y) / d.y;
        let p = eye + d * t;
        (p.x.abs() <= SCREEN_HALF && p.z.abs() <= SCREEN_HALF).then_some((p.x, p.z))
    };
    let mut out = vec![None; (CW * CH) as usize];
    for y in 0..CH {
        for x in 0..CW {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let centre = on_screen(cx, cy);
            let corners = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)];
            if !corners.iter().all(|(dx, dy)| on_screen(cx + dx, cy + dy).is_some() == centre.is_some()) {
                continue;
            }
            out[(y * CW + x) as usize] = match centre {
                None => Some(false),
                Some((px, pz)) => mask_keeps(px, pz, wrap),
            };
        }
    }
    out
}

/// Pixels of `hdr` (ambient-lit only: the albedo) whose class differs from `expected`:
/// the screen's kept texels are red (sRGB 220, 40, 40: linear r over 0.6, g under 0.05),
/// the floor grey 0.5; anything else (a dropped texel's blue, a blend) is a mismatch
/// either way.
fn coverage_mismatches(hdr: &[[f32; 4]], expected: &[Option<bool>]) -> Vec<usize> {
    let red = |p: &[f32; 4]| p[0] > 0.6 && p[1] < 0.05 && p[2] < 0.05;
    let grey = |p: &[f32; 4]| (0..3).all(|c| (p[c] - 0.5).abs() < 0.01);
    (0..expected.len())
        .filter(|&i| match expected[i] {
            None => false,
            Some(true) => !red(&hdr[i]),
            Some(false) => !grey(&hdr[i]),
        })
        .collect()
}

/// Every wrap mode on each axis (u's mode differing from v's) at texture coordinates on
/// both sides of [0, 1], for an alpha-masked screen seen from above: brute force, Forward+,
/// Tiled Deferred and the visibility buffer (hardware and compute rasters) keep exactly
/// the texels the CPU's wrap of the mask keeps (pixels over a texel or screen edge
/// excepted, `expected_coverage`). The same comparison rejects brute force's image against
/// the expectation with either axis's mode replaced by each other mode (the comparison's
/// negative test, and the proof that the scene tells every mode apart on both axes).
#[test]
fn alpha_masks_wrap_each_axis_by_its_own_mode_in_every_raster_path() {
    let ctx = gpu();
    for wrap in WRAP_CASES {
        let scene = wrap_scene(wrap);
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        let lb = LightBuffers::new(&ctx.device, &[]).unwrap();
        let camera = coverage_camera();
        let expected = expected_coverage(wrap);
        let kept = expected.iter().filter(|e| **e == Some(true)).count();
        let dropped = expected.iter().filter(|e| **e == Some(false)).count();
        eprintln!("{wrap:?}: {kept} kept and {dropped} floor pixels compared");
        assert!(kept > 1000 && dropped > 1000, "{wrap:?}: {kept} kept, {dropped} floor");
        let fs = |method| FrameSettings { method, ambient: Vec3::ONE, ..Default::default() };
        let mut frames = Vec::new();
        for (name, method) in [
            ("brute force", Method::BruteForce { cutoff: true }),
            ("Forward+", Method::ForwardPlus),
            ("Tiled Deferred", Method::TiledDeferred),
        ] {
            let mut r = FrameRenderer::new(ctx, &sg, &lb, CW, CH, fs(method)).unwrap();
            frames.push((name.to_string(), render_frame(ctx, &mut r, &sg, &camera)));
        }
        for (raster, frame, _) in visibility_frames(ctx, (&sg, &lb, &camera), (CW, CH), fs(Method::Visibility)) {
            frames.push((format!("visibility ({})", raster.name()), frame));
        }
        for (name, frame) in &frames {
            let bad = coverage_mismatches(&frame.hdr, &expected);
            assert!(
                bad.is_empty(),
                "{wrap:?} {name}: {} pixels keep other texels than the CPU's wrap, e.g. ({}, {}): {:?}",
                bad.len(),
                bad[0] % CW as usize,
                bad[0] / CW as usize,
                frame.hdr[bad[0]]
            );
        }
        let brute = &frames[0].1;
        for other in ALL_WRAPS {
            for (axis, wrong) in [(0, (other, wrap.1)), (1, (wrap.0, other))] {
                if wrong == wrap {
                    continue;
                }
                let n = coverage_mismatches(&brute.hdr, &expected_coverage(wrong)).len();
                assert!(n >= 100, "{wrap:?}: axis {axis} read as {other:?} differs at only {n} pixels");
            }
        }
    }
}

// ---- the shadow atlas and the traced reference's mask lookups ----

const SW: u32 = 160;
const SH: u32 = 120;
/// The spot over the screen: straight down from twice the screen's height, so the mask's
/// shadow on the floor is the mask magnified twice.
const SPOT_Y: f32 = 2.0 * SCREEN_Y;
const SPOT_OUTER: f32 = 0.7;

fn shadow_spot() -> Light {
    Light::spot(Vec3::new(0.0, SPOT_Y, 0.0), Vec3::NEG_Y, Vec3::ONE, 200.0, 0.6, SPOT_OUTER, 0.01).expect("spot")
}

/// A camera under the screen's height looking at the floor beneath it (no ray of it meets
/// the screen over the floor it sees).
fn shadow_camera() -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 3.4, 5.0),
        Vec3::new(0.0, 0.0, -0.3),
        Vec3::Y,
        55f32.to_radians(),
        SW as f32 / SH as f32,
        0.1,
        None,
    )
    .unwrap()
}

/// Whether the spot at `light` reaches floor point `p` through the masked screen, by the
/// CPU: where the segment crosses the screen's plane, outside the screen or on a dropped
/// texel. None near a texel edge ([`mask_keeps`]).
fn reaches(p: Vec3, light: Vec3, wrap: (Wrap, Wrap)) -> Option<bool> {
    let s = (SCREEN_Y - p.y) / (light.y - p.y);
    let c = p + (light - p) * s;
    if c.x.abs() > SCREEN_HALF || c.z.abs() > SCREEN_HALF {
        return Some(true);
    }
    mask_keeps(c.x, c.z, wrap).map(|keeps| !keeps)
}

/// Per pixel of the shadow camera: whether the spot reaches the floor point there (None
/// off the floor, or within `border` metres on the floor of a point the CPU judges
/// otherwise, or near a texel edge).
fn expected_light(depth: &[f32], wrap: (Wrap, Wrap), border: f32) -> Vec<Option<bool>> {
    let camera = shadow_camera();
    let inv_view = camera.view().inverse();
    let light = shadow_spot().position;
    (0..(SW * SH) as usize)
        .map(|i| {
            let (x, y) = (i as u32 % SW, i as u32 / SW);
            let pv = tiledlight_cull::reference::pixel_view_position(&camera, SW, SH, x, y, depth[i])?;
            let p = (inv_view * pv.extend(1.0)).truncate();
            // Floor points inside the inner cone (0.6 rad), with a 5% margin: lit at full spot
            // strength where nothing occludes.
            if p.y.abs() > 1e-3 || p.x.hypot(p.z) > 0.95 * SPOT_Y * 0.6f32.tan() {
                return None;
            }
            let centre = reaches(p, light, wrap)?;
            let ring = (0..16).map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 16.0;
                reaches(p + Vec3::new(a.cos(), 0.0, a.sin()) * border, light, wrap)
            });
            let ring: Vec<Option<bool>> = ring.chain([reaches(p + Vec3::X * border * 0.5, light, wrap)]).collect();
            ring.iter().all(|r| r.is_none_or(|r| r == centre)).then_some(centre)
        })
        .collect()
}

/// Pixels where `shadowed / unshadowed` (the light's visibility: no ambient) is not 1
/// (within 1%: f16 rounding of both images) where `expected` says lit, or not 0 (within
/// 1%) where it says dark.
fn visibility_mismatches(shadowed: &Frame, unshadowed: &Frame, expected: &[Option<bool>]) -> Vec<usize> {
    (0..expected.len())
        .filter(|&i| {
            let Some(lit) = expected[i] else { return false };
            let (s, u) = (shadowed.hdr[i][1], unshadowed.hdr[i][1]);
            if u < 1e-3 {
                return true; // the spot must light every compared floor pixel
            }
            let ratio = s / u;
            if lit {
                ratio < 0.99
            } else {
                ratio > 0.01
            }
        })
        .collect()
}

/// The masked screen's shadow on the floor under a spot, in the shadow atlas (brute force
/// with shadow maps) and in the traced reference (its shadow rays' mask lookups), against
/// the CPU's wrap of the mask, for each pair of wrap modes. Pixels near a shadow edge are
/// not judged: for the atlas within a border derived from the face's texel (tile 512, the
/// spot's outer half-angle 0.7 rad, widened by at most 5% for the filter's reach, texel
/// `2 tan(0.7) 1.05 / 512` = 0.0034 of the distance, 7 m: 0.024 m) times the filter's
/// reach plus rasterisation and the normal offset (2 + 1 + 0.5 + 1 = 4.5 texels for 5x5
/// PCF), times 1.5 for the floor's slant to the light's rays off its axis (at most 27
/// degrees here: 1 / cos^3 = 1.4): 0.16 m; for the rays within 0.01 m (the traced surface
/// is rebuilt within ~1e-5 m). The comparison rejects the images against each other wrap
/// mode on either axis (its negative test).
#[test]
fn masked_shadows_wrap_each_axis_by_its_own_mode_in_the_atlas_and_the_traced_reference() {
    use tiledlight_cull::shadow::ShadowOptions;
    let ctx = gpu();
    let shadows = ShadowOptions { tile_size: 512, ..ShadowOptions::default() };
    let texel = 2.0 * SPOT_OUTER.tan() * 1.05 / 512.0 * SPOT_Y;
    let atlas_border = texel * (2.0 + 1.0 + 0.5 + 1.0) * 1.5;
    eprintln!("atlas texel at the floor {texel:.4} m, border {atlas_border:.3} m");
    let camera = shadow_camera();
    let spot = shadow_spot();
    for wrap in WRAP_CASES {
        let scene = wrap_scene(wrap);
        let mut sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
        sg.add_trace(&ctx.device, &scene).unwrap();
        let plain = LightBuffers::new(&ctx.device, &[spot]).unwrap();
        let casting = LightBuffers::with_casters(&ctx.device, &[spot], (0, 1)).unwrap();
        let fs = |method| FrameSettings { method, ambient: Vec3::ZERO, shadows, ..Default::default() };
        let render = |lb: &LightBuffers, method| {
            let mut r = FrameRenderer::new(ctx, &sg, lb, SW, SH, fs(method)).unwrap();
            let f = render_frame(ctx, &mut r, &sg, &camera);
            (f, r.read_depth(ctx).unwrap())
        };
        let (unshadowed, depth) = render(&plain, Method::BruteForce { cutoff: true });
        let (atlas, _) = render(&casting, Method::BruteForce { cutoff: true });
        let (uncut, _) = render(&plain, Method::BruteForce { cutoff: false });
        let (traced, _) = render(&plain, Method::TRUTH);
        for (name, shadowed, reference, border) in
            [("shadow atlas", &atlas, &unshadowed, atlas_border), ("traced", &traced, &uncut, 0.01)]
        {
            let expected = expected_light(&depth, wrap, border);
            let lit = expected.iter().filter(|e| **e == Some(true)).count();
            let dark = expected.iter().filter(|e| **e == Some(false)).count();
            let bad = visibility_mismatches(shadowed, reference, &expected);
            eprintln!("{wrap:?} {name}: {lit} lit and {dark} dark floor pixels judged, {} wrong", bad.len());
            assert!(lit > 800 && dark > 800, "{wrap:?} {name}: {lit} lit, {dark} dark");
            assert!(
                bad.is_empty(),
                "{wrap:?} {name}: {} floor pixels lit otherwise than the CPU's wrap, e.g. ({}, {})",
                bad.len(),
                bad[0] as u32 % SW,
                bad[0] as u32 / SW
            );
            for other in ALL_WRAPS {
                for (axis, wrong) in [(0, (other, wrap.1)), (1, (wrap.0, other))] {
                    if wrong != wrap {
                        let n =
                            visibility_mismatches(shadowed, reference, &expected_light(&depth, wrong, border)).len();
                        assert!(n >= 50, "{wrap:?} {name}: axis {axis} read as {other:?} differs at only {n} pixels");
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Class 2: minified, mipmapped textures on both coordinate sets, with transforms.

const MW: u32 = 128;
const MH: u32 = 72;
/// Texels a side of the two noise textures (mip levels 0 to 6).
const NOISE: u32 = 64;

/// `NOISE`^2 RGBA8 texels of white noise (a fixed hash of the texel and `seed`), opaque.
/// Each mip level the loader builds (`scene_gpu::mip_chain`, a 2:1 triangle filter) is an
/// average of the level above, so noise differs from level to level everywhere: a pixel
/// whose level of detail is off by one reads another blend of texels, tens of percent
/// away (the test below measures it against the image without mipmaps).
fn noise(seed: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity((NOISE * NOISE * 4) as usize);
    for i in 0..NOISE * NOISE {
        for c in 0..3u32 {
            let mut h = i.wrapping_mul(0x9e37_79b9) ^ (c + 3 * seed).wrapping_mul(0x85eb_ca6b);
            h ^= h >> 15;
            h = h.wrapping_mul(0x2c1b_3c6d);
            h ^= h >> 12;
            out.push((h & 0xff) as u8);
        }
        out.push(255);
    }
    out
}

/// Set 0 on the floor at (x, z): half a unit a metre along each axis.
fn floor_uv0(x: f32, z: f32) -> [f32; 2] {
    [0.5 * x, 0.5 * z]
}

/// Set 1: another orientation and scale (so its gradients are not set 0's).
fn floor_uv1(x: f32, z: f32) -> [f32; 2] {
    [0.25 * z + 0.1 * x, 0.3 * x]
}

/// The base colour's transform (set 0): strongly anisotropic, so the screen-x gradient
/// outgrows the screen-y one near the camera and the y one wins far away (a level taken
/// from one gradient alone is wrong somewhere), and rotated.
const BASE_TRANSFORM: tiledlight_scene::UvTransform =
    tiledlight_scene::UvTransform { offset: [0.3, -0.2], rotation: 0.5, scale: [6.0, 1.5] };
/// The emissive texture's (set 1).
const EMISSIVE_TRANSFORM: tiledlight_scene::UvTransform =
    tiledlight_scene::UvTransform { offset: [-0.1, 0.4], rotation: -0.7, scale: [2.5, 4.0] };

/// A 12 m floor seen at a grazing angle: sRGB noise as base colour on set 0 and as emission
/// on set 1, each with its `KHR_texture_transform`, trilinear, repeating. `baked`: the
/// transforms applied to the vertex coordinates instead (identity transforms in the
/// material): the hardware then differentiates the transformed coordinates itself.
/// `mipmaps`: false reads level 0 only (glTF's plain LINEAR minification).
fn mip_scene(baked: bool, mipmaps: bool) -> Scene {
    let s = 6.0;
    let corners = [[-s, -s], [-s, s], [s, s], [s, -s]];
    let set = |f: fn(f32, f32) -> [f32; 2], t: tiledlight_scene::UvTransform| -> Vec<[f32; 2]> {
        corners.iter().map(|c| if baked { t.apply(f(c[0], c[1])) } else { f(c[0], c[1]) }).collect()
    };
    let mesh = tiledlight_scene::Mesh {
        name: "floor".into(),
        positions: corners.iter().map(|c| [c[0], 0.0, c[1]]).collect(),
        normals: vec![[0.0, 1.0, 0.0]; 4],
        uvs: set(floor_uv0, BASE_TRANSFORM),
        uvs1: set(floor_uv1, EMISSIVE_TRANSFORM),
        tangents: Vec::new(),
        indices: vec![0, 1, 2, 0, 2, 3],
    };
    let sampler = Sampler {
        wrap_u: Wrap::Repeat,
        wrap_v: Wrap::Repeat,
        mag: Filter::Linear,
        min: Filter::Linear,
        mipmap: mipmaps.then_some(Filter::Linear),
    };
    let slot = |texture, tex_coord, transform| TextureRef {
        texture,
        tex_coord,
        sampler,
        transform: if baked { tiledlight_scene::UvTransform::default() } else { transform },
    };
    let material = Material {
        name: "noise".into(),
        base_color: [1.0; 4],
        base_color_texture: Some(slot(0, 0, BASE_TRANSFORM)),
        roughness: 0.7,
        metallic: 0.0,
        emissive: [0.4, 0.4, 0.4],
        emissive_texture: Some(slot(1, 1, EMISSIVE_TRANSFORM)),
        ..Material::default()
    };
    let tex = |name: &str, seed| Texture { name: name.into(), width: NOISE, height: NOISE, rgba8: noise(seed) };
    let mut scene = Scene {
        name: "mipmapped floor".into(),
        meshes: vec![mesh],
        materials: vec![material],
        textures: vec![tex("noise a", 1), tex("noise b", 2)],
        instances: vec![Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }],
        lights: vec![],
        camera: None,
        bounds: Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate().expect("mip scene is valid");
    scene
}

fn mip_camera() -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 1.0, 5.5),
        Vec3::new(0.0, 0.0, -4.0),
        Vec3::Y,
        50f32.to_radians(),
        MW as f32 / MH as f32,
        0.1,
        None,
    )
    .unwrap()
}

fn mip_lights() -> Vec<Light> {
    vec![Light::point(Vec3::new(0.5, 1.5, 1.0), Vec3::new(1.0, 0.95, 0.9), 6.0, 0.01).unwrap()]
}

/// The level of detail the CPU expects per floor pixel for set `uv` through `t` (log2 of
/// the longer screen gradient in texels: Vulkan's isotropic LOD), from ray casts of the
/// pixel and its right and lower neighbours; None off the floor.
fn cpu_lods(uv: fn(f32, f32) -> [f32; 2], t: tiledlight_scene::UvTransform) -> Vec<Option<f32>> {
    let camera = mip_camera();
    let eye = camera.eye();
    let at = |sx: f32, sy: f32| {
        let d = pixel_ray(&camera, (MW, MH), sx, sy);
        let p = eye + d * (-eye.y / d.y);
        (d.y < 0.0 && p.x.abs() < 6.0 && p.z.abs() < 6.0).then(|| Vec2::from(t.apply(uv(p.x, p.z))) * NOISE as f32)
    };
    (0..MW * MH)
        .map(|i| {
            let (x, y) = ((i % MW) as f32 + 0.5, (i / MW) as f32 + 0.5);
            let (c, r, d) = (at(x, y)?, at(x + 1.0, y)?, at(x, y + 1.0)?);
            let (dx, dy) = ((r - c).length(), (d - c).length());
            Some(dx.max(dy).log2())
        })
        .collect()
}

/// The outliers of the explicit gradients (the visibility buffer with either raster, the
/// traced reference) on the mipmapped noise floor: measured on lavapipe, the same
/// 66 of 9,104 pixels (0.72%) beyond the HDR limit, worst 4.5x it (4.5e-2), all in the
/// second rows of 2x2 quads (rows 69 and 71, x 47 to 97) where the levels are 2.2 (set 0)
/// and 0.9 (set 1); rows 68 and 70 there are bit-equal to brute force. Not the light (moved
/// away, the same pixels), not the near-plane clip (a floor that ends in front of the eye,
/// the same), not the split diagonal (far from it). Cause not yet found (tests/README.md,
/// known gaps). Taking the gradients at the pixel's own row instead of the quad's first
/// (the derivative bug this test is for) puts 590 pixels (6.5%) past the limit, worst 10x,
/// and fails FLIP: so 1%, at most 5x the limit, still rejects it; on hardware rasterisers
/// with the factor of [`visibility_outliers`] as well.
fn mip_outliers() -> Outliers {
    let o = visibility_outliers(false);
    Outliers { share: o.share.max(0.01), factor: o.factor.max(5.0) }
}

/// Minified, mipmapped textures on set 0 (base colour) and set 1 (emission), each with a
/// scaling and rotating `KHR_texture_transform`, on a floor at a grazing angle (levels of
/// detail from under 1 to over 5 across the image, by the CPU). Compared:
/// - brute force (the hardware's implicit derivatives of the coordinates, carried through
///   the transform by `sample_slot`) against the same floor with the transforms baked into
///   the vertex coordinates (the hardware differentiates the transformed coordinates):
///   `FORWARD_VS_REFERENCE` (f16 rounding; the two differ only by float rounding of an
///   affine map) — a transform applied to the coordinates but not to their gradients, or
///   not rotated, picks other levels;
/// - the visibility buffer (its analytic gradients, `textureSampleGrad`; hardware and
///   compute rasters) and the traced reference against brute force, under
///   `assert_visibility_matches` (the suite's limits; lavapipe's LOD from the fragment
///   stage's coarse derivatives is what the visibility buffer reproduces, see
///   `visibility.rs`);
/// - Tiled Deferred against brute force (its G-buffer pass samples as brute force does).
///
/// The image without mipmaps differs from brute force's beyond every one of those limits
/// (proving the levels matter here): FLIP mean over 0.05.
#[test]
fn mipmapped_transformed_textures_on_both_sets_pick_the_hardwares_levels() {
    let ctx = gpu();
    let camera = mip_camera();
    let lights = mip_lights();
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();
    let ambient = Vec3::splat(0.3);
    let fs = |method| FrameSettings { method, ambient, ..Default::default() };
    let scene = mip_scene(false, true);
    let mut sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    sg.add_trace(&ctx.device, &scene).unwrap();

    // Several levels across the image, on both sets.
    for (name, lods) in
        [("set 0", cpu_lods(floor_uv0, BASE_TRANSFORM)), ("set 1", cpu_lods(floor_uv1, EMISSIVE_TRANSFORM))]
    {
        let levels: std::collections::BTreeSet<i32> =
            lods.iter().flatten().map(|l| l.floor().max(0.0) as i32).collect();
        eprintln!("{name}: levels of detail {levels:?}");
        assert!(levels.len() >= 4, "{name}: only levels {levels:?}");
    }

    let render = |sg: &SceneGpu, method| {
        let mut r = FrameRenderer::new(ctx, sg, &lb, MW, MH, fs(method)).unwrap();
        let f = render_frame(ctx, &mut r, sg, &camera);
        (f, r.read_depth(ctx).unwrap())
    };
    let (brute, depth) = render(&sg, Method::BruteForce { cutoff: true });
    let lit = brute.hdr.iter().filter(|p| p[0] > 0.0).count();
    assert!(lit > (MW * MH / 2) as usize, "the floor fills most of the frame: {lit}");

    let baked_scene = mip_scene(true, true);
    let baked_sg = SceneGpu::new(&ctx.device, &ctx.queue, &baked_scene).unwrap();
    let (baked, _) = render(&baked_sg, Method::BruteForce { cutoff: true });
    assert_matches_reference_frame("mips-baked-transform", MW, &baked, &brute, FORWARD_VS_REFERENCE);

    let flat_scene = mip_scene(false, false);
    let flat_sg = SceneGpu::new(&ctx.device, &ctx.queue, &flat_scene).unwrap();
    let (flat, _) = render(&flat_sg, Method::BruteForce { cutoff: true });
    let no_mips =
        tiledlight_tests::compare::compare_with_reference("mips-none", MW, &brute, &flat, FORWARD_VS_REFERENCE);
    assert!(no_mips.flip.mean > 0.05, "the levels must matter: FLIP mean without mipmaps {:.4}", no_mips.flip.mean);

    let shifted = brute.clone().allow_position_error(&depth, MW, (&camera, &lb.packed), RASTER_POSITION_ERROR_PX);
    for (raster, visibility, ties) in visibility_frames(ctx, (&sg, &lb, &camera), (MW, MH), fs(Method::Visibility)) {
        let reference = shifted.clone().forgive_hdr(&ties).0;
        let name = format!("mips-visibility-{}", raster.name());
        assert_matches_with_outliers(&name, MW, (&reference, &visibility), VISIBILITY_VS_REFERENCE, mip_outliers());
    }
    let (uncut, uncut_depth) = render(&sg, Method::BruteForce { cutoff: false });
    let uncut = uncut.allow_position_error(&uncut_depth, MW, (&camera, &lb.packed), RASTER_POSITION_ERROR_PX);
    let (traced, _) = render(&sg, Method::TRUTH);
    assert_matches_with_outliers("mips-traced", MW, (&uncut, &traced), VISIBILITY_VS_REFERENCE, mip_outliers());
    let (deferred, _) = render(&sg, Method::TiledDeferred);
    let reference = brute.clone().allow_gbuffer_normals(&depth, MW, &camera, &lb.packed);
    assert_matches_reference_frame("mips-deferred", MW, &reference, &deferred, DEFERRED_VS_REFERENCE);
}
