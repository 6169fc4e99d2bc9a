//! # volga-adf — adaptively sampled distance fields
//!
//! An ADF (Frisken, Perry, Rockwood & Jones 2000; survey §17.9) is an octree whose cells
//! store the signed distance at their 8 corners; the distance anywhere is the trilinear
//! reconstruction inside the leaf containing the point. A cell is split while that
//! reconstruction misses the true distance by more than a tolerance at its 19 test points
//! (centre, face centres, edge midpoints), down to a maximum depth, so cells are large
//! where the surface is flat and small where it curves or has sharp features. Cells
//! whose corners are all of one sign and farther from the surface than the cell's
//! diagonal are leaves without tests (Frisken's pruning: no surface passes through them).
//!
//! * **Build** ([`Adf::build`]) from any [`AdfSource`] (a [`DistanceSource`] with the
//!   build's optional shortcuts): a triangle mesh
//!   ([`MeshSource`]: exact distance, sign by the generalized winding number, proven per
//!   point, so the open Stanford bunny gets the same inside as the voxelizer's), a shape
//!   of the geometry layer ([`ShapeSource`]), CSG trees of sources ([`Csg`]), a sampled
//!   signed-distance volume ([`FieldSource`]), or another ADF. The top levels are built in
//!   parallel; the tree is identical for any thread count. The build evaluates each
//!   lattice point once per subtree, lets a source narrow its work per cell
//!   ([`AdfSource::candidates`]: a mesh scans the few triangles that can be nearest
//!   instead of walking its BVH) and prove a whole far cell's sign at once
//!   ([`AdfSource::side_of_empty_cell`]); these change the work, never the tree.
//! * **Queries**: [`Adf::distance`], [`Adf::gradient`] (the trilinear cell's analytic
//!   derivative), [`Adf::closest_point`], [`Adf::inside`], [`Adf::range`] (conservative
//!   bounds over a box), [`Adf::ray_hit`] (the cell structure walked with sphere-tracing
//!   steps, the first crossing found exactly in the leaf where it lies).
//! * **Rendering**: an `Adf` is a [`volga_core::Field`] of signed-distance kind, so the
//!   raycaster renders it directly; iso rays ask [`volga_core::Field::first_crossing`],
//!   which the ADF answers with its own leaf walk ([`Adf::first_crossing_between`]), and
//!   a tile's rays ask [`volga_core::Field::first_crossings`], answered by the batched
//!   walk ([`Adf::first_crossings_between`]: the same answers, with [`WALK_WINDOW`] rays'
//!   memory reads overlapped; `OneRayWalk` renders one ray at a time),
//!   other modes sample it and skip empty space with per-cell ranges. The walk runs on an
//!   index built on the first ray (module `walk`: a 128³ grid of tree nodes with
//!   conservative minima, each cell's chessboard reach to the nearest cell that can hold
//!   the surface, 4³-cell blocks, the box of cells that can hold the surface, a compact
//!   copy of the child links; [`Adf::walk_index_bytes`]); the reference walk
//!   without it is [`Adf::first_crossing_by_descent`] (`DescentWalk` renders with it).
//!   `DescentWalk` and `OneRayWalk` are for benchmarks and tests, behind the cargo
//!   feature `reference-walks`.
//! * **CSG and edits** ([`Adf::combine`], [`Adf::edit`]): union, intersection and
//!   difference with another ADF or any source, regenerating only the cells the operation
//!   can change (the Kizamu approach of Perry & Frisken 2001); counted in [`EditStats`].
//! * **Conversions**: [`Adf::to_narrow_band`] (a sparse signed-distance volume) and
//!   [`Adf::to_mesh`] (the zero iso-surface through `volga_mesh::extract_surface`); a
//!   sculpt samples an ADF with `volga_sculpt::Sculpt::from_field` like any distance field.
//! * **Accuracy**: [`measure_errors`] at random points against an exact source, and
//!   [`measure_errors_with_probes`] with the points themselves ([`Probe`]).
//!
//! ## Precision
//! Geometry is `f64` world space (`world_*`): the root cube, cell corners and queries, so
//! an ADF at 1e6 resolves cells down to 1e-9 of a unit. Stored corner distances are `f32`
//! payloads (half the memory of `f64`; their rounding, ≤ 6e-8 relative to the value, is
//! included in the build's tolerance checks because the build tests the reconstruction
//! from the rounded corners).
//!
//! ## Guarantees and their limits
//! The tolerance is checked at each leaf's 19 test points (Frisken's criterion, with the
//! safety factor [`TEST_MARGIN`]), not everywhere in the cell; leaves at the maximum depth are not checked (they are the
//! resolution limit: sharp edges, where the signed distance has a crease, and, for open
//! meshes, the surface across a hole where the winding-number sign jumps). Pruned leaves
//! carry the right sign everywhere (1-Lipschitz argument) but not the tolerance. The
//! accuracy figures in `docs/ADF.md` are measured at random points against exact distance.

#![deny(unsafe_code)]
#![warn(missing_docs)]

mod convert;
mod cubic;
mod dual;
mod edit;
mod field;
mod measure;
mod ray;
mod reach;
#[cfg(feature = "reference-walks")]
mod reference_walks;
mod source;
#[cfg(test)]
mod test_rng;
mod tree;
mod walk;

pub use edit::EditStats;
pub use measure::{measure_errors, measure_errors_with_probes, ErrorStats, Probe};
pub use ray::RayHit;
#[cfg(feature = "reference-walks")]
pub use reference_walks::{DescentWalk, OneRayWalk};
pub use source::{AdfSource, CellCandidates, Csg, CsgOp, FieldSource, MeshSource, Sample, SurfaceMeasures};
pub use tree::{
    Adf, AdfOptions, BuildEstimate, BuildStats, LeafInfo, BUILD_BYTES_PER_CELL, MAX_SUPPORTED_DEPTH, TEST_MARGIN,
};
/// The signed distance a build samples, and a shape as one (from `volga-shapes`).
pub use volga_shapes::{DistanceSource, ShapeSource};
pub use walk::WALK_WINDOW;

use volga_core::FieldKind;

/// Why an ADF could not be built or edited.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum AdfError {
    /// [`AdfOptions::tolerance`] is not finite and > 0.
    #[error("tolerance must be a finite number > 0, got {0} (a tolerance of 0 would split every curved cell down to the maximum depth)")]
    Tolerance(f64),
    /// [`AdfOptions::max_depth`] exceeds [`MAX_SUPPORTED_DEPTH`].
    #[error("max_depth {0} exceeds the supported {MAX_SUPPORTED_DEPTH}")]
    Depth(u8),
    /// [`AdfOptions::band`] is not finite and ≥ 0.
    #[error("band must be finite and ≥ 0, got {0}")]
    Band(f64),
    /// [`AdfOptions::margin`] is not finite and ≥ 0.
    #[error("margin must be finite and ≥ 0, got {0}")]
    Margin(f64),
    /// The source has nothing to build a root cube around (no triangles, empty bounds, a
    /// single point without a margin).
    #[error("nothing to build from: {0}")]
    EmptySource(String),
    /// A mesh source with more triangles than its candidate lists can name.
    #[error("the mesh has {0} triangles; a mesh source takes at most 2^31 - 1")]
    TooManyTriangles(usize),
    /// The source is unbounded (an infinite cylinder, a half-space): an ADF covers a
    /// finite root cube around the source's bounds.
    #[error("the source is unbounded (its bounds reach {min:?}..{max:?}): an ADF needs a bounded source, e.g. intersect it with a box")]
    Unbounded {
        /// The bounds' minimum corner.
        min: [f64; 3],
        /// The bounds' maximum corner.
        max: [f64; 3],
    },
    /// The source's distance at this world point is NaN or infinite.
    #[error("the source's value is not finite at {0:?}")]
    NonFinite([f64; 3]),
    /// [`FieldSource::new`] was given a field of this kind, not a signed distance.
    #[error("a {0:?} field is not a signed distance")]
    NotADistance(FieldKind),
    /// The build would hold more than [`AdfOptions::max_cells`] cells.
    #[error(
        "the ADF build stopped at its limit of {limit} cells ({bytes} bytes while building, {per_cell} per cell) before the tolerance was met; raise the tolerance, lower max_depth or allow more memory",
        per_cell = BUILD_BYTES_PER_CELL
    )]
    TooManyCells {
        /// [`AdfOptions::max_cells`].
        limit: usize,
        /// The bytes the build would hold past the limit ([`BUILD_BYTES_PER_CELL`] per
        /// cell).
        bytes: u64,
    },
    /// [`Adf::combine`] was given ADFs with different root cubes.
    #[error("CSG operands must share their root cube and depth limit (build the second with Adf::build_like)")]
    Mismatched,
}
