//! Cameras with reversed-Z projections (depth 1 at the near plane, 0 at the far plane
//! or at infinity), right-handed, looking down -Z in view space. Construction rejects
//! NaN/inf and degenerate parameters with a typed error. Depends on glam only.

use glam::{Mat4, Vec3, Vec4};

use crate::error::CullError;

/// The projection of a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with vertical field of view `fov_y` (radians), `aspect` = width/height,
    /// near plane distance, and far plane distance or `None` for an infinite far plane.
    Perspective {
        /// Vertical field of view, radians, in (0, pi).
        fov_y: f32,
        /// Width / height.
        aspect: f32,
        /// Near plane distance, > 0.
        near: f32,
        /// Far plane distance (> near) or infinite.
        far: Option<f32>,
    },
    /// Orthographic with half-height `half_height` (metres), `aspect` = width/height,
    /// near (>= 0) and far (> near) plane distances.
    Orthographic {
        /// Half of the view volume's height.
        half_height: f32,
        /// Width / height.
        aspect: f32,
        /// Near plane distance, >= 0.
        near: f32,
        /// Far plane distance, > near.
        far: f32,
    },
}

/// Parameters to turn a reversed-Z depth value into a view distance, identical on CPU and
/// GPU: perspective `dist = near / (d * (1 - k) + k)` with `k = near / far` (0 when far is
/// infinite, so no division by infinity); orthographic `dist = far - d * (far - near)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthParams {
    /// True for orthographic.
    pub orthographic: bool,
    /// Near plane distance.
    pub near: f32,
    /// Far plane distance (`f32::INFINITY` when infinite).
    pub far: f32,
    /// `near / far` (0 when infinite).
    pub k: f32,
}

impl DepthParams {
    /// View distance (positive, along -Z) of a reversed-Z depth value. Sky (depth 0 with an
    /// infinite far plane) returns `f32::INFINITY`, never NaN.
    pub fn view_distance(&self, depth: f32) -> f32 {
        if self.orthographic {
            self.far - depth * (self.far - self.near)
        } else {
            let denom = depth * (1.0 - self.k) + self.k;
            if denom <= 0.0 {
                f32::INFINITY
            } else {
                self.near / denom
            }
        }
    }

    /// Reversed-Z depth of a view distance (inverse of [`Self::view_distance`]).
    pub fn depth(&self, distance: f32) -> f32 {
        if self.orthographic {
            (self.far - distance) / (self.far - self.near)
        } else {
            (self.near / distance - self.k) / (1.0 - self.k)
        }
    }
}

/// A camera: a rigid view transform and a reversed-Z projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: Vec3,
    view: Mat4,
    projection: Projection,
    proj: Mat4,
}

fn check(cond: bool, what: impl FnOnce() -> String) -> Result<(), CullError> {
    if cond {
        Ok(())
    } else {
        Err(CullError::InvalidCamera(what()))
    }
}

fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Result<Mat4, CullError> {
    check(eye.is_finite(), || format!("eye {eye} is not finite"))?;
    check(target.is_finite(), || format!("target {target} is not finite"))?;
    check(up.is_finite(), || format!("up {up} is not finite"))?;
    let fwd = target - eye;
    check(fwd.length() > 1e-6 * eye.length().max(1.0), || format!("target {target} coincides with eye {eye}"))?;
    let fwd = fwd.normalize();
    check(up.length_squared() > 0.0 && fwd.cross(up.normalize()).length() > 1e-4, || {
        format!("up {up} is zero or parallel to the view direction {fwd}")
    })?;
    Ok(Mat4::look_to_rh(eye, fwd, up.normalize()))
}

impl Camera {
    /// A perspective camera at `eye` looking at `target`. `far: None` is an infinite far plane.
    pub fn perspective(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y: f32,
        aspect: f32,
        near: f32,
        far: Option<f32>,
    ) -> Result<Self, CullError> {
        let view = look_at(eye, target, up)?;
        Self::from_view(view, Projection::Perspective { fov_y, aspect, near, far })
    }

    /// An orthographic camera at `eye` looking at `target`.
    #[allow(clippy::too_many_arguments)]
    pub fn orthographic(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        half_height: f32,
        aspect: f32,
        near: f32,
        far: f32,
    ) -> Result<Self, CullError> {
        let view = look_at(eye, target, up)?;
        Self::from_view(view, Projection::Orthographic { half_height, aspect, near, far })
    }

    /// A camera from a world-to-view matrix (must be finite and invertible) and a projection.
    pub fn from_view(view: Mat4, projection: Projection) -> Result<Self, CullError> {
        check(view.is_finite(), || "view matrix is not finite".into())?;
        let det = view.determinant();
        check(det.is_finite() && det.abs() > 1e-12, || format!("view matrix is singular (det {det})"))?;
        let proj = match projection {
            Projection::Perspective { fov_y, aspect, near, far } => {
                check(fov_y.is_finite() && fov_y > 0.0 && fov_y < std::f32::consts::PI, || {
                    format!("field of view {} degrees must be in (0, 180)", fov_y.to_degrees())
                })?;
                check(aspect.is_finite() && aspect > 0.0, || {
                    format!("aspect ratio {aspect} must be finite and positive")
                })?;
                check(near.is_finite() && near > 0.0, || format!("near plane {near} must be finite and positive"))?;
                match far {
                    None => Mat4::perspective_infinite_reverse_rh(fov_y, aspect, near),
                    Some(far) => {
                        check(far.is_finite() && far > near, || {
                            format!("far plane {far} must be finite and beyond near {near}")
                        })?;
                        // glam maps z_near to 0 and z_far to 1: swapping them reverses Z.
                        Mat4::perspective_rh(fov_y, aspect, far, near)
                    }
                }
            }
            Projection::Orthographic { half_height, aspect, near, far } => {
                check(half_height.is_finite() && half_height > 0.0, || {
                    format!("orthographic half-height {half_height} must be finite and positive")
                })?;
                check(aspect.is_finite() && aspect > 0.0, || {
                    format!("aspect ratio {aspect} must be finite and positive")
                })?;
                check(near.is_finite() && near >= 0.0, || {
                    format!("near plane {near} must be finite and non-negative")
                })?;
                check(far.is_finite() && far > near, || {
                    format!("far plane {far} must be finite and beyond near {near}")
                })?;
                let hw = half_height * aspect;
                Mat4::orthographic_rh(-hw, hw, -half_height, half_height, far, near)
            }
        };
        check(proj.is_finite(), || format!("projection {projection:?} is not finite"))?;
        let eye = view.inverse().w_axis.truncate();
        Ok(Self { eye, view, projection, proj })
    }

    /// This camera with another aspect ratio (a resized window).
    pub fn with_aspect(&self, aspect: f32) -> Result<Self, CullError> {
        let projection = match self.projection {
            Projection::Perspective { fov_y, near, far, .. } => Projection::Perspective { fov_y, aspect, near, far },
            Projection::Orthographic { half_height, near, far, .. } => {
                Projection::Orthographic { half_height, aspect, near, far }
            }
        };
        Self::from_view(self.view, projection)
    }

    /// Eye position, world space.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
    /// World-to-view matrix.
    pub fn view(&self) -> Mat4 {
        self.view
    }
    /// View-to-clip matrix (reversed-Z).
    pub fn proj(&self) -> Mat4 {
        self.proj
    }
    /// World-to-clip matrix.
    pub fn view_proj(&self) -> Mat4 {
        self.proj * self.view
    }
    /// The projection parameters.
    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// Parameters for depth <-> view distance.
    pub fn depth_params(&self) -> DepthParams {
        match self.projection {
            Projection::Perspective { near, far, .. } => DepthParams {
                orthographic: false,
                near,
                far: far.unwrap_or(f32::INFINITY),
                k: far.map_or(0.0, |f| near / f),
            },
            Projection::Orthographic { near, far, .. } => DepthParams { orthographic: true, near, far, k: near / far },
        }
    }

    /// View-space position of a point given in NDC x, y (y up) and reversed-Z depth.
    /// Depth 0 with an infinite far plane (sky) has no position: returns `None`.
    pub fn unproject_view(&self, ndc_x: f32, ndc_y: f32, depth: f32) -> Option<Vec3> {
        let dist = self.depth_params().view_distance(depth);
        if !dist.is_finite() {
            return None;
        }
        Some(self.view_point_at(ndc_x, ndc_y, dist))
    }

    /// View-space point at NDC (x, y) and view distance `dist` (along -Z). Uses the
    /// projection's entries directly (no matrix inverse), identically in WGSL.
    pub fn view_point_at(&self, ndc_x: f32, ndc_y: f32, dist: f32) -> Vec3 {
        view_point_at(&self.proj, self.depth_params().orthographic, ndc_x, ndc_y, dist)
    }
}

/// View-space point at NDC (x, y) and view distance `dist`, for a projection whose x and y
/// rows are `(p00, 0, p20, p30)` and `(0, p11, p21, p31)` (symmetric or off-centre).
/// Perspective: clip.w = dist, so x = (ndc_x * dist - p20 * -dist - p30) / p00.
pub fn view_point_at(proj: &Mat4, orthographic: bool, ndc_x: f32, ndc_y: f32, dist: f32) -> Vec3 {
    let z = -dist;
    let w = if orthographic { 1.0 } else { dist };
    let x = (ndc_x * w - proj.z_axis.x * z - proj.w_axis.x) / proj.x_axis.x;
    let y = (ndc_y * w - proj.z_axis.y * z - proj.w_axis.y) / proj.y_axis.y;
    Vec3::new(x, y, z)
}

/// The plane (xyz normal pointing inside, w offset; `dot(n, p) + w >= 0` inside) through
/// which clip-space coordinate `row` equals `edge * clip.w`, with `sign` +1 to keep
/// `row >= edge * w` and -1 for `row <= edge * w`. Built from projection rows (no cross
/// products of nearly parallel corner rays, whose error grows for 1 px tiles and narrow
/// fields of view), then normalised.
pub fn clip_edge_plane(proj: &Mat4, row: usize, edge: f32, sign: f32) -> Vec4 {
    let r = proj.row(row);
    let w = proj.row(3);
    let p = (r - w * edge) * sign;
    p / p.truncate().length()
}
