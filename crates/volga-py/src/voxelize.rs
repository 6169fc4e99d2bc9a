//! `volga.voxelize` and `volga.VoxelJob`: a mesh voxelization's options checked into a
//! job and its grid, run whole or region by region (each region bit for bit the whole
//! grid's voxels).

use std::sync::{Arc, OnceLock};

use glam::{DVec3, IVec3};
use numpy::PyArray2;
use pyo3::prelude::*;
use serde_json::{json, Value};
use volga_core::{Grid, IndexBox, NoProgress, SparseVolume, Transform};
use volga_mesh::TriMesh;
use volga_voxelize::{MeshJob, MeshJobMode, MeshVoxelizer, Separability, SurfaceMode};

use crate::arrays;
use crate::errors::{check_memory, value_error};
use crate::grid::{Kind, VoxelGrid};
use crate::mesh::Mesh;
use crate::threads;

/// The grid of a voxelization: `resolution` voxels along the longest side of `bounds` (or
/// of the mesh's box), or voxels of side `pitch`; without `bounds` the mesh's box is padded
/// by the band plus one voxel as `volga voxelize` does (the same grid for the same
/// resolution), with `bounds` the grid covers exactly that box (voxel centres at
/// `lo + pitch/2 + ijk·pitch`).
fn layout(
    job: &MeshJob,
    mesh_bounds: &volga_core::Aabb,
    resolution: Option<u32>,
    pitch: Option<f64>,
    bounds: Option<(DVec3, DVec3)>,
) -> PyResult<Grid> {
    let job_error = |e: volga_voxelize::JobError| match (e.field, pitch) {
        ("mesh", _) => value_error(format!("mesh: {e}")),
        (_, Some(h)) => value_error(
            e.message
                .replace(&format!("--resolution {}", job.resolution), &format!("pitch {h}")),
        ),
        (_, None) => value_error(e.message.replace("--resolution", "resolution")),
    };
    match bounds {
        None => match (resolution, pitch) {
            (Some(_), None) => job.layout(mesh_bounds).map_err(job_error),
            (None, Some(h)) => job.layout_with_spacing(mesh_bounds, h).map_err(job_error),
            _ => unreachable!("checked by the caller"),
        },
        Some((lo, hi)) => {
            let size = hi - lo;
            let h = match (resolution, pitch) {
                (Some(n), None) => size.max_element() / n as f64,
                (None, Some(h)) => h,
                _ => unreachable!("checked by the caller"),
            };
            let dims = (size / h).ceil().max(DVec3::ONE);
            if dims.max_element() > (i32::MAX / 2) as f64 {
                return Err(value_error(format!(
                    "bounds: {:.0}×{:.0}×{:.0} voxels is more than a grid can hold",
                    dims.x, dims.y, dims.z
                )));
            }
            let transform = Transform::new(lo + DVec3::splat(0.5 * h), DVec3::splat(h))
                .map_err(|e| value_error(format!("bounds: {e}")))?;
            Grid::new(transform, dims.as_uvec3()).map_err(|e| value_error(format!("bounds: {e}")))
        }
    }
}

/// A mesh voxelization's options, checked: the job and its grid (`volga voxelize`'s
/// layout, or exactly `bounds`).
#[allow(clippy::too_many_arguments)]
fn plan_job(
    mesh: &Mesh,
    resolution: Option<i64>,
    pitch: Option<f64>,
    bounds: Option<&Bound<'_, PyAny>>,
    mode: &str,
    separability: Option<u32>,
    band: Option<f64>,
    thickness: Option<f64>,
    solid: Option<bool>,
    signed: Option<bool>,
) -> PyResult<(MeshJob, Grid)> {
    let resolution = match resolution {
        None => None,
        Some(n) if (1..=65536).contains(&n) => Some(n as u32),
        Some(n) => return Err(value_error(format!("resolution must lie in 1..=65536, got {n}"))),
    };
    match (resolution, pitch) {
        (Some(_), Some(_)) => return Err(value_error("give resolution or pitch, not both")),
        (None, None) => {
            return Err(value_error(
                "give resolution (voxels along the longest side) or pitch (voxel size)",
            ))
        }
        (None, Some(h)) if !(h.is_finite() && h > 0.0) => {
            return Err(value_error(format!("pitch must be finite and > 0, got {h}")))
        }
        _ => {}
    }
    let bounds = match bounds {
        None => None,
        Some(b) => {
            let corners = arrays::points("bounds", b)?;
            if corners.len() != 2 || corners[0].cmpge(corners[1]).any() {
                return Err(value_error(
                    "bounds: expected ((xmin, ymin, zmin), (xmax, ymax, zmax)) with min < max on every axis",
                ));
            }
            Some((corners[0], corners[1]))
        }
    };
    // Options a mode would ignore are refused, as `volga voxelize` refuses its flags.
    let given: [(&str, bool); 5] = [
        ("separability", separability.is_some()),
        ("band", band.is_some()),
        ("thickness", thickness.is_some()),
        ("solid", solid.is_some()),
        ("signed", signed.is_some()),
    ];
    let allowed: &[&str] = match mode {
        "surface" | "solid" => &["separability"],
        "anti_aliased" if solid == Some(true) => &["solid"],
        "anti_aliased" => &["thickness", "solid"],
        "distance" => &["band", "signed"],
        other => {
            return Err(value_error(format!(
                "mode must be \"surface\", \"solid\", \"anti_aliased\" or \"distance\", got \"{other}\""
            )))
        }
    };
    if let Some((name, _)) = given.iter().find(|(name, set)| *set && !allowed.contains(name)) {
        return Err(value_error(format!(
            "{name} does not apply to mode=\"{mode}\"{}",
            match (*name, mode) {
                ("solid", "surface") => " (use mode=\"solid\")",
                ("thickness", "anti_aliased") => " with solid=True (a solid has no thickness)",
                _ => "",
            }
        )));
    }
    let separability = separability.unwrap_or(26);
    let separability_of = || {
        Separability::from_number(separability)
            .ok_or_else(|| value_error(format!("separability must be 6, 18 or 26, got {separability}")))
    };
    let job_mode = match mode {
        "surface" | "solid" => MeshJobMode::Binary {
            separability: separability_of()?,
            solid: mode == "solid",
        },
        "anti_aliased" => {
            let thickness = thickness.unwrap_or(1.0);
            if !(thickness.is_finite() && thickness > 0.0) {
                return Err(value_error(format!(
                    "thickness must be finite and > 0, got {thickness}"
                )));
            }
            MeshJobMode::AntiAliased {
                thickness_voxels: thickness,
                solid: solid.unwrap_or(false),
            }
        }
        _ => {
            let band = band.unwrap_or(3.0);
            if !(band.is_finite() && band > 0.0 && band <= 1000.0) {
                return Err(value_error(format!("band must lie in (0, 1000] voxels, got {band}")));
            }
            MeshJobMode::Distance {
                half_width_voxels: band,
                signed: signed.unwrap_or(true),
            }
        }
    };
    let mesh_bounds = mesh.inner.bounds();
    let job = MeshJob {
        resolution: resolution.unwrap_or(1),
        mode: job_mode,
    };
    let grid = layout(&job, &mesh_bounds, resolution, pitch, bounds)?;
    Ok((job, grid))
}

/// `(lo, hi)` voxel indices as a region of `grid` (`0 ≤ lo < hi ≤ shape`).
pub fn parse_region(grid: &Grid, region: &Bound<'_, PyAny>) -> PyResult<IndexBox> {
    let bad = || {
        let d = grid.dims();
        value_error(format!(
            "region: expected ((i0, j0, k0), (i1, j1, k1)) voxel indices with 0 ≤ lo < hi ≤ shape ({}, {}, {})",
            d.x, d.y, d.z
        ))
    };
    let (lo, hi): (Vec<i64>, Vec<i64>) = region.extract().map_err(|_| bad())?;
    if lo.len() != 3 || hi.len() != 3 {
        return Err(bad());
    }
    let fits = |v: i64| i32::try_from(v).map_err(|_| bad());
    let b = IndexBox::new(
        IVec3::new(fits(lo[0])?, fits(lo[1])?, fits(lo[2])?),
        IVec3::new(fits(hi[0])?, fits(hi[1])?, fits(hi[2])?),
    );
    grid.window(&b).map_err(|e| value_error(e.to_string()))?;
    Ok(b)
}

/// The statistics of a run, as `VoxelGrid.stats`.
fn run_stats(
    job: &MeshJob,
    mesh: &TriMesh,
    volume: &SparseVolume,
    run_boundary: Option<usize>,
    peak: u64,
    sign: Option<volga_voxelize::SignStats>,
) -> Value {
    let boundary_edges = run_boundary.unwrap_or_else(|| mesh.boundary_edge_count());
    json!({
        "mode": job.mode_name(),
        "triangles": mesh.triangles.len(),
        "boundary_edges": boundary_edges,
        "closed": boundary_edges == 0,
        "active_voxels": volume.active_voxel_count(),
        "bricks": volume.density.brick_count(),
        "dense_bricks": volume.density.dense_brick_count(),
        "estimated_memory_bytes": peak,
        "sign": sign.map(|s| serde_json::to_value(s).unwrap_or(Value::Null)),
    })
}

/// Voxelizes a mesh (see the Python docstring in `volga/__init__.py`).
#[pyfunction]
#[pyo3(signature = (mesh, resolution=None, pitch=None, bounds=None, mode="surface", separability=None, band=None, thickness=None, solid=None, signed=None, memory_limit=None, threads=None, region=None))]
#[allow(clippy::too_many_arguments)]
pub fn voxelize(
    py: Python<'_>,
    mesh: &Mesh,
    resolution: Option<i64>,
    pitch: Option<f64>,
    bounds: Option<&Bound<'_, PyAny>>,
    mode: &str,
    separability: Option<u32>,
    band: Option<f64>,
    thickness: Option<f64>,
    solid: Option<bool>,
    signed: Option<bool>,
    memory_limit: Option<u64>,
    threads: Option<usize>,
    region: Option<&Bound<'_, PyAny>>,
) -> PyResult<VoxelGrid> {
    threads::check(threads)?;
    let (job, grid) = plan_job(
        mesh,
        resolution,
        pitch,
        bounds,
        mode,
        separability,
        band,
        thickness,
        solid,
        signed,
    )?;
    let region = region.map(|r| parse_region(&grid, r)).transpose()?;
    let job_handle = VoxelJob::with(mesh.inner.clone(), job, grid);
    job_handle.run(py, region, memory_limit, threads)
}

/// A mesh voxelization planned once and run region by region (`volga.VoxelJob`): the
/// grid is fixed at construction, the mesh is prepared (BVH, feature regions, sign
/// oracle) on first use and kept, and every region is bit for bit the same voxels of the
/// whole-grid result.
#[pyclass(module = "volga._volga", frozen)]
pub struct VoxelJob {
    mesh: Arc<TriMesh>,
    job: MeshJob,
    grid: Grid,
    voxelizer: OnceLock<Option<Arc<MeshVoxelizer>>>,
}

impl VoxelJob {
    fn with(mesh: Arc<TriMesh>, job: MeshJob, grid: Grid) -> VoxelJob {
        VoxelJob {
            mesh,
            job,
            grid,
            voxelizer: OnceLock::new(),
        }
    }

    fn surface_mode(&self) -> SurfaceMode {
        match self.job.mode {
            MeshJobMode::Distance {
                half_width_voxels,
                signed,
            } => SurfaceMode::Distance {
                half_width_voxels,
                signed,
            },
            MeshJobMode::Binary { separability, .. } => SurfaceMode::Binary(separability),
            MeshJobMode::AntiAliased { solid: true, .. } => SurfaceMode::Solid,
            MeshJobMode::AntiAliased { thickness_voxels, .. } => SurfaceMode::Shell {
                thickness: thickness_voxels * self.grid.transform.spacing().x,
            },
        }
    }

    /// The prepared mesh, built once (on the pool for `threads`, without the GIL).
    fn prepared(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<Option<Arc<MeshVoxelizer>>> {
        if let Some(v) = self.voxelizer.get() {
            return Ok(v.clone());
        }
        let (job, mesh) = (self.job, self.mesh.clone());
        let built = threads::run(py, threads, move || job.voxelizer(&mesh).map(Arc::new))?;
        Ok(self.voxelizer.get_or_init(|| built).clone())
    }

    fn run(
        &self,
        py: Python<'_>,
        region: Option<IndexBox>,
        memory_limit: Option<u64>,
        threads: Option<usize>,
    ) -> PyResult<VoxelGrid> {
        let d = self.grid.dims();
        let estimate = match &region {
            None => self.job.estimate(&self.mesh, &self.grid),
            Some(r) => self.job.estimate_region(&self.mesh, &self.grid, r),
        };
        let what = match &region {
            None => format!("voxelizing on a {}×{}×{} grid", d.x, d.y, d.z),
            Some(r) => {
                let s = r.max - r.min;
                format!(
                    "voxelizing a {}×{}×{} region of a {}×{}×{} grid",
                    s.x, s.y, s.z, d.x, d.y, d.z
                )
            }
        };
        check_memory(&what, estimate.peak_bytes, memory_limit)?;
        let voxelizer = self.prepared(py, threads)?;
        let (job, grid, mesh) = (self.job, self.grid, self.mesh.clone());
        let run = threads::run(py, threads, move || match region {
            None => Ok(job.run_with_voxelizer(&mesh, voxelizer.as_deref(), &grid, &NoProgress)),
            Some(r) => job.run_region(&mesh, voxelizer.as_deref(), &grid, &r, &NoProgress),
        })?
        .map_err(|e| value_error(e.to_string()))?;
        let stats = run_stats(
            &self.job,
            &self.mesh,
            &run.volume,
            run.boundary_edges,
            estimate.peak_bytes,
            run.sign,
        );
        Ok(VoxelGrid::new(run.volume, self.job.mode_name(), stats))
    }
}

#[pymethods]
impl VoxelJob {
    /// `VoxelJob(mesh, resolution=None, pitch=None, bounds=None, mode="surface", ...)`:
    /// the options of `volga.voxelize`, checked; the grid is laid out at once.
    #[new]
    #[pyo3(signature = (mesh, resolution=None, pitch=None, bounds=None, mode="surface", separability=None, band=None, thickness=None, solid=None, signed=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        mesh: &Mesh,
        resolution: Option<i64>,
        pitch: Option<f64>,
        bounds: Option<&Bound<'_, PyAny>>,
        mode: &str,
        separability: Option<u32>,
        band: Option<f64>,
        thickness: Option<f64>,
        solid: Option<bool>,
        signed: Option<bool>,
    ) -> PyResult<VoxelJob> {
        let (job, grid) = plan_job(
            mesh,
            resolution,
            pitch,
            bounds,
            mode,
            separability,
            band,
            thickness,
            solid,
            signed,
        )?;
        Ok(VoxelJob::with(mesh.inner.clone(), job, grid))
    }

    /// (nx, ny, nz): the whole grid's voxels along x, y, z.
    #[getter]
    fn shape(&self) -> (u32, u32, u32) {
        let d = self.grid.dims();
        (d.x, d.y, d.z)
    }

    /// (4, 4) float64 transform from the whole grid's index space to world (voxel centres).
    #[getter]
    fn transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        arrays::transform_matrix(py, &self.grid.transform)
    }

    /// Voxel edge length (world units).
    #[getter]
    fn pitch(&self) -> f64 {
        self.grid.transform.spacing().x
    }

    /// The job's description, as `VoxelGrid.mode`.
    #[getter]
    fn mode(&self) -> String {
        self.job.mode_name()
    }

    /// `"binary"`, `"density"` or `"distance"`: what every region's values are.
    #[getter]
    fn kind(&self) -> &'static str {
        match self.job.mode {
            MeshJobMode::Binary { .. } => Kind::Binary.name(),
            MeshJobMode::AntiAliased { .. } => Kind::Density.name(),
            MeshJobMode::Distance { .. } => Kind::Distance.name(),
        }
    }

    /// The value of voxels no surface reaches outside the mesh (0, or the band for
    /// distances).
    #[getter]
    fn background(&self) -> f32 {
        self.surface_mode().background(&self.grid)
    }

    /// Triangles of the mesh.
    #[getter]
    fn triangles(&self) -> usize {
        self.mesh.triangles.len()
    }

    /// An upper bound (bytes) on the peak memory of voxelizing `region` (default: the
    /// whole grid), as `volga voxelize` checks it; the mesh's prepared data included.
    #[pyo3(signature = (region=None))]
    fn estimate(&self, region: Option<&Bound<'_, PyAny>>) -> PyResult<u64> {
        Ok(match region {
            None => self.job.estimate(&self.mesh, &self.grid).peak_bytes,
            Some(r) => {
                let r = parse_region(&self.grid, r)?;
                self.job.estimate_region(&self.mesh, &self.grid, &r).peak_bytes
            }
        })
    }

    /// Prepares the mesh now (otherwise the first `run` does).
    #[pyo3(signature = (threads=None))]
    fn prepare(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<()> {
        self.prepared(py, threads).map(|_| ())
    }

    /// The voxels of `region` = `((i0, j0, k0), (i1, j1, k1))` (default: the whole grid)
    /// as a `VoxelGrid` of their own (its transform places voxel [0, 0, 0] at the
    /// region's first voxel), bit for bit as in the whole grid. Refused with
    /// `MemoryError` over `memory_limit`.
    #[pyo3(signature = (region=None, memory_limit=None, threads=None))]
    fn run_region(
        &self,
        py: Python<'_>,
        region: Option<&Bound<'_, PyAny>>,
        memory_limit: Option<u64>,
        threads: Option<usize>,
    ) -> PyResult<VoxelGrid> {
        threads::check(threads)?;
        let region = region.map(|r| parse_region(&self.grid, r)).transpose()?;
        self.run(py, region, memory_limit, threads)
    }
}
