//! # volga-voxelize — turning geometry into voxels
//!
//! * **Anti-aliased analytic solids** (survey §17.4): the shapes of the geometry layer
//!   (`volga-shapes`, re-exported as [`shapes`]: sphere, boxes, ellipsoid, cylinder, cone,
//!   general quadric, capsule, torus, each with a signed distance) sampled with the
//!   **oriented box filter** of Sramek & Kaufman ([`OrientedBoxFilter`]) and merged with
//!   the fuzzy union (max, survey eq. 17): [`voxelize_solids`].
//! * **Binary surfaces** of triangles with 6/18/26 separability ([`binary`]), lines
//!   ([`lines`]) and distance-driven modes for any signed distance ([`surfaces`]).
//! * **Meshes** ([`MeshVoxelizer`]): exact narrow-band distances (each triangle evaluated
//!   only in the regions where it can be nearest), anti-aliased shells and solids, and
//!   inside = generalized winding number ≥ ½, **proven** for every voxel on any mesh
//!   (open, self-intersecting, overlapping, flat), with how each sign was proven in
//!   [`SignStats`]; the `check` module (cargo feature `testing`, off by default) holds
//!   signs against a brute-force winding number for tests and benchmarks.
//!
//! Coordinates and geometry are **`f64`** (world space, index space for the discrete
//! tests); the output is a [`volga_core::SparseVolume`] whose payload is **`f32`**
//! (density in \[0, 1\], a distance in world units, and colour when asked): geometry
//! needs the precision for exact decisions far from the origin, payloads do not. Work
//! follows the surface: only bricks a band reaches are sampled voxel by voxel; bricks
//! wholly inside a solid are one uniform value, bricks wholly outside are not stored.
//! Results are identical for any thread count.
//!
//! ```
//! use volga_voxelize::{voxelize_solids, Solid, Shape, shapes::Sphere};
//! use volga_core::{Grid, Transform, NoProgress};
//! use glam::{DVec3, UVec3};
//! let grid = Grid::new(Transform::new(DVec3::splat(-16.0), DVec3::ONE).unwrap(), UVec3::splat(33)).unwrap();
//! let solids = [Solid::new(Shape::Sphere(Sphere::new(DVec3::ZERO, 10.0).unwrap()), [1.0; 3])];
//! let volume = voxelize_solids(&grid, &solids, false, &NoProgress);
//! assert_eq!(volume.density.get(glam::IVec3::splat(16)), 1.0);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod binary;
mod blocks;
#[cfg(feature = "testing")]
pub mod check;
mod field;
mod job;
pub mod lines;
mod mask;
pub mod measure;
mod mesh;
mod pairs;
mod profile;
mod regions;
mod sign;
mod solids;
pub mod surfaces;
mod tri_distance;

pub use binary::{triangle_covers_voxel, voxelize_mesh_surface, voxelize_triangles, Separability};
pub use field::AnalyticField;
pub use job::{parse_bytes_bound, JobError, JobEstimate, MeshJob, MeshJobMode, MeshRun};
pub use lines::{polyline_segments, segment_voxels, voxelize_segments, LineConnectivity, UnsupportedAdjacency};
pub use mesh::MeshVoxelizer;
pub use profile::{ProfileStage, VoxelizeProfile};
pub use sign::SignStats;
pub use solids::{estimate_solid_bricks, merge_max, voxelize_solids, voxelize_solids_in, Solid};
pub use surfaces::{voxelize_shapes, voxelize_shapes_in, SurfaceMode};
/// The geometry layer, re-exported: shapes and the filter live in `volga-shapes`.
pub use volga_shapes as shapes;
pub use volga_shapes::{OrientedBoxFilter, Shape, SignedDistance};
