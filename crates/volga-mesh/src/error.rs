use std::path::PathBuf;

use thiserror::Error;

/// Why a mesh file could not be loaded. Every message names the file; OBJ syntax
/// errors also name the line (1-based), so a user can open the file at the fault.
#[derive(Debug, Error)]
pub enum MeshError {
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A malformed OBJ statement, located by volga's own scan of the text.
    #[error("{}:{line}: {message}", path.display())]
    ObjSyntax {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A `v` statement whose coordinates are NaN or infinite (after the optional `w` divide).
    #[error(
        "{}:{line}: vertex {vertex} is not finite: ({}, {}, {})",
        path.display(), position[0], position[1], position[2]
    )]
    NonFiniteVertex {
        path: PathBuf,
        line: usize,
        /// 1-based, as OBJ faces count vertices.
        vertex: usize,
        position: [f64; 3],
    },
    /// An OBJ error reported by `tobj` that the line scan could not locate.
    #[error("{}: {message}", path.display())]
    Obj { path: PathBuf, message: String },
    /// A glTF/GLB file that does not parse or whose buffers and accessors are inconsistent.
    #[error("{}: {message}", path.display())]
    Gltf { path: PathBuf, message: String },
    /// The glTF parser panicked on the file (a malformed document that volga's own checks
    /// did not catch first); the panic was caught and its message kept. Kept apart from
    /// [`MeshError::Gltf`] so tests and fuzzing can tell a caught panic from a refusal.
    #[error("{}: malformed glTF (parser failure: {reason})", path.display())]
    GltfPanic { path: PathBuf, reason: String },
    /// A glTF primitive whose topology is not a triangle list.
    #[error("{}: mesh {mesh}, primitive {primitive}: mode {mode} is not supported (only TRIANGLES)", path.display())]
    UnsupportedPrimitive {
        path: PathBuf,
        /// The mesh's name if it has one, else `#index`.
        mesh: String,
        primitive: usize,
        mode: String,
    },
    #[error("{}: the mesh has no triangles", path.display())]
    Empty { path: PathBuf },
    #[error("{}: more than {} vertices do not fit 32-bit triangle indices", path.display(), u32::MAX)]
    TooManyVertices { path: PathBuf },
    #[error("{}: unknown mesh format (expected .obj, .gltf or .glb)", path.display())]
    UnknownFormat { path: PathBuf },
}

/// Why a [`crate::TriMesh`] built in memory is invalid (see [`crate::TriMesh::new`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum InvalidMesh {
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {vertex_count} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertex_count: usize,
    },
    #[error("vertex {vertex} is not finite: {position:?}")]
    NonFiniteVertex { vertex: usize, position: [f64; 3] },
    #[error("{0} vertices do not fit 32-bit triangle indices")]
    TooManyVertices(usize),
}
