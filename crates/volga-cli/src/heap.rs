//! The process's heap: freed memory kept for the next job instead of handed back to the
//! kernel, and handed back at the start of each reported stage.
//!
//! glibc serves blocks above its mmap threshold (128 KiB, rising to at most 32 MiB)
//! with fresh mappings and unmaps them when freed, trims a heap's free top above
//! 128 KiB, and unmaps a worker thread's extra heap (64 MiB each) once it is empty. A
//! voxelizer call allocates tens of MiB of tables in such blocks (the bunny at N = 256:
//! about 16,000 pages), so every call faults them in and zeroes them again: about 40 ms
//! of CPU per call of the bunny's narrow band at 256, about 7 % of it (`perf`:
//! `exc_page_fault`, `clear_page_erms`). Served repeatedly (`bench --serve`, builds with
//! several nodes), the second and later calls reuse the first's pages.
//!
//! Each reported stage still measures its own peak: [`stage_start`] returns the free
//! memory to the kernel before resetting the peak.

/// Keeps freed blocks for reuse: blocks up to 32 MiB come from the heap, a heap's free
/// top is returned only above 1 GiB, and an empty worker heap is kept while less than
/// 64 MiB (the top pad) would be freed. Call once, before any thread allocates.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets glibc allocator parameters, under the allocator's own
    // lock; it takes plain integers and touches no memory of ours.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

/// Hands the heap's free memory back to the kernel, then resets the peak resident set
/// ([`volga_scene::reset_peak_rss`]): the stage hook the CLI passes to `build`,
/// `voxelize` and `bench`.
pub fn stage_start() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` releases free pages of glibc's heaps under the allocator's
    // own locks; memory in use is untouched.
    unsafe {
        libc::malloc_trim(0);
    }
    volga_scene::reset_peak_rss();
}
