//! `volga`: build scene files, voxelize meshes, validate voxel models, time jobs,
//! measure what accuracy costs in time.
//!
//! Exit codes: 0 success, 1 the build (or a check) failed, 2 bad input.
#![deny(unsafe_code)]

mod accuracy;
mod adf;
mod bench;
mod bench_extract;
mod bench_noise;
mod bench_render;
mod bench_sculpt;
mod convert;
mod failure;
#[allow(unsafe_code)]
mod heap;
mod mesh_out;
mod progress;
mod sculpt;
mod validate;
mod voxelize;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use volga_scene::{build, plan::plan, validate_scene, BuildOptions};

#[derive(Parser)]
#[command(name = "volga", version, about = "volga — a volume graphics modeling kernel")]
struct Cli {
    /// Worker threads (default: all cores), at most 4× the cores available (and at
    /// least 16 are allowed). Results are identical for any count.
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Plan and build a scene: voxelize, render its images, write its volumes and a report.json.
    Build {
        /// Scene file (.ron or .json).
        scene: PathBuf,
        /// Output directory (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Refuse builds estimated to need more memory than this (e.g. 512M, 8G);
        /// default: the machine's available memory.
        #[arg(long, value_parser = parse_size)]
        memory_limit: Option<u64>,
        /// Let the scene read files outside its own folder (absolute paths, `..` above it);
        /// by default only files inside it are read.
        #[arg(long)]
        allow_outside_paths: bool,
    },
    /// Voxelize a mesh: binary surface or solid with 6/18/26 separability, anti-aliased
    /// surface or solid, or narrow-band signed distance.
    Voxelize(voxelize::VoxelizeArgs),
    /// Validate a voxel model (.binvox, .nrrd, .vdb) as a discrete surface: components, N-separability,
    /// simple voxels, Euler characteristic; with --mesh, tunnels through it and cover.
    Validate(validate::ValidateArgs),
    /// Convert a voxel model between .binvox, .nrrd and .vdb (OpenVDB), placed where the
    /// input says.
    Convert(convert::ConvertArgs),
    /// Apply a stroke file to a saved sculpt (or its start object); write the sculpt, a mesh, voxels, an image.
    Sculpt(sculpt::SculptArgs),
    /// Build an adaptively sampled distance field of a mesh: its statistics, accuracy and a
    /// shaded render (adf.json, adf.png in --out).
    Adf(adf::AdfBuildArgs),
    /// Time a job warm, in one process (for benchmarks; see docs/BENCHMARKS.md).
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Measure every accuracy knob against exact references: one Markdown table and one
    /// SVG plot per knob, and a JSON of raw figures with the machine (docs/accuracy).
    Accuracy(accuracy::AccuracyArgs),
    /// Validate a scene and print its plan (channels, effects, memory estimate) without building.
    Plan {
        /// Scene file (.ron or .json).
        scene: PathBuf,
        /// Refuse scenes estimated to need more memory than this (as for `build`).
        #[arg(long, value_parser = parse_size)]
        memory_limit: Option<u64>,
        /// Let the scene read files outside its own folder (as for `build`).
        #[arg(long)]
        allow_outside_paths: bool,
    },
}

/// Parses `123`, `64K`, `512M`, `8G`, `1T` (binary units).
pub(crate) fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let (num, mul) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let m = match c.to_ascii_uppercase() {
                'K' => 1u64 << 10,
                'M' => 1 << 20,
                'G' => 1 << 30,
                'T' => 1 << 40,
                _ => return Err(format!("unknown size unit `{c}` (use K, M, G or T)")),
            };
            (&t[..i], m)
        }
        _ => (t, 1),
    };
    let n: f64 = num.parse().map_err(|_| format!("`{s}` is not a size"))?;
    if !(n.is_finite() && n >= 0.0) {
        return Err(format!("`{s}` is not a size"));
    }
    Ok((n * mul as f64) as u64)
}

/// The most worker threads `--threads` accepts on a machine with `cores` available
/// cores: 4× the cores, and never fewer than 16 (so results can be compared across
/// counts on small machines).
pub(crate) fn max_threads(cores: usize) -> usize {
    cores.saturating_mul(4).max(16)
}

fn main() -> ExitCode {
    heap::keep_freed_memory();
    // Interrupted (SIGINT, SIGTERM, SIGHUP): delete the temp files of outputs not yet
    // renamed, so existing outputs stay as they were and nothing half-written is left.
    // Exit 130, the shell's code for an interrupt.
    let _ = ctrlc::set_handler(|| {
        volga_io::remove_temp_files();
        eprintln!("interrupted: no output written");
        std::process::exit(130);
    });
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("error: --threads must be ≥ 1");
            return ExitCode::from(2);
        }
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        let cap = max_threads(cores);
        if n > cap {
            eprintln!(
                "error: --threads {n} is more than this machine can run usefully: at most {cap} (4× its {cores} available cores, and at least 16)"
            );
            return ExitCode::from(2);
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(n).build_global() {
            eprintln!("error: cannot start {n} threads: {e}");
            return ExitCode::from(1);
        }
    }
    match cli.command {
        Command::Build {
            scene,
            out,
            memory_limit,
            allow_outside_paths,
        } => {
            volga_core::memory::set_input_limit(memory_limit);
            let progress = progress::BarProgress::new();
            let options = BuildOptions {
                out_dir: out,
                memory_limit,
                stage_start: Some(heap::stage_start),
                allow_outside_paths,
            };
            match build(&scene, &options, &progress) {
                Ok(report) => {
                    for o in &report.outputs {
                        println!("wrote {}", o.display());
                    }
                    println!(
                        "built {} in {:.2} s: {} active voxels in {} bricks",
                        scene.display(),
                        report.total_wall_s,
                        report.voxels.active,
                        report.voxels.bricks
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(if e.is_bad_input() { 2 } else { 1 })
                }
            }
        }
        Command::Voxelize(args) => {
            let progress = progress::BarProgress::new();
            match voxelize::run(args, &progress) {
                Ok(()) => ExitCode::SUCCESS,
                Err(f) => {
                    eprintln!("error: {}", f.message);
                    ExitCode::from(f.code)
                }
            }
        }
        Command::Validate(args) => match validate::run(args) {
            Ok(true) => ExitCode::SUCCESS,
            Ok(false) => ExitCode::from(1),
            Err(f) => {
                eprintln!("error: {}", f.message);
                ExitCode::from(f.code)
            }
        },
        Command::Convert(args) => match convert::run(args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(f) => {
                eprintln!("error: {}", f.message);
                ExitCode::from(f.code)
            }
        },
        Command::Sculpt(args) => match sculpt::run(args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(f) => {
                eprintln!("error: {}", f.message);
                ExitCode::from(f.code)
            }
        },
        Command::Adf(args) => match adf::run(args, &progress::BarProgress::new()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(f) => {
                eprintln!("error: {}", f.message);
                ExitCode::from(f.code)
            }
        },
        Command::Bench(command) => match bench::run(command) {
            Ok(()) => ExitCode::SUCCESS,
            Err(f) => {
                eprintln!("error: {}", f.message);
                ExitCode::from(f.code)
            }
        },
        Command::Accuracy(args) => match accuracy::run(args) {
            Ok(()) => ExitCode::SUCCESS,
            Err(f) => {
                eprintln!("error: {}", f.message);
                ExitCode::from(f.code)
            }
        },
        Command::Plan {
            scene,
            memory_limit,
            allow_outside_paths,
        } => {
            volga_core::memory::set_input_limit(memory_limit);
            // The same stages as `build` up to the plan, with the same memory limit.
            let result = validate_scene(&scene).and_then(|mut s| {
                s.allow_outside_paths = allow_outside_paths;
                s.resolve(memory_limit)?;
                plan(&s, memory_limit)
            });
            match result {
                Ok(p) => {
                    println!("{}", serde_json::to_string_pretty(&p).expect("plan serializes"));
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(2)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{max_threads, parse_size};

    #[test]
    fn thread_cap() {
        assert_eq!(max_threads(1), 16);
        assert_eq!(max_threads(2), 16);
        assert_eq!(max_threads(64), 256);
    }

    #[test]
    fn sizes() {
        assert_eq!(parse_size("512"), Ok(512));
        assert_eq!(parse_size("1K"), Ok(1024));
        assert_eq!(parse_size("1.5G"), Ok(3 << 29));
        assert!(parse_size("12Q").is_err());
        assert!(parse_size("-1").is_err());
        assert!(parse_size("").is_err());
    }
}
