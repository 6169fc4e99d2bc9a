use thiserror::Error;

/// Errors raised when constructing core types from invalid parameters.
///
/// The kernel validates at construction so that a `Grid` or `Transform` that exists is
/// always usable (no zero spacing, no NaN origin, no zero-sized grid).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    #[error("spacing must be finite and > 0 on every axis, got {0:?}")]
    BadSpacing([f64; 3]),
    #[error("origin must be finite, got {0:?}")]
    BadOrigin([f64; 3]),
    #[error("grid dimensions must be ≥ 1 on every axis, got {0:?}")]
    EmptyGrid([u32; 3]),
    #[error("grid of {dims:?} voxels needs {bytes} bytes, which does not fit in this address space")]
    TooLarge { dims: [u32; 3], bytes: u128 },
}
