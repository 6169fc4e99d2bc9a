//! Constructive volume geometry (survey §17.5): spatial objects carrying a density in
//! \[0, 1\] and attributes (RGB colour, material id) combined by the fuzzy operators of
//! eq. 17, the algebraic operators of eq. 18 and blending ([`Op`], [`complement`]).
//!
//! * [`Cvg`] is a tree of operators over [`Leaf`]s (any `volga_core::Field`: filtered
//!   analytic shapes of `volga-shapes`, sampled volumes, hypertextures, fuzzy
//!   [`Radial`] primitives); [`CvgField`] is the tree as a `Field`, sampled lazily by
//!   the raycaster, with conservative interval bounds per box ([`Cvg::range`]) so empty
//!   space is skipped, and with the region it can reach ([`Cvg::support`]).
//! * [`bake`] voxelizes any field over only that region (an intersection bakes the
//!   overlap), bricks settled by their bounds alone cost no samples.
//! * [`voxblt`] copies or combines a cuboid block of one volume into another.
//!
//! Attribute rules are documented on [`Op::attributes`]. World space is `f64`; baked
//! payloads `f32` (the workspace's conventions, docs/ARCHITECTURE.md).
//!
//! ```
//! use glam::{DVec3, UVec3};
//! use volga_core::{Field, Grid, Transform};
//! use volga_cvg::{bake, Core, Cvg, CvgField, Op, Radial};
//!
//! let fuzzy = |c: DVec3| Cvg::leaf(Radial::new(Core::Point(c), 1.0, 0.05).unwrap());
//! // Two fuzzy spheres (density 1 − r): their fuzzy intersection (eq. 17).
//! let tree = Cvg::op(Op::Intersection, fuzzy(DVec3::ZERO), fuzzy(DVec3::X));
//! assert_eq!(tree.density(DVec3::new(0.5, 0.0, 0.0)), 0.5);
//! // It reaches only the overlap of the two boxes; bake just that.
//! let grid = Grid::new(Transform::new(DVec3::splat(-1.5), DVec3::splat(0.1)).unwrap(), UVec3::splat(40)).unwrap();
//! let field = CvgField::new(tree, &grid.world_bounds());
//! assert_eq!(field.bounds().min.x, 0.0);
//! let (volume, stats) = bake(&field, &grid, false);
//! assert!(stats.bricks_visited < 125 && volume.active_voxel_count() > 0);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bake;
mod error;
mod op;
mod radial;
mod tree;
mod voxblt;

pub use bake::{bake, bake_in, BakeStats};
pub use error::CvgError;
pub use op::{complement, Attributes, Op};
pub use radial::{Core, Radial};
pub use tree::{Cvg, CvgField, Leaf, LeafColour};
pub use voxblt::{voxblt, BlockOp};
