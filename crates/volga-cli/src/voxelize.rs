//! `volga voxelize`: one mesh to one voxel file, with a report shaped like
//! `volga build`'s (a `stages` list with the voxelization in a stage named `voxelize`).

use std::path::{Path, PathBuf};

use clap::Args;

use crate::failure::{bad_input, failed, Failure};
use serde::Serialize;
use volga_core::memory::{self, Bytes};
use volga_core::{Grid, Progress, SparseVolume};
use volga_io::{StagedOutputs, VoxelFormat};
use volga_scene::{StageReport, Stages};
use volga_voxelize::{parse_bytes_bound, JobEstimate, MeshJob, MeshJobMode, MeshRun, Separability, SignStats};

/// What to voxelize and how: shared by `volga voxelize` and `volga bench voxelize`.
/// Flags that a mode would ignore are refused (`--unsigned` goes only with `--distance`,
/// `--thickness` only with an anti-aliased surface, `--solid` not with `--distance`).
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
    /// Fill the inside (generalized winding number ≥ ½): a solid instead of a surface
    /// (with --separability or --anti-aliased).
    #[arg(long, conflicts_with = "distance")]
    solid: bool,
    /// Unsigned distances (with `--distance`).
    #[arg(long, conflicts_with_all = ["separability", "anti_aliased"])]
    unsigned: bool,
    /// Thickness of an anti-aliased surface, in voxels (with --anti-aliased, without --solid).
    #[arg(long, default_value_t = 1.0, conflicts_with_all = ["separability", "distance", "solid"])]
    thickness: f64,
    /// Refuse runs estimated to need more memory than this (e.g. 8G); default: the
    /// machine's available memory. Checked before reading the mesh (from the file's
    /// size) and before voxelizing (from the triangles and the grid).
    #[arg(long, value_parser = crate::parse_size)]
    memory_limit: Option<u64>,
}

#[derive(Args)]
pub struct VoxelizeArgs {
    #[command(flatten)]
    job: JobArgs,
    /// Output: .binvox (binary modes), .nrrd (+ .raw beside it) or .vdb (OpenVDB: a
    /// level set for --distance, else a fog volume).
    #[arg(long)]
    out: PathBuf,
    /// Write a JSON report here.
    #[arg(long)]
    report: Option<PathBuf>,
    #[command(flatten)]
    vdb: VdbArgs,
    /// Also write the volume's iso-surface as a mesh (.obj or .ply): ½ of the density
    /// (anti-aliased, binary) or 0 of the distance, on the voxel-centre lattice, closed
    /// where the surface meets the grid's border (outside the grid is empty).
    #[arg(long = "mesh", id = "mesh_out", value_name = "MESH_OUT")]
    mesh_out: Option<PathBuf>,
    #[command(flatten)]
    mesh_args: crate::mesh_out::MeshArgs,
}

/// How a `.vdb` output is written.
#[derive(clap::Args, Clone, Default)]
pub struct VdbArgs {
    /// Compression of a .vdb output's values: blosc (default, as OpenVDB's own:
    /// Blosc-LZ4), zip (readable by OpenVDB builds without Blosc; slower) or none.
    #[arg(long, value_name = "none|zip|blosc")]
    pub vdb_compression: Option<String>,
    /// Store a .vdb output's values as 16-bit floats (half the size, 11 significant bits).
    #[arg(long)]
    pub vdb_half: bool,
}

impl VdbArgs {
    /// The options for output `out`; the flags are refused for an output that is not
    /// `.vdb` (exit 2).
    pub fn options(&self, out: &Path) -> Result<volga_io::VdbOptions, Failure> {
        let is_vdb = VoxelFormat::from_path(out).is_ok_and(|f| f == VoxelFormat::Vdb);
        if !is_vdb && (self.vdb_compression.is_some() || self.vdb_half) {
            return Err(bad_input(format!(
                "{}: --vdb-compression and --vdb-half apply to .vdb outputs only",
                out.display()
            )));
        }
        let compression = match self.vdb_compression.as_deref() {
            None => volga_io::VdbCompression::default(),
            Some(name) => volga_io::VdbCompression::from_name(name)
                .ok_or_else(|| bad_input(format!("--vdb-compression `{name}`: expected none, zip or blosc")))?,
        };
        Ok(volga_io::VdbOptions {
            compression,
            half: self.vdb_half,
        })
    }
}

fn parse_separability(s: &str) -> Result<Separability, String> {
    s.parse::<u32>()
        .ok()
        .and_then(Separability::from_number)
        .ok_or_else(|| format!("`{s}`: separability must be 6, 18 or 26"))
}

#[derive(Serialize, Clone)]
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
    /// Jobs that use the inside: how every voxel's sign was proven (fast per-triangle
    /// interval, caps, or the certified whole-mesh winding number) and what made the
    /// mesh hard (unclean triangles, boundary cycle).
    #[serde(skip_serializing_if = "Option::is_none")]
    sign: Option<SignStats>,
    warnings: Vec<String>,
    outputs: Vec<PathBuf>,
}

#[derive(Serialize, Clone)]
struct GridReport {
    dims: [u32; 3],
    voxel_size: f64,
    origin: [f64; 3],
}

#[derive(Serialize, Clone)]
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

/// The format of an output path, from its extension; `.binvox` only for binary modes.
pub fn output_format(out: &Path, binary: bool) -> Result<VoxelFormat, Failure> {
    let format = VoxelFormat::from_path(out).map_err(|e| bad_input(e.to_string()))?;
    if format == VoxelFormat::Binvox && !binary {
        return Err(bad_input(format!(
            "{}: .binvox holds binary voxels; use --separability, or write .nrrd",
            out.display()
        )));
    }
    Ok(format)
}

/// A checked job: the mesh read, the grid laid out, the memory estimate under the limit.
pub struct Job {
    pub spec: MeshJob,
    pub mesh: volga_mesh::TriMesh,
    pub grid: Grid,
    pub estimate: JobEstimate,
    /// The bound checked before parsing the mesh file (0 when its size is unknown).
    pub parse_bound: u64,
}

impl Job {
    /// An upper bound on the run's peak memory: the larger of the parsing bound and the
    /// job's estimate.
    pub fn peak_bound(&self) -> u64 {
        self.parse_bound.max(self.estimate.peak_bytes)
    }
}

impl JobArgs {
    pub fn mesh_path(&self) -> &Path {
        &self.mesh
    }

    /// The library job these arguments describe.
    pub fn spec(&self) -> Result<MeshJob, Failure> {
        let mode = match (self.separability, self.distance) {
            (Some(separability), _) => MeshJobMode::Binary {
                separability,
                solid: self.solid,
            },
            (None, Some(half_width_voxels)) => MeshJobMode::Distance {
                half_width_voxels,
                signed: !self.unsigned,
            },
            (None, None) if self.anti_aliased => MeshJobMode::AntiAliased {
                thickness_voxels: self.thickness,
                solid: self.solid,
            },
            (None, None) => {
                return Err(bad_input(
                    "choose a mode: --separability 6|18|26, --anti-aliased or --distance HALFWIDTH",
                ))
            }
        };
        let spec = MeshJob {
            resolution: self.resolution,
            mode,
        };
        spec.check().map_err(|e| bad_input(e.to_string()))?;
        Ok(spec)
    }

    pub fn limit(&self) -> u64 {
        self.memory_limit.or_else(memory::available_bytes).unwrap_or(u64::MAX)
    }

    /// Checks the arguments, refuses a mesh file whose parsing could need more memory
    /// than the limit, reads the mesh (in a stage named `read_mesh`), lays out the grid
    /// and refuses a job estimated to need more memory than the limit.
    pub fn prepare(&self, stages: &mut Stages) -> Result<Job, Failure> {
        let spec = self.spec()?;
        let limit = self.limit();
        let mut parse_bound = 0;
        if let Ok(meta) = std::fs::metadata(&self.mesh) {
            let extension = self
                .mesh
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase)
                .unwrap_or_default();
            let bound = parse_bytes_bound(meta.len(), &extension);
            parse_bound = bound;
            if bound > limit {
                return Err(bad_input(format!(
                    "{}: reading this {} file may need up to {}, more than the {} available (set --memory-limit to allow it)",
                    self.mesh.display(),
                    Bytes(meta.len() as u128),
                    Bytes(bound as u128),
                    Bytes(limit as u128)
                )));
            }
        }

        let mesh = stages
            .run("read_mesh", || volga_mesh::load_mesh(&self.mesh))
            .map_err(|e| bad_input(e.to_string()))?;
        let grid = spec.layout(&mesh.bounds()).map_err(|e| match e.field {
            "mesh" => bad_input(format!("{}: {e}", self.mesh.display())),
            _ => bad_input(e.to_string()),
        })?;
        let estimate = spec.estimate(&mesh, &grid);
        if estimate.peak_bytes > limit {
            let dims = grid.dims();
            return Err(bad_input(format!(
                "{}: voxelizing at --resolution {} ({}×{}×{} voxels) needs an estimated {}, more than the {} available",
                self.mesh.display(),
                self.resolution,
                dims.x,
                dims.y,
                dims.z,
                Bytes(estimate.peak_bytes as u128),
                Bytes(limit as u128)
            )));
        }
        Ok(Job {
            spec,
            mesh,
            grid,
            estimate,
            parse_bound,
        })
    }
}

impl Job {
    /// The voxelization itself, everything the `voxelize` stage times: the volume, the
    /// mesh's boundary-edge count when the job needed its topology, how the signs were
    /// proven, and the mode's name.
    pub fn voxelize(&self, progress: &dyn Progress) -> (MeshRun, String) {
        (self.spec.run(&self.mesh, &self.grid, progress), self.spec.mode_name())
    }

    /// [`Job::voxelize`], and where its time went ([`MeshJob::run_profiled`]).
    pub fn voxelize_profiled(&self, progress: &dyn Progress) -> (MeshRun, String, volga_voxelize::VoxelizeProfile) {
        let (run, profile) = self.spec.run_profiled(&self.mesh, &self.grid, progress);
        (run, self.spec.mode_name(), profile)
    }

    /// The voxel count a job reports: band voxels of distance fields (|d| < half-width,
    /// comparable to a level set's active voxels), else the active voxels.
    pub fn voxel_count(&self, volume: &SparseVolume) -> u64 {
        if matches!(self.spec.mode, MeshJobMode::Distance { .. }) {
            band_voxel_count(volume)
        } else {
            volume.active_voxel_count()
        }
    }
}

/// Refuses a `--report` that is one of the model's files (the `.binvox`, or the
/// `.nrrd` or its `.raw`): the model would silently become the report. Paths are
/// compared canonicalized (their directory resolved, so `./a/../x.json` and symbolic
/// links to the same directory compare equal).
pub fn check_distinct_outputs(out: &Path, format: VoxelFormat, report: Option<&Path>) -> Result<(), Failure> {
    let Some(report) = report else { return Ok(()) };
    let real = |p: &Path| -> PathBuf {
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
        match p.file_name() {
            Some(name) => {
                let joined = dir.join(name);
                joined.canonicalize().unwrap_or(joined)
            }
            None => dir,
        }
    };
    let report_real = real(report);
    for model_file in format.output_paths(out, false) {
        if real(&model_file) == report_real {
            return Err(bad_input(format!(
                "--report {} is the same file as the model's {}: choose another report path",
                report.display(),
                model_file.display()
            )));
        }
    }
    Ok(())
}

/// A report to write with the model: its path, and its JSON made from the model's
/// final paths.
pub type ReportOutput<'a> = (&'a Path, &'a dyn Fn(&[PathBuf]) -> Vec<u8>);

/// Bytes a report may take on disk (the free-space check; reports are a few KiB).
const REPORT_BYTES_BOUND: u64 = 1 << 20;

/// Writes the model (and the report, when given one) all or nothing: both are staged
/// first, and nothing is replaced unless every file could be written. The free space
/// of each output's filesystem is checked first (exit 1 with the sizes when short).
/// `report` is called with the model's final paths and the write's duration so far.
pub fn write_outputs(
    out: &Path,
    volume: &SparseVolume,
    vdb: &volga_io::VdbOptions,
    report: Option<ReportOutput<'_>>,
) -> Result<Vec<PathBuf>, Failure> {
    write_outputs_with(out, volume, vdb, report, None)
}

/// The iso-surface of a voxelized volume: ½ of a density, 0 of a distance, on the
/// voxel-centre lattice grown by one voxel (outside the grid reads the background, so a
/// surface touching the border closes there).
pub fn volume_surface(
    volume: &SparseVolume,
    args: &crate::mesh_out::MeshArgs,
    limit: u64,
    path: &Path,
) -> Result<volga_mesh::Surface, Failure> {
    let field = volga_core::Sampled::new(volume, volga_core::Filter::Trilinear);
    let iso = match volume.density_kind {
        volga_core::ChannelKind::SignedDistance => 0.0,
        _ => 0.5,
    };
    let h = volume.grid.transform.min_spacing();
    let b = volume.grid.center_bounds();
    let region = volga_core::Aabb::new(b.min - h, b.max + h);
    crate::mesh_out::extract(&field, region, h, iso, args, limit, path)
}

/// [`write_outputs`] with a mesh file staged beside the model.
pub fn write_outputs_with(
    out: &Path,
    volume: &SparseVolume,
    vdb: &volga_io::VdbOptions,
    report: Option<ReportOutput<'_>>,
    mesh: Option<(&Path, &[u8])>,
) -> Result<Vec<PathBuf>, Failure> {
    let format = VoxelFormat::from_path(out).map_err(|e| bad_input(e.to_string()))?;
    let mut needs: Vec<(PathBuf, u64)> = vec![(out.to_path_buf(), format.bytes_bound(volume))];
    if let Some((path, bytes)) = mesh {
        needs.push((path.to_path_buf(), bytes.len() as u64));
    }
    if let Some((path, _)) = report {
        needs.push((path.to_path_buf(), REPORT_BYTES_BOUND));
    }
    volga_io::check_free_space_for(&needs).map_err(|e| failed(e.to_string()))?;
    let mut staged = StagedOutputs::new();
    let mut outputs =
        volga_io::write_voxel_model_with(out, volume, vdb, &mut staged).map_err(|e| failed(e.to_string()))?;
    if let Some((path, bytes)) = mesh {
        staged
            .stage(path, |w| w.write_all(bytes))
            .map_err(|e| failed(e.to_string()))?;
        outputs.push(path.to_path_buf());
    }
    if let Some((path, make)) = report {
        let json = make(&outputs);
        staged
            .stage(path, |w| w.write_all(&json))
            .map_err(|e| failed(e.to_string()))?;
        outputs = staged.commit().map_err(|e| failed(e.to_string()))?;
        outputs.retain(|p| p != path);
        Ok(outputs)
    } else {
        staged.commit().map_err(|e| failed(e.to_string()))
    }
}

pub fn run(args: VoxelizeArgs, progress: &dyn Progress) -> Result<(), Failure> {
    let job_args = &args.job;
    volga_core::memory::set_input_limit(job_args.memory_limit);
    let format = output_format(&args.out, job_args.spec()?.is_binary())?;
    let vdb = args.vdb.options(&args.out)?;
    check_distinct_outputs(&args.out, format, args.report.as_deref())?;
    args.mesh_args.checked()?;
    match &args.mesh_out {
        Some(p) => crate::mesh_out::check_mesh_path(p)?,
        None if args.mesh_args.given() => {
            return Err(bad_input("--mesh-method and --mesh-adaptivity need --mesh".to_string()))
        }
        None => {}
    }
    let mut stages = Stages::with_stage_start(crate::heap::stage_start);
    let job = job_args.prepare(&mut stages)?;
    if format == VoxelFormat::Nrrd {
        // A NRRD's size is known from the grid: refuse before voxelizing.
        let d = job.grid.dims().as_u64vec3();
        let bytes = (d.x * d.y * d.z).saturating_mul(4);
        volga_io::check_free_space_for(&[(args.out.clone(), bytes)]).map_err(|e| failed(e.to_string()))?;
    }
    let (run, mode) = stages.run("voxelize", || job.voxelize(progress));
    let MeshRun {
        volume,
        boundary_edges: voxelizer_edges,
        sign,
    } = run;
    // Binary surfaces need no topology of the mesh: count its boundary for the report
    // outside the timed stage.
    let boundary_edges = voxelizer_edges.unwrap_or_else(|| job.mesh.boundary_edge_count());
    let mut warnings = Vec::new();
    if job.spec.needs_inside() && boundary_edges > 0 {
        let w = format!(
            "{} is not closed ({boundary_edges} boundary edges): inside means generalized winding number ≥ ½",
            job_args.mesh.display()
        );
        eprintln!("warning: {w}");
        warnings.push(w);
    }

    let grid = &job.grid;
    let mut report = Report {
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
        stages: Vec::new(),
        voxels: VoxelCounts {
            active: volume.active_voxel_count(),
            band: matches!(job.spec.mode, MeshJobMode::Distance { .. }).then(|| band_voxel_count(&volume)),
            bricks: volume.density.brick_count(),
            dense_bricks: volume.density.dense_brick_count(),
        },
        estimated_memory_bytes: job.peak_bound(),
        sign,
        warnings,
        outputs: Vec::new(),
    };

    // The mesh first, in its own stage (so the report lists it and `write` times the
    // files only).
    let mesh = match &args.mesh_out {
        Some(path) => {
            let surface = stages.run("mesh", || {
                volume_surface(&volume, &args.mesh_args, job_args.limit(), path)
            })?;
            Some((path.as_path(), crate::mesh_out::mesh_bytes(path, &surface)))
        }
        None => None,
    };
    // The model and the report are staged together; the report's `write` stage times
    // the model's staging (the report itself is a few KiB).
    let write_start = std::time::Instant::now();
    let before = stages.list.clone();
    let make_report = |outputs: &[PathBuf]| -> Vec<u8> {
        let mut list = before.clone();
        list.push(StageReport {
            name: "write".into(),
            wall_s: write_start.elapsed().as_secs_f64(),
            peak_mem_bytes: volga_scene::peak_rss_bytes(),
        });
        let r = Report {
            stages: list,
            outputs: outputs.to_vec(),
            ..report.clone()
        };
        serde_json::to_vec_pretty(&r).expect("report serializes")
    };
    let outputs = stages.run("write", || {
        write_outputs_with(
            &args.out,
            &volume,
            &vdb,
            args.report
                .as_deref()
                .map(|p| (p, &make_report as &dyn Fn(&[PathBuf]) -> Vec<u8>)),
            mesh.as_ref().map(|(p, b)| (*p, b.as_slice())),
        )
    })?;
    report.stages = stages.list;
    report.outputs = outputs;
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
    if let Some(sign) = &report.sign {
        println!(
            "signs proven: {} voxels by their nearest triangle, {} by the caps, {} by the whole mesh's certified winding number ({} in the band; {} unclean triangles, {} boundary-cycle edges)",
            sign.fast_voxels,
            sign.cap_voxels,
            sign.exact_voxels,
            sign.exact_band_voxels,
            sign.unclean_triangles,
            sign.boundary_cycle_edges
        );
    }
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
