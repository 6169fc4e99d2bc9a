//! `volga adf` (build an ADF from a mesh, write its statistics and a render) and
//! `volga bench adf` (time the build, measure its accuracy, render speed; one JSON).
//!
//! Tolerances are fractions of the mesh's bounding-box diagonal, and so are the reported
//! errors (`max_error`, `rms_error`): measured at points within 2 % of the diagonal of
//! the surface against the exact signed distance (nearest triangle, certified winding
//! sign).
//!
//! Every flag is checked before the mesh is read, and the build's memory (the ADF's
//! estimated cells, the image, the probes) against `--memory-limit` before it runs; the
//! build itself stops at the cells that limit allows, should the estimate be low.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use glam::{DVec3, Vec3};
use serde_json::{json, Value};
use volga_adf::{
    measure_errors, measure_errors_with_probes, Adf, AdfOptions, BuildEstimate, DescentWalk, ErrorStats, MeshSource,
    OneRayWalk, Probe, MAX_SUPPORTED_DEPTH,
};
use volga_core::memory::Bytes;
use volga_core::Field;
use volga_core::{Aabb, NoProgress, Progress};
use volga_render::{Camera, Iso, Projection, RenderSettings, Renderer, SurfaceColour};

use crate::failure::{bad_input, failed, Failure};

#[derive(Args, Clone)]
pub struct AdfArgs {
    /// Triangle mesh (.obj, .gltf, .glb).
    pub mesh: PathBuf,
    /// Tolerance as a fraction of the bounding-box diagonal (> 0). A tolerance whose
    /// estimated cells do not fit in --memory-limit is refused before the build.
    #[arg(long, default_value_t = 1e-4, allow_hyphen_values = true)]
    pub tolerance: f64,
    /// Maximum octree depth (the root cube is level 0), at most 24.
    #[arg(long, default_value_t = 12)]
    pub max_depth: u8,
    /// Band around the surface (fraction of the diagonal) kept free of pruned leaves, so
    /// the tolerance holds in all of it (0: Frisken's pruning, accuracy at the surface).
    #[arg(long, default_value_t = 0.0)]
    pub band: f64,
    /// Points (within 2 % of the diagonal of the surface) the errors are measured at:
    /// 1 to 10,000,000 (each may take up to 200 exact distance queries to find).
    #[arg(long, default_value_t = 20_000)]
    pub points: usize,
    /// Image size of the render (square), 1 to 16384.
    #[arg(long, default_value_t = 512)]
    pub size: u32,
    /// Refuse builds estimated to need more memory than this (e.g. 512M, 8G), and stop
    /// a build that passes it; default: the machine's available memory.
    #[arg(long, value_parser = crate::parse_size)]
    pub memory_limit: Option<u64>,
}

/// Most `--points`: 10⁷ points give error figures far finer than any tolerance needs,
/// and take up to 2·10⁹ exact distance queries to find.
pub const MAX_POINTS: usize = 10_000_000;

/// Bytes per `--probes-out` point held while writing: the probe (48), its JSON value
/// (6 numbers) and its text.
const PROBE_OUT_BYTES: u64 = 48 + 6 * 48 + 160;

/// Bytes of the walk index besides its 4 bytes per cell (`walk.rs`: a 128³ grid of
/// node indices, minima and reaches; measured 49 MB with the bunny's 6.97 M cells).
const WALK_GRID_BYTES: u64 = 128 * 128 * 128 * 16;

#[derive(Args)]
pub struct AdfBuildArgs {
    #[command(flatten)]
    pub adf: AdfArgs,
    /// Output directory: adf.json (statistics) and adf.png (shaded render).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the ADF as an OpenVDB level set (.vdb): its reconstruction at the voxel
    /// centres of a narrow band (`Adf::to_narrow_band`), world units.
    #[arg(long)]
    pub vdb: Option<PathBuf>,
    /// Voxels along the longest side of the mesh's box for --vdb, 8 to 4096.
    #[arg(long, default_value_t = 256)]
    pub vdb_resolution: u32,
    /// Half-width of the --vdb band in voxels, 1 to 64 (the level set's background).
    #[arg(long, default_value_t = 3.0)]
    pub vdb_band: f64,
    #[command(flatten)]
    pub vdb_options: crate::voxelize::VdbArgs,
    /// Also write the ADF's zero iso-surface as a mesh (.obj or .ply), extracted on a
    /// lattice of --mesh-resolution cells along the longest side of the mesh's box.
    #[arg(long = "mesh", id = "mesh_out", value_name = "MESH_OUT")]
    pub mesh_out: Option<PathBuf>,
    /// Lattice cells along the longest side of the mesh's box for --mesh, 8 to 4096.
    #[arg(long, default_value_t = 256)]
    pub mesh_resolution: u32,
    /// Extract --mesh on the ADF's own leaves (its dual grid: a leaf of any size is meshed
    /// at its own size, no lattice) instead of a lattice of --mesh-resolution cells; by
    /// --mesh-method cubes or tetrahedra, --mesh-adaptivity counted in the finest leaf's
    /// size.
    #[arg(long, conflicts_with = "mesh_resolution")]
    pub mesh_on_leaves: bool,
    #[command(flatten)]
    pub mesh_args: crate::mesh_out::MeshArgs,
}

/// `--mesh --mesh-on-leaves`: the surface on the ADF's own leaves, refused (exit 1) when
/// the dual grid or the surface would pass `memory_limit`.
fn mesh_on_leaves(
    adf: &Adf,
    args: &crate::mesh_out::MeshArgs,
    memory_limit: u64,
    path: &std::path::Path,
) -> Result<volga_mesh::Surface, Failure> {
    let (method, adaptivity) = args.checked()?;
    let leaves = adf.stats().leaves as u64;
    let needed = leaves.saturating_mul(volga_mesh::TREE_BYTES_PER_LEAF);
    if needed > memory_limit {
        return Err(failed(format!(
            "--mesh {}: the dual grid of {leaves} leaves needs {} ({needed} bytes), more than the memory limit {} ({memory_limit} bytes)",
            path.display(),
            volga_core::memory::Bytes(needed as u128),
            volga_core::memory::Bytes(memory_limit as u128)
        )));
    }
    let finest = adf.cell_size(adf.stats().depth_reached);
    let max_triangles = (memory_limit - needed) / (volga_mesh::BYTES_PER_TRIANGLE + 64);
    adf.to_mesh_on_leaves(method, adaptivity * finest, max_triangles)
        .map_err(|e| match e {
            volga_mesh::ExtractError::TooManyTriangles { .. } => failed(format!("--mesh {}: {e}", path.display())),
            e => bad_input(format!("--mesh {}: {e}", path.display())),
        })
}

/// The grid of a `--vdb` level set: `resolution` voxels along the longest side of the
/// mesh's box, grown by the band and one voxel on every side.
fn vdb_grid(bounds: &Aabb, resolution: u32, band: f64) -> Result<volga_core::Grid, Failure> {
    let h = bounds.size().max_element() / resolution as f64;
    let pad = glam::DVec3::splat((band + 1.0) * h);
    let (lo, hi) = (bounds.min - pad, bounds.max + pad);
    let dims = ((hi - lo) / h).ceil().as_uvec3() + glam::UVec3::ONE;
    let transform =
        volga_core::Transform::new(lo, glam::DVec3::splat(h)).map_err(|e| bad_input(format!("--vdb: {e}")))?;
    volga_core::Grid::new(transform, dims).map_err(|e| bad_input(format!("--vdb: {e}")))
}

#[derive(Args)]
pub struct AdfBenchArgs {
    #[command(flatten)]
    pub adf: AdfArgs,
    /// Timed builds; the median is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..))]
    pub repeat: u64,
    /// Timed frames of the render; the median is reported.
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// Print one JSON object (the only output format; accepted for symmetry with the
    /// other benchmarks).
    #[arg(long)]
    pub json: bool,
    /// Also write the error probes (points, exact signed distances, ADF values) and the
    /// bounding-box diagonal to this JSON file (layout in docs/ADF.md), written atomically.
    #[arg(long)]
    pub probes_out: Option<PathBuf>,
}

struct Built {
    estimate: BuildEstimate,
    mesh_bounds: Aabb,
    source: MeshSource,
    adf: Adf,
    build_times: Vec<f64>,
}

/// The flags' own bounds, checked before anything is read (exit 2 naming the flag).
fn check_flags(args: &AdfArgs) -> Result<(), Failure> {
    if !(args.tolerance.is_finite() && args.tolerance > 0.0) {
        return Err(bad_input(format!(
            "--tolerance {}: must be a finite number > 0 (a fraction of the mesh's bounding-box diagonal)",
            args.tolerance
        )));
    }
    if args.max_depth > MAX_SUPPORTED_DEPTH {
        return Err(bad_input(format!(
            "--max-depth {}: must be at most {MAX_SUPPORTED_DEPTH}",
            args.max_depth
        )));
    }
    if !(args.band.is_finite() && args.band >= 0.0) {
        return Err(bad_input(format!(
            "--band {}: must be a finite number ≥ 0 (a fraction of the diagonal)",
            args.band
        )));
    }
    if !(1..=MAX_POINTS).contains(&args.points) {
        return Err(bad_input(format!(
            "--points {}: must be 1 to {MAX_POINTS} (the errors are measured at these points; with none there is no error to report)",
            args.points
        )));
    }
    let side = (volga_render::MAX_PIXELS as f64).sqrt() as u32;
    if !(1..=side).contains(&args.size) {
        return Err(bad_input(format!(
            "--size {}: must be 1 to {side} (a {0}² image; at most {} pixels)",
            args.size,
            volga_render::MAX_PIXELS
        )));
    }
    Ok(())
}

/// `--out` must be a directory or creatable as one: refused before the build if it, or
/// the nearest of its ancestors that exists, is not a directory.
fn check_out_dir(out: &Path) -> Result<(), Failure> {
    let mut p = Some(out);
    while let Some(dir) = p {
        if let Ok(meta) = std::fs::metadata(dir) {
            if meta.is_dir() {
                return Ok(());
            }
            let what = if dir == out { "is" } else { "lies under" };
            return Err(bad_input(format!(
                "--out {}: {what} an existing file{}, not a directory",
                out.display(),
                if dir == out {
                    String::new()
                } else {
                    format!(" ({})", dir.display())
                }
            )));
        }
        p = dir.parent().filter(|d| !d.as_os_str().is_empty());
    }
    Ok(())
}

/// Bytes per triangle of the mesh and its source (positions, indices, triangles,
/// boxes, normals, scan blocks, BVH, winding-number data). The peak resident memory of
/// `volga adf MESH --tolerance 0.5 --points 1 --size 8` grows by 1,742 bytes per
/// triangle from spot (5,856 triangles, 16.5 MB) to the bunny (69,451, 124.7 MB), at
/// commit c4e77b1; this keeps a margin above it.
const SOURCE_BYTES_PER_TRIANGLE: u64 = 2048;

/// The memory of everything but the ADF's build: the mesh and its source, the walk
/// index (its grid, and 4 bytes per cell), the image, and (with `--probes-out`) the
/// probes.
fn other_bytes(args: &AdfArgs, triangles: usize, estimate: &BuildEstimate, probes_out: bool) -> u64 {
    let image = u64::from(args.size).pow(2) * (16 + 16 + 4 + 4);
    let probes = if probes_out {
        args.points as u64 * PROBE_OUT_BYTES
    } else {
        0
    };
    let source = triangles as u64 * SOURCE_BYTES_PER_TRIANGLE;
    let walk = WALK_GRID_BYTES.saturating_add(estimate.cells.saturating_mul(4));
    source.saturating_add(walk).saturating_add(image).saturating_add(probes)
}

/// Refuses (exit 1) a build whose estimate does not fit the memory limit, with the cells
/// and bytes needed; returns the cell limit the build stops at.
fn check_memory(
    args: &AdfArgs,
    triangles: usize,
    estimate: &BuildEstimate,
    probes_out: bool,
) -> Result<usize, Failure> {
    let (limit, which) = match args.memory_limit {
        Some(l) => (l, "--memory-limit"),
        None => (
            volga_core::memory::available_bytes().unwrap_or(u64::MAX),
            "the memory available (--memory-limit)",
        ),
    };
    let other = other_bytes(args, triangles, estimate, probes_out);
    let needed = estimate.build_bytes.saturating_add(other);
    if needed > limit {
        return Err(bad_input(format!(
            "--tolerance {} (--max-depth {}): the ADF needs about {} cells, {} while building, plus {} for the mesh and the render{}: {} in all, more than {which}, {}; raise --tolerance or lower --max-depth",
            args.tolerance,
            args.max_depth,
            estimate.cells,
            Bytes(u128::from(estimate.build_bytes)),
            Bytes(u128::from(other)),
            if probes_out { " and the probes" } else { "" },
            Bytes(u128::from(needed)),
            Bytes(u128::from(limit)),
        )));
    }
    Ok(BuildEstimate::cells_within(limit - other))
}

fn build(args: &AdfArgs, repeat: u64, probes_out: bool, progress: &dyn Progress) -> Result<Built, Failure> {
    check_flags(args)?;
    let mesh = volga_mesh::load_mesh(&args.mesh).map_err(|e| bad_input(e.to_string()))?;
    let source = MeshSource::new(&mesh).map_err(|e| bad_input(format!("{}: {e}", args.mesh.display())))?;
    let bounds = mesh.bounds();
    let diagonal = bounds.size().length();
    let mut options = AdfOptions {
        max_depth: args.max_depth,
        band: args.band * diagonal,
        ..AdfOptions::relative(args.tolerance, &bounds)
    };
    if !(options.tolerance > 0.0 && options.tolerance.is_finite()) {
        return Err(bad_input(format!(
            "--tolerance {}: {} (the mesh's diagonal) times it is {}, not a positive distance",
            args.tolerance, diagonal, options.tolerance
        )));
    }
    let estimate = Adf::estimate(&source, &options).map_err(|e| bad_input(format!("{}: {e}", args.mesh.display())))?;
    options.max_cells = check_memory(args, mesh.triangle_count(), &estimate, probes_out)?;
    let mut times = Vec::new();
    let mut adf = None;
    for _ in 0..repeat {
        drop(adf.take());
        let start = Instant::now();
        let built = Adf::build_with_progress(&source, options, progress).map_err(|e| match e {
            volga_adf::AdfError::TooManyCells { .. } => failed(format!(
                "--tolerance {} (--max-depth {}): {e} (estimated {} cells)",
                args.tolerance, args.max_depth, estimate.cells
            )),
            e => bad_input(format!("{}: {e}", args.mesh.display())),
        })?;
        times.push(start.elapsed().as_secs_f64());
        adf = Some(built);
    }
    Ok(Built {
        estimate,
        mesh_bounds: bounds,
        source,
        adf: adf.expect("at least one build"),
        build_times: times,
    })
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

/// A camera in front of and above `bounds`, framing it.
fn camera(bounds: &Aabb) -> Result<Camera, Failure> {
    let centre = bounds.center();
    let radius = 0.5 * bounds.size().length();
    let dir = DVec3::new(0.35, 0.45, 1.0).normalize();
    let fov = 30.0f64;
    Camera::look_at(
        centre + dir * radius / (fov.to_radians() * 0.5).sin(),
        centre,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: fov },
    )
    .map_err(|e| failed(e.to_string()))
}

/// Statistics and accuracy as JSON (errors relative to the bounding-box diagonal), and the
/// points the errors were measured at.
/// Errors are `null` when no point was measured (every candidate fell in a pruned leaf):
/// 0 would read as a perfect build.
fn report(b: &Built, args: &AdfArgs, keep_probes: bool) -> (Value, Vec<Probe>) {
    let diagonal = b.mesh_bounds.size().length();
    let band = 0.02 * diagonal;
    let (errors, probes) = if keep_probes {
        measure_errors_with_probes(&b.adf, &b.source, &b.mesh_bounds, band, args.points)
    } else {
        (
            measure_errors(&b.adf, &b.source, &b.mesh_bounds, band, args.points),
            Vec::new(),
        )
    };
    let relative = |e: f64, e_stats: &ErrorStats| (e_stats.points > 0).then_some(e / diagonal);
    let s = b.adf.stats();
    let value = json!({
        "mesh": args.mesh.display().to_string(),
        "tolerance": args.tolerance,
        "max_depth": args.max_depth,
        "threads": rayon::current_num_threads(),
        "build_s": median(&b.build_times),
        "build_times_s": b.build_times,
        "cells": s.cells,
        "estimated_cells": b.estimate.cells,
        "estimated_build_bytes": b.estimate.build_bytes,
        "leaves": s.leaves,
        "pruned_leaves": s.pruned_leaves,
        "jump_leaves": s.jump_leaves,
        "max_depth_leaves": s.max_depth_leaves,
        "depth_reached": s.depth_reached,
        "evaluations": s.evaluations,
        "bytes": b.adf.memory_bytes(),
        "max_error": relative(errors.max, &errors),
        "rms_error": relative(errors.rms, &errors),
        "max_error_below_max_depth": relative(errors.max_below_max_depth, &errors),
        "error_points": errors.points,
        "error_points_at_max_depth": errors.points_at_max_depth,
        "error_points_pruned": errors.points_pruned,
        "source_queries": b.source.queries(),
        "integer_winding_queries": b.source.integer_queries(),
        "sign_differences": errors.sign_differences,
    });
    (value, probes)
}

/// The probe file of `--probes-out` (format `volga-adf-probes/1`, see docs/ADF.md).
fn probes_json(b: &Built, args: &AdfArgs, probes: &[Probe]) -> Value {
    let diagonal = b.mesh_bounds.size().length();
    json!({
        "format": "volga-adf-probes/1",
        "mesh": args.mesh.display().to_string(),
        "bounds_min": b.mesh_bounds.min.to_array(),
        "bounds_max": b.mesh_bounds.max.to_array(),
        "diagonal": diagonal,
        "tolerance_relative": args.tolerance,
        "tolerance_world": args.tolerance * diagonal,
        "band_world": 0.02 * diagonal,
        "columns": ["x", "y", "z", "exact_signed_distance", "adf_distance", "at_max_depth"],
        "probes": probes
            .iter()
            .map(|p| json!([p.world_pos.x, p.world_pos.y, p.world_pos.z, p.exact, p.reconstructed, p.at_max_depth as u8]))
            .collect::<Vec<_>>(),
    })
}

/// The shaded iso-surface `d = 0` at `size`².
fn render_setup(size: u32) -> (RenderSettings, Iso) {
    let settings = RenderSettings::new(size, size);
    let iso = Iso {
        value: 0.0,
        colour: SurfaceColour::Constant(Vec3::new(0.85, 0.8, 0.7)),
    };
    (settings, iso)
}

/// `volga adf MESH --out DIR`.
pub fn run(args: AdfBuildArgs, progress: &dyn Progress) -> Result<(), Failure> {
    check_flags(&args.adf)?;
    check_out_dir(&args.out)?;
    let vdb_options = match &args.vdb {
        Some(path) => {
            if !(8..=4096).contains(&args.vdb_resolution) {
                return Err(bad_input(format!(
                    "--vdb-resolution {}: must be 8 to 4096",
                    args.vdb_resolution
                )));
            }
            if !(args.vdb_band.is_finite() && (1.0..=64.0).contains(&args.vdb_band)) {
                return Err(bad_input(format!(
                    "--vdb-band {}: must be 1 to 64 voxels",
                    args.vdb_band
                )));
            }
            if volga_io::VoxelFormat::from_path(path).ok() != Some(volga_io::VoxelFormat::Vdb) {
                return Err(bad_input(format!("--vdb {}: must name a .vdb file", path.display())));
            }
            Some(args.vdb_options.options(path)?)
        }
        None => {
            if args.vdb_options.vdb_compression.is_some() || args.vdb_options.vdb_half {
                return Err(bad_input("--vdb-compression and --vdb-half need --vdb".to_string()));
            }
            None
        }
    };
    args.mesh_args.checked()?;
    match &args.mesh_out {
        Some(p) => {
            crate::mesh_out::check_mesh_path(p)?;
            if args.mesh_on_leaves && args.mesh_args.checked()?.0 == volga_mesh::ExtractMethod::Dual {
                return Err(bad_input(
                    "--mesh-on-leaves: --mesh-method dual does not run on the leaves (use cubes or tetrahedra)"
                        .to_string(),
                ));
            }
            if !(8..=4096).contains(&args.mesh_resolution) {
                return Err(bad_input(format!(
                    "--mesh-resolution {}: must be 8 to 4096",
                    args.mesh_resolution
                )));
            }
        }
        None if args.mesh_args.given() || args.mesh_on_leaves => {
            return Err(bad_input(
                "--mesh-method, --mesh-adaptivity and --mesh-on-leaves need --mesh".to_string(),
            ))
        }
        None => {}
    }
    let built = build(&args.adf, 1, false, progress)?;
    let mesh_out = match &args.mesh_out {
        Some(path) if args.mesh_on_leaves => {
            let limit = args.adf.memory_limit.unwrap_or_else(volga_core::memory::input_limit);
            let start = Instant::now();
            let surface = mesh_on_leaves(&built.adf, &args.mesh_args, limit, path)?;
            Some((path.clone(), surface, start.elapsed().as_secs_f64()))
        }
        Some(path) => {
            let b = built.mesh_bounds;
            let cell = b.size().max_element() / args.mesh_resolution as f64;
            let region = Aabb::new(b.min - 2.0 * cell, b.max + 2.0 * cell);
            let limit = args.adf.memory_limit.unwrap_or_else(volga_core::memory::input_limit);
            let start = Instant::now();
            let surface = crate::mesh_out::extract(&built.adf, region, cell, 0.0, &args.mesh_args, limit, path)?;
            Some((path.clone(), surface, start.elapsed().as_secs_f64()))
        }
        None => None,
    };
    let level_set = match (&args.vdb, vdb_options) {
        (Some(path), Some(options)) => {
            let grid = vdb_grid(&built.mesh_bounds, args.vdb_resolution, args.vdb_band)?;
            // Every brick of the grid dense at worst: refuse before sampling.
            let ext = volga_core::brick_extent(grid.dims()).as_u64vec3();
            let worst = (ext.x * ext.y * ext.z).saturating_mul(512 * 4 + 48);
            let limit = args.adf.memory_limit.unwrap_or_else(volga_core::memory::input_limit);
            if worst > limit {
                return Err(bad_input(format!(
                    "--vdb-resolution {}: the band may need {} ({worst} bytes), more than the memory limit {} ({limit} bytes)",
                    args.vdb_resolution,
                    volga_core::memory::Bytes(worst as u128),
                    volga_core::memory::Bytes(limit as u128)
                )));
            }
            let h = grid.transform.spacing().x;
            let volume = built.adf.to_narrow_band(grid, args.vdb_band * h);
            Some((path.clone(), volume, options))
        }
        _ => None,
    };
    let (mut value, _) = report(&built, &args.adf, false);
    if let Some((path, volume, options)) = &level_set {
        let d = volume.grid.dims();
        value["vdb"] = json!({
            "path": path,
            "dims": [d.x, d.y, d.z],
            "voxel_size": volume.grid.transform.spacing().x,
            "band_world": volume.density.background(),
            "band_voxels": volga_io::vdb_active_voxels(volume),
            "compression": options.compression.name(),
            "half": options.half,
        });
    }
    if let Some((path, surface, seconds)) = &mesh_out {
        value["mesh"] = json!({
            "path": path,
            "method": args.mesh_args.mesh_method,
            "adaptivity": args.mesh_args.mesh_adaptivity,
            "on_leaves": args.mesh_on_leaves,
            "triangles": surface.mesh.triangle_count(),
            "vertices": surface.mesh.positions.len(),
            "seconds": seconds,
        });
    }
    let (settings, iso) = render_setup(args.adf.size);
    let renderer = Renderer::new(&built.adf, &iso, &settings).map_err(|e| failed(e.to_string()))?;
    let start = Instant::now();
    let (image, _) = renderer.render(&camera(&built.mesh_bounds)?, &NoProgress);
    value["render_s"] = json!(start.elapsed().as_secs_f64());
    std::fs::create_dir_all(&args.out).map_err(|e| failed(format!("{}: {e}", args.out.display())))?;
    let mut staged = volga_io::StagedOutputs::new();
    let text = serde_json::to_string_pretty(&value).expect("json");
    let io = |e: volga_io::IoError| failed(e.to_string());
    staged
        .stage(&args.out.join("adf.json"), |w| w.write_all(text.as_bytes()))
        .map_err(io)?;
    let rgba = image.to_rgba8();
    staged
        .stage(&args.out.join("adf.png"), |w| {
            volga_io::encode_png(w, image.width, image.height, &rgba)
        })
        .map_err(io)?;
    if let Some((path, surface, _)) = &mesh_out {
        let bytes = crate::mesh_out::mesh_bytes(path, surface);
        volga_io::check_free_space_for(&[(path.clone(), bytes.len() as u64)]).map_err(io)?;
        staged.stage(path, |w| w.write_all(&bytes)).map_err(io)?;
    }
    if let Some((path, volume, options)) = &level_set {
        volga_io::check_free_space_for(&[(path.clone(), volga_io::vdb_bytes_bound(volume, options.half))])
            .map_err(io)?;
        volga_io::write_vdb(path, volume, options, &mut staged).map_err(io)?;
    }
    staged.commit().map_err(io)?;
    println!("{text}");
    Ok(())
}

/// `volga bench adf MESH --tolerance T --json`.
pub fn bench(args: AdfBenchArgs) -> Result<(), Failure> {
    let probes_out = args.probes_out.is_some();
    let built = build(&args.adf, args.repeat, probes_out, &NoProgress)?;
    let (mut value, probes) = report(&built, &args.adf, probes_out);
    if let Some(path) = &args.probes_out {
        let text = serde_json::to_string(&probes_json(&built, &args.adf, &probes)).expect("json");
        volga_io::write_atomic(path, |w| w.write_all(text.as_bytes()))
            .map_err(|e| failed(format!("--probes-out {}: {e}", path.display())))?;
        value["probes_out"] = json!(path.display().to_string());
    }
    let (settings, iso) = render_setup(args.adf.size);
    let cam = camera(&built.mesh_bounds)?;
    // The walk index is built before the timed frames; its time and memory are reported.
    let (index_s, index_bytes) = timed_cpu(|| built.adf.walk_index_bytes());
    value["walk_index_build_s"] = json!(index_s.0);
    value["walk_index_bytes"] = json!(index_bytes);
    value["walk_reach_bytes"] = json!(built.adf.walk_reach_bytes());
    // The reference walk (no index), rendered in the same run for a ratio against the index.
    let descent = DescentWalk(&built.adf);
    let (descent_frames, descent_cpu, _) = time_frames(&descent, &iso, &settings, &cam, args.frames)?;
    value["render_fps_descent"] = json!(1.0 / median(&descent_frames));
    value["render_cpu_s_descent"] = json!(median(&descent_cpu));
    // The indexed walk one ray at a time (before batching), in the same run.
    let one_ray = OneRayWalk(&built.adf);
    let (one_ray_frames, one_ray_cpu, _) = time_frames(&one_ray, &iso, &settings, &cam, args.frames)?;
    value["render_fps_one_ray"] = json!(1.0 / median(&one_ray_frames));
    value["render_cpu_s_one_ray"] = json!(median(&one_ray_cpu));
    let (frames, cpu, warm) = time_frames(&built.adf, &iso, &settings, &cam, args.frames)?;
    value["render_size"] = json!(args.adf.size);
    value["render_fps"] = json!(1.0 / median(&frames));
    value["render_times_s"] = json!(frames);
    value["render_cpu_s"] = json!(median(&cpu));
    value["loadavg"] = json!(std::fs::read_to_string("/proc/loadavg").unwrap_or_default().trim());
    value["render_samples"] = json!(warm.samples);
    value["render_rays"] = json!(warm.rays);
    value["render_cells_skipped"] = json!(warm.cells_skipped);
    value["render_gradient_evaluations"] = json!(warm.gradient_evaluations);
    let walk_start = Instant::now();
    let (leaves, hits) = leaves_per_ray(&built.adf, &cam, args.adf.size, false);
    value["ray_walk_s_one_thread"] = json!(walk_start.elapsed().as_secs_f64());
    value["ray_leaves_mean"] = json!(leaves as f64 / (args.adf.size as f64).powi(2));
    value["ray_hits"] = json!(hits);
    value["ray_walk_s_one_thread_batched"] = json!(batched_walk_s(&built.adf, &cam, args.adf.size));
    let walk_start = Instant::now();
    let (leaves, hits) = leaves_per_ray(&built.adf, &cam, args.adf.size, true);
    value["ray_walk_s_one_thread_descent"] = json!(walk_start.elapsed().as_secs_f64());
    value["ray_leaves_mean_descent"] = json!(leaves as f64 / (args.adf.size as f64).powi(2));
    value["ray_hits_descent"] = json!(hits);
    println!("{value}");
    Ok(())
}

/// Timed frames (after one warm-up): wall seconds, CPU seconds (all threads) per frame,
/// and the warm-up's counters.
fn time_frames<F: Field + ?Sized>(
    field: &F,
    iso: &Iso,
    settings: &RenderSettings,
    cam: &Camera,
    frames: usize,
) -> Result<(Vec<f64>, Vec<f64>, volga_render::RenderStats), Failure> {
    let renderer = Renderer::new(field, iso, settings).map_err(|e| failed(e.to_string()))?;
    let (_, warm) = renderer.render(cam, &NoProgress);
    let mut wall = Vec::new();
    let mut cpu = Vec::new();
    for _ in 0..frames.max(1) {
        let (c, _) = timed_cpu(|| renderer.render(cam, &NoProgress));
        wall.push(c.0);
        cpu.push(c.1);
    }
    Ok((wall, cpu, warm))
}

/// CPU time of the whole process so far (every thread), in nanoseconds, from
/// `/proc/self/task/*/schedstat`; `None` where that is not readable.
fn process_cpu_ns() -> Option<u64> {
    let mut total = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

/// `((wall s, CPU s of all threads), result)` of `f` (CPU NaN where unknown).
fn timed_cpu<T>(f: impl FnOnce() -> T) -> ((f64, f64), T) {
    let cpu0 = process_cpu_ns();
    let start = Instant::now();
    let out = f();
    let wall = start.elapsed().as_secs_f64();
    let cpu = match (cpu0, process_cpu_ns()) {
        (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-9,
        _ => f64::NAN,
    };
    ((wall, cpu), out)
}

/// Seconds (one thread) of the batched walk ([`Adf::first_crossings_between`]) over the
/// camera's pixel-centre rays, a 16×16 tile's rays per batch as the renderer asks them.
fn batched_walk_s(adf: &Adf, camera: &Camera, size: u32) -> f64 {
    let tile = 16;
    let mut rays = Vec::new();
    let mut out = Vec::new();
    let start = Instant::now();
    for ty in (0..size).step_by(tile) {
        for tx in (0..size).step_by(tile) {
            rays.clear();
            for y in ty..(ty + tile as u32).min(size) {
                for x in tx..(tx + tile as u32).min(size) {
                    let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5, size, size);
                    let (t0, t1) = adf.root_box().ray_interval(ray.origin, ray.dir).unwrap_or((0.0, -1.0));
                    rays.push(volga_core::CrossingRay {
                        world_origin: ray.origin,
                        world_dir: ray.dir,
                        t0,
                        t1,
                    });
                }
            }
            out.resize(rays.len(), (None, 0));
            adf.first_crossings_between(&rays, 0.0, &mut out);
            std::hint::black_box(&out);
        }
    }
    start.elapsed().as_secs_f64()
}

/// Steps of the ray walk over the camera's pixel-centre rays (the work of the iso
/// render's leaf walk), and the rays that hit: the indexed walk, or the reference walk
/// without the index (`descent`).
fn leaves_per_ray(adf: &Adf, camera: &Camera, size: u32, descent: bool) -> (u64, u64) {
    let mut leaves = 0u64;
    let mut hits = 0u64;
    for y in 0..size {
        for x in 0..size {
            let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5, size, size);
            let (t0, t1) = adf.root_box().ray_interval(ray.origin, ray.dir).unwrap_or((0.0, -1.0));
            let (hit, steps) = if descent {
                adf.first_crossing_by_descent(ray.origin, ray.dir, t0, t1, 0.0)
            } else {
                adf.first_crossing_between(ray.origin, ray.dir, t0, t1, 0.0)
            };
            leaves += steps as u64;
            hits += hit.is_some() as u64;
        }
    }
    (leaves, hits)
}
