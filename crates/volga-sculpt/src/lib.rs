//! # volga-sculpt — volume sculpting on a dynamic-resolution octree
//!
//! The sculpting capability of the survey's §17.9: a free-form solid (a block, a voxelized
//! mesh, any [`volga_core::Field`]) is carved, sawn, sprayed, painted and smoothed with
//! volume-sampled tools (Wang & Kaufman), stored in Bærentzen's octree with dynamic
//! resolution: leaves at any level, homogeneous regions one node, detail inserted only
//! where a tool's boundary passes and collapsed again when it becomes homogeneous.
//!
//! * [`Sculpt`]: the session — [`Sculpt::apply`] a [`Stroke`] (a [`Tool`] and an
//!   [`Operation`]), [`Sculpt::undo`] / [`Sculpt::redo`] (history steps share unchanged
//!   subtrees), [`Sculpt::to_bytes`] / [`Sculpt::from_bytes`] (versioned, checksummed),
//!   [`Sculpt::save`] / [`Sculpt::open`] (the same on a path: atomic, errors naming it),
//!   [`Sculpt::to_sparse_volume`] and [`Sculpt::surface`] (mesh) exports.
//! * The sculpt is a [`volga_core::Field`] (trilinear density, density-weighted colour,
//!   per-node value ranges), so `volga-render` draws it and skips its homogeneous nodes;
//!   each edit's [`EditReport::changed_world`] bounds the pixels a re-render must redo.
//! * Tools ([`Tool`]): any analytic shape of volga-shapes, a torus or a closed mesh at a
//!   [`Pose`], or such a tool swept along a polyline ([`Tool::swept`], the saw).
//!
//! ## Spaces and units
//! World space is `f64` (`world_*`, `DVec3`). The sculpt's voxels live on a
//! [`SculptGrid`]: voxel `ijk` (index space, `IVec3`) has its centre at
//! `origin + ijk·spacing` (isotropic spacing), `8·2^levels` voxels per axis; payloads are
//! `f32` densities in \[0, 1\] (½ on the surface, the oriented box profile of survey §17.4)
//! and `f32` linear RGB colours.
//!
//! ```
//! use glam::DVec3;
//! use volga_core::Field;
//! use volga_sculpt::{Operation, Sculpt, SculptGrid, Stroke, Tool};
//! use volga_shapes::{AxisBox, FilteredDensity, OrientedBoxFilter};
//!
//! let grid = SculptGrid::new(DVec3::ZERO, 1.0, 3).unwrap(); // 64³ voxels
//! let block = FilteredDensity::new(
//!     AxisBox::new(DVec3::splat(8.0), DVec3::splat(56.0)).unwrap(),
//!     OrientedBoxFilter::for_spacing(DVec3::ONE),
//! );
//! let mut sculpt = Sculpt::from_field(grid, &block, [0.8, 0.7, 0.6]);
//! let before = sculpt.stats().nodes();
//! let carve = Stroke::new(Tool::sphere(DVec3::splat(32.0), 6.0).unwrap(), Operation::Carve).unwrap();
//! let report = sculpt.apply(&carve);
//! assert!(sculpt.value(DVec3::splat(32.0)) == 0.0); // hollowed out
//! assert!(report.changed_world.unwrap().contains(DVec3::new(32.0, 32.0, 26.5)));
//! sculpt.undo();
//! assert_eq!(sculpt.stats().nodes(), before);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bounds;
mod edit;
mod export;
mod field;
mod file;
mod octree;
mod sculpt;
mod tool;

pub use bounds::BRICK_BYTES_BOUND;
pub use edit::{EditReport, Operation, Stroke};
pub use file::{crc32, FileError, SculptFileError, FORMAT_VERSION};
pub use octree::{NodeStats, SculptGrid, Voxel, BRICK, MAX_LEVELS, MAX_WORLD};
pub use sculpt::Sculpt;
pub use tool::{MeshTool, Pose, Tool, ToolError, ToolShape, MAX_SWEEP_SAMPLES};

/// Why a sculpt could not be made or edited.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SculptError {
    /// The grid's placement or depth is not valid ([`SculptGrid::new`]).
    #[error("sculpt grid needs an origin within ±1e100, a spacing of at least 1e-100, an extent (spacing × voxels per axis) of at most 1e100 and at most {MAX_LEVELS} levels; got origin {origin:?}, spacing {spacing:e}, levels {levels}")]
    Grid {
        /// The origin given.
        origin: [f64; 3],
        /// The spacing given.
        spacing: f64,
        /// The number of levels given.
        levels: u32,
    },
    /// An operation's parameters are out of range (the message says which).
    #[error("invalid operation {0}")]
    Operation(String),
    /// The tool was refused.
    #[error(transparent)]
    Tool(#[from] ToolError),
}
