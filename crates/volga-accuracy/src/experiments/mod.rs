//! The registry of experiments: one function per knob, each with its exact reference.
//!
//! **Adding a knob** (cubic filters, pre-integration, shadow quality, ADF tolerance,
//! octree depth…): write `experiments/<knob>.rs` with
//! `pub const EXPERIMENT: Experiment = Experiment { id, run }`, whose `run` sweeps the
//! knob at [`Size::Quick`] and [`Size::Full`] sizes and returns a [`KnobResult`] (every
//! setting timed with [`crate::timed`], its errors measured against an exact
//! reference, which a test of the same file checks against an independent
//! computation), then add the module and one line to [`EXPERIMENTS`]. The table, the
//! plot and the JSON follow from the result; `volga accuracy --quick` in the test suite
//! runs it from then on.

use volga_core::Progress;

use crate::KnobResult;

mod adf_tolerance;
mod binary_vs_antialiased;
mod extraction;
mod filter_width;
mod narrow_band;
mod render_effects;
mod render_filters;
mod render_step;
mod resolution;
mod supersample;

pub use supersample::supersampled_binary;

/// How large an experiment's settings are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Size {
    /// Every setting kind at small sizes: seconds, for the test suite.
    Quick,
    /// The sizes the committed tables and plots show: minutes.
    Full,
}

impl Size {
    /// `quick` or `full`, as the report and `volga accuracy` name the size.
    pub fn name(self) -> &'static str {
        match self {
            Size::Quick => "quick",
            Size::Full => "full",
        }
    }

    /// `quick` at [`Size::Quick`], `full` at [`Size::Full`].
    pub fn pick<T>(self, quick: T, full: T) -> T {
        match self {
            Size::Quick => quick,
            Size::Full => full,
        }
    }
}

/// What an experiment is given: its size and where to report progress (one unit
/// per setting).
pub struct Context<'a> {
    /// The size to run the experiment's settings at.
    pub size: Size,
    progress: &'a dyn Progress,
    /// Extra output files (images) the experiments attach, in attachment order.
    attachments: std::sync::Mutex<Vec<(String, Vec<u8>)>>,
}

impl<'a> Context<'a> {
    /// A context for experiments of `size`, reporting progress to `progress`, with no
    /// attachments yet.
    pub fn new(size: Size, progress: &'a dyn Progress) -> Self {
        Context {
            size,
            progress,
            attachments: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// Adds an output file `name` (e.g. an image an experiment rendered) beside the
    /// tables and plots.
    pub fn attach(&self, name: &str, bytes: Vec<u8>) {
        self.attachments
            .lock()
            .expect("attachments lock")
            .push((name.to_string(), bytes));
    }

    /// The attached files, in attachment order.
    pub fn take_attachments(&self) -> Vec<(String, Vec<u8>)> {
        std::mem::take(&mut *self.attachments.lock().expect("attachments lock"))
    }

    /// Announces `settings` settings for the experiment `id`.
    pub fn start(&self, id: &str, settings: usize) {
        self.progress.start(id, settings as u64);
    }

    /// One more setting is measured.
    pub fn setting_done(&self) {
        self.progress.inc(1);
    }

    /// The experiment is done: ends its progress report.
    pub fn finish(&self) {
        self.progress.finish();
    }
}

/// One knob's experiment: `run` sweeps the knob and measures every setting.
#[derive(Clone, Copy)]
pub struct Experiment {
    /// File stem of its outputs (`<id>.md`, `<id>.svg`).
    pub id: &'static str,
    /// Sweeps the knob and measures every setting, reporting progress through the context.
    pub run: fn(&Context) -> KnobResult,
}

/// Every experiment `volga accuracy` runs, in the order of the outputs.
pub const EXPERIMENTS: &[Experiment] = &[
    resolution::EXPERIMENT,
    binary_vs_antialiased::EXPERIMENT,
    filter_width::EXPERIMENT,
    narrow_band::EXPERIMENT,
    render_step::EXPERIMENT,
    render_filters::EXPERIMENT,
    adf_tolerance::EXPERIMENT,
    extraction::EXPERIMENT,
    render_effects::EXPERIMENT,
    render_effects::SUPERSAMPLING,
];

/// The names of the files experiments attach ([`Context::attach`]), in order.
pub(crate) fn attachment_names() -> Vec<String> {
    render_filters::attachment_names()
}

/// The grid of `n³` voxels whose cells tile the scene box `[−1, 1]³`.
pub fn scene_grid(n: u32) -> volga_core::Grid {
    volga_core::Grid::covering(&crate::references::scene_box(), glam::UVec3::splat(n)).expect("valid scene grid")
}

/// The solid-voxelization errors every voxelization experiment reports: position,
/// normal, volume and area against the shape's exact distance, volume and area.
pub(crate) fn solid_errors(
    setting: crate::Setting,
    volume: &volga_core::SparseVolume,
    measured_volume: f64,
    shape: &crate::references::ReferenceShape,
) -> crate::Setting {
    let e = crate::measure::surface_errors(volume, 0.5, shape);
    setting
        .error("position_rms", e.position_rms)
        .error("position_max", e.position_max)
        .error("normal_rms_deg", e.normal_rms_deg)
        .error("volume_rel", (measured_volume / shape.volume() - 1.0).abs())
        .error("area_rel", (e.area / shape.area() - 1.0).abs())
}

/// The metrics of [`solid_errors`], for tables and plots.
pub(crate) fn solid_metrics() -> Vec<crate::Metric> {
    use crate::Metric;
    vec![
        Metric {
            id: "position_rms",
            label: "surface position error, RMS (world units)",
        },
        Metric {
            id: "normal_rms_deg",
            label: "normal error, RMS (degrees)",
        },
        Metric {
            id: "volume_rel",
            label: "volume error (relative)",
        },
        Metric {
            id: "area_rel",
            label: "area error (relative)",
        },
        Metric {
            id: "position_max",
            label: "surface position error, max both ways (world units)",
        },
    ]
}
