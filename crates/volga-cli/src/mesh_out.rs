//! Mesh outputs shared by `voxelize --mesh`, `sculpt --mesh` and `adf --mesh`: the
//! extraction method and adaptivity flags, the bounded extraction, the file's bytes.

use std::path::Path;

use volga_core::{Aabb, Field};
use volga_mesh::{ExtractMethod, Extraction, Surface};

use crate::failure::{bad_input, failed, Failure};

/// How a mesh output is extracted.
#[derive(clap::Args, Clone, Debug)]
pub struct MeshArgs {
    /// Extraction method of a --mesh output: cubes (marching cubes with the asymptotic
    /// decider and interior tunnels; the default), dual (dual contouring: sharp edges and
    /// corners kept) or tetrahedra (three times the triangles).
    #[arg(long, value_name = "cubes|dual|tetrahedra", default_value = "cubes")]
    pub mesh_method: String,
    /// Simplify a --mesh output: vertices merge while each stays within this many voxels of
    /// the planes of the triangles it replaces (0 to 10; 0 keeps every triangle).
    #[arg(long, value_name = "VOXELS", default_value_t = 0.0)]
    pub mesh_adaptivity: f64,
}

impl MeshArgs {
    /// The method and adaptivity, checked (exit 2 naming the flag).
    pub fn checked(&self) -> Result<(ExtractMethod, f64), Failure> {
        let method = ExtractMethod::from_name(&self.mesh_method).ok_or_else(|| {
            bad_input(format!(
                "--mesh-method `{}`: expected cubes, dual or tetrahedra",
                self.mesh_method
            ))
        })?;
        if !(self.mesh_adaptivity.is_finite() && (0.0..=10.0).contains(&self.mesh_adaptivity)) {
            return Err(bad_input(format!(
                "--mesh-adaptivity {}: must be 0 to 10 voxels",
                self.mesh_adaptivity
            )));
        }
        Ok((method, self.mesh_adaptivity))
    }

    /// Whether either flag was changed from its default (refused without --mesh).
    pub fn given(&self) -> bool {
        self.mesh_method != "cubes" || self.mesh_adaptivity != 0.0
    }
}

/// Checks a --mesh path's extension (`.obj` or `.ply`).
pub fn check_mesh_path(path: &Path) -> Result<(), Failure> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("obj") | Some("ply") => Ok(()),
        _ => Err(bad_input(format!("--mesh {}: expected .obj or .ply", path.display()))),
    }
}

/// The iso-surface of `field` on the lattice of spacing `cell` over `region`, by `args`'
/// method, stopping (exit 1) past what `memory_limit` holds.
pub fn extract<F: Field + ?Sized>(
    field: &F,
    region: Aabb,
    cell: f64,
    iso: f64,
    args: &MeshArgs,
    memory_limit: u64,
    path: &Path,
) -> Result<Surface, Failure> {
    let (method, adaptivity) = args.checked()?;
    let job = Extraction::new(region, cell, iso)
        .with_method(method)
        .with_adaptivity(adaptivity);
    volga_mesh::extract_surface_bounded(field, &job, memory_limit / (volga_mesh::BYTES_PER_TRIANGLE + 64)).map_err(
        |e| match e {
            volga_mesh::ExtractError::TooManyTriangles { .. } => failed(format!("--mesh {}: {e}", path.display())),
            e => bad_input(format!("--mesh {}: {e}", path.display())),
        },
    )
}

/// The file's bytes: OBJ or binary PLY by extension, with the normals.
pub fn mesh_bytes(path: &Path, surface: &Surface) -> Vec<u8> {
    if path.extension().and_then(|e| e.to_str()) == Some("ply") {
        volga_mesh::ply_bytes(&surface.mesh, Some(&surface.normals))
    } else {
        volga_mesh::obj_bytes(&surface.mesh, Some(&surface.normals))
    }
}
