//! Reading meshes from files. Every error names the file (and, for OBJ, the line).

mod gltf_file;
mod obj;

use std::path::Path;

pub use gltf_file::{load_gltf, read_gltf};
pub use obj::{load_obj, read_obj};

use crate::{MeshError, TriMesh};

/// Loads `.obj`, `.gltf` or `.glb` (extension case-insensitive).
pub fn load_mesh(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
    let path = path.as_ref();
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("obj") => load_obj(path),
        Some("gltf" | "glb") => load_gltf(path),
        _ => Err(MeshError::UnknownFormat { path: path.to_owned() }),
    }
}
