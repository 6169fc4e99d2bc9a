//! `volga.VoxelGrid` (a sparse volume with its kind), `voxelize`, `extract_mesh` and
//! `load_volume`.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use glam::{DVec3, IVec3, UVec3};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple};
use serde_json::{json, Value};
use volga_core::{
    Brick, ChannelKind, Field, Filter, Grid, IndexBox, NoProgress, Sampled, SparseVolume, Transform, BRICK_VOXELS,
};
use volga_mesh::TriMesh;
use volga_voxelize::{MeshJob, MeshJobMode, MeshVoxelizer, Separability, SurfaceMode};

use crate::arrays;
use crate::errors::{check_memory, io_error, value_error};
use crate::json::to_py;
use crate::mesh::Mesh;
use crate::threads;

/// What a grid's values are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// 0 or 1 (`matrix` is bool).
    Binary,
    /// Anti-aliased density in [0, 1], ½ on the surface.
    Density,
    /// Signed distance in world units (negative inside), clamped to ± the background.
    Distance,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Binary => "binary",
            Kind::Density => "density",
            Kind::Distance => "distance",
        }
    }

    fn parse(s: &str) -> PyResult<Kind> {
        match s {
            "binary" => Ok(Kind::Binary),
            "density" => Ok(Kind::Density),
            "distance" => Ok(Kind::Distance),
            _ => Err(value_error(format!("unknown grid kind `{s}`"))),
        }
    }

    pub fn of(volume: &SparseVolume) -> Kind {
        match volume.density_kind {
            ChannelKind::Binary => Kind::Binary,
            ChannelKind::SignedDistance => Kind::Distance,
            _ => Kind::Density,
        }
    }

    fn channel(self) -> ChannelKind {
        match self {
            Kind::Binary => ChannelKind::Binary,
            Kind::Density => ChannelKind::Density,
            Kind::Distance => ChannelKind::SignedDistance,
        }
    }
}

/// A voxel grid: sparse bricks of f32 values on a regular lattice, voxel `[i, j, k]`
/// centred at `origin + (i, j, k)·pitch` (world units).
#[pyclass(module = "volga._volga", frozen)]
pub struct VoxelGrid {
    pub volume: Arc<SparseVolume>,
    pub kind: Kind,
    pub mode: String,
    /// Statistics of the run that made it (JSON object).
    pub stats: Value,
}

impl VoxelGrid {
    pub fn new(volume: SparseVolume, mode: String, stats: Value) -> VoxelGrid {
        let kind = Kind::of(&volume);
        VoxelGrid {
            volume: Arc::new(volume),
            kind,
            mode,
            stats,
        }
    }

    fn dims(&self) -> UVec3 {
        self.volume.grid.dims()
    }

    /// Voxels listed by `sparse_indices`: those differing from the background, or for
    /// distances those inside the band (|d| < background).
    fn listed(&self) -> Vec<(IVec3, f32)> {
        let density = &self.volume.density;
        let bg = density.background();
        let grid_box = self.volume.grid.index_box();
        let keep = |v: f32| match self.kind {
            Kind::Distance => v.abs() < bg.abs(),
            _ => v != bg,
        };
        let mut out = Vec::new();
        for b in density.sorted_bricks() {
            for ijk in volga_core::brick_index_box(b).intersection(&grid_box).iter() {
                let v = density.get(ijk);
                if keep(v) {
                    out.push((ijk, v));
                }
            }
        }
        out.sort_unstable_by_key(|(ijk, _)| (ijk.x, ijk.y, ijk.z));
        out
    }

    /// Refuses a dense copy larger than the memory available.
    fn check_dense(&self, bytes_per_voxel: u64, memory_limit: Option<u64>) -> PyResult<u64> {
        let voxels = self.volume.grid.voxel_count();
        let d = self.dims();
        check_memory(
            &format!("a dense {}×{}×{} array", d.x, d.y, d.z),
            voxels.saturating_mul(bytes_per_voxel),
            memory_limit,
        )?;
        Ok(voxels)
    }
}

#[pymethods]
impl VoxelGrid {
    /// (nx, ny, nz): voxels along x, y, z.
    #[getter]
    fn shape(&self) -> (u32, u32, u32) {
        let d = self.dims();
        (d.x, d.y, d.z)
    }

    /// Voxel edge length (world units; the grid is isotropic when made by `voxelize`).
    #[getter]
    fn pitch(&self) -> f64 {
        self.volume.grid.transform.spacing().x
    }

    /// (3,) float64 voxel spacing along x, y, z.
    #[getter]
    fn spacing<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.volume.grid.transform.spacing().to_array().to_vec())
    }

    /// (3,) float64 world position of voxel [0, 0, 0]'s centre.
    #[getter]
    fn origin<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.volume.grid.transform.origin().to_array().to_vec())
    }

    /// (4, 4) float64 homogeneous transform from index space to world space at voxel
    /// centres (trimesh's `VoxelGrid.transform`).
    #[getter]
    fn transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        arrays::transform_matrix(py, &self.volume.grid.transform)
    }

    /// (2, 3) float64 world box covered by the voxels' cells.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let g = &self.volume.grid;
        let half = 0.5 * g.transform.spacing();
        let lo = g.transform.origin() - half;
        let hi = g.transform.origin() + (g.dims().as_dvec3() - DVec3::ONE) * g.transform.spacing() + half;
        arrays::vec3_array(py, vec![lo, hi])
    }

    /// `"binary"`, `"density"` or `"distance"`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.kind.name()
    }

    /// How the grid was made (e.g. `binary 26-separating surface`).
    #[getter]
    fn mode(&self) -> &str {
        &self.mode
    }

    /// The value of every voxel not stored: 0 for binary and density grids, the band's
    /// half-width (world units) for distances.
    #[getter]
    fn background(&self) -> f32 {
        self.volume.density.background()
    }

    /// Statistics of the run (dict): mode, voxel and brick counts, and for modes that use
    /// the inside how every sign was proven (`sign`).
    #[getter]
    fn stats(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_py(py, &self.stats)
    }

    /// The dense array indexed `[i, j, k]`: bool for binary grids, float32 otherwise.
    /// Refused with `MemoryError` when it would not fit in `memory_limit` (default: the
    /// machine's available memory). The array is a Fortran-ordered view (x fastest, the
    /// kernel's layout) of a buffer numpy owns; no copy is made.
    #[pyo3(signature = (memory_limit=None))]
    fn dense<'py>(&self, py: Python<'py>, memory_limit: Option<u64>) -> PyResult<Bound<'py, PyAny>> {
        let binary = self.kind == Kind::Binary;
        self.check_dense(if binary { 1 } else { 4 }, memory_limit)?;
        let volume = self.volume.clone();
        let dense = py
            .detach(move || volume.to_dense())
            .map_err(|e| value_error(e.to_string()))?;
        let d = self.dims();
        let shape = [d.z as usize, d.y as usize, d.x as usize];
        let data = dense.density.into_vec();
        let array = if binary {
            let bits: Vec<bool> = data.iter().map(|&v| v >= 0.5).collect();
            drop(data);
            PyArray1::from_vec(py, bits).reshape(shape)?.into_any()
        } else {
            PyArray1::from_vec(py, data).reshape(shape)?.into_any()
        };
        array.call_method0("transpose")
    }

    /// `dense()` with the default memory limit: the `[i, j, k]` array.
    #[getter]
    fn matrix<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.dense(py, None)
    }

    /// (K, 3) int64 indices of the stored voxels in `[i, j, k]` order: voxels that differ
    /// from the background (for distances: the band, |d| < background).
    #[getter]
    fn sparse_indices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let listed = self.listed();
        let flat: Vec<i64> = listed
            .iter()
            .flat_map(|(ijk, _)| [ijk.x as i64, ijk.y as i64, ijk.z as i64])
            .collect();
        PyArray1::from_vec(py, flat).reshape([listed.len(), 3])
    }

    /// (K,) values of `sparse_indices`' voxels: bool for binary grids, float32 otherwise.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let listed = self.listed();
        if self.kind == Kind::Binary {
            PyArray1::from_vec(py, listed.iter().map(|(_, v)| *v >= 0.5).collect::<Vec<_>>()).into_any()
        } else {
            PyArray1::from_vec(py, listed.iter().map(|(_, v)| *v).collect::<Vec<_>>()).into_any()
        }
    }

    /// Trilinear reconstruction of the grid at world points (K, 3) → (K,) float64.
    #[pyo3(signature = (points, threads=None))]
    fn sample<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let field = Sampled::new(&*self.volume, Filter::Trilinear);
        let values = arrays::map_points(py, "points", points, threads, move |p| field.value(p))?;
        Ok(PyArray1::from_vec(py, values))
    }

    /// Writes the grid as an OpenVDB `.vdb` file: a distance grid as a level set
    /// (`surface`, background = the band), others as a fog volume (`density`).
    /// `compression`: `"blosc"` (default, OpenVDB's own), `"zip"` or `"none"`; `half`:
    /// 16-bit floats.
    /// All or nothing, like `save`. Returns the paths written.
    #[pyo3(signature = (path, compression="blosc", half=false))]
    fn to_vdb(&self, py: Python<'_>, path: PathBuf, compression: &str, half: bool) -> PyResult<Vec<PathBuf>> {
        if volga_io::VoxelFormat::from_path(&path).ok() != Some(volga_io::VoxelFormat::Vdb) {
            return Err(value_error(format!("{}: to_vdb writes a .vdb file", path.display())));
        }
        let compression = volga_io::VdbCompression::from_name(compression)
            .ok_or_else(|| value_error(format!("compression `{compression}`: expected none, zip or blosc")))?;
        let options = volga_io::VdbOptions { compression, half };
        let volume = self.volume.clone();
        py.detach(move || {
            volga_io::check_free_space_for(&[(path.clone(), volga_io::vdb_bytes_bound(&volume, half))])?;
            let mut staged = volga_io::StagedOutputs::new();
            volga_io::write_vdb(&path, &volume, &options, &mut staged)?;
            staged.commit()
        })
        .map_err(io_error)
    }

    /// Writes the grid by extension: `.binvox` (binary grids), `.nrrd` (+ `.raw` beside
    /// it) or `.vdb` (as `to_vdb` with its defaults). All or nothing: files are staged
    /// and renamed once complete. Returns the paths.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<Vec<PathBuf>> {
        let format = volga_io::VoxelFormat::from_path(&path).map_err(io_error)?;
        if format == volga_io::VoxelFormat::Binvox && self.kind != Kind::Binary {
            return Err(value_error(format!(
                "{}: .binvox holds binary voxels; this grid holds {} values: write .nrrd",
                path.display(),
                self.kind.name()
            )));
        }
        let volume = self.volume.clone();
        py.detach(move || {
            volga_io::check_free_space_for(&[(path.clone(), format.bytes_bound(&volume))])?;
            let mut staged = volga_io::StagedOutputs::new();
            volga_io::write_voxel_model(&path, &volume, &mut staged)?;
            staged.commit()
        })
        .map_err(io_error)
    }

    fn __repr__(&self) -> String {
        let d = self.dims();
        format!(
            "volga.VoxelGrid({}×{}×{}, {}, pitch {}, {})",
            d.x,
            d.y,
            d.z,
            self.kind.name(),
            self.pitch(),
            self.mode
        )
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let me = slf.get();
        let v = &me.volume;
        let mut coords: Vec<i32> = Vec::new();
        let mut lens: Vec<u16> = Vec::new();
        let mut values: Vec<f32> = Vec::new();
        for b in v.density.sorted_bricks() {
            let voxels = v.density.brick_voxels(b);
            coords.extend_from_slice(&b.to_array());
            lens.push(voxels.len() as u16);
            values.extend_from_slice(voxels);
        }
        let t = &v.grid.transform;
        // Floats as their bit patterns: the copy is the same grid to the bit.
        let header = json!({
            "origin": t.origin().to_array().map(f64::to_bits),
            "spacing": t.spacing().to_array().map(f64::to_bits),
            "dims": v.grid.dims().to_array(),
            "background": v.density.background().to_bits(),
            "kind": me.kind.name(),
            "mode": me.mode,
            "stats": me.stats,
        });
        let bytes = |b: &[u8]| PyBytes::new(py, b).into_any();
        let state = PyTuple::new(
            py,
            [
                header.to_string().into_pyobject(py)?.into_any(),
                bytes(&coords.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>()),
                bytes(&lens.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>()),
                bytes(&values.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>()),
            ],
        )?;
        let restore = py.get_type::<VoxelGrid>().getattr("_from_state")?;
        PyTuple::new(py, [restore, state.into_any()])
    }

    /// Rebuilds a pickled grid (the state `__reduce__` makes).
    #[staticmethod]
    fn _from_state(header: &str, coords: &[u8], lens: &[u8], values: &[u8]) -> PyResult<VoxelGrid> {
        let bad = |what: &str| value_error(format!("VoxelGrid state: {what}"));
        let h: Value = serde_json::from_str(header).map_err(|e| bad(&e.to_string()))?;
        let v3 = |k: &str| -> PyResult<DVec3> {
            let a: [u64; 3] = serde_json::from_value(h[k].clone()).map_err(|e| bad(&format!("{k}: {e}")))?;
            Ok(DVec3::from_array(a.map(f64::from_bits)))
        };
        let dims: [u32; 3] = serde_json::from_value(h["dims"].clone()).map_err(|e| bad(&format!("dims: {e}")))?;
        let background = h["background"]
            .as_u64()
            .and_then(|b| u32::try_from(b).ok())
            .map(f32::from_bits)
            .ok_or_else(|| bad("background"))?;
        let kind = Kind::parse(h["kind"].as_str().ok_or_else(|| bad("kind"))?)?;
        let transform = Transform::new(v3("origin")?, v3("spacing")?).map_err(|e| bad(&e.to_string()))?;
        let grid = Grid::new(transform, UVec3::from_array(dims)).map_err(|e| bad(&e.to_string()))?;
        let mut volume = SparseVolume::new(grid, background, false).with_density_kind(kind.channel());
        let coords: Vec<i32> = coords
            .chunks_exact(4)
            .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let lens: Vec<usize> = lens
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as usize)
            .collect();
        let values: Vec<f32> = values
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if coords.len() != 3 * lens.len() || lens.iter().sum::<usize>() != values.len() {
            return Err(bad("brick lists of different lengths"));
        }
        let mut at = 0;
        for (k, &len) in lens.iter().enumerate() {
            let b = IVec3::new(coords[3 * k], coords[3 * k + 1], coords[3 * k + 2]);
            let brick = match len {
                1 => Brick::Uniform(values[at]),
                BRICK_VOXELS => {
                    let mut data = [0f32; BRICK_VOXELS];
                    data.copy_from_slice(&values[at..at + len]);
                    Brick::Dense(Arc::new(data))
                }
                _ => return Err(bad("a brick of neither 1 nor 512 values")),
            };
            volume.density.insert_brick(b, brick);
            at += len;
        }
        Ok(VoxelGrid {
            volume: Arc::new(volume),
            kind,
            mode: h["mode"].as_str().unwrap_or_default().to_string(),
            stats: h["stats"].clone(),
        })
    }
}

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

/// The iso-surface of a grid as `(vertices (N, 3) float64, faces (M, 3) int64)`, on the
/// lattice of voxel centres grown by one voxel (where the grid reads its background), so
/// closed and manifold even where the surface touches the grid's last voxels; vertices
/// refined onto the surface.
#[pyfunction]
#[pyo3(signature = (grid, iso=None, threads=None, method="cubes", adaptivity=0.0))]
pub fn extract_mesh<'py>(
    py: Python<'py>,
    grid: &VoxelGrid,
    iso: Option<f64>,
    threads: Option<usize>,
    method: &str,
    adaptivity: f64,
) -> PyResult<arrays::MeshArrays<'py>> {
    let method = volga_mesh::ExtractMethod::from_name(method)
        .ok_or_else(|| value_error(format!("method `{method}`: expected cubes, dual or tetrahedra")))?;
    if !(adaptivity.is_finite() && (0.0..=10.0).contains(&adaptivity)) {
        return Err(value_error(format!("adaptivity {adaptivity}: must be 0 to 10 voxels")));
    }
    let iso = iso.unwrap_or(match grid.kind {
        Kind::Distance => 0.0,
        _ => 0.5,
    });
    if !iso.is_finite() {
        return Err(value_error(format!("iso must be finite, got {iso}")));
    }
    let volume = grid.volume.clone();
    let surface = threads::run(py, threads, move || {
        let field = Sampled::new(&*volume, Filter::Trilinear);
        // The voxel-centre lattice grown by one voxel, where the grid reads its
        // background: a surface touching the grid's last voxels still closes, and the
        // samples are the voxels themselves (what `volga voxelize --mesh` extracts on).
        let h = volume.grid.transform.min_spacing();
        let centres = volume.grid.center_bounds();
        let region = volga_core::Aabb::new(centres.min - h, centres.max + h);
        let job = volga_mesh::Extraction::new(region, h, iso)
            .with_method(method)
            .with_adaptivity(adaptivity);
        volga_mesh::extract_surface_with(&field, &job)
    })?
    .map_err(|e| value_error(e.to_string()))?;
    arrays::mesh_arrays(py, surface.mesh)
}

/// Reads a voxel model (`.binvox`, volga's `.nrrd`, or the first float grid of an
/// OpenVDB `.vdb`: a level set as distances, a fog volume as densities) as a grid.
#[pyfunction]
pub fn load_volume(py: Python<'_>, path: PathBuf) -> PyResult<VoxelGrid> {
    let model = py.detach(|| volga_io::read_voxel_model(&path)).map_err(io_error)?;
    let (volume, values) = match model {
        model @ volga_io::VoxelModel::Binvox(_) => (
            model.into_volume(&path).map_err(|e| value_error(e.to_string()))?,
            "occupancy",
        ),
        volga_io::VoxelModel::Nrrd { volume, values } => {
            let kind = match values {
                volga_io::VoxelValues::Occupancy => ChannelKind::Binary,
                volga_io::VoxelValues::Density => ChannelKind::Density,
                volga_io::VoxelValues::Distance { .. } => ChannelKind::SignedDistance,
            };
            let background = match values {
                volga_io::VoxelValues::Distance { background, .. } => background,
                _ => 0.0,
            };
            let mut sparse = SparseVolume::from_dense(&volume).with_density_kind(kind);
            if background != sparse.density.background() {
                let mut rebased = SparseVolume::new(volume.grid, background, false).with_density_kind(kind);
                for ijk in volume.grid.index_box().iter() {
                    let v = volume.density.get(ijk);
                    if v != background {
                        rebased.density.set(ijk, v);
                    }
                }
                sparse = rebased;
            }
            (sparse, values.name())
        }
        volga_io::VoxelModel::Vdb { grid, values } => {
            let kind = match values {
                volga_io::VoxelValues::Occupancy => ChannelKind::Binary,
                volga_io::VoxelValues::Density => ChannelKind::Density,
                volga_io::VoxelValues::Distance { .. } => ChannelKind::SignedDistance,
            };
            (grid.volume.with_density_kind(kind), values.name())
        }
    };
    let stats = json!({ "path": path, "values": values, "active_voxels": volume.active_voxel_count() });
    Ok(VoxelGrid::new(volume, format!("read from {}", path.display()), stats))
}
