//! `volga build`: load → plan → voxelize → render → write, with a report.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::nodes::Node;
use serde::Serialize;
use volga_core::{Progress, Sampled, SparseVolume};
use volga_io::StagedOutputs;
use volga_render::{render, RenderError, RenderStats};

use crate::model::SceneFile;
use crate::plan::{plan, Plan};
use crate::stages::{StageReport, Stages};
use crate::{load, BuildError, RenderSource, Scene, SceneError};

/// What `volga build` did, written to `{out}/report.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The scene file built.
    pub scene: PathBuf,
    /// The version of volga that built it.
    pub volga_version: &'static str,
    /// Worker threads the build ran with (rayon's pool).
    pub threads: usize,
    /// The voxel grid the scene asked for.
    pub grid: GridReport,
    /// What the planner decided and why, with its memory estimate.
    pub plan: Plan,
    /// Every stage in the order run, with its wall time and peak memory.
    pub stages: Vec<StageReport>,
    /// What the baked volume holds; zeros when nothing was voxelized.
    pub voxels: VoxelReport,
    /// One entry per PNG written (per frame for turntables).
    pub images: Vec<ImageReport>,
    /// Every file written, `report.json` last.
    pub outputs: Vec<PathBuf>,
    /// Perlin evaluations (one per octave) and Worley searches over the whole build.
    pub noise_evaluations: u64,
    /// Per procedural node: samples taken and noise evaluated (bake and renders).
    pub node_counters: Vec<crate::nodes::procedural::NodeCounters>,
    /// Wall time of the whole build in seconds.
    pub total_wall_s: f64,
}

/// The voxel grid of a build, as `report.json` lists it.
#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    /// Voxels along x, y and z.
    pub dims: [u32; 3],
    /// Voxel edge lengths along x, y and z (world units).
    pub voxel_size: [f64; 3],
    /// World position of voxel (0, 0, 0)'s centre.
    pub origin: [f64; 3],
    /// Voxels in all (`dims` multiplied).
    pub voxels: u64,
}

/// What the baked volume holds, as `report.json` lists it (all zero when nothing was
/// voxelized).
#[derive(Debug, Clone, Default, Serialize)]
pub struct VoxelReport {
    /// Voxels with non-zero density.
    pub active: u64,
    /// Bricks of 8³ voxels stored.
    pub bricks: usize,
    /// Bricks stored voxel by voxel.
    pub dense_bricks: usize,
    /// Bricks stored as one value (all their voxels equal).
    pub uniform_bricks: usize,
    /// Bricks of the colour channel (0 without one).
    pub colour_bricks: usize,
    /// Bytes the volume holds (bricks and map).
    pub volume_memory_bytes: u64,
}

/// One image written, as `report.json` lists it: the renderer's counters.
#[derive(Debug, Clone, Serialize)]
pub struct ImageReport {
    /// File stem (`name`, or `{name}_0007` for a turntable frame).
    pub name: String,
    /// The PNG written.
    pub file: PathBuf,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Rays cast (`supersampling²` per pixel).
    pub rays: u64,
    /// Field values evaluated along the rays.
    pub samples: u64,
    /// Gradient evaluations for shading (0 when unlit).
    pub gradient_evaluations: u64,
    /// `Volume` rays stopped by early ray termination.
    pub rays_terminated_early: u64,
    /// Empty-space skips (a count of skips, each over one or more macro cells).
    pub cells_skipped: u64,
    /// Shadow rays cast and field values they read (0 when no light casts shadows).
    pub shadow_rays: u64,
    /// Field values read along shadow rays.
    pub shadow_samples: u64,
}

/// Parses and validates a scene file (no I/O but reading it).
pub fn validate_scene(path: &Path) -> Result<Scene, SceneError> {
    let file = load::parse_file(path)?;
    crate::validate::validate(path, &file)
}

/// Parses, validates and resolves a scene file (loads the meshes it names).
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let mut scene = validate_scene(path)?;
    scene.resolve(None)?;
    Ok(scene)
}

/// Options of a build.
#[derive(Debug, Clone)]
pub struct BuildOptions {
    /// Folder the outputs and `report.json` are written to; created when missing.
    pub out_dir: PathBuf,
    /// Refuse builds estimated to need more than this; `None`: the machine's available
    /// memory.
    pub memory_limit: Option<u64>,
    /// Called at the start of every build stage: `Some(`[`reset_peak_rss`](crate::reset_peak_rss)`)`
    /// makes each stage's reported peak its own (what the `volga` CLI does); `None`
    /// leaves process-wide state alone and reports the process's peak so far.
    pub stage_start: Option<fn()>,
    /// Whether the scene may name files outside its own folder (absolute paths, `..`
    /// climbing above it). Off by default, so a service can build scenes it did not
    /// write without their reading arbitrary files; the CLI's `--allow-outside-paths`.
    pub allow_outside_paths: bool,
}

/// Builds a scene: every output is staged under a temporary name and renamed only
/// once all of them are complete, so a failed build leaves earlier outputs intact.
pub fn build(path: &Path, options: &BuildOptions, progress: &dyn Progress) -> Result<Report, BuildError> {
    build_with(path, None, options, progress)
}

/// [`build`] of a scene already parsed (e.g. made in memory by a program): `path` names
/// it in messages and in the report, and relative paths in it are read from its folder.
pub fn build_parsed(
    path: &Path,
    file: &SceneFile,
    options: &BuildOptions,
    progress: &dyn Progress,
) -> Result<Report, BuildError> {
    build_with(path, Some(file), options, progress)
}

fn build_with(
    path: &Path,
    file: Option<&SceneFile>,
    options: &BuildOptions,
    progress: &dyn Progress,
) -> Result<Report, BuildError> {
    let start = Instant::now();
    let mut stages = match options.stage_start {
        Some(hook) => Stages::with_stage_start(hook),
        None => Stages::default(),
    };
    let mut scene = stages.run("load", || match file {
        Some(file) => crate::validate::validate(path, file),
        None => validate_scene(path),
    })?;
    scene.allow_outside_paths = options.allow_outside_paths;
    stages.run("resolve", || scene.resolve(options.memory_limit))?;
    let plan = stages.run("plan", || plan(&scene, options.memory_limit))?;
    // Volumes: NRRDs are dense; a `.vdb` holds at most a leaf per brick of the grid
    // (512 values plus masks and headers: a quarter more) and its internal nodes (values,
    // masks, headers). Check the disk before any work.
    let grid_voxels = scene.grid.voxel_count();
    let ext = volga_core::brick_extent(scene.grid.dims()).as_u64vec3();
    let brick_voxels = (ext.x * ext.y * ext.z).saturating_mul(512);
    let l1_nodes = ext.x.div_ceil(16) * ext.y.div_ceil(16) * ext.z.div_ceil(16);
    let l2_nodes = ext.x.div_ceil(512) * ext.y.div_ceil(512) * ext.z.div_ceil(512);
    let disk: Vec<(PathBuf, u64)> = scene
        .volumes
        .iter()
        .flat_map(|v| {
            let per_voxel = if v.colour { 16 } else { 4 };
            let files: Vec<(PathBuf, u64)> = match v.format {
                crate::model::VolumeFormatSpec::Nrrd => {
                    let density = (
                        options.out_dir.join(format!("{}.raw", v.name)),
                        grid_voxels.saturating_mul(4),
                    );
                    let colour = (
                        options.out_dir.join(format!("{}_colour.raw", v.name)),
                        grid_voxels.saturating_mul(12),
                    );
                    std::iter::once(density).chain(v.colour.then_some(colour)).collect()
                }
                crate::model::VolumeFormatSpec::Vdb => vec![(
                    options.out_dir.join(format!("{}.vdb", v.name)),
                    brick_voxels.saturating_mul(per_voxel).saturating_mul(5) / 4
                        + l1_nodes.saturating_mul(per_voxel * 4096 + 4096)
                        + l2_nodes.saturating_mul(per_voxel * 32768 + 32768)
                        + (64 << 10),
                )],
            };
            files
        })
        .chain(std::iter::once((
            options.out_dir.join("images.png"),
            plan.work.image_disk_bytes,
        )))
        .collect();
    volga_io::check_free_space_for(&disk)?;

    // Only when an image renders the baked volume or a volume output writes it.
    let mut volume = match plan.voxelize.enabled {
        true => Some(stages.run("voxelize", || {
            scene.root.bake(&scene.grid, plan.colour_channel, progress)
        })?),
        false => None,
    };
    let voxels = volume.as_ref().map(voxel_report).unwrap_or_default();

    std::fs::create_dir_all(&options.out_dir).map_err(|source| volga_io::IoError::Io {
        path: options.out_dir.clone(),
        source,
    })?;
    let mut staged = StagedOutputs::new();
    let mut images = Vec::new();
    for job in &scene.images {
        let frames: Vec<(String, volga_render::Camera)> = match &job.turntable {
            None => vec![(job.name.clone(), job.camera)],
            Some(t) => (0..t.frames)
                .map(|k| {
                    let camera = t.camera(&job.camera, k).unwrap_or(job.camera);
                    (crate::turntable::frame_stem(&job.name, k), camera)
                })
                .collect(),
        };
        for (name, camera) in &frames {
            let (image, stats) = stages
                .run(format!("render:{name}"), || match (job.source, &volume) {
                    (RenderSource::Baked, Some(volume)) => {
                        let field = Sampled::new(volume, job.filter).with_gradient(job.gradient);
                        render(&field, camera, &job.mode, &job.settings, progress)
                    }
                    _ => {
                        let field = scene
                            .root
                            .lazy_field(&scene.grid)
                            .map_err(|e| RenderError::BadSetting {
                                name: "source".into(),
                                reason: e.to_string(),
                            })?;
                        render(field.as_ref(), camera, &job.mode, &job.settings, progress)
                    }
                })
                .map_err(|e| BuildError::Render {
                    image: name.clone(),
                    message: e.to_string(),
                })?;
            let file = options.out_dir.join(format!("{name}.png"));
            stages.run(format!("encode:{name}"), || {
                if job.bit_depth == 16 {
                    let rgba = image.to_rgba16();
                    staged.stage(&file, |w| volga_io::encode_png16(w, image.width, image.height, &rgba))
                } else {
                    let rgba = image.to_rgba8();
                    staged.stage(&file, |w| volga_io::encode_png(w, image.width, image.height, &rgba))
                }
            })?;
            images.push(image_report(name, file, &image, stats));
        }
    }

    stages.run("write", || -> Result<(), BuildError> {
        for v in &scene.volumes {
            let Some(volume) = volume.as_mut() else { break };
            // Only the channels the output asks for: hide colour from the writer when
            // it was allocated for images but not requested here.
            let colour = if v.colour { None } else { volume.colour.take() };
            let r = match v.format {
                crate::model::VolumeFormatSpec::Nrrd => {
                    volga_io::write_nrrd(&options.out_dir, &v.name, volume, &mut staged)
                }
                crate::model::VolumeFormatSpec::Vdb => volga_io::write_vdb(
                    &options.out_dir.join(format!("{}.vdb", v.name)),
                    volume,
                    &volga_io::VdbOptions {
                        half: v.half,
                        ..Default::default()
                    },
                    &mut staged,
                ),
            };
            if colour.is_some() {
                volume.colour = colour;
            }
            r?;
        }
        Ok(())
    })?;
    for m in &scene.meshes {
        stages.run(format!("mesh:{}", m.name), || {
            let left = plan.memory_limit_bytes.saturating_sub(plan.memory.total_bytes);
            write_mesh(&scene, m, &options.out_dir, &mut staged, left)
        })?;
    }
    let outputs = staged.staged_paths();

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
        noise_evaluations: 0,
        node_counters: Vec::new(),
        total_wall_s: 0.0,
    };
    report.node_counters = crate::nodes::all_counters(&scene.root);
    report.noise_evaluations = report.node_counters.iter().map(|c| c.noise_evaluations).sum();
    report.outputs.push(report_path.clone());
    report.stages = stages.list;
    report.total_wall_s = start.elapsed().as_secs_f64();
    let json = serde_json::to_vec_pretty(&report).expect("report serializes");
    // The report is staged with the other outputs: nothing is replaced unless every
    // file, the report included, could be written.
    staged.stage(&report_path, |w| w.write_all(&json))?;
    staged.commit()?;
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
        shadow_rays: s.shadow_rays,
        shadow_samples: s.shadow_samples,
    }
}

/// A mesh output: the ½ iso-surface of the lazy tree on the grid's voxel-centre lattice
/// (refined onto the surface), through volga-mesh's shared extractor.
fn write_mesh(
    scene: &Scene,
    m: &crate::model::MeshOutputSpec,
    out_dir: &Path,
    staged: &mut StagedOutputs,
    max_bytes: u64,
) -> Result<(), BuildError> {
    let field = scene.root.lazy_field(&scene.grid)?;
    // The triangles (and the file's bytes) fit in what the plan left of the memory limit:
    // the extraction stops, with an error, past that many triangles.
    let surface = volga_mesh::extract_surface_bounded(
        field.as_ref(),
        &volga_mesh::Extraction::new(scene.grid.world_bounds(), scene.grid.transform.min_spacing(), 0.5)
            .with_method(m.method.unwrap_or_default().into())
            .with_adaptivity(m.adaptivity.unwrap_or(0.0)),
        max_bytes / (volga_mesh::BYTES_PER_TRIANGLE + 64),
    )
    .map_err(|e| match e {
        volga_mesh::ExtractError::TooManyTriangles { .. } => BuildError::Limit {
            output: format!("{}: outputs.meshes.{}", scene.source.display(), m.name),
            message: e.to_string(),
        },
        e => BuildError::Scene(SceneError::Invalid {
            path: scene.source.clone(),
            field: format!("outputs.meshes.{}", m.name),
            message: e.to_string(),
        }),
    })?;
    let (ext, bytes) = match m.format {
        crate::model::MeshFormatSpec::Obj => ("obj", volga_mesh::obj_bytes(&surface.mesh, Some(&surface.normals))),
        crate::model::MeshFormatSpec::Ply => ("ply", volga_mesh::ply_bytes(&surface.mesh, Some(&surface.normals))),
    };
    staged.stage(&out_dir.join(format!("{}.{ext}", m.name)), |w| w.write_all(&bytes))?;
    Ok(())
}
