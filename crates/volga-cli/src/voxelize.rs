//! `volga voxelize`: one mesh to one voxel file, with a report shaped like
//! `volga build`'s (a `stages` list with the voxelization in a stage named `voxelize`).

use std::path::{Path, PathBuf};

use clap::Args;

use crate::failure::{bad_input, failed, Failure};
use glam::{DVec3, UVec3};
use serde::Serialize;
use volga_core::memory::{self, Bytes};
use volga_core::{Grid, Progress, SparseVolume, Transform};
use volga_scene::{StageReport, Stages};
use volga_voxelize::{voxelize_mesh_surface, MeshVoxelizer, Separability, SurfaceMode};

/// What to voxelize and how: shared by `volga voxelize` and `volga bench voxelize`.
#[derive(Args)]
pub struct JobArgs {
    /// Mesh file: .obj, .gltf or .glb.
    mesh: PathBuf,
    /// Voxels along the longest side of the mesh's bounding box.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    resolution: u32,
    /// Binary surface with this separability (6, 18 or 26).
    #[arg(long, value_parser = parse_separability, group = "mode")]
    separability: Option<Separability>,
    /// Anti-aliased (oriented box filter) surface of `--thickness`, or solid with `--solid`.
    #[arg(long, group = "mode")]
    anti_aliased: bool,
    /// Narrow-band signed distance field of this half-width (voxels); world units in the file.
    #[arg(long, value_name = "HALFWIDTH", group = "mode")]
    distance: Option<f64>,
    /// Fill the inside (generalized winding number ≥ ½): a solid instead of a surface.
    #[arg(long)]
    solid: bool,
    /// Unsigned distances (with `--distance`).
    #[arg(long)]
    unsigned: bool,
    /// Thickness of an anti-aliased surface, in voxels.
    #[arg(long, default_value_t = 1.0)]
    thickness: f64,
    /// Refuse runs estimated to need more memory than this (e.g. 8G).
    #[arg(long, value_parser = crate::parse_size)]
    memory_limit: Option<u64>,
}

#[derive(Args)]
pub struct VoxelizeArgs {
    #[command(flatten)]
    job: JobArgs,
    /// Output: .binvox (binary modes) or .nrrd (+ .raw beside it).
    #[arg(long)]
    out: PathBuf,
    /// Write a JSON report here.
    #[arg(long)]
    report: Option<PathBuf>,
}

fn parse_separability(s: &str) -> Result<Separability, String> {
    s.parse::<u32>()
        .ok()
        .and_then(Separability::from_number)
        .ok_or_else(|| format!("`{s}`: separability must be 6, 18 or 26"))
}

#[derive(Serialize)]
struct Report {
    mesh: PathBuf,
    triangles: usize,
    boundary_edges: usize,
    closed: bool,
    mode: String,
    threads: usize,
    grid: GridReport,
    stages: Vec<StageReport>,
    voxels: VoxelCounts,
    estimated_memory_bytes: u64,
    warnings: Vec<String>,
    outputs: Vec<PathBuf>,
}

#[derive(Serialize)]
struct GridReport {
    dims: [u32; 3],
    voxel_size: f64,
    origin: [f64; 3],
}

#[derive(Serialize)]
struct VoxelCounts {
    /// Voxels that differ from the background: black voxels of binary modes, non-zero
    /// density, or distances inside the band.
    active: u64,
    /// Distance modes: voxels strictly inside the band (|d| < half-width), the figure
    /// comparable to a level set's active voxels.
    #[serde(skip_serializing_if = "Option::is_none")]
    band: Option<u64>,
    bricks: usize,
    dense_bricks: usize,
}

pub enum Format {
    Binvox,
    Nrrd,
}

impl Format {
    /// The format of an output path, from its extension; `.binvox` only for binary modes.
    pub fn of(out: &Path, binary: bool) -> Result<Format, Failure> {
        let format = match out
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("binvox") => Format::Binvox,
            Some("nrrd") => Format::Nrrd,
            _ => {
                return Err(bad_input(format!(
                    "{}: output must end in .binvox or .nrrd",
                    out.display()
                )))
            }
        };
        if matches!(format, Format::Binvox) && !binary {
            return Err(bad_input(format!(
                "{}: .binvox holds binary voxels; use --separability, or write .nrrd",
                out.display()
            )));
        }
        Ok(format)
    }
}

/// A checked job: the mesh read, the grid laid out, the memory estimate under the limit.
pub struct Job {
    pub mesh: volga_mesh::TriMesh,
    pub grid: Grid,
    pub estimate: u64,
}

impl JobArgs {
    pub fn mesh_path(&self) -> &Path {
        &self.mesh
    }

    pub fn is_binary(&self) -> bool {
        self.separability.is_some()
    }

    /// Whether the job needs the inside of the mesh (winding numbers).
    fn needs_inside(&self) -> bool {
        self.solid || (self.distance.is_some() && !self.unsigned)
    }

    /// Checks the arguments, reads the mesh (in a stage named `read_mesh`), lays out the
    /// grid and refuses a job estimated to need more memory than the limit.
    pub fn prepare(&self, stages: &mut Stages) -> Result<Job, Failure> {
        if !(self.thickness.is_finite() && self.thickness > 0.0) {
            return Err(bad_input(format!(
                "--thickness must be finite and > 0, got {}",
                self.thickness
            )));
        }
        if let Some(hw) = self.distance {
            if !(hw.is_finite() && hw > 0.0 && hw <= 1000.0) {
                return Err(bad_input(format!("--distance must lie in (0, 1000] voxels, got {hw}")));
            }
        }
        if !self.is_binary() && !self.anti_aliased && self.distance.is_none() {
            return Err(bad_input(
                "choose a mode: --separability 6|18|26, --anti-aliased or --distance HALFWIDTH",
            ));
        }

        let mesh = stages
            .run("read_mesh", || volga_mesh::load_mesh(&self.mesh))
            .map_err(|e| bad_input(e.to_string()))?;

        let bounds = mesh.bounds();
        let h = bounds.size().max_element() / self.resolution as f64;
        if !(h.is_finite() && h > 0.0) {
            return Err(bad_input(format!(
                "{}: the mesh has no extent to voxelize",
                self.mesh.display()
            )));
        }
        let band_voxels = match (self.distance, self.anti_aliased) {
            (Some(hw), _) => hw,
            (None, true) => 0.5 * self.thickness + 3f64.sqrt(),
            _ => 1.0,
        };
        let pad = band_voxels.ceil() + 1.0;
        let dims_f = (bounds.size() / h).ceil() + 2.0 * pad;
        let dims = UVec3::new(dims_f.x as u32, dims_f.y as u32, dims_f.z as u32).max(UVec3::ONE);
        let origin = bounds.min - DVec3::splat(pad * h) + DVec3::splat(0.5 * h);
        let grid = Transform::new(origin, DVec3::splat(h))
            .and_then(|t| Grid::new(t, dims))
            .map_err(|e| bad_input(format!("--resolution {}: {e}", self.resolution)))?;

        // Memory: every brick a triangle's band can touch (dense), plus one value per
        // brick of the grid for filled interiors, plus the BVH and per-triangle data of
        // the distance voxelizer (~2.4 KB a triangle with its feature regions; ~100
        // bytes for a binary surface alone).
        let (band_bricks, grid_bricks) = MeshVoxelizer::estimate_bricks(&mesh, &grid, band_voxels * h);
        let uses_distance = self.solid || !self.is_binary();
        let per_triangle = if uses_distance { 2400 } else { 100 };
        let estimate = band_bricks * (2048 + 64) + grid_bricks * 48 + mesh.triangles.len() as u64 * per_triangle;
        let limit = self.memory_limit.or_else(memory::available_bytes).unwrap_or(u64::MAX);
        if estimate > limit {
            return Err(bad_input(format!(
                "{}: voxelizing at --resolution {} ({}×{}×{} voxels) needs an estimated {}, more than the {} available",
                self.mesh.display(),
                self.resolution,
                dims.x,
                dims.y,
                dims.z,
                Bytes(estimate as u128),
                Bytes(limit as u128)
            )));
        }
        Ok(Job { mesh, grid, estimate })
    }

    /// The voxelization itself, everything the `voxelize` stage times: the volume, the
    /// mesh's boundary-edge count when the job needed its topology, and the mode's name.
    pub fn voxelize(&self, job: &Job, progress: &dyn Progress) -> (SparseVolume, Option<usize>, String) {
        let (mesh, grid) = (&job.mesh, &job.grid);
        let voxelizer = (self.needs_inside() || !self.is_binary()).then(|| MeshVoxelizer::new(mesh));
        let boundary_edges = voxelizer.as_ref().map(|v| v.boundary_edge_count());
        let (volume, mode) = match (self.separability, self.distance) {
            (Some(sep), _) => {
                let mut surface = voxelize_mesh_surface(grid, mesh, sep, progress);
                if self.solid {
                    let inside =
                        voxelizer
                            .as_ref()
                            .expect("built for --solid")
                            .voxelize(grid, SurfaceMode::Inside, progress);
                    volga_voxelize::merge_max(&mut surface, &inside, [1.0; 3]);
                }
                (
                    surface,
                    format!(
                        "binary {}-separating {}",
                        sep.number(),
                        if self.solid { "solid" } else { "surface" }
                    ),
                )
            }
            (None, Some(hw)) => (
                voxelizer.as_ref().expect("built").voxelize(
                    grid,
                    SurfaceMode::Distance {
                        half_width_voxels: hw,
                        signed: !self.unsigned,
                    },
                    progress,
                ),
                format!(
                    "{} distance, half-width {hw} voxels",
                    if self.unsigned { "unsigned" } else { "signed" }
                ),
            ),
            (None, None) => {
                let mode = if self.solid {
                    SurfaceMode::Solid
                } else {
                    SurfaceMode::Shell {
                        thickness: self.thickness * grid.transform.spacing().x,
                    }
                };
                (
                    voxelizer.as_ref().expect("built").voxelize(grid, mode, progress),
                    if self.solid {
                        "anti-aliased solid".to_string()
                    } else {
                        format!("anti-aliased surface, thickness {} voxels", self.thickness)
                    },
                )
            }
        };
        (volume, boundary_edges, mode)
    }

    /// The voxel count a job reports: band voxels of distance fields (|d| < half-width,
    /// comparable to a level set's active voxels), else the active voxels.
    pub fn voxel_count(&self, volume: &SparseVolume) -> u64 {
        if self.distance.is_some() {
            band_voxel_count(volume)
        } else {
            volume.active_voxel_count()
        }
    }
}

pub fn run(args: VoxelizeArgs, progress: &dyn Progress) -> Result<(), Failure> {
    let job_args = &args.job;
    let format = Format::of(&args.out, job_args.is_binary())?;
    let mut stages = Stages::default();
    let job = job_args.prepare(&mut stages)?;
    let (volume, voxelizer_edges, mode) = stages.run("voxelize", || job_args.voxelize(&job, progress));
    // Binary surfaces need no topology of the mesh: count its boundary for the report
    // outside the timed stage.
    let boundary_edges = voxelizer_edges.unwrap_or_else(|| job.mesh.boundary_edge_count());
    let mut warnings = Vec::new();
    if job_args.needs_inside() && boundary_edges > 0 {
        let w = format!(
            "{} is not closed ({boundary_edges} boundary edges): inside means generalized winding number ≥ ½",
            job_args.mesh.display()
        );
        eprintln!("warning: {w}");
        warnings.push(w);
    }

    let outputs = stages
        .run("write", || write(&args.out, &format, &volume))
        .map_err(|e| failed(e.to_string()))?;

    let grid = &job.grid;
    let report = Report {
        mesh: job_args.mesh.clone(),
        triangles: job.mesh.triangles.len(),
        boundary_edges,
        closed: boundary_edges == 0,
        mode,
        threads: rayon::current_num_threads(),
        grid: GridReport {
            dims: grid.dims().to_array(),
            voxel_size: grid.transform.spacing().x,
            origin: grid.transform.origin().to_array(),
        },
        stages: stages.list,
        voxels: VoxelCounts {
            active: volume.active_voxel_count(),
            band: job_args.distance.map(|_| band_voxel_count(&volume)),
            bricks: volume.density.brick_count(),
            dense_bricks: volume.density.dense_brick_count(),
        },
        estimated_memory_bytes: job.estimate,
        warnings,
        outputs,
    };
    if let Some(path) = &args.report {
        let json = serde_json::to_vec_pretty(&report).expect("report serializes");
        volga_io::write_atomic(path, |w| w.write_all(&json)).map_err(|e| failed(e.to_string()))?;
    }
    println!(
        "{}: {} → {} ({} {}, {:.3} s voxelizing)",
        job_args.mesh.display(),
        report.mode,
        args.out.display(),
        report.voxels.band.unwrap_or(report.voxels.active),
        if report.voxels.band.is_some() {
            "band voxels"
        } else {
            "active voxels"
        },
        report
            .stages
            .iter()
            .find(|s| s.name == "voxelize")
            .map_or(0.0, |s| s.wall_s)
    );
    Ok(())
}

/// Voxels whose distance lies strictly inside the band (|d| < background).
fn band_voxel_count(volume: &SparseVolume) -> u64 {
    let bg = volume.density.background().abs();
    let grid_box = volume.grid.index_box();
    volume
        .density
        .sorted_bricks()
        .iter()
        .map(|&b| {
            volga_core::brick_index_box(b)
                .intersection(&grid_box)
                .iter()
                .filter(|ijk| volume.density.get(*ijk).abs() < bg)
                .count() as u64
        })
        .sum()
}

pub fn write(out: &Path, format: &Format, volume: &SparseVolume) -> Result<Vec<PathBuf>, volga_io::IoError> {
    match format {
        Format::Binvox => {
            let g = &volume.grid;
            let h = g.transform.spacing().x;
            let dims = g.dims();
            let filled = volume.density.sorted_bricks().into_iter().flat_map(|b| {
                volga_core::brick_index_box(b)
                    .intersection(&g.index_box())
                    .iter()
                    .filter(|ijk| volume.density.get(*ijk) > 0.5)
                    .map(|ijk| ijk.as_uvec3())
                    .collect::<Vec<_>>()
            });
            // binvox grids are cubes (`dim D D D`); other tools assume it, so the grid is
            // padded with empty voxels to its largest extent (voxel 0 stays where it is).
            let model = volga_io::Binvox::from_filled(
                UVec3::splat(dims.max_element()),
                g.transform.origin() - DVec3::splat(0.5 * h),
                h * dims.max_element() as f64,
                filled,
            )
            .map_err(|e| volga_io::IoError::Format {
                path: out.to_owned(),
                line: None,
                message: e.to_string(),
            })?;
            volga_io::write_binvox(out, &model)?;
            Ok(vec![out.to_owned()])
        }
        Format::Nrrd => {
            let dir = out
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            let stem = out
                .file_stem()
                .and_then(|s| s.to_str())
                .ok_or_else(|| volga_io::IoError::Format {
                    path: out.to_owned(),
                    line: None,
                    message: "the output name is not valid UTF-8".into(),
                })?;
            let mut staged = volga_io::StagedOutputs::new();
            volga_io::write_nrrd(dir, stem, volume, &mut staged)?;
            staged.commit()
        }
    }
}
