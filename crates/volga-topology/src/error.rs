use thiserror::Error;

/// Errors raised when building a [`VoxelSet`](crate::VoxelSet) from caller input.
///
/// The analyses themselves cannot fail: a `VoxelSet` that exists is valid (sorted,
/// deduplicated, inside its grid), so every function over it is total.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum TopologyError {
    /// A grid needs at least one voxel on every axis.
    #[error("voxel grid dimensions must be ≥ 1 on every axis, got {0:?}")]
    EmptyGrid([u32; 3]),
    /// The grid's row index (8 bytes per `(y, z)` row) or its voxel count does not fit
    /// in memory or in the address space; nothing was allocated.
    #[error("voxel grid of {dims:?} voxels needs {bytes} bytes for its row index, more than is available")]
    TooLarge {
        /// Voxels per axis of the grid asked for.
        dims: [u32; 3],
        /// Bytes the row index would take.
        bytes: u128,
    },
    /// A voxel given to a constructor lies outside the grid `0 ≤ ijk < dims`.
    #[error("voxel {ijk:?} lies outside the grid 0..{dims:?}")]
    OutsideGrid {
        /// The voxel (index space).
        ijk: [i32; 3],
        /// Voxels per axis of the grid.
        dims: [u32; 3],
    },
}
