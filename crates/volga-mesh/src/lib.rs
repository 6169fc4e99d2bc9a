//! # volga-mesh — triangle meshes in, exact geometric queries out
//!
//! The mesh side of volga's voxelizers (survey §17.1–17.4): what they ask of a
//! triangle mesh, answered exactly.
//!
//! * [`TriMesh`] holds positions and triangles; [`load_mesh`] reads OBJ (via `tobj`)
//!   and glTF/GLB (via `gltf`) into it, with errors that name the file and, for OBJ,
//!   the line. Topology queries ([`TriMesh::edge_stats`], [`TriMesh::is_closed`])
//!   weld exactly-equal positions first, so texture seams are not holes.
//! * Predicates over single triangles, written here with their sources cited:
//!   [`closest_point_on_triangle`] (with the [`Feature`] it lands on),
//!   [`triangle_box_overlap`] (separating axes), [`segment_crosses_triangle`]
//!   (signed volumes, exact signs by Shewchuk's adaptive predicates via `robust`),
//!   [`solid_angle`] and the exact [`winding_number`].
//! * [`Bvh`] accelerates them over a whole mesh: exact nearest point (branch and
//!   bound), triangles touching a box, the fast winding number of Barill et al., and
//!   [`Bvh::winding_number_bounded`], the same with a certified error bound, refined
//!   until it proves what is asked. [`unclean`] generates the meshes users bring
//!   (self-intersecting, overlapping, open, flat, single triangles) for tests.
//!   [`signed_distance`] combines the exact distance with the winding-number sign.
//! * [`CappedWinding`] proves `w ≥ ½` fast for many nearby points: the winding number
//!   of the mesh closed by cones over its boundary cycle ([`cap_triangles`]) is an
//!   integer off its sheets, carried from point to point by certified sheet crossings
//!   ([`CappedWinding::integer_along`]); only the few cone triangles are summed per
//!   point. The ADF builder (`volga-adf`) uses it.
//! * [`extract_surface`] meshes the iso-surface of any [`volga_core::Field`] (marching
//!   tetrahedra, watertight and manifold for closed surfaces, normals from the gradient);
//!   [`obj_bytes`] and [`ply_bytes`] write meshes as bytes for atomic output.
//!
//! ## Spaces, units, precision
//! Everything here is **world space**, in the mesh file's units, as `f64`
//! (`glam::DVec3`). Meshes are commonly placed far from the origin and voxelized
//! finely: at 1e6 an `f32` resolves only 0.06, while the predicates must decide
//! contact at exact ties (a face lying on a voxel face). Predicates also work relative
//! to a point of the triangle or box, so their precision follows the size of the
//! geometry, not its distance from the origin.
//!
//! ## Inside and outside
//! A point is inside when the generalized winding number is `≥ ½`. For a closed,
//! consistently oriented mesh that is the usual answer (1 inside, 0 outside); for an
//! open mesh (the Stanford bunny has 223 boundary edges) it is the documented answer
//! rather than whatever a ray-parity test happens to produce.
//!
//! ```
//! use glam::DVec3;
//! use volga_core::Aabb;
//! use volga_mesh::{signed_distance, Bvh, TriMesh};
//!
//! let cube = TriMesh::from_aabb(&Aabb::new(DVec3::splat(-1.0), DVec3::ONE));
//! assert!(cube.is_closed());
//! let bvh = Bvh::build(&cube);
//! assert_eq!(signed_distance(&bvh, DVec3::new(0.0, 0.0, 3.0)), 2.0);
//! assert_eq!(signed_distance(&bvh, DVec3::new(0.0, 0.5, 0.0)), -0.5);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bvh;
mod capped;
mod closest;
mod cones;
mod error;
pub mod extract;
mod gradient;
mod intersect;
mod load;
mod mesh;
mod overlap;
mod queries;
mod segment;
mod signed;
pub mod unclean;
mod winding;
mod write;

pub use bvh::{Bvh, Closest, WindingBound, FAR_FIELD_BETA};
pub use capped::{cap_triangles, signed_crossing, CappedWinding, InsideCost, WindingModel};
pub use closest::{
    closest_point_on_segment, closest_point_on_triangle, closest_point_with_frame, point_triangle_distance_squared,
    FaceFrame, Feature,
};
pub use cones::ConeCaps;
pub use error::{InvalidMesh, MeshError};
pub use extract::{
    extract_surface, extract_surface_bounded, extract_surface_with, extract_tree_cells, CellExtraction, ExtractError,
    ExtractMethod, Extraction, IsoIndex, Surface, TreeLeaf, VertexPlacement, BYTES_PER_TRIANGLE, MAX_BLOCKS,
    TREE_BYTES_PER_LEAF,
};
pub use gradient::SegmentTree;
pub use intersect::triangles_may_intersect;
pub use load::{load_gltf, load_mesh, load_obj, read_gltf, read_obj};
pub use mesh::{EdgeStats, TriMesh};
pub use overlap::{triangle_box_overlap, triangle_meets_open_box};
pub use queries::MeshQueries;
pub use segment::segment_crosses_triangle;
pub use signed::{signed_distance, signed_distance_within};
pub use winding::{solid_angle, winding_number};
pub use write::{obj_bytes, ply_bytes};
