//! `volga.Adf`: adaptively sampled distance fields (Frisken et al. 2000) of meshes and
//! shapes, their queries, CSG, meshes and renders. An ADF pickles as the recipe that built
//! it (the build is deterministic, so the copy is the same tree).

use std::path::Path;
use std::sync::Arc;

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use serde_json::json;
use volga_adf::{AdfOptions, CsgOp, MeshSource, ShapeSource};
use volga_core::Aabb;
use volga_scene::model::ShapeSpec;

use crate::arrays;
use crate::errors::{scene_error, value_error};
use crate::json::to_py;
use crate::mesh::Mesh;
use crate::threads;

/// How an ADF was made.
enum Recipe {
    Mesh { mesh: Py<Mesh>, options: Options },
    Shape { json: String, options: Options },
    Csg { op: CsgOp, a: Py<Adf>, b: Py<Adf> },
}

#[derive(Clone, Copy)]
struct Options {
    tolerance: f64,
    max_depth: u8,
    band: f64,
}

impl Options {
    fn check(tolerance: f64, max_depth: u8, band: f64) -> PyResult<Options> {
        if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0) {
            return Err(value_error(format!(
                "tolerance is a fraction of the bounding box's diagonal in (0, 1), got {tolerance}"
            )));
        }
        if max_depth > volga_adf::MAX_SUPPORTED_DEPTH {
            return Err(value_error(format!(
                "max_depth must be at most {}, got {max_depth}",
                volga_adf::MAX_SUPPORTED_DEPTH
            )));
        }
        if !(band.is_finite() && band >= 0.0) {
            return Err(value_error(format!("band must be finite and ≥ 0, got {band}")));
        }
        Ok(Options {
            tolerance,
            max_depth,
            band,
        })
    }

    /// The build options for a source with `bounds` (tolerance and band are fractions of
    /// its diagonal, as `volga adf` takes them).
    fn adf_options(&self, bounds: &Aabb) -> AdfOptions {
        AdfOptions {
            max_depth: self.max_depth,
            band: self.band * bounds.size().length(),
            ..AdfOptions::relative(self.tolerance, bounds)
        }
    }
}

fn adf_error(e: volga_adf::AdfError) -> PyErr {
    match e {
        volga_adf::AdfError::TooManyCells { .. } => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
        e => value_error(e.to_string()),
    }
}

fn op_of(name: &str) -> PyResult<CsgOp> {
    match name {
        "union" => Ok(CsgOp::Union),
        "intersection" => Ok(CsgOp::Intersection),
        "difference" => Ok(CsgOp::Difference),
        _ => Err(value_error(format!(
            "op must be \"union\", \"intersection\" or \"difference\", got \"{name}\""
        ))),
    }
}

fn op_name(op: CsgOp) -> &'static str {
    match op {
        CsgOp::Union => "union",
        CsgOp::Intersection => "intersection",
        CsgOp::Difference => "difference",
    }
}

/// An adaptively sampled distance field: signed distance (negative inside) anywhere in its
/// root cube, within the tolerance of the exact distance near the surface.
#[pyclass(module = "volga._volga", frozen)]
pub struct Adf {
    pub inner: Arc<volga_adf::Adf>,
    recipe: Recipe,
    /// The source's bounds (what renders frame).
    bounds: Aabb,
}

impl Adf {
    pub fn surface_bounds(&self) -> Aabb {
        self.bounds
    }

    fn shape_of(json: &str) -> PyResult<volga_shapes::Shape> {
        let spec: ShapeSpec = crate::json::parse("shape", json)?;
        volga_scene::nodes::shape::shape_from_spec(Path::new("<adf>"), "shape", &spec).map_err(scene_error)
    }
}

#[pymethods]
impl Adf {
    /// Builds the ADF of a mesh: exact distances, signs by the certified winding number
    /// (open and self-intersecting meshes included). `tolerance` and `band` are fractions
    /// of the mesh's bounding-box diagonal.
    #[staticmethod]
    #[pyo3(signature = (mesh, tolerance=1e-3, max_depth=12, band=0.0, threads=None))]
    fn from_mesh(
        py: Python<'_>,
        mesh: Py<Mesh>,
        tolerance: f64,
        max_depth: u8,
        band: f64,
        threads: Option<usize>,
    ) -> PyResult<Adf> {
        let options = Options::check(tolerance, max_depth, band)?;
        let tri = mesh.get().inner.clone();
        let bounds = tri.bounds();
        let adf_options = options.adf_options(&bounds);
        let adf = threads::run(py, threads, move || {
            let source = MeshSource::new(&tri)?;
            volga_adf::Adf::build(&source, adf_options)
        })?
        .map_err(adf_error)?;
        Ok(Adf {
            inner: Arc::new(adf),
            recipe: Recipe::Mesh { mesh, options },
            bounds,
        })
    }

    /// Builds the ADF of an analytic shape given as scene JSON (e.g.
    /// `{"Sphere": {"center": [0, 0, 0], "radius": 1}}`).
    #[staticmethod]
    #[pyo3(signature = (shape_json, tolerance=1e-3, max_depth=12, band=0.0, threads=None))]
    fn from_shape(
        py: Python<'_>,
        shape_json: String,
        tolerance: f64,
        max_depth: u8,
        band: f64,
        threads: Option<usize>,
    ) -> PyResult<Adf> {
        let options = Options::check(tolerance, max_depth, band)?;
        let shape = Adf::shape_of(&shape_json)?;
        let bounds = volga_shapes::SignedDistance::bounds(&shape);
        if !(bounds.min.is_finite() && bounds.max.is_finite()) {
            return Err(value_error(
                "shape: an unbounded shape has no ADF (give a cylinder a half_length, a cone a height)",
            ));
        }
        let adf_options = options.adf_options(&bounds);
        let adf = threads::run(py, threads, move || {
            volga_adf::Adf::build(&ShapeSource(shape), adf_options)
        })?
        .map_err(adf_error)?;
        Ok(Adf {
            inner: Arc::new(adf),
            recipe: Recipe::Shape {
                json: shape_json,
                options,
            },
            bounds,
        })
    }

    /// CSG with another ADF: `"union"`, `"intersection"` or `"difference"` (self minus
    /// other). The other is resampled on this ADF's cells when their root cubes differ.
    #[pyo3(signature = (other, op, threads=None))]
    fn combine(slf: &Bound<'_, Self>, other: &Bound<'_, Adf>, op: &str, threads: Option<usize>) -> PyResult<Adf> {
        let py = slf.py();
        let csg = op_of(op)?;
        let (a, b) = (slf.get().inner.clone(), other.get().inner.clone());
        let result = threads::run(py, threads, move || -> Result<volga_adf::Adf, volga_adf::AdfError> {
            match a.combine(&b, csg) {
                Ok((adf, _)) => Ok(adf),
                Err(volga_adf::AdfError::Mismatched) => {
                    let b_like = a.build_like(&*b)?;
                    a.combine(&b_like, csg).map(|(adf, _)| adf)
                }
                Err(e) => Err(e),
            }
        })?
        .map_err(adf_error)?;
        let (ba, bb) = (slf.get().bounds, other.get().bounds);
        let bounds = match csg {
            CsgOp::Union => Aabb::new(ba.min.min(bb.min), ba.max.max(bb.max)),
            _ => ba,
        };
        Ok(Adf {
            inner: Arc::new(result),
            recipe: Recipe::Csg {
                op: csg,
                a: slf.clone().unbind(),
                b: other.clone().unbind(),
            },
            bounds,
        })
    }

    /// Signed distance (trilinear in the leaf) at world points (K, 3) → (K,) float64.
    #[pyo3(signature = (points, threads=None))]
    fn distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let adf = self.inner.clone();
        let v = arrays::map_points(py, "points", points, threads, move |p| adf.distance(p))?;
        Ok(PyArray1::from_vec(py, v))
    }

    /// Gradient of the distance (the leaf's trilinear derivative) at world points → (K, 3).
    #[pyo3(signature = (points, threads=None))]
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let adf = self.inner.clone();
        let v = arrays::map_points(py, "points", points, threads, move |p| adf.gradient(p))?;
        arrays::vec3_array(py, v)
    }

    /// Closest surface points (one Newton step along the gradient) → (K, 3).
    #[pyo3(signature = (points, threads=None))]
    fn closest_point<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let adf = self.inner.clone();
        let v = arrays::map_points(py, "points", points, threads, move |p| adf.closest_point(p))?;
        arrays::vec3_array(py, v)
    }

    /// Whether each point is inside (distance < 0) → (K,) bool.
    #[pyo3(signature = (points, threads=None))]
    fn inside<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let adf = self.inner.clone();
        let v = arrays::map_points(py, "points", points, threads, move |p| adf.inside(p))?;
        Ok(PyArray1::from_vec(py, v))
    }

    /// The zero iso-surface as `(vertices, faces)` on a lattice of `cell` world units
    /// (default: 1/256 of the source's longest side), or with `on_leaves` on the ADF's own
    /// leaves (its dual grid, no lattice; `cell` must then be left out). `method`: cubes,
    /// dual (lattice only) or tetrahedra; `adaptivity` (0 to 10, in cells, or in the finest
    /// leaf's size on the leaves) merges vertices within that distance of the planes of
    /// the triangles they replace.
    #[pyo3(signature = (cell=None, threads=None, on_leaves=false, method="cubes", adaptivity=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn to_mesh<'py>(
        &self,
        py: Python<'py>,
        cell: Option<f64>,
        threads: Option<usize>,
        on_leaves: bool,
        method: &str,
        adaptivity: f64,
    ) -> PyResult<arrays::MeshArrays<'py>> {
        let method = volga_mesh::ExtractMethod::from_name(method)
            .ok_or_else(|| value_error(format!("method `{method}`: expected cubes, dual or tetrahedra")))?;
        if !(adaptivity.is_finite() && (0.0..=10.0).contains(&adaptivity)) {
            return Err(value_error(format!("adaptivity {adaptivity}: must be 0 to 10")));
        }
        let adf = self.inner.clone();
        if on_leaves {
            if cell.is_some() {
                return Err(value_error(
                    "cell: not used with on_leaves=True (the leaves are the cells)".to_string(),
                ));
            }
            if method == volga_mesh::ExtractMethod::Dual {
                return Err(value_error(
                    "method `dual` does not run on the leaves: use cubes or tetrahedra".to_string(),
                ));
            }
            let finest = adf.cell_size(adf.stats().depth_reached);
            let surface = threads::run(py, threads, move || {
                adf.to_mesh_on_leaves(method, adaptivity * finest, u64::MAX)
            })?
            .map_err(|e| value_error(e.to_string()))?;
            return arrays::mesh_arrays(py, surface.mesh);
        }
        let cell = cell.unwrap_or(self.bounds.size().max_element() / 256.0);
        if !(cell.is_finite() && cell > 0.0) {
            return Err(value_error(format!("cell must be finite and > 0, got {cell}")));
        }
        let side = self.inner.root_box().size().max_element();
        if side / cell > 4096.0 {
            return Err(value_error(format!(
                "cell {cell}: more than 4096 cells along the root cube's side {side}"
            )));
        }
        let job = volga_mesh::Extraction::new(adf.root_box(), cell, 0.0)
            .with_method(method)
            .with_adaptivity(adaptivity);
        let surface = threads::run(py, threads, move || adf.to_mesh_with(&job, u64::MAX))?
            .map_err(|e| value_error(e.to_string()))?;
        arrays::mesh_arrays(py, surface.mesh)
    }

    /// Build statistics: cells, leaves, depth reached, evaluations, bytes, tolerance (world).
    #[getter]
    fn stats(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let s = self.inner.stats();
        let o = self.inner.options();
        let value = json!({
            "cells": s.cells,
            "leaves": s.leaves,
            "pruned_leaves": s.pruned_leaves,
            "max_depth_leaves": s.max_depth_leaves,
            "depth_reached": s.depth_reached,
            "evaluations": s.evaluations,
            "bytes": self.inner.memory_bytes(),
            "tolerance_world": o.tolerance,
            "max_depth": o.max_depth,
        });
        to_py(py, &value)
    }

    /// (2, 3) root cube of the tree.
    #[getter]
    fn root_box<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let b = self.inner.root_box();
        arrays::vec3_array(py, vec![b.min, b.max])
    }

    #[getter]
    fn cell_count(&self) -> usize {
        self.inner.cell_count()
    }

    fn __repr__(&self) -> String {
        format!("volga.Adf({} cells)", self.inner.cell_count())
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let me = slf.get();
        let restore = py.get_type::<Adf>().getattr("_from_recipe")?;
        let recipe = match &me.recipe {
            Recipe::Mesh { mesh, options: o } => PyTuple::new(
                py,
                [
                    "mesh".into_pyobject(py)?.into_any(),
                    mesh.bind(py).clone().into_any(),
                    o.tolerance.into_pyobject(py)?.into_any(),
                    o.max_depth.into_pyobject(py)?.into_any(),
                    o.band.into_pyobject(py)?.into_any(),
                ],
            )?,
            Recipe::Shape { json, options: o } => PyTuple::new(
                py,
                [
                    "shape".into_pyobject(py)?.into_any(),
                    json.into_pyobject(py)?.into_any(),
                    o.tolerance.into_pyobject(py)?.into_any(),
                    o.max_depth.into_pyobject(py)?.into_any(),
                    o.band.into_pyobject(py)?.into_any(),
                ],
            )?,
            Recipe::Csg { op, a, b } => PyTuple::new(
                py,
                [
                    "csg".into_pyobject(py)?.into_any(),
                    op_name(*op).into_pyobject(py)?.into_any(),
                    a.bind(py).clone().into_any(),
                    b.bind(py).clone().into_any(),
                ],
            )?,
        };
        PyTuple::new(py, [restore, PyTuple::new(py, [recipe])?.into_any()])
    }

    /// Rebuilds a pickled ADF from its recipe.
    #[staticmethod]
    fn _from_recipe(py: Python<'_>, recipe: &Bound<'_, PyTuple>) -> PyResult<Adf> {
        let kind: String = recipe.get_item(0)?.extract()?;
        match kind.as_str() {
            "mesh" => Adf::from_mesh(
                py,
                recipe.get_item(1)?.extract()?,
                recipe.get_item(2)?.extract()?,
                recipe.get_item(3)?.extract()?,
                recipe.get_item(4)?.extract()?,
                None,
            ),
            "shape" => Adf::from_shape(
                py,
                recipe.get_item(1)?.extract()?,
                recipe.get_item(2)?.extract()?,
                recipe.get_item(3)?.extract()?,
                recipe.get_item(4)?.extract()?,
                None,
            ),
            "csg" => {
                let op: String = recipe.get_item(1)?.extract()?;
                let a = recipe.get_item(2)?.cast_into::<Adf>()?;
                let b = recipe.get_item(3)?.cast_into::<Adf>()?;
                Adf::combine(&a, &b, &op, None)
            }
            other => Err(value_error(format!("Adf recipe: unknown kind `{other}`"))),
        }
    }
}
