//! `volga bench render`: frames per second of the embedded raycaster on 256³ volumes at
//! 512×512, against a plain trilinear raycaster written here and timed in the same run.
//!
//! Two volumes (`--volumes`): `ct`, a synthetic CT-like head phantom (air, skin, skull,
//! brain, ventricles and a dense lesion, the phantom's edges anti-aliased over one voxel),
//! and `bunny`, `--mesh` voxelized as an anti-aliased solid at `--size` voxels along its
//! longest side. Each is rendered three ways, in turns, `--warmup` untimed rounds then
//! `--repeat` timed ones. The renderers are prepared once per volume and mode
//! ([`Renderer::new`]: validation and the empty-space skipping grid, what a viewer does
//! once per volume), their preparation timed apart (`*_prepare_s`); a frame is one
//! [`Renderer::render`] of the view:
//!
//! * `iso`: the shaded iso-surface at 0.5 (one white light, constant colour);
//! * `dvr`: shaded semi-transparent volume rendering, early ray termination **off**,
//!   empty-space skipping on;
//! * `baseline`: the same DVR image from a plain raycaster over a dense copy of the
//!   volume — one trilinear sample at a time, no skipping, no early termination, the
//!   same lattice, classification, opacity correction and shading (see [`plain_dvr`]).
//!
//! Each volume also reports the median CPU seconds per frame summed over threads
//! (`*_cpu_s`, Linux): on a shared machine wall-clock frames stretch, CPU time much less.
//!
//! It prints one JSON object: the top-level `iso_fps`, `dvr_fps`, `baseline_fps`,
//! `samples_per_s` (DVR samples per second) are the **minimum over the volumes** (the
//! slower volume decides); `volumes` holds each volume's medians, counters and the
//! largest channel difference between the DVR and baseline images. These keys are stable.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use glam::{DVec3, IVec3, UVec3, Vec3, Vec4};
use rayon::prelude::*;
use serde_json::{json, Value};
use volga_core::{
    brick_index_box, Aabb, Brick, Field, Filter, Grid, NoProgress, Sampled, SparseVolume, BRICK_DIM, BRICK_VOXELS,
};
use volga_render::{
    Camera, Image, Iso, Lighting, Material, Projection, RenderSettings, RenderStats, Renderer, SurfaceColour,
    TransferFunction, Volume,
};
use volga_voxelize::{MeshJob, MeshJobMode};

use crate::failure::{bad_input, failed, Failure};

/// Samples per second of the survey's VolumePro 500 board (survey §7), for scale.
const VOLUMEPRO_500_SAMPLES_PER_S: f64 = 5e8;

#[derive(Args)]
pub struct RenderBenchArgs {
    /// Print the result as one JSON object (the only output format).
    #[arg(long)]
    json: bool,
    /// Voxels along each side of the CT phantom and along the bunny's longest side.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=1024))]
    size: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=8192))]
    width: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=8192))]
    height: u32,
    /// Ray step in voxels (the renderer's default is 0.5).
    #[arg(long, default_value_t = 0.5)]
    step_voxels: f64,
    /// Edge of the square pixel tiles rendered in parallel (the renderer's default is
    /// 16; never changes the image, only the order rays read memory in).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=4096))]
    tile_size: u32,
    /// Render sampled volumes through the renderer's packed fast path (`on`, the
    /// renderer's default) or its general path (`off`), to compare them in one build.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    packed: String,
    /// The mesh voxelized for the `bunny` volume.
    #[arg(long, default_value = "tests/data/stanford-bunny.obj")]
    mesh: PathBuf,
    /// Volumes to render: `ct`, `bunny` (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = [String::from("ct"), String::from("bunny")])]
    volumes: Vec<String>,
    /// Untimed rounds first.
    #[arg(long, default_value_t = 1)]
    warmup: usize,
    /// Timed rounds; medians are reported.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
    repeat: u64,
    /// Reconstruction filter of the `iso` and `dvr` renders: `trilinear` (default),
    /// `nearest`, `catmull-rom`, `b-spline` (the baseline stays trilinear, so
    /// `dvr_baseline_max_abs_diff` compares like with like only for trilinear).
    #[arg(long, default_value = "trilinear")]
    filter: String,
    /// Modes to time: `iso`, `dvr`, `baseline` (comma separated; for profiling one
    /// mode). A mode left out reports `null`.
    #[arg(long, value_delimiter = ',', default_values_t = [String::from("iso"), String::from("dvr"), String::from("baseline")])]
    modes: Vec<String>,
    /// Write each volume's iso, DVR and baseline images here as PNG (to look at them).
    #[arg(long)]
    images: Option<PathBuf>,
    /// Also time each effect against the plain shaded render (`effects` per volume:
    /// shadows, pre-integration, cubic filter; see `bench_effects.rs`).
    #[arg(long)]
    effects: bool,
    /// Timed frames per effect configuration (medians are reported).
    #[arg(long, default_value_t = 1)]
    effects_repeat: usize,
}

#[path = "bench_effects.rs"]
mod bench_effects;

/// One benchmark volume with how it is viewed and classified.
struct BenchVolume {
    name: &'static str,
    volume: SparseVolume,
    camera: Camera,
    transfer: TransferFunction,
}

pub fn run(args: RenderBenchArgs) -> Result<(), Failure> {
    if !args.json {
        return Err(bad_input("bench render prints JSON only: pass --json"));
    }
    if !(args.step_voxels.is_finite() && args.step_voxels > 0.0 && args.step_voxels <= 16.0) {
        return Err(bad_input(format!(
            "--step-voxels must be in (0, 16], got {}",
            args.step_voxels
        )));
    }
    let mut volumes = Vec::new();
    for name in &args.volumes {
        volumes.push(match name.as_str() {
            "ct" => ct_phantom(args.size)?,
            "bunny" => bunny(&args.mesh, args.size)?,
            other => return Err(bad_input(format!("--volumes: unknown volume `{other}` (ct, bunny)"))),
        });
    }
    if volumes.is_empty() {
        return Err(bad_input("--volumes: nothing to render"));
    }
    let mut reports = Vec::new();
    for v in &volumes {
        reports.push(bench_volume(v, &args)?);
    }
    let min_of = |key: &str| {
        reports
            .iter()
            .filter_map(|r| r[key].as_f64())
            .fold(f64::INFINITY, f64::min)
    };
    let report = json!({
        "iso_fps": min_of("iso_fps"),
        "dvr_fps": min_of("dvr_fps"),
        "baseline_fps": min_of("baseline_fps"),
        "samples_per_s": min_of("samples_per_s"),
        "aggregate": "minimum over volumes",
        "volumepro500_samples_per_s": VOLUMEPRO_500_SAMPLES_PER_S,
        "width": args.width,
        "height": args.height,
        "size": args.size,
        "step_voxels": args.step_voxels,
        "tile_size": args.tile_size,
        "packed": args.packed,
        "filter": args.filter,
        "threads": rayon::current_num_threads(),
        "warmup": args.warmup,
        "repeat": args.repeat,
        "volumes": reports,
    });
    println!("{}", serde_json::to_string_pretty(&report).expect("report serializes"));
    Ok(())
}

fn median(times: &[f64]) -> f64 {
    let mut s = times.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let out = f();
    (start.elapsed().as_secs_f64(), out)
}

/// CPU time of the whole process so far (every thread), in nanoseconds, from
/// `/proc/self/task/*/schedstat` (Linux); `None` elsewhere. On a machine shared with
/// other work, wall-clock frames stretch while CPU time per frame stays near what the
/// frame costs: both are reported.
fn process_cpu_ns() -> Option<u64> {
    let mut total = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

/// [`timed`], plus the CPU seconds spent (all threads; NaN where unknown).
fn timed_cpu<T>(f: impl FnOnce() -> T) -> (f64, f64, T) {
    let cpu0 = process_cpu_ns();
    let (t, out) = timed(f);
    let cpu = match (cpu0, process_cpu_ns()) {
        (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-9,
        _ => f64::NAN,
    };
    (t, cpu, out)
}

fn bench_volume(v: &BenchVolume, args: &RenderBenchArgs) -> Result<Value, Failure> {
    let filter = Filter::ALL
        .into_iter()
        .find(|f| f.name() == args.filter)
        .ok_or_else(|| {
            bad_input(format!(
                "--filter: unknown filter `{}` (nearest, trilinear, catmull-rom, b-spline)",
                args.filter
            ))
        })?;
    let field = Sampled::new(&v.volume, filter);
    let mut lit = RenderSettings::new(args.width, args.height);
    lit.sampling.step_voxels = args.step_voxels;
    lit.image.tile_size = args.tile_size;
    lit.sampling.packed_path = args.packed == "on";
    let iso_mode = Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(Vec3::new(0.85, 0.8, 0.7)),
    };
    let dvr_mode = Volume::new(v.transfer.clone(), false);
    let mut dvr = lit.clone();
    dvr.sampling.early_termination_alpha = 2.0; // off: every ray is integrated to its end

    // Prepared once per volume and mode, as a viewer would (timed apart).
    let render_err = |e: volga_render::RenderError| failed(format!("{}: {e}", v.name));
    let (iso_prepare_s, iso_renderer) = timed(|| Renderer::new(&field, &iso_mode, &lit));
    let iso_renderer = iso_renderer.map_err(render_err)?;
    let (dvr_prepare_s, dvr_renderer) = timed(|| Renderer::new(&field, &dvr_mode, &dvr));
    let dvr_renderer = dvr_renderer.map_err(render_err)?;
    let (baseline_prepare_s, plain) = timed(|| PlainDvr::new(&v.volume, &v.transfer, &dvr));
    let plain = plain?;

    for m in &args.modes {
        if !["iso", "dvr", "baseline"].contains(&m.as_str()) {
            return Err(bad_input(format!("--modes: unknown mode `{m}` (iso, dvr, baseline)")));
        }
    }
    let wants = |m: &str| args.modes.iter().any(|x| x == m);
    let mut iso_times = Vec::new();
    let mut dvr_times = Vec::new();
    let mut base_times = Vec::new();
    let mut cpu_times = [Vec::new(), Vec::new(), Vec::new()];
    /// The last round's images and counters: iso, DVR, baseline (with its sample count).
    type Round = (
        Option<(Image, RenderStats)>,
        Option<(Image, RenderStats)>,
        Option<(Image, u64)>,
    );
    let mut last: Round = (None, None, None);
    for round in 0..args.warmup + args.repeat as usize {
        let timed_round = round >= args.warmup;
        if wants("iso") {
            let (t, c, out) = timed_cpu(|| iso_renderer.render(&v.camera, &NoProgress));
            if timed_round {
                iso_times.push(t);
                cpu_times[0].push(c);
            }
            last.0 = Some(out);
        }
        if wants("dvr") {
            let (t, c, out) = timed_cpu(|| dvr_renderer.render(&v.camera, &NoProgress));
            if timed_round {
                dvr_times.push(t);
                cpu_times[1].push(c);
            }
            last.1 = Some(out);
        }
        if wants("baseline") {
            let (t, c, out) = timed_cpu(|| plain.render(&v.camera));
            if timed_round {
                base_times.push(t);
                cpu_times[2].push(c);
            }
            last.2 = Some(out);
        }
    }
    let max_diff = match (&last.1, &last.2) {
        (Some((dvr_img, _)), Some((base_img, _))) => dvr_img
            .pixels
            .iter()
            .zip(&base_img.pixels)
            .map(|(a, b)| (*a - *b).abs().max_element())
            .fold(0.0f32, f32::max),
        _ => f32::NAN,
    };
    if let Some(dir) = &args.images {
        std::fs::create_dir_all(dir).map_err(|e| failed(format!("{}: {e}", dir.display())))?;
        let images = [
            ("iso", last.0.as_ref().map(|x| &x.0)),
            ("dvr", last.1.as_ref().map(|x| &x.0)),
            ("baseline", last.2.as_ref().map(|x| &x.0)),
        ];
        for (kind, img) in images {
            let Some(img) = img else { continue };
            let path = dir.join(format!("bench_{}_{kind}.png", v.name));
            volga_io::write_png(&path, img.width, img.height, &img.to_rgba8()).map_err(|e| failed(e.to_string()))?;
        }
    }
    let iso_stats = last.0.map(|x| x.1).unwrap_or_default();
    let dvr_stats = last.1.map(|x| x.1).unwrap_or_default();
    let base_samples = last.2.map_or(0, |x| x.1);
    let (iso_t, dvr_t, base_t) = (median(&iso_times), median(&dvr_times), median(&base_times));
    let dims = v.volume.grid.dims();
    let effects = match args.effects {
        true => bench_effects::effects(&v.volume, &v.transfer, &v.camera, &lit, args.effects_repeat)?,
        false => Value::Null,
    };
    Ok(json!({
        "effects": effects,
        "name": v.name,
        "dims": [dims.x, dims.y, dims.z],
        "iso_fps": 1.0 / iso_t,
        "dvr_fps": 1.0 / dvr_t,
        "baseline_fps": 1.0 / base_t,
        "samples_per_s": dvr_stats.samples as f64 / dvr_t,
        "baseline_samples_per_s": base_samples as f64 / base_t,
        "dvr_vs_volumepro500": dvr_stats.samples as f64 / dvr_t / VOLUMEPRO_500_SAMPLES_PER_S,
        "dvr_speedup_over_baseline": base_t / dvr_t,
        "iso_cpu_s": median(&cpu_times[0]),
        "dvr_cpu_s": median(&cpu_times[1]),
        "baseline_cpu_s": median(&cpu_times[2]),
        "iso_prepare_s": iso_prepare_s,
        "dvr_prepare_s": dvr_prepare_s,
        "iso_packed": iso_renderer.is_packed(),
        "dvr_packed": dvr_renderer.is_packed(),
        "baseline_prepare_s": baseline_prepare_s,
        "iso_times_s": iso_times,
        "dvr_times_s": dvr_times,
        "baseline_times_s": base_times,
        "iso": stats_json(&iso_stats),
        "dvr": stats_json(&dvr_stats),
        "baseline_samples": base_samples,
        "dvr_baseline_max_abs_diff": max_diff,
    }))
}

fn stats_json(s: &RenderStats) -> Value {
    json!({
        "rays": s.rays,
        "samples": s.samples,
        "gradient_evaluations": s.gradient_evaluations,
        "rays_terminated_early": s.rays_terminated_early,
        "cells_skipped": s.cells_skipped,
    })
}

/// A camera three-quarters above the front of `bounds`, framing it.
fn view(bounds: &Aabb, azimuth_deg: f64, elevation_deg: f64) -> Result<Camera, Failure> {
    let centre = bounds.center();
    let radius = 0.5 * bounds.size().length();
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    let dir = DVec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
    let fov = 30.0f64;
    let distance = radius / (fov.to_radians() * 0.5).sin();
    Camera::look_at(
        centre + dir * distance,
        centre,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: fov },
    )
    .map_err(|e| failed(e.to_string()))
}

/// A volume of `grid` filled brick by brick (in parallel) from `density(world_pos)`;
/// bricks equal to the background are left out.
fn fill(grid: Grid, density: impl Fn(DVec3) -> f32 + Sync) -> SparseVolume {
    let nb = grid.dims().as_ivec3().map(|d| (d + BRICK_DIM - 1) / BRICK_DIM);
    let bricks: Vec<IVec3> = (0..nb.z)
        .flat_map(|z| (0..nb.y).flat_map(move |y| (0..nb.x).map(move |x| IVec3::new(x, y, z))))
        .collect();
    let filled: Vec<(IVec3, Brick<f32>)> = bricks
        .par_iter()
        .map(|&b| {
            let mut voxels = [0.0f32; BRICK_VOXELS];
            for (o, ijk) in brick_index_box(b).iter().enumerate() {
                if grid.contains(ijk) {
                    voxels[o] = density(grid.transform.voxel_center(ijk));
                }
            }
            (b, Brick::from_voxels(&voxels))
        })
        .collect();
    let mut volume = SparseVolume::new(grid, 0.0, false);
    for (b, brick) in filled {
        if brick != Brick::Uniform(0.0) {
            volume.density.insert_brick(b, brick);
        }
    }
    volume
}

/// A CT-like head phantom (after Shepp and Logan's, in 3D) on `[-1, 1]³` at `size³`:
/// skin 0.3, skull 1.0, brain 0.4, ventricles 0.15, two lesions 0.6, air 0; each
/// ellipsoid blended over three voxels (`smoothstep` of its approximate signed distance,
/// so that the trilinear normals show no voxel steps), later ones painted over earlier ones.
fn ct_phantom(size: u32) -> Result<BenchVolume, Failure> {
    let bounds = Aabb::new(DVec3::splat(-1.0), DVec3::ONE);
    let grid = Grid::covering(&bounds, UVec3::splat(size)).map_err(|e| failed(e.to_string()))?;
    let h = 2.0 / size as f64;
    // (centre, radii, density)
    let parts: [(DVec3, DVec3, f32); 7] = [
        (DVec3::ZERO, DVec3::new(0.72, 0.9, 0.8), 0.3),
        (DVec3::new(0.0, 0.02, 0.0), DVec3::new(0.66, 0.84, 0.74), 1.0),
        (DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.6, 0.78, 0.68), 0.4),
        (DVec3::new(0.2, 0.1, 0.0), DVec3::new(0.09, 0.3, 0.12), 0.15),
        (DVec3::new(-0.2, 0.1, 0.0), DVec3::new(0.1, 0.32, 0.12), 0.15),
        (DVec3::new(0.0, -0.35, 0.3), DVec3::new(0.08, 0.06, 0.08), 0.6),
        (DVec3::new(0.25, -0.5, -0.2), DVec3::new(0.05, 0.05, 0.05), 0.6),
    ];
    let volume = fill(grid, |p| {
        let mut d = 0.0f32;
        for (c, r, value) in parts {
            // First-order distance to the ellipsoid surface, negative inside.
            let q = (p - c) / r;
            let len = q.length();
            let grad = (q / r).length();
            let sd = if grad > 0.0 {
                (len * len - 1.0) / (2.0 * grad)
            } else {
                -1.0
            };
            let t = (0.5 - sd / (3.0 * h)).clamp(0.0, 1.0) as f32;
            d += (value - d) * t * t * (3.0 - 2.0 * t);
        }
        d
    });
    let transfer = TransferFunction::new(vec![
        (0.0, Vec4::new(0.0, 0.0, 0.0, 0.0)),
        (0.1, Vec4::new(0.9, 0.6, 0.5, 0.0)),
        (0.3, Vec4::new(0.9, 0.6, 0.5, 0.02)),
        (0.4, Vec4::new(0.8, 0.5, 0.5, 0.03)),
        (0.6, Vec4::new(1.0, 0.3, 0.2, 0.2)),
        (0.8, Vec4::new(1.0, 1.0, 0.9, 0.03)),
        (1.0, Vec4::new(1.0, 1.0, 0.95, 0.06)),
    ])
    .map_err(|e| failed(e.to_string()))?;
    let camera = view(&bounds, 35.0, 20.0)?;
    Ok(BenchVolume {
        name: "ct",
        volume,
        camera,
        transfer,
    })
}

/// `mesh` voxelized as an anti-aliased solid with `size` voxels along its longest side.
fn bunny(mesh_path: &std::path::Path, size: u32) -> Result<BenchVolume, Failure> {
    let mesh = volga_mesh::load_mesh(mesh_path).map_err(|e| bad_input(format!("--mesh: {e}")))?;
    let job = MeshJob {
        resolution: size,
        mode: MeshJobMode::AntiAliased {
            thickness_voxels: 1.0,
            solid: true,
        },
    };
    job.check().map_err(|e| bad_input(e.to_string()))?;
    let grid = job.layout(&mesh.bounds()).map_err(|e| bad_input(e.to_string()))?;
    let volume = job.run(&mesh, &grid, &NoProgress).volume;
    let transfer = TransferFunction::new(vec![
        (0.0, Vec4::new(0.0, 0.0, 0.0, 0.0)),
        (0.2, Vec4::new(0.9, 0.7, 0.4, 0.0)),
        (0.5, Vec4::new(0.95, 0.75, 0.45, 0.25)),
        (1.0, Vec4::new(0.6, 0.3, 0.2, 0.02)),
    ])
    .map_err(|e| failed(e.to_string()))?;
    let camera = view(&Sampled::new(&volume, Filter::Trilinear).bounds(), 20.0, 15.0)?;
    Ok(BenchVolume {
        name: "bunny",
        volume,
        camera,
        transfer,
    })
}

/// The baseline: a plain shaded DVR raycaster over a dense `f32` copy of the volume,
/// written out in full so nothing of the renderer's sampling path is shared. One ray
/// per pixel clipped to the same bounds, samples at `t0 + (i + ½)·Δs`, trilinear
/// reconstruction, post-classification, opacity correction, Blinn-Phong with central
/// differences of the reconstruction one voxel apart, front-to-back compositing over
/// the background: no empty-space skipping, no early ray termination, one sample at a
/// time. Rows in parallel with rayon.
struct PlainDvr<'a> {
    data: Vec<f32>,
    dims: IVec3,
    background: f32,
    origin: DVec3,
    spacing: DVec3,
    bounds: Aabb,
    step: f64,
    alpha_exponent: f64,
    transfer: &'a TransferFunction,
    lights: Vec<(DVec3, Vec3)>,
    ambient: Vec3,
    material: Material,
    bg: Vec4,
    width: u32,
    height: u32,
}

impl<'a> PlainDvr<'a> {
    fn new(volume: &SparseVolume, transfer: &'a TransferFunction, s: &RenderSettings) -> Result<Self, Failure> {
        let grid = volume.grid;
        let dims = grid.dims().as_ivec3();
        let n = grid.voxel_count() as usize;
        let mut data = vec![0.0f32; n];
        data.par_chunks_mut(dims.x as usize).enumerate().for_each(|(row, out)| {
            let (y, z) = (row as i32 % dims.y, row as i32 / dims.y);
            for (x, o) in out.iter_mut().enumerate() {
                *o = volume.density.get(IVec3::new(x as i32, y, z));
            }
        });
        let field = Sampled::new(volume, Filter::Trilinear);
        let bounds = field.bounds();
        let step = s
            .sampling
            .world_step(&bounds, field.sample_spacing())
            .map_err(|e| failed(e.to_string()))?;
        let Lighting {
            lights,
            ambient_colour,
            material,
            ..
        } = &s.lighting;
        Ok(PlainDvr {
            data,
            dims,
            background: volume.density.background(),
            origin: grid.transform.origin(),
            spacing: grid.transform.spacing(),
            bounds,
            step,
            alpha_exponent: s.sampling.step_voxels / s.sampling.reference_step_voxels,
            transfer,
            lights: lights.iter().map(|l| (l.direction.normalize(), l.colour)).collect(),
            ambient: *ambient_colour * material.ambient,
            material: *material,
            bg: s.image.background,
            width: s.image.width,
            height: s.image.height,
        })
    }

    #[inline]
    fn voxel(&self, x: i32, y: i32, z: i32) -> f32 {
        if x < 0 || y < 0 || z < 0 || x >= self.dims.x || y >= self.dims.y || z >= self.dims.z {
            return self.background;
        }
        self.data[(x + self.dims.x * (y + self.dims.y * z)) as usize]
    }

    #[inline]
    fn value(&self, world_pos: DVec3) -> f64 {
        let index_pos = (world_pos - self.origin) / self.spacing;
        let base = index_pos.floor();
        let f = index_pos - base;
        let (x, y, z) = (base.x as i32, base.y as i32, base.z as i32);
        let c = |dx, dy, dz| self.voxel(x + dx, y + dy, z + dz) as f64;
        let x00 = c(0, 0, 0) + (c(1, 0, 0) - c(0, 0, 0)) * f.x;
        let x10 = c(0, 1, 0) + (c(1, 1, 0) - c(0, 1, 0)) * f.x;
        let x01 = c(0, 0, 1) + (c(1, 0, 1) - c(0, 0, 1)) * f.x;
        let x11 = c(0, 1, 1) + (c(1, 1, 1) - c(0, 1, 1)) * f.x;
        let y0 = x00 + (x10 - x00) * f.y;
        let y1 = x01 + (x11 - x01) * f.y;
        y0 + (y1 - y0) * f.z
    }

    fn gradient(&self, p: DVec3) -> DVec3 {
        let h = self.spacing;
        let d = |e: DVec3, hh: f64| (self.value(p + e) - self.value(p - e)) / (2.0 * hh);
        DVec3::new(d(DVec3::X * h.x, h.x), d(DVec3::Y * h.y, h.y), d(DVec3::Z * h.z, h.z))
    }

    fn shade(&self, colour: Vec3, outward: DVec3, ray_dir: DVec3) -> Vec3 {
        let view = -ray_dir;
        let len = outward.length();
        let mut n = if len.is_finite() && len > 1e-9 / self.spacing.min_element() {
            outward / len
        } else {
            view
        };
        if n.dot(view) < 0.0 {
            n = -n;
        }
        let m = &self.material;
        let mut r = self.ambient * colour;
        for &(l, cl) in &self.lights {
            let n_dot_l = n.dot(l).max(0.0) as f32;
            let h = (l + view).normalize_or_zero();
            let n_dot_h = n.dot(h).max(0.0) as f32;
            r += cl * colour * (m.diffuse * n_dot_l) + cl * (m.specular * n_dot_h.powf(m.shininess));
        }
        r
    }

    /// The image and the number of samples taken.
    fn render(&self, camera: &Camera) -> (Image, u64) {
        let (w, h) = (self.width, self.height);
        let rows: Vec<(Vec<Vec4>, u64)> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut samples = 0u64;
                let row = (0..w)
                    .map(|x| {
                        let ray = camera.ray(x as f64, y as f64, w, h);
                        let (c, a) = self.trace(ray.origin, ray.dir, &mut samples);
                        let premult = c + self.bg.truncate() * (self.bg.w * (1.0 - a));
                        premult.extend(1.0).clamp(Vec4::ZERO, Vec4::ONE)
                    })
                    .collect();
                (row, samples)
            })
            .collect();
        let samples = rows.iter().map(|r| r.1).sum();
        let pixels = rows.into_iter().flat_map(|r| r.0).collect();
        (
            Image {
                width: w,
                height: h,
                pixels,
            },
            samples,
        )
    }

    fn trace(&self, origin: DVec3, dir: DVec3, samples: &mut u64) -> (Vec3, f32) {
        let Some((t0, t1)) = self.bounds.ray_interval(origin, dir) else {
            return (Vec3::ZERO, 0.0);
        };
        let mut c = Vec3::ZERO;
        let mut a = 0.0f32;
        let mut i = 0u64;
        loop {
            let t = t0 + (i as f64 + 0.5) * self.step;
            if t > t1 {
                break;
            }
            i += 1;
            *samples += 1;
            let p = origin + dir * t;
            let rgba = self.transfer.eval(self.value(p));
            if rgba.w <= 0.0 {
                continue;
            }
            let alpha = if self.alpha_exponent == 1.0 || rgba.w >= 1.0 {
                rgba.w
            } else {
                (1.0 - (1.0 - rgba.w as f64).powf(self.alpha_exponent)) as f32
            };
            let rgb = self.shade(rgba.truncate(), -self.gradient(p), dir);
            let w = (1.0 - a) * alpha;
            c += rgb * w;
            a += w;
        }
        (c, a)
    }
}
