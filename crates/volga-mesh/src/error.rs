use std::path::PathBuf;

use thiserror::Error;

/// Why a mesh file could not be loaded. Every message names the file; OBJ syntax
/// errors also name the line (1-based), so a user can open the file at the fault.
#[derive(Debug, Error)]
pub enum MeshError {
    /// The file itself could not be read (missing, unreadable, a directory…) by
    /// [`load_obj`](crate::load_obj), [`load_gltf`](crate::load_gltf) or
    /// [`load_mesh`](crate::load_mesh); the message adds the OS error. A glTF's external
    /// buffer that cannot be read is a [`MeshError::Gltf`] instead.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The path given to the loader.
        path: PathBuf,
        /// The error the operating system reported.
        #[source]
        source: std::io::Error,
    },
    /// A malformed OBJ statement, located by volga's own scan of the text.
    #[error("{}:{line}: {message}", path.display())]
    ObjSyntax {
        /// The file (the `path` given to the loader or to [`read_obj`](crate::read_obj)).
        path: PathBuf,
        /// 1-based line of the statement; for bytes that are not UTF-8, the line of the
        /// first invalid byte.
        line: usize,
        /// What is wrong, followed for a bad statement by the line's text in backticks
        /// (trimmed, cut after 60 characters); `not UTF-8 text` for binary input.
        message: String,
    },
    /// A `v` statement whose coordinates are NaN or infinite (after the optional `w` divide).
    #[error(
        "{}:{line}: vertex {vertex} is not finite: ({}, {}, {})",
        path.display(), position[0], position[1], position[2]
    )]
    NonFiniteVertex {
        /// The file (the `path` given to the loader or to [`read_obj`](crate::read_obj)).
        path: PathBuf,
        /// 1-based line of the `v` statement.
        line: usize,
        /// 1-based, as OBJ faces count vertices.
        vertex: usize,
        /// The coordinates `(x, y, z)` after the `w` divide, at least one NaN or infinite
        /// (a tiny `w` can overflow finite input).
        position: [f64; 3],
    },
    /// An OBJ error reported by `tobj` that the line scan could not locate.
    #[error("{}: {message}", path.display())]
    Obj {
        /// The file (the `path` given to the loader or to [`read_obj`](crate::read_obj)).
        path: PathBuf,
        /// `tobj`'s error text, or `` object `name` has a face index out of range ``.
        message: String,
    },
    /// A glTF/GLB file that does not parse or whose buffers and accessors are inconsistent.
    #[error("{}: {message}", path.display())]
    Gltf {
        /// The file (the `path` given to the loader or to [`read_gltf`](crate::read_gltf)).
        path: PathBuf,
        /// What is wrong, naming the mesh and primitive, accessor, bufferView, buffer or
        /// node concerned. Besides parse errors and out-of-bounds accessors this covers
        /// external buffers that cannot be read or lie outside the model's folder,
        /// unsupported data (sparse accessors, non-float or non-`VEC3` positions,
        /// non-base64 data URIs), a missing `POSITION` attribute, index counts that are
        /// not a multiple of 3, vertices that are not finite in world space, node
        /// hierarchies deeper than 256 levels or over 2²⁰ node instances, and instancing
        /// that expands to more than 2²⁷ triangles.
        message: String,
    },
    /// The glTF parser panicked on the file (a malformed document that volga's own checks
    /// did not catch first); the panic was caught and its message kept. Kept apart from
    /// [`MeshError::Gltf`] so tests and fuzzing can tell a caught panic from a refusal.
    #[error("{}: malformed glTF (parser failure: {reason})", path.display())]
    GltfPanic {
        /// The file (the `path` given to the loader or to [`read_gltf`](crate::read_gltf)).
        path: PathBuf,
        /// The panic's message; empty if its payload was not a string.
        reason: String,
    },
    /// A glTF primitive whose topology is not a triangle list.
    #[error("{}: mesh {mesh}, primitive {primitive}: mode {mode} is not supported (only TRIANGLES)", path.display())]
    UnsupportedPrimitive {
        /// The file (the `path` given to the loader or to [`read_gltf`](crate::read_gltf)).
        path: PathBuf,
        /// The mesh's name in backticks (`` `wheel` ``) if it has one, else `#` and its
        /// 0-based index (`#3`).
        mesh: String,
        /// 0-based index of the primitive within its mesh.
        primitive: usize,
        /// The primitive's topology as glTF names it: `POINTS`, `LINES`, `LINE_LOOP`,
        /// `LINE_STRIP`, `TRIANGLE_STRIP` or `TRIANGLE_FAN`.
        mode: String,
    },
    /// The file parsed but yields no triangles: an OBJ without faces (points and lines
    /// are skipped), or a glTF whose scene(s) instance no mesh or only empty primitives.
    #[error("{}: the mesh has no triangles", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// The mesh would have more than `u32::MAX` vertices (for glTF, counted after
    /// expanding node instances), which [`TriMesh`](crate::TriMesh)'s `u32` triangle
    /// indices cannot address.
    #[error("{}: more than {} vertices do not fit 32-bit triangle indices", path.display(), u32::MAX)]
    TooManyVertices {
        /// The file.
        path: PathBuf,
    },
    /// [`load_mesh`](crate::load_mesh) was given a path whose extension is not `obj`,
    /// `gltf` or `glb` (in any case), or that has none. Decided from the name alone;
    /// the file is not opened.
    #[error("{}: unknown mesh format (expected .obj, .gltf or .glb)", path.display())]
    UnknownFormat {
        /// The path given.
        path: PathBuf,
    },
}

/// Why a [`crate::TriMesh`] built in memory is invalid (see [`crate::TriMesh::new`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum InvalidMesh {
    /// A triangle holds a vertex index `≥ positions.len()`. Reports the first such
    /// triangle and its first offending corner; checked last.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {vertex_count} vertices")]
    IndexOutOfRange {
        /// 0-based index of the triangle in `triangles`.
        triangle: usize,
        /// The out-of-range vertex index it holds.
        index: u32,
        /// `positions.len()`: valid indices are `0..vertex_count`.
        vertex_count: usize,
    },
    /// A position has a NaN or infinite coordinate (the first such position is reported),
    /// whether or not a triangle uses it.
    #[error("vertex {vertex} is not finite: {position:?}")]
    NonFiniteVertex {
        /// 0-based index into `positions` (unlike the 1-based
        /// [`MeshError::NonFiniteVertex`] of OBJ files).
        vertex: usize,
        /// Its coordinates `(x, y, z)`.
        position: [f64; 3],
    },
    /// More than `u32::MAX` positions, which `u32` triangle indices cannot address;
    /// holds `positions.len()`. Checked first.
    #[error("{0} vertices do not fit 32-bit triangle indices")]
    TooManyVertices(usize),
}
