//! Independent checks of the pieces brute force shares with every method (issue 43, class
//! 7): a bug in them is invisible to a method-vs-brute-force comparison, so each is checked
//! here against a value computed on the CPU from first principles, never by the WGSL under
//! test nor by a CPU twin that mirrors it.
//!
//! - **The blended composite** (`blended.wgsl`'s premultiplied shading, the sorted "over"
//!   into the layer, `blended_composite.wgsl`): emissive, ambient-lit panes of known colour
//!   and alpha facing the camera, each covering a pixel rectangle whose edges lie on pixel
//!   boundaries (no pixel centre within half a pixel of an edge, so coverage is certain),
//!   over an opaque emissive wall and the sky. The expected pixel is Porter-Duff "over" of
//!   the panes' colours, back to front, on the method's own opaque pixel; with weighted
//!   blended OIT, McGuire and Bavoil's formula (JCGT 2(2) 2013, eq. 9's weight). Checked
//!   for brute force, Forward+ and Tiled Deferred. The comparison must reject a composite
//!   shifted by one pixel, panes composited in the wrong order and a colour premultiplied
//!   twice. A failure means the blended shading, the sort or the composite is wrong in
//!   every method alike.
//! - **The material sample** (`material_at` and `material_color`,
//!   `shaders/common/scene.wgsl`): run in a compute kernel over the real `SceneGpu`
//!   upload (its material buffer, textures, sampler and sRGB choice) at known texture
//!   coordinates with zero gradients (mip 0), against values computed here from the
//!   texture's bytes: sRGB decode (colour slots), bilinear filtering by hand, wrap
//!   (repeat), the factors, the `KHR_texture_transform` rows written from the extension,
//!   the second UV set, occlusion strength and the tangent-space normal map. The
//!   comparison must reject metallic and roughness swapped, a sample one texel off and a
//!   base colour not sRGB-decoded. A failure means a material is read wrongly in every
//!   method alike.
//!
//! (The BRDF has its own independent check: `crates/cull/tests/brdf_reference.rs`.)

use glam::{Mat4, Vec3};
use tiledlight_cull::Camera;
use tiledlight_frame::{FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::features::BlendMode;
use tiledlight_gpu::knobs::Knobs;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_scene::{AlphaMode, Instance, Material, Scene, Texture, TextureRef, UvTransform};
use tiledlight_tests::compare::{render_frame, LAVAPIPE_SRGB_DECODE_ERROR};
use tiledlight_tests::images::srgb_to_linear;
use tiledlight_tests::kernels::Rng;
use tiledlight_tests::{gpu, is_lavapipe, scenes};

// ---------------------------------------------------------------------------------------
// The blended composite
// ---------------------------------------------------------------------------------------

/// Small frame: the composite is per pixel, so a few thousand pixels hold every case.
const W: u32 = 96;
const H: u32 = 64;
const FOV_Y_DEG: f32 = 50.0;

/// The ambient radiance of the composite tests (times base colour: the unlit term).
const AMBIENT: Vec3 = Vec3::new(0.25, 0.2, 0.3);

/// A rectangle facing the camera (which sits at the origin looking down -Z) at view depth
/// `depth`, covering the pixels `[x0, x1) x [y0, y1)`: its edges project onto pixel
/// boundaries. Lit by ambient light only, it shades to `AMBIENT * base + emission`.
#[derive(Clone, Copy, Debug)]
struct Rect {
    px: [u32; 4],
    depth: f32,
    base: [f32; 3],
    emission: [f32; 3],
    /// 1 for the opaque wall.
    alpha: f32,
}

impl Rect {
    /// The colour the surface shades to (before coverage): ambient on base colour plus
    /// emission; nothing else lights it.
    fn colour(&self) -> Vec3 {
        AMBIENT * Vec3::from(self.base) + Vec3::from(self.emission)
    }

    fn covers(&self, x: u32, y: u32) -> bool {
        let [x0, x1, y0, y1] = self.px;
        (x0..x1).contains(&x) && (y0..y1).contains(&y)
    }

    /// The instance transform of a unit quad (XZ plane, facing +Y) onto this rectangle,
    /// from the pinhole projection written here: pixel `p` at view depth `d` is at
    /// `x = (2 p / W - 1) d tan(fov/2) aspect`, `y = (1 - 2 p / H) d tan(fov/2)`.
    fn transform(&self) -> Mat4 {
        let t = (FOV_Y_DEG.to_radians() * 0.5).tan() * self.depth;
        let aspect = W as f32 / H as f32;
        let [x0, x1, y0, y1] = self.px.map(|v| v as f32);
        let wx = |p: f32| (2.0 * p / W as f32 - 1.0) * t * aspect;
        let wy = |p: f32| (1.0 - 2.0 * p / H as f32) * t;
        let centre = Vec3::new((wx(x0) + wx(x1)) * 0.5, (wy(y0) + wy(y1)) * 0.5, -self.depth);
        let size = Vec3::new(wx(x1) - wx(x0), 1.0, wy(y0) - wy(y1));
        // Rotating +Y onto +Z: the quad's z runs along -y, its normal faces the camera.
        Mat4::from_translation(centre) * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2) * Mat4::from_scale(size)
    }
}

/// The opaque wall: emissive, over the left two thirds of the frame at 20 m; the sky (0)
/// elsewhere.
fn wall() -> Rect {
    Rect { px: [0, 64, 0, H], depth: 20.0, base: [0.5, 0.4, 0.6], emission: [0.3, 0.5, 0.2], alpha: 1.0 }
}

/// Three panes overlapping each other, the wall and the sky. Listed nearest first, so the
/// scene's material order (which the instance buffer follows) draws them front to back:
/// only the sort makes "over" right.
fn panes() -> Vec<Rect> {
    vec![
        Rect { px: [20, 70, 10, 40], depth: 3.0, base: [0.9, 0.2, 0.1], emission: [0.6, 0.1, 0.05], alpha: 0.5 },
        Rect { px: [40, 90, 24, 56], depth: 6.0, base: [0.1, 0.8, 0.3], emission: [0.05, 0.9, 0.2], alpha: 0.7 },
        Rect { px: [8, 52, 30, 60], depth: 9.0, base: [0.2, 0.3, 1.0], emission: [0.1, 0.2, 1.5], alpha: 0.35 },
    ]
}

fn rect_material(name: &str, r: &Rect) -> Material {
    let mut m = scenes::material(name, [r.base[0], r.base[1], r.base[2], r.alpha], 0.5, 0.0);
    // glTF keeps each emissive factor in [0, 1]; HDR emission (the third pane's 1.5) goes
    // through the strength.
    let strength = r.emission.iter().copied().fold(1.0f32, f32::max);
    m.emissive = r.emission.map(|e| e / strength);
    m.emissive_strength = strength;
    if r.alpha < 1.0 {
        m.alpha_mode = AlphaMode::Blend;
        m.double_sided = true;
    }
    m
}

/// The wall and `panes` (materials in list order, the wall last).
fn composite_scene(panes: &[Rect]) -> Scene {
    let mut rects: Vec<Rect> = panes.to_vec();
    rects.push(wall());
    let materials = rects.iter().enumerate().map(|(i, r)| rect_material(&format!("rect{i}"), r)).collect();
    let instances =
        rects.iter().enumerate().map(|(i, r)| Instance { mesh: 0, material: i, transform: r.transform() }).collect();
    let mut scene = Scene {
        name: "composite".into(),
        meshes: vec![scenes::quad("unit", 1.0)],
        materials,
        textures: vec![],
        instances,
        lights: vec![],
        camera: None,
        bounds: tiledlight_scene::Aabb::empty(),
    };
    scene.bounds = scene.compute_bounds();
    scene.validate().expect("composite scene");
    scene
}

fn composite_camera() -> Camera {
    Camera::perspective(Vec3::ZERO, -Vec3::Z, Vec3::Y, FOV_Y_DEG.to_radians(), W as f32 / H as f32, 0.1, None)
        .expect("camera")
}

/// How the CPU model composites (the right ways, and the broken ones the negative test
/// feeds the comparison).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Model {
    /// Porter-Duff "over", farthest pane first.
    Over,
    /// Weighted blended OIT (McGuire and Bavoil 2013).
    Weighted,
    /// Broken: "over" nearest first.
    OverWrongOrder,
    /// Broken: each pane's colour multiplied by its alpha twice.
    OverPremultipliedTwice,
}

/// McGuire and Bavoil's weight, their equation 9, `z` the view depth in metres.
fn mcguire_bavoil_weight(alpha: f32, z: f32) -> f64 {
    let (a, z) = (alpha as f64, z as f64);
    a * (0.03 / (1e-5 + (z / 200.0).powi(4))).clamp(1e-2, 3e3)
}

/// The expected pixel: the panes covering (x, y) composited on `background` (the
/// method's own opaque pixel), in f64, with its tolerance: every f16 store on the way (the
/// layer or accumulation after each pane, the revealage, the composite) rounds by at most
/// 2^-11 of a value no larger than the sum of magnitudes `s` involved, and the errors pass
/// on with factors at most 1 (over) or are summed (the weighted ratio: numerator and
/// denominator), so (3 n + 3) 2^-11 s for n panes, plus 1e-6 for f16's subnormal floor.
fn expected_pixel(panes: &[Rect], x: u32, y: u32, background: Vec3, model: Model) -> (Vec3, f32) {
    let mut here: Vec<&Rect> = panes.iter().filter(|p| p.covers(x, y)).collect();
    // Farthest first.
    here.sort_by(|a, b| b.depth.total_cmp(&a.depth));
    let bg = background.as_dvec3();
    let mut s = bg.abs().max_element();
    let c = match model {
        Model::Over | Model::OverWrongOrder | Model::OverPremultipliedTwice => {
            if model == Model::OverWrongOrder {
                here.reverse();
            }
            let mut c = bg;
            for p in &here {
                let a = p.alpha as f64;
                let premultiplied = if model == Model::OverPremultipliedTwice { a * a } else { a };
                c = p.colour().as_dvec3() * premultiplied + (1.0 - a) * c;
                s += p.colour().as_dvec3().max_element();
            }
            c
        }
        Model::Weighted => {
            let (mut num, mut den, mut reveal) = (glam::DVec3::ZERO, 0.0, 1.0);
            for p in &here {
                let a = p.alpha as f64;
                let w = mcguire_bavoil_weight(p.alpha, p.depth);
                num += p.colour().as_dvec3() * a * w;
                den += a * w;
                reveal *= 1.0 - a;
                s += p.colour().as_dvec3().max_element();
            }
            if here.is_empty() {
                bg
            } else {
                num / den * (1.0 - reveal) + reveal * bg
            }
        }
    };
    let n = here.len() as f64;
    let tol = (3.0 * n + 3.0) * 2f64.powi(-11) * s + 1e-6;
    (c.as_vec3(), tol as f32)
}

/// Every pixel where `hdr` differs from the CPU composite of `panes` over `background`
/// (both W x H) beyond [`expected_pixel`]'s tolerance, `shift` moving the expected image
/// right by that many pixels (0 for the real check; 1 is the negative test's broken
/// expectation).
fn composite_mismatches(
    hdr: &[[f32; 4]],
    background: &[[f32; 4]],
    panes: &[Rect],
    model: Model,
    shift: u32,
) -> Vec<String> {
    let mut bad = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let (ex, ey) = (x.saturating_sub(shift), y);
            let j = (ey * W + ex) as usize;
            let bg = Vec3::from_slice(&background[j][..3]);
            let (want, tol) = expected_pixel(panes, ex, ey, bg, model);
            let got = Vec3::from_slice(&hdr[i][..3]);
            let err = (got - want).abs().max_element();
            if err.is_nan() || err > tol {
                bad.push(format!("({x}, {y}): GPU {got} expected {want} (error {err:.3e}, tolerance {tol:.3e})"));
            }
        }
    }
    bad
}

/// One frame's HDR image of `scene` by `method` with `blend`, lit by ambient light only.
fn composite_frame(scene: &Scene, method: Method, blend: BlendMode) -> Vec<[f32; 4]> {
    let ctx = gpu();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &[]).unwrap();
    let knobs = Knobs { blend_mode: blend, ..Knobs::default() };
    let s = FrameSettings { method, knobs, ambient: AMBIENT, ..Default::default() };
    let mut r = FrameRenderer::new(ctx, &sg, &lights, W, H, s).expect("renderer");
    render_frame(ctx, &mut r, &sg, &composite_camera()).hdr
}

const METHODS: [(&str, Method); 3] = [
    ("brute force", Method::BruteForce { cutoff: true }),
    ("Forward+", Method::ForwardPlus),
    ("Tiled Deferred", Method::TiledDeferred),
];

/// Checks `blend` for every method against `model`; returns brute force's frame and
/// background for the negative test.
fn check_composite(blend: BlendMode, model: Model) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let panes = panes();
    let with = composite_scene(&panes);
    let without = composite_scene(&[]);
    let mut first = None;
    for (name, method) in METHODS {
        let background = composite_frame(&without, method, blend);
        if matches!(method, Method::BruteForce { .. }) {
            // The background itself is the unlit term written here: the wall's colour, the
            // sky 0, to one f16 step (2^-10 relative: Vulkan lets a float render target
            // round toward zero, and lavapipe does: 0.58 is stored as 1187/2048).
            let wall = wall();
            for y in 0..H {
                for x in 0..W {
                    let want = if wall.covers(x, y) { wall.colour() } else { Vec3::ZERO };
                    let got = Vec3::from_slice(&background[(y * W + x) as usize][..3]);
                    let err = (got - want).abs().max_element();
                    assert!(
                        err <= 2f32.powi(-10) * want.max_element() + 1e-6,
                        "background ({x}, {y}): {got} vs {want}"
                    );
                }
            }
        }
        let hdr = composite_frame(&with, method, blend);
        let bad = composite_mismatches(&hdr, &background, &panes, model, 0);
        assert!(
            bad.is_empty(),
            "{name}, {blend:?}: {} pixels differ from the CPU composite:\n{}",
            bad.len(),
            bad[..bad.len().min(8)].join("\n")
        );
        first.get_or_insert((hdr, background));
    }
    first.expect("brute force ran")
}

/// Sorted blending: every method's composite is the panes' "over", back to front, on its own
/// opaque pixel; the comparison rejects a composite shifted by one pixel, the panes in the
/// wrong order and colours premultiplied twice.
#[test]
fn sorted_composite_is_over_back_to_front() {
    let (hdr, background) = check_composite(BlendMode::Sorted, Model::Over);
    let panes = panes();
    let covered = (0..W * H).filter(|&i| panes.iter().any(|p| p.covers(i % W, i / W))).count();
    assert!(covered > 2000, "the panes cover {covered} pixels");
    for (what, model, shift) in [
        ("shifted by one pixel", Model::Over, 1),
        ("in the wrong order", Model::OverWrongOrder, 0),
        ("premultiplied twice", Model::OverPremultipliedTwice, 0),
    ] {
        let bad = composite_mismatches(&hdr, &background, &panes, model, shift);
        eprintln!("a composite {what}: {} pixels rejected", bad.len());
        assert!(bad.len() > 50, "a composite {what} must be rejected ({} pixels)", bad.len());
    }
}

/// Weighted blended OIT: every method's composite is McGuire and Bavoil's formula with
/// their weight (eq. 9) at the panes' view depths; it is not "over" (the comparison with
/// the sorted model rejects it where two panes overlap).
#[test]
fn weighted_composite_is_mcguire_bavoil() {
    let (hdr, background) = check_composite(BlendMode::WeightedOit, Model::Weighted);
    let bad = composite_mismatches(&hdr, &background, &panes(), Model::Over, 0);
    eprintln!("weighted OIT against 'over': {} pixels differ", bad.len());
    assert!(bad.len() > 50, "weighted OIT must differ from 'over' where panes overlap ({} pixels)", bad.len());
}

// ---------------------------------------------------------------------------------------
// The material sample
// ---------------------------------------------------------------------------------------

/// The kernel: `material_color` and `material_at` of material 0 at each case's texture
/// coordinates with zero gradients (mip 0), seen from the front or the back. VISIBILITY
/// puts the instance and material buffers at group 1's bindings 24 and 25 (as the
/// visibility buffer's compute pass has them); group 0 (the view) is unused.
const MATERIAL_KERNEL: &str = r#"
    let z = vec2<f32>(0.0);
    let sets = UvSets(c.uv0, z, z, c.uv1, z, z);
    let ms = material_at(0u, sets, material_color(0u, sets), c.n.xyz, c.t, c.n.w > 0.0);
    out[i] = array<f32, 16>(ms.base.x, ms.base.y, ms.base.z, ms.alpha, ms.roughness, ms.metallic,
        ms.normal.x, ms.normal.y, ms.normal.z, ms.occlusion, ms.emission.x, ms.emission.y, ms.emission.z,
        0.0, 0.0, 0.0);
}
"#;

const MATERIAL_DEFINES: [&str; 4] = ["TEXTURES", "NORMAL_MAP", "UV1", "VISIBILITY"];

/// One case: texture coordinates of both sets, the interpolated normal (w > 0: seen from
/// the front) and tangent (bitangent sign in w).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Case {
    uv0: [f32; 2],
    uv1: [f32; 2],
    n: [f32; 4],
    t: [f32; 4],
}

/// A texture of random bytes (40..=255 in colour channels: the sRGB decode bound is
/// relative, dark codes are where adapters stray most).
fn random_texture(name: &str, w: u32, h: u32, rng: &mut Rng) -> Texture {
    let rgba8 = (0..w * h * 4).map(|_| 40 + (rng.unit() * 216.0) as u8).collect();
    Texture { name: name.into(), width: w, height: h, rgba8 }
}

/// A texture reference with the default sampler (repeat, bilinear, trilinear mips).
fn tex_ref(texture: usize, tex_coord: u32, offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> TextureRef {
    TextureRef { tex_coord, transform: UvTransform { offset, rotation, scale }, ..TextureRef::new(texture) }
}

/// One material with every slot: base colour (8x8 sRGB, offset), an ORM image (4x8,
/// linear) read by metallic-roughness (scaled, offset) and occlusion (offset) as glTF
/// packs them, a normal map (8x4) and an emissive texture (8x8 sRGB) on UV set 1 rotated
/// by pi (where both readings of the extension's rotation direction agree: its README's
/// matrix and its example disagree, glTF issue 1563) and scaled. Every transform maps
/// coordinates on a 1/64 grid to texel positions on a 1/16-texel grid, which a texture
/// unit's 4 or more sub-texel bits hold exactly.
fn material_scene() -> Scene {
    let mut rng = Rng(0x00c0_10a7);
    let textures = vec![
        random_texture("base", 8, 8, &mut rng),
        random_texture("orm", 4, 8, &mut rng),
        random_texture("normal", 8, 4, &mut rng),
        random_texture("emissive", 8, 8, &mut rng),
    ];
    let material = Material {
        name: "every slot".into(),
        base_color: [0.8, 0.6, 0.9, 0.7],
        base_color_texture: Some(tex_ref(0, 0, [0.25, -0.125], 0.0, [1.0, 1.0])),
        roughness: 0.9,
        metallic: 0.75,
        metallic_roughness_texture: Some(tex_ref(1, 0, [0.125, 0.25], 0.0, [2.0, 0.5])),
        normal_texture: Some(tex_ref(2, 0, [0.0, 0.0], 0.0, [1.0, 1.0])),
        normal_scale: 0.8,
        occlusion_texture: Some(tex_ref(1, 0, [0.5, 0.0], 0.0, [1.0, 1.0])),
        occlusion_strength: 0.7,
        emissive: [0.5, 1.0, 0.25],
        emissive_strength: 3.0,
        emissive_texture: Some(tex_ref(3, 1, [0.0625, 0.0], std::f32::consts::PI, [1.0, 2.0])),
        ..Material::default()
    };
    let mut mesh = scenes::quad("quad", 1.0);
    mesh.tangents = vec![[1.0, 0.0, 0.0, 1.0]; 4];
    mesh.uvs1 = mesh.uvs.clone();
    let instances = vec![Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }];
    scenes::assemble("material", vec![mesh], (vec![material], textures), instances)
}

/// Seeded cases: coordinates on the 1/64 grid in [-1, 2) (repeat wraps them), random
/// unit normals with a tangent not orthogonal to them (the sample re-orthogonalises),
/// both bitangent signs, front and back.
fn material_cases() -> Vec<Case> {
    let mut rng = Rng(0x5eed_7a11);
    let grid = |rng: &mut Rng| (rng.range(-64.0, 128.0)).floor() / 64.0;
    (0..512)
        .map(|k| {
            let n = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::Z);
            let t = n.any_orthonormal_vector() + 0.2 * n;
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let front = if k % 3 == 0 { -1.0 } else { 1.0 };
            Case {
                uv0: [grid(&mut rng), grid(&mut rng)],
                uv1: [grid(&mut rng), grid(&mut rng)],
                n: [n.x, n.y, n.z, front],
                t: [t.x, t.y, t.z, sign],
            }
        })
        .collect()
}

/// `material_at` on the GPU over `cases`: 16 floats a case (base rgb, alpha, roughness,
/// metallic, normal xyz, occlusion, emission rgb, padding).
fn run_material_kernel(scene: &Scene, cases: &[Case]) -> Vec<[f32; 16]> {
    run_scene_kernel(scene, cases, MATERIAL_KERNEL)
}

/// What every scene kernel starts with: the scene's WGSL, the cases and the output, and
/// `main`'s head up to the case `c` (the kernel's body follows, then `}`).
const KERNEL_HEAD: &str = r#"
#include "common/scene.wgsl"
struct Case { uv0: vec2<f32>, uv1: vec2<f32>, n: vec4<f32>, t: vec4<f32> }
@group(3) @binding(0) var<storage, read> cases: array<Case>;
@group(3) @binding(1) var<storage, read_write> out: array<array<f32, 16>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&cases) { return; }
    let c = cases[i];
"#;

/// The kernel whose body (after [`KERNEL_HEAD`]) is `body`, over `cases` writing 16 floats
/// each, on the GPU with `scene`'s instances, materials and texture arrays.
fn run_scene_kernel(scene: &Scene, cases: &[Case], body: &str) -> Vec<[f32; 16]> {
    let kernel = format!("{KERNEL_HEAD}{body}");
    let ctx = gpu();
    let device = &ctx.device;
    let sg = SceneGpu::new(device, &ctx.queue, scene).unwrap();
    let textures = sg.textures.as_ref().expect("textured scene");
    let files = |p: &str| match p {
        "test.material_at" => Some(kernel.to_string()),
        _ => tiledlight_gpu::shader::embedded(p).map(str::to_owned),
    };
    let text = tiledlight_gpu::shader::preprocess_with(&files, "test.material_at", &MATERIAL_DEFINES)
        .expect("preprocess")
        .text;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("test.material_at"),
        source: wgpu::ShaderSource::Wgsl(text.into()),
    });
    let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
    };
    let empty = layout("test.material_at.view", &[]);
    let scene_layout = layout("test.material_at.scene", &[storage(24, true), storage(25, true)]);
    let io_layout = layout("test.material_at.io", &[storage(0, true), storage(1, false)]);
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input = tiledlight_gpu::util::buffer_init(device, "test.material_at.cases", bytemuck::cast_slice(cases), usage);
    let output = tiledlight_gpu::util::buffer_zeroed(device, "test.material_at.out", cases.len() as u64 * 64, usage);
    let group = |label, layout: &wgpu::BindGroupLayout, entries: &[wgpu::BindGroupEntry<'_>]| {
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries })
    };
    let empty_group = group("test.material_at.view", &empty, &[]);
    let scene_group = group(
        "test.material_at.scene",
        &scene_layout,
        &[tiledlight_gpu::util::buffer_entry(24, &sg.instances), tiledlight_gpu::util::buffer_entry(25, &sg.materials)],
    );
    let io_group = group(
        "test.material_at.io",
        &io_layout,
        &[tiledlight_gpu::util::buffer_entry(0, &input), tiledlight_gpu::util::buffer_entry(1, &output)],
    );
    let pipeline = tiledlight_gpu::util::compute_pipeline(
        device,
        "test.material_at",
        &[&empty, &scene_layout, &textures.layout, &io_layout],
        &module,
        &[],
    );
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &empty_group, &[]);
        pass.set_bind_group(1, &scene_group, &[]);
        pass.set_bind_group(2, &textures.bind_group, &[]);
        pass.set_bind_group(3, &io_group, &[]);
        pass.dispatch_workgroups((cases.len() as u32).div_ceil(64), 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    let out: Vec<f32> = tiledlight_gpu::readback::read_buffer(device, &ctx.queue, &output).expect("readback");
    out.chunks_exact(16).map(|c| c.try_into().unwrap()).collect()
}

/// How the CPU reads a texture (the right way, and the broken ways of the negative test).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Reading {
    Right,
    /// Broken: metallic from green, roughness from blue.
    SwappedChannels,
    /// Broken: every sample one texel to the right.
    OneTexelOff,
    /// Broken: the base colour's bytes taken as linear.
    NoSrgbDecode,
}

/// A bilinear sample at mip 0 of `tex` at `uv`, repeat-wrapped, each texel's channels
/// decoded by `decode` (channel index, byte) before filtering (as the texture unit
/// filters decoded values); with the spread (max - min) of the four texels per channel.
fn bilinear(tex: &Texture, uv: [f32; 2], decode: impl Fn(usize, u8) -> f64, texel_shift: i64) -> ([f64; 4], [f64; 4]) {
    let (w, h) = (tex.width as i64, tex.height as i64);
    // Texel centres sit at (i + 0.5) / size.
    let x = uv[0] as f64 * w as f64 - 0.5;
    let y = uv[1] as f64 * h as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let texel = |i: i64, j: i64| {
        let (i, j) = ((i + texel_shift).rem_euclid(w), j.rem_euclid(h));
        let at = ((j * w + i) * 4) as usize;
        [0, 1, 2, 3].map(|c| decode(c, tex.rgba8[at + c]))
    };
    let (i0, j0) = (x0 as i64, y0 as i64);
    let q = [texel(i0, j0), texel(i0 + 1, j0), texel(i0, j0 + 1), texel(i0 + 1, j0 + 1)];
    let weights = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
    let mut value = [0.0; 4];
    let mut spread = [0.0; 4];
    for c in 0..4 {
        value[c] = (0..4).map(|k| weights[k] * q[k][c]).sum();
        let (lo, hi) = q.iter().fold((f64::MAX, f64::MIN), |(lo, hi), t| (lo.min(t[c]), hi.max(t[c])));
        spread[c] = hi - lo;
    }
    (value, spread)
}

/// `KHR_texture_transform` written from the extension: `T(offset) R(rotation) S(scale)`
/// with its README's rotation matrix (columns (cos, sin) and (-sin, cos)).
fn transformed(t: &UvTransform, uv: [f32; 2]) -> [f32; 2] {
    let (u, v) = (uv[0] as f64 * t.scale[0] as f64, uv[1] as f64 * t.scale[1] as f64);
    let (s, c) = (t.rotation as f64).sin_cos();
    [(c * u - s * v + t.offset[0] as f64) as f32, (s * u + c * v + t.offset[1] as f64) as f32]
}

/// What an adapter's texture unit adds to a filtered sample beyond the filter weights.
#[derive(Clone, Copy)]
struct Precision {
    /// An sRGB channel's decode error, relative to the value.
    srgb_error: f64,
    /// A linear UNORM channel's error after filtering: lavapipe filters 8-bit texels in 8-bit
    /// fixed point and returns the result at that precision (its roughness reads 180/255
    /// exactly where the bilinear blend is 179.47/255), so one step, 1/255; elsewhere the
    /// decode and arithmetic, 1e-5.
    linear_filter: f64,
}

/// The expected material sample of one case, with a tolerance per output: 16 values like
/// the kernel's rows.
///
/// Tolerances, per value: the filter's weights are quantised to the texture unit's
/// sub-texel precision (Vulkan's minimum is 4 bits; lavapipe and NVIDIA have 8): the
/// coordinates here sit on a 1/16-texel grid, held exactly, but the pi rotation's sine
/// (8.7e-8, not 0 in f32) moves them by up to 1e-6 texel, so one quantum (2^-8) of the four
/// texels' spread; a linear channel's filtered precision ([`Precision::linear_filter`]); an
/// sRGB channel
/// the adapter's decode error relative to the value (`LAVAPIPE_SRGB_DECODE_ERROR` on
/// lavapipe, measured by `gbuffer_texel.rs`; 1e-2 elsewhere, the bound that test asserts).
/// The normal: each map channel's tolerance d moves m = (2 t - 1) (s, s, 1) by 2 d (s, s, 1),
/// which moves the unit normal by at most twice that over |m|.
fn expected_material(scene: &Scene, case: &Case, reading: Reading, adapter: Precision) -> ([f64; 16], [f64; 16]) {
    let m = &scene.materials[0];
    let sample = |r: &TextureRef, srgb: bool| {
        let uv = if r.tex_coord == 1 { case.uv1 } else { case.uv0 };
        let shift = i64::from(reading == Reading::OneTexelOff);
        let decode = |c: usize, b: u8| {
            let linear = b as f64 / 255.0;
            if srgb && c < 3 {
                srgb_to_linear(linear as f32) as f64
            } else {
                linear
            }
        };
        let (v, spread) = bilinear(&scene.textures[r.texture], transformed(&r.transform, uv), decode, shift);
        let tol: [f64; 4] = std::array::from_fn(|c| {
            let decode = if srgb && c < 3 { adapter.srgb_error * v[c] } else { adapter.linear_filter };
            spread[c] * 2f64.powi(-8) + decode + 1e-6
        });
        (v, tol)
    };
    let (mut out, mut tol) = ([0.0; 16], [0.0; 16]);
    let srgb_base = reading != Reading::NoSrgbDecode;
    let (b, bt) = sample(m.base_color_texture.as_ref().unwrap(), srgb_base);
    for c in 0..4 {
        out[c] = m.base_color[c] as f64 * b[c];
        tol[c] = m.base_color[c] as f64 * bt[c];
    }
    let (mr, mrt) = sample(m.metallic_roughness_texture.as_ref().unwrap(), false);
    // glTF: roughness in green, metalness in blue.
    let (g, bl) = if reading == Reading::SwappedChannels { (2, 1) } else { (1, 2) };
    out[4] = m.roughness as f64 * mr[g];
    tol[4] = m.roughness as f64 * mrt[g];
    out[5] = m.metallic as f64 * mr[bl];
    tol[5] = m.metallic as f64 * mrt[bl];
    // The normal map (glTF: tangent space, (2 t - 1) scaled in x and y by normalTexture.scale).
    let (nt, ntt) = sample(m.normal_texture.as_ref().unwrap(), false);
    let n = Vec3::from_slice(&case.n[..3]).as_dvec3().normalize();
    let t_in = Vec3::from_slice(&case.t[..3]).as_dvec3();
    let t = (t_in - n * n.dot(t_in)).normalize();
    let bt_ = n.cross(t) * case.t[3] as f64;
    let s = m.normal_scale as f64;
    let mv = glam::DVec3::new((2.0 * nt[0] - 1.0) * s, (2.0 * nt[1] - 1.0) * s, 2.0 * nt[2] - 1.0);
    let p = t * mv.x + bt_ * mv.y + n * mv.z;
    let front = if case.n[3] > 0.0 { 1.0 } else { -1.0 };
    let normal = p.normalize() * front;
    let dm = glam::DVec3::new(2.0 * ntt[0] * s, 2.0 * ntt[1] * s, 2.0 * ntt[2]).length();
    for c in 0..3 {
        out[6 + c] = normal[c];
        tol[6 + c] = 2.0 * dm / p.length() + 1e-5;
    }
    // Occlusion: red, `1 + strength (o - 1)`.
    let (o, ot) = sample(m.occlusion_texture.as_ref().unwrap(), false);
    let k = m.occlusion_strength as f64;
    out[9] = 1.0 + k * (o[0] - 1.0);
    tol[9] = k * ot[0];
    let (e, et) = sample(m.emissive_texture.as_ref().unwrap(), true);
    for c in 0..3 {
        let f = m.emissive[c] as f64 * m.emissive_strength as f64;
        out[10 + c] = f * e[c];
        tol[10 + c] = f * et[c];
    }
    (out, tol)
}

const FIELDS: [&str; 13] = [
    "base.r",
    "base.g",
    "base.b",
    "alpha",
    "roughness",
    "metallic",
    "normal.x",
    "normal.y",
    "normal.z",
    "occlusion",
    "emission.r",
    "emission.g",
    "emission.b",
];

/// Every (case, value) where the GPU's row differs from the CPU's expectation (read
/// `reading`) beyond its tolerance.
fn material_mismatches(scene: &Scene, cases: &[Case], rows: &[[f32; 16]], reading: Reading) -> Vec<String> {
    let adapter = if is_lavapipe(gpu()) {
        Precision { srgb_error: LAVAPIPE_SRGB_DECODE_ERROR as f64, linear_filter: 1.0 / 255.0 }
    } else {
        Precision { srgb_error: 1e-2, linear_filter: 1e-5 }
    };
    let mut bad = Vec::new();
    for (i, (case, row)) in cases.iter().zip(rows).enumerate() {
        let (want, tol) = expected_material(scene, case, reading, adapter);
        for (k, field) in FIELDS.iter().enumerate() {
            let err = (row[k] as f64 - want[k]).abs();
            if err.is_nan() || err > tol[k] {
                bad.push(format!(
                    "case {i} ({case:?}): {field} GPU {} expected {} (error {err:.3e}, tolerance {:.3e})",
                    row[k], want[k], tol[k]
                ));
            }
        }
    }
    bad
}

/// `material_at` on the GPU against the material computed from the texture bytes, every
/// slot; the comparison rejects metallic and roughness swapped, a sample one texel off
/// and a base colour taken as linear.
#[test]
fn material_sample_matches_the_texture_bytes() {
    let scene = material_scene();
    let cases = material_cases();
    let rows = run_material_kernel(&scene, &cases);
    let bad = material_mismatches(&scene, &cases, &rows, Reading::Right);
    assert!(
        bad.is_empty(),
        "{} values of {} cases differ from the texture bytes:\n{}",
        bad.len(),
        cases.len(),
        bad[..bad.len().min(12)].join("\n")
    );
    // The cases must reach both UV sets' wrap and both sides.
    assert!(cases.iter().any(|c| c.uv0[0] < 0.0) && cases.iter().any(|c| c.uv1[1] > 1.0));
    for (what, reading) in [
        ("metallic and roughness swapped", Reading::SwappedChannels),
        ("one texel off", Reading::OneTexelOff),
        ("a base colour without sRGB decode", Reading::NoSrgbDecode),
    ] {
        let bad = material_mismatches(&scene, &cases, &rows, reading);
        eprintln!("{what}: {} values rejected", bad.len());
        assert!(bad.len() * 4 > cases.len(), "{what} must be rejected ({} values of {} cases)", bad.len(), cases.len());
    }
}

/// The texture kernel: `material_color` of material `u32(n.x)` at `uv0` with screen
/// gradients `t.xy` (x) and `t.zw` (y): the texture arrays' sampling, filter and mip level
/// included; then `material_at`'s roughness, metallic, occlusion and emission (the
/// materials have no map in those slots: the factors, 1 and 0 exactly).
const TEXTURE_KERNEL: &str = r#"
    let sets = UvSets(c.uv0, c.t.xy, c.t.zw, c.uv0, c.t.xy, c.t.zw);
    let mi = u32(c.n.x);
    let b = material_color(mi, sets);
    let ms = material_at(mi, sets, b, vec3<f32>(0.0, 0.0, 1.0), vec4<f32>(1.0, 0.0, 0.0, 1.0), true);
    out[i] = array<f32, 16>(b.x, b.y, b.z, b.w, ms.roughness, ms.metallic, ms.occlusion,
        ms.emission.x, ms.emission.y, ms.emission.z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
}
"#;

/// Twelve materials, each with a base-colour image of its own size (twelve sRGB classes:
/// more than the eight arrays, so some share a padded layer; five sizes not powers of
/// two) and its own sampler (every wrap on each axis, nearest and linear, no, nearest and
/// linear mipmaps).
fn texture_array_scene() -> Scene {
    use tiledlight_scene::{Filter, Sampler, Wrap};
    let mut rng = Rng(0x7e57_a77a);
    let sizes =
        [(16, 16), (8, 8), (5, 3), (7, 7), (13, 9), (32, 8), (33, 17), (4, 16), (64, 64), (2, 2), (20, 12), (1, 9)];
    let wraps = [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge];
    let filters = [Filter::Nearest, Filter::Linear];
    let textures: Vec<Texture> =
        sizes.iter().enumerate().map(|(k, &(w, h))| random_texture(&format!("t{k}"), w, h, &mut rng)).collect();
    let materials = (0..sizes.len())
        .map(|k| {
            let sampler = Sampler {
                wrap_u: wraps[k % 3],
                wrap_v: wraps[(k / 3) % 3],
                mag: filters[k % 2],
                min: filters[(k / 2) % 2],
                mipmap: [None, Some(Filter::Nearest), Some(Filter::Linear)][k % 3],
            };
            Material {
                name: format!("m{k}"),
                base_color: [1.0; 4],
                base_color_texture: Some(TextureRef { sampler, ..TextureRef::new(k) }),
                ..Material::default()
            }
        })
        .collect();
    let instances = vec![Instance { mesh: 0, material: 0, transform: Mat4::IDENTITY }];
    scenes::assemble("texture arrays", vec![scenes::quad("quad", 1.0)], (materials, textures), instances)
}

/// How the CPU reads the arrays' textures in [`texture_mismatches`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum TexReading {
    Right,
    /// Broken: one mip level finer than asked (gradients halved).
    LevelOff,
    /// Broken: every wrap taken as repeat.
    RepeatOnly,
}

/// Values of `rows` (the texture kernel over `cases`) that differ from the CPU twin's
/// sample read as `reading`, beyond the adapter's sRGB decode error.
fn texture_mismatches(scene: &Scene, cases: &[Case], rows: &[[f32; 16]], reading: TexReading) -> Vec<String> {
    use tiledlight_cull::texture::{Mips, WRAP_REPEAT};
    let srgb_error = if is_lavapipe(gpu()) { LAVAPIPE_SRGB_DECODE_ERROR } else { 1e-2 };
    let mips: Vec<Mips> = scene.textures.iter().map(|t| Mips::new(t.width, t.height, &t.rgba8, true)).collect();
    let mut bad = Vec::new();
    for (i, (c, row)) in cases.iter().zip(rows).enumerate() {
        let m = c.n[0] as usize;
        let t = scene.materials[m].base_color_texture.as_ref().unwrap();
        let mut s = tiledlight_gpu::scene_gpu::texture_sampling(&t.sampler);
        if reading == TexReading::RepeatOnly {
            s.wrap = [WRAP_REPEAT; 2];
        }
        let scale = if reading == TexReading::LevelOff { 0.5 } else { 1.0 };
        let (dx, dy) = (glam::Vec2::new(c.t[0], c.t[1]) * scale, glam::Vec2::new(c.t[2], c.t[3]) * scale);
        let want = mips[t.texture].sample(s, glam::Vec2::from(c.uv0), dx, dy);
        for k in 0..4 {
            let err = (row[k] - want[k]).abs();
            if err.is_nan() || err > srgb_error * want[k].max(0.05) + 1e-4 {
                bad.push(format!("case {i} (material {m}, {c:?}): channel {k} GPU {} CPU {}", row[k], want[k]));
            }
        }
        // A slot without its bit is never read.
        let mat = &scene.materials[m];
        let unlit = [mat.roughness, mat.metallic, 1.0, 0.0, 0.0, 0.0];
        if row[4..10] != unlit {
            bad.push(format!("case {i} (material {m}): roughness, metallic, occlusion, emission {:?}", &row[4..10]));
        }
    }
    bad
}

/// The texture arrays on the GPU read every image as the CPU twin
/// (`tiledlight_cull::texture`) does: twelve image sizes in eight arrays (so smaller images
/// sit padded in larger layers and must wrap within their own size), every wrap mode,
/// filter and mipmap mode, coordinates up to 40 periods from the origin and gradients
/// from magnification to past the last level. The comparison rejects a sample one level
/// off and wraps all taken as repeat.
#[test]
fn texture_arrays_sample_every_image_as_the_cpu_twin() {
    let scene = texture_array_scene();
    let sg = SceneGpu::new(&gpu().device, &gpu().queue, &scene).unwrap();
    let plan = &sg.textures.as_ref().expect("textured").plan;
    assert_eq!(plan.arrays.len(), tiledlight_gpu::texture_arrays::MATERIAL_ARRAYS);
    assert!(plan.padding_bytes() > 0, "the test must put images in padded layers");
    drop(sg);
    let mut rng = Rng(0x5a3b_1e55);
    let cases: Vec<Case> = (0..scene.materials.len() * 96)
        .map(|k| {
            let m = k % scene.materials.len();
            let far = if k % 7 == 0 { 40.0 } else { 3.0 };
            // Gradients of 2^-4 to 2^7 texels a pixel of a 16-texel image.
            let g = 2f32.powf(rng.range(-4.0, 7.0)) / 16.0;
            let a = rng.range(0.0, std::f32::consts::TAU);
            Case {
                uv0: [rng.range(-far, far), rng.range(-far, far)],
                uv1: [0.0; 2],
                n: [m as f32, 0.0, 0.0, 1.0],
                t: [g * a.cos(), g * a.sin(), -g * a.sin() * 0.5, g * a.cos() * 0.5],
            }
        })
        .collect();
    let rows = run_scene_kernel(&scene, &cases, TEXTURE_KERNEL);
    let bad = texture_mismatches(&scene, &cases, &rows, TexReading::Right);
    assert!(
        bad.is_empty(),
        "{} values of {} cases differ from the CPU twin:\n{}",
        bad.len(),
        cases.len(),
        bad[..bad.len().min(12)].join("\n")
    );
    for reading in [TexReading::LevelOff, TexReading::RepeatOnly] {
        let bad = texture_mismatches(&scene, &cases, &rows, reading);
        eprintln!("{reading:?}: {} values rejected", bad.len());
        assert!(bad.len() * 10 > cases.len(), "{reading:?} must be rejected ({} of {} cases)", bad.len(), cases.len());
    }
}
