//! Memory accounting: what the machine has, and refusing what it cannot hold.

use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

/// The limit set by [`set_input_limit`]; 0 when none is set.
static INPUT_LIMIT: AtomicU64 = AtomicU64::new(0);

/// Sets the most memory (bytes) one input file's contents may take in this process:
/// the CLI sets it from `--memory-limit`. `None` returns to the default, the machine's
/// available memory.
pub fn set_input_limit(limit: Option<u64>) {
    INPUT_LIMIT.store(limit.map_or(0, |l| l.max(1)), Ordering::Relaxed);
}

/// The most bytes a reader may hold for one input (a file's contents, or the voxels a
/// volume file declares): the limit set by [`set_input_limit`], else the machine's
/// available memory, else (where that cannot be read) 16 GiB.
pub fn input_limit() -> u64 {
    match INPUT_LIMIT.load(Ordering::Relaxed) {
        0 => available_bytes().unwrap_or(16 << 30),
        l => l,
    }
}

/// Bytes of memory available to a new allocation, from `/proc/meminfo`'s
/// `MemAvailable` (Linux); `None` where that cannot be read.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo_available(&text)
}

fn parse_meminfo_available(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A byte count printed with a binary unit (`1.50 GiB`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Bytes(pub u128);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const UNITS: [&str; 7] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
        let mut v = self.0 as f64;
        let mut u = 0;
        while v >= 1024.0 && u + 1 < UNITS.len() {
            v /= 1024.0;
            u += 1;
        }
        if u == 0 {
            write!(f, "{} B", self.0)
        } else {
            write!(f, "{v:.2} {}", UNITS[u])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_meminfo() {
        let t = "MemTotal: 100 kB\nMemFree: 10 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(parse_meminfo_available(t), Some(2048 * 1024));
        assert_eq!(parse_meminfo_available("MemTotal: 1 kB\n"), None);
    }

    #[test]
    fn formats_bytes() {
        assert_eq!(Bytes(512).to_string(), "512 B");
        assert_eq!(Bytes(3 * 1024 * 1024 * 1024 / 2).to_string(), "1.50 GiB");
    }
}
