//! `volga.Sculpt`: a sculpting session on Bærentzen's dynamic-resolution octree. Tools and
//! operations are the stroke files' (`volga sculpt --strokes`), given as JSON text by the
//! Python layer, validated with errors naming the field.

use std::path::{Path, PathBuf};

use glam::DVec3;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple};
use serde_json::json;
use volga_core::{Aabb, Field};
use volga_scene::strokes::{StartSpec, StrokeSpec};
use volga_sculpt::{SculptFileError, SculptGrid, Stroke};

use crate::arrays;
use crate::errors::{check_memory, os_error, scene_error, value_error};
use crate::grid::VoxelGrid;
use crate::json::to_py;
use crate::threads;

/// Names a stroke in messages (the Python layer's arguments, not a file).
const ORIGIN: &str = "<sculpt>";

/// A sculpt: densities in [0, 1] (½ on the surface) and colours on an octree of
/// `8·2^levels` voxels per axis.
#[pyclass(module = "volga._volga")]
pub struct Sculpt {
    pub inner: volga_sculpt::Sculpt,
}

impl Sculpt {
    /// The box to frame in renders: the content's, or the grid's when empty.
    pub fn bounds(&self) -> Aabb {
        self.inner.content_bounds().unwrap_or_else(|| {
            let g = self.inner.grid();
            g.centres_box(&g.index_box())
        })
    }

    fn stroke(&self, stroke_json: &str) -> PyResult<Stroke> {
        let spec: StrokeSpec = crate::json::parse("stroke", stroke_json)?;
        let strokes = volga_scene::strokes::validate_stroke_list(
            Path::new(ORIGIN),
            "stroke",
            &[spec],
            self.inner.grid().spacing(),
            // Strokes given in code name files the program chose.
            true,
        )
        .map_err(scene_error)?;
        Ok(strokes.into_iter().next().expect("one stroke in, one out"))
    }
}

/// An estimate of the memory of sampling an object on a sculpt of `dims³` voxels: the dense
/// 8³ bricks a surface as large as the grid's box would need (a convex object inside the
/// box has less surface), at 2.2 KB each (densities, one colour, node), plus the fixed
/// process memory. Objects with more surface than their box (folds, many parts) can exceed it.
fn sample_bytes_bound(dims: u64) -> u64 {
    let bricks_per_side = dims.div_ceil(8);
    (24 << 20) + 6 * bricks_per_side * bricks_per_side * 2200
}

fn bytes_error(path: &Path, e: volga_sculpt::FileError) -> PyErr {
    value_error(format!("{}: {e}", path.display()))
}

/// A sculpt file's error as Python's: `ValueError` for bytes that are not a sculpt,
/// `MemoryError` for a file too large, `OSError` otherwise; messages as before the crate
/// read and wrote paths itself ("PATH: …", writes "cannot access PATH: …").
fn file_error(e: SculptFileError) -> PyErr {
    match e {
        SculptFileError::Format { .. } => value_error(e.to_string()),
        SculptFileError::TooLarge { .. } => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
        SculptFileError::Write { path, source } => os_error(format!("cannot access {}: {source}", path.display())),
        SculptFileError::Read { .. } | SculptFileError::NotAFile { .. } => os_error(e.to_string()),
    }
}

#[pymethods]
impl Sculpt {
    /// `Sculpt(start_json)`: a new sculpt from a stroke file's `start` (bounds, voxel size,
    /// object) as JSON text; an object of `null` starts empty.
    #[new]
    #[pyo3(signature = (start_json, memory_limit=None))]
    fn new(py: Python<'_>, start_json: &str, memory_limit: Option<u64>) -> PyResult<Sculpt> {
        let value: serde_json::Value =
            serde_json::from_str(start_json).map_err(|e| value_error(format!("start: {e}")))?;
        if value.get("object").is_some_and(|o| o.is_null()) {
            // An empty sculpt on a grid covering the bounds.
            let bounds: volga_scene::model::BoundsSpec =
                serde_json::from_value(value["bounds"].clone()).map_err(|e| value_error(format!("bounds: {e}")))?;
            let h = value["voxel_size"]
                .as_f64()
                .ok_or_else(|| value_error("voxel_size: expected a number"))?;
            let (min, max) = (DVec3::from_array(bounds.min), DVec3::from_array(bounds.max));
            if !(min.is_finite() && max.is_finite()) || min.cmpge(max).any() {
                return Err(value_error("bounds: min must be finite and below max on every axis"));
            }
            if !(h.is_finite() && h > 0.0) {
                return Err(value_error(format!("voxel_size must be finite and > 0, got {h}")));
            }
            let grid = SculptGrid::covering(&Aabb::new(min, max), h).map_err(|e| value_error(e.to_string()))?;
            if grid.levels() > 11 {
                return Err(value_error(format!(
                    "voxel_size: {} voxels per axis is more than the 16384 a sculpt may have",
                    grid.dims()
                )));
            }
            let colour = value
                .get("colour")
                .and_then(|c| serde_json::from_value::<[f32; 3]>(c.clone()).ok())
                .unwrap_or([0.8, 0.8, 0.8]);
            return Ok(Sculpt {
                inner: volga_sculpt::Sculpt::empty(grid, colour),
            });
        }
        let start: StartSpec = crate::json::parse("start", start_json)?;
        let (min, max) = (DVec3::from_array(start.bounds.min), DVec3::from_array(start.bounds.max));
        if min.is_finite() && max.is_finite() && min.cmplt(max).all() {
            if let Ok(grid) = SculptGrid::covering(&Aabb::new(min, max), start.voxel_size) {
                let d = grid.dims() as u64;
                check_memory(
                    &format!("sampling the object on a {d}³ sculpt"),
                    sample_bytes_bound(d),
                    memory_limit,
                )?;
            }
        }
        let limit = memory_limit
            .or_else(volga_core::memory::available_bytes)
            .unwrap_or(u64::MAX);
        let sculpt = py
            .detach(|| volga_scene::strokes::start_sculpt(Path::new(ORIGIN), &start, limit, true))
            .map_err(scene_error)?;
        Ok(Sculpt { inner: sculpt })
    }

    /// Applies one stroke (stroke-file JSON: `op`, `tool`, `rotation_deg`, `translate`,
    /// `path`) and returns the edit's report: the changed voxels and the world box a
    /// re-render must redo (`None` when nothing changed).
    #[pyo3(signature = (stroke_json, threads=None))]
    fn apply(&mut self, py: Python<'_>, stroke_json: &str, threads: Option<usize>) -> PyResult<Py<PyAny>> {
        let stroke = self.stroke(stroke_json)?;
        let inner = &mut self.inner;
        let report = threads::run(py, threads, move || inner.apply(&stroke))?;
        let value = json!({
            "changed_voxels": report.changed_voxels.map(|b| [b.min.to_array(), b.max.to_array()]),
            "changed_world": report.changed_world.map(|b| [b.min.to_array(), b.max.to_array()]),
        });
        to_py(py, &value)
    }

    /// Undoes the last edit; False when there is none.
    fn undo(&mut self) -> bool {
        self.inner.undo()
    }

    /// Redoes the last undone edit; False when there is none.
    fn redo(&mut self) -> bool {
        self.inner.redo()
    }

    #[getter]
    fn undo_len(&self) -> usize {
        self.inner.undo_len()
    }

    #[getter]
    fn redo_len(&self) -> usize {
        self.inner.redo_len()
    }

    /// The grid: `origin` (voxel [0, 0, 0]'s centre), `voxel_size`, `levels`, `dims`
    /// (voxels per axis), and the tree's node counts and bytes.
    #[getter]
    fn stats(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let g = self.inner.grid();
        let s = self.inner.stats();
        let value = json!({
            "origin": g.origin().to_array(),
            "voxel_size": g.spacing(),
            "levels": g.levels(),
            "dims": g.dims(),
            "nodes": s.nodes(),
            "uniform": s.uniform,
            "bricks": s.bricks,
            "coloured_bricks": s.coloured_bricks,
            "branches": s.branches,
            "bytes": s.bytes,
            "history_bytes": self.inner.history_bytes(),
        });
        to_py(py, &value)
    }

    /// Density (trilinear) at world points (K, 3) → (K,) float64.
    fn value<'py>(&self, py: Python<'py>, points: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let points = arrays::points("points", points)?;
        let inner = &self.inner;
        let v = py.detach(|| points.iter().map(|&p| inner.value(p)).collect::<Vec<f64>>());
        Ok(PyArray1::from_vec(py, v))
    }

    /// The surface as `(vertices, faces)`, extracted on a lattice of `cell_voxels` voxels.
    #[pyo3(signature = (cell_voxels=1.0, threads=None))]
    fn to_mesh<'py>(
        &self,
        py: Python<'py>,
        cell_voxels: f64,
        threads: Option<usize>,
    ) -> PyResult<arrays::MeshArrays<'py>> {
        if !(cell_voxels.is_finite() && cell_voxels >= 0.25) {
            return Err(value_error(format!(
                "cell_voxels must be finite and ≥ 0.25, got {cell_voxels}"
            )));
        }
        let inner = &self.inner;
        let surface =
            threads::run(py, threads, move || inner.surface(cell_voxels))?.map_err(|e| value_error(e.to_string()))?;
        arrays::mesh_arrays(py, surface.mesh)
    }

    /// The densities as a `VoxelGrid` (kind `density`) on the sculpt's grid.
    fn to_grid(&self, py: Python<'_>) -> PyResult<VoxelGrid> {
        let inner = &self.inner;
        let volume = py.detach(|| inner.to_sparse_volume(false));
        let stats = json!({ "active_voxels": volume.active_voxel_count(), "bricks": volume.density.brick_count() });
        Ok(VoxelGrid::new(volume, "sculpt".to_string(), stats))
    }

    /// The sculpt file's bytes (versioned, checksummed; `volga sculpt` reads them).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.to_bytes())
    }

    /// A sculpt from a sculpt file's bytes.
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<Sculpt> {
        volga_sculpt::Sculpt::from_bytes(data)
            .map(|inner| Sculpt { inner })
            .map_err(|e| bytes_error(Path::new("sculpt bytes"), e))
    }

    /// Writes the sculpt file, all or nothing (a temporary file renamed once complete).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let inner = &self.inner;
        py.detach(|| {
            volga_io::check_free_space_for(&[(path.clone(), inner.file_len())]).map_err(crate::errors::io_error)?;
            inner.save(&path).map_err(file_error)
        })
    }

    /// Opens a sculpt file. Only regular files are read, and only when their size fits in
    /// `memory_limit` (default: the machine's available memory).
    #[staticmethod]
    #[pyo3(signature = (path, memory_limit=None))]
    fn open(py: Python<'_>, path: PathBuf, memory_limit: Option<u64>) -> PyResult<Sculpt> {
        let meta = std::fs::metadata(&path).map_err(|e| os_error(format!("{}: {e}", path.display())))?;
        if !meta.is_file() {
            return Err(os_error(format!("{}: not a regular file", path.display())));
        }
        // The tree in memory takes about what the file does; the bytes are held meanwhile.
        check_memory(
            &format!("{}: reading this file", path.display()),
            meta.len().saturating_mul(3),
            memory_limit,
        )?;
        // The memory check above is this method's (`memory_limit`), so no other limit here.
        py.detach(|| volga_sculpt::Sculpt::open_with_limit(&path, u64::MAX))
            .map(|inner| Sculpt { inner })
            .map_err(file_error)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let bytes = PyBytes::new(py, &slf.borrow().inner.to_bytes());
        let restore = py.get_type::<Sculpt>().getattr("from_bytes")?;
        PyTuple::new(py, [restore, PyTuple::new(py, [bytes])?.into_any()])
    }

    fn __repr__(&self) -> String {
        let g = self.inner.grid();
        format!(
            "volga.Sculpt({0}³ voxels of {1}, {2} nodes)",
            g.dims(),
            g.spacing(),
            self.inner.stats().nodes()
        )
    }
}
