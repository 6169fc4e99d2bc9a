//! Why a CVG object could not be made: [`CvgError`].

use glam::DVec3;

/// An argument a constructor of this crate refuses, named with the value it got.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CvgError {
    /// [`crate::Radial::new`]: `radius` is not finite and > 0.
    #[error("radius must be finite and > 0, got {0}")]
    Radius(f64),
    /// [`crate::Radial::new`]: `sample_spacing` is not finite and > 0.
    #[error("sample_spacing must be finite and > 0, got {0}")]
    SampleSpacing(f64),
    /// [`crate::Radial::new`]: the core's `center` (a point's position, an axis's
    /// centre) is not finite.
    #[error("core center must be finite, got {0}")]
    Center(DVec3),
    /// [`crate::Radial::new`]: the core's `axis` has no direction (zero, too small to
    /// normalize, or not finite).
    #[error("core axis must be a finite non-zero vector, got {0}")]
    Axis(DVec3),
    /// [`crate::Radial::new`]: the core's `half_length` is not finite and > 0.
    #[error("core half_length must be finite and > 0, got {0}")]
    HalfLength(f64),
}
