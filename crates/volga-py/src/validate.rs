//! `volga.validate`: the validator's verdict on a grid or a numpy array, the same JSON as
//! `volga validate --json`.

use glam::{DVec3, IVec3, UVec3};
use numpy::{AllowTypeChange, PyArrayLikeDyn};
use pyo3::prelude::*;
use volga_core::Transform;
use volga_topology::{verdict, Connectivity, Requirement, VerdictError, VerdictInput, VoxelSet};

use crate::errors::value_error;
use crate::grid::{Kind, VoxelGrid};
use crate::json::report_to_py;
use crate::mesh::Mesh;
use crate::threads;

/// The index→world transform of a (4, 4) matrix that scales and translates only.
fn transform_of(obj: &Bound<'_, PyAny>) -> PyResult<Transform> {
    let m: Vec<Vec<f64>> = obj
        .call_method0("tolist")
        .and_then(|l| l.extract())
        .or_else(|_| obj.extract())
        .map_err(|_| value_error("transform: expected a (4, 4) matrix"))?;
    if m.len() != 4 || m.iter().any(|r| r.len() != 4) {
        return Err(value_error("transform: expected a (4, 4) matrix"));
    }
    for (r, row) in m.iter().enumerate().take(3) {
        for (c, &v) in row.iter().enumerate().take(3) {
            if r != c && v != 0.0 {
                return Err(value_error(format!(
                    "transform: only scale and translation are supported (entry [{r}, {c}] is {v})"
                )));
            }
        }
    }
    if m[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(value_error("transform: the last row must be (0, 0, 0, 1)"));
    }
    Transform::new(
        DVec3::new(m[0][3], m[1][3], m[2][3]),
        DVec3::new(m[0][0], m[1][1], m[2][2]),
    )
    .map_err(|e| value_error(format!("transform: {e}")))
}

/// The black voxels of an `[i, j, k]` array: nonzero (bool) or ≥ 0.5 (numbers).
fn set_of_array(obj: &Bound<'_, PyAny>) -> PyResult<(VoxelSet, &'static str)> {
    let array = obj
        .extract::<PyArrayLikeDyn<'_, f32, AllowTypeChange>>()
        .map_err(|_| value_error("grid: expected a volga.VoxelGrid or a 3-D array"))?;
    let view = array.as_array();
    if view.ndim() != 3 {
        return Err(value_error(format!(
            "grid: expected a 3-D array indexed [i, j, k], got shape {:?}",
            view.shape()
        )));
    }
    let s = view.shape();
    if s.iter().any(|&n| n == 0 || n > (i32::MAX / 2) as usize) {
        return Err(value_error(format!("grid: cannot validate an array of shape {s:?}")));
    }
    let dims = UVec3::new(s[0] as u32, s[1] as u32, s[2] as u32);
    let mut binary = true;
    let mut black = Vec::new();
    for ((i, j, k), &v) in view
        .into_dimensionality::<numpy::ndarray::Ix3>()
        .map_err(|e| value_error(format!("grid: {e}")))?
        .indexed_iter()
    {
        if !v.is_finite() {
            return Err(value_error(format!("grid[{i}, {j}, {k}] is not finite: {v}")));
        }
        if v != 0.0 && v != 1.0 {
            binary = false;
        }
        if v >= 0.5 {
            black.push(IVec3::new(i as i32, j as i32, k as i32));
        }
    }
    let set = VoxelSet::from_voxels(dims, black).map_err(|e| value_error(format!("grid: {e}")))?;
    Ok((set, if binary { "occupancy" } else { "density" }))
}

/// Validates a grid or an array (see the Python docstring in `volga/__init__.py`).
#[pyfunction]
#[pyo3(signature = (grid, connectivity=26, mesh=None, require=vec!["separating".to_string()], transform=None, pad=false, listed=32, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn validate(
    py: Python<'_>,
    grid: &Bound<'_, PyAny>,
    connectivity: u32,
    mesh: Option<&Mesh>,
    require: Vec<String>,
    transform: Option<&Bound<'_, PyAny>>,
    pad: bool,
    listed: usize,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    let n = Connectivity::from_number(connectivity)
        .ok_or_else(|| value_error(format!("connectivity must be 6, 18 or 26, got {connectivity}")))?;
    let requirements = require
        .iter()
        .map(|r| {
            r.parse::<Requirement>()
                .map_err(|e| value_error(format!("require: {e}")))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let (set, values, grid_transform, format) = if let Ok(g) = grid.cast::<VoxelGrid>() {
        let g = g.get();
        if g.kind == Kind::Distance {
            return Err(value_error(format!(
                "grid: the grid holds distances, not occupancy (background {}): validate checks binary models; \
                 voxelize with mode=\"surface\" or \"solid\", or threshold the field yourself (black = distance ≤ 0)",
                g.volume.density.background()
            )));
        }
        let set = VoxelSet::from_sparse(&g.volume, 0.5).map_err(|e| value_error(format!("grid: {e}")))?;
        let values = if g.kind == Kind::Binary { "occupancy" } else { "density" };
        (set, values, g.volume.grid.transform, "grid")
    } else {
        let (set, values) = set_of_array(grid)?;
        let t = Transform::new(DVec3::ZERO, DVec3::ONE).expect("the unit transform is valid");
        (set, values, t, "array")
    };
    let transform = match transform {
        Some(t) => transform_of(t)?,
        None => grid_transform,
    };
    let mesh = mesh.map(|m| m.inner.clone());
    let result = threads::run(py, threads, move || {
        verdict(VerdictInput {
            model: None,
            format,
            values,
            set,
            transform,
            connectivity: n,
            mesh: mesh.as_deref().map(|m| (m, None)),
            requirements: &requirements,
            pad,
            listed,
        })
    })?
    .map_err(|e| match e {
        VerdictError::CoverNeedsMesh => value_error("require: cover needs a reference surface: pass mesh="),
        e => value_error(e.to_string()),
    })?;
    report_to_py(py, &result)
}
