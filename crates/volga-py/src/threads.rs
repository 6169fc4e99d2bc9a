//! `threads=`: heavy calls run without the GIL on a rayon pool of the requested size.
//! Pools are kept per size, so repeated calls do not respawn threads. The kernel's
//! results are identical for any thread count (its parallel loops write by index).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use pyo3::prelude::*;
use rayon::{ThreadPool, ThreadPoolBuilder};

use crate::errors::value_error;

/// Most threads a call may ask for: 4× the cores, at least 16 (as `volga --threads`).
pub fn max_threads() -> usize {
    (4 * std::thread::available_parallelism().map_or(1, |n| n.get())).max(16)
}

fn pool(threads: usize) -> PyResult<Arc<ThreadPool>> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<ThreadPool>>>> = OnceLock::new();
    let pools = POOLS.get_or_init(|| Mutex::new(HashMap::new()));
    let mut pools = pools.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(p) = pools.get(&threads) {
        return Ok(p.clone());
    }
    let p = Arc::new(
        ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("volga-{i}"))
            .build()
            .map_err(|e| value_error(format!("threads={threads}: {e}")))?,
    );
    pools.insert(threads, p.clone());
    Ok(p)
}

/// Checks `threads` (None: rayon's global pool, sized by `RAYON_NUM_THREADS` or the cores).
pub fn check(threads: Option<usize>) -> PyResult<()> {
    match threads {
        Some(0) => Err(value_error("threads must be ≥ 1 (or None for every core)")),
        Some(t) if t > max_threads() => Err(value_error(format!(
            "threads={t} is more than the {} a call may use (4× the cores, at least 16)",
            max_threads()
        ))),
        _ => Ok(()),
    }
}

/// Runs `f` with the GIL released, on the pool for `threads`.
pub fn run<R: Send>(py: Python<'_>, threads: Option<usize>, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    check(threads)?;
    match threads {
        None => Ok(py.detach(f)),
        Some(t) => {
            let pool = pool(t)?;
            Ok(py.detach(move || pool.install(f)))
        }
    }
}

/// The number of threads a call with `threads=None` uses.
#[pyfunction]
pub fn default_threads() -> usize {
    rayon::current_num_threads()
}
