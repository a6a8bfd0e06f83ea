//! The camera of a run: a pinned one ([`crate::CameraBookmark`]), else the scene's own,
//! else one framing the scene's bounds ([`choose_camera`]), always at the screen's aspect
//! ratio. Depends on tiledlight-cull (`Camera`), tiledlight-scene (`CameraDesc`, `Aabb`)
//! and [`crate::settings`]; no GPU work.

use anyhow::{ensure, Context, Result};
use glam::Vec3;
use tiledlight_cull::Camera;
use tiledlight_scene::{Aabb, CameraDesc};

use crate::settings::Settings;

/// Vertical field of view of the camera that frames a scene without its own camera.
const FRAMING_FOV_Y_DEG: f32 = 60.0;

/// The camera of a run at the screen's aspect ratio, and where it came from (for the
/// report): the settings' bookmark, else the scene's own camera, else one framing the
/// scene's bounds.
pub fn choose_camera(
    settings: &Settings,
    scene_camera: Option<&CameraDesc>,
    bounds: &Aabb,
) -> Result<(Camera, String)> {
    let aspect = settings.width as f32 / settings.height as f32;
    Ok(match (&settings.camera, scene_camera) {
        (Some(bookmark), _) => {
            let path = &bookmark.path;
            let cam = camera_from_desc(&bookmark.camera, aspect)
                .with_context(|| format!("--camera {}: unusable camera", path.display()))?;
            (cam, format!("bookmark {}", path.display()))
        }
        (None, Some(desc)) => (
            camera_from_desc(desc, aspect).context("the scene's camera is unusable")?,
            "the scene's camera".to_string(),
        ),
        (None, None) => (frame_bounds(bounds, aspect)?, "framing the scene bounds".to_string()),
    })
}

/// The scene's suggested camera at the screen's aspect ratio.
pub fn camera_from_desc(d: &CameraDesc, aspect: f32) -> Result<Camera> {
    Ok(Camera::perspective(d.eye, d.target, d.up, d.fov_y, aspect, d.near, d.far)?)
}

/// A camera in front of the scene (+z side, a little above) that sees the whole bounding
/// sphere of `bounds`, with an infinite far plane.
pub fn frame_bounds(bounds: &Aabb, aspect: f32) -> Result<Camera> {
    ensure!(bounds.is_valid(), "the scene has no valid bounds to frame a camera on");
    let center = bounds.center();
    // A flat or point-like scene still needs a distance to stand back.
    let radius = (0.5 * bounds.size().length()).max(1e-3);
    let fov_y = FRAMING_FOV_Y_DEG.to_radians();
    let half_x = ((fov_y * 0.5).tan() * aspect).atan();
    let half = (fov_y * 0.5).min(half_x);
    let dist = radius / half.sin();
    let dir = Vec3::new(0.0, 0.35, 1.0).normalize();
    let eye = center + dir * dist;
    // Every surface is at least dist - radius away; reversed-Z keeps precision with a
    // small near plane, so halve that for margin.
    let near = ((dist - radius) * 0.5).max(dist * 1e-4);
    Ok(Camera::perspective(eye, center, Vec3::Y, fov_y, aspect, near, None)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::CameraBookmark;

    #[test]
    fn framing_sees_the_whole_box() {
        let b = Aabb::new(Vec3::new(-10.0, 0.0, -3.0), Vec3::new(10.0, 5.0, 3.0));
        let cam = frame_bounds(&b, 16.0 / 9.0).unwrap();
        for i in 0..8 {
            let p = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let c = cam.view_proj() * p.extend(1.0);
            let ndc = c.truncate() / c.w;
            assert!(c.w > 0.0 && ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0, "corner {p} at {ndc}");
            assert!(ndc.z > 0.0 && ndc.z <= 1.0, "corner {p} depth {}", ndc.z);
        }
        assert!(frame_bounds(&Aabb::empty(), 1.0).is_err());
    }

    #[test]
    fn bookmark_then_scene_camera_then_framing() {
        let bounds = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let desc = CameraDesc {
            eye: Vec3::new(0.0, 0.0, 9.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 1.0,
            near: 0.1,
            far: None,
        };
        let scene_cam = CameraDesc { eye: Vec3::new(0.0, 0.0, 5.0), ..desc };
        let plain = Settings { width: 200, height: 100, ..Settings::default() };
        let pinned =
            Settings { camera: Some(CameraBookmark { path: "cam.txt".into(), camera: desc }), ..plain.clone() };
        let (cam, from) = choose_camera(&pinned, Some(&scene_cam), &bounds).unwrap();
        assert_eq!((cam.eye(), from.as_str()), (desc.eye, "bookmark cam.txt"));
        let (cam, from) = choose_camera(&plain, Some(&scene_cam), &bounds).unwrap();
        assert_eq!((cam.eye(), from.as_str()), (scene_cam.eye, "the scene's camera"));
        let (_, from) = choose_camera(&plain, None, &bounds).unwrap();
        assert_eq!(from, "framing the scene bounds");
        let bad = CameraBookmark { path: "bad.txt".into(), camera: CameraDesc { fov_y: 0.0, ..desc } };
        let e = choose_camera(&Settings { camera: Some(bad), ..plain }, None, &bounds).unwrap_err();
        assert!(format!("{e:#}").contains("--camera bad.txt: unusable camera"), "{e:#}");
    }
}
