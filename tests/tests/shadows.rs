//! Shadow-casting lights against a CPU ray-cast visibility reference
//! (`tiledlight_cull::raycast`, alpha masks honoured through `scenes::alpha_blocks`), on
//! lavapipe and real GPUs.
//!
//! - **The ray-cast comparison** ([`compare_visibility`], a function returning a verdict).
//!   Each light is rendered alone (every other light's radiance zeroed in the shading
//!   buffer, announced through `Renderer::lights_moved`: the light order, culling and the
//!   shader's caster indexing stay the production ones), shadowed and not; a pixel's
//!   visibility is the ratio. It must be lit (>= 0.98) where the ray cast says the light
//!   reaches the pixel and dark (<= 0.02) where it does not — both directions fail alike —
//!   unless the ray cast's visibility changes within a border around the pixel's lookup
//!   ([`border_texels`]: the filter's reach `r + 1`, half a texel of rasterisation and the
//!   normal offset, in texels whose size the test derives from the face's field of view and
//!   tile size ([`face_of`]), not from the production functions). The smallest margin
//!   (border minus the farthest penumbra pixel's distance to an edge) is printed.
//! - **Many casters.** Three point and three spot lights, two of each casting shadows
//!   (more lights than casters of each kind): spot faces indexed by the point-light count,
//!   a light reading another caster's faces or a non-caster reading a shadow put a shadow
//!   where the ray cast has none. For every filter (1, 3, 5 taps) and format (d16, d32).
//! - **Single casters**: a point, a spot and a point light whose shadow crosses a cube-face
//!   seam (a crack along it would be lit pixels inside the shadow; this case also sees a
//!   doubled normal offset), and Forward+ and Tiled Deferred.
//! - **Extremes**: a near plane of 1e-4 with no far plane; lights at the eye; lights inside
//!   an instance's bounds (under a table); lights 0.2-0.3 m from an occluder (0.2% of their
//!   radius); alpha-masked casters (and the same frames against a solid-screen ray cast,
//!   which must fail); MSAA 4x in both methods (pixels covering one surface); the 2.5D,
//!   clustered and scatter layouts in both methods.
//! - **The comparison can fail**: one flipped pixel each way, a shadow shifted by a pixel,
//!   another caster's shadow and a shadowed non-caster are rejected.
//! - **Acne and contact.** A lit plane at up to 80 degrees incidence stays lit; a box
//!   resting on the floor shadows the floor from within a stated number of texels of the
//!   contact.
//! - **Methods agree.** Forward+ and Tiled Deferred against brute force with the same
//!   shadows; shadows only darken pixels that the ray cast says some caster cannot see.
//! - **Only what moved.** A still frame draws no shadow face; moving one light redraws only
//!   its faces (counted, not timed).
//! - **The atlas itself** (the shadow pass's CPU twin): every texel of every face holds the
//!   depth of the first surface a ray through the texel centre meets; that comparison
//!   rejects one flipped texel and a face read one row off.
//! - **Peter-panning**: a plate hovering 0.8 texel over the floor shadows it (a bias grown
//!   past the design's half texel on axis lets light under it).
//! - **Bad input**: more casters than the atlas or the scene holds, wide spot cones.
//!
//! Ambient is zero, so a pixel's visibility is its shadowed radiance over its unshadowed
//! radiance (the same renderer without casters).

use glam::{Mat4, Vec3};
use tiledlight_cull::light::shadow_casters;
use tiledlight_cull::raycast::{surface_points, SurfacePoint as Surface, Triangles};
use tiledlight_cull::shadow::{ShadowFilter, ShadowFormat, ShadowOptions};
use tiledlight_cull::{Camera, Light};
use tiledlight_frame::{Diagnostics, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::{ClusterOptions, CullOptions};
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
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

fn renderer(kind: Kind, scene: &SceneGpu, lights: &LightBuffers, shadows: ShadowOptions) -> FrameRenderer {
    renderer_for(Variant { kind, cull: CullOptions::default(), msaa: 1 }, scene, lights, shadows)
}

/// A renderer configuration: method, light-grid layout and MSAA samples.
#[derive(Clone, Copy, Debug)]
struct Variant {
    kind: Kind,
    cull: CullOptions,
    msaa: u32,
}

impl Variant {
    fn of(kind: Kind) -> Self {
        Self { kind, cull: CullOptions::default(), msaa: 1 }
    }
}

fn renderer_for(v: Variant, scene: &SceneGpu, lights: &LightBuffers, shadows: ShadowOptions) -> FrameRenderer {
    let ctx = gpu();
    let (cull, msaa) = (v.cull, v.msaa);
    match v.kind {
        Kind::BruteForce | Kind::ForwardPlus => {
            let method =
                if v.kind == Kind::BruteForce { Method::BruteForce { cutoff: true } } else { Method::ForwardPlus };
            let s = FrameSettings { method, shadows, cull, msaa, ambient: Vec3::ZERO, ..Default::default() };
            FrameRenderer::new(ctx, scene, lights, W, H, s).expect("forward renderer")
        }
        Kind::Deferred => {
            let s = FrameSettings {
                method: Method::TiledDeferred,
                shadows,
                cull,
                msaa,
                ambient: Vec3::ZERO,
                ..Default::default()
            };
            FrameRenderer::new(ctx, scene, lights, W, H, s).expect("deferred renderer")
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
    let shadowed = render_frame(ctx, &mut r, &sg, cam);
    let depth = r.read_depth(ctx).expect("depth");
    let mut r = renderer(kind, &sg, &without, opts);
    let unshadowed = render_frame(ctx, &mut r, &sg, cam);
    Rendered { shadowed, unshadowed, depth }
}

fn lum(p: [f32; 4]) -> f32 {
    p[0] + p[1] + p[2]
}

/// Below this luminance of a light's unshadowed radiance a pixel is not judged: its ratio is
/// f16 noise (outside the radius or cone, or lit at grazing incidence).
const DIM: f32 = 2e-3;

/// Visibility a pixel the ray cast calls lit must reach, and a shadowed one stay under:
/// the ratio of two f16 HDR values (rounding 2^-11 relative each) is exact to ~1e-3, and
/// 2% leaves room for it and nothing else.
const LIT: f32 = 0.98;
const DARK: f32 = 0.02;

/// The shadow map's geometry at a surface point, derived here from the design
/// (crates/cull/src/shadow.rs module doc, steps 1-2) and NOT from the production functions
/// (`shadow::widened_tan`, `shadow::texel_per_depth`), so the test's tolerance does not grow
/// when they regress:
/// - a point light's faces are the cube's six 90-degree faces along the world axes (the
///   face of a direction is its largest axis), their texel rows along the other two world
///   axes; a spot's one face is centred on its axis, the cone's outer angle at the face
///   proper's edge, rows horizontal (the face's x axis is `axis x world up`);
/// - each tile of `tile` texels keeps a ring of `r + 1` texels (the filter's reach) around
///   the face proper, which therefore covers the inner `tile - 2 (r + 1)` texels: one texel
///   spans `2 tan(half-angle) / (tile - 2 (r + 1))` of the image plane at unit depth.
#[derive(Clone, Copy, Debug)]
struct Face {
    origin: Vec3,
    /// Unit axis and unit texel-row and -column directions.
    axis: Vec3,
    u: Vec3,
    v: Vec3,
    /// Image-plane size of one texel at unit depth.
    texel: f32,
}

fn face_of(light: &Light, p: Vec3, opts: ShadowOptions) -> Face {
    let margin = opts.filter.radius() as f32 + 1.0;
    let inner = opts.tile_size as f32 - 2.0 * margin;
    match light.kind {
        tiledlight_cull::LightKind::Point => {
            let d = p - light.position;
            let k = d.abs().max_position();
            let mut axis = Vec3::ZERO;
            axis[k] = d[k].signum();
            let (mut u, mut v) = (Vec3::ZERO, Vec3::ZERO);
            u[(k + 1) % 3] = 1.0;
            v[(k + 2) % 3] = 1.0;
            Face { origin: light.position, axis, u, v, texel: 2.0 / inner }
        }
        tiledlight_cull::LightKind::Spot { direction, outer_angle, .. } => {
            let up = if direction.y.abs() < 0.99 { Vec3::Y } else { Vec3::X };
            let u = direction.cross(up).normalize();
            let v = u.cross(direction);
            Face { origin: light.position, axis: direction, u, v, texel: 2.0 * outer_angle.tan() / inner }
        }
    }
}

impl Face {
    /// The point of the plane through `p` with normal `n` whose ray from the light passes
    /// `(du, dv)` texels from `p`'s in the shadow map; `None` where that ray runs parallel
    /// to the plane or meets it behind the light (grazing light: the ring cannot be drawn).
    fn offset(&self, p: Vec3, n: Vec3, du: f32, dv: f32) -> Option<Vec3> {
        let d = p - self.origin;
        let w = d.dot(self.axis);
        if w <= 0.0 {
            return None;
        }
        let dir = d / w + (self.u * du + self.v * dv) * self.texel;
        let denom = dir.dot(n);
        if denom.abs() < 1e-6 {
            return None;
        }
        let t = d.dot(n) / denom;
        (t > 0.0).then(|| self.origin + dir * t)
    }
}

/// Normal offset of the lookup, in texels at the receiver per `sin(theta)`: the design
/// lifts the lookup point by one on-axis texel (`tan-step x view depth`) times `sin(theta)`
/// (crates/cull/src/shadow.rs step 4). Restated here: a regression that lifts it further
/// moves the shadow beyond the border below.
const NORMAL_OFFSET_TEXELS: f32 = 1.0;

/// The border, in shadow-map texels (a square in the face's texel grid, Chebyshev
/// distance), within which the GPU's visibility of surface point `p` (normal `n`) may differ
/// from the ray cast's at `p` — the sum of what moves a PCF result from the exact answer:
/// - the filter's reach: its outermost tap lies `r` texels from the lookup and the hardware
///   2x2 comparison reads one texel further: `r + 1`;
/// - the rasterised silhouette: the shadow pass stores an occluder where it covers a texel's
///   centre, so the stored edge is within half a texel of the true one: `0.5`;
/// - the normal offset: the lookup point moves `NORMAL_OFFSET_TEXELS x sin(theta)` on-axis
///   texels (`texel x w`, w the view depth) along `n`; only the part across the ray moves it
///   in the map (`sin(theta)` of it), and across the ray at distance `w / cos(phi)` a world
///   length `a` turns the ray by `a cos(phi) / w`, which moves the map point by up to
///   `1 / cos^2(phi)` times that (phi: the ray's angle to the face's axis): at most
///   `NORMAL_OFFSET_TEXELS x sin^2(theta) / cos(phi)` texels.
fn border_texels(face: &Face, light: &Light, p: Vec3, n: Vec3, opts: ShadowOptions) -> f32 {
    let l = (light.position - p).normalize();
    let cos_t = n.dot(l).clamp(-1.0, 1.0);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let cos_phi = (-l).dot(face.axis).max(1e-3);
    opts.filter.radius() as f32 + 1.0 + 0.5 + NORMAL_OFFSET_TEXELS * sin_t * sin_t / cos_phi
}

/// The CPU ray cast with the scene's alpha masks: a segment is blocked by a triangle where
/// its material is opaque (`scenes::alpha_blocks`).
struct Reference<'a> {
    tris: Triangles,
    blocks: Box<dyn Fn(usize, f32, f32) -> bool + 'a>,
}

impl<'a> Reference<'a> {
    fn new(scene: &'a Scene) -> Self {
        Self { tris: Triangles::new(scene.world_triangles()), blocks: Box::new(scenes::alpha_blocks(scene)) }
    }

    /// The ray cast with every triangle solid, alpha-masked ones too: an upper bound on
    /// what can occlude.
    fn solid(scene: &Scene) -> Self {
        Self { tris: Triangles::new(scene.world_triangles()), blocks: Box::new(|_, _, _| true) }
    }

    /// Whether the light at `light` reaches surface point `q` with normal `n` (the segment
    /// starts 1 mm off the surface and ends 1 mm short of the light).
    fn visible(&self, light: Vec3, q: Vec3, n: Vec3) -> bool {
        let eps = 1e-3;
        !self.tris.occluded_where(q + n * eps, light, eps, &*self.blocks)
    }

    /// The smallest Chebyshev distance in texels (to a quarter texel, up to `max`) at which
    /// the ray cast's visibility differs from `centre`, searched on the squares around `p`'s
    /// lookup (16 points each); `Some(h)` also where a square cannot be drawn (grazing
    /// light), `None` when the visibility is the same everywhere within `max`.
    fn edge_distance(&self, face: &Face, light: Vec3, s: Surface, centre: bool, max: f32) -> Option<f32> {
        let mut h = 0.25;
        while h <= max + 1e-6 {
            for k in 0..16 {
                let t = -1.0 + (k % 4) as f32 * 0.5;
                let (du, dv) = match k / 4 {
                    0 => (t, -1.0),
                    1 => (1.0, t),
                    2 => (-t, 1.0),
                    _ => (-1.0, -t),
                };
                match face.offset(s.position, s.normal, du * h, dv * h) {
                    Some(q) if self.visible(light, q, s.normal) == centre => {}
                    _ => return Some(h),
                }
            }
            h += 0.25;
        }
        None
    }
}

/// A pixel where the GPU and the ray cast disagree beyond the border: (x, y, visibility).
type Miss = (u32, u32, f32);

/// One light's visibility compared with the ray cast.
#[derive(Debug, Default)]
struct Verdict {
    /// Pixels the light reaches that the ray cast calls lit / shadowed at their centre and
    /// that the GPU agrees on (the sets a wrong shadow would show in).
    lit: usize,
    shadowed: usize,
    /// Lit by the ray cast, darker than `LIT` on the GPU, no visibility change within the
    /// border: the two directions of failure.
    lit_but_dark: Vec<Miss>,
    shadowed_but_lit: Vec<Miss>,
    /// Smallest `border - distance to the nearest visibility change` over the pixels where
    /// the GPU differs from the centre's answer but within the border (the penumbra):
    /// how close the accepted pixels came to failing, in texels (infinite when none).
    margin: f32,
    /// The border's range over the pixels judged, in texels.
    border: (f32, f32),
    /// Visibility as grey with the verdicts painted over it (red: lit but dark, green:
    /// shadowed but lit), written on failure.
    overlay: Vec<u8>,
}

impl Verdict {
    fn passed(&self) -> bool {
        self.lit_but_dark.is_empty() && self.shadowed_but_lit.is_empty()
    }
}

/// Compares the GPU's visibility of `light` (`vis`, per pixel: shadowed over unshadowed
/// radiance of this light alone; `None` where it is dimmer than [`DIM`]) with the ray cast,
/// in both directions: a pixel differing from the ray cast at its centre fails unless the
/// ray cast's visibility changes within [`border_texels`] of it. A light that casts no
/// shadow (`caster` false) must be fully lit everywhere; its `shadowed` counts the pixels
/// the ray cast would shadow, where a wrong shadow lookup would show.
fn compare_visibility(
    reference: &Reference<'_>,
    light: &Light,
    caster: bool,
    surfaces: &[Option<Surface>],
    vis: &[Option<f32>],
    opts: ShadowOptions,
) -> Verdict {
    let mut t = Verdict { margin: f32::INFINITY, border: (f32::INFINITY, 0.0), ..Default::default() };
    t.overlay = vis
        .iter()
        .flat_map(|v| {
            let g = (v.unwrap_or(0.0).clamp(0.0, 1.0) * 200.0) as u8 + if v.is_some() { 40 } else { 0 };
            [g, g, g, 255]
        })
        .collect();
    for (i, (s, v)) in surfaces.iter().zip(vis).enumerate() {
        let (Some(s), Some(v)) = (s, v) else { continue };
        let (x, y) = (i as u32 % W, i as u32 / W);
        let centre = reference.visible(light.position, s.position, s.normal);
        let expect_lit = centre || !caster;
        let agrees = if expect_lit { *v >= LIT } else { *v <= DARK };
        if agrees {
            if centre {
                t.lit += 1;
            } else {
                t.shadowed += 1;
            }
            continue;
        }
        let miss = (x, y, *v);
        if !caster {
            t.lit_but_dark.push(miss);
            t.overlay[i * 4..i * 4 + 3].copy_from_slice(&[255, 0, 0]);
            continue;
        }
        let face = face_of(light, s.position, opts);
        let b = border_texels(&face, light, s.position, s.normal, opts);
        t.border = (t.border.0.min(b), t.border.1.max(b));
        match reference.edge_distance(&face, light.position, *s, centre, b) {
            Some(d) => t.margin = t.margin.min(b - d),
            None if centre => {
                t.lit_but_dark.push(miss);
                t.overlay[i * 4..i * 4 + 3].copy_from_slice(&[255, 0, 0]);
            }
            None => {
                t.shadowed_but_lit.push(miss);
                t.overlay[i * 4..i * 4 + 3].copy_from_slice(&[0, 255, 0]);
            }
        }
    }
    t
}

/// Per light, per pixel: luminance of that light's radiance alone, rendered by `r` with
/// every other light's radiance zeroed in the shading buffer (announced through
/// `Renderer::lights_moved`, as a program would). Every light stays in the buffers with its
/// radius, so the light order, the culling and the shader's caster indexing are the
/// production ones; only the shaded sum is one light's. Restores the buffer afterwards.
///
/// (Distinct colours would isolate only three lights, one per channel; zeroing isolates any
/// number, and a still shadow atlas — no caster moved — proves the shadows are the same
/// ones every frame: asserted.)
fn per_light(r: &mut FrameRenderer, sg: &SceneGpu, lb: &LightBuffers, cam: &Camera) -> Vec<Vec<f32>> {
    let ctx = gpu();
    let mut out = Vec::new();
    for i in 0..lb.packed.len() {
        let mut p = lb.packed.clone();
        for (j, sh) in p.shading.iter_mut().enumerate() {
            if j != i {
                sh.radiance = [0.0; 3];
            }
        }
        ctx.queue.write_buffer(&lb.shading, 0, &shading_bytes(&p.shading));
        r.lights_moved(&ctx.queue, &p).expect("lights moved");
        let f = render_frame(ctx, r, sg, cam);
        if let (Some(a), true) = (r.outputs().shadow_atlas, i > 0) {
            assert_eq!(a.faces_drawn_last_frame(), 0, "light {i}: a radiance change redrew shadow faces");
        }
        out.push(f.hdr.iter().map(|p| lum(*p)).collect());
    }
    ctx.queue.write_buffer(&lb.shading, 0, &shading_bytes(&lb.packed.shading));
    out
}

/// The shading buffer's bytes (`GpuShadingLight`: eight little-endian f32 each).
fn shading_bytes(lights: &[tiledlight_cull::light::GpuShadingLight]) -> Vec<u8> {
    let mut out = Vec::with_capacity(lights.len() * 32);
    for l in lights {
        let f = [
            l.position[0],
            l.position[1],
            l.position[2],
            l.radius,
            l.radiance[0],
            l.radiance[1],
            l.radiance[2],
            l._pad,
        ];
        out.extend(f.iter().flat_map(|x| x.to_le_bytes()));
    }
    out
}

/// A multi-light ray-cast case: the lights in the order the GPU packs them (points, then
/// spots, the casters first within each kind, as `LightBuffers::with_casters` orders the
/// brightest first: asserted), and per light the fewest lit and shadowed pixels its
/// comparison must have (so neither direction is tested on nothing).
struct Case<'a> {
    name: &'a str,
    scene: &'a Scene,
    lights: Vec<Light>,
    casters: (u32, u32),
    camera: Camera,
    min_counts: Vec<(usize, usize)>,
}

impl Case<'_> {
    fn is_caster(&self, i: usize) -> bool {
        let num_point = self.lights.iter().filter(|l| !l.is_spot()).count();
        i < self.casters.0 as usize || (i >= num_point && i - num_point < self.casters.1 as usize)
    }
}

/// A case rendered: the surfaces the pixels show, and per shadow option, per light, per
/// pixel the light's visibility (shadowed over unshadowed radiance of that light alone;
/// `None` where it is dimmer than [`DIM`]).
struct Visibility {
    surfaces: Vec<Option<Surface>>,
    vis: Vec<Vec<Vec<Option<f32>>>>,
}

/// The pixels of `surfaces` whose eight neighbours lie on the same plane (normals within
/// 2.6 degrees, positions within 1e-3 of their distance off it): with MSAA a pixel's samples may lie on several surfaces and the resolve
/// averages their shading, while the 1x surface point describes one of them; at a crease
/// (a box's edge) the other face's samples are judged by the wrong plane. Those pixels,
/// and silhouettes (no surface point), are left out of the MSAA comparisons.
fn single_surface_pixels(surfaces: &[Option<Surface>]) -> Vec<Option<Surface>> {
    let (w, h) = (W as i64, H as i64);
    (0..surfaces.len())
        .map(|i| {
            let s = surfaces[i]?;
            let (x, y) = (i as i64 % w, i as i64 / w);
            for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    return None;
                }
                let n = surfaces[(ny * w + nx) as usize]?;
                // Same orientation and the same plane (a floor behind a box's top edge
                // has the top's normal).
                let off_plane = (n.position - s.position).dot(s.normal).abs();
                if n.normal.dot(s.normal) < 0.999 || off_plane > 1e-3 * (n.position - s.position).length() + 1e-4 {
                    return None;
                }
            }
            Some(s)
        })
        .collect()
}

/// Renders `case` with `variant` for each of `options`, each light alone, shadowed and not.
fn render_case(case: &Case<'_>, variant: Variant, options: &[ShadowOptions]) -> Visibility {
    let ctx = gpu();
    let sg = SceneGpu::new(&ctx.device, &ctx.queue, case.scene).expect("scene");
    let with = LightBuffers::with_casters(&ctx.device, &case.lights, case.casters).expect("lights with casters");
    let without = LightBuffers::new(&ctx.device, &case.lights).expect("lights");
    assert_eq!(with.packed.shading, without.packed.shading, "{}: the lights must be given in packed order", case.name);
    let ordered: Vec<Light> = shadow_casters(&case.lights, case.casters).unwrap();
    for (k, c) in ordered.iter().enumerate() {
        let i = if k < case.casters.0 as usize { k } else { with.num_point() as usize + k - case.casters.0 as usize };
        assert_eq!(c.position, case.lights[i].position, "{}: caster {k} is light {i}", case.name);
    }
    // Surfaces from a 1x depth buffer (MSAA variants shade the same surfaces at the pixel
    // centre away from geometric edges, where `surface_points` has none).
    let depth = {
        let mut r = renderer_for(Variant::of(Kind::BruteForce), &sg, &without, ShadowOptions::default());
        render_frame(ctx, &mut r, &sg, &case.camera);
        r.read_depth(ctx).expect("depth")
    };
    let mut surfaces = surface_points(&case.camera, W, H, &depth);
    if variant.msaa > 1 {
        surfaces = single_surface_pixels(&surfaces);
    }
    let full = {
        let mut r = renderer_for(variant, &sg, &without, ShadowOptions::default());
        per_light(&mut r, &sg, &without, &case.camera)
    };
    let vis = options
        .iter()
        .map(|&opts| {
            let mut r = renderer_for(variant, &sg, &with, opts);
            let shadowed = per_light(&mut r, &sg, &with, &case.camera);
            full.iter()
                .zip(&shadowed)
                .map(|(f, s)| f.iter().zip(s).map(|(&f, &s)| (f >= DIM).then(|| s / f)).collect())
                .collect()
        })
        .collect();
    Visibility { surfaces, vis }
}

/// Renders `case` with `variant` for each of `options` and compares every light with the
/// ray cast. Returns the failures as text (empty: passed), after printing each light's
/// counts, border and margin.
fn run_case(case: &Case<'_>, reference: &Reference<'_>, variant: Variant, options: &[ShadowOptions]) -> Vec<String> {
    let rendered = render_case(case, variant, options);
    let mut failures = Vec::new();
    for (&opts, per_light) in options.iter().zip(&rendered.vis) {
        for (i, (light, vis)) in case.lights.iter().zip(per_light).enumerate() {
            let caster = case.is_caster(i);
            let t = compare_visibility(reference, light, caster, &rendered.surfaces, vis, opts);
            let what = format!(
                "{} light {i} ({}{}; {:?} {} {}x MSAA, {}x{} PCF, {} px, {})",
                case.name,
                if light.is_spot() { "spot" } else { "point" },
                if caster { " caster" } else { "" },
                variant.kind,
                layout_name(variant.cull),
                variant.msaa,
                opts.filter.size(),
                opts.filter.size(),
                opts.tile_size,
                opts.format.name()
            );
            let penumbra = if t.margin.is_finite() {
                format!("border {:.2}-{:.2} texels, margin {:.2} texels", t.border.0, t.border.1, t.margin)
            } else {
                "no penumbra pixel".to_string()
            };
            eprintln!(
                "{what}: {} lit, {} shadowed; {penumbra}; wrong: {} lit-but-dark, {} shadowed-but-lit",
                t.lit,
                t.shadowed,
                t.lit_but_dark.len(),
                t.shadowed_but_lit.len()
            );
            let (min_lit, min_shadowed) = case.min_counts[i];
            if t.lit < min_lit || t.shadowed < min_shadowed {
                failures.push(format!(
                    "{what}: too few pixels to judge: {} lit (need {min_lit}), {} shadowed (need {min_shadowed})",
                    t.lit, t.shadowed
                ));
            }
            if !t.passed() || std::env::var_os("TILEDLIGHT_SHADOW_OVERLAYS").is_some() {
                let file = format!(
                    "shadows-{}-{i}-{:?}-{}-{}x-{}-{}.png",
                    case.name,
                    variant.kind,
                    layout_name(variant.cull),
                    variant.msaa,
                    opts.filter.size(),
                    opts.format.name()
                )
                .replace(' ', "_");
                tiledlight_tests::images::save_png(&tiledlight_tests::output_dir().join(file), W, H, &t.overlay);
            }
            if !t.passed() {
                failures.push(format!(
                    "{what}: the GPU disagrees with the ray cast beyond the border (x, y, visibility): \
                     lit but dark {:?} ({} in all); shadowed but lit {:?} ({} in all)",
                    &t.lit_but_dark[..t.lit_but_dark.len().min(6)],
                    t.lit_but_dark.len(),
                    &t.shadowed_but_lit[..t.shadowed_but_lit.len().min(6)],
                    t.shadowed_but_lit.len()
                ));
            }
        }
    }
    failures
}

fn layout_name(c: CullOptions) -> &'static str {
    match (c.clusters.is_some(), c.depth_mask, c.scatter) {
        (true, _, _) => "clustered",
        (false, true, _) => "2.5D",
        (false, false, true) => "tiled-scatter",
        _ => "tiled",
    }
}

fn assert_case(case: &Case<'_>, reference: &Reference<'_>, variant: Variant, options: &[ShadowOptions]) {
    let failures = run_case(case, reference, variant, options);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
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

/// A white spot at `pos` aimed at `at`, cone 0.5-0.7 rad, cut off at 0.01.
fn spot_at(pos: Vec3, at: Vec3, intensity: f32) -> Light {
    Light::spot(pos, (at - pos).normalize(), Vec3::ONE, intensity, 0.5, 0.7, 0.01).expect("spot")
}

fn point(pos: Vec3, intensity: f32) -> Light {
    Light::point(pos, Vec3::ONE, intensity, 0.01).expect("light")
}

fn assert_matches_ray_cast(name: &str, scene: &Scene, light: Light, opts: ShadowOptions, kind: Kind) {
    let casters = if light.is_spot() { (0, 1) } else { (1, 0) };
    // Both sets must be large, or the comparison tests nothing.
    let case = Case { name, scene, lights: vec![light], casters, camera: box_camera(), min_counts: vec![(2000, 200)] };
    assert_case(&case, &Reference::new(scene), Variant::of(kind), &[opts]);
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
    let reference = Reference::new(&scene);
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
        let face = face_of(&light, s.position, opts);
        let b = border_texels(&face, &light, s.position, s.normal, opts);
        if reference.visible(light.position, s.position, s.normal)
            || reference.edge_distance(&face, light.position, s, false, b).is_some()
        {
            continue;
        }
        shadowed += 1;
        let v = lum(r.shadowed.hdr[i]) / full;
        // One texel's world size there (the face's tan-step times the view depth).
        let texel = face.texel * (s.position - light.position).dot(face.axis);
        let gap = (s.position.x - 1.0) / texel;
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
/// rebuilds positions from depth and stores packed (14-bit octahedral) normals, so its lookups move by a fraction
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
        render_frame(ctx, &mut r, &sg, &cam)
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
///
/// The ray cast here treats every triangle as solid, the alpha-masked screen too: an upper
/// bound on what can occlude, the same on every adapter. The mixed scene's screen samples
/// its mask with linear filtering through mipmaps, and Vulkan leaves the level of detail a
/// shadow pass picks to the implementation, so where its checker's shadow edges fall
/// differs between adapters by more than a shadow texel: measured on the H200 (where the
/// masked ray cast flagged six floor pixels 0.5-3 texels beyond the border, darkened 1-15%)
/// and on lavapipe (one pixel of one spot's shadow, lit 41%, when every light was compared
/// alone against the masked ray cast). The mask's own shadow, both directions, is compared
/// in `alpha_masked_casters_match_the_masked_ray_cast`, whose screen is sampled NEAREST
/// without mipmaps so its edges are exact on every adapter.
#[test]
fn shadows_darken_only_what_a_caster_cannot_see() {
    let scene = scenes::mixed_scene();
    let reference = Reference::solid(&scene);
    let light_list = bright_mixed_lights();
    let cam = scenes::mixed_camera(W, H);
    let opts = ShadowOptions::default();
    let r = render_pair(Kind::BruteForce, &scene, &light_list, (3, 2), opts, &cam);
    // The casters in the packed order: the lights as the GPU holds them.
    let casters: Vec<Light> = shadow_casters(&light_list, (3, 2)).unwrap();
    let (mut darkened, mut seen) = (0, Vec::new());
    for (i, s) in surface_points(&cam, W, H, &r.depth).into_iter().enumerate() {
        let Some(s) = s else { continue };
        let full = lum(r.unshadowed.hdr[i]);
        if full < 2e-3 || lum(r.shadowed.hdr[i]) > 0.995 * full {
            continue;
        }
        darkened += 1;
        let hidden = casters.iter().any(|c| {
            let face = face_of(c, s.position, opts);
            let b = border_texels(&face, c, s.position, s.normal, opts);
            !reference.visible(c.position, s.position, s.normal)
                || reference.edge_distance(&face, c.position, s, true, b).is_some()
        });
        if !hidden {
            // Per caster: its border and how far away (texels, searched to 4x the border)
            // its visibility changes, to tell a border too narrow from a wrong shadow.
            let detail: Vec<String> = casters
                .iter()
                .map(|c| {
                    let face = face_of(c, s.position, opts);
                    let b = border_texels(&face, c, s.position, s.normal, opts);
                    format!(
                        "border {b:.2}, change at {:?}",
                        reference.edge_distance(&face, c.position, s, true, 4.0 * b)
                    )
                })
                .collect();
            seen.push(format!(
                "({}, {}) at {:?}, visibility {:.4}: {}",
                i as u32 % W,
                i as u32 / W,
                s.position,
                lum(r.shadowed.hdr[i]) / full,
                detail.join("; ")
            ));
        }
    }
    eprintln!("{darkened} pixels darkened by shadows, {} of them seen by every caster", seen.len());
    assert!(seen.is_empty(), "darkened by shadows but every caster sees them:\n{}", seen.join("\n"));
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
        let mut drawn = |r: &mut FrameRenderer| {
            r.render_once(ctx, &mut timer, &sg, &cam).unwrap();
            r.outputs().shadow_atlas.expect("atlas").faces_drawn_last_frame()
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

/// The ray cast's depth for every texel of one atlas face (`tile` x `tile`, row-major):
/// the reversed-Z depth (`near / view depth`) of the first surface hit by the ray from the
/// light through the texel's centre, or 0 where the ray hits nothing or only geometry
/// nearer than the near plane (clipped).
fn face_ray_cast_depth(tris: &Triangles, light: &Light, (view, proj): (Mat4, Mat4), tile: u32) -> Vec<f32> {
    let inv = (proj * view).inverse();
    let near = proj.w_axis.z;
    let axis = view.inverse().transform_vector3(Vec3::NEG_Z);
    (0..tile * tile)
        .map(|i| {
            let (u, v) = (i % tile, i / tile);
            let ndc = ((u as f32 + 0.5) / tile as f32 * 2.0 - 1.0, 1.0 - (v as f32 + 0.5) / tile as f32 * 2.0);
            let far = inv.project_point3(Vec3::new(ndc.0, ndc.1, 0.5));
            let ray = (far - light.position).normalize();
            match tris.first_hit(light.position, ray, 1e4) {
                Some(t) if t * ray.dot(axis) >= near => near / (t * ray.dot(axis)),
                _ => 0.0,
            }
        })
        .collect()
}

/// Whether the ray cast's depth around texel (u, v) of a face (`expected`, `tile` wide) is
/// flat: its 3x3 neighbourhood within 4 quanta of 16-bit depth plus 2% (no silhouette
/// edge crosses it, where coverage rather than depth decides the texel).
fn flat_texel(expected: &[f32], tile: u32, u: u32, v: u32) -> bool {
    let at = |u: u32, v: u32| expected[(v * tile + u) as usize];
    let e = at(u, v);
    (v - 1..=v + 1).all(|y| (u - 1..=u + 1).all(|x| (at(x, y) - e).abs() < 4.0 / 65535.0 + e * 0.02))
}

/// Texels of one face where the atlas differs from the ray cast: (u, v, got, expected).
type AtlasMiss = (u32, u32, f32, f32);

/// Compares the atlas layer `texels` (`width` wide) inside `rect` with `expected` (from
/// [`face_ray_cast_depth`]) where the texel's 3x3 neighbourhood agrees (no silhouette edge
/// crosses it, where coverage decides), within 2 quanta of 16-bit depth (rounding of both
/// sides). Returns the texels compared and those that differ.
fn compare_atlas_face(
    texels: &[f32],
    width: usize,
    rect: tiledlight_cull::shadow::FaceRect,
    expected: &[f32],
    tile: u32,
) -> (usize, Vec<AtlasMiss>) {
    let (mut compared, mut wrong) = (0, Vec::new());
    for v in 1..tile - 1 {
        for u in 1..tile - 1 {
            if !flat_texel(expected, tile, u, v) {
                continue;
            }
            let e = expected[(v * tile + u) as usize];
            compared += 1;
            let got = texels[(rect.y + v) as usize * width + (rect.x + u) as usize];
            if (got - e).abs() > 2.0 / 65535.0 {
                wrong.push((u, v, got, e));
            }
        }
    }
    (compared, wrong)
}

/// The shadow pass's CPU twin: each texel of each face holds the ray cast's depth
/// ([`face_ray_cast_depth`]), compared by [`compare_atlas_face`]. The comparison can fail:
/// the same atlas with two compared texels flipped (one emptied, one filled at the near
/// plane) is rejected at exactly those texels, and a face read one
/// texel row off (a wrong tile offset) is rejected outright.
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
    let atlas = r.outputs().shadow_atlas.expect("atlas");
    let layout = atlas.layout;
    let texels = atlas.read_layer(&ctx.device, &ctx.queue, 0).unwrap();
    let width = layout.width() as usize;
    let tile = opts.tile_size;
    let mut faces: Vec<(u32, Light)> = (0..6).map(|f| (layout.point_face(0, f), light_list[0])).collect();
    faces.push((layout.spot_face(0), spot_light));
    let expected: Vec<Vec<f32>> = faces
        .iter()
        .map(|&(face, light)| face_ray_cast_depth(&tris, &light, atlas.face_view_proj(face), tile))
        .collect();
    let (mut compared, mut wrong) = (0, Vec::new());
    for (&(face, _), e) in faces.iter().zip(&expected) {
        let (c, w) = compare_atlas_face(&texels, width, layout.rect(face), e, tile);
        compared += c;
        wrong.extend(w.into_iter().map(|m| (face, m)));
    }
    eprintln!("atlas: {compared} texels compared, {} wrong", wrong.len());
    assert!(compared > 40_000, "too few texels compared: {compared}");
    assert!(
        wrong.is_empty(),
        "atlas texels differ from the ray cast (face, (u, v, got, expected)): {:?}",
        &wrong[..wrong.len().min(10)]
    );

    // Negative: the spot face with one occluder texel emptied and another filled at the
    // near plane (depth 1).
    let (face, e) = (faces[6].0, &expected[6]);
    let rect = layout.rect(face);
    let index = |(u, v): (u32, u32)| (rect.y + v) as usize * width + (rect.x + u) as usize;
    let mut flat_hits = (tile / 4..3 * tile / 4)
        .flat_map(|v| (tile / 4..3 * tile / 4).map(move |u| (u, v)))
        .filter(|&(u, v)| e[(v * tile + u) as usize] > 0.0 && flat_texel(e, tile, u, v));
    let (emptied, filled) = (flat_hits.next().expect("a flat texel"), flat_hits.nth(40).expect("another"));
    let mut flipped = texels.clone();
    flipped[index(emptied)] = 0.0;
    flipped[index(filled)] = 1.0;
    let (_, caught) = compare_atlas_face(&flipped, width, rect, e, tile);
    let mut caught: Vec<(u32, u32)> = caught.iter().map(|m| (m.0, m.1)).collect();
    caught.sort_by_key(|&(u, v)| (v, u));
    eprintln!("atlas negative: flipped {emptied:?} and {filled:?}, rejected {caught:?}");
    let mut want = vec![emptied, filled];
    want.sort_by_key(|&(u, v)| (v, u));
    assert_eq!(caught, want, "each flipped texel, and only it, must be rejected");
    // Negative: the face read one texel row lower (a wrong tile offset).
    let shifted = tiledlight_cull::shadow::FaceRect { y: rect.y + 1, ..rect };
    let (c, off) = compare_atlas_face(&texels, width, shifted, e, tile);
    eprintln!("atlas negative: a face read one row off: {} of {c} texels rejected", off.len());
    assert!(off.len() * 100 > c, "a face read one row off must be rejected ({} of {c})", off.len());
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
    let s = FrameSettings { shadows: opts, ..Default::default() };
    let e = err_text(FrameRenderer::new(ctx, &sg, &lights, W, H, s));
    assert!(e.contains(&format!("{n} point")) && e.contains(&format!("{max_layers} layers")), "{e}");
    // Tile sizes out of range.
    let lights = LightBuffers::with_casters(&ctx.device, &few, (1, 0)).unwrap();
    for tile in [64, 2048] {
        let s = FrameSettings {
            method: Method::TiledDeferred,
            shadows: ShadowOptions { tile_size: tile, ..Default::default() },
            ..Default::default()
        };
        let e = err_text(FrameRenderer::new(ctx, &sg, &lights, W, H, s));
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
    let f = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings::default()).unwrap();
    assert!(f.outputs().shadow_atlas.is_none() && f.features().shadows.is_none());
    assert!(!f.plan().has(tiledlight_frame::plan::Step::ShadowMaps));
    assert!(f.memory().entries.iter().all(|(c, _)| !c.starts_with("shadow")));
    let d = FrameRenderer::new(ctx, &sg, &lights, W, H, FrameSettings::of(Method::TiledDeferred)).unwrap();
    assert!(d.outputs().shadow_atlas.is_none());
}

/// Three point lights (the first two cast shadows) and three spots (the first two cast)
/// around the box, each caster's shadow of the box in view, in the order the GPU packs
/// them (each caster brighter than the non-casters of its kind). More point lights than
/// point casters and more spots than spot casters: a shader that finds a spot's face by
/// `num_point_lights` instead of the point-caster count, or a light reading another
/// caster's faces, puts its shadow elsewhere; a non-caster that reads shadows gets one.
fn multi_lights() -> Vec<Light> {
    let spot =
        |p: Vec3, at: Vec3, i: f32| Light::spot(p, (at - p).normalize(), Vec3::ONE, i, 0.45, 0.7, 0.01).expect("spot");
    vec![
        point(Vec3::new(1.5, 6.0, 1.0), 200.0),
        point(Vec3::new(-4.5, 3.2, -2.5), 180.0),
        point(Vec3::new(3.5, 4.5, -3.0), 100.0),
        spot(Vec3::new(-3.0, 7.0, 2.0), Vec3::ZERO, 300.0),
        spot(Vec3::new(4.0, 6.0, 3.0), Vec3::new(-1.0, 0.0, -1.0), 280.0),
        spot(Vec3::new(-1.0, 7.0, -5.0), Vec3::new(0.5, 0.0, 1.0), 150.0),
    ]
}

/// Lit and shadowed pixels each light's comparison needs (measured on lavapipe with 5x5
/// PCF: see the printed counts; about half of each, so a shadow that left the view or a
/// light that lit nothing fails).
const MULTI_MIN: [(usize, usize); 6] =
    [(15000, 300), (15000, 300), (15000, 300), (8000, 300), (8000, 300), (8000, 300)];

fn multi_case(scene: &Scene) -> Case<'_> {
    Case {
        name: "multi",
        scene,
        lights: multi_lights(),
        casters: (2, 2),
        camera: box_camera(),
        min_counts: MULTI_MIN.to_vec(),
    }
}

/// Several casters of both kinds and lights that cast none, every light alone against
/// the ray cast in both directions, for each filter (1, 3, 5 taps) in 16-bit depth and for
/// 32-bit depth.
#[test]
fn many_casters_match_the_ray_cast_for_every_filter_and_format() {
    let scene = shadow_box_scene(0.5);
    let reference = Reference::new(&scene);
    let mut options: Vec<ShadowOptions> =
        FILTERS.iter().map(|&filter| ShadowOptions { filter, ..Default::default() }).collect();
    options.push(ShadowOptions { format: ShadowFormat::Depth32, tile_size: 512, ..Default::default() });
    options.push(ShadowOptions { format: ShadowFormat::Depth32, filter: ShadowFilter::Tap1, ..Default::default() });
    assert_case(&multi_case(&scene), &reference, Variant::of(Kind::BruteForce), &options);
}

/// The ray-cast comparison can fail: on the GPU's own visibility of the multi-caster case
/// (5x5 PCF) broken on purpose, it rejects
/// - one pixel flipped each way (a shadowed pixel, far from any edge, made fully lit; a lit
///   one made dark): exactly that pixel;
/// - the shadow shifted sideways by a few pixels (the smallest rejected shift printed and
///   bounded);
/// - a caster's visibility judged against another caster's ray cast (the shader reading
///   another light's faces, simulated on the CPU);
/// - a caster's visibility judged as a light without shadows (a non-caster that reads a
///   shadow).
#[test]
fn ray_cast_comparison_rejects_broken_shadows() {
    let scene = shadow_box_scene(0.5);
    let reference = Reference::new(&scene);
    let case = multi_case(&scene);
    let opts = ShadowOptions::default();
    let rendered = render_case(&case, Variant::of(Kind::BruteForce), &[opts]);
    let surfaces = &rendered.surfaces;
    let judge = |light: usize, caster: bool, vis: &[Option<f32>]| {
        compare_visibility(&reference, &case.lights[light], caster, surfaces, vis, opts)
    };
    for light in [0, 3] {
        let l = &case.lights[light];
        let vis = &rendered.vis[0][light];
        assert!(judge(light, true, vis).passed(), "light {light}: the unbroken input must pass");
        // A pixel far from every edge in each state.
        let certain = |want_lit: bool| {
            (0..vis.len())
                .find(|&i| {
                    let (Some(s), Some(v)) = (surfaces[i], vis[i]) else { return false };
                    let centre = reference.visible(l.position, s.position, s.normal);
                    let face = face_of(l, s.position, opts);
                    let b = border_texels(&face, l, s.position, s.normal, opts);
                    centre == want_lit
                        && (if want_lit { v >= LIT } else { v <= DARK })
                        && reference.edge_distance(&face, l.position, s, centre, 2.0 * b).is_none()
                })
                .expect("a pixel far from the shadow's edges")
        };
        for (want_lit, flipped) in [(true, 0.0), (false, 1.0)] {
            let i = certain(want_lit);
            let mut broken = vis.clone();
            broken[i] = Some(flipped);
            let t = judge(light, true, &broken);
            let wrong = if want_lit { &t.lit_but_dark } else { &t.shadowed_but_lit };
            let other = if want_lit { &t.shadowed_but_lit } else { &t.lit_but_dark };
            assert_eq!(wrong.len(), 1, "light {light}: one flipped pixel ({i}) must be rejected: {wrong:?}");
            assert_eq!((wrong[0].0, wrong[0].1), (i as u32 % W, i as u32 / W));
            assert!(other.is_empty());
        }
        // The whole image shifted right by k pixels: the shadow moves, its edges do not
        // line up with the ray cast's any more.
        let shifted = |k: usize| -> Vec<Option<f32>> {
            (0..vis.len()).map(|i| if (i % W as usize) < k { None } else { vis[i - k] }).collect()
        };
        let first = (1..=8).find(|&k| !judge(light, true, &shifted(k)).passed());
        eprintln!("light {light}: the smallest shift of the shadow rejected: {first:?} pixels");
        // The border is 3.6-4.9 texels of 2.3-3.3 cm here, seen from 11-12 m where a pixel
        // spans ~7.5 cm (about three texels), and the GPU's penumbra already uses all but
        // ~1 texel of it (the printed margin): a shift of one or two pixels is past it.
        assert!(first.is_some_and(|k| k <= 2), "light {light}: a shifted shadow passed ({first:?})");
        // Another caster's shadow, and a shadow on a light that casts none.
        let other = if light == 0 { 1 } else { 4 };
        assert!(!judge(other, true, vis).passed(), "light {light}'s shadow judged as light {other}'s must fail");
        assert!(!judge(light, false, vis).passed(), "light {light}'s shadow on a non-caster must fail");
    }
}

/// Each light alone against the ray cast, 5x5 PCF, for the extremes: see each case.
fn assert_extreme(case: &Case<'_>, reference: &Reference<'_>) {
    assert_case(case, reference, Variant::of(Kind::BruteForce), &[ShadowOptions::default()]);
}

/// The multi-caster case seen by a camera with a 1e-4 m near plane and an infinite far
/// plane (reversed-Z: the depth buffer holds `1e-4 / distance`, the surfaces are rebuilt
/// from it).
#[test]
fn shadows_with_a_near_plane_of_1e_4_and_no_far_plane() {
    let scene = shadow_box_scene(0.5);
    let mut case = multi_case(&scene);
    case.name = "near 1e-4";
    case.camera = Camera::perspective(
        Vec3::new(0.0, 9.0, 9.0),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::Y,
        60f32.to_radians(),
        W as f32 / H as f32,
        1e-4,
        None,
    )
    .expect("camera");
    assert_extreme(&case, &Reference::new(&scene));
}

/// A point and a spot caster at the camera's eye (the spot along the view): every surface
/// the camera sees, the light sees, so the ray cast shadows nothing and the GPU must not
/// either (no acne, no near-plane clipping of what the light faces); a third caster
/// elsewhere keeps the shadowed direction tested in the same frames.
#[test]
fn shadows_of_a_light_at_the_eye() {
    let scene = shadow_box_scene(0.5);
    let cam = box_camera();
    let eye = cam.eye();
    let target = Vec3::new(0.5, 0.0, 0.0);
    let spot = spot_at(eye, target, 400.0);
    let case = Case {
        name: "at the eye",
        scene: &scene,
        lights: vec![point(eye, 300.0), point(Vec3::new(1.5, 6.0, 1.0), 200.0), spot],
        casters: (2, 1),
        camera: cam,
        // The eye's lights shadow nothing the camera sees: no shadowed pixel to ask for.
        min_counts: vec![(30000, 0), (15000, 300), (15000, 0)],
    };
    assert_extreme(&case, &Reference::new(&scene));
}

/// Casters inside an instance's bounds: a point and a spot light under a table (one
/// instance: top and legs), the legs shadowing the floor around it. The shadow faces'
/// near plane ignores the instance around the light (`shadow::nearest_bounds`), so it
/// stays at 1% of the radius; every table surface lies beyond it here.
#[test]
fn shadows_of_lights_inside_an_instances_bounds() {
    let scene = scenes::table_scene();
    let under = Vec3::new(0.2, 1.0, -0.1);
    let spot_pos = Vec3::new(-0.3, 1.3, 0.4);
    let spot =
        Light::spot(spot_pos, (Vec3::new(-4.0, 0.0, 3.0) - spot_pos).normalize(), Vec3::ONE, 60.0, 0.6, 0.9, 0.01)
            .expect("spot");
    let camera = Camera::perspective(
        Vec3::new(5.0, 7.0, 9.0),
        Vec3::new(-0.5, 0.0, 0.0),
        Vec3::Y,
        60f32.to_radians(),
        W as f32 / H as f32,
        0.1,
        None,
    )
    .expect("camera");
    let case = Case {
        name: "inside bounds",
        scene: &scene,
        lights: vec![point(under, 60.0), spot],
        casters: (1, 1),
        camera,
        min_counts: vec![(5000, 300), (3000, 300)],
    };
    let table = scene.instances[1].transform;
    let bounds = scene.meshes[1].bounds().transformed(&table);
    assert!(bounds.contains(under) && bounds.contains(spot_pos), "the lights must be inside the table's bounds");
    assert_extreme(&case, &Reference::new(&scene));
}

/// Casters next to an occluder, far closer than 1% of their radius (141 m: 1.4 m): a point
/// light 0.3 m from the box's side and a spot 0.2 m over its top, 0.2 m inside its front
/// edge, aiming down past the edge (the box cuts off the half of the cone nearer it). The
/// faces' near plane must come in short of the box (`shadow_near`), and 16-bit depth keep
/// its resolution far away.
#[test]
fn shadows_of_lights_next_to_an_occluder() {
    let scene = shadow_box_scene(0.5);
    let spot_pos = Vec3::new(0.3, 2.7, 0.8);
    let spot = spot_at(spot_pos, Vec3::new(0.3, 0.0, 3.5), 200.0);
    let case = Case {
        name: "next to an occluder",
        scene: &scene,
        lights: vec![point(Vec3::new(1.3, 1.5, 0.0), 200.0), spot],
        casters: (1, 1),
        camera: box_camera(),
        min_counts: vec![(5000, 300), (3000, 300)],
    };
    let radius = case.lights[0].radius;
    assert!(0.3 < 0.01 * radius, "the point light must be within 1% of its radius ({radius} m) of the box");
    assert_extreme(&case, &Reference::new(&scene));
}

/// Alpha-masked casters: a horizontal screen with a checker of holes over the floor, a
/// point and a spot caster over it. The ray cast lets light through the holes exactly where
/// the GPU's alpha test discards (`scenes::alpha_blocks`; nearest sampling), so the
/// floor's checker of light and shadow must match in both directions; the same frames
/// judged against a ray cast that treats the screen as solid must fail (the mask is what
/// makes them agree).
#[test]
fn alpha_masked_casters_match_the_masked_ray_cast() {
    let scene = scenes::masked_screen_scene();
    let spot_pos = Vec3::new(-3.0, 6.0, 2.0);
    let spot = spot_at(spot_pos, Vec3::new(0.5, 0.0, -0.5), 300.0);
    let case = Case {
        name: "alpha mask",
        scene: &scene,
        lights: vec![point(Vec3::new(0.3, 5.0, 0.2), 200.0), spot],
        casters: (1, 1),
        camera: box_camera(),
        min_counts: vec![(5000, 1000), (3000, 300)],
    };
    let masked = Reference::new(&scene);
    assert_extreme(&case, &masked);
    let solid = Reference::solid(&scene);
    let opts = ShadowOptions::default();
    let rendered = render_case(&case, Variant::of(Kind::BruteForce), &[opts]);
    for (i, light) in case.lights.iter().enumerate() {
        let t = compare_visibility(&solid, light, true, &rendered.surfaces, &rendered.vis[0][i], opts);
        eprintln!("alpha mask light {i} against a solid screen: {} lit but dark", t.shadowed_but_lit.len());
        assert!(t.shadowed_but_lit.len() > 200, "light {i}: the holes' light must contradict a solid screen");
    }
}

/// The multi-caster case rendered with 4x MSAA by Forward+ and Tiled Deferred (the shading
/// runs once per pixel away from edges; the surfaces are the 1x depth buffer's).
#[test]
fn shadows_with_msaa_4x_match_the_ray_cast() {
    let scene = shadow_box_scene(0.5);
    let reference = Reference::new(&scene);
    let case = Case { name: "msaa", ..multi_case(&scene) };
    for kind in [Kind::ForwardPlus, Kind::Deferred] {
        let v = Variant { msaa: 4, ..Variant::of(kind) };
        assert_case(&case, &reference, v, &[ShadowOptions::default()]);
    }
}

/// The multi-caster case in each light-grid layout: 2.5D depth masks, clusters and
/// light-centric (scatter) assignment, in Forward+ and Tiled Deferred.
#[test]
fn shadows_in_every_layout_match_the_ray_cast() {
    let scene = shadow_box_scene(0.5);
    let reference = Reference::new(&scene);
    let d = CullOptions::default();
    let layouts = [
        CullOptions { depth_mask: true, ..d },
        CullOptions { clusters: Some(ClusterOptions::default()), ..d },
        CullOptions { scatter: true, ..d },
    ];
    let mut failures = Vec::new();
    for cull in layouts {
        for kind in [Kind::ForwardPlus, Kind::Deferred] {
            let case = Case { name: "layout", ..multi_case(&scene) };
            failures.extend(run_case(&case, &reference, Variant { kind, cull, msaa: 1 }, &[ShadowOptions::default()]));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Peter-panning: the depth bias must stay below what a thin occluder close to its receiver
/// needs. A spot 30 m over the floor pointing straight down (128 px tile, one tap, 32-bit
/// depth: quantisation is micrometres there, so only the bias decides) and a plate hovering
/// over the floor by 0.8 of a shadow texel at the floor (the texel from the face's own
/// geometry, `face_of`: 0.41 m). The design's bias for a receiver facing the light on the
/// face's axis is half a texel (slope 0: `tiledlight_cull::shadow`'s slope-scaled bias),
/// and the normal offset lifts the lookup by `sin(theta)` texels, under 0.01 texel within
/// 0.25 m of the axis: the floor under the plate's middle (the tap and its 2x2 footprint
/// inside the plate) must be dark. A bias grown past 0.8 texel (doubled, say) lets the
/// light under the plate. The camera looks under the plate from 8 degrees over the floor
/// (steeper than the ray cast's surface reconstruction needs at its 20 degree field).
#[test]
fn a_plate_hovering_a_texel_over_the_floor_shadows_it() {
    let light = Light::spot(Vec3::new(0.0, 30.0, 0.0), Vec3::NEG_Y, Vec3::ONE, 900.0, 0.5, 0.7, 0.01).expect("spot");
    let opts = ShadowOptions { format: ShadowFormat::Depth32, tile_size: 128, filter: ShadowFilter::Tap1 };
    let texel = {
        let face = face_of(&light, Vec3::ZERO, opts);
        face.texel * (Vec3::ZERO - light.position).dot(face.axis)
    };
    let h = 0.8 * texel;
    let mut scene = scenes::floor_scene(0.8, 0.0, vec![]);
    // The plate reaches two texels past the checked region (0.25 m): the tap's footprint.
    let half = 0.25 + 2.0 * texel;
    scene.meshes.push(scenes::quad("plate", 2.0 * half));
    scene.instances.push(tiledlight_scene::Instance {
        mesh: 1,
        material: 0,
        transform: Mat4::from_translation(Vec3::new(0.0, h, 0.0)),
    });
    scene.bounds = scene.compute_bounds();
    scene.bounds.max.y = 31.0;
    let reference = Reference::new(&scene);
    let cam = Camera::perspective(
        Vec3::new(0.0, 0.84, 6.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::Y,
        20f32.to_radians(),
        W as f32 / H as f32,
        0.01,
        None,
    )
    .expect("camera");
    let r = render_pair(Kind::BruteForce, &scene, &[light], (0, 1), opts, &cam);
    let (mut under, mut leaks) = (0, Vec::new());
    for (i, s) in surface_points(&cam, W, H, &r.depth).into_iter().enumerate() {
        let Some(s) = s else { continue };
        let full = lum(r.unshadowed.hdr[i]);
        if full < DIM || s.position.y.abs() > 0.25 * h || s.position.x.abs() > 0.25 || s.position.z.abs() > 0.25 {
            continue;
        }
        assert!(!reference.visible(light.position, s.position, s.normal), "the plate hides {:?}", s.position);
        under += 1;
        let v = lum(r.shadowed.hdr[i]) / full;
        if v > DARK {
            leaks.push((i as u32 % W, i as u32 / W, v));
        }
    }
    eprintln!(
        "hovering plate {h:.3} m (0.8 of a {texel:.3} m texel): {under} floor pixels under it, {} lit",
        leaks.len()
    );
    assert!(under > 200, "the floor under the plate must be in view ({under} pixels)");
    assert!(leaks.is_empty(), "light under the plate (x, y, visibility): {:?}", &leaks[..leaks.len().min(10)]);
}
