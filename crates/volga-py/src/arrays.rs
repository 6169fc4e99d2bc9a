//! numpy arrays in and out. Inputs take any float or integer dtype and any layout
//! (numpy converts once, as `np.asarray(x, dtype=...)` would); shapes and finiteness are
//! checked with errors naming the argument. Outputs hand their `Vec` buffers to numpy
//! without a copy.

use glam::DVec3;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2, PyArrayLikeDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::errors::value_error;

/// The shape of `obj` as numpy sees it, for error messages.
fn shape_of(obj: &Bound<'_, PyAny>) -> String {
    match obj.extract::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>() {
        Ok(a) => format!("{:?}", a.shape()),
        Err(_) => format!(
            "an object of type {}",
            obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ),
    }
}

/// `obj` as a numpy array whose dtype kind is one of `kinds` (numpy's `dtype.kind` letters:
/// `i` signed, `u` unsigned integers, `f` floats), so bools, complex numbers, strings and
/// fractional indices are refused instead of silently cast.
fn numeric<'py>(name: &str, obj: &Bound<'py, PyAny>, kinds: &str, what: &str) -> PyResult<Bound<'py, PyAny>> {
    let array = obj
        .py()
        .import("numpy")?
        .call_method1("asarray", (obj,))
        .map_err(|e| value_error(format!("{name}: expected {what}: {e}")))?;
    let dtype = array.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if !kinds.contains(kind.as_str()) {
        return Err(value_error(format!(
            "{name}: expected {what}, got an array of dtype {dtype}"
        )));
    }
    Ok(array)
}

/// An `(K, 3)` array of finite coordinates as world points.
pub fn points(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<DVec3>> {
    let obj = &numeric(name, obj, "iuf", "real numbers")?;
    let array = obj.extract::<PyArrayLike2<'_, f64, AllowTypeChange>>().map_err(|_| {
        value_error(format!(
            "{name}: expected an array of shape (K, 3) of numbers, got {}",
            shape_of(obj)
        ))
    })?;
    let view = array.as_array();
    if view.ncols() != 3 {
        return Err(value_error(format!(
            "{name}: expected an array of shape (K, 3), got {:?}",
            view.shape()
        )));
    }
    let mut out = Vec::with_capacity(view.nrows());
    for (k, row) in view.rows().into_iter().enumerate() {
        let p = DVec3::new(row[0], row[1], row[2]);
        if !p.is_finite() {
            return Err(value_error(format!(
                "{name}[{k}] is not finite: ({}, {}, {})",
                p.x, p.y, p.z
            )));
        }
        out.push(p);
    }
    Ok(out)
}

/// An `(M, 3)` array of vertex indices below `vertex_count`.
pub fn faces(name: &str, obj: &Bound<'_, PyAny>, vertex_count: usize) -> PyResult<Vec<[u32; 3]>> {
    let obj = &numeric(name, obj, "iu", "integer vertex indices")?;
    let array = obj.extract::<PyArrayLike2<'_, i64, AllowTypeChange>>().map_err(|_| {
        value_error(format!(
            "{name}: expected an integer array of shape (M, 3), got {}",
            shape_of(obj)
        ))
    })?;
    let view = array.as_array();
    if view.ncols() != 3 && view.nrows() > 0 {
        return Err(value_error(format!(
            "{name}: expected an array of shape (M, 3), got {:?}",
            view.shape()
        )));
    }
    let mut out = Vec::with_capacity(view.nrows());
    for (k, row) in view.rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for (c, &i) in row.iter().enumerate() {
            if i < 0 || i as u64 >= vertex_count as u64 {
                return Err(value_error(format!(
                    "{name}[{k}] names vertex {i}, but there are {vertex_count} vertices"
                )));
            }
            t[c] = i as u32;
        }
        out.push(t);
    }
    Ok(out)
}

/// A length-3 vector of finite numbers.
pub fn vec3(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<DVec3> {
    let v: Vec<f64> = obj
        .extract()
        .map_err(|_| value_error(format!("{name}: expected 3 numbers")))?;
    if v.len() != 3 {
        return Err(value_error(format!("{name}: expected 3 numbers, got {}", v.len())));
    }
    let p = DVec3::new(v[0], v[1], v[2]);
    if !p.is_finite() {
        return Err(value_error(format!(
            "{name} is not finite: ({}, {}, {})",
            p.x, p.y, p.z
        )));
    }
    Ok(p)
}

/// `(K, 3)` float64 array owning `data` (no copy).
pub fn vec3_array<'py>(py: Python<'py>, data: Vec<DVec3>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = data.len();
    let flat: Vec<f64> = data.into_iter().flat_map(|p| p.to_array()).collect();
    PyArray1::from_vec(py, flat).reshape([n, 3])
}

/// `(M, 3)` int64 array of triangles.
pub fn faces_array<'py>(py: Python<'py>, triangles: &[[u32; 3]]) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let flat: Vec<i64> = triangles.iter().flat_map(|t| t.map(i64::from)).collect();
    PyArray1::from_vec(py, flat).reshape([triangles.len(), 3])
}

/// `f` of every point of the `(K, 3)` argument `name`, in parallel without the GIL.
pub fn map_points<T: Send>(
    py: Python<'_>,
    name: &str,
    points: &Bound<'_, PyAny>,
    threads: Option<usize>,
    f: impl Fn(DVec3) -> T + Sync + Send,
) -> PyResult<Vec<T>> {
    use rayon::prelude::*;
    let points = self::points(name, points)?;
    crate::threads::run(py, threads, move || points.par_iter().map(|&p| f(p)).collect())
}

/// A mesh as `(vertices (N, 3) float64, faces (M, 3) int64)`.
pub type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

pub fn mesh_arrays(py: Python<'_>, mesh: volga_mesh::TriMesh) -> PyResult<MeshArrays<'_>> {
    Ok((vec3_array(py, mesh.positions)?, faces_array(py, &mesh.triangles)?))
}

/// The (4, 4) float64 homogeneous transform from index space to world space at voxel
/// centres (trimesh's `VoxelGrid.transform`).
pub fn transform_matrix<'py>(py: Python<'py>, t: &volga_core::Transform) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let (o, s) = (t.origin(), t.spacing());
    let m = vec![
        s.x, 0.0, 0.0, o.x, 0.0, s.y, 0.0, o.y, 0.0, 0.0, s.z, o.z, 0.0, 0.0, 0.0, 1.0,
    ];
    numpy::PyArrayMethods::reshape(&numpy::PyArray1::from_vec(py, m), [4, 4])
}
