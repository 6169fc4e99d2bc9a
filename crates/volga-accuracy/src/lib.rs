//! # volga-accuracy — what accuracy costs in time
//!
//! Every knob of volga that trades accuracy for speed is swept here and each setting
//! measured three ways: its **error** against an exact reference (analytic shapes
//! with exact distances, volumes and areas; brute-force distances to a mesh; the
//! Marschner–Lobb signal), its **wall time** and its **memory**. [`run`] executes the
//! registry of experiments ([`EXPERIMENTS`], one function per knob; see the
//! `experiments` module for how to add one) and returns a [`Report`] whose
//! [`Report::files`] are one Markdown table and one SVG plot per knob plus one JSON of
//! every raw figure and the machine it ran on. `volga accuracy` writes them;
//! `docs/accuracy/` holds the committed run.
//!
//! ## Spaces and units
//! Every experiment voxelizes or renders inside the world box `[−1, 1]³`
//! ([`references::scene_box`]); positions are world space `f64`, errors are world
//! units unless a metric's label says voxels, degrees or a relative figure. Times are
//! seconds of wall time with all worker threads; memory is bytes.
//!
//! ## Determinism
//! Every error figure is a pure function of the setting: sums are formed per brick
//! or per chunk and added in a fixed order, so 1 and 16 threads give the same
//! figures. Only times and peak RSS vary between runs.
//!
//! ```no_run
//! use volga_accuracy::{run, Size};
//! use volga_core::NoProgress;
//! let report = run(Size::Quick, "example", &NoProgress);
//! for (name, bytes) in report.files().unwrap() {
//!     println!("{name}: {} bytes", bytes.len());
//! }
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod experiments;
mod machine;
pub mod measure;
mod plot;
mod record;
pub mod references;
mod report;

use std::time::Instant;

use volga_core::Progress;

pub use experiments::{scene_grid, supersampled_binary, Context, Experiment, Size, EXPERIMENTS};
pub use machine::Machine;
pub use record::{timed, KnobResult, Metric, Series, Setting, Timing};
pub use report::{format_figure, markdown_table, output_names, Report, RAW_JSON};

/// Runs every experiment of [`EXPERIMENTS`] at `size`, reporting one progress unit
/// per setting; `command` is recorded in the report as the command line that ran it.
pub fn run(size: Size, command: &str, progress: &dyn Progress) -> Report {
    let start = Instant::now();
    let mut report = Report::new(command.to_string(), size, Machine::current());
    let ctx = Context::new(size, progress);
    for experiment in EXPERIMENTS {
        report.experiments.push((experiment.run)(&ctx));
    }
    report.attachments = ctx.take_attachments();
    report.finish(start.elapsed().as_secs_f64());
    report
}

/// Runs only the experiments of [`EXPERIMENTS`] whose ids are in `ids` (in registry
/// order), like [`run`]; `None` if an id names no experiment.
pub fn run_only(size: Size, command: &str, ids: &[String], progress: &dyn Progress) -> Option<Report> {
    if ids.iter().any(|id| !EXPERIMENTS.iter().any(|e| e.id == id.as_str())) {
        return None;
    }
    let start = Instant::now();
    let mut report = Report::new(command.to_string(), size, Machine::current());
    let ctx = Context::new(size, progress);
    for experiment in EXPERIMENTS.iter().filter(|e| ids.iter().any(|id| id == e.id)) {
        report.experiments.push((experiment.run)(&ctx));
    }
    report.attachments = ctx.take_attachments();
    report.finish(start.elapsed().as_secs_f64());
    Some(report)
}
