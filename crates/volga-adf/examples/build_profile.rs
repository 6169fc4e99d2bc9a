//! Times the build of a mesh's ADF alone (no render, no error measurement) and prints a
//! fingerprint of the tree, so two versions of the build can be compared for identical
//! output:
//!
//! `cargo run --release -p volga-adf --example build_profile -- MESH [TOLERANCE] [THREADS]`
//!
//! Prints one JSON line: wall and process CPU seconds of the build, the build's counters,
//! and `fingerprint`, a hash of every leaf (minimum, size, depth) and of the
//! reconstruction's bits at 2¹⁶ pseudo-random points of the root cube and at every leaf's
//! minimum corner.

use std::hash::{Hash, Hasher};
use std::time::Instant;

use glam::DVec3;
use volga_adf::{Adf, AdfOptions, MeshSource};

/// CPU seconds of this process so far (user + system, `/proc/self/stat`), 0 where not
/// readable.
fn process_cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which is in parentheses): utime is field 14, stime 15.
    let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else {
        return 0.0;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    // rest starts at field 3 (state): utime = field 14 → index 11.
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: build_profile MESH [TOLERANCE] [THREADS]");
    let tolerance: f64 = args.get(2).map_or(1e-3, |s| s.parse().expect("tolerance"));
    let threads: usize = args.get(3).map_or(0, |s| s.parse().expect("threads"));
    let mesh = volga_mesh::load_mesh(path).expect("mesh");
    let source = MeshSource::new(&mesh).expect("source");
    let options = AdfOptions::relative(tolerance, &mesh.bounds());
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
    let cpu0 = process_cpu_s();
    let start = Instant::now();
    let adf = pool.install(|| Adf::build(&source, options)).expect("build");
    let wall = start.elapsed().as_secs_f64();
    let cpu = process_cpu_s() - cpu0;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let leaves = adf.leaves();
    for &(min, size, depth) in &leaves {
        min.to_array().map(f64::to_bits).hash(&mut h);
        size.to_bits().hash(&mut h);
        depth.hash(&mut h);
        adf.distance(min).to_bits().hash(&mut h);
    }
    let root = adf.root_box();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..1 << 16 {
        let t = DVec3::new(next(), next(), next());
        let p = root.min + t * root.size();
        adf.distance(p).to_bits().hash(&mut h);
    }
    let s = adf.stats();
    println!(
        "{{\"build_s\": {wall:.3}, \"cpu_s\": {cpu:.2}, \"cells\": {}, \"leaves\": {}, \"pruned\": {}, \
         \"max_depth_leaves\": {}, \"jump_leaves\": {}, \"evaluations\": {}, \"source_queries\": {}, \
         \"integer_queries\": {}, \"fingerprint\": \"{:016x}\"}}",
        s.cells,
        s.leaves,
        s.pruned_leaves,
        s.max_depth_leaves,
        s.jump_leaves,
        s.evaluations,
        source.queries(),
        source.integer_queries(),
        h.finish()
    );
}
