//! `volga accuracy`: runs every accuracy experiment and writes one Markdown table and
//! one SVG plot per knob, and one JSON of raw figures, all or nothing.

use std::path::PathBuf;

use clap::Args;
use volga_accuracy::{run as run_experiments, run_only, Size, EXPERIMENTS, RAW_JSON};
use volga_io::StagedOutputs;

use crate::failure::{bad_input, failed, Failure};
use crate::progress::BarProgress;

#[derive(Args)]
pub struct AccuracyArgs {
    /// Run every experiment at small sizes (seconds; what the test suite runs). The
    /// same files are written.
    #[arg(long)]
    quick: bool,
    /// Run only these experiments (comma-separated ids, e.g. `render_filters`): their
    /// tables, plots and images are written, the JSON of every figure is not.
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Output directory (created if missing).
    #[arg(long, default_value = "docs/accuracy")]
    out: PathBuf,
}

/// The command line as typed, for the report (`volga accuracy --out docs/accuracy`).
fn command_line() -> String {
    std::iter::once("volga".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ")
}

pub fn run(args: AccuracyArgs) -> Result<(), Failure> {
    let out = &args.out;
    // Checked before minutes of work, not after.
    if out.exists() && !out.is_dir() {
        return Err(bad_input(format!(
            "--out {}: exists and is not a directory",
            out.display()
        )));
    }
    std::fs::create_dir_all(out)
        .map_err(|e| bad_input(format!("--out {}: cannot create the directory: {e}", out.display())))?;
    for id in &args.only {
        if !EXPERIMENTS.iter().any(|e| e.id == id) {
            let known: Vec<&str> = EXPERIMENTS.iter().map(|e| e.id).collect();
            return Err(bad_input(format!(
                "--only {id}: no such experiment (known: {})",
                known.join(", ")
            )));
        }
    }
    let size = if args.quick { Size::Quick } else { Size::Full };
    let progress = BarProgress::new();
    let report = if args.only.is_empty() {
        run_experiments(size, &command_line(), &progress)
    } else {
        run_only(size, &command_line(), &args.only, &progress)
            .ok_or_else(|| bad_input(format!("--only {}: unknown experiment id", args.only.join(","))))?
    };
    let mut files = report
        .files()
        .map_err(|e| failed(format!("cannot draw the plots: {e}")))?;
    if !args.only.is_empty() {
        // A partial run must not replace the JSON of every figure.
        files.retain(|(name, _)| name != RAW_JSON);
    }
    let mut staged = StagedOutputs::new();
    for (name, bytes) in &files {
        staged
            .stage(&out.join(name), |w| w.write_all(bytes))
            .map_err(|e| failed(e.to_string()))?;
    }
    let written = staged.commit().map_err(|e| failed(e.to_string()))?;
    for path in written {
        println!("wrote {}", path.display());
    }
    println!(
        "{} experiments ({} size) in {:.1} s",
        report.experiments.len(),
        size.name(),
        report.wall_time_s
    );
    Ok(())
}
