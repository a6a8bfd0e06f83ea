//! `tiledlight export` round trip on the GPU (lavapipe in CI): the courtyard with grid
//! objects (two of them blended glass), banners glowing, random point and spot lights and
//! its camera, written as glTF (`tiledlight_setup::export`) and loaded back as a scene
//! file with the same flags, gives the same lights (exactly), the same camera (within
//! float rounding) and, rendered by Forward+ and Tiled Deferred, the same image.

use std::path::Path;

use tiledlight_frame::Diagnostics as _;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_scene::{GridDensity, Light, LightKind};
use tiledlight_setup::export::export;
use tiledlight_setup::{LightPlacement, Method, Prepared, SceneCpu, SceneSource, Settings};
use tiledlight_tests::images::{assert_flip, FlipThresholds};

const W: u32 = 320;
const H: u32 = 180;

/// The image of the loaded file against the original's. Positions, indices, materials,
/// texels and lights are bit-identical; normals, spot directions and the camera differ by
/// float rounding (the loader re-normalises them; about 1e-7 relative), which moves a
/// pixel's value by a unit of the last 8-bit place here and there. Measured on lavapipe:
/// FLIP mean 0.00000, 99.9th percentile 0.0009, max 0.006 (both methods). The thresholds
/// (mean 1e-4, 99.9th percentile 0.02) leave room for other adapters' rounding; a lost
/// light or a wrong material gives a mean of several 1e-2.
const SAME_IMAGE: FlipThresholds = FlipThresholds { mean: 1e-4, percentile: (0.999, 0.02) };

fn settings(method: Method) -> Settings {
    Settings {
        width: W,
        height: H,
        lights: Some(96),
        spot_lights: Some(24),
        grid_objects: 8,
        density: GridDensity::Low,
        transparent_objects: 2,
        emissive: true,
        method,
        // A fixed exposure: the two runs must tonemap alike.
        exposure: 1.0,
        auto_exposure: false,
        ..Settings::default()
    }
}

/// The same run from the exported file: its own lights only, nothing generated.
fn from_file(original: &Settings, path: &Path) -> Settings {
    Settings {
        scene: SceneSource::File(path.to_path_buf()),
        lights: None,
        spot_lights: None,
        grid_objects: 0,
        transparent_objects: 0,
        emissive: false,
        placement: LightPlacement::Bounds,
        ..original.clone()
    }
}

fn render(prep: &Prepared) -> Vec<u8> {
    let mut timer = GpuTimer::new(&prep.ctx).unwrap();
    let mut r = prep.renderer(false).unwrap();
    r.render_once(&prep.ctx, &mut timer, &prep.scene_gpu, &prep.camera).unwrap();
    let ldr = r.read_ldr(&prep.ctx).unwrap();
    prep.check_gpu_errors().unwrap();
    ldr
}

#[test]
fn exported_courtyard_loads_back_with_the_same_lights_camera_and_image() {
    let dir = tempfile::tempdir().unwrap();
    let a = settings(Method::ForwardPlus);
    let cpu = SceneCpu::load(&a).unwrap();
    assert_eq!(cpu.lights.iter().filter(|l| matches!(l.kind, LightKind::Spot { .. })).count(), 24);
    let path = dir.path().join("courtyard.gltf");
    let summary = export(&cpu, &a, &path).unwrap();
    assert_eq!((summary.point_lights, summary.spot_lights, summary.images), (96, 24, 1));

    let b = from_file(&a, &path);
    let back = SceneCpu::load(&b).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    assert_eq!((back.file_lights, back.camera_source.as_str()), (120, "the scene's camera"));
    // Positions, colours, intensities, radii and spot angles bit for bit; spot directions
    // within 1e-6 (the loader re-normalises the unit direction it reads exactly, which can
    // move it by one ulp).
    assert_eq!(back.lights.len(), cpu.lights.len());
    for (i, (b, l)) in back.lights.iter().zip(&cpu.lights).enumerate() {
        if let (LightKind::Spot { direction: db, .. }, LightKind::Spot { direction: dl, .. }) = (b.kind, l.kind) {
            assert!((db - dl).abs().max_element() <= 1e-6, "light {i}: direction {db} vs {dl}");
        }
        let same_direction = match (b.kind, l.kind) {
            (LightKind::Spot { inner_angle, outer_angle, .. }, LightKind::Spot { direction, .. }) => {
                LightKind::Spot { direction, inner_angle, outer_angle }
            }
            (k, _) => k,
        };
        assert_eq!(Light { kind: same_direction, ..*b }, *l, "light {i}");
    }
    // The camera: eye and view-projection within float rounding of the node matrix (the
    // inverse of the view, re-orthonormalised by the loader's look-at).
    assert!((back.camera.eye() - cpu.camera.eye()).length() < 1e-4, "{} vs {}", back.camera.eye(), cpu.camera.eye());
    assert_eq!(back.camera.projection(), cpu.camera.projection());
    let d = (back.camera.view_proj() - cpu.camera.view_proj()).to_cols_array().iter().fold(0f32, |m, x| m.max(x.abs()));
    assert!(d < 1e-5, "view-projection differs by {d}");
    assert_eq!(back.scene.instances.len(), cpu.scene.instances.len());
    assert_eq!(back.scene.triangle_count(), cpu.scene.triangle_count());

    // One device for both scenes: reconfigure loads the file on the same context.
    for method in [Method::ForwardPlus, Method::TiledDeferred] {
        let (a, b) = (Settings { method, ..a.clone() }, Settings { method, ..b.clone() });
        let mut prep = Prepared::new(&a).unwrap();
        let original = render(&prep);
        prep.reconfigure(&b).unwrap();
        assert_eq!((prep.light_summary.point, prep.light_summary.spot, prep.light_summary.from_file), (96, 24, 120));
        let loaded = render(&prep);
        let lit = original.chunks_exact(4).filter(|p| p[..3].iter().any(|&c| c > 40)).count();
        assert!(lit > (W * H / 20) as usize, "the frame is lit ({lit} pixels), so the comparison means something");
        assert_flip(&format!("export-roundtrip-{}", method.name()), W, H, &original, &loaded, SAME_IMAGE);
    }
}
