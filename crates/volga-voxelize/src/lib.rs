//! # volga-voxelize — turning geometry into voxels
//!
//! This first part holds **volume-sampled analytic solids** (survey §17.4): a sphere,
//! an axis-aligned box and an oriented box, each with an exact signed distance
//! ([`shapes`]), sampled with the **oriented box filter** of Sramek & Kaufman
//! ([`OrientedBoxFilter`]): density is a linear function of the signed distance across
//! a band of width 2√3 voxels, 0.5 on the surface. Several solids merge with the fuzzy
//! union (max, survey eq. 17). Mesh, line and quadric voxelizers join this crate later.
//!
//! Coordinates: shapes live in **world space** (`f64`); the output is a
//! [`volga_core::SparseVolume`] whose payload is `f32` density in \[0, 1\] (and colour
//! when asked). Work is proportional to the surface: only bricks within the filter band
//! of a surface are sampled voxel by voxel; bricks wholly inside a solid are stored as
//! one uniform value, bricks wholly outside are not stored.
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

pub mod binary;
mod field;
mod filter;
pub mod lines;
mod mask;
pub mod measure;
mod mesh;
mod pairs;
mod regions;
pub mod shapes;
mod solids;
pub mod surfaces;
mod tri_distance;

pub use binary::{triangle_covers_voxel, voxelize_mesh_surface, voxelize_triangles, Separability};
pub use field::AnalyticField;
pub use filter::OrientedBoxFilter;
pub use lines::{polyline_segments, segment_voxels, voxelize_segments, LineConnectivity};
pub use mesh::MeshVoxelizer;
pub use shapes::{Shape, SignedDistance};
pub use solids::{estimate_solid_bricks, merge_max, voxelize_solids, Solid};
pub use surfaces::{voxelize_shapes, SurfaceMode};
