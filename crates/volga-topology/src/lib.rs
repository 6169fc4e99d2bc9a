//! # volga-topology — discrete topology of binary voxel sets (survey 17.2)
//!
//! Given a set of black voxels, this crate answers whether it is a sound discrete
//! surface: its N-connected components, whether it is N-separating, which of its
//! voxels are N-simple, whether it is N-minimal, where tunnels through a continuous
//! surface pass, and the Euler characteristic, cavities and handles of the black
//! solid. [`analyze`] runs them all into one serializable [`TopologyReport`].
//!
//! ## Space
//! Everything is in **index space**: a voxel is an integer `ijk: IVec3` of its grid;
//! there are no world coordinates here (convert through the grid transform of
//! `volga_core` before and after). The voxel space `Σ` of the survey is the grid
//! `0 ≤ ijk < dims` of a [`VoxelSet`]: voxels outside the grid are **not part of `Σ`**
//! — neither black nor white, they connect nothing. Call [`VoxelSet::padded`] to add
//! a white layer around the grid when the outside should count as one white region.
//!
//! ## Definitions (survey 17.2)
//! * Two voxels are **6-adjacent** if they share a face, **18-adjacent** if they share
//!   a face or an edge, **26-adjacent** if they share a face, an edge or a vertex
//!   ([`Connectivity`]).
//! * An **N-path** is a sequence of voxels of one colour, consecutive ones
//!   N-adjacent; a set is **N-connected** if an N-path joins every pair of its voxels;
//!   an **N-component** is a maximal N-connected set ([`black_components`],
//!   [`white_components`]).
//! * The black set `S` is **N-separating** in `Σ` if the white voxels `Σ − S` form at
//!   least two white N-components.
//! * A black voxel `p` is **N-simple** if removing it merges no two white
//!   N-components: the set stays N-separating with the same separated regions. The
//!   survey asks only that `S − p` still be N-separating; the two agree when white has
//!   exactly two components (a closed surface's inside and outside, or the two sides
//!   of a plane), and ours is the stricter one otherwise (removing a wall between two
//!   of three rooms keeps the survey's "separating" but merges regions). Removing a
//!   voxel with no white N-neighbour creates a new one-voxel cavity and merges
//!   nothing: simple. This is separation-preserving simplicity, not the
//!   topology-preserving simple point of digital topology (which also preserves black
//!   components, tunnels and cavities).
//! * `S` is **N-minimal** if it is N-separating and has no N-simple voxel
//!   ([`is_minimal`]).
//! * An **N-tunnel** through a continuous surface is a pair of N-adjacent white
//!   voxels whose connecting segment crosses the surface ([`tunnels`] for any surface
//!   given as a crossing predicate, [`mesh_tunnels`] for a triangle mesh). With a
//!   reference surface, `S` is **N-separating with respect to it** when there is no
//!   N-tunnel: the definition for open surfaces, whose white set need not split.
//! * `S` **covers** a surface when every point of it lies in a black voxel's closed
//!   cell; the cover is **minimal** when removing any one black voxel uncovers a point
//!   ([`cover`]).
//!
//! ## Exact and local simplicity
//! [`is_simple`] / [`simple_voxels`] are **exact**: with the global white labels, `p`
//! is simple iff the labels of its white N-neighbours (inside the grid) take at most
//! one value. Any white N-path through `p` after its removal enters and leaves `p`
//! through white N-neighbours, so regions can merge only if two neighbours carry
//! different labels — and then they do merge, through `p`.
//!
//! [`is_simple_local`] decides from the 3×3×3 neighbourhood alone: `p` is locally
//! simple if its white N-neighbours are N-connected by white voxels of the
//! neighbourhood minus `p`. It is **sound**: locally simple ⇒ simple (a local white
//! path is a white path). The two disagree exactly on the voxels whose white
//! N-neighbours fall into two or more local pieces that all belong to **one** global
//! white component — pieces joined only by white paths that leave the neighbourhood:
//! a voxel of a fin (a wall with a free edge, the white going around it), or next to a
//! hole in the surface. Everywhere else they agree; in particular on a closed surface
//! with no other part of itself within the 3×3×3 window of `p`, whose local pieces
//! are its two sides, inside and outside. The test
//! `local_and_exact_simplicity_differ_on_a_fin` shows a voxel where they differ.
//!
//! ## Checks against a reference mesh
//! [`SurfaceMesh`] holds triangles in the set's index space (converted from world space
//! with the grid's transform, the arithmetic volga's voxelizers use) and the transform
//! for reporting world positions. [`analyze_with_mesh`] adds a [`MeshReport`] to the
//! report: N-tunnels with their location (both voxels, the triangle, the crossing point
//! in index and world space), cover, uncovered triangles, black voxels the surface does
//! not touch, redundant voxels and minimal cover. Segment–triangle and closed
//! triangle–box tests are `volga-mesh`'s ([`volga_mesh::segment_crosses_triangle`],
//! touching counts; [`volga_mesh::triangle_box_overlap`]); the open-box test that
//! decides cover exactly is [`triangle_meets_open_box`]. The cover test and why it is
//! exact are documented on [`cover`]. Each triangle visits only the voxels near it, so
//! the cost follows the surface.
//!
//! ## Euler characteristic, cavities and handles
//! [`euler_characteristic`] counts `χ = V − E + F − C` over the distinct vertices,
//! edges, faces and cubes of the black voxels taken as closed unit cubes.
//! [`betti_numbers`] adds `b0` (black 26-components), `b2` (cavities: white
//! 6-components not touching the grid border) and `b1 = b0 + b2 − χ` (handles). These
//! hold for the (26, 6) adjacency pair, the one under which the union of closed
//! cubes and its open complement are connected, whatever N a report uses.
//!
//! ## Cost
//! Labelling works on maximal x-runs of each colour per row (a row without black
//! voxels is one white run), united with the runs of neighbouring rows by union-find:
//! time and memory are linear in rows + black voxels, not in the grid volume, so a
//! 1024³ shell costs its voxels and a 1024² row index. Work is split by z-slabs and
//! combined in a fixed order: results do not depend on the thread count.
//!
//! ```
//! use glam::{IVec3, UVec3};
//! use volga_topology::{analyze, Connectivity, VoxelSet};
//! // The plane z = 2 across a 5×5×5 grid separates z < 2 from z > 2.
//! let plane = (0..5).flat_map(|y| (0..5).map(move |x| IVec3::new(x, y, 2)));
//! let set = VoxelSet::from_voxels(UVec3::splat(5), plane).unwrap();
//! let report = analyze(&set, Connectivity::TwentySix);
//! assert!(report.separating && report.minimal);
//! assert_eq!(report.white_component_count, 2);
//! assert_eq!(report.euler_characteristic, 1);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod brute;
mod components;
mod connectivity;
mod error;
mod euler;
mod report;
mod runs;
mod set;
mod simple;
mod surface;
mod tunnel;
mod verdict;

pub use components::{black_components, white_components, Component, Components};
pub use connectivity::Connectivity;
pub use error::TopologyError;
pub use euler::{betti_numbers, euler_characteristic, Betti};
pub use report::{
    analyze, analyze_with, analyze_with_mesh, AnalyzeOptions, Check, Region, TopologyReport, WhiteComponent,
};
pub use set::VoxelSet;
pub use simple::{is_minimal, is_simple, is_simple_local, leaks_if_removed, simple_voxels, simple_voxels_with, Leak};
pub use surface::{
    check_mesh, cover, mesh_tunnels, triangle_meets_open_box, Cover, MeshReport, MeshTunnel, SurfaceMesh,
    UncoveredTriangle,
};
pub use tunnel::{tunnels, Tunnel};
pub use verdict::{verdict, MeshInfo, Requirement, RequirementResult, Verdict, VerdictError, VerdictInput};
