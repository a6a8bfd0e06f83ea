//! Named demo setups (`--demo NAME`): the built-in courtyard dressed so that one feature is
//! obvious at a glance, for the README's gallery (`scripts/gallery.sh`) and for a first
//! look. A demo is two things:
//!
//! 1. **Flags** ([`Demo::flags`]): ordinary command-line flags (light counts, shadow
//!    casters, grid objects, the light grid layout...). The app puts them in front of the
//!    user's own, so any flag given on the command line wins.
//! 2. **Dressing** ([`Demo::dress`]): what no flag can say: hand-placed lights, a camera
//!    chosen for the feature, a coloured panel for light to bounce off, and, for the
//!    million lights, hues that vary smoothly across the courtyard ([`Demo::recolour`])
//!    instead of one random hue per light.
//!
//! Pure data and CPU work; depends on tiledlight-cull (lights) and tiledlight-scene (the
//! courtyard, meshes, materials, cameras).

use anyhow::{Context, Result};
use glam::{Mat4, Vec3};
use tiledlight_cull::Light;
use tiledlight_scene::{hue_color, CameraDesc, Instance, Material, Mesh, Scene, DEFAULT_LIGHT_THRESHOLD};

/// A demo setup of the built-in courtyard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Demo {
    /// Column and sphere shadows on the floor from six bright casters, nothing else lit.
    Shadows,
    /// One shadow-casting spot on a red panel, nothing else lit, at a fixed exposure; with
    /// `--vpl` the panel's red bounce lights the floor and the arches (render it with and
    /// without).
    Vpl,
    /// Glass spheres (blended, lit from both sides) among opaque ones over a lit floor.
    Glass,
    /// A million lights on the surfaces, their hue changing smoothly along the courtyard.
    Million,
    /// The lights-per-tile heat map over 4,096 lights and the 280 grid spheres (choose the
    /// layout with `--grid`).
    Heatmap,
    /// Clusters of the whole frustum serving opaque and glass geometry; the heat map
    /// shows each tile's fullest cluster.
    Clusters,
}

impl Demo {
    /// Every demo, in the order the help and the gallery list them.
    pub const ALL: [Demo; 6] = [Demo::Shadows, Demo::Vpl, Demo::Glass, Demo::Million, Demo::Heatmap, Demo::Clusters];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Demo::Shadows => "shadows",
            Demo::Vpl => "vpl",
            Demo::Glass => "glass",
            Demo::Million => "million",
            Demo::Heatmap => "heatmap",
            Demo::Clusters => "clusters",
        }
    }

    /// One line: what the demo shows.
    pub fn summary(self) -> &'static str {
        match self {
            Demo::Shadows => "six bright shadow casters among the columns and 60 spheres, nothing else lit",
            Demo::Vpl => "one spot on a red panel, nothing else lit; add --vpl for its red bounce on the floor",
            Demo::Glass => "30 glass spheres among 30 opaque ones over a floor lit by 512 lights",
            Demo::Million => "a million lights on the surfaces, hues varying smoothly along the courtyard",
            Demo::Heatmap => "4,096 lights over the Figure 9 scene with the lights-per-tile heat map",
            Demo::Clusters => "clustered lists (24 slices) serving opaque and glass geometry, heat map on",
        }
    }

    /// The flags the demo stands for, given before the user's own (which win).
    pub fn flags(self) -> &'static [&'static str] {
        match self {
            Demo::Shadows => &[
                "--lights",
                "0",
                "--grid-objects",
                "60",
                "--shadow-point-lights",
                "6",
                "--shadow-size",
                "1024",
                "--shadow-filter",
                "5",
            ],
            // Physical VPL shading (Dachsbacher and Stamminger's inverse square): the
            // sample's smoothstep falloff spreads the bounce too thinly to see here.
            Demo::Vpl => &[
                "--lights",
                "0",
                "--shadow-spot-lights",
                "1",
                "--shadow-size",
                "1024",
                "--exposure",
                "0.7",
                "--vpl-shading",
                "physical",
            ],
            Demo::Glass => {
                &["--lights", "512", "--grid-objects", "60", "--transparent-objects", "30", "--density", "high"]
            }
            Demo::Million => &["--light-preset", "million"],
            Demo::Heatmap => &["--lights", "4096", "--grid-objects", "280"],
            Demo::Clusters => {
                &["--lights", "4096", "--grid-objects", "280", "--transparent-objects", "40", "--grid", "clustered"]
            }
        }
    }

    /// The point and spot lights [`Self::dress`] places (before any random ones).
    pub fn light_counts(self) -> (u64, u64) {
        match self {
            Demo::Shadows => (6, 0),
            Demo::Vpl => (0, 1),
            _ => (0, 0),
        }
    }

    /// Whether `render` draws the heat map by default (it writes the plain image otherwise).
    pub fn shows_heatmap(self) -> bool {
        matches!(self, Demo::Heatmap | Demo::Clusters)
    }

    /// Dresses the courtyard: the demo's own lights (added to the scene's, so they come
    /// before any random ones), its camera, and (`vpl`) the red panel.
    pub fn dress(self, scene: &mut Scene) -> Result<()> {
        let t = DEFAULT_LIGHT_THRESHOLD;
        let camera = |eye: Vec3, target: Vec3| CameraDesc {
            eye,
            target,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: None,
        };
        match self {
            Demo::Shadows => {
                // Warm casters 1.8 m up between the columns and the spheres: each column
                // throws a long shadow across the floor, each sphere a round one.
                let warm = Vec3::new(1.0, 0.85, 0.65);
                for (x, z) in [(-3.5f32, -10.0f32), (3.5, -10.0), (-3.5, -2.0), (3.5, -2.0), (-3.5, 6.0), (3.5, 6.0)] {
                    scene.lights.push(Light::point(Vec3::new(x, 1.8, z), warm, 300.0, t).context("demo light")?);
                }
                scene.camera = Some(camera(Vec3::new(0.0, 7.5, 15.0), Vec3::new(0.0, 0.0, -3.0)));
            }
            Demo::Vpl => {
                // A 5 x 3.5 m red panel standing on the floor, facing the camera side (+Z).
                let mesh = scene.meshes.len();
                scene.meshes.push(panel_mesh(5.0, 3.5));
                let material = scene.materials.len();
                scene.materials.push(Material {
                    name: "red panel".into(),
                    base_color: [0.9, 0.08, 0.05, 1.0],
                    roughness: 0.9,
                    // Dielectric: glTF's default metallic is 1, and a metal has no diffuse
                    // albedo, so its RSM texels would carry no flux and make no VPL light.
                    metallic: 0.0,
                    ..Material::default()
                });
                let at = Mat4::from_translation(Vec3::new(0.0, 0.0, -4.0));
                scene.instances.push(Instance { mesh, material, transform: at });
                // One white spot from above and in front, its cone on the panel alone.
                let apex = Vec3::new(0.0, 5.0, 4.0);
                let dir = (Vec3::new(0.0, 1.75, -4.0) - apex).normalize();
                let spot = Light::spot(apex, dir, Vec3::ONE, 900.0, SPOT_INNER, SPOT_OUTER, t).context("demo spot")?;
                scene.lights.push(spot);
                scene.camera = Some(camera(Vec3::new(4.5, 2.2, 5.0), Vec3::new(-0.5, 0.6, -3.0)));
            }
            Demo::Glass => {
                scene.camera = Some(camera(Vec3::new(1.5, 1.6, 9.0), Vec3::new(-0.5, 0.4, 0.0)));
            }
            Demo::Million | Demo::Heatmap | Demo::Clusters => {}
        }
        scene.bounds = scene.compute_bounds();
        Ok(())
    }

    /// The million demo recolours the random lights by position: the hue turns once along
    /// the courtyard's length and a quarter across it, so neighbouring lights share a
    /// colour and the image shows bands rather than confetti. Other demos leave the lights.
    pub fn recolour(self, lights: &mut [Light], bounds: (Vec3, Vec3)) {
        if self != Demo::Million {
            return;
        }
        let size = (bounds.1 - bounds.0).max(Vec3::splat(1e-3));
        for l in lights.iter_mut() {
            let p = (l.position - bounds.0) / size;
            l.color = hue_color((p.z + 0.25 * p.x).fract());
        }
    }
}

/// The VPL demo's spot: half-angles (radians) of its full-intensity core and its edge (a
/// 12-degree cone: on the panel, not the floor).
const SPOT_INNER: f32 = 0.16;
const SPOT_OUTER: f32 = 0.21;

/// A `w` x `h` upright panel: its base on y = 0, centred on x = 0, facing +Z, with a back
/// face of its own (both sides light and cast).
fn panel_mesh(w: f32, h: f32) -> Mesh {
    let x = w * 0.5;
    let front = [[-x, 0.0, 0.0], [x, 0.0, 0.0], [x, h, 0.0], [-x, h, 0.0]];
    let mut positions = front.to_vec();
    positions.extend(front);
    let mut normals = vec![[0.0, 0.0, 1.0]; 4];
    normals.extend([[0.0, 0.0, -1.0]; 4]);
    Mesh {
        name: "demo panel".into(),
        positions,
        normals,
        uvs: [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]].repeat(2),
        indices: vec![0, 1, 2, 0, 2, 3, 4, 6, 5, 4, 7, 6],
        ..Mesh::default()
    }
}

/// The demo named `s` ([`Demo::name`]), or an error listing the names.
pub fn parse(s: &str) -> Result<Demo> {
    Demo::ALL.into_iter().find(|d| d.name() == s).with_context(|| {
        let names: Vec<_> = Demo::ALL.iter().map(|d| d.name()).collect();
        format!("--demo {s}: unknown demo; expected one of {}", names.join(", "))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_cull::LightKind;
    use tiledlight_scene::{default_scene, DefaultSceneOptions};

    #[test]
    fn names_round_trip_and_unknown_names_list_them() {
        for d in Demo::ALL {
            assert_eq!(parse(d.name()).unwrap(), d);
            assert!(!d.summary().is_empty());
            assert_eq!(d.flags().len() % 2, 0, "{}: flags come in name-value pairs", d.name());
        }
        let e = parse("sparkles").unwrap_err().to_string();
        assert!(e.contains("shadows, vpl, glass, million, heatmap, clusters"), "{e}");
    }

    #[test]
    fn dressing_adds_what_each_demo_needs_and_keeps_the_scene_valid() {
        for d in Demo::ALL {
            let mut s = default_scene(&DefaultSceneOptions::default()).unwrap();
            let (instances, camera) = (s.instances.len(), s.camera);
            d.dress(&mut s).unwrap();
            s.validate().unwrap();
            let lights = s.lights.len();
            let spots = s.lights.iter().filter(|l| matches!(l.kind, LightKind::Spot { .. })).count() as u64;
            assert_eq!(d.light_counts(), (lights as u64 - spots, spots), "{}", d.name());
            match d {
                Demo::Shadows => assert_eq!(lights, 6),
                Demo::Vpl => {
                    assert_eq!((lights, s.instances.len()), (1, instances + 1));
                    assert!(matches!(s.lights[0].kind, LightKind::Spot { .. }));
                    // A dielectric panel: a metal has no diffuse albedo, so its RSM texels
                    // would carry no flux and the demo would show no bounce at all.
                    let panel = &s.materials[s.instances.last().unwrap().material];
                    assert_eq!((panel.metallic, panel.base_color[0]), (0.0, 0.9));
                    // The panel is inside the spot's reach: its centre within the radius.
                    let l = &s.lights[0];
                    assert!(l.position.distance(Vec3::new(0.0, 1.75, -4.0)) < l.radius);
                }
                _ => assert_eq!(lights, 0),
            }
            let moved = s.camera != camera;
            assert_eq!(moved, matches!(d, Demo::Shadows | Demo::Vpl | Demo::Glass), "{}", d.name());
        }
    }

    #[test]
    fn million_hues_vary_smoothly_and_stay_saturated() {
        let bounds = (Vec3::new(-8.0, 0.0, -18.0), Vec3::new(8.0, 13.0, 18.0));
        let make = |z: f32| Light::point(Vec3::new(0.0, 1.0, z), Vec3::ONE, 1.0, 0.1).unwrap();
        let mut lights: Vec<Light> = (0..100).map(|i| make(-18.0 + 0.36 * i as f32)).collect();
        Demo::Million.recolour(&mut lights, bounds);
        for w in lights.windows(2) {
            // 0.36 m apart: at most 1% of a turn, i.e. 0.06 of a channel between neighbours.
            let step = (w[0].color - w[1].color).abs().max_element();
            assert!(step < 0.07, "{:?} -> {:?}", w[0].color, w[1].color);
        }
        for l in &lights {
            assert!((l.color.max_element() - 1.0).abs() < 1e-6 && l.color.min_element() >= 0.0, "{:?}", l.color);
        }
        let mut same = lights.clone();
        Demo::Glass.recolour(&mut same, bounds);
        assert_eq!(
            same.iter().map(|l| l.color).collect::<Vec<_>>(),
            lights.iter().map(|l| l.color).collect::<Vec<_>>()
        );
    }
}
