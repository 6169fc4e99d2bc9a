//! Times the build of a mesh's ADF alone (no render, no error measurement) and prints a
//! fingerprint of the tree, so two versions of the build can be compared for identical
//! output:
//!
//! `cargo run --release -p volga-adf --example build_profile -- MESH [TOLERANCE] [THREADS]`
//!
//! Prints one JSON line: wall and process CPU seconds of the build, the build's counters,
//! and `fingerprint`, a hash of every leaf (minimum, size, depth) and of the
//! reconstruction's bits at 2¹⁶ pseudo-random points of the root cube and at every leaf's
//! minimum corner; `distinct_corners`, the distinct corner points of the leaves (the
//! fewest exact evaluations any build of these cells needs); `leaf_eval_ns`, the time of
//! one evaluation at the centre of a deepest leaf among its candidate list (the build's
//! path), and `leaf_eval_bvh_ns`, the same through the BVH.

use std::hash::{Hash, Hasher};
use std::time::Instant;

use glam::DVec3;
use volga_adf::{Adf, AdfOptions, AdfSource, MeshSource};

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
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
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
    // Distinct leaf corners: every stored corner value is one of them, so an ADF of these
    // cells needs at least this many exact evaluations (the rest of `evaluations` are test
    // points of leaves and of pruned cells' sign checks).
    let unit = adf.cell_size(adf.stats().depth_reached);
    let mut corners = rustc_hash::FxHashSet::default();
    for &(min, size, _) in &leaves {
        let k = ((min - root.min) / unit).round();
        let n = (size / unit).round() as u64;
        for b in 0..8u64 {
            let key = [
                k.x as u64 + (b & 1) * n,
                k.y as u64 + ((b >> 1) & 1) * n,
                k.z as u64 + ((b >> 2) & 1) * n,
            ];
            corners.insert(key);
        }
    }
    let distinct_corners = corners.len();
    drop(corners);
    // The cost of one exact evaluation at a leaf as the build makes it: at the centre of
    // up to 20,000 leaves of the deepest level, among the leaf's candidate list, carried
    // from its minimum corner (lists and corner samples prepared untimed; one thread).
    let deepest = adf.stats().depth_reached;
    let cells: Vec<(DVec3, f64)> = leaves
        .iter()
        .filter(|l| l.2 == deepest)
        .step_by((leaves.len() / 20_000).max(1))
        .take(20_000)
        .map(|l| (l.0, l.1))
        .collect();
    let prepared: Vec<_> = cells
        .iter()
        .map(|&(min, size)| {
            let corner = source.sample(min, None);
            let cell = volga_core::Aabb::new(min, min + DVec3::splat(size));
            let list = source
                .candidates(&cell, corner.value.abs() + size * 3f64.sqrt(), None)
                .expect("a mesh narrows");
            (min, size, corner, list)
        })
        .collect();
    let timer = Instant::now();
    let mut checksum = 0.0;
    for (min, size, corner, list) in &prepared {
        let p = *min + DVec3::splat(size * 0.5);
        checksum += source.sample_among(p, Some((*min, corner)), list).value;
    }
    let leaf_eval_ns = timer.elapsed().as_secs_f64() * 1e9 / prepared.len().max(1) as f64;
    let timer = Instant::now();
    for (min, size, corner, _) in &prepared {
        let p = *min + DVec3::splat(size * 0.5);
        checksum -= source.sample(p, Some((*min, corner))).value;
    }
    let leaf_eval_bvh_ns = timer.elapsed().as_secs_f64() * 1e9 / prepared.len().max(1) as f64;
    assert!(checksum.abs() < 1e-9, "scan and BVH agree");
    let s = adf.stats();
    println!(
        "{{\"build_s\": {wall:.3}, \"cpu_s\": {cpu:.2}, \"cells\": {}, \"leaves\": {}, \"pruned\": {}, \
         \"max_depth_leaves\": {}, \"jump_leaves\": {}, \"evaluations\": {}, \"source_queries\": {}, \
         \"integer_queries\": {}, \"distinct_corners\": {distinct_corners}, \"leaf_eval_ns\": {leaf_eval_ns:.0}, \"leaf_eval_bvh_ns\": {leaf_eval_bvh_ns:.0}, \"fingerprint\": \"{:016x}\"}}",
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
