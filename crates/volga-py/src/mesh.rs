//! `volga.Mesh`, `load_mesh` and the point queries (`signed_distance`, `winding_number`,
//! `inside`).

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use volga_mesh::{MeshQueries, TriMesh};

use crate::arrays;
use crate::errors::{check_memory, mesh_error, value_error};
use crate::threads;

/// A triangle mesh: `vertices` (N, 3) float64 world positions and `faces` (M, 3) int64
/// vertex indices. Immutable; queries build their acceleration structures once and keep them.
#[pyclass(module = "volga._volga", frozen)]
pub struct Mesh {
    pub inner: Arc<TriMesh>,
    queries: OnceLock<Arc<MeshQueries>>,
}

impl Mesh {
    pub fn from_tri_mesh(mesh: TriMesh) -> Mesh {
        Mesh {
            inner: Arc::new(mesh),
            queries: OnceLock::new(),
        }
    }

    /// The point-query structures, built on first use (without the GIL).
    pub fn queries(&self, py: Python<'_>) -> Arc<MeshQueries> {
        if let Some(q) = self.queries.get() {
            return q.clone();
        }
        let mesh = self.inner.clone();
        let built = py.detach(move || Arc::new(MeshQueries::new(&mesh)));
        self.queries.get_or_init(|| built).clone()
    }
}

#[pymethods]
impl Mesh {
    /// `Mesh(vertices, faces)`: vertices (N, 3) of any float/int dtype, faces (M, 3) of any
    /// integer dtype, both in any memory layout.
    #[new]
    fn new(vertices: &Bound<'_, PyAny>, faces: &Bound<'_, PyAny>) -> PyResult<Mesh> {
        let positions = arrays::points("vertices", vertices)?;
        let triangles = arrays::faces("faces", faces, positions.len())?;
        let mesh = TriMesh::new(positions, triangles).map_err(|e| value_error(format!("mesh: {e}")))?;
        Ok(Mesh::from_tri_mesh(mesh))
    }

    /// (N, 3) float64 vertex positions (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        arrays::vec3_array(py, self.inner.positions.clone())
    }

    /// (M, 3) int64 vertex indices (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        arrays::faces_array(py, &self.inner.triangles)
    }

    /// (2, 3) float64: the bounding box's min and max corners.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let b = self.inner.bounds();
        arrays::vec3_array(py, vec![b.min, b.max])
    }

    /// Edges used by exactly one triangle (0 for a closed mesh).
    #[getter]
    fn boundary_edges(&self) -> usize {
        self.inner.boundary_edge_count()
    }

    /// Whether every edge is used by exactly two triangles.
    #[getter]
    fn is_closed(&self) -> bool {
        self.inner.is_closed()
    }

    fn __len__(&self) -> usize {
        self.inner.triangles.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "volga.Mesh({} vertices, {} faces, {})",
            self.inner.positions.len(),
            self.inner.triangles.len(),
            if self.inner.is_closed() { "closed" } else { "open" }
        )
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let me = slf.get();
        let cls = py.get_type::<Mesh>();
        let args = PyTuple::new(
            py,
            [
                arrays::vec3_array(py, me.inner.positions.clone())?.into_any(),
                arrays::faces_array(py, &me.inner.triangles)?.into_any(),
            ],
        )?;
        PyTuple::new(py, [cls.into_any(), args.into_any()])
    }
}

/// Reads an OBJ, glTF or GLB mesh. The file's size is checked first: parsing it must fit in
/// `memory_limit` bytes (default: the machine's available memory).
#[pyfunction]
#[pyo3(signature = (path, memory_limit=None))]
pub fn load_mesh(py: Python<'_>, path: PathBuf, memory_limit: Option<u64>) -> PyResult<Mesh> {
    if let Ok(meta) = std::fs::metadata(&path) {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let bound = volga_voxelize::parse_bytes_bound(meta.len(), &ext);
        check_memory(&format!("{}: reading this file", path.display()), bound, memory_limit)?;
    }
    let mesh = py.detach(|| volga_mesh::load_mesh(&path)).map_err(mesh_error)?;
    Ok(Mesh::from_tri_mesh(mesh))
}

/// Signed distances (negative inside), exact magnitude, certified sign.
#[pyfunction]
#[pyo3(signature = (mesh, points, threads=None))]
pub fn signed_distance<'py>(
    py: Python<'py>,
    mesh: &Mesh,
    points: &Bound<'py, PyAny>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let points = arrays::points("points", points)?;
    threads::check(threads)?;
    let queries = mesh.queries(py);
    let d = threads::run(py, threads, move || queries.signed_distances(&points))?;
    Ok(PyArray1::from_vec(py, d))
}

/// Generalized winding numbers: within `tolerance` of the exact sum (certified), or with
/// `tolerance=None` the fast far-field approximation (not certified).
#[pyfunction]
#[pyo3(signature = (mesh, points, tolerance=None, threads=None))]
pub fn winding_number<'py>(
    py: Python<'py>,
    mesh: &Mesh,
    points: &Bound<'py, PyAny>,
    tolerance: Option<f64>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    if let Some(t) = tolerance {
        if !(t.is_finite() && t >= 0.0) {
            return Err(value_error(format!(
                "tolerance must be finite and ≥ 0 (or None), got {t}"
            )));
        }
    }
    let points = arrays::points("points", points)?;
    threads::check(threads)?;
    let queries = mesh.queries(py);
    let w = threads::run(py, threads, move || match tolerance {
        Some(t) => queries.winding_numbers(&points, t),
        None => queries.fast_winding_numbers(&points),
    })?;
    Ok(PyArray1::from_vec(py, w))
}

/// Whether each point's winding number is ≥ ½, proven.
#[pyfunction]
#[pyo3(signature = (mesh, points, threads=None))]
pub fn inside<'py>(
    py: Python<'py>,
    mesh: &Mesh,
    points: &Bound<'py, PyAny>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let points = arrays::points("points", points)?;
    threads::check(threads)?;
    let queries = mesh.queries(py);
    let w = threads::run(py, threads, move || queries.insides(&points))?;
    Ok(PyArray1::from_vec(py, w))
}
