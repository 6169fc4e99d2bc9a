//! # volga-scene — scene files, planning and `volga build`
//!
//! A scene file (RON or JSON, chosen by extension) names a grid, a tree of nodes
//! (`objects`, their union, or `root`), a transfer function, lights, cameras and
//! outputs. This crate
//!
//! 1. parses it into the raw serde types of [`model`] (unknown fields and wrong types
//!    are errors naming file, line and column),
//! 2. validates it into a [`Scene`] whose objects are a tree of [`nodes`] (one file per
//!    node kind; out-of-range values are errors naming the field path, e.g.
//!    `objects[1].shape.radius`); validation reads no other file,
//! 3. resolves it ([`Scene::resolve`]): loads the meshes the nodes name, after checking
//!    from each file's size that parsing it fits in memory,
//! 4. plans it ([`plan::plan`]): whether anything is voxelized, which channels and
//!    effects the outputs call for (each image's integrator says what it needs), and an
//!    upper bound on the memory the build needs, refused before anything is allocated
//!    when it exceeds the available memory,
//! 5. builds it ([`build`]): bakes the tree when an output reads the volume, renders
//!    each image from the baked volume or the lazy tree, and writes PNG / NRRD outputs
//!    and `report.json` (every stage's wall time and peak memory) all or nothing.
//!
//! World coordinates in scenes are `f64`; the serde types stay in this crate, and the
//! kernel crates only ever see validated values.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod build;
mod ctx;
mod error;
mod load;
pub mod model;
pub mod nodes;
pub mod plan;
mod stages;
pub mod strokes;
pub mod turntable;
mod validate;

pub use build::{
    build, build_parsed, load_scene, validate_scene, BuildOptions, GridReport, ImageReport, Report, VoxelReport,
};
pub use error::{BuildError, SceneError};
pub use load::{parse_file, parse_json, parse_ron};
pub use plan::{bake_region, Decision, MemoryEstimate, Plan};
pub use stages::{peak_rss_bytes, reset_peak_rss, StageReport, Stages};
pub use validate::{content_bounds, validate, ImageJob, RenderSource, Scene};
