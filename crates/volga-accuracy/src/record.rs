//! What an experiment returns: settings of one knob, each with its errors, time and memory.

use std::collections::BTreeMap;
use std::time::Instant;

use serde::Serialize;

/// One setting of a knob, measured: the parameters that define it, every error
/// against the reference, the wall time of the operation the knob controls and the
/// memory it holds.
#[derive(Debug, Clone, Serialize)]
pub struct Setting {
    /// Short label drawn beside the point (`N=128`, `W=3.46`).
    pub label: String,
    /// The setting's parameters (resolution, widths, steps…).
    pub params: BTreeMap<String, f64>,
    /// Errors by metric id ([`Metric::id`]); units in the metric's label.
    pub errors: BTreeMap<String, f64>,
    /// Wall time of the operation the knob controls (seconds; the fastest of the
    /// repeats [`timed`] made).
    pub time_s: f64,
    /// Bytes of the data structure the operation produced (a volume's bricks, an image).
    pub memory_bytes: u64,
    /// The process's peak resident set while the operation ran, where Linux lets us
    /// reset it (`/proc/self/clear_refs`); includes everything else the process holds.
    pub peak_rss_bytes: Option<u64>,
}

/// The settings of one method or input along the knob (one curve of the plot).
#[derive(Debug, Clone, Serialize)]
pub struct Series {
    /// Legend label of the curve (a method or input, e.g. `binary`, `bunny (… triangles)`).
    pub name: String,
    /// Its settings, in the order the curve joins them.
    pub settings: Vec<Setting>,
}

/// An error measure an experiment reports: the table has a column and the plot a panel
/// for each.
#[derive(Debug, Clone, Serialize)]
pub struct Metric {
    /// Key of the metric in [`Setting::errors`] and the raw JSON (`position_rms`,
    /// `max_error`).
    pub id: &'static str,
    /// Axis and column label, with its unit.
    pub label: &'static str,
}

/// Everything one experiment measured, ready for its table, plot and the raw JSON.
#[derive(Debug, Clone, Serialize)]
pub struct KnobResult {
    /// File stem of its table and plot (`resolution` → `resolution.md`, `resolution.svg`).
    pub id: &'static str,
    /// Heading of the table and title of the plot.
    pub title: &'static str,
    /// What is varied.
    pub knob: &'static str,
    /// The exact reference the errors are measured against.
    pub reference: &'static str,
    /// What the time measures.
    pub timed: &'static str,
    /// The error measures reported, one table column and plot panel each.
    pub metrics: Vec<Metric>,
    /// The curves: one per method or input.
    pub series: Vec<Series>,
}

impl Setting {
    /// A measured setting with no errors yet: `label` for the plot, its parameters as
    /// `(name, value)`, the [`Timing`] from [`timed`] and `memory_bytes` of the data it
    /// produced. Add errors with [`Setting::error`].
    pub fn new(label: impl Into<String>, params: &[(&str, f64)], timing: Timing, memory_bytes: u64) -> Self {
        Setting {
            label: label.into(),
            params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            errors: BTreeMap::new(),
            time_s: timing.seconds,
            memory_bytes,
            peak_rss_bytes: timing.peak_rss_bytes,
        }
    }

    /// Adds an error figure (builder style).
    pub fn error(mut self, metric: &str, value: f64) -> Self {
        self.errors.insert(metric.to_string(), value);
        self
    }
}

/// How long an operation took and the peak memory while it ran.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Wall time of the fastest run, in seconds.
    pub seconds: f64,
    /// Peak resident set of the process while `op` ran, in bytes; `None` where the peak
    /// could not be reset or read (outside Linux).
    pub peak_rss_bytes: Option<u64>,
}

/// Runs `op` and times it. Operations faster than 0.2 s are repeated (at most 20 runs,
/// at most about 1 s in all) and the fastest run counts, so small settings are not
/// timer and machine-load noise. `op` must be deterministic: the last result is
/// returned.
pub fn timed<T>(mut op: impl FnMut() -> T) -> (T, Timing) {
    let reset = reset_peak_rss();
    let start = Instant::now();
    let mut result = op();
    let mut best = start.elapsed().as_secs_f64();
    let mut total = best;
    let mut runs = 1;
    while best < 0.2 && runs < 20 && total < 1.0 {
        let t = Instant::now();
        result = op();
        let s = t.elapsed().as_secs_f64();
        best = best.min(s);
        total += s;
        runs += 1;
    }
    let peak = if reset {
        read_status_kib("VmHWM:").map(|k| k * 1024)
    } else {
        None
    };
    (
        result,
        Timing {
            seconds: best,
            peak_rss_bytes: peak,
        },
    )
}

/// Resets the process's peak RSS (Linux ≥ 4.0: writing 5 to `/proc/self/clear_refs`).
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// A `kB` field of `/proc/self/status`.
fn read_status_kib(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timed_returns_the_result_and_a_positive_time() {
        let (v, t) = timed(|| (0..1000u64).sum::<u64>());
        assert_eq!(v, 499_500);
        assert!(t.seconds >= 0.0 && t.seconds < 1.0);
    }

    #[test]
    fn settings_collect_errors_by_metric() {
        let t = Timing {
            seconds: 0.5,
            peak_rss_bytes: None,
        };
        let s = Setting::new("N=8", &[("resolution", 8.0)], t, 64).error("position_rms", 0.1);
        assert_eq!(s.params["resolution"], 8.0);
        assert_eq!(s.errors["position_rms"], 0.1);
        assert_eq!(s.time_s, 0.5);
    }
}
