//! `volga.build`: a scene file, or a scene given as a JSON text (the Python layer turns a
//! dict into it with the same field names as RON/JSON scene files), built like `volga build`.

use std::path::PathBuf;

use pyo3::prelude::*;
use volga_core::NoProgress;
use volga_scene::BuildOptions;

use crate::errors::build_error;
use crate::json::report_to_py;
use crate::threads;

/// Builds a scene; returns the build report (the `report.json` the build writes).
/// `scene_json` is a scene given as JSON text, named `path` in messages (relative paths in
/// it are read from `path`'s folder); without it, `path` is the scene file.
#[pyfunction]
#[pyo3(signature = (path, out, scene_json=None, memory_limit=None, threads=None, allow_outside_paths=false))]
pub fn build(
    py: Python<'_>,
    path: PathBuf,
    out: PathBuf,
    scene_json: Option<String>,
    memory_limit: Option<u64>,
    threads: Option<usize>,
    allow_outside_paths: bool,
) -> PyResult<Py<PyAny>> {
    let file = match &scene_json {
        Some(text) => Some(crate::json::parse::<volga_scene::model::SceneFile>("scene", text)?),
        None => None,
    };
    let options = BuildOptions {
        out_dir: out,
        memory_limit,
        stage_start: None,
        allow_outside_paths,
    };
    let report = threads::run(py, threads, move || match &file {
        Some(file) => volga_scene::build_parsed(&path, file, &options, &NoProgress),
        None => volga_scene::build(&path, &options, &NoProgress),
    })?
    .map_err(build_error)?;
    report_to_py(py, &report)
}

/// A scene validated and resolved once (`volga.SceneJob`), baked region by region: every
/// region is bit for bit the same voxels as the whole bake.
#[pyclass(module = "volga._volga", frozen)]
pub struct SceneJob {
    scene: std::sync::Arc<volga_scene::Scene>,
}

#[pymethods]
impl SceneJob {
    /// `SceneJob(path, scene_json=None, memory_limit=None, allow_outside_paths=False)`:
    /// validates the scene and loads the files it names (checked against `memory_limit`).
    #[new]
    #[pyo3(signature = (path, scene_json=None, memory_limit=None, allow_outside_paths=false))]
    fn new(
        py: Python<'_>,
        path: PathBuf,
        scene_json: Option<String>,
        memory_limit: Option<u64>,
        allow_outside_paths: bool,
    ) -> PyResult<SceneJob> {
        let file = match &scene_json {
            Some(text) => Some(crate::json::parse::<volga_scene::model::SceneFile>("scene", text)?),
            None => None,
        };
        let scene = py
            .detach(move || -> Result<volga_scene::Scene, volga_scene::SceneError> {
                let mut scene = match &file {
                    Some(file) => volga_scene::validate(&path, file)?,
                    None => volga_scene::validate_scene(&path)?,
                };
                scene.allow_outside_paths = allow_outside_paths;
                scene.resolve(memory_limit)?;
                Ok(scene)
            })
            .map_err(crate::errors::scene_error)?;
        Ok(SceneJob {
            scene: std::sync::Arc::new(scene),
        })
    }

    /// (nx, ny, nz): the scene grid's voxels along x, y, z.
    #[getter]
    fn shape(&self) -> (u32, u32, u32) {
        let d = self.scene.grid.dims();
        (d.x, d.y, d.z)
    }

    /// (4, 4) float64 transform from the scene grid's index space to world (voxel centres).
    #[getter]
    fn transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        crate::arrays::transform_matrix(py, &self.scene.grid.transform)
    }

    /// The scene's baked density over `region` = `((i0, j0, k0), (i1, j1, k1))` (default:
    /// the whole grid) as a `VoxelGrid` of its own, bit for bit the whole bake's voxels;
    /// memory checked for the region first (`MemoryError`).
    #[pyo3(signature = (region=None, memory_limit=None, threads=None))]
    fn bake(
        &self,
        py: Python<'_>,
        region: Option<&Bound<'_, PyAny>>,
        memory_limit: Option<u64>,
        threads: Option<usize>,
    ) -> PyResult<crate::grid::VoxelGrid> {
        threads::check(threads)?;
        let region = match region {
            Some(r) => crate::voxelize::parse_region(&self.scene.grid, r)?,
            None => self.scene.grid.index_box(),
        };
        let scene = self.scene.clone();
        let volume = threads::run(py, threads, move || {
            volga_scene::bake_region(&scene, &region, false, memory_limit, &NoProgress)
        })?
        .map_err(crate::errors::scene_error)?;
        let stats = serde_json::json!({
            "active_voxels": volume.active_voxel_count(),
            "bricks": volume.density.brick_count(),
            "dense_bricks": volume.density.dense_brick_count(),
        });
        Ok(crate::grid::VoxelGrid::new(volume, "scene bake".to_string(), stats))
    }
}
