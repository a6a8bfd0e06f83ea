//! glTF metallic-roughness materials in full, through the loader and every renderer:
//! normal maps (MikkTSpace tangents), metallic-roughness and occlusion textures, emission
//! (`KHR_materials_emissive_strength`), the second texture coordinate set,
//! `KHR_texture_transform`, sampler wrap modes and `KHR_mesh_quantization`. Every scene is a
//! glTF file this test writes (JSON with the buffer and PNG images as data URIs) and loads
//! with `tiledlight_scene::load_gltf`, so the loader's reading is under test too.
//!
//! Each image is checked against a CPU expectation computed pixel by pixel with the CPU
//! twins (`tiledlight_cull::material`, `tiledlight_cull::brdf`) at the position rebuilt from
//! the brute-force depth, within 3e-3 relative (floor 1e-3): the f16 HDR target rounds to
//! 2^-11 relative, and the GPU interpolates what the CPU rebuilds from depth (about 1e-5
//! apart), as in `heatmap_and_brdf.rs`'s BRDF test. sRGB texels are expected as ranges: a
//! conforming GPU may decode byte b anywhere between the linear values of b - 0.5 and
//! b + 0.5 (llvmpipe decodes 40 0.5% low and 90 0.6% high; `independent.rs` measured it),
//! and shading grows with the albedo and the emission, so the GPU value must lie between
//! the CPU values at the two ends, give or take the tolerance. Textures are sampled nearest and pixels
//! within 3% of a texel edge are skipped (interpolated and rebuilt coordinates may pick
//! different texels there). Forward+ and Tiled Deferred are then compared with brute force
//! under the suite's tolerances (`tiledlight_tests::compare`: Forward+ sums the same lights
//! in another order; Tiled Deferred stores an 8-bit sRGB albedo, a packed 14-bit octahedral normal and, for
//! emission and occlusion, an f16 emission target).

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3, Vec4};
use serde_json::{json, Value};
use tiledlight_cull::brdf::{brdf_cos, windowed_attenuation, Surface};
use tiledlight_cull::material::{emission, normal_from_map, occlusion, roughness_metallic, unlit_term};
use tiledlight_cull::reference::pixel_view_position;
use tiledlight_cull::{Camera, Light};
use tiledlight_deferred::gbuffer::EMISSION_FORMAT_SMALL;
use tiledlight_frame::{DeferredFrame, Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::bindings::layout_entries;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::{MaterialFeatures, SceneGpu, TEXTURE_BINDINGS};
use tiledlight_scene::{load_gltf, Scene, UvTransform, Wrap};
use tiledlight_tests::compare::{
    assert_matches_reference_frame, assert_visibility_matches, render_frame, visibility_frames, visibility_matches,
    Frame, DEFERRED_SMALL_EMISSION_VS_REFERENCE, DEFERRED_VS_REFERENCE, FORWARD_VS_REFERENCE, RASTER_POSITION_ERROR_PX,
    VISIBILITY_VS_REFERENCE,
};
use tiledlight_tests::subpixel::{self, shifted_lookups};

use tiledlight_tests::images::{linear_to_srgb, srgb_to_linear};
use tiledlight_tests::{gpu, scenes};

const W: u32 = 128;
const H: u32 = 96;

// ---- writing glTF files ----

use tiledlight_gltf_writer::{png, png_data_uri, Buffer, CLAMP, I16, I8, LINEAR, MIRROR, NEAREST, REPEAT, U16, U8};

/// A glTF document under construction: one buffer (the shared test-support writer's), images
/// as PNG data URIs, textures and samplers.
#[derive(Default)]
struct Doc {
    buf: Buffer,
    images: Vec<Value>,
    textures: Vec<Value>,
    samplers: Vec<Value>,
}

impl Doc {
    /// An accessor over `bytes`, each element `stride` bytes apart.
    fn accessor(&mut self, bytes: &[u8], component: (u32, bool), shape: (usize, &str, usize)) -> usize {
        self.buf.accessor(bytes, component, shape)
    }

    /// A tightly packed float accessor of `ty`.
    fn floats(&mut self, v: &[f32], ty: &str) -> usize {
        self.buf.floats(v, ty)
    }

    fn indices(&mut self, v: &[u16]) -> usize {
        self.buf.indices_u16(v)
    }

    /// A texture of `w` x `h` RGBA8 texels (a PNG image) read with a sampler of `wrap`
    /// (s, t) and nearest filtering; returns its index.
    fn texture(&mut self, w: u32, h: u32, rgba: &[u8], wrap: (u32, u32)) -> usize {
        self.images.push(json!({"uri": png_data_uri(&png(w, h, rgba))}));
        self.samplers.push(json!({"magFilter": NEAREST, "minFilter": NEAREST, "wrapS": wrap.0, "wrapT": wrap.1}));
        self.textures.push(json!({"source": self.images.len() - 1, "sampler": self.samplers.len() - 1}));
        self.textures.len() - 1
    }

    /// Writes `name.gltf` (everything embedded) drawing `prim` with `material` at the origin.
    fn write(self, dir: &Path, name: &str, prim: Value, material: Value, extensions: &[&str]) -> PathBuf {
        let mut prim = prim;
        prim["material"] = json!(0);
        let mut root = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"name": name, "primitives": [prim]}],
            "materials": [material],
            "buffers": [{"byteLength": self.buf.data.len(), "uri": format!("data:application/octet-stream;base64,{}", tiledlight_gltf_writer::base64(&self.buf.data))}],
            "bufferViews": self.buf.views,
            "accessors": self.buf.accessors,
        });
        for (key, list) in [("images", self.images), ("textures", self.textures), ("samplers", self.samplers)] {
            if !list.is_empty() {
                root[key] = json!(list);
            }
        }
        if !extensions.is_empty() {
            root["extensionsUsed"] = json!(extensions);
        }
        if extensions.contains(&"KHR_mesh_quantization") {
            root["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
        }
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
        path
    }
}

/// The quad x, y in [-1, 1], z = 0, facing +Z, as float attributes: set 0 maps x to u and y
/// down the image (`uv0_at`), set 1 (when asked) is `uv1_at`. No tangents: MikkTSpace makes
/// them when a normal map needs them.
fn quad(doc: &mut Doc, uv1: bool) -> Value {
    let corners = [[-1.0f32, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let pos: Vec<f32> = corners.iter().flat_map(|c| [c[0], c[1], 0.0]).collect();
    let nrm: Vec<f32> = corners.iter().flat_map(|_| [0.0, 0.0, 1.0]).collect();
    let uv0: Vec<f32> = corners.iter().flat_map(|c| uv0_at(Vec2::from(*c)).to_array()).collect();
    let p = doc.floats(&pos, "VEC3");
    let n = doc.floats(&nrm, "VEC3");
    let t = doc.floats(&uv0, "VEC2");
    let i = doc.indices(&[0, 1, 2, 0, 2, 3]);
    let mut prim = json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t}, "indices": i});
    if uv1 {
        let uv1: Vec<f32> = corners.iter().flat_map(|c| uv1_at(Vec2::from(*c)).to_array()).collect();
        prim["attributes"]["TEXCOORD_1"] = json!(doc.floats(&uv1, "VEC2"));
    }
    prim
}

/// Texture coordinate set 0 at quad point (x, y): u along +x, v down (glTF images run down).
fn uv0_at(p: Vec2) -> Vec2 {
    Vec2::new((p.x + 1.0) * 0.5, (1.0 - p.y) * 0.5)
}

/// Set 1: a different mapping (u along +y, v along +x, over 1.5 units), so a texture read
/// with it lands elsewhere than with set 0.
fn uv1_at(p: Vec2) -> Vec2 {
    Vec2::new((p.y + 1.0) * 0.75, (p.x + 1.0) * 0.75)
}

fn load(path: &Path) -> Scene {
    load_gltf(path, 0.01).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

// ---- the CPU expectation ----

/// The texel (x, y) a nearest-filtered `w` x `h` texture returns at `uv` with `wrap` (s, t),
/// as Vulkan wraps texel coordinates; None within 3% of a texel edge.
fn nearest_texel(uv: Vec2, (w, h): (u32, u32), wrap: (Wrap, Wrap)) -> Option<(u32, u32)> {
    let axis = |c: f32, n: u32, wrap: Wrap| {
        let t = c * n as f32;
        let f = t - t.floor();
        if !(0.03..=0.97).contains(&f) {
            return None;
        }
        let i = t.floor() as i64;
        let n = i64::from(n);
        Some(match wrap {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        } as u32)
    };
    Some((axis(uv.x, w, wrap.0)?, axis(uv.y, h, wrap.1)?))
}

/// A linear texel of `rgba` (data textures: no decoding).
fn texel(rgba: &[u8], w: u32, (x, y): (u32, u32)) -> Vec4 {
    let i = ((y * w + x) * 4) as usize;
    Vec4::from_array([0, 1, 2, 3].map(|k| f32::from(rgba[i + k]) / 255.0))
}

/// The lowest and highest linear colour a GPU may decode sRGB texel (x, y) of `rgba` to:
/// each byte b anywhere between b - 0.5 and b + 0.5.
fn srgb_range(rgba: &[u8], w: u32, (x, y): (u32, u32)) -> [Vec3; 2] {
    let i = ((y * w + x) * 4) as usize;
    let decode = |o: f32| {
        Vec3::from_array([0, 1, 2].map(|k| srgb_to_linear(((f32::from(rgba[i + k]) + o) / 255.0).clamp(0.0, 1.0))))
    };
    [decode(-0.5), decode(0.5)]
}

/// What the CPU says a quad point's surface is.
#[derive(Clone, Copy)]
struct Expected {
    albedo: Vec3,
    roughness: f32,
    metallic: f32,
    normal: Vec3,
    occlusion: f32,
    emission: Vec3,
}

impl Default for Expected {
    fn default() -> Self {
        Self { albedo: Vec3::ONE, roughness: 1.0, metallic: 1.0, normal: Vec3::Z, occlusion: 1.0, emission: Vec3::ZERO }
    }
}

/// The CPU's linear HDR at world point `p` seen from `eye`.
fn shade_cpu(e: &Expected, p: Vec3, eye: Vec3, lights: &[Light], ambient: Vec3) -> Vec3 {
    let v = (eye - p).normalize();
    let s = Surface { albedo: e.albedo, roughness: e.roughness, metallic: e.metallic };
    let mut c = unlit_term(ambient, e.albedo, e.occlusion, e.emission);
    for l in lights {
        let to = l.position - p;
        let d2 = to.length_squared();
        if d2 >= l.radius * l.radius {
            continue;
        }
        c += l.color * l.intensity * windowed_attenuation(d2, l.radius) * brdf_cos(e.normal, v, to / d2.sqrt(), &s);
    }
    c
}

fn camera() -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::ZERO,
        Vec3::Y,
        60f32.to_radians(),
        W as f32 / H as f32,
        0.1,
        None,
    )
    .unwrap()
}

/// A pixel compared with the CPU: its index, set-0 coordinates and world position.
#[derive(Clone, Copy)]
struct Checked {
    i: usize,
    uv: Vec2,
    p: Vec3,
}

/// The ends of an expectation: equal unless an sRGB texel makes it a range
/// ([`srgb_range`]); the shading grows from the first to the second.
type Ends = [Expected; 2];

fn exact(e: Expected) -> Ends {
    [e, e]
}

/// One scene's three images.
struct Frames {
    brute: Frame,
    forward: Frame,
    deferred: Frame,
}

/// Renders `scene` lit by `lights` (ambient `ambient`) with brute force, Forward+, Tiled
/// Deferred and the visibility buffer (its material evaluated in compute from
/// reconstructed attributes, textures by explicit gradients); checks brute force against `expect` (per quad point: its position and set-0
/// coordinates; None to skip; else the two ends of the expected surface) pixel by pixel and
/// the tiled methods against brute force.
/// Returns the frames and the checked pixels.
fn render_and_check(
    name: &str,
    scene: &Scene,
    (lights, ambient): (&[Light], Vec3),
    expect: impl Fn(Vec3, Vec2) -> Option<Ends>,
) -> (Frames, Vec<Checked>) {
    let ctx = gpu();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, lights).unwrap();
    let cam = camera();
    let fs = |method| FrameSettings { method, ambient, ..Default::default() };
    let mut bf = FrameRenderer::new(ctx, &sg, &lb, W, H, fs(Method::BruteForce { cutoff: true })).unwrap();
    let brute = render_frame(ctx, &mut bf, &sg, &cam);
    let depth = bf.read_depth(ctx).unwrap();
    let inv_view = cam.view().inverse();
    let (mut checked, mut worst) = (Vec::new(), 0.0f32);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let Some(pv) = pixel_view_position(&cam, W, H, x, y, depth[i]) else { continue };
            let p = (inv_view * pv.extend(1.0)).truncate();
            let uv = uv0_at(p.truncate());
            let Some([lo, hi]) = expect(p, uv) else { continue };
            let (lo, hi) =
                (shade_cpu(&lo, p, cam.eye(), lights, ambient), shade_cpu(&hi, p, cam.eye(), lights, ambient));
            for c in 0..3 {
                let got = brute.hdr[i][c];
                let outside = (lo[c].min(hi[c]) - got).max(got - lo[c].max(hi[c])).max(0.0);
                let err = outside / got.abs().max(1e-3);
                worst = worst.max(err);
                assert!(
                    err <= 3e-3,
                    "{name}: pixel ({x}, {y}) channel {c}: GPU {got}, CPU {} to {} (uv {uv})",
                    lo[c],
                    hi[c]
                );
            }
            checked.push(Checked { i, uv, p });
        }
    }
    eprintln!("{name}: brute force vs CPU, {} pixels, worst relative error {worst:.2e}", checked.len());
    assert!(checked.len() > (W * H / 8) as usize, "{name}: too few pixels checked ({})", checked.len());
    let (forward, deferred) = tiled_against_brute(name, (&sg, &lb, &cam), ambient, (&brute, &depth), false);
    (Frames { brute, forward, deferred }, checked)
}

/// Forward+, Tiled Deferred and the visibility buffer (both rasters) against `brute` (brute
/// force's frame, `depth` its depth) with the tolerances every material test uses; returns
/// Forward+'s and Tiled Deferred's frames. Tiled Deferred's reference allows what the packed
/// normal may move diffuse light ([`Frame::allow_gbuffer_normals`]) and, with `surface`,
/// what the rounding of the whole surface the G-buffer holds may move every lobe
/// (`surface_allowance`: normal, roughness and metallic, for scenes whose metallic values
/// are not on the G-buffer's 1/15 grid).
fn tiled_against_brute(
    name: &str,
    (sg, lb, cam): (&SceneGpu, &LightBuffers, &Camera),
    ambient: Vec3,
    (brute, depth): (&Frame, &[f32]),
    surface: bool,
) -> (Frame, Frame) {
    let ctx = gpu();
    let fs = |method| FrameSettings { method, ambient, ..Default::default() };
    let mut forward = FrameRenderer::new(ctx, sg, lb, W, H, fs(Method::ForwardPlus)).unwrap();
    let forward = render_frame(ctx, &mut forward, sg, cam);
    assert_matches_reference_frame(&format!("{name}-forward"), W, brute, &forward, FORWARD_VS_REFERENCE);
    let mut dr = FrameRenderer::new(ctx, sg, lb, W, H, fs(Method::TiledDeferred)).unwrap();
    let deferred = render_frame(ctx, &mut dr, sg, cam);
    let mut reference = brute.clone().allow_gbuffer_normals(depth, W, cam, &lb.packed);
    if surface {
        let gbuffer = tiledlight_tests::gbuffer::read_gbuffer(ctx, &dr, (W, H));
        reference = reference
            .with_allowance(&tiledlight_tests::gbuffer::surface_allowance(&gbuffer, depth, W, cam, &lb.packed));
    }
    let small_emission = dr.passes::<DeferredFrame>().expect("Tiled Deferred").gbuffer().emission_format()
        == Some(EMISSION_FORMAT_SMALL);
    let tolerance = if small_emission { DEFERRED_SMALL_EMISSION_VS_REFERENCE } else { DEFERRED_VS_REFERENCE };
    assert_matches_reference_frame(&format!("{name}-deferred"), W, &reference, &deferred, tolerance);
    let (positioned, with_shift) = visibility_reference((sg, lb, cam), ambient, (brute, depth));
    let covered = depth.iter().filter(|&&d| d > 0.0).count();
    for (raster, visibility, ties) in visibility_frames(ctx, (sg, lb, cam), (W, H), fs(Method::Visibility)) {
        let name = format!("{name}-visibility-{}", raster.name());
        let (without, reference) = (positioned.clone().forgive_hdr(&ties).0, with_shift.clone().forgive_hdr(&ties).0);
        let visibility = shifted_lookups(&name, (&without, &reference), visibility, VISIBILITY_VS_REFERENCE, covered);
        assert_visibility_matches(&name, W, (&reference, &visibility), false);
    }
    (forward, deferred)
}

/// Brute force's frame `brute` (depth `depth`) as the visibility buffer's reference, before
/// and after the sub-pixel shift's texture lookups (`tiledlight_tests::subpixel`): both with
/// the lighting's position allowance ([`Frame::allow_position_error`]).
fn visibility_reference(
    (sg, lb, cam): (&SceneGpu, &LightBuffers, &Camera),
    ambient: Vec3,
    (brute, depth): (&Frame, &[f32]),
) -> (Frame, Frame) {
    let ctx = gpu();
    let positioned = brute.clone().allow_position_error(depth, W, (cam, &lb.packed), RASTER_POSITION_ERROR_PX);
    let settings = FrameSettings { method: Method::BruteForce { cutoff: true }, ambient, ..Default::default() };
    let mut bf = FrameRenderer::new(ctx, sg, lb, W, H, settings).unwrap();
    let shifted = subpixel::shifted_frames(ctx, &mut bf, sg, cam, H);
    let with_shift = positioned.clone().allow_subpixel_shift(depth, W, &shifted);
    (positioned, with_shift)
}

/// Mean r + g + b of `frame`'s pixels among `checked` whose uv passes `pick`.
fn mean_of(frame: &Frame, checked: &[Checked], pick: impl Fn(Vec2) -> bool) -> f32 {
    let v: Vec<f32> = checked
        .iter()
        .filter(|c| pick(c.uv))
        .map(|c| frame.hdr[c.i][0] + frame.hdr[c.i][1] + frame.hdr[c.i][2])
        .collect();
    assert!(!v.is_empty());
    v.iter().sum::<f32>() / v.len() as f32
}

// ---- the tests ----

/// A normal map whose left half leans 45 degrees towards +x (+tangent) and right half
/// towards -x, lit from far to the right: the left half faces the light (n.l about 0.84),
/// the right half faces away (lit by ambient only), the opposite of what the flat quad's
/// own normal gives (the right half is nearer the light). The swapped map swaps the
/// halves. Tangents come from MikkTSpace (the file has none).
#[test]
fn normal_map_moves_the_lighting() {
    let dir = tempfile::tempdir().unwrap();
    let toward_plus_x = [218u8, 128, 218, 255];
    let toward_minus_x = [37u8, 128, 218, 255];
    let light = Light::point(Vec3::new(4.0, 0.0, 1.0), Vec3::ONE, 40.0, 0.01).unwrap();
    let ambient = Vec3::splat(0.05);
    for (k, map) in [[toward_plus_x, toward_minus_x], [toward_minus_x, toward_plus_x]].into_iter().enumerate() {
        let mut doc = Doc::default();
        let prim = quad(&mut doc, false);
        let tex = doc.texture(2, 1, &map.concat(), (REPEAT, REPEAT));
        let material = json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.6},
            "normalTexture": {"index": tex, "scale": 1.0}
        });
        let scene = load(&doc.write(dir.path(), &format!("normal{k}"), prim, material, &[]));
        let t = scene.meshes[0].tangents[0];
        assert!((t[0] - 1.0).abs() < 1e-5 && t[3] == -1.0, "MikkTSpace tangent {t:?}");
        let rgba = map.concat();
        let (frames, checked) = render_and_check(&format!("normal-map-{k}"), &scene, (&[light], ambient), |_, uv| {
            let texel_at = nearest_texel(uv, (2, 1), (Wrap::Repeat, Wrap::Repeat))?;
            let tx = texel(&rgba, 2, texel_at).truncate();
            Some(exact(Expected {
                albedo: Vec3::splat(0.8),
                roughness: 0.6,
                metallic: 0.0,
                normal: normal_from_map(Vec3::Z, Vec4::from(t), tx, 1.0),
                ..Default::default()
            }))
        });
        let left = mean_of(&frames.brute, &checked, |uv| uv.x < 0.5);
        let right = mean_of(&frames.brute, &checked, |uv| uv.x > 0.5);
        eprintln!("normal map {k}: left {left:.4}, right {right:.4}");
        if k == 0 {
            assert!(left > 3.0 * right, "the half leaning towards the light must be brighter: {left} vs {right}");
        } else {
            assert!(right > 3.0 * left, "the swapped map must swap the halves: {left} vs {right}");
        }
    }
}

/// Metallic-roughness (left: rough dielectric, right: smooth metal) and occlusion (top:
/// none, bottom: 0.25 at strength 0.8) textures over a base colour factor, lit by two
/// lights and a strong ambient: each pixel as the CPU BRDF predicts, and each texture
/// visibly changes its half.
#[test]
fn metallic_roughness_and_occlusion_follow_the_cpu_brdf() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = Doc::default();
    let prim = quad(&mut doc, false);
    let mr = [[0u8, 255, 0, 255], [0, 64, 255, 255]].concat();
    let ao = [[255u8, 0, 0, 255], [64, 0, 0, 255]].concat();
    let mr_tex = doc.texture(2, 1, &mr, (CLAMP, CLAMP));
    let ao_tex = doc.texture(1, 2, &ao, (CLAMP, CLAMP));
    // An albedo the G-buffer's 8-bit sRGB target holds exactly (sRGB codes 230, 200, 160):
    // an albedo between codes is Tiled Deferred's known ~0.5% error (tiledlight_tests::compare),
    // which over a frame filled by one colour turns every pixel one LDR step off.
    let albedo = Vec3::new(230.0, 200.0, 160.0).map(|c| srgb_to_linear(c / 255.0));
    let material = json!({
        "pbrMetallicRoughness": {
            "baseColorFactor": [albedo.x, albedo.y, albedo.z, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.9,
            "metallicRoughnessTexture": {"index": mr_tex}
        },
        "occlusionTexture": {"index": ao_tex, "strength": 0.8}
    });
    let scene = load(&doc.write(dir.path(), "mr_occlusion", prim, material, &[]));
    let lights = [
        Light::point(Vec3::new(-0.5, 0.3, 0.8), Vec3::new(1.0, 0.9, 0.8), 2.0, 0.01).unwrap(),
        Light::point(Vec3::new(0.6, -0.4, 0.5), Vec3::new(0.7, 0.8, 1.0), 1.5, 0.01).unwrap(),
    ];
    let ambient = Vec3::splat(0.4);
    let (frames, checked) = render_and_check("mr-occlusion", &scene, (&lights, ambient), |_, uv| {
        let m = texel(&mr, 2, nearest_texel(uv, (2, 1), (Wrap::ClampToEdge, Wrap::ClampToEdge))?);
        let o = texel(&ao, 1, nearest_texel(uv, (1, 2), (Wrap::ClampToEdge, Wrap::ClampToEdge))?);
        let (roughness, metallic) = roughness_metallic(0.9, 1.0, m);
        Some(exact(Expected { albedo, roughness, metallic, occlusion: occlusion(o.x, 0.8), ..Default::default() }))
    });
    // Occlusion darkens the bottom's ambient: compare top and bottom at mirrored heights
    // of the left (dielectric) half, where ambient x albedo dominates.
    let top = mean_of(&frames.brute, &checked, |uv| uv.x < 0.5 && uv.y < 0.5);
    let bottom = mean_of(&frames.brute, &checked, |uv| uv.x < 0.5 && uv.y > 0.5);
    eprintln!("occlusion: top {top:.4}, bottom {bottom:.4}");
    assert!(bottom < 0.8 * top, "occlusion must darken the bottom half: {bottom} vs {top}");
    // Without the metallic-roughness texture (its factors alone: rough 0.9 metal) the CPU
    // predicts another image: the texture must move most pixels of both halves by more
    // than 10%, far beyond the 3e-3 the GPU was held to above.
    let cam = camera();
    for (half, pick) in [("left", 0.0f32..0.5), ("right", 0.5..1.0)] {
        let cs: Vec<&Checked> = checked.iter().filter(|c| pick.contains(&c.uv.x)).collect();
        let moved = cs
            .iter()
            .filter(|c| {
                let o = texel(&ao, 1, nearest_texel(c.uv, (1, 2), (Wrap::ClampToEdge, Wrap::ClampToEdge)).unwrap());
                let e = Expected {
                    albedo,
                    roughness: 0.9,
                    metallic: 1.0,
                    occlusion: occlusion(o.x, 0.8),
                    ..Default::default()
                };
                let without = shade_cpu(&e, c.p, cam.eye(), &lights, ambient);
                let got = Vec3::from_slice(&frames.brute.hdr[c.i][..3]);
                (got - without).abs().max_element() > 0.1 * without.max_element()
            })
            .count();
        eprintln!("metallic-roughness texture: {moved} of {} {half} pixels moved by > 10%", cs.len());
        assert!(moved * 2 > cs.len(), "the {half} half barely depends on its metallic-roughness texel");
    }
}

/// An emissive quad lit by nothing (no lights, no ambient): its pixels are emissive factor x
/// `KHR_materials_emissive_strength` x the emissive texel (sRGB decoded), in HDR, and
/// through exposure, the ACES fit and sRGB encoding in the tonemapped image (within one
/// 8-bit step: the GPU's sRGB encoding rounds, the f16 target too).
#[test]
fn emissive_quad_lit_by_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = Doc::default();
    let prim = quad(&mut doc, false);
    let em = [200u8, 150, 90, 255];
    let tex = doc.texture(1, 1, &em, (REPEAT, REPEAT));
    let material = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]},
        "emissiveFactor": [1.0, 0.5, 0.25],
        "emissiveTexture": {"index": tex},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}}
    });
    let scene = load(&doc.write(dir.path(), "emissive", prim, material, &["KHR_materials_emissive_strength"]));
    let [lo, hi] = srgb_range(&em, 1, (0, 0)).map(|t| emission(Vec3::new(1.0, 0.5, 0.25), 3.0, t));
    let (frames, checked) = render_and_check("emissive", &scene, (&[], Vec3::ZERO), |_, _| {
        let e = |emission| Expected { emission, albedo: Vec3::splat(0.5), ..Default::default() };
        Some([e(lo), e(hi)])
    });
    let aces = |x: f32| ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0);
    let ldr = |e: Vec3| e.to_array().map(|c| (linear_to_srgb(aces(c)) * 255.0).round());
    let emission_small = gpu().device.features().contains(wgpu::Features::RG11B10UFLOAT_RENDERABLE);
    let (ldr_lo, ldr_hi) = (ldr(lo), ldr(hi));
    eprintln!("emission {lo} to {hi}: tonemapped {ldr_lo:?} to {ldr_hi:?}");
    for (method, f) in
        [("brute force", &frames.brute), ("Forward+", &frames.forward), ("Tiled Deferred", &frames.deferred)]
    {
        for &Checked { i, .. } in &checked {
            for c in 0..3 {
                let got = f32::from(f.ldr[i * 4 + c]);
                let (a, b) = (ldr_lo[c], ldr_hi[c]);
                assert!(
                    got >= a - 1.0 && got <= b + 1.0,
                    "{method}: pixel {i} channel {c}: {got}, expected {a} to {b}"
                );
                // Tiled Deferred's emission passes through its G-buffer target: Rg11b10Ufloat
                // rounds to half a step of a 6-bit mantissa (red, green: 2^-7 relative) or a
                // 5-bit one (blue: 2^-6), Rgba16Float to 2^-11; 3e-3 for the other methods.
                let small = method == "Tiled Deferred" && emission_small;
                let rel = if !small {
                    3e-3
                } else if c == 2 {
                    1.0 / 64.0
                } else {
                    1.0 / 128.0
                };
                let hdr = f.hdr[i][c];
                let (a, b) = (lo[c] * (1.0 - rel), hi[c] * (1.0 + rel));
                assert!(hdr >= a && hdr <= b, "{method}: pixel {i} channel {c}: HDR {hdr}, expected {a} to {b}");
            }
        }
    }
    // Every covered pixel was checked (none is skipped); the sky around stays black.
    let covered: std::collections::HashSet<usize> = checked.iter().map(|c| c.i).collect();
    for (method, f) in
        [("brute force", &frames.brute), ("Forward+", &frames.forward), ("Tiled Deferred", &frames.deferred)]
    {
        let lit_sky = f.hdr.iter().enumerate().filter(|(i, p)| !covered.contains(i) && p[..3] != [0.0; 3]).count();
        assert_eq!(lit_sky, 0, "{method}: sky pixels with light");
    }
}

/// The base colour read with texture coordinate set 1 through a `KHR_texture_transform`
/// (scale, rotation and offset), with each sampler wrap mode: every pixel shows the texel
/// the CPU's transform and wrap pick (ambient-only light, so a pixel is ambient x texel).
/// The same texture on set 0 without a transform lands elsewhere.
#[test]
fn second_uv_set_texture_transform_and_wrap_modes_move_the_texture() {
    let dir = tempfile::tempdir().unwrap();
    let rgba = [[230u8, 40, 40, 255], [40, 200, 60, 255], [50, 70, 220, 255], [240, 230, 210, 255]].concat();
    let transform = UvTransform { offset: [0.3, -0.2], rotation: 0.4, scale: [1.7, 1.3] };
    let cases = [
        ("repeat", (REPEAT, REPEAT), (Wrap::Repeat, Wrap::Repeat), Some(1)),
        ("mirror-clamp", (MIRROR, CLAMP), (Wrap::MirroredRepeat, Wrap::ClampToEdge), Some(1)),
        ("clamp-mirror", (CLAMP, MIRROR), (Wrap::ClampToEdge, Wrap::MirroredRepeat), Some(1)),
        ("set0-plain", (REPEAT, REPEAT), (Wrap::Repeat, Wrap::Repeat), None),
    ];
    let mut images = Vec::new();
    for (name, gl_wrap, wrap, set1) in cases {
        let mut doc = Doc::default();
        let prim = quad(&mut doc, set1.is_some());
        let tex = doc.texture(2, 2, &rgba, gl_wrap);
        let info = match set1 {
            Some(set) => json!({"index": tex, "texCoord": 0, "extensions": {"KHR_texture_transform": {
                "offset": transform.offset, "rotation": transform.rotation, "scale": transform.scale, "texCoord": set}}}),
            None => json!({"index": tex}),
        };
        let material = json!({"pbrMetallicRoughness": {"baseColorTexture": info, "metallicFactor": 0.0}});
        let scene = load(&doc.write(dir.path(), name, prim, material, &["KHR_texture_transform"]));
        assert_eq!(scene.materials[0].base_color_texture.unwrap().tex_coord, u32::from(set1.is_some()));
        let (frames, _) = render_and_check(&format!("uv-{name}"), &scene, (&[], Vec3::ONE), |p, uv0| {
            let uv = match set1 {
                Some(_) => Vec2::from(transform.apply(uv1_at(p.truncate()).to_array())),
                None => uv0,
            };
            let ends = srgb_range(&rgba, 2, nearest_texel(uv, (2, 2), wrap)?);
            Some(ends.map(|albedo| Expected { albedo, ..Default::default() }))
        });
        images.push(frames.brute.hdr);
    }
    // Every case shows the texture somewhere else: no two images alike.
    for a in 0..images.len() {
        for b in a + 1..images.len() {
            let differ = images[a].iter().zip(&images[b]).filter(|(x, y)| (x[0] - y[0]).abs() > 0.05).count();
            assert!(differ > 100, "cases {a} and {b} differ in only {differ} pixels");
        }
    }
}

/// `KHR_mesh_quantization`: the quad stored as normalised shorts (positions), normalised
/// bytes (normals, tangents), plain unsigned bytes scaled by a texture transform (set 0)
/// and normalised unsigned shorts (set 1), and its float twin holding the dequantised
/// values: the loaded meshes are equal and every method renders identical images, bit for
/// bit (the same f32 data reaches the same shaders).
#[test]
fn quantized_mesh_renders_like_its_float_twin() {
    let dir = tempfile::tempdir().unwrap();
    let pos: [[i16; 3]; 4] = [[-32767, -32767, 0], [32767, -32767, 0], [32767, 32767, 0], [-32767, 32767, 0]];
    let uv0: [[u8; 2]; 4] = [[0, 8], [8, 8], [8, 0], [0, 0]];
    let uv1: [[u16; 2]; 4] = [[0, 0], [0, 65535], [65535, 65535], [65535, 0]];
    let normal_map = [[200u8, 100, 230, 255], [80, 160, 220, 255]].concat();
    let base = [[230u8, 40, 40, 255], [40, 200, 60, 255], [50, 70, 220, 255], [240, 230, 210, 255]].concat();
    let material = |doc: &mut Doc| {
        let b = doc.texture(2, 2, &base, (REPEAT, REPEAT));
        let n = doc.texture(2, 1, &normal_map, (MIRROR, REPEAT));
        json!({
            "pbrMetallicRoughness": {"baseColorTexture": {"index": b, "extensions":
                {"KHR_texture_transform": {"scale": [0.125, 0.125]}}}, "metallicFactor": 0.2, "roughnessFactor": 0.4},
            "normalTexture": {"index": n, "texCoord": 1}
        })
    };
    // Quantised.
    let mut q = Doc::default();
    let le = |v: i16| v.to_le_bytes();
    let pb: Vec<u8> = pos.iter().flat_map(|p| [le(p[0]), le(p[1]), le(p[2]), [0, 0]].concat()).collect();
    let p = q.accessor(&pb, (I16, true), (4, "VEC3", 8));
    q.buf.accessors[p]["min"] = json!([-32767, -32767, 0]);
    q.buf.accessors[p]["max"] = json!([32767, 32767, 0]);
    let n = q.accessor(&[0, 0, 127, 0].repeat(4), (I8, true), (4, "VEC3", 4));
    let t = q.accessor(&[127, 0, 0, 129].repeat(4), (I8, true), (4, "VEC4", 4));
    let u0b: Vec<u8> = uv0.iter().flat_map(|u| [u[0], u[1], 0, 0]).collect();
    let u0 = q.accessor(&u0b, (U8, false), (4, "VEC2", 4));
    let u1b: Vec<u8> = uv1.iter().flat_map(|u| [u[0].to_le_bytes(), u[1].to_le_bytes()].concat()).collect();
    let u1 = q.accessor(&u1b, (U16, true), (4, "VEC2", 4));
    let i = q.indices(&[0, 1, 2, 0, 2, 3]);
    let qm = material(&mut q);
    let qprim = json!({"attributes": {"POSITION": p, "NORMAL": n, "TANGENT": t, "TEXCOORD_0": u0, "TEXCOORD_1": u1}, "indices": i});
    let quantized =
        load(&q.write(dir.path(), "quantized", qprim, qm, &["KHR_mesh_quantization", "KHR_texture_transform"]));
    // Float twin: the specification's dequantisation in f32.
    let mut f = Doc::default();
    let fp: Vec<f32> = pos.iter().flat_map(|p| p.map(|c| (f32::from(c) / 32767.0).max(-1.0))).collect();
    let p = f.floats(&fp, "VEC3");
    let n = f.floats(&[0.0, 0.0, 1.0].repeat(4), "VEC3");
    let t = f.floats(&[1.0, 0.0, 0.0, -1.0].repeat(4), "VEC4");
    let u0 = f.floats(&uv0.iter().flat_map(|u| u.map(f32::from)).collect::<Vec<_>>(), "VEC2");
    let u1 = f.floats(&uv1.iter().flat_map(|u| u.map(|c| f32::from(c) / 65535.0)).collect::<Vec<_>>(), "VEC2");
    let i = f.indices(&[0, 1, 2, 0, 2, 3]);
    let fm = material(&mut f);
    let fprim = json!({"attributes": {"POSITION": p, "NORMAL": n, "TANGENT": t, "TEXCOORD_0": u0, "TEXCOORD_1": u1}, "indices": i});
    let float = load(&f.write(dir.path(), "float", fprim, fm, &["KHR_texture_transform"]));
    let unnamed = |s: &Scene| {
        s.meshes.iter().map(|m| tiledlight_scene::Mesh { name: String::new(), ..m.clone() }).collect::<Vec<_>>()
    };
    assert_eq!(unnamed(&quantized), unnamed(&float), "dequantised attributes equal the float twin's");
    assert_eq!(quantized.meshes[0].tangents[0], [1.0, 0.0, 0.0, -1.0]);

    let ctx = gpu();
    let lights = [Light::point(Vec3::new(0.3, 0.4, 0.9), Vec3::ONE, 3.0, 0.01).unwrap()];
    let lb = LightBuffers::new(&ctx.device, &lights).unwrap();
    let cam = camera();
    let render = |scene: &Scene, deferred: bool, method: Method| {
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
        let frame = if deferred {
            let mut r = FrameRenderer::new(ctx, &sg, &lb, W, H, FrameSettings::of(Method::TiledDeferred)).unwrap();
            render_frame(ctx, &mut r, &sg, &cam)
        } else {
            let mut r =
                FrameRenderer::new(ctx, &sg, &lb, W, H, FrameSettings { method, ..Default::default() }).unwrap();
            render_frame(ctx, &mut r, &sg, &cam)
        };
        frame.hdr
    };
    for (name, deferred, method) in [
        ("brute force", false, Method::BruteForce { cutoff: true }),
        ("Forward+", false, Method::ForwardPlus),
        ("Tiled Deferred", true, Method::ForwardPlus),
    ] {
        let a = render(&quantized, deferred, method);
        let b = render(&float, deferred, method);
        let lit = a.iter().filter(|p| p[0] > 0.01).count();
        assert!(lit > (W * H / 4) as usize, "{name}: the quad must cover the frame ({lit} lit pixels)");
        // Bit for bit, except that a parallel GPU may sum a tile's lights in another order
        // (one light here: no order to change).
        assert!(a == b, "{name}: the quantised mesh renders differently from its float twin");
    }
}

/// "Model only what the scene requires": the courtyard (base colour textures only) and a
/// plain scene compile and bind no material path beyond theirs (no tangent or second UV
/// buffer, no texture arrays beyond their images' classes, no emission target), while a
/// scene with every material feature gets each of them.
#[test]
fn scenes_without_material_maps_get_no_extra_paths() {
    let ctx = gpu();
    let lights = LightBuffers::new(&ctx.device, &[]).unwrap();
    let check = |name: &str, scene: &Scene, want: MaterialFeatures| {
        let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).unwrap();
        assert_eq!(sg.material_features, want, "{name}");
        assert_eq!(sg.tangents.is_some(), want.normal_map, "{name}: tangent buffer");
        assert_eq!(sg.uvs1.is_some(), want.uv1, "{name}: second uv buffer");
        assert_eq!(sg.textures.is_some(), want.textures, "{name}: group 2");
        let d = FrameRenderer::new(ctx, &sg, &lights, 64, 48, FrameSettings::of(Method::TiledDeferred)).unwrap();
        assert_eq!(d.features().materials, want, "{name}: the renderer's features");
        let gbuffer = d.memory().get("deferred.gbuffer");
        // The packed surface (8 B); emission in 4 B (Rg11b10Ufloat) unless something is
        // occlusion-mapped or the device cannot render to it, then 8 (Rgba16Float).
        let small = ctx.device.features().contains(wgpu::Features::RG11B10UFLOAT_RENDERABLE) && !want.occlusion;
        let per_pixel = 8 + if !want.emission_target() {
            0
        } else if small {
            4
        } else {
            8
        };
        assert_eq!(gbuffer, 64 * 48 * per_pixel, "{name}: G-buffer bytes ({per_pixel} a pixel besides depth)");
        let f = FrameRenderer::new(ctx, &sg, &lights, 64, 48, FrameSettings::default()).unwrap();
        assert_eq!(f.features().material_defines(), want.defines(), "{name}: Forward+ variant");
        // Group 2 exists only with TEXTURES: its eight arrays, as many of them real as
        // the scene's images have classes (size and colour space), without padding.
        let arrays = sg.textures.as_ref().map_or(0, |t| {
            assert_eq!(layout_entries(TEXTURE_BINDINGS, &want.defines()).len(), 8, "{name}");
            assert_eq!(t.plan.padding_bytes(), 0, "{name}: images of few sizes are not padded");
            t.plan.arrays.len()
        });
        eprintln!("{name}: defines {:?}, {arrays} texture arrays", want.defines());
        arrays
    };
    let plain = scenes::floor_scene(0.5, 0.0, vec![]);
    assert_eq!(check("floor", &plain, MaterialFeatures::default()), 0);
    let courtyard = scenes::courtyard();
    let textures_only = MaterialFeatures { textures: true, ..Default::default() };
    assert_eq!(check("courtyard", &courtyard, textures_only), 1, "one 64x64 sRGB image, one array");

    // Every feature.
    let dir = tempfile::tempdir().unwrap();
    let mut doc = Doc::default();
    let prim = quad(&mut doc, true);
    let white = [255u8; 4];
    let tex: Vec<usize> = (0..5).map(|_| doc.texture(1, 1, &white, (REPEAT, REPEAT))).collect();
    let material = json!({
        "pbrMetallicRoughness": {"baseColorTexture": {"index": tex[0]}, "metallicRoughnessTexture": {"index": tex[1], "texCoord": 1}},
        "normalTexture": {"index": tex[2]}, "occlusionTexture": {"index": tex[3]},
        "emissiveTexture": {"index": tex[4]}, "emissiveFactor": [1.0, 1.0, 1.0]
    });
    let full = load(&doc.write(dir.path(), "full", prim, material, &[]));
    let all = MaterialFeatures {
        textures: true,
        metallic_roughness: true,
        normal_map: true,
        occlusion: true,
        emissive: true,
        uv1: true,
    };
    // Five 1x1 images: the two colour slots' sRGB, the three data slots' linear.
    assert_eq!(check("full", &full, all), 2);
    // Emission alone: the emission target and define, no texture group.
    let mut emissive = plain.clone();
    emissive.materials[0].emissive = [1.0, 0.0, 0.0];
    let emission_only = MaterialFeatures { emissive: true, ..Default::default() };
    assert_eq!(check("emissive floor", &emissive, emission_only), 0);
}

// ---- the README's normal-mapped asset ----

/// Where the README's normal-mapped model lives (relative to the workspace root).
const STUDS_ASSET: &str = "assets/normal-mapped/studs.gltf";

/// Texels of the studs' normal map a side, and studs a side.
const STUDS_TEXELS: u32 = 128;
const STUDS_PER_SIDE: u32 = 4;

/// The studs' tangent-space normal map: a `STUDS_PER_SIDE`^2 grid of round studs (each a
/// spherical cap leaning up to 53 degrees at its rim) on a flat ground, RGBA8, glTF's
/// convention (+X right, +Y up the image, +Z out of the surface).
fn studs_normal_map() -> Vec<u8> {
    let cell = (STUDS_TEXELS / STUDS_PER_SIDE) as f32;
    let radius = 0.4 * cell;
    let mut rgba = Vec::with_capacity((STUDS_TEXELS * STUDS_TEXELS * 4) as usize);
    for y in 0..STUDS_TEXELS {
        for x in 0..STUDS_TEXELS {
            // Offset from the centre of the texel's cell, in texels; image rows run down.
            let c = |t: u32| (t as f32 + 0.5) % cell - 0.5 * cell;
            let d = Vec2::new(c(x), -c(y)) / radius;
            let xy = if d.length() < 1.0 { 0.8 * d } else { Vec2::ZERO };
            let n = Vec3::new(xy.x, xy.y, (1.0 - xy.length_squared()).sqrt());
            let byte = |v: f32| ((v * 0.5 + 0.5) * 255.0).round() as u8;
            rgba.extend([byte(n.x), byte(n.y), byte(n.z), 255]);
        }
    }
    rgba
}

/// The README's normal-mapped model: a 2 m square facing +Z (the materials tests' quad),
/// warm grey and fairly smooth, with [`studs_normal_map`] sampled linearly; no tangents in
/// the file (MikkTSpace makes them). Written to `dir` as `studs.gltf`, everything embedded.
fn studs_gltf(dir: &Path) -> PathBuf {
    let mut doc = Doc::default();
    let prim = quad(&mut doc, false);
    let tex = doc.texture(STUDS_TEXELS, STUDS_TEXELS, &studs_normal_map(), (REPEAT, REPEAT));
    // Linear filtering: the studs' rims are smooth, not texel steps.
    doc.samplers[0] = json!({"magFilter": LINEAR, "minFilter": LINEAR, "wrapS": REPEAT, "wrapT": REPEAT});
    let material = json!({
        "name": "studded plate",
        "pbrMetallicRoughness": {"baseColorFactor": [0.75, 0.72, 0.68, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.45},
        "normalTexture": {"index": tex, "scale": 1.0}
    });
    doc.write(dir, "studs", prim, material, &[])
}

/// The asset in `assets/` is what [`studs_gltf`] writes (compared as loaded: geometry,
/// material and the normal map's texels; PNG bytes may differ between encoder versions).
/// `TILEDLIGHT_WRITE_ASSETS=1` writes it again. No GPU needed.
#[test]
fn the_readme_normal_mapped_asset_is_current() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let asset = root.join(STUDS_ASSET);
    let dir = tempfile::tempdir().unwrap();
    let made = studs_gltf(dir.path());
    if std::env::var_os("TILEDLIGHT_WRITE_ASSETS").is_some() {
        std::fs::create_dir_all(asset.parent().unwrap()).unwrap();
        std::fs::copy(&made, &asset).unwrap();
        eprintln!("wrote {}", asset.display());
    }
    let (expected, found) = (load(&made), load(&asset));
    assert_eq!(found.meshes, expected.meshes, "{}: geometry differs", asset.display());
    assert_eq!(found.materials, expected.materials, "{}: material differs", asset.display());
    assert_eq!(found.textures, expected.textures, "{}: normal map differs", asset.display());
    // The studs really lean: the map's texels span +-0.8 in x and y.
    let m = studs_normal_map();
    let xs: Vec<u8> = m.chunks_exact(4).map(|t| t[0]).collect();
    assert!(xs.iter().min() < Some(&30) && xs.iter().max() > Some(&225), "{:?}", (xs.iter().min(), xs.iter().max()));
    assert!(found.meshes[0].tangents.len() == 4, "MikkTSpace tangents for the normal map");
}

/// The many-material scene (16 textured materials) under 96 point and 16 spot lights, its
/// camera, and brute force's frame and depth of it: what its tests compare with.
struct ManyMaterials {
    camera: Camera,
    sg: SceneGpu,
    lb: LightBuffers,
    bs: FrameSettings,
    brute: Frame,
    depth: Vec<f32>,
}

fn many_materials() -> ManyMaterials {
    let ctx = gpu();
    let scene = tiledlight_scene::materials::materials_scene(16).expect("materials scene");
    let camera = scenes::courtyard_camera(&scene, W, H);
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lb = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 96, 16, 5)).unwrap();
    let bs = FrameSettings { method: Method::BruteForce { cutoff: true }, ..Default::default() };
    let mut bf = FrameRenderer::new(ctx, &sg, &lb, W, H, bs).unwrap();
    let brute = render_frame(ctx, &mut bf, &sg, &camera);
    let depth = bf.read_depth(ctx).unwrap();
    ManyMaterials { camera, sg, lb, bs, brute, depth }
}

/// The many-material scene (issue 46, `--scene materials`) at 16 materials, which cover every
/// map and sampler it has (normal maps, masks, the second uv set, texture transforms,
/// metallic-roughness, occlusion and emission images, every wrap mode, a nearest sampler,
/// images of seven sizes, two not powers of two): Forward+, Tiled Deferred and the visibility
/// buffer with both rasters against brute force at one sample a pixel, with the tolerances
/// of the other material tests (`render_and_check`). The scene's 577 instances and 16
/// materials are shaded by one visibility dispatch; the images must not tell.
#[test]
fn the_many_material_scene_agrees_with_brute_force() {
    let ManyMaterials { camera, sg, lb, bs, brute, depth } = many_materials();
    let covered = depth.iter().filter(|&&d| d > 0.0).count();
    assert!(covered * 2 > (W * H) as usize, "the boxes and floor fill the view ({covered} pixels)");
    let lit = brute.hdr.iter().filter(|p| p[0] + p[1] + p[2] > 1e-3).count();
    assert!(lit * 4 > covered, "the lights reach the boxes ({lit} of {covered} pixels lit)");

    // The packed G-buffer rounds metallic to 1/15 steps, and this scene's metallic images
    // are 8-bit: Tiled Deferred's reference carries the whole surface's rounding.
    tiled_against_brute("materials-scene", (&sg, &lb, &camera), bs.ambient, (&brute, &depth), true);
}

/// The negative test of the sub-pixel shift's allowance (`tiledlight_tests::subpixel`): the
/// many-material scene's visibility buffer with its whole image moved by one pixel, 256
/// grid steps, is rejected by the comparison that accepts one step's texel flips, and needs
/// the allowance at more than the 1% of the pixels that `shifted_lookups` accepts.
#[test]
fn a_visibility_image_moved_by_a_pixel_is_not_a_texel_flip() {
    let ctx = gpu();
    let ManyMaterials { camera, sg, lb, bs, brute, depth } = many_materials();
    let (without, with_shift) = visibility_reference((&sg, &lb, &camera), bs.ambient, (&brute, &depth));
    let allowed = with_shift.allowance.iter().filter(|&&a| a > 0.0).count();
    assert!(allowed > 100, "the shifted frames flip texels somewhere ({allowed} pixels)");
    let vs = FrameSettings { method: Method::Visibility, ..Default::default() };
    let mut vr = FrameRenderer::new(ctx, &sg, &lb, W, H, vs).unwrap();
    let moved = render_frame(ctx, &mut vr, &sg, &subpixel::shifted_camera(&camera, H, (1.0, 0.0), 1.0));
    assert!(!visibility_matches("moved-by-a-pixel", W, &with_shift, &moved), "a one-pixel move passed");
    let covered = depth.iter().filter(|&&d| d > 0.0).count();
    let caught = std::panic::catch_unwind(|| {
        shifted_lookups("moved-by-a-pixel", (&without, &with_shift), moved.clone(), VISIBILITY_VS_REFERENCE, covered)
    });
    assert!(caught.is_err(), "shifted_lookups accepted a one-pixel move as texel flips");
    // The same frame unmoved passes both.
    let exact = render_frame(ctx, &mut vr, &sg, &camera);
    let exact = shifted_lookups("unmoved", (&without, &with_shift), exact, VISIBILITY_VS_REFERENCE, covered);
    assert!(visibility_matches("unmoved", W, &with_shift, &exact));
}
