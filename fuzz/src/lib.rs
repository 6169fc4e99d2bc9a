//! The shared harness of volga's fuzz targets (see `harness.rs` and docs/FUZZING.md).

mod harness;

pub use harness::{Harness, Mutator, SceneBudget, ADF_MAX_CELLS, ADF_MAX_DEPTH, MAX_STROKES, NRRD_SPLIT, TARGETS};

/// The process-wide harness of a fuzz target.
pub fn harness() -> &'static Harness {
    static HARNESS: std::sync::OnceLock<Harness> = std::sync::OnceLock::new();
    HARNESS.get_or_init(Harness::new)
}
