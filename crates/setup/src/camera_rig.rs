//! An interactive camera (the viewer's, and any engine's that wants one): fly (WASD + mouse look, speed on the wheel) or orbit (drag to turn
//! around a target, wheel to zoom), kept as eye + yaw/pitch so neither mode can roll or
//! flip over the pole. Converts to a [`Camera`] for rendering and to a [`CameraDesc`] for
//! bookmarks. Right-handed, Y up; yaw 0 looks down -Z. Depends on glam, tiledlight-cull
//! and tiledlight-scene only (no window or GPU types, so it is unit-tested; the app's
//! viewer turns winit's input into its calls).

use anyhow::Result;
use glam::Vec3;
use tiledlight_cull::camera::Projection;
use tiledlight_cull::Camera;
use tiledlight_scene::CameraDesc;

/// Radians of turn per pixel of mouse motion.
pub const LOOK_PER_PIXEL: f32 = 0.004;
/// Pitch is kept this far from straight up or down.
const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;
/// Field of view used when the starting camera is orthographic.
const FALLBACK_FOV_Y: f32 = std::f32::consts::FRAC_PI_3;

/// How the mouse and keys move the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Free flight.
    Fly,
    /// Turning around a target point.
    Orbit,
}

/// Movement asked for this frame: each axis in [-1, 1] (right, up, forward).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    /// Strafe right (+) or left (-).
    pub right: f32,
    /// Up (+) or down (-), world Y.
    pub up: f32,
    /// Forward (+) or back (-).
    pub forward: f32,
    /// Speed multiplier (e.g. shift held).
    pub boost: f32,
}

/// A camera the user steers.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraRig {
    /// Fly or orbit.
    pub mode: Mode,
    /// Eye position.
    pub eye: Vec3,
    /// Turn around +Y, radians; 0 looks down -Z, positive turns right.
    pub yaw: f32,
    /// Up/down angle, radians.
    pub pitch: f32,
    /// Distance from the eye to the orbit target (and to the bookmark's target).
    pub distance: f32,
    /// Flight speed, metres per second.
    pub speed: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Near plane.
    pub near: f32,
    /// Far plane (None: infinite).
    pub far: Option<f32>,
}

impl CameraRig {
    /// A rig at `camera`'s pose and projection, its orbit target `distance` ahead.
    pub fn from_camera(camera: &Camera, distance: f32) -> Self {
        let forward = -camera.view().inverse().z_axis.truncate().normalize_or(Vec3::NEG_Z);
        let (fov_y, near, far) = match camera.projection() {
            Projection::Perspective { fov_y, near, far, .. } => (fov_y, near, far),
            Projection::Orthographic { .. } => (FALLBACK_FOV_Y, 0.1, None),
        };
        let mut rig = Self {
            mode: Mode::Fly,
            eye: camera.eye(),
            yaw: 0.0,
            pitch: 0.0,
            distance: distance.max(1e-3),
            speed: (distance * 0.5).max(0.1),
            fov_y,
            near,
            far,
        };
        rig.look_along(forward);
        rig
    }

    /// Points the camera along `dir`.
    pub fn look_along(&mut self, dir: Vec3) {
        let d = dir.normalize_or(Vec3::NEG_Z);
        self.pitch = d.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
        self.yaw = d.x.atan2(-d.z);
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(sy * cp, sp, -cy * cp)
    }

    /// Unit right vector (horizontal).
    pub fn right(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        Vec3::new(cy, 0.0, sy)
    }

    /// The point the orbit turns around.
    pub fn target(&self) -> Vec3 {
        self.eye + self.forward() * self.distance
    }

    /// Turns by a mouse motion of (dx, dy) pixels: in fly mode the view turns around the
    /// eye, in orbit mode the eye moves around the target.
    pub fn turn(&mut self, dx: f32, dy: f32) {
        let target = self.target();
        self.yaw = (self.yaw + dx * LOOK_PER_PIXEL).rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch - dy * LOOK_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
        if self.mode == Mode::Orbit {
            self.eye = target - self.forward() * self.distance;
        }
    }

    /// Moves for `dt` seconds (fly mode; in orbit mode the target moves with the eye).
    pub fn step(&mut self, m: Motion, dt: f32) {
        let v = self.right() * m.right + Vec3::Y * m.up + self.forward() * m.forward;
        if v != Vec3::ZERO && dt.is_finite() && dt > 0.0 {
            self.eye += v.normalize() * self.speed * m.boost.max(1.0) * dt.min(0.25);
        }
    }

    /// Mouse-wheel `steps` (positive away from the user): flight speed in fly mode, distance
    /// to the target in orbit mode.
    pub fn wheel(&mut self, steps: f32) {
        if !steps.is_finite() {
            return;
        }
        match self.mode {
            Mode::Fly => self.speed = (self.speed * 1.2f32.powf(steps)).clamp(1e-3, 1e5),
            Mode::Orbit => {
                let target = self.target();
                self.distance = (self.distance * 0.9f32.powf(steps)).clamp(1e-2, 1e6);
                self.eye = target - self.forward() * self.distance;
            }
        }
    }

    /// The camera at aspect ratio `aspect`.
    pub fn camera(&self, aspect: f32) -> Result<Camera> {
        Ok(Camera::perspective(self.eye, self.target(), Vec3::Y, self.fov_y, aspect, self.near, self.far)?)
    }

    /// The bookmark of this view.
    pub fn desc(&self) -> CameraDesc {
        CameraDesc {
            eye: self.eye,
            target: self.target(),
            up: Vec3::Y,
            fov_y: self.fov_y,
            near: self.near,
            far: self.far,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig() -> CameraRig {
        let cam =
            Camera::perspective(Vec3::new(0.0, 2.0, 10.0), Vec3::new(0.0, 2.0, 0.0), Vec3::Y, 1.0, 1.5, 0.1, None)
                .unwrap();
        CameraRig::from_camera(&cam, 10.0)
    }

    #[test]
    fn pose_survives_the_round_trip() {
        let r = rig();
        assert!((r.forward() - Vec3::NEG_Z).length() < 1e-6, "{}", r.forward());
        assert!((r.target() - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5);
        let cam = r.camera(1.5).unwrap();
        assert!((cam.eye() - r.eye).length() < 1e-5);
        let d = r.desc();
        assert_eq!((d.eye, d.fov_y, d.near, d.far), (r.eye, 1.0, 0.1, None));
    }

    #[test]
    fn fly_moves_along_the_view() {
        let mut r = rig();
        r.speed = 4.0;
        r.step(Motion { forward: 1.0, boost: 1.0, ..Motion::default() }, 0.25);
        assert!((r.eye - Vec3::new(0.0, 2.0, 9.0)).length() < 1e-5, "{}", r.eye);
        // Turning right by 90 degrees looks down +X; strafing right then moves to +Z.
        r.turn(std::f32::consts::FRAC_PI_2 / LOOK_PER_PIXEL, 0.0);
        assert!((r.forward() - Vec3::X).length() < 1e-4, "{}", r.forward());
        assert!((r.right() - Vec3::Z).length() < 1e-4, "{}", r.right());
    }

    #[test]
    fn pitch_never_flips() {
        let mut r = rig();
        r.turn(0.0, -1e6);
        assert!(r.pitch <= MAX_PITCH && r.camera(1.0).is_ok());
        r.turn(0.0, 1e6);
        assert!(r.pitch >= -MAX_PITCH && r.camera(1.0).is_ok());
    }

    #[test]
    fn orbit_keeps_the_target() {
        let mut r = rig();
        r.mode = Mode::Orbit;
        let t = r.target();
        r.turn(300.0, 100.0);
        assert!((r.target() - t).length() < 1e-4);
        r.wheel(3.0);
        assert!((r.target() - t).length() < 1e-4);
        assert!(r.distance < 10.0);
        r.wheel(f32::NAN);
        assert!(r.eye.is_finite());
    }
}
