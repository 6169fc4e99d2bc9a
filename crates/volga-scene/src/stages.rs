//! Per-stage wall time and peak memory for the build report.

use std::time::Instant;

use serde::Serialize;

/// One stage of a job as `report.json` lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageReport {
    /// The stage's name: `load`, `resolve`, `plan`, `voxelize`, `render:{image}`,
    /// `encode:{image}`, `write`, `mesh:{name}`.
    pub name: String,
    /// Wall time of the stage in seconds.
    pub wall_s: f64,
    /// Peak resident memory of the process (bytes, `VmHWM` read at the stage's end;
    /// 0 where /proc is unavailable): the peak during the stage when the program
    /// resets the high-water mark at each stage's start (a
    /// [`Stages::with_stage_start`] hook, as the `volga` CLI does), else the process's
    /// peak so far.
    pub peak_mem_bytes: u64,
}

/// Wall time and peak memory of the named stages of a job, in order.
#[derive(Debug, Default)]
pub struct Stages {
    /// The stages run so far.
    pub list: Vec<StageReport>,
    /// Called at the start of every stage (see [`Stages::with_stage_start`]).
    stage_start: Option<fn()>,
}

impl Stages {
    /// Stages that call `hook` at the start of each one. The library never changes
    /// process-wide state itself; a program that owns its process may pass
    /// [`reset_peak_rss`] so each stage's peak is its own.
    pub fn with_stage_start(hook: fn()) -> Self {
        Stages {
            list: Vec::new(),
            stage_start: Some(hook),
        }
    }

    /// Runs `f` as the stage `name`, recording its wall time and peak memory.
    pub fn run<T>(&mut self, name: impl Into<String>, f: impl FnOnce() -> T) -> T {
        if let Some(hook) = self.stage_start {
            hook();
        }
        let start = Instant::now();
        let out = f();
        self.list.push(StageReport {
            name: name.into(),
            wall_s: start.elapsed().as_secs_f64(),
            peak_mem_bytes: peak_rss_bytes(),
        });
        out
    }
}

/// Resets the process's peak resident set (`VmHWM`) to its current size by writing 5
/// to `/proc/self/clear_refs` (Linux ≥ 4.0; nothing elsewhere). It changes state that
/// belongs to the whole process (what an embedding program's own peak-memory readings
/// see), so only a program that owns its process should call it, e.g. as a
/// [`Stages::with_stage_start`] hook.
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's peak resident set since the last reset, in bytes.
pub fn peak_rss_bytes() -> u64 {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return 0;
    };
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
        .map_or(0, |kib| kib * 1024)
}
