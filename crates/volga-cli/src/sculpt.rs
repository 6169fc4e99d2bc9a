//! `volga sculpt`: apply a stroke file to a saved sculpt (or to the stroke file's start
//! object) and write the sculpt, a mesh, a voxel model and an image, all or nothing.
//!
//! Prints one JSON object: strokes applied, the world box each changed, node counts and
//! memory, and the files written.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use glam::{DVec3, Vec3};
use serde_json::json;
use volga_core::memory::Bytes;
use volga_core::{NoProgress, Progress};
use volga_io::{StagedOutputs, VoxelFormat};

/// Bytes a mesh file named by a stroke file may take to parse when the available memory is unknown.
const FALLBACK_MEMORY_LIMIT: u64 = 4 << 30;
use volga_render::{Camera, Iso, Projection, RenderSettings, Renderer, SurfaceColour};
use volga_scene::strokes::{parse_stroke_file, start_sculpt, validate_strokes};
use volga_sculpt::{Sculpt, BRICK_BYTES_BOUND};

use crate::failure::{bad_input, failed, Failure};

#[derive(Args)]
pub struct SculptArgs {
    /// The stroke file (.ron or .json).
    #[arg(long)]
    strokes: PathBuf,
    /// A saved sculpt to start from (else the stroke file's `start`).
    #[arg(long)]
    sculpt: Option<PathBuf>,
    /// Write the sculpt here (versioned binary, checksummed).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the ½ iso-surface as a mesh (.obj or .ply).
    #[arg(long)]
    mesh: Option<PathBuf>,
    #[command(flatten)]
    mesh_args: crate::mesh_out::MeshArgs,
    /// Write the voxels (.nrrd, .binvox or .vdb: a fog volume of the densities, with a
    /// `color` grid).
    #[arg(long)]
    volume: Option<PathBuf>,
    #[command(flatten)]
    vdb_args: crate::voxelize::VdbArgs,
    /// Render the sculpt (iso-surface, its colours) to this PNG.
    #[arg(long)]
    image: Option<PathBuf>,
    /// Image width and height.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=8192))]
    size: u32,
    /// Refuse work estimated to need more memory than this (e.g. 512M, 8G): reading the
    /// sculpt and the stroke file's meshes, sampling the start object, the outputs;
    /// default: the machine's available memory.
    #[arg(long, value_parser = crate::parse_size)]
    memory_limit: Option<u64>,
    /// Let the stroke file read mesh tools outside its own folder (absolute paths, `..`
    /// above it); by default only files inside it are read.
    #[arg(long)]
    allow_outside_paths: bool,
}

pub fn run(args: SculptArgs) -> Result<(), Failure> {
    volga_core::memory::set_input_limit(args.memory_limit);
    let limit = args
        .memory_limit
        .or_else(volga_core::memory::available_bytes)
        .unwrap_or(FALLBACK_MEMORY_LIMIT);
    let file = parse_stroke_file(&args.strokes).map_err(|e| bad_input(e.to_string()))?;
    let mut sculpt = match (&args.sculpt, &file.start) {
        // Regular files only, refused before reading if too large for memory; the error
        // names the file ("PATH: what is wrong").
        (Some(path), _) => Sculpt::open_with_limit(path, limit / 2).map_err(|e| bad_input(e.to_string()))?,
        (None, Some(start)) => {
            start_sculpt(&args.strokes, start, limit, args.allow_outside_paths).map_err(|e| bad_input(e.to_string()))?
        }
        (None, None) => {
            return Err(bad_input(format!(
                "{}: no `start` in the stroke file and no --sculpt to apply it to",
                args.strokes.display()
            )))
        }
    };
    let strokes = validate_strokes(&args.strokes, &file, sculpt.grid().spacing(), args.allow_outside_paths)
        .map_err(|e| bad_input(e.to_string()))?;
    let mesh_format = match &args.mesh {
        Some(p) => match p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("obj") => Some(false),
            Some("ply") => Some(true),
            _ => return Err(bad_input(format!("--mesh {}: expected .obj or .ply", p.display()))),
        },
        None => None,
    };
    let (mesh_method, mesh_adaptivity) = args.mesh_args.checked()?;
    if args.mesh.is_none() && args.mesh_args.given() {
        return Err(bad_input("--mesh-method and --mesh-adaptivity need --mesh".to_string()));
    }
    let voxel_format = match &args.volume {
        Some(p) => Some(VoxelFormat::from_path(p).map_err(|e| bad_input(format!("--volume: {e}")))?),
        None => None,
    };
    let vdb = match &args.volume {
        Some(p) => args.vdb_args.options(p)?,
        None if args.vdb_args.vdb_compression.is_some() || args.vdb_args.vdb_half => {
            return Err(bad_input(
                "--vdb-compression and --vdb-half need --volume X.vdb".to_string(),
            ))
        }
        None => Default::default(),
    };
    // Every output a different file, whatever the spelling of its path.
    let mut outputs: Vec<(String, PathBuf)> = Vec::new();
    for (flag, path) in [("--out", &args.out), ("--mesh", &args.mesh), ("--image", &args.image)] {
        if let Some(p) = path {
            outputs.push((format!("{flag} {}", p.display()), p.clone()));
        }
    }
    if let (Some(p), Some(format)) = (&args.volume, voxel_format) {
        for file in format.output_paths(p, true) {
            outputs.push((format!("--volume {} (writes {})", p.display(), file.display()), file));
        }
    }
    for (i, (a, pa)) in outputs.iter().enumerate() {
        for (b, pb) in &outputs[..i] {
            if volga_io::output_identity(pa) == volga_io::output_identity(pb) {
                return Err(bad_input(format!(
                    "{a} and {b} are the same file: choose different outputs"
                )));
            }
        }
    }

    // The strokes' memory, bounded before any is applied.
    let too_large = |what: String, needed: u128| {
        bad_input(format!(
            "{what} needs up to {} ({needed} bytes), more than the memory limit of {} ({limit} bytes); raise --memory-limit or use fewer voxels",
            Bytes(needed),
            Bytes(limit as u128)
        ))
    };
    let mut octree_bound = sculpt.stats().bytes as u128;
    for (i, stroke) in strokes.iter().enumerate() {
        octree_bound += sculpt.stroke_brick_bound(stroke) * BRICK_BYTES_BOUND as u128;
        if octree_bound > limit as u128 {
            return Err(too_large(
                format!("applying strokes[0..={i}] of {}", args.strokes.display()),
                octree_bound,
            ));
        }
    }
    if args.image.is_some() {
        // Float and 8-bit pixels, and the PNG.
        let needed = args.size as u128 * args.size as u128 * 24;
        if needed > limit as u128 {
            return Err(too_large(format!("--image at --size {}", args.size), needed));
        }
    }

    let start = Instant::now();
    let progress = crate::progress::BarProgress::new();
    let mut changed = Vec::new();
    progress.start("strokes", strokes.len() as u64);
    for stroke in &strokes {
        let report = sculpt.apply(stroke);
        changed.push(report.changed_world.map(|b| [b.min.to_array(), b.max.to_array()]));
        progress.inc(1);
    }
    progress.finish();
    let edit_s = start.elapsed().as_secs_f64();
    let stats = sculpt.stats();
    if let Some(path) = &args.volume {
        let (bricks, needed) = sculpt.sparse_volume_bytes(true);
        if needed > limit as u128 {
            return Err(too_large(
                format!("--volume {} ({bricks} bricks of 8³ voxels)", path.display()),
                needed,
            ));
        }
    }

    let mut staged = StagedOutputs::new();
    let io = |e: volga_io::IoError| failed(e.to_string());
    if let Some(out) = &args.out {
        let bytes = sculpt.to_bytes();
        staged.stage(out, |w| w.write_all(&bytes)).map_err(io)?;
    }
    let mut triangles = None;
    if let (Some(path), Some(ply)) = (&args.mesh, mesh_format) {
        let surface = sculpt
            .surface_with(
                1.0,
                mesh_method,
                mesh_adaptivity,
                limit / volga_mesh::BYTES_PER_TRIANGLE,
            )
            .map_err(|e| bad_input(format!("--mesh {}: {e}", path.display())))?;
        triangles = Some(surface.mesh.triangle_count());
        let bytes = if ply {
            volga_mesh::ply_bytes(&surface.mesh, Some(&surface.normals))
        } else {
            volga_mesh::obj_bytes(&surface.mesh, Some(&surface.normals))
        };
        staged.stage(path, |w| w.write_all(&bytes)).map_err(io)?;
    }
    if let (Some(path), Some(_)) = (&args.volume, voxel_format) {
        let volume = sculpt.to_sparse_volume(true);
        volga_io::write_voxel_model_with(path, &volume, &vdb, &mut staged).map_err(io)?;
    }
    if let Some(path) = &args.image {
        let rgba = render(&sculpt, args.size)?;
        staged
            .stage(path, |w| volga_io::encode_png(w, args.size, args.size, &rgba))
            .map_err(io)?;
    }
    let written = staged.commit().map_err(io)?;
    let out = json!({
        "strokes": strokes.len(),
        "edit_s": edit_s,
        "changed_world": changed,
        "nodes": stats.nodes(),
        "bricks": stats.bricks,
        "octree_bytes": stats.bytes,
        "voxels_per_axis": sculpt.grid().dims(),
        "mesh_triangles": triangles,
        "written": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    });
    println!("{out}");
    Ok(())
}

/// The iso-surface at ½ in the sculpt's colours, seen from the front (+z), slightly from
/// above and the right, framing the material.
pub fn render(sculpt: &Sculpt, size: u32) -> Result<Vec<u8>, Failure> {
    use volga_core::Field;
    let bounds = sculpt.content_bounds().unwrap_or_else(|| sculpt.bounds());
    let centre = bounds.center();
    let radius = 0.5 * bounds.size().length().max(sculpt.grid().spacing());
    let fov = 30.0f64;
    let dir = DVec3::new(0.35, 0.2, 1.0).normalize();
    let camera = Camera::look_at(
        centre + dir * (radius / (fov.to_radians() * 0.5).sin()),
        centre,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: fov },
    )
    .map_err(|e| failed(e.to_string()))?;
    let mut settings = RenderSettings::new(size, size);
    settings.lighting.lights[0].direction = DVec3::new(0.6, 0.8, 1.0);
    settings.lighting.ambient_colour = Vec3::splat(0.35);
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::FromField,
    };
    let renderer = Renderer::new(sculpt, &iso, &settings).map_err(|e| failed(e.to_string()))?;
    Ok(renderer.render(&camera, &NoProgress).0.to_rgba8())
}
