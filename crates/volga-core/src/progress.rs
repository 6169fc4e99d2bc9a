/// Progress reporting from long kernel loops, without the kernel depending on a UI.
///
/// Implementations must be cheap and thread-safe: parallel loops call `inc` from
/// several workers. The CLI implements it with a progress bar on stderr.
pub trait Progress: Sync {
    /// Announce a new step of `total` units named `stage`.
    fn start(&self, stage: &str, total: u64);
    /// `n` more units of the current step are done.
    fn inc(&self, n: u64);
    /// The current step is over.
    fn finish(&self);
}

/// A [`Progress`] that shows nothing.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _stage: &str, _total: u64) {}
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
}
