//! Event counters that threads bump without sharing a cache line: one slot per rayon
//! worker (modulo [`SLOTS`]), summed when read. Counts are exact for any thread count.

use std::sync::atomic::{AtomicU64, Ordering};

/// Slots; rayon workers beyond this share slots (still exact, just contended).
pub const SLOTS: usize = 16;

#[repr(align(64))]
#[derive(Debug, Default)]
struct Slot(AtomicU64);

/// A sharded event counter.
#[derive(Debug, Default)]
pub struct Counter {
    slots: [Slot; SLOTS],
}

impl Counter {
    /// A counter at 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `n` events (to the calling rayon worker's slot).
    #[inline]
    pub fn add(&self, n: u64) {
        let i = rayon::current_thread_index().unwrap_or(0) % SLOTS;
        self.slots[i].0.fetch_add(n, Ordering::Relaxed);
    }

    /// The sum of all slots.
    pub fn get(&self) -> u64 {
        self.slots.iter().map(|s| s.0.load(Ordering::Relaxed)).sum()
    }

    /// Sets every slot back to 0.
    pub fn reset(&self) {
        for s in &self.slots {
            s.0.store(0, Ordering::Relaxed);
        }
    }
}
