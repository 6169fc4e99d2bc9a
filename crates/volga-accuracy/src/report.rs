//! The outputs of a run: one Markdown table per knob, one SVG plot per knob, and one
//! JSON file with every raw figure and the machine.

use serde::Serialize;

use crate::machine::{load_average, Machine};
use crate::{plot, KnobResult, Size, EXPERIMENTS};

/// Name of the JSON file of raw figures.
pub const RAW_JSON: &str = "accuracy.json";

/// Everything one `volga accuracy` run measured.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The command line that produced it.
    pub command: String,
    /// `quick` or `full`.
    pub size: &'static str,
    /// Wall time of the whole run (seconds).
    pub wall_time_s: f64,
    /// The machine the run measured, with its load before and after.
    pub machine: Machine,
    /// One result per experiment run, in registry order.
    pub experiments: Vec<KnobResult>,
    /// Files the experiments attached (rendered images), written after the tables.
    #[serde(skip)]
    pub attachments: Vec<(String, Vec<u8>)>,
}

/// The file names a run writes, in order: `<id>.md` and `<id>.svg` per experiment, then
/// [`RAW_JSON`], then the images experiments attach. The same for `--quick` and the
/// full run.
pub fn output_names() -> Vec<String> {
    let mut names: Vec<String> = EXPERIMENTS
        .iter()
        .flat_map(|e| [format!("{}.md", e.id), format!("{}.svg", e.id)])
        .collect();
    names.push(RAW_JSON.to_string());
    names.extend(crate::experiments::attachment_names());
    names
}

impl Report {
    pub(crate) fn new(command: String, size: Size, machine: Machine) -> Self {
        Report {
            command,
            size: size.name(),
            wall_time_s: 0.0,
            machine,
            experiments: Vec::new(),
            attachments: Vec::new(),
        }
    }

    pub(crate) fn finish(&mut self, wall_time_s: f64) {
        self.wall_time_s = wall_time_s;
        self.machine.load_average_end = load_average();
    }

    /// The output files as `(name, contents)`, in [`output_names`] order, then the
    /// attached files.
    pub fn files(&self) -> Result<Vec<(String, Vec<u8>)>, String> {
        let mut out = Vec::new();
        for result in &self.experiments {
            out.push((format!("{}.md", result.id), markdown_table(result, self).into_bytes()));
            out.push((format!("{}.svg", result.id), plot::plot_svg(result)?.into_bytes()));
        }
        let json = serde_json::to_string_pretty(self).map_err(|e| e.to_string())?;
        out.push((RAW_JSON.to_string(), json.into_bytes()));
        out.extend(self.attachments.iter().cloned());
        Ok(out)
    }
}

/// A figure with three significant digits: decimals for 0.001 ≤ |v| < 10⁴, else
/// scientific notation; `—` for a missing or non-finite figure.
pub fn format_figure(v: Option<f64>) -> String {
    let Some(v) = v.filter(|v| v.is_finite()) else {
        return "—".into();
    };
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.2e}")
    }
}

fn mib(bytes: u64) -> String {
    format_figure(Some(bytes as f64 / (1024.0 * 1024.0)))
}

/// The Markdown table of one knob: a row per setting, a column per metric, then time
/// and memory.
pub fn markdown_table(result: &KnobResult, report: &Report) -> String {
    let mut s = format!("# {}\n\n", result.title);
    s += &format!("* **Knob:** {}.\n", result.knob);
    s += &format!("* **Reference:** {}.\n", result.reference);
    s += &format!("* **Time:** {}.\n", result.timed);
    s += "* **Memory:** bytes of the data structure the operation produced; peak RSS is the whole process's while it ran.\n";
    s += &format!(
        "* **Run:** `{}` ({} size), {:.1} s wall time, {} threads on {} cores ({}).\n\n",
        report.command,
        report.size,
        report.wall_time_s,
        report.machine.threads,
        report.machine.cores,
        report.machine.cpu_model.as_deref().unwrap_or("unknown CPU"),
    );
    s += &format!("![{}]({}.svg)\n\n", result.title, result.id);
    s += "| series | setting |";
    for m in &result.metrics {
        s += &format!(" {} |", m.label);
    }
    s += " time (s) | memory (MiB) | peak RSS (MiB) |\n|---|---|";
    for _ in &result.metrics {
        s += "---:|";
    }
    s += "---:|---:|---:|\n";
    for series in &result.series {
        for p in &series.settings {
            s += &format!("| {} | {} |", series.name, p.label);
            for m in &result.metrics {
                s += &format!(" {} |", format_figure(p.errors.get(m.id).copied()));
            }
            s += &format!(
                " {} | {} | {} |\n",
                format_figure(Some(p.time_s)),
                mib(p.memory_bytes),
                p.peak_rss_bytes.map_or("—".to_string(), mib)
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_have_three_significant_digits() {
        assert_eq!(format_figure(Some(0.012345)), "0.0123");
        assert_eq!(format_figure(Some(123.456)), "123");
        assert_eq!(format_figure(Some(1.5)), "1.50");
        assert_eq!(format_figure(Some(2.5e-5)), "2.50e-5");
        assert_eq!(format_figure(Some(0.0)), "0");
        assert_eq!(format_figure(None), "—");
        assert_eq!(format_figure(Some(f64::NAN)), "—");
    }

    #[test]
    fn names_cover_every_experiment() {
        let names = output_names();
        let attached = crate::experiments::attachment_names();
        assert_eq!(names.len(), 2 * EXPERIMENTS.len() + 1 + attached.len());
        assert!(names.contains(&"resolution.svg".to_string()));
        assert_eq!(names[2 * EXPERIMENTS.len()], RAW_JSON);
        assert!(attached.contains(&"render_filters_catmull-rom_analytic.png".to_string()));
        assert_eq!(&names[2 * EXPERIMENTS.len() + 1..], &attached[..]);
    }
}
