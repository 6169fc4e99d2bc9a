//! What every CLI test needs: run the built `volga`, read its stderr, pass paths.
#![allow(dead_code)] // each test file uses its own subset

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `volga` binary built for these tests.
pub fn volga(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_volga"))
        .args(args)
        .output()
        .expect("volga runs")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as a command-line argument.
pub fn arg(p: &Path) -> &str {
    p.to_str().unwrap()
}
