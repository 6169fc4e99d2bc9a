use glam::DVec3;

use crate::RenderError;

/// How world space is projected onto the image plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Parallel rays; the image spans `height_world` world units vertically (the
    /// horizontal extent follows the image's aspect ratio).
    Orthographic {
        /// Full vertical extent of the image in world units; finite and > 0.
        height_world: f64,
    },
    /// Rays from the eye; `fov_y_deg` is the full vertical field of view in degrees.
    Perspective {
        /// Full vertical field of view in degrees; finite, in (0, 180).
        fov_y_deg: f64,
    },
}

/// A ray `origin + t·dir` in world space; cameras produce unit `dir`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// World position at `t = 0`: the eye (perspective) or a point of the image plane
    /// through the eye (orthographic).
    pub origin: DVec3,
    /// World direction; unit length from a [`Camera`], so `t` is a world distance.
    pub dir: DVec3,
}

impl Ray {
    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// A validated pinhole or orthographic camera with an orthonormal frame.
///
/// The frame is right-handed: `right = forward × up`, so a camera looking along
/// world +z with up +y has image x growing towards world −x.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    projection: Projection,
    /// Half the image-plane height: world units (orthographic) or `tan(fov/2)`
    /// at unit distance (perspective).
    half_height: f64,
}

/// `v / |v|` computed without overflow for huge components; zero if `v` is zero or
/// not finite.
pub(crate) fn safe_normalize(v: DVec3) -> DVec3 {
    let m = v.abs().max_element();
    if m.is_nan() || m <= 0.0 || !m.is_finite() {
        return DVec3::ZERO;
    }
    (v / m).normalize_or_zero()
}

impl Camera {
    /// A camera at `eye` looking at `target` with `up` giving the image's vertical.
    ///
    /// Validates: finite inputs, `eye != target`, `up` non-zero and not parallel to
    /// the view direction, `fov_y_deg` in (0, 180), `height_world > 0`.
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3, projection: Projection) -> Result<Camera, RenderError> {
        for (name, v) in [("eye", eye), ("target", target), ("up", up)] {
            if !v.is_finite() {
                return Err(RenderError::NonFiniteCamera {
                    name,
                    value: v.to_array(),
                });
            }
        }
        let view = target - eye;
        let forward = if view.is_finite() {
            safe_normalize(view)
        } else {
            DVec3::ZERO
        };
        if forward == DVec3::ZERO {
            return Err(RenderError::EyeEqualsTarget {
                eye: eye.to_array(),
                target: target.to_array(),
            });
        }
        let up_n = safe_normalize(up);
        let right = forward.cross(up_n);
        if up_n == DVec3::ZERO || right.length() < 1e-9 {
            return Err(RenderError::UpParallelToView(up.to_array()));
        }
        let right = right.normalize();
        let true_up = right.cross(forward).normalize();
        let half_height = match projection {
            Projection::Orthographic { height_world } => {
                if !(height_world.is_finite() && height_world > 0.0) {
                    return Err(RenderError::BadHeight(height_world));
                }
                height_world * 0.5
            }
            Projection::Perspective { fov_y_deg } => {
                if !(fov_y_deg.is_finite() && fov_y_deg > 0.0 && fov_y_deg < 180.0) {
                    return Err(RenderError::BadFov(fov_y_deg));
                }
                (fov_y_deg.to_radians() * 0.5).tan()
            }
        };
        Ok(Camera {
            eye,
            forward,
            right,
            up: true_up,
            projection,
            half_height,
        })
    }

    /// The ray through pixel `(px, py)` of a `width × height` image.
    ///
    /// `(px, py)` are pixel indices (fractions allowed for sub-pixel offsets): the
    /// ray passes through the image-plane point `(px + 0.5, py + 0.5)`, so integer
    /// arguments give pixel centres; `py` grows downwards. `dir` is unit length.
    /// Orthographic rays are parallel to the view direction with origins on the
    /// image plane through the eye; perspective rays start at the eye.
    /// A zero `width` or `height` is treated as 1.
    pub fn ray(&self, px: f64, py: f64, width: u32, height: u32) -> Ray {
        let w = width.max(1) as f64;
        let h = height.max(1) as f64;
        let sx = ((px + 0.5) / w * 2.0 - 1.0) * self.half_height * (w / h);
        let sy = (1.0 - (py + 0.5) / h * 2.0) * self.half_height;
        match self.projection {
            Projection::Orthographic { .. } => Ray {
                origin: self.eye + self.right * sx + self.up * sy,
                dir: self.forward,
            },
            Projection::Perspective { .. } => Ray {
                origin: self.eye,
                dir: (self.forward + self.right * sx + self.up * sy).normalize(),
            },
        }
    }

    /// World position of the eye: where perspective rays start, and the centre of the
    /// plane orthographic rays start on.
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// Unit view direction (from the eye towards the target).
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// Unit image-x direction in world space.
    pub fn right(&self) -> DVec3 {
        self.right
    }

    /// Unit image-up direction in world space (orthogonal to `forward`).
    pub fn up(&self) -> DVec3 {
        self.up
    }

    /// The projection the camera was made with.
    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// This camera turned rigidly (eye, view direction and up) by `angle_rad` about the
    /// line through `center` along `axis`, counter-clockwise seen from the axis' tip:
    /// one frame of a turntable. `None` when `axis` is zero or any input is not finite.
    pub fn orbit(&self, center: DVec3, axis: DVec3, angle_rad: f64) -> Option<Camera> {
        let axis = safe_normalize(axis);
        if axis == DVec3::ZERO || !center.is_finite() || !angle_rad.is_finite() {
            return None;
        }
        let q = glam::DQuat::from_axis_angle(axis, angle_rad);
        let eye = center + q * (self.eye - center);
        eye.is_finite().then(|| Camera {
            eye,
            forward: (q * self.forward).normalize(),
            right: (q * self.right).normalize(),
            up: (q * self.up).normalize(),
            ..*self
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ortho(h: f64) -> Projection {
        Projection::Orthographic { height_world: h }
    }

    #[test]
    fn validation_errors() {
        let p = Projection::Perspective { fov_y_deg: 45.0 };
        let (e, t, u) = (DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y);
        assert!(Camera::look_at(e, t, u, p).is_ok());
        assert!(matches!(
            Camera::look_at(DVec3::new(f64::NAN, 0.0, 0.0), t, u, p),
            Err(RenderError::NonFiniteCamera { name: "eye", .. })
        ));
        assert!(matches!(
            Camera::look_at(e, DVec3::splat(f64::INFINITY), u, p),
            Err(RenderError::NonFiniteCamera { name: "target", .. })
        ));
        assert!(matches!(
            Camera::look_at(e, e, u, p),
            Err(RenderError::EyeEqualsTarget { .. })
        ));
        assert!(matches!(
            Camera::look_at(e, t, DVec3::Z * 3.0, p),
            Err(RenderError::UpParallelToView(_))
        ));
        assert!(matches!(
            Camera::look_at(e, t, DVec3::ZERO, p),
            Err(RenderError::UpParallelToView(_))
        ));
        for fov in [0.0, 180.0, -5.0, f64::NAN, 200.0] {
            assert!(matches!(
                Camera::look_at(e, t, u, Projection::Perspective { fov_y_deg: fov }),
                Err(RenderError::BadFov(_))
            ));
        }
        for h in [0.0, -1.0, f64::INFINITY, f64::NAN] {
            assert!(matches!(
                Camera::look_at(e, t, u, ortho(h)),
                Err(RenderError::BadHeight(_))
            ));
        }
        // Huge but finite coordinates do not overflow the frame computation.
        assert!(Camera::look_at(DVec3::splat(1e308), DVec3::splat(-1e308), u, p).is_err());
        assert!(Camera::look_at(DVec3::new(1e307, 0.0, 0.0), DVec3::ZERO, u, p).is_ok());
        let msg = Camera::look_at(e, t, u, Projection::Perspective { fov_y_deg: 0.0 })
            .unwrap_err()
            .to_string();
        assert!(msg.contains("fov_y_deg"), "{msg}");
    }

    #[test]
    fn perspective_centre_ray_points_at_target() {
        let eye = DVec3::new(3.0, -2.0, 7.0);
        let target = DVec3::new(0.5, 1.0, -1.0);
        let cam = Camera::look_at(eye, target, DVec3::Z, Projection::Perspective { fov_y_deg: 40.0 }).unwrap();
        let want = (target - eye).normalize();
        // Odd size: the centre pixel's centre; even size: the point between pixels.
        let r = cam.ray(2.0, 2.0, 5, 5);
        assert!((r.dir - want).length() < 1e-12);
        assert_eq!(r.origin, eye);
        let r = cam.ray(31.5, 23.5, 64, 48);
        assert!((r.dir - want).length() < 1e-12);
        assert!((r.dir.length() - 1.0).abs() < 1e-12);
        // y grows downwards: a top-row pixel points more along `up`.
        assert!(cam.ray(2.0, 0.0, 5, 5).dir.dot(cam.up()) > 0.0);
        assert!(cam.ray(4.0, 2.0, 5, 5).dir.dot(cam.right()) > 0.0);
    }

    #[test]
    fn orthographic_rays_are_parallel_and_span_the_height() {
        let cam = Camera::look_at(DVec3::new(0.0, 0.0, -10.0), DVec3::ZERO, DVec3::Y, ortho(4.0)).unwrap();
        assert_eq!(cam.forward(), DVec3::Z);
        let top = cam.ray(0.0, -0.5, 1, 1);
        let bottom = cam.ray(0.0, 0.5, 1, 1);
        assert_eq!(top.dir, DVec3::Z);
        assert!((top.origin.y - 2.0).abs() < 1e-12);
        assert!((bottom.origin.y + 2.0).abs() < 1e-12);
        assert!((cam.ray(0.0, 0.0, 1, 1).origin - cam.eye()).length() < 1e-12);
        // A zero-sized image does not divide by zero.
        assert!(cam.ray(0.0, 0.0, 0, 0).origin.is_finite());
    }
}
