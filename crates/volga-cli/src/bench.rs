//! `volga bench voxelize`: the voxelization of `volga voxelize`, timed warm in one
//! process — what a program calling the library sees, and how the peer benchmark
//! (`bench/peers/`) measures the peers, each in a persistent worker after a warm-up.
//!
//! Without `--serve` it makes `--warmup` untimed runs, then `--repeat` timed ones, and
//! prints one JSON object (every time, their median, the voxel count). With `--serve`
//! it reads the mesh, makes the warm-up runs, prints a JSON `ready` line and then
//! answers standard input line by line: `run` makes one timed run and prints
//! `{"t": seconds, "voxels": n}`; `dump PATH` writes the last result (`.binvox` or
//! `.nrrd` by extension) and prints `{"ok": true}`. Only the voxelization is inside
//! the timer, as in the `voxelize` stage of `volga voxelize --report`.

use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, Subcommand};
use serde_json::json;
use volga_core::{NoProgress, SparseVolume};
use volga_scene::Stages;

use crate::failure::{bad_input, failed, Failure};
use crate::voxelize::{output_format, write_outputs, JobArgs};

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Time `volga voxelize`'s voxelization warm, in one process (mesh read once).
    Voxelize(BenchArgs),
    /// Frames per second of the raycaster (iso, DVR) against a plain raycaster, as JSON.
    Render(crate::bench_render::RenderBenchArgs),
    /// Noise throughput (4-octave fBm) against the `noise` crate and simdnoise, as JSON.
    Noise(crate::bench_noise::NoiseBenchArgs),
    /// Sculpt edit latency, memory, re-render and mesh extraction against OpenVDB and scikit-image, as JSON.
    Sculpt(crate::bench_sculpt::SculptBenchArgs),
    /// Build an ADF of a mesh: build time, cells, bytes, errors, render speed, as JSON.
    Adf(crate::adf::AdfBenchArgs),
    /// Every mesh extraction method on a mesh's anti-aliased solid: seconds, triangles,
    /// Hausdorff distance to the exact mesh (voxels), sharp-edge error, manifold check, as JSON.
    Extract(crate::bench_extract::ExtractBenchArgs),
}

#[derive(Args)]
pub struct BenchArgs {
    #[command(flatten)]
    job: JobArgs,
    /// Untimed runs first (page in code and memory).
    #[arg(long, default_value_t = 1)]
    warmup: usize,
    /// Timed runs; the median is reported.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
    repeat: u64,
    /// Serve runs on request over stdin/stdout (the peer benchmark's worker protocol).
    #[arg(long)]
    serve: bool,
    /// Write the last result here (.binvox, .nrrd or .vdb).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also report where the time goes: per stage (preparing the mesh, distances, band
    /// signs, flood signs, far field, ...) the median wall and CPU seconds of the timed
    /// runs, under `profile`. Timing costs a few clock reads per brick.
    #[arg(long, conflicts_with = "serve")]
    profile: bool,
}

pub fn run(command: BenchCommand) -> Result<(), Failure> {
    let args = match command {
        BenchCommand::Voxelize(args) => args,
        BenchCommand::Render(args) => return crate::bench_render::run(args),
        BenchCommand::Noise(args) => return crate::bench_noise::run(args),
        BenchCommand::Sculpt(args) => return crate::bench_sculpt::run(args),
        BenchCommand::Adf(args) => return crate::adf::bench(args),
        BenchCommand::Extract(args) => return crate::bench_extract::run(args),
    };
    let job_args = &args.job;
    let binary = job_args.spec()?.is_binary();
    if let Some(out) = &args.out {
        output_format(out, binary)?;
    }
    let job = job_args.prepare(&mut Stages::with_stage_start(crate::heap::stage_start))?;
    let profiles = std::cell::RefCell::new(Vec::new());
    let once = || {
        let start = Instant::now();
        let (run, mode) = if args.profile {
            let (run, mode, profile) = job.voxelize_profiled(&NoProgress);
            profiles.borrow_mut().push(profile);
            (run, mode)
        } else {
            job.voxelize(&NoProgress)
        };
        let volume = run.volume;
        (start.elapsed().as_secs_f64(), volume, mode)
    };
    let mut last: Option<(SparseVolume, String)> = None;
    for _ in 0..args.warmup {
        drop(last.take()); // free the previous result first, as a fresh run would find it
        let (_, volume, mode) = once();
        last = Some((volume, mode));
    }

    let stdout = std::io::stdout();
    if args.serve {
        let say = |value: serde_json::Value| -> Result<(), Failure> {
            let mut out = stdout.lock();
            writeln!(out, "{value}")
                .and_then(|()| out.flush())
                .map_err(|e| failed(format!("stdout: {e}")))
        };
        say(json!({
            "ready": true,
            "tool": "volga",
            "version": env!("CARGO_PKG_VERSION"),
            "threads": rayon::current_num_threads(),
            "triangles": job.mesh.triangles.len(),
        }))?;
        for line in std::io::stdin().lock().lines() {
            let line = line.map_err(|e| failed(format!("stdin: {e}")))?;
            let mut words = line.splitn(2, char::is_whitespace);
            match (words.next(), words.next().map(str::trim)) {
                (Some("run"), None) => {
                    drop(last.take()); // free the previous result first, as a fresh run would find it
                    let (t, volume, mode) = once();
                    say(json!({ "t": t, "voxels": job.voxel_count(&volume) }))?;
                    last = Some((volume, mode));
                }
                (Some("dump"), Some(path)) if !path.is_empty() => {
                    let path = PathBuf::from(path);
                    let (volume, _) = last.as_ref().ok_or_else(|| bad_input("dump: nothing has run yet"))?;
                    output_format(&path, binary)?;
                    write_outputs(&path, volume, &Default::default(), None)?;
                    say(json!({ "ok": true }))?;
                }
                (None | Some(""), _) => {}
                _ => {
                    return Err(bad_input(format!(
                        "bench --serve: unknown request `{line}` (run | dump PATH)"
                    )))
                }
            }
        }
        return Ok(());
    }

    profiles.borrow_mut().clear(); // the warm-up runs' profiles
    let mut times = Vec::new();
    for _ in 0..args.repeat {
        drop(last.take()); // free the previous result first, as a fresh run would find it
        let (t, volume, mode) = once();
        times.push(t);
        last = Some((volume, mode));
    }
    let (volume, mode) = last.expect("repeat ≥ 1");
    let median = median_of(&times);
    if let Some(out) = &args.out {
        write_outputs(out, &volume, &Default::default(), None)?;
    }
    let mut report = json!({
        "mesh": job_args.mesh_path(),
        "mode": mode,
        "triangles": job.mesh.triangles.len(),
        "threads": rayon::current_num_threads(),
        "warmup": args.warmup,
        "times_s": times,
        "median_s": median,
        "voxels": job.voxel_count(&volume),
    });
    if args.profile {
        report["profile"] = profile_medians(&profiles.borrow());
    }
    println!("{}", serde_json::to_string_pretty(&report).expect("report serializes"));
    Ok(())
}

fn median_of(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    if sorted.len() % 2 == 1 {
        sorted[sorted.len() / 2]
    } else {
        0.5 * (sorted[sorted.len() / 2 - 1] + sorted[sorted.len() / 2])
    }
}

/// Per stage (in the first run's order), the median wall and CPU seconds over the runs,
/// and each median wall's share of their sum.
fn profile_medians(profiles: &[volga_voxelize::VoxelizeProfile]) -> serde_json::Value {
    let Some(first) = profiles.first() else {
        return json!([]);
    };
    let stages: Vec<(&str, f64, f64)> = first
        .stages
        .iter()
        .enumerate()
        .map(|(i, stage)| {
            let of = |f: fn(&volga_voxelize::ProfileStage) -> f64| {
                median_of(
                    &profiles
                        .iter()
                        .filter_map(|p| p.stages.get(i))
                        .map(f)
                        .collect::<Vec<_>>(),
                )
            };
            (stage.name, of(|s| s.wall_s), of(|s| s.cpu_s))
        })
        .collect();
    let total: f64 = stages.iter().map(|s| s.1).sum();
    json!(stages
        .iter()
        .map(|(name, wall, cpu)| json!({
            "name": name,
            "wall_s": wall,
            "cpu_s": cpu,
            "share": if total > 0.0 { wall / total } else { 0.0 },
        }))
        .collect::<Vec<_>>())
}
