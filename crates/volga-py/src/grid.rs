//! `volga.VoxelGrid` (a sparse volume with its kind), `extract_mesh` and `load_volume`;
//! `voxelize` and `VoxelJob` are in `voxelize.rs`.

use std::path::PathBuf;
use std::sync::Arc;

use glam::{DVec3, IVec3, UVec3};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple};
use serde_json::{json, Value};
use volga_core::{Brick, ChannelKind, Field, Filter, Grid, Sampled, SparseVolume, Transform, BRICK_VOXELS};

use crate::arrays;
use crate::errors::{check_memory, io_error, value_error};
use crate::json::to_py;
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
