//! Why a texture could not be made: [`TextureError`].

use glam::Vec3;

/// An argument a constructor of this crate refuses, named with the value it got.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TextureError {
    /// [`crate::HyperTexture::new`]: `soft_width` is not finite and > 0.
    #[error("soft_width must be finite and > 0, got {0}")]
    SoftWidth(f64),
    /// [`crate::HyperTexture::new`]: `sample_spacing` is not finite and > 0.
    #[error("sample_spacing must be finite and > 0, got {0}")]
    SampleSpacing(f64),
    /// [`crate::SampledDistance::new`]: `values` does not hold one distance per voxel.
    #[error("values must hold one distance per voxel of the grid ({expected}), got {got}")]
    ValueCount {
        /// Voxels of the grid.
        expected: u64,
        /// Length of `values`.
        got: usize,
    },
    /// [`crate::ColourSpline::new`]: `knots` is empty.
    #[error("knots must hold at least one knot, got none")]
    NoKnots,
    /// [`crate::ColourSpline::new`]: a knot's position or colour is not finite.
    #[error("knots[{index}] must be finite, got position {position} and colour {colour}")]
    KnotNotFinite {
        /// Index of the knot in `knots`.
        index: usize,
        /// Its position.
        position: f64,
        /// Its colour (linear RGB).
        colour: Vec3,
    },
    /// [`crate::ColourSpline::new`]: a knot's position is not above the previous one's.
    #[error("knots[{index}] must lie after knots[{}] at {previous}, got position {position}", .index - 1)]
    KnotOrder {
        /// Index of the knot in `knots`.
        index: usize,
        /// Its position.
        position: f64,
        /// The previous knot's position.
        previous: f64,
    },
}
