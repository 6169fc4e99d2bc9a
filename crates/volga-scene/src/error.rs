use std::path::PathBuf;

use thiserror::Error;
use volga_core::memory::Bytes;

/// Bad input in a scene: every message names the file and the line/column or the
/// field path, so the user can go straight to the mistake.
#[derive(Debug, Error)]
pub enum SceneError {
    #[error("cannot read {}: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{}: unsupported scene file extension (expected .ron or .json)", path.display())]
    Extension { path: PathBuf },
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{}: field `{field}`: {message}", path.display())]
    Invalid {
        path: PathBuf,
        field: String,
        message: String,
    },
    #[error(
        "{}: the build needs an estimated {needed} of memory ({detail}), more than the {limit} available; \
         lower grid.resolution or shrink grid.bounds",
        path.display()
    )]
    TooLarge {
        path: PathBuf,
        needed: Bytes,
        limit: Bytes,
        detail: String,
    },
}

/// A build that was planned but failed while running (an output could not be
/// written, say). Earlier outputs are left as they were.
#[derive(Debug, Error)]
pub enum BuildError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Io(#[from] volga_io::IoError),
    #[error("rendering image `{image}` failed: {message}")]
    Render { image: String, message: String },
}

impl BuildError {
    /// True when the user's input was at fault (CLI exit code 2), false when the build
    /// itself failed (exit code 1).
    pub fn is_bad_input(&self) -> bool {
        matches!(self, BuildError::Scene(_))
    }
}
