//! # volga — a volume graphics modeling kernel
//!
//! volga turns geometry into voxels, combines and decorates voxel objects, and renders
//! them with its own raycaster. This facade re-exports the public API of its crates:
//!
//! * [`core`] (`volga-core`): grid transform, dense and sparse bricked volumes, the
//!   [`Field`] sampling trait, reconstruction filters;
//! * [`mesh`] (`volga-mesh`): triangle meshes, OBJ/glTF loading, exact predicates, BVH;
//! * [`voxelize`] (`volga-voxelize`): binary (6/18/26-separating) and anti-aliased
//!   voxelization of triangles, meshes, lines, quadrics and solids; distance fields;
//! * [`topology`] (`volga-topology`): discrete topology and the voxelization validator;
//! * [`render`] (`volga-render`): cameras, transfer functions, iso-surface and volume
//!   rendering over any [`Field`];
//! * [`io`] (`volga-io`): PNG and NRRD files, atomic writes;
//! * [`sculpt`] (`volga-sculpt`): volume sculpting on a dynamic-resolution octree
//!   (carve, saw, spray, paint, smooth; undo/redo; save/load; exports);
//! * [`scene`] (`volga-scene`): scene files, planning and the `volga build` pipeline.
//!
//! World coordinates are `f64`, voxel payloads `f32` (see [`core`] for why).
//!
//! ```
//! use volga::{Grid, Transform, Field, Filter, Sampled, NoProgress};
//! use volga::voxelize::{voxelize_solids, Solid, Shape, shapes::Sphere};
//! use glam::{DVec3, UVec3};
//!
//! let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(32)).unwrap();
//! let ball = Solid::new(Shape::Sphere(Sphere::new(DVec3::splat(16.0), 10.0).unwrap()), [1.0, 0.5, 0.2]);
//! let volume = voxelize_solids(&grid, &[ball], false, &NoProgress);
//! let field = Sampled::new(&volume, Filter::Trilinear);
//! // Density is 0.5 on the sphere's surface (oriented box filter, survey §17.4).
//! assert!((field.value(DVec3::new(26.0, 16.0, 16.0)) - 0.5).abs() < 1e-6);
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub use glam;
pub use volga_adf as adf;
pub use volga_core as core;
pub use volga_cvg as cvg;
pub use volga_io as io;
pub use volga_mesh as mesh;
pub use volga_render as render;
pub use volga_scene as scene;
pub use volga_sculpt as sculpt;
pub use volga_shapes as shapes;
pub use volga_texture as texture;
pub use volga_topology as topology;
pub use volga_voxelize as voxelize;

pub use volga_core::{
    Aabb, DenseVolume, Field, Filter, Grid, IndexBox, NoProgress, Progress, Sampled, SparseVolume, Transform,
};

/// What most programs need, in one import: `use volga::prelude::*;`.
///
/// The vector types of [`glam`] (world positions are `DVec3`, voxel indices `IVec3`,
/// grid sizes `UVec3`), the core types (grids, volumes, the [`Field`] trait and its
/// reconstruction), loading and querying meshes, the mesh-voxelize job, reading and
/// writing voxel models, the validator, rendering, scenes and sculpting. Everything else
/// stays under its crate's module ([`voxelize`], [`render`], …).
pub mod prelude {
    pub use glam::{DVec3, IVec3, UVec3, Vec3, Vec4};

    pub use volga_core::{
        Aabb, Adjacency, DenseVolume, Field, FieldKind, Filter, GradientMethod, Grid, IndexBox, NoProgress, Progress,
        Sampled, SparseVolume, Transform,
    };
    pub use volga_io::{read_voxel_model, save_voxel_model, write_png, VoxelModel};
    pub use volga_mesh::{load_mesh, MeshQueries, TriMesh};
    pub use volga_render::{render, Camera, Image, Mode, Projection, RenderSettings, Renderer};
    pub use volga_scene::{build, BuildOptions};
    pub use volga_sculpt::{Operation, Pose, Sculpt, Stroke, Tool};
    pub use volga_topology::{verdict, Connectivity, Requirement, Verdict, VerdictInput, VoxelSet};
    pub use volga_voxelize::{MeshJob, MeshJobMode, Separability};
}
