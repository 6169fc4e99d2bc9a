use thiserror::Error;

/// Errors raised when constructing core types from invalid parameters.
///
/// The kernel validates at construction so that a `Grid` or `Transform` that exists is
/// always usable (no zero spacing, no NaN origin, no zero-sized grid).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// A [`Transform`](crate::Transform) spacing with a zero, negative, infinite or NaN
    /// component; holds, and the message shows, the spacing given (x, y, z).
    #[error("spacing must be finite and > 0 on every axis, got {0:?}")]
    BadSpacing([f64; 3]),
    /// A [`Transform`](crate::Transform) origin with an infinite or NaN component; holds,
    /// and the message shows, the origin given (x, y, z).
    #[error("origin must be finite, got {0:?}")]
    BadOrigin([f64; 3]),
    /// A [`Grid`](crate::Grid) or [`Shape3`](crate::Shape3) with 0 voxels along some axis;
    /// holds, and the message shows, the dims given.
    #[error("grid dimensions must be ≥ 1 on every axis, got {0:?}")]
    EmptyGrid([u32; 3]),
    /// A grid too large to represent: [`Grid::new`](crate::Grid::new) with an axis above
    /// `i32::MAX / 2` voxels, or [`Grid::shape`](crate::Grid::shape) /
    /// [`Shape3::new`](crate::Shape3::new) (and so the dense volumes) with a voxel count that
    /// does not fit in `usize`. The message names the dims and the voxel count.
    #[error("grid of {dims:?} voxels ({voxels} voxels) is too large to address: at most 1073741823 voxels per axis and a voxel count that fits in this address space")]
    TooLarge {
        /// The dims asked for.
        dims: [u32; 3],
        /// The voxel count `dims.x · dims.y · dims.z`.
        voxels: u128,
    },
    /// A region (a half-open box of voxel indices) that is empty or not inside the grid;
    /// the message names both.
    #[error("region {min:?}..{max:?} is empty or not inside the grid of {dims:?} voxels (need 0 ≤ min < max ≤ dims)")]
    BadRegion {
        /// The region's first voxel.
        min: [i32; 3],
        /// One past the region's last voxel.
        max: [i32; 3],
        /// The grid's dims.
        dims: [u32; 3],
    },
}
