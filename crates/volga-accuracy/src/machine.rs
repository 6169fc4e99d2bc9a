//! The machine a run measured: what the raw figures need beside them to be compared.

use serde::Serialize;

/// Cores, CPU, OS, volga's version and commit, and the load before and after the run.
#[derive(Debug, Clone, Serialize)]
pub struct Machine {
    /// Cores available to this process.
    pub cores: usize,
    /// Worker threads the experiments ran with (rayon's pool).
    pub threads: usize,
    /// `model name` from `/proc/cpuinfo`.
    pub cpu_model: Option<String>,
    /// `PRETTY_NAME` from `/etc/os-release`, and the kernel release.
    pub os: Option<String>,
    /// Kernel release, from `/proc/sys/kernel/osrelease`.
    pub kernel: Option<String>,
    /// Physical memory (`MemTotal` of `/proc/meminfo`), in bytes.
    pub memory_total_bytes: Option<u64>,
    /// The version of volga that ran.
    pub volga_version: &'static str,
    /// `git describe --always --dirty` of the working directory, if it is a checkout.
    pub commit: Option<String>,
    /// 1-, 5- and 15-minute load averages (`/proc/loadavg`) at the start and the end.
    pub load_average_start: Option<[f64; 3]>,
    /// Load averages at the end of the run (`None` until the run finishes, or without
    /// `/proc/loadavg`).
    pub load_average_end: Option<[f64; 3]>,
}

impl Machine {
    /// Reads what it can; missing pieces are `None`, never an error.
    pub fn current() -> Self {
        Machine {
            cores: std::thread::available_parallelism().map_or(1, |c| c.get()),
            threads: rayon::current_num_threads(),
            cpu_model: read("/proc/cpuinfo").and_then(|t| field(&t, "model name", ':')),
            os: read("/etc/os-release")
                .and_then(|t| field(&t, "PRETTY_NAME", '='))
                .map(|s| s.trim_matches('"').to_string()),
            kernel: read("/proc/sys/kernel/osrelease").map(|s| s.trim().to_string()),
            memory_total_bytes: read("/proc/meminfo")
                .and_then(|t| field(&t, "MemTotal", ':'))
                .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
                .map(|kib| kib * 1024),
            volga_version: env!("CARGO_PKG_VERSION"),
            commit: git_commit(),
            load_average_start: load_average(),
            load_average_end: None,
        }
    }
}

fn read(path: &str) -> Option<String> {
    std::fs::read_to_string(path).ok()
}

/// The value after `sep` on the first line whose key is `key`.
fn field(text: &str, key: &str, sep: char) -> Option<String> {
    text.lines().find_map(|l| {
        let (k, v) = l.split_once(sep)?;
        (k.trim() == key).then(|| v.trim().to_string())
    })
}

pub(crate) fn load_average() -> Option<[f64; 3]> {
    let text = read("/proc/loadavg")?;
    let mut it = text.split_whitespace().map(|v| v.parse::<f64>().ok());
    Some([it.next()??, it.next()??, it.next()??])
}

fn git_commit() -> Option<String> {
    let out = std::process::Command::new("git")
        .args(["describe", "--always", "--dirty", "--abbrev=12"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
        .filter(|s| !s.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_key_value_files() {
        let cpuinfo = "processor\t: 0\nmodel name\t: Some CPU @ 2.0GHz\n";
        assert_eq!(field(cpuinfo, "model name", ':').as_deref(), Some("Some CPU @ 2.0GHz"));
        let os = "NAME=\"X\"\nPRETTY_NAME=\"Debian 12\"\n";
        assert_eq!(field(os, "PRETTY_NAME", '=').as_deref(), Some("\"Debian 12\""));
        assert_eq!(field(os, "MISSING", '='), None);
    }

    #[test]
    fn reads_this_machine() {
        let m = Machine::current();
        assert!(m.cores >= 1 && m.threads >= 1);
    }
}
