//! `volga build`: load → plan → voxelize → render → write, with a report.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use volga_core::{Progress, Sampled, SparseVolume};
use volga_io::StagedOutputs;
use volga_render::{render, RenderStats};
use volga_voxelize::{merge_max, voxelize_solids, MeshVoxelizer, SurfaceMode};

use crate::plan::{plan, Plan};
use crate::stages::{StageReport, Stages};
use crate::{load, BuildError, Scene, SceneError};

/// What `volga build` did, written to `{out}/report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub scene: PathBuf,
    pub volga_version: &'static str,
    pub threads: usize,
    pub grid: GridReport,
    pub plan: Plan,
    pub stages: Vec<StageReport>,
    pub voxels: VoxelReport,
    pub images: Vec<ImageReport>,
    pub outputs: Vec<PathBuf>,
    pub total_wall_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    pub dims: [u32; 3],
    pub voxel_size: [f64; 3],
    /// World position of voxel (0, 0, 0)'s centre.
    pub origin: [f64; 3],
    pub voxels: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct VoxelReport {
    /// Voxels with non-zero density.
    pub active: u64,
    pub bricks: usize,
    pub dense_bricks: usize,
    pub uniform_bricks: usize,
    pub colour_bricks: usize,
    pub volume_memory_bytes: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ImageReport {
    pub name: String,
    pub file: PathBuf,
    pub width: u32,
    pub height: u32,
    pub rays: u64,
    pub samples: u64,
    pub gradient_evaluations: u64,
    pub rays_terminated_early: u64,
    pub cells_skipped: u64,
}

/// Parses and validates a scene file.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let file = load::parse_file(path)?;
    crate::validate::validate(path, &file)
}

/// Options of a build.
#[derive(Debug, Clone)]
pub struct BuildOptions {
    pub out_dir: PathBuf,
    /// Refuse builds estimated to need more than this; `None`: the machine's available
    /// memory.
    pub memory_limit: Option<u64>,
}

/// Builds a scene: every output is staged under a temporary name and renamed only
/// once all of them are complete, so a failed build leaves earlier outputs intact.
pub fn build(path: &Path, options: &BuildOptions, progress: &dyn Progress) -> Result<Report, BuildError> {
    let start = Instant::now();
    let mut stages = Stages::default();
    let scene = stages.run("load", || load_scene(path))?;
    let plan = stages.run("plan", || plan(&scene, options.memory_limit))?;

    let mut volume = stages.run("voxelize", || {
        let mut volume = voxelize_solids(&scene.grid, &scene.solids, plan.colour_channel, progress);
        // Meshes join the fuzzy union after the analytic solids, in scene order.
        for m in &scene.meshes {
            let solid = MeshVoxelizer::new(&m.mesh).voxelize(&scene.grid, SurfaceMode::Solid, progress);
            merge_max(&mut volume, &solid, m.colour);
        }
        volume
    });
    let voxels = voxel_report(&volume);

    std::fs::create_dir_all(&options.out_dir).map_err(|source| volga_io::IoError::Io {
        path: options.out_dir.clone(),
        source,
    })?;
    let mut staged = StagedOutputs::new();
    let mut images = Vec::new();
    for job in &scene.images {
        let (image, stats) = stages
            .run(format!("render:{}", job.name), || {
                let field = Sampled::new(&volume, job.filter);
                render(&field, &job.camera, &job.mode, &job.settings, progress)
            })
            .map_err(|e| BuildError::Render {
                image: job.name.clone(),
                message: e.to_string(),
            })?;
        let file = options.out_dir.join(format!("{}.png", job.name));
        stages.run(format!("encode:{}", job.name), || {
            let rgba = image.to_rgba8();
            staged.stage(&file, |w| volga_io::encode_png(w, image.width, image.height, &rgba))
        })?;
        images.push(image_report(&job.name, file, &image, stats));
    }

    let outputs = stages.run("write", || -> Result<Vec<PathBuf>, BuildError> {
        for v in &scene.volumes {
            // Only the channels the output asks for: hide colour from the writer when
            // it was allocated for images but not requested here.
            let colour = if v.colour { None } else { volume.colour.take() };
            let r = volga_io::write_nrrd(&options.out_dir, &v.name, &volume, &mut staged);
            if colour.is_some() {
                volume.colour = colour;
            }
            r?;
        }
        Ok(staged.commit()?)
    })?;

    let report_path = options.out_dir.join("report.json");
    let mut report = Report {
        scene: path.to_owned(),
        volga_version: env!("CARGO_PKG_VERSION"),
        threads: rayon::current_num_threads(),
        grid: GridReport {
            dims: scene.grid.dims().to_array(),
            voxel_size: scene.grid.transform.spacing().to_array(),
            origin: scene.grid.transform.origin().to_array(),
            voxels: scene.grid.voxel_count(),
        },
        plan,
        stages: Vec::new(),
        voxels,
        images,
        outputs,
        total_wall_s: 0.0,
    };
    report.outputs.push(report_path.clone());
    report.stages = stages.list;
    report.total_wall_s = start.elapsed().as_secs_f64();
    let json = serde_json::to_vec_pretty(&report).expect("report serializes");
    volga_io::write_atomic(&report_path, |w| w.write_all(&json))?;
    Ok(report)
}

fn voxel_report(volume: &SparseVolume) -> VoxelReport {
    let bricks = volume.density.brick_count();
    let dense = volume.density.dense_brick_count();
    VoxelReport {
        active: volume.active_voxel_count(),
        bricks,
        dense_bricks: dense,
        uniform_bricks: bricks - dense,
        colour_bricks: volume.colour.as_ref().map_or(0, |c| c.brick_count()),
        volume_memory_bytes: volume.memory_bytes(),
    }
}

fn image_report(name: &str, file: PathBuf, image: &volga_render::Image, s: RenderStats) -> ImageReport {
    ImageReport {
        name: name.to_string(),
        file,
        width: image.width,
        height: image.height,
        rays: s.rays,
        samples: s.samples,
        gradient_evaluations: s.gradient_evaluations,
        rays_terminated_early: s.rays_terminated_early,
        cells_skipped: s.cells_skipped,
    }
}
