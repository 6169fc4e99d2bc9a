//! # volga-py — the `volga` Python package's native module (`volga._volga`)
//!
//! Thin bindings over the kernel's public API, built by maturin (PyO3, abi3, the `numpy`
//! crate). The pure-Python layer (`python/volga/`) normalises arguments (meshes given as
//! objects with `.vertices`/`.faces`, dict scenes and tools) and documents every function;
//! this module does the work:
//!
//! * arrays come in as any float or integer dtype and any memory layout (converted once,
//!   checked for shape and finiteness, errors naming the argument);
//! * every heavy call releases the GIL and runs on a rayon pool of the requested size
//!   (`threads=`), whose results are identical for any thread count;
//! * errors are `ValueError` (bad input, naming the argument or field path), `MemoryError`
//!   (a refused allocation, naming the size needed and the limit) or `OSError` (files), with
//!   the CLI's messages;
//! * large results are handed to numpy without a copy (`Vec` buffers become arrays).
//!
//! Coordinates: world space is `f64` (`world_*`), voxel indices `ijk` are `[i, j, k]`
//! along x, y, z as in trimesh's `VoxelGrid.matrix`; voxel payloads are `f32`.

use pyo3::prelude::*;

mod adf;
mod arrays;
mod errors;
mod grid;
mod json;
mod mesh;
mod render;
mod scene;
mod sculpt;
mod threads;
mod validate;
mod voxelize;

#[pymodule]
fn _volga(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<mesh::Mesh>()?;
    m.add_class::<grid::VoxelGrid>()?;
    m.add_class::<voxelize::VoxelJob>()?;
    m.add_class::<scene::SceneJob>()?;
    m.add_class::<sculpt::Sculpt>()?;
    m.add_class::<adf::Adf>()?;
    m.add_function(wrap_pyfunction!(mesh::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::signed_distance, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::winding_number, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::inside, m)?)?;
    m.add_function(wrap_pyfunction!(voxelize::voxelize, m)?)?;
    m.add_function(wrap_pyfunction!(grid::extract_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(grid::load_volume, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    m.add_function(wrap_pyfunction!(scene::build, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(threads::default_threads, m)?)?;
    Ok(())
}
