use thiserror::Error;

/// Errors raised by the renderer; each message names the offending parameter.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RenderError {
    #[error("camera `{name}` must be finite, got {value:?}")]
    NonFiniteCamera { name: &'static str, value: [f64; 3] },
    #[error(
        "camera `eye` and `target` must differ (and `target - eye` must be finite), got eye {eye:?}, target {target:?}"
    )]
    EyeEqualsTarget { eye: [f64; 3], target: [f64; 3] },
    #[error("camera `up` must be non-zero and not parallel to the view direction, got {0:?}")]
    UpParallelToView([f64; 3]),
    #[error("perspective `fov_y_deg` must be finite and in (0, 180), got {0}")]
    BadFov(f64),
    #[error("orthographic `height_world` must be finite and > 0, got {0}")]
    BadHeight(f64),
    #[error("transfer function `points` must not be empty")]
    EmptyTransferFunction,
    #[error("transfer function control point `value` must be finite, got {0}")]
    NonFiniteTransferValue(f64),
    #[error("transfer function `rgba` must be in [0, 1] on every channel, got {rgba:?} at value {value}")]
    TransferColourOutOfRange { value: f64, rgba: [f32; 4] },
    #[error("transfer function has duplicate control point `value` {0}")]
    DuplicateTransferValue(f64),
    /// `name` is the setting's path, e.g. `sampling.step_voxels`,
    /// `lighting.lights[0].direction` or `mode.value`.
    #[error("render setting `{name}` is invalid: {reason}")]
    BadSetting { name: String, reason: String },
    #[error("field `bounds()` must be finite and non-empty, got min {min:?}, max {max:?}")]
    BadFieldBounds { min: [f64; 3], max: [f64; 3] },
    #[error("field `sample_spacing()` must be finite and > 0, got {0}")]
    BadSampleSpacing(f64),
}

pub(crate) fn bad_setting(name: impl Into<String>, reason: impl Into<String>) -> RenderError {
    RenderError::BadSetting {
        name: name.into(),
        reason: reason.into(),
    }
}
