//! Turntable sequences: one image output rendered as `frames` numbered PNGs
//! (`{name}_0000.png`, `{name}_0001.png`, …), frame `k` seen by the image's camera
//! turned by `360°·k/frames` about an axis ([`Camera::orbit`]). The frames are staged
//! with the build's other outputs, so a failed build writes none of them.

use glam::DVec3;
use volga_render::Camera;

use crate::ctx::Ctx;
use crate::model::TurntableSpec;
use crate::SceneError;

/// Most frames one turntable may ask for.
pub const MAX_TURNTABLE_FRAMES: u32 = 3600;

/// A validated turntable.
#[derive(Clone, Debug, PartialEq)]
pub struct Turntable {
    /// Number of frames, 1 to [`MAX_TURNTABLE_FRAMES`]; frame `k` is turned by
    /// `360°·k/frames`.
    pub frames: u32,
    /// Unit rotation axis.
    pub axis: DVec3,
    /// A world point on the axis.
    pub center: DVec3,
}

impl Turntable {
    /// The camera of frame `k` (`camera` turned by `2π·k/frames`).
    pub fn camera(&self, camera: &Camera, k: u32) -> Option<Camera> {
        let angle = std::f64::consts::TAU * k as f64 / self.frames as f64;
        camera.orbit(self.center, self.axis, angle)
    }
}

/// File stem of frame `k` of the image output `name`: `{name}_{k:04}`.
pub fn frame_stem(name: &str, k: u32) -> String {
    format!("{name}_{k:04}")
}

/// Checks a turntable of the image at field path `f` (`outputs.images[i].turntable`)
/// rendered with `camera`: 1 to [`MAX_TURNTABLE_FRAMES`] frames, a finite non-zero
/// axis, a finite centre (default: `target`, the camera's target, or one unit ahead
/// of the eye without one) and a camera that stays valid in every frame.
pub(crate) fn validate(
    cx: &Ctx,
    f: &str,
    t: &TurntableSpec,
    camera: &Camera,
    target: Option<DVec3>,
) -> Result<Turntable, SceneError> {
    if !(1..=MAX_TURNTABLE_FRAMES).contains(&t.frames) {
        return Err(cx.err(
            format!("{f}.frames"),
            format!("must lie in 1..={MAX_TURNTABLE_FRAMES}, got {}", t.frames),
        ));
    }
    let axis = cx.finite3(&format!("{f}.axis"), t.axis)?;
    if axis.length_squared() == 0.0 || !axis.length_squared().is_finite() {
        return Err(cx.err(format!("{f}.axis"), "must be a finite, non-zero vector"));
    }
    let center = match t.center {
        Some(c) => cx.finite3(&format!("{f}.center"), c)?,
        None => target.unwrap_or(camera.eye() + camera.forward()),
    };
    let turntable = Turntable {
        frames: t.frames,
        axis: axis.normalize(),
        center,
    };
    for k in 0..t.frames {
        if turntable.camera(camera, k).is_none() {
            return Err(cx.err(f, format!("frame {k}'s camera is not finite")));
        }
    }
    Ok(turntable)
}
