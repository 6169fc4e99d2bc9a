use thiserror::Error;

/// Errors raised by the renderer; each message names the offending parameter.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RenderError {
    /// [`Camera::look_at`](crate::Camera::look_at) got an `eye`, `target` or `up` with an
    /// infinite or NaN component; the message names the argument and its value.
    #[error("camera `{name}` must be finite, got {value:?}")]
    NonFiniteCamera {
        /// `"eye"`, `"target"` or `"up"`.
        name: &'static str,
        /// The argument's value (x, y, z).
        value: [f64; 3],
    },
    /// [`Camera::look_at`](crate::Camera::look_at) got no view direction: `eye == target`,
    /// or `target − eye` overflows to infinity. The message names both points.
    #[error(
        "camera `eye` and `target` must differ (and `target - eye` must be finite), got eye {eye:?}, target {target:?}"
    )]
    EyeEqualsTarget {
        /// The eye given.
        eye: [f64; 3],
        /// The target given.
        target: [f64; 3],
    },
    /// [`Camera::look_at`](crate::Camera::look_at) got an `up` that is zero or (nearly)
    /// parallel to the view direction, so the image's vertical is undefined; holds, and the
    /// message shows, the `up` given.
    #[error("camera `up` must be non-zero and not parallel to the view direction, got {0:?}")]
    UpParallelToView([f64; 3]),
    /// A [`Projection::Perspective`](crate::Projection::Perspective) field of view that is
    /// not finite or not in (0, 180) degrees; holds, and the message shows, the value.
    #[error("perspective `fov_y_deg` must be finite and in (0, 180), got {0}")]
    BadFov(f64),
    /// A [`Projection::Orthographic`](crate::Projection::Orthographic) height that is not
    /// finite and > 0; holds, and the message shows, the value.
    #[error("orthographic `height_world` must be finite and > 0, got {0}")]
    BadHeight(f64),
    /// [`TransferFunction::new`](crate::TransferFunction::new) got no control point.
    #[error("transfer function `points` must not be empty")]
    EmptyTransferFunction,
    /// [`TransferFunction::new`](crate::TransferFunction::new) got a control point whose
    /// value is infinite or NaN; holds, and the message shows, that value.
    #[error("transfer function control point `value` must be finite, got {0}")]
    NonFiniteTransferValue(f64),
    /// [`TransferFunction::new`](crate::TransferFunction::new) got a control point with an
    /// RGBA channel outside \[0, 1\] or NaN; the message names the point's value and RGBA.
    #[error("transfer function `rgba` must be in [0, 1] on every channel, got {rgba:?} at value {value}")]
    TransferColourOutOfRange {
        /// The control point's value.
        value: f64,
        /// Its RGBA, at least one channel of which is out of range.
        rgba: [f32; 4],
    },
    /// [`TransferFunction::new`](crate::TransferFunction::new) got two control points with
    /// the same value; holds, and the message shows, that value.
    #[error("transfer function has duplicate control point `value` {0}")]
    DuplicateTransferValue(f64),
    /// A render setting or mode parameter out of its range: raised by
    /// [`RenderSettings::validate`](crate::RenderSettings::validate), the integrators'
    /// [`Integrator::validate`](crate::Integrator::validate) and
    /// [`Sampling::world_step`](crate::Sampling::world_step) (too many samples per ray).
    /// The message names the setting and the reason.
    #[error("render setting `{name}` is invalid: {reason}")]
    BadSetting {
        /// The setting's path, e.g. `sampling.step_voxels`,
        /// `lighting.lights[0].direction` or `mode.value`.
        name: String,
        /// What is wrong, usually with the value found (e.g. `must be ≥ 1, got 0×512`).
        reason: String,
    },
    /// The field's [`Field::bounds`](volga_core::Field::bounds) has an infinite or NaN
    /// corner or is empty, so rays cannot be clipped to it (raised by
    /// [`Sampling::world_step`](crate::Sampling::world_step) and so by every render). The
    /// message names both corners.
    #[error("field `bounds()` must be finite and non-empty, got min {min:?}, max {max:?}")]
    BadFieldBounds {
        /// The bounds' minimum corner.
        min: [f64; 3],
        /// The bounds' maximum corner.
        max: [f64; 3],
    },
    /// The field's [`Field::sample_spacing`](volga_core::Field::sample_spacing) is not
    /// finite and > 0 (raised by [`Sampling::world_step`](crate::Sampling::world_step) and so
    /// by every render); holds, and the message shows, the value.
    #[error("field `sample_spacing()` must be finite and > 0, got {0}")]
    BadSampleSpacing(f64),
}

pub(crate) fn bad_setting(name: impl Into<String>, reason: impl Into<String>) -> RenderError {
    RenderError::BadSetting {
        name: name.into(),
        reason: reason.into(),
    }
}
