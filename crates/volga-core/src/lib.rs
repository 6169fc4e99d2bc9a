//! # volga-core — grids, volumes and the one sampling interface
//!
//! Everything else in volga is a tool over the types defined here (survey §17; the
//! split follows OpenVDB's tree/tools separation):
//!
//! * [`Transform`] maps **world space** (`world_*`, metres or whatever unit the scene
//!   uses) to continuous **index space** (`index_*`, `ijk` for integer voxel
//!   coordinates) with per-axis spacing and an origin. [`Grid`] adds the voxel extent.
//! * [`DenseVolume`] and [`SparseVolume`] store voxel payloads; [`SparseGrid`] is the
//!   bricked storage (8³ bricks addressed by **brick space** coordinates `brick_*`).
//! * [`Field`] is the narrow trait every representation implements and the renderer
//!   consumes: value, gradient, colour, bounds and a conservative value range.
//!
//! ## Voxel convention (stated once, used everywhere)
//! Voxel `ijk` is a *sample point* at `world = origin + ijk ⊙ spacing`; it stands for
//! the cell `[ijk − ½, ijk + ½)` in index space. A grid of `dims` voxels therefore
//! covers the world box `origin − spacing/2 .. origin + (dims − ½) ⊙ spacing`.
//! Nearest-neighbour reconstruction follows the same half-open rule: a point exactly
//! between two voxel centres belongs to the upper one (`floor(x + ½)`).
//! Outside the grid every voxel has the volume's background value.
//!
//! ## Precision
//! Geometry (positions, distances, transforms) is `f64`: a grid whose origin sits at
//! 1e6 still resolves 1e-6 of a voxel, which `f32` cannot (its spacing at 1e6 is
//! 0.06). Voxel payloads (density, colour) are `f32`: they are bounded quantities in
//! \[0, 1\] (or distances of a few voxels) where `f32`'s 24 bits exceed any render or
//! filter accuracy, and they halve memory, which bounds how large a volume fits.
//! Reconstruction arithmetic is done in `f64`, so trilinear interpolation of stored
//! values is exact up to the final rounding.
//!
//! ```
//! use volga_core::{Grid, Transform, DenseVolume, Sampled, Filter, Field};
//! use glam::{DVec3, UVec3};
//! let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::splat(0.5)).unwrap(), UVec3::splat(4)).unwrap();
//! let mut vol = DenseVolume::new(grid, 0.0, false).unwrap();
//! vol.density.set(glam::IVec3::new(1, 1, 1), 1.0);
//! let field = Sampled::new(&vol, Filter::Trilinear);
//! assert_eq!(field.value(DVec3::new(0.5, 0.5, 0.75)), 0.5);
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod aabb;
mod adjacency;
mod atlas;
mod channel;
mod dense;
mod error;
mod field;
mod filters;
mod grid;
pub mod input;

/// The largest world coordinate or length volga's grids accept (scene grids, sculpts):
/// sums, differences and squares of such values stay finite in `f64`.
pub const MAX_WORLD: f64 = 1e100;
/// The smallest voxel size volga's grids accept: squares of lengths a few voxels long
/// stay normal `f64` numbers (a spacing of 1e-300 would square to 0).
pub const MIN_SPACING: f64 = 1e-100;
mod layout;
pub mod memory;
mod progress;
mod sampled;
mod sparse;
mod units;

pub use aabb::Aabb;
pub use adjacency::Adjacency;
pub use atlas::{AtlasReader, BrickAtlas, MAX_ATLAS_BYTES};
pub use channel::ChannelKind;
pub use dense::{Dense, DenseVolume};
pub use error::CoreError;
pub use field::{Crossing, CrossingRay, Field, FieldKind, Line};
pub use filters::{Filter, GradientMethod};
pub use grid::{fast_floor, Grid, IndexBox, Transform};
pub use layout::Shape3;
pub use progress::{NoProgress, Progress};
pub use sampled::{DenseReader, Sampled, SampledVoxels, SparseReader, VoxelBlock, VoxelReader, VoxelSource};
pub use sparse::{
    brick_extent, brick_index_box, brick_of, bricks_meeting, gather_brick, Brick, SparseGrid, SparseVolume, BRICK_DIM,
    BRICK_LOG2, BRICK_SHAPE, BRICK_VOXELS,
};

/// Linear RGB colour payload, each component in \[0, 1\].
pub type Rgb = [f32; 3];
