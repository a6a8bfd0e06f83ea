//! The worst pixel of a setting against its reference, explained (issue 44): where it is,
//! both images' HDR values there, and the lights that pour the most light onto it, each
//! with what the truth does with it (its shadow ray) and what the setting does (its
//! radius cutoff, whether it casts a shadow map).
//!
//! 1. The pixel is [`HdrError::worst_pixel`](tiledlight_metrics::HdrError): the largest
//!    channel difference.
//! 2. Its surface is put back in the world from the setting's read-back depth
//!    ([`tiledlight_cull::raycast::surface_point`]: the pixel centre's position, the normal
//!    from the depth differences; none at a silhouette, where the normal is unknown).
//! 3. Every light's unshadowed arrival there is evaluated on the CPU: luminance of its
//!    radiance, times the inverse-square falloff without cutoff (what the truth sums),
//!    times the spot cone, times `n·l` when the normal is known. No BRDF: the material is
//!    not read back, and the question is which light, not how much of it is specular.
//! 4. The three largest get: the setting's windowed falloff at its radius (the cutoff's
//!    share), whether the setting shadows them (a caster), and the truth's visibility: the
//!    segment to the light through the scene's shadow geometry
//!    ([`tiledlight_scene::trace::TraceGeometry`], masks honoured, blended glass left out,
//!    the traced reference's offset).
//!
//! Depends on tiledlight-cull (falloffs, the surface point, packed lights), tiledlight-scene
//! (the shadow geometry) and tiledlight-metrics.

use glam::Vec3;
use tiledlight_cull::brdf::{spot_falloff, unwindowed_attenuation, windowed_attenuation};
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::raycast::{pixel_position, surface_point, SurfacePoint};
use tiledlight_cull::Camera;
use tiledlight_scene::trace::TraceGeometry;

/// How many lights a worst pixel lists.
pub const TOP_LIGHTS: usize = 3;

/// One light's share of a pixel ([`attribute`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightShare {
    /// The light's index in the packed order (points first, casters first of each kind).
    pub index: usize,
    /// A spot light.
    pub spot: bool,
    /// The setting draws a shadow map for it.
    pub caster: bool,
    /// Its unshadowed arrival without the cutoff (luminance, times `n·l` when the normal
    /// is known): what the truth adds where the light is visible.
    pub unshadowed: f32,
    /// The same through the setting's windowed falloff: what the setting adds, before its
    /// shadow map (if it casts one).
    pub windowed: f32,
    /// The truth's shadow ray: true when nothing blocks the segment to the light (None
    /// without shadow geometry).
    pub visible: Option<bool>,
}

/// The worst pixel of a setting, explained.
#[derive(Clone, Debug, PartialEq)]
pub struct WorstPixel {
    /// Column.
    pub x: u32,
    /// Row (top first).
    pub y: u32,
    /// The reference's linear RGB there.
    pub reference: [f32; 3],
    /// The setting's linear RGB there.
    pub setting: [f32; 3],
    /// The surface there (None: sky, or a silhouette whose normal is unknown).
    pub surface: Option<SurfacePoint>,
    /// The largest [`TOP_LIGHTS`] contributions, largest first.
    pub lights: Vec<LightShare>,
}

/// The frame a worst pixel is explained in: the setting's camera, its read-back depth, its
/// packed lights (radii at the setting's threshold, caster counts) and the scene's shadow
/// geometry.
pub struct Frame<'a> {
    /// The camera the frame was drawn with.
    pub camera: &'a Camera,
    /// Width and height.
    pub size: (u32, u32),
    /// Reversed-Z depth, one value a pixel, row-major.
    pub depth: &'a [f32],
    /// The setting's lights as uploaded.
    pub lights: &'a PackedLights,
    /// What the truth's shadow rays see (None: visibility not evaluated).
    pub geometry: Option<&'a TraceGeometry>,
}

/// Rec. 709 luminance.
fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Packed light `i`'s unshadowed arrival at `p` (normal `n` when known): (no cutoff, the
/// setting's window) (step 3).
fn arrival(lights: &PackedLights, i: usize, p: Vec3, n: Option<Vec3>) -> (f32, f32) {
    let l = &lights.shading[i];
    let to_light = Vec3::from(l.position) - p;
    let d2 = to_light.length_squared();
    let dir = to_light / d2.sqrt().max(f32::MIN_POSITIVE);
    let mut k = luminance(l.radiance);
    if let Some(n) = n {
        k *= n.dot(dir).max(0.0);
    }
    if i >= lights.num_point as usize {
        let s = &lights.spots[i - lights.num_point as usize];
        k *= spot_falloff((-dir).dot(Vec3::from(s.direction)), s.angle_scale, s.angle_offset);
    }
    (k * unwindowed_attenuation(d2), k * windowed_attenuation(d2, l.radius))
}

/// Whether packed light `i` casts a shadow map.
fn is_caster(lights: &PackedLights, i: usize) -> bool {
    let points = lights.num_point as usize;
    if i < points {
        i < lights.shadow_points as usize
    } else {
        i - points < lights.shadow_spots as usize
    }
}

/// Explains pixel `pixel` (row-major index) of `frame`: `reference` and `setting` are the
/// two HDR images (RGBA, same size as the frame). None when the index is off the image.
pub fn attribute(frame: &Frame<'_>, pixel: usize, reference: &[[f32; 4]], setting: &[[f32; 4]]) -> Option<WorstPixel> {
    let (w, h) = frame.size;
    if pixel >= (w as usize) * (h as usize) || pixel >= reference.len() || pixel >= setting.len() {
        return None;
    }
    let (x, y) = ((pixel % w as usize) as u32, (pixel / w as usize) as u32);
    let rgb = |p: &[f32; 4]| [p[0], p[1], p[2]];
    // The position without the silhouette rule when the normal is unknown: the light's
    // distance still ranks the lights (without n·l).
    let surface = surface_point(frame.camera, w, h, frame.depth, x, y);
    let position = surface.map(|s| s.position).or_else(|| pixel_position(frame.camera, w, h, frame.depth, x, y));
    let mut lights = Vec::new();
    if let Some(p) = position {
        let n = surface.map(|s| s.normal);
        let mut all: Vec<(usize, f32, f32)> = (0..frame.lights.len())
            .map(|i| {
                let (u, wnd) = arrival(frame.lights, i, p, n);
                (i, u, wnd)
            })
            .filter(|&(_, u, _)| u > 0.0)
            .collect();
        // Largest first; ties by index so the report is reproducible.
        all.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        for &(i, unshadowed, windowed) in all.iter().take(TOP_LIGHTS) {
            let visible = frame.geometry.map(|g| {
                let eps = g.eps(p);
                let from = p + n.unwrap_or(Vec3::ZERO) * eps;
                !g.occluded(from, Vec3::from(frame.lights.shading[i].position), eps)
            });
            lights.push(LightShare {
                index: i,
                spot: i >= frame.lights.num_point as usize,
                caster: is_caster(frame.lights, i),
                unshadowed,
                windowed,
                visible,
            });
        }
    }
    Some(WorstPixel { x, y, reference: rgb(&reference[pixel]), setting: rgb(&setting[pixel]), surface, lights })
}

impl LightShare {
    /// "#12 spot caster: 3.1 unshadowed, 2.9 windowed, shadowed": one light for the report
    /// and the CSV.
    pub fn describe(&self) -> String {
        let kind = if self.spot { "spot" } else { "point" };
        let caster = if self.caster { " caster" } else { "" };
        let ray = match self.visible {
            Some(true) => ", visible",
            Some(false) => ", shadowed",
            None => "",
        };
        format!(
            "#{} {kind}{caster}: {:.4e} unshadowed, {:.4e} windowed{ray}",
            self.index, self.unshadowed, self.windowed
        )
    }
}

impl WorstPixel {
    /// The CSV cells: `worst_x`, `worst_y`, `worst_reference` and `worst_setting` (RGB as
    /// "r g b"), `worst_lights` (the lights' [`LightShare::describe`] joined by "; ").
    pub fn csv(&self) -> [String; 5] {
        let rgb = |c: [f32; 3]| format!("{:.6e} {:.6e} {:.6e}", c[0], c[1], c[2]);
        [
            self.x.to_string(),
            self.y.to_string(),
            rgb(self.reference),
            rgb(self.setting),
            self.lights.iter().map(LightShare::describe).collect::<Vec<_>>().join("; "),
        ]
    }

    /// One report line: "worst pixel (812, 402): reference 0.21 0.19 0.17, setting 1617 ...;
    /// lights: ...".
    pub fn line(&self) -> String {
        let rgb = |c: [f32; 3]| format!("{:.4} {:.4} {:.4}", c[0], c[1], c[2]);
        let normal = if self.surface.is_some() { "" } else { " (normal unknown: silhouette or sky; no n.l)" };
        let lights = if self.lights.is_empty() {
            "no light reaches it".to_string()
        } else {
            self.lights.iter().map(LightShare::describe).collect::<Vec<_>>().join("; ")
        };
        format!(
            "worst pixel ({}, {}): reference {}, setting {}{normal}; largest lights: {lights}",
            self.x,
            self.y,
            rgb(self.reference),
            rgb(self.setting)
        )
    }
}

/// The CSV columns [`WorstPixel::csv`] fills.
pub const COLUMNS: [&str; 5] = ["worst_x", "worst_y", "worst_reference", "worst_setting", "worst_lights"];

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_cull::light::{try_pack_lights_with_casters, Light};

    /// The reversed-Z depth of the floor y = 0 (every pixel sees it) through `cam`.
    fn floor_depth(cam: &Camera, w: u32, h: u32) -> Vec<f32> {
        let (to_world, params) = (cam.view().inverse(), cam.depth_params());
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let ndc = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / h as f32 * 2.0);
                let dir = to_world.transform_point3(cam.view_point_at(ndc.0, ndc.1, 1.0)) - cam.eye();
                let hit = cam.eye() + dir * (-cam.eye().y / dir.y);
                params.depth(-cam.view().transform_point3(hit).z)
            })
            .collect()
    }

    /// A camera looking straight down at the floor from 10 m, and its depth.
    fn floor_frame(w: u32, h: u32) -> (Camera, Vec<f32>) {
        let cam =
            Camera::perspective(Vec3::new(0.0, 10.0, 0.001), Vec3::ZERO, Vec3::Y, 0.8, w as f32 / h as f32, 0.1, None)
                .unwrap();
        let depth = floor_depth(&cam, w, h);
        (cam, depth)
    }

    /// The worst pixel is found where the images differ, the nearest light ranks first, a
    /// light under the floor contributes nothing (n.l), the cutoff shows in the windowed
    /// value, and casters are the packed order's first.
    #[test]
    fn the_nearest_light_explains_the_pixel() {
        let (w, h) = (16u32, 12u32);
        let (cam, depth) = floor_frame(w, h);
        let p = surface_point(&cam, w, h, &depth, 5, 7).expect("the floor").position;
        let lights = [
            Light::point(p + Vec3::new(0.0, 0.5, 0.0), Vec3::ONE, 1.0, 2.0).unwrap(), // radius 0.71 m
            Light::point(p + Vec3::new(3.0, 2.0, 0.0), Vec3::ONE, 1.0, 1e-4).unwrap(),
            Light::point(p + Vec3::new(0.0, -0.2, 0.0), Vec3::ONE, 50.0, 1e-4).unwrap(), // under the floor
            Light::point(p + Vec3::new(-6.0, 4.0, 0.0), Vec3::ONE, 1.0, 1e-4).unwrap(),
        ];
        let packed = try_pack_lights_with_casters(&lights, (0, 0)).unwrap();
        let reference = vec![[0.5f32, 0.5, 0.5, 1.0]; (w * h) as usize];
        let mut setting = reference.clone();
        let pixel = (7 * w + 5) as usize;
        setting[pixel] = [9.0, 0.5, 0.5, 1.0];
        let e = tiledlight_metrics::HdrError::of(&reference, &setting);
        assert_eq!(e.worst_pixel, Some(pixel));
        let frame = Frame { camera: &cam, size: (w, h), depth: &depth, lights: &packed, geometry: None };
        let wp = attribute(&frame, pixel, &reference, &setting).expect("on the image");
        assert_eq!((wp.x, wp.y), (5, 7));
        assert_eq!((wp.reference, wp.setting), ([0.5, 0.5, 0.5], [9.0, 0.5, 0.5]));
        assert!(wp.surface.is_some());
        let order: Vec<usize> = wp.lights.iter().map(|l| l.index).collect();
        let packed_pos = |want: Vec3| packed.shading.iter().position(|l| Vec3::from(l.position) == want).unwrap();
        assert_eq!(
            order,
            vec![packed_pos(lights[0].position), packed_pos(lights[1].position), packed_pos(lights[3].position)],
            "{wp:?}"
        );
        // 1 / 0.25 m^2 unshadowed; inside the 0.71 m radius the window is (1 - 0.25)^2 of it.
        let first = wp.lights[0];
        assert!((first.unshadowed - 4.0).abs() < 1e-4, "{first:?}");
        let x = 0.25f32 / 0.5;
        assert!((first.windowed - 4.0 * (1.0 - x * x).powi(2)).abs() < 1e-4, "{first:?}");
        assert!(wp.lights.iter().all(|l| !l.caster && !l.spot && l.visible.is_none()), "{wp:?}");
        assert!(wp.line().contains("worst pixel (5, 7)") && wp.csv()[4].split("; ").count() == 3);
        // Off the image: nothing.
        assert!(attribute(&frame, (w * h) as usize, &reference, &setting).is_none());
    }

    /// Casters are the first `shadow_points` points and the first `shadow_spots` spots of
    /// the packed order.
    #[test]
    fn casters_are_the_first_of_each_kind() {
        let lights = PackedLights { num_point: 3, shadow_points: 1, shadow_spots: 1, ..PackedLights::default() };
        let casters: Vec<bool> = (0..5).map(|i| is_caster(&lights, i)).collect();
        assert_eq!(casters, [true, false, false, true, false]);
    }

    /// With the shadow geometry, a light behind the box is shadowed and one above the
    /// pixel visible (the truth's ray); the same frame without geometry says neither (the
    /// negative case: no visibility is claimed that was not evaluated).
    #[test]
    fn the_truths_ray_says_which_light_is_blocked() {
        // The shadow box scene: a floor at y = 0 and a 2 m box on the origin. The camera
        // looks down at the floor 6 m beside it.
        let (w, h) = (16u32, 12u32);
        let cam = Camera::perspective(
            Vec3::new(6.0, 10.0, 0.001),
            Vec3::new(6.0, 0.0, 0.0),
            Vec3::Y,
            0.8,
            16.0 / 12.0,
            0.1,
            None,
        )
        .unwrap();
        let depth = floor_depth(&cam, w, h);
        let pixel = (6 * w + 8) as usize;
        let p = surface_point(&cam, w, h, &depth, 8, 6).expect("the floor").position;
        assert!((p.x - 6.0).abs() < 1.0 && p.y.abs() < 1e-3, "{p}");
        // The segment to (-6, 1, 0) passes through the box (x in [-1, 1], y under 2).
        let behind = Light::point(Vec3::new(-6.0, 1.0, p.z), Vec3::ONE, 1.0, 1e-4).unwrap();
        let above = Light::point(p + Vec3::new(0.0, 3.0, 0.0), Vec3::ONE, 1.0, 1e-4).unwrap();
        let packed = try_pack_lights_with_casters(&[behind, above], (0, 0)).unwrap();
        let geometry = TraceGeometry::of(&tiledlight_scene::shadow_box_scene(0.0));
        let img = vec![[0.1f32, 0.1, 0.1, 1.0]; (w * h) as usize];
        let mut frame = Frame { camera: &cam, size: (w, h), depth: &depth, lights: &packed, geometry: Some(&geometry) };
        let wp = attribute(&frame, pixel, &img, &img).unwrap();
        assert_eq!(wp.lights.len(), 2, "{wp:?}");
        let by_pos = |wp: &WorstPixel, want: Vec3| {
            wp.lights.iter().find(|l| Vec3::from(packed.shading[l.index].position) == want).copied().unwrap()
        };
        assert_eq!(by_pos(&wp, behind.position).visible, Some(false), "{wp:?}");
        assert_eq!(by_pos(&wp, above.position).visible, Some(true), "{wp:?}");
        assert!(wp.line().contains("shadowed") && wp.line().contains("visible"));
        frame.geometry = None;
        let wp = attribute(&frame, pixel, &img, &img).unwrap();
        assert!(wp.lights.iter().all(|l| l.visible.is_none()));
    }
}
