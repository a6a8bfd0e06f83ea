//! Shadow-casting lights against a CPU ray-cast visibility reference
//! (`tiledlight_cull::raycast`), on lavapipe and real GPUs.
//!
//! - **Ray-cast sets.** A box over a floor, one caster per case (a point light, a spot
//!   light, a point light whose shadow crosses a cube-face seam): a pixel the ray cast calls
//!   lit must be lit in the GPU image and a shadowed one dark, outside a border around the
//!   shadow's edge whose width comes from the filter's footprint and the shadow texel's size
//!   there ([`border`]). A crack along the face seam would be lit pixels inside the shadow.
//! - **Acne and contact.** A lit plane at up to 80 degrees incidence stays lit; a box
//!   resting on the floor shadows the floor from within a stated number of texels of the
//!   contact.
//! - **Methods agree.** Forward+ and Tiled Deferred against brute force with the same
//!   shadows; shadows only darken pixels that the ray cast says some caster cannot see.
//! - **Only what moved.** A still frame draws no shadow face; moving one light redraws only
//!   its faces (counted, not timed).
//! - **The atlas itself** (the shadow pass's CPU twin): every texel of every face holds the
//!   depth of the first surface a ray through the texel centre meets.
//! - **Bad input**: more casters than the atlas or the scene holds, wide spot cones.
//!
//! Ambient is zero, so a pixel's visibility is its shadowed radiance over its unshadowed
//! radiance (the same renderer without casters).

use glam::{Mat4, Vec3};
use tiledlight_cull::light::shadow_casters;
use tiledlight_cull::raycast::{surface_points, SurfacePoint as Surface, Triangles};
use tiledlight_cull::shadow::{self, ShadowFilter, ShadowFormat, ShadowOptions};
use tiledlight_cull::{Camera, Light};
use tiledlight_deferred::{DeferredRenderer, DeferredSettings};
use tiledlight_forward::{ForwardRenderer, ForwardSettings, Method};
use tiledlight_gpu::diagnostics::Diagnostics;
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::Renderer;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::{shadow_box_scene, Scene};
use tiledlight_tests::compare::{assert_matches_reference_frame, render_frame, Frame, FORWARD_VS_REFERENCE};
use tiledlight_tests::{err_text, gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

/// The renderer a case draws with.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    BruteForce,
    ForwardPlus,
    Deferred,
}

fn renderer(kind: Kind, scene: &SceneGpu, lights: &LightBuffers, shadows: ShadowOptions) -> Box<dyn Renderer> {
    let ctx = gpu();
    match kind {
        Kind::BruteForce | Kind::ForwardPlus => {
            let method =
                if kind == Kind::BruteForce { Method::BruteForce { cutoff: true } } else { Method::ForwardPlus };
            let s = ForwardSettings { method, shadows, ambient: Vec3::ZERO, ..Default::default() };
            Box::new(ForwardRenderer::new(ctx, scene, lights, W, H, s).expect("forward renderer"))
        }
        Kind::Deferred => {
            let s = DeferredSettings { shadows, ambient: Vec3::ZERO, ..Default::default() };
            Box::new(DeferredRenderer::new(ctx, scene, lights, W, H, s).expect("deferred renderer"))
        }
    }
}

/// One rendered case: shadowed and unshadowed frames and the depth buffer.
struct Rendered {
    shadowed: Frame,
    unshadowed: Frame,
    depth: Vec<f32>,
}

fn render_pair(
    kind: Kind,
    scene: &Scene,
    lights: &[Light],
    casters: (u32, u32),
    opts: ShadowOptions,
    cam: &Camera,
) -> Rendered {
    let ctx = gpu();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, scene).expect("scene");
    let with = LightBuffers::with_casters(&ctx.device, lights, casters).expect("lights with casters");
    let without = LightBuffers::new(&ctx.device, lights).expect("lights");
    let mut r = renderer(kind, &sg, &with, opts);
    let shadowed = render_frame(ctx, r.as_mut(), &sg, cam);
    let depth = r.read_depth(ctx).expect("depth");
    let mut r = renderer(kind, &sg, &without, opts);
    let unshadowed = render_frame(ctx, r.as_mut(), &sg, cam);
    Rendered { shadowed, unshadowed, depth }
}

fn lum(p: [f32; 4]) -> f32 {
    p[0] + p[1] + p[2]
}

/// World size of a shadow texel at `p` for caster light `l` (position, and for spots the
/// axis and outer-angle tangent).
fn texel_at(light: &Light, p: Vec3, opts: ShadowOptions) -> f32 {
    let d = p - light.position;
    match light.kind {
        tiledlight_cull::LightKind::Point => {
            let depth = d.abs().max_element();
            shadow::texel_per_depth(shadow::widened_tan(1.0, opts.tile_size, opts.filter), opts.tile_size) * depth
        }
        tiledlight_cull::LightKind::Spot { direction, outer_angle, .. } => {
            let t = shadow::widened_tan(outer_angle.tan(), opts.tile_size, opts.filter);
            shadow::texel_per_depth(t, opts.tile_size) * d.dot(direction)
        }
    }
}

/// The border around a shadow edge where the GPU may differ from the ray cast: the
/// filter's reach (`r + 1` texels, the last for the hardware 2x2 comparison), the normal
/// offset (`r + 1.5`) and constant offset (0.5), plus one texel of rasterisation, all
/// measured on the shadow map and stretched onto the surface by `1 / cos` of the light's
/// incidence (capped at 4x).
fn border(light: &Light, s: Surface, opts: ShadowOptions) -> f32 {
    let r = opts.filter.radius() as f32;
    let texels = (r + 1.0) + (r + 1.5) + 0.5 + 1.0;
    let l = (light.position - s.position).normalize();
    texels * texel_at(light, s.position, opts) / s.normal.dot(l).max(0.25)
}

/// Ray-cast visibility of `light` from surface `s`: lit, shadowed, or near an edge
/// (visibility differs somewhere within the border, sampled at 12 points of the tangent
/// plane).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Truth {
    Lit,
    Shadowed,
    Edge,
}

fn truth(tris: &Triangles, light: &Light, s: Surface, opts: ShadowOptions) -> Truth {
    let eps = 1e-3;
    let visible = |p: Vec3| !tris.occluded(p + s.normal * eps, light.position, eps);
    let centre = visible(s.position);
    let b = border(light, s, opts);
    let t1 = s.normal.any_orthonormal_vector();
    let t2 = s.normal.cross(t1);
    for k in 0..12 {
        let a = k as f32 * std::f32::consts::TAU / 12.0;
        for scale in [0.5, 1.0] {
            let q = s.position + (t1 * a.cos() + t2 * a.sin()) * b * scale;
            if visible(q) != centre {
                return Truth::Edge;
            }
        }
    }
    if centre {
        Truth::Lit
    } else {
        Truth::Shadowed
    }
}

/// Counts of one ray-cast comparison.
#[derive(Debug, Default)]
struct Tally {
    lit: usize,
    shadowed: usize,
    lit_but_dark: Vec<(u32, u32, f32)>,
    shadowed_but_lit: Vec<(u32, u32, f32)>,
    /// The shadowed image with the ray cast's verdicts painted over it (blue: edge band,
    /// cyan: shadowed, red: lit but dark, green: shadowed but lit), written on failure.
    overlay: Vec<u8>,
}

/// Compares the GPU's visibility of one caster with the ray cast, pixel by pixel, where
/// the light reaches the surface (inside its radius and cone, facing it).
fn compare_with_ray_cast(scene: &Scene, light: &Light, r: &Rendered, cam: &Camera, opts: ShadowOptions) -> Tally {
    let tris = Triangles::new(scene.world_triangles());
    let mut t = Tally { overlay: r.shadowed.ldr.clone(), ..Default::default() };
    for (i, s) in surface_points(cam, W, H, &r.depth).into_iter().enumerate() {
        let Some(s) = s else { continue };
        let full = lum(r.unshadowed.hdr[i]);
        // Too dim to measure a ratio (outside the radius or cone, grazing light).
        if full < 2e-3 {
            continue;
        }
        let v = lum(r.shadowed.hdr[i]) / full;
        let (x, y) = (i as u32 % W, i as u32 / W);
        let mut paint = |c: [u8; 3]| t.overlay[i * 4..i * 4 + 3].copy_from_slice(&c);
        match truth(&tris, light, s, opts) {
            Truth::Lit => {
                t.lit += 1;
                if v < 0.98 {
                    paint([255, 0, 0]);
                    t.lit_but_dark.push((x, y, v));
                }
            }
            Truth::Shadowed => {
                t.shadowed += 1;
                if v > 0.02 {
                    paint([0, 255, 0]);
                    t.shadowed_but_lit.push((x, y, v));
                } else {
                    paint([0, 90, 90]);
                }
            }
            Truth::Edge => paint([0, 0, 160]),
        }
    }
    t
}

/// A camera above and in front of the box scene.
fn box_camera() -> Camera {
    Camera::perspective(
        Vec3::new(0.0, 9.0, 9.0),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::Y,
        60f32.to_radians(),
        W as f32 / H as f32,
        0.1,
        None,
    )
    .expect("camera")
}

fn point(pos: Vec3, intensity: f32) -> Light {
    Light::point(pos, Vec3::ONE, intensity, 0.01).expect("light")
}

fn assert_matches_ray_cast(name: &str, scene: &Scene, light: Light, opts: ShadowOptions, kind: Kind) {
    let cam = box_camera();
    let casters = if light.is_spot() { (0, 1) } else { (1, 0) };
    let r = render_pair(kind, scene, &[light], casters, opts, &cam);
    let t = compare_with_ray_cast(scene, &light, &r, &cam, opts);
    eprintln!(
        "{name} ({kind:?}, {}x{} PCF, {} px, {}): {} lit, {} shadowed, wrong: {} lit-but-dark, {} shadowed-but-lit",
        opts.filter.size(),
        opts.filter.size(),
        opts.tile_size,
        opts.format.name(),
        t.lit,
        t.shadowed,
        t.lit_but_dark.len(),
        t.shadowed_but_lit.len()
    );
    let ok = t.lit_but_dark.is_empty() && t.shadowed_but_lit.is_empty();
    if !ok || std::env::var_os("TILEDLIGHT_SHADOW_OVERLAYS").is_some() {
        let file = format!("shadows-{name}-{kind:?}-{}-{}.png", opts.filter.size(), opts.tile_size).replace(' ', "_");
        tiledlight_tests::images::save_png(&tiledlight_tests::output_dir().join(file), W, H, &t.overlay);
    }
    // Both sets must be large, or the comparison tests nothing.
    assert!(t.lit > 2000 && t.shadowed > 200, "{name}: too few certain pixels: lit {}, shadowed {}", t.lit, t.shadowed);
    assert!(
        t.lit_but_dark.is_empty() && t.shadowed_but_lit.is_empty(),
        "{name}: the GPU disagrees with the ray cast outside the border (x, y, visibility): \
         lit but dark {:?}; shadowed but lit {:?}",
        &t.lit_but_dark[..t.lit_but_dark.len().min(10)],
        &t.shadowed_but_lit[..t.shadowed_but_lit.len().min(10)]
    );
}

const FILTERS: [ShadowFilter; 3] = [ShadowFilter::Tap1, ShadowFilter::Pcf3, ShadowFilter::Pcf5];

#[test]
fn point_light_shadow_matches_ray_cast() {
    let scene = shadow_box_scene(0.5);
    for filter in FILTERS {
        let opts = ShadowOptions { filter, ..Default::default() };
        assert_matches_ray_cast("point", &scene, point(Vec3::new(1.5, 6.0, 1.0), 200.0), opts, Kind::BruteForce);
    }
    let d32 = ShadowOptions { format: ShadowFormat::Depth32, tile_size: 512, ..Default::default() };
    assert_matches_ray_cast("point d32", &scene, point(Vec3::new(1.5, 6.0, 1.0), 200.0), d32, Kind::BruteForce);
}

#[test]
fn spot_light_shadow_matches_ray_cast() {
    let scene = shadow_box_scene(0.5);
    let dir = (Vec3::new(0.0, 0.0, 0.0) - Vec3::new(-3.0, 7.0, 2.0)).normalize();
    let spot = Light::spot(Vec3::new(-3.0, 7.0, 2.0), dir, Vec3::ONE, 300.0, 0.5, 0.7, 0.01).expect("spot");
    for filter in FILTERS {
        let opts = ShadowOptions { filter, ..Default::default() };
        assert_matches_ray_cast("spot", &scene, spot, opts, Kind::BruteForce);
    }
}

/// A point light 3 m over the floor at x = 0: floor points at |x| = 3 lie on the seam
/// between its -Y face and its +X face, and the box's shadow spans x = 1.5 to 4.
#[test]
fn shadow_across_a_cube_face_seam_has_no_crack() {
    let mut scene = shadow_box_scene(0.5);
    // Move the box to x = 1..3 (it is centred at the origin, 2 m wide).
    for inst in scene.instances.iter_mut().skip(1) {
        inst.transform = Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0)) * inst.transform;
    }
    scene.bounds = scene.compute_bounds();
    let light = point(Vec3::new(0.0, 3.5, 0.0), 200.0);
    for filter in [ShadowFilter::Tap1, ShadowFilter::Pcf5] {
        let opts = ShadowOptions { filter, ..Default::default() };
        assert_matches_ray_cast("seam", &scene, light, opts, Kind::BruteForce);
    }
}

#[test]
fn forward_plus_and_tiled_deferred_match_the_ray_cast_too() {
    let scene = shadow_box_scene(0.5);
    let opts = ShadowOptions::default();
    for kind in [Kind::ForwardPlus, Kind::Deferred] {
        assert_matches_ray_cast("point", &scene, point(Vec3::new(1.5, 6.0, 1.0), 200.0), opts, kind);
    }
}

/// A lit floor with nothing over it, lit at up to 85 degrees incidence: every pixel up to
/// 80 degrees must be fully lit (no acne), for each filter, format and the extreme tile
/// sizes. Measured: 100% (lavapipe, H200).
#[test]
fn no_acne_on_a_plane_at_grazing_incidence() {
    let scene = scenes::floor_scene(0.8, 0.0, vec![]);
    // 1 m over the floor; the camera sees the floor from 1 m to ~12 m from the light's foot,
    // where the incidence reaches 85 degrees.
    let light = point(Vec3::new(-6.0, 1.0, 0.0), 400.0);
    let cam = Camera::perspective(
        Vec3::new(2.0, 4.0, 6.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::Y,
        70f32.to_radians(),
        W as f32 / H as f32,
        0.1,
        None,
    )
    .expect("camera");
    let cases = [
        ShadowOptions { filter: ShadowFilter::Tap1, ..Default::default() },
        ShadowOptions { filter: ShadowFilter::Pcf3, tile_size: 128, ..Default::default() },
        ShadowOptions::default(),
        ShadowOptions { tile_size: 1024, ..Default::default() },
        ShadowOptions { format: ShadowFormat::Depth32, tile_size: 1024, ..Default::default() },
    ];
    for opts in cases {
        let r = render_pair(Kind::BruteForce, &scene, &[light], (1, 0), opts, &cam);
        let (mut counted, mut dark, mut steepest) = (0, Vec::new(), 0f32);
        for (i, s) in surface_points(&cam, W, H, &r.depth).into_iter().enumerate() {
            let Some(s) = s else { continue };
            let full = lum(r.unshadowed.hdr[i]);
            let cos = s.normal.dot((light.position - s.position).normalize());
            if full < 2e-3 || cos < 80f32.to_radians().cos() {
                continue;
            }
            counted += 1;
            steepest = steepest.max(cos.acos().to_degrees());
            let v = lum(r.shadowed.hdr[i]) / full;
            if v < 0.98 {
                dark.push((i as u32 % W, i as u32 / W, v));
            }
        }
        eprintln!("acne {opts:?}: {counted} lit-plane pixels up to {steepest:.1} degrees, {} darkened", dark.len());
        assert!(counted > 5_000 && steepest > 79.0, "{opts:?}: the plane must fill the frame up to 80 degrees");
        assert!(dark.is_empty(), "{opts:?}: acne at (x, y, visibility) {:?}", &dark[..dark.len().min(10)]);
    }
}

/// A box resting on the floor: where the ray cast says the floor is shadowed, the GPU's
/// shadow must start at most `CONTACT_TEXELS` shadow texels from the box (the normal
/// offset lifts the floor point by up to r + 1.5 texels and the filter reaches r + 1 more;
/// 2r + 3.5 for the 5x5 filter is 7.5, and the light at 45 degrees adds nothing beyond
/// that). Light leaking under the box would show as lit floor next to its base.
#[test]
fn contact_shadow_starts_at_the_box() {
    const CONTACT_TEXELS: f32 = 7.5;
    let scene = shadow_box_scene(0.0);
    let tris = Triangles::new(scene.world_triangles());
    let light = point(Vec3::new(-5.0, 5.0, 0.5), 300.0);
    let mut lit_gap = 0f32;
    let cam = box_camera();
    let opts = ShadowOptions::default();
    let r = render_pair(Kind::BruteForce, &scene, &[light], (1, 0), opts, &cam);
    let (mut shadowed, mut far_leak) = (0, Vec::new());
    let mut overlay = r.shadowed.ldr.clone();
    for (i, s) in surface_points(&cam, W, H, &r.depth).into_iter().enumerate() {
        let Some(s) = s else { continue };
        let full = lum(r.unshadowed.hdr[i]);
        // Floor pixels on the shadow side (x > 1), in the box's shadow by the ray cast.
        if full < 2e-3 || s.position.y.abs() > 1e-3 || s.position.x <= 1.0 || s.position.z.abs() > 0.9 {
            continue;
        }
        // Shadowed by the ray cast, away from the shadow's outer edge (where the filter's
        // penumbra is expected); the box's base is not an edge: under it is shadow too.
        if truth(&tris, &light, s, opts) != Truth::Shadowed {
            continue;
        }
        shadowed += 1;
        let v = lum(r.shadowed.hdr[i]) / full;
        let gap = (s.position.x - 1.0) / texel_at(&light, s.position, opts);
        if v > 0.5 {
            lit_gap = lit_gap.max(gap);
        }
        if v > 0.5 && gap > CONTACT_TEXELS {
            far_leak.push((i as u32 % W, i as u32 / W, gap, v));
            overlay[i * 4..i * 4 + 3].copy_from_slice(&[255, 0, 0]);
        } else {
            overlay[i * 4..i * 4 + 3].copy_from_slice(&[0, 90, 90]);
        }
    }
    if !far_leak.is_empty() {
        tiledlight_tests::images::save_png(&tiledlight_tests::output_dir().join("shadows-contact.png"), W, H, &overlay);
    }
    eprintln!(
        "contact: {shadowed} shadowed floor pixels; lit ones reach {lit_gap:.1} texels from the box, {} beyond {CONTACT_TEXELS}",
        far_leak.len()
    );
    assert!(shadowed > 300, "the box's shadow must be in view ({shadowed} pixels)");
    assert!(
        far_leak.is_empty(),
        "light leaks under the box (x, y, texels from it, visibility): {:?}",
        &far_leak[..far_leak.len().min(10)]
    );
}

/// Several casters of both kinds, an alpha-masked screen, unshadowed lights too: Forward+
/// must equal brute force with the same shadows within the usual tolerance (the lookups are
/// the same code on the same data; only the summation order differs); Tiled Deferred
/// rebuilds positions from depth and stores f16 normals, so its lookups move by a fraction
/// of a texel: compared by FLIP only, the limits stated below.
#[test]
fn methods_agree_with_shadows() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let mut light_list = scenes::lights_in_slab(&scene, 2.0, 4.0, 12, 6, 7);
    light_list.push(point(Vec3::new(-1.0, 3.5, 0.0), 60.0));
    let lights = LightBuffers::with_casters(&ctx.device, &light_list, (4, 3)).unwrap();
    let cam = scenes::mixed_camera(W, H);
    let opts = ShadowOptions::default();
    let frame = |kind| {
        let mut r = renderer(kind, &sg, &lights, opts);
        render_frame(ctx, r.as_mut(), &sg, &cam)
    };
    let reference = frame(Kind::BruteForce);
    assert_matches_reference_frame("shadows-forward", W, &reference, &frame(Kind::ForwardPlus), FORWARD_VS_REFERENCE);
    // FLIP mean 0.02 and p99 0.1: the G-buffer's 8-bit albedo alone gives 0.0104 / 0.031
    // (compare::DEFERRED_VS_REFERENCE); a sub-texel shift of a PCF edge changes edge pixels
    // by up to one filter step (1/25) more.
    let deferred = frame(Kind::Deferred);
    let t = tiledlight_tests::images::FlipThresholds { mean: 0.02, percentile: (0.99, 0.1) };
    tiledlight_tests::images::assert_flip("shadows-deferred", W, H, &reference.ldr, &deferred.ldr, t);
}

/// Shadows only darken: every pixel the shadowed frame makes darker is, by the ray cast,
/// hidden from some caster somewhere within that caster's border.
#[test]
fn shadows_darken_only_what_a_caster_cannot_see() {
    let scene = scenes::mixed_scene();
    let tris = Triangles::new(scene.world_triangles());
    let light_list = bright_mixed_lights();
    let cam = scenes::mixed_camera(W, H);
    let opts = ShadowOptions::default();
    let r = render_pair(Kind::BruteForce, &scene, &light_list, (3, 2), opts, &cam);
    // The casters in the packed order: the lights as the GPU holds them.
    let casters: Vec<Light> = shadow_casters(&light_list, (3, 2)).unwrap();
    let mut darkened = 0;
    for (i, s) in surface_points(&cam, W, H, &r.depth).into_iter().enumerate() {
        let Some(s) = s else { continue };
        let full = lum(r.unshadowed.hdr[i]);
        if full < 2e-3 || lum(r.shadowed.hdr[i]) > 0.995 * full {
            continue;
        }
        darkened += 1;
        let hidden = casters.iter().any(|c| truth(&tris, c, s, opts) != Truth::Lit);
        assert!(hidden, "pixel ({}, {}) darkened by shadows but every caster sees it", i as u32 % W, i as u32 / W);
    }
    eprintln!("{darkened} pixels darkened by shadows, each hidden from some caster");
    assert!(darkened > 500, "shadows must darken part of the frame ({darkened} pixels)");
}

/// Three point and two spot lights bright enough to light the mixed scene's floor, boxes
/// and screens, with shadows falling on each other.
fn bright_mixed_lights() -> Vec<Light> {
    let spot = |p: Vec3, d: Vec3, c: Vec3| Light::spot(p, d.normalize(), c, 40.0, 0.3, 0.6, 0.05).expect("spot");
    vec![
        Light::point(Vec3::new(-1.0, 3.5, 0.0), Vec3::ONE, 40.0, 0.05).expect("light"),
        Light::point(Vec3::new(4.0, 2.5, -1.0), Vec3::new(1.0, 0.7, 0.4), 20.0, 0.05).expect("light"),
        Light::point(Vec3::new(-4.5, 2.0, 2.5), Vec3::new(0.5, 1.0, 0.6), 15.0, 0.05).expect("light"),
        spot(Vec3::new(-5.0, 4.0, 3.0), Vec3::new(0.6, -1.0, -0.6), Vec3::new(0.3, 0.5, 0.9)),
        spot(Vec3::new(5.0, 4.5, 4.0), Vec3::new(-0.8, -1.0, -0.9), Vec3::new(1.0, 0.9, 0.6)),
    ]
}

/// A still frame draws no shadow face; moving one point light redraws its six faces, one
/// spot light its one.
#[test]
fn only_moved_casters_are_redrawn() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let light_list = scenes::lights_in_slab(&scene, 2.0, 4.0, 5, 4, 5);
    let lights = LightBuffers::with_casters(&ctx.device, &light_list, (3, 2)).unwrap();
    let cam = scenes::mixed_camera(W, H);
    for kind in [Kind::ForwardPlus, Kind::Deferred] {
        let mut r = renderer(kind, &sg, &lights, ShadowOptions::default());
        let mut timer = GpuTimer::new(ctx).unwrap();
        let mut drawn = |r: &mut Box<dyn Renderer>| {
            r.render_once(ctx, &mut timer, &sg, &cam).unwrap();
            r.shadow_atlas().expect("atlas").faces_drawn_last_frame()
        };
        assert_eq!(drawn(&mut r), 3 * 6 + 2, "{kind:?}: the first frame draws every face");
        assert_eq!(drawn(&mut r), 0, "{kind:?}: a still frame draws none");
        let mut moved = lights.packed.clone();
        moved.shading[1].position[0] += 0.25;
        r.lights_moved(&ctx.queue, &moved).unwrap();
        assert_eq!(drawn(&mut r), 6, "{kind:?}: one moved point caster");
        let spot = moved.num_point as usize + 1;
        moved.spots[1].direction = (Vec3::from(moved.spots[1].direction) + Vec3::X * 0.1).normalize().to_array();
        r.lights_moved(&ctx.queue, &moved).unwrap();
        assert_eq!(drawn(&mut r), 1, "{kind:?}: one turned spot caster (light {spot})");
        // An unshadowed light moving redraws nothing.
        moved.shading[4].position[1] += 0.5;
        r.lights_moved(&ctx.queue, &moved).unwrap();
        assert_eq!(drawn(&mut r), 0, "{kind:?}: an unshadowed light moved");
    }
}

/// The shadow pass's CPU twin: each texel of each face holds the reversed-Z depth
/// (`near / view depth`) of the first surface hit by the ray from the light through the
/// texel's centre, or 0 where the ray hits nothing. Compared where the texel's 3x3
/// neighbourhood agrees (no silhouette edge crosses it, where coverage decides), within
/// 2 quanta of 16-bit depth (rounding of both sides).
#[test]
fn atlas_texels_hold_the_ray_cast_depth() {
    let ctx = gpu();
    let scene = shadow_box_scene(0.5);
    let tris = Triangles::new(scene.world_triangles());
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
    let spot_light = Light::spot(Vec3::new(-1.0, 5.0, -1.0), dir, Vec3::ONE, 300.0, 0.5, 0.7, 0.01).unwrap();
    let light_list = vec![point(Vec3::new(1.5, 4.0, 1.0), 200.0), spot_light];
    let lights = LightBuffers::with_casters(&ctx.device, &light_list, (1, 1)).unwrap();
    let opts = ShadowOptions { tile_size: 128, ..Default::default() };
    let mut r = renderer(Kind::ForwardPlus, &sg, &lights, opts);
    let mut timer = GpuTimer::new(ctx).unwrap();
    r.render_once(ctx, &mut timer, &sg, &box_camera()).unwrap();
    let atlas = r.shadow_atlas().expect("atlas");
    let layout = atlas.layout;
    let texels = atlas.read_layer(&ctx.device, &ctx.queue, 0).unwrap();
    let width = layout.width() as usize;
    let tile = opts.tile_size;
    let mut faces: Vec<(u32, Light)> = (0..6).map(|f| (layout.point_face(0, f), light_list[0])).collect();
    faces.push((layout.spot_face(0), spot_light));
    let (mut compared, mut wrong) = (0, Vec::new());
    for (face, light) in faces {
        let (view, proj) = atlas.face_view_proj(face);
        let rect = layout.rect(face);
        let inv = (proj * view).inverse();
        // The near plane the atlas chose: depth = near / view depth.
        let near = proj.w_axis.z;
        let expected = |u: i64, v: i64| -> f32 {
            let ndc = ((u as f32 + 0.5) / tile as f32 * 2.0 - 1.0, 1.0 - (v as f32 + 0.5) / tile as f32 * 2.0);
            let far = inv.project_point3(Vec3::new(ndc.0, ndc.1, 0.5));
            let ray = (far - light.position).normalize();
            let axis = view.inverse().transform_vector3(Vec3::NEG_Z);
            match tris.first_hit(light.position, ray, 1e4) {
                // Geometry nearer than the near plane is clipped.
                Some(t) if t * ray.dot(axis) >= near => near / (t * ray.dot(axis)),
                _ => 0.0,
            }
        };
        for v in 1..tile as i64 - 1 {
            for u in 1..tile as i64 - 1 {
                let e = expected(u, v);
                let flat = (-1..=1)
                    .all(|dv| (-1..=1).all(|du| ((expected(u + du, v + dv) - e).abs()) < 4.0 / 65535.0 + e * 0.02));
                if !flat {
                    continue;
                }
                compared += 1;
                let got = texels[(rect.y as usize + v as usize) * width + rect.x as usize + u as usize];
                if (got - e).abs() > 2.0 / 65535.0 {
                    wrong.push((face, u, v, got, e));
                }
            }
        }
    }
    eprintln!("atlas: {compared} texels compared, {} wrong", wrong.len());
    assert!(compared > 40_000, "too few texels compared: {compared}");
    assert!(
        wrong.is_empty(),
        "atlas texels differ from the ray cast (face, u, v, got, expected): {:?}",
        &wrong[..wrong.len().min(10)]
    );
}

#[test]
fn bad_shadow_input_is_named() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let few = scenes::lights(&scene, 3, 1, 1);
    // More casters than lights of the kind.
    let e = err_text(LightBuffers::with_casters(&ctx.device, &few, (4, 0)));
    assert!(e.contains("4 shadow-casting point lights") && e.contains("has 3"), "{e}");
    let e = err_text(LightBuffers::with_casters(&ctx.device, &few, (0, 2)));
    assert!(e.contains("2 shadow-casting spot lights") && e.contains("has 1"), "{e}");
    // A spot too wide for one tile is never chosen.
    let wide = vec![Light::spot(Vec3::Y * 3.0, Vec3::NEG_Y, Vec3::ONE, 10.0, 1.0, 1.5, 0.01).unwrap()];
    let e = err_text(LightBuffers::with_casters(&ctx.device, &wide, (0, 1)));
    assert!(e.contains("at most 80 degrees"), "{e}");
    // More casters than the atlas holds: the texture-array layer limit, named with the
    // casters and the rows they need.
    let max_layers = ctx.device.limits().max_texture_array_layers;
    let rows_per_layer = ctx.device.limits().max_texture_dimension_2d / 1024;
    let n = max_layers * rows_per_layer + 1;
    let many = scenes::lights(&scene, n, 0, 2);
    let lights = LightBuffers::with_casters(&ctx.device, &many, (n, 0)).unwrap();
    let opts = ShadowOptions { tile_size: 1024, ..Default::default() };
    let s = ForwardSettings { shadows: opts, ..Default::default() };
    let e = err_text(ForwardRenderer::new(ctx, &sg, &lights, W, H, s));
    assert!(e.contains(&format!("{n} point")) && e.contains(&format!("{max_layers} layers")), "{e}");
    // Tile sizes out of range.
    let lights = LightBuffers::with_casters(&ctx.device, &few, (1, 0)).unwrap();
    for tile in [64, 2048] {
        let s =
            DeferredSettings { shadows: ShadowOptions { tile_size: tile, ..Default::default() }, ..Default::default() };
        let e = err_text(DeferredRenderer::new(ctx, &sg, &lights, W, H, s));
        assert!(e.contains(&format!("shadow tile {tile}")) && e.contains("128 to 1024"), "{e}");
    }
}

/// Without casters nothing of the shadow path exists: no atlas, no plan step, no memory.
#[test]
fn no_casters_no_shadow_path() {
    let ctx = gpu();
    let scene = scenes::mixed_scene();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &scenes::lights(&scene, 8, 2, 1)).unwrap();
    let f = ForwardRenderer::new(ctx, &sg, &lights, W, H, ForwardSettings::default()).unwrap();
    assert!(f.shadow_atlas().is_none() && f.features().shadows.is_none());
    assert!(!f.plan().has(tiledlight_gpu::plan::Step::ShadowMaps));
    assert!(f.memory().entries.iter().all(|(c, _)| !c.starts_with("shadow")));
    let d = DeferredRenderer::new(ctx, &sg, &lights, W, H, DeferredSettings::default()).unwrap();
    assert!(d.shadow_atlas().is_none());
}
