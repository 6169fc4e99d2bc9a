//! # volga-shapes — the geometry layer: shapes, signed distances, the oriented box filter
//!
//! Everything a tool needs to *describe* geometry, below every tool that turns it into
//! voxels, sculpts it or combines it (voxelize, topology, and the coming cvg, texture,
//! sculpt and adf crates all depend on this crate, never on each other):
//!
//! * [`SignedDistance`]: an exact (1-Lipschitz) or first-order signed distance, negative
//!   inside, with tight world bounds; implemented by every analytic shape of [`shapes`]
//!   (sphere, axis-aligned and oriented boxes, ellipsoid, cylinder, cone, general
//!   quadric, capsule; [`Shape`] is their closed set, dispatched once per brick) and by
//!   shapes added in their own file ([`Torus`]).
//! * [`OrientedBoxFilter`]: the oriented box filter of Sramek & Kaufman (survey §17.4):
//!   density `clamp(½ − d/W, 0, 1)` of a signed distance `d`.
//! * [`DistanceSource`]: what the tools that consume a signed distance (ADFs,
//!   hypertextures) ask of it — the distance, conservative ranges over boxes, bounds,
//!   exactness — and [`ShapeSource`], any [`SignedDistance`] as one.
//! * Adapters that make any signed distance a [`volga_core::Field`] the raycaster can
//!   render: [`FilteredDensity`] (distance → filtered density, the value voxelizers
//!   store) and [`DistanceField`] (the distance itself), and [`Negated`] (flip a
//!   field's sign, e.g. to turn an outside-positive distance into an inside-positive one).
//!
//! ## Spaces and precision
//! Every position is **world space** `f64` (`world_pos: DVec3`); distances are world
//! units, `f64`, so that a shape placed at 1e6 still resolves 1e-9 of a unit. Densities
//! are `f64` here (they are computed, not stored); voxel payloads become `f32` only in the
//! tools that store them.
//!
//! ```
//! use volga_shapes::{Sphere, SignedDistance, OrientedBoxFilter, FilteredDensity};
//! use volga_core::Field;
//! use glam::DVec3;
//! let ball = Sphere::new(DVec3::ZERO, 2.0).unwrap();
//! assert_eq!(ball.signed_distance(DVec3::new(3.0, 0.0, 0.0)), 1.0);
//! let density = FilteredDensity::new(ball, OrientedBoxFilter::for_spacing(DVec3::splat(0.1)));
//! assert_eq!(density.value(DVec3::new(2.0, 0.0, 0.0)), 0.5); // ½ on the surface
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod adapters;
mod filter;
pub mod shapes;
mod source;
mod torus;

pub use adapters::{DistanceField, FilteredDensity, Negated};
pub use filter::OrientedBoxFilter;
pub use shapes::{
    AxisBox, Capsule, Cone, Cylinder, Ellipsoid, InvalidShape, OrientedBox, Quadric, Shape, SignedDistance, Sphere,
};
pub use source::{DistanceSource, ShapeSource};
pub use torus::Torus;
