//! Per-stage wall time and peak memory for the build report.

use std::time::Instant;

use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageReport {
    pub name: String,
    pub wall_s: f64,
    /// Peak resident memory of the process during the stage (bytes), measured by
    /// resetting the kernel's high-water mark (`/proc/self/clear_refs`) at the stage's
    /// start and reading `VmHWM` at its end. 0 where /proc is unavailable.
    pub peak_mem_bytes: u64,
}

#[derive(Debug, Default)]
pub struct Stages {
    pub list: Vec<StageReport>,
}

impl Stages {
    pub fn run<T>(&mut self, name: impl Into<String>, f: impl FnOnce() -> T) -> T {
        reset_peak_rss();
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

fn reset_peak_rss() {
    // Writing "5" resets VmHWM to the current RSS (Linux ≥ 4.0); ignore failure.
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
