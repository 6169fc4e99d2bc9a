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
