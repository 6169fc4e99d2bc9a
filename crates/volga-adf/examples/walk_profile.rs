//! Times the indexed ray walk alone (no renderer) over a 512² perspective view of a mesh's
//! ADF, the view of `volga bench adf`, and checks it against the reference walk:
//!
//! `cargo run --release -p volga-adf --example walk_profile -- MESH [TOLERANCE] [PASSES]`
//!
//! Prints one JSON line: the ADF's cells, the walk index's bytes, seconds per pass over
//! all pixel-centre rays on one thread (median), steps per ray, hits, and how many rays
//! differ from the reference walk (hit against miss, or `t` by more than 1e-9 of the
//! root cube).

use std::time::Instant;

use glam::DVec3;
use volga_adf::{Adf, AdfOptions, MeshSource};
use volga_core::CrossingRay;

/// CPU seconds of this thread so far (`/proc/thread-self/schedstat`), so the figure does
/// not follow the machine's load; wall seconds where that is not readable.
fn thread_cpu_s() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .map_or_else(
            || {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0.0, |d| d.as_secs_f64())
            },
            |ns| ns as f64 * 1e-9,
        )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: walk_profile MESH [TOLERANCE] [PASSES]");
    let tolerance: f64 = args.get(2).map_or(1e-3, |s| s.parse().expect("tolerance"));
    let passes: usize = args.get(3).map_or(10, |s| s.parse().expect("passes"));
    let mesh = volga_mesh::load_mesh(path).expect("mesh");
    let source = MeshSource::new(&mesh).expect("source");
    let bounds = mesh.bounds();
    let options = AdfOptions {
        max_depth: 12,
        ..AdfOptions::relative(tolerance, &bounds)
    };
    let adf = Adf::build(&source, options).expect("build");
    let start = Instant::now();
    let index_bytes = adf.walk_index_bytes();
    let index_s = start.elapsed().as_secs_f64();

    // The camera of `volga bench adf`: in front of and above the bounds, 30° field of view.
    let size = 512usize;
    let centre = bounds.center();
    let radius = 0.5 * bounds.size().length();
    let fov = 30f64.to_radians();
    let eye = centre + DVec3::new(0.35, 0.45, 1.0).normalize() * radius / (fov * 0.5).sin();
    let forward = (centre - eye).normalize();
    let right = forward.cross(DVec3::Y).normalize();
    let up = right.cross(forward);
    let half = (fov * 0.5).tan();
    let mut pixel = Vec::new();
    let rays: Vec<(DVec3, f64, f64)> = (0..size * size)
        .filter_map(|k| {
            let (x, y) = ((k % size) as f64 + 0.5, (k / size) as f64 + 0.5);
            let sx = (x / size as f64 * 2.0 - 1.0) * half;
            let sy = (1.0 - y / size as f64 * 2.0) * half;
            let dir = (forward + right * sx + up * sy).normalize();
            let (t0, t1) = adf.root_box().ray_interval(eye, dir)?;
            pixel.push(k);
            Some((dir, t0, t1))
        })
        .collect();

    let mut times = Vec::new();
    let (mut steps, mut hits) = (0u64, 0u64);
    for _ in 0..passes.max(1) {
        let start = thread_cpu_s();
        steps = 0;
        hits = 0;
        for &(dir, t0, t1) in &rays {
            let (hit, s) = adf.first_crossing_between(eye, dir, t0, t1, 0.0);
            steps += s as u64;
            hits += hit.is_some() as u64;
        }
        times.push(thread_cpu_s() - start);
    }
    times.sort_by(f64::total_cmp);
    // The same rays split by outcome, and in the renderer's order (16×16 tiles): where
    // the time goes, and what ray coherence gives.
    let outcome: Vec<bool> = rays
        .iter()
        .map(|&(dir, t0, t1)| adf.first_crossing_between(eye, dir, t0, t1, 0.0).0.is_some())
        .collect();
    let pass_over = |subset: &dyn Fn(usize) -> bool| -> f64 {
        let mut best = Vec::new();
        for _ in 0..passes.max(1) {
            let start = thread_cpu_s();
            for (i, &(dir, t0, t1)) in rays.iter().enumerate() {
                if subset(i) {
                    std::hint::black_box(adf.first_crossing_between(eye, dir, t0, t1, 0.0));
                }
            }
            best.push(thread_cpu_s() - start);
        }
        best.sort_by(f64::total_cmp);
        best[best.len() / 2]
    };
    let hit_s = pass_over(&|i| outcome[i]);
    let miss_s = pass_over(&|i| !outcome[i]);
    let tiled: Vec<usize> = {
        let mut order: Vec<usize> = (0..rays.len()).collect();
        order.sort_by_key(|&i| (pixel[i] / size / 16, pixel[i] % size / 16, pixel[i]));
        order
    };
    let mut tile_times = Vec::new();
    for _ in 0..passes.max(1) {
        let start = thread_cpu_s();
        for &i in &tiled {
            let (dir, t0, t1) = rays[i];
            std::hint::black_box(adf.first_crossing_between(eye, dir, t0, t1, 0.0));
        }
        tile_times.push(thread_cpu_s() - start);
    }
    tile_times.sort_by(f64::total_cmp);
    // The batched walk (`Adf::first_crossings_between`) over each 16×16 tile's rays,
    // as the renderer calls it, and its answers against the one-ray walk's.
    let walk_rays: Vec<CrossingRay> = tiled
        .iter()
        .map(|&i| {
            let (dir, t0, t1) = rays[i];
            CrossingRay {
                world_origin: eye,
                world_dir: dir,
                t0,
                t1,
            }
        })
        .collect();
    let mut batch_out = vec![(None, 0u32); walk_rays.len()];
    let mut batch_times = Vec::new();
    for _ in 0..passes.max(1) {
        let start = thread_cpu_s();
        let mut from = 0;
        while from < tiled.len() {
            // The rays of one tile (tile-ordered, so a tile's rays are consecutive).
            let tile = |i: usize| (pixel[tiled[i]] / size / 16, pixel[tiled[i]] % size / 16);
            let mut to = from + 1;
            while to < tiled.len() && tile(to) == tile(from) {
                to += 1;
            }
            adf.first_crossings_between(&walk_rays[from..to], 0.0, &mut batch_out[from..to]);
            from = to;
        }
        batch_times.push(thread_cpu_s() - start);
    }
    batch_times.sort_by(f64::total_cmp);
    let batch_differ = walk_rays
        .iter()
        .zip(&batch_out)
        .filter(|(r, b)| {
            let one = adf.first_crossing_between(r.world_origin, r.world_dir, r.t0, r.t1, 0.0);
            one.0.map(f64::to_bits) != b.0.map(f64::to_bits) || one.1 != b.1
        })
        .count();
    eprintln!(
        "{{\"walk_cpu_s_batched_tiles\":{:.4},\"batched_rays_differing\":{batch_differ}}}",
        batch_times[batch_times.len() / 2]
    );
    eprintln!(
        "{{\"walk_cpu_s_hit_rays\":{hit_s:.4},\"walk_cpu_s_missed_rays\":{miss_s:.4},\"walk_cpu_s_tile_order\":{:.4}}}",
        tile_times[tile_times.len() / 2]
    );
    let start = Instant::now();
    let mut differ = 0u64;
    for &(dir, t0, t1) in &rays {
        let (a, _) = adf.first_crossing_between(eye, dir, t0, t1, 0.0);
        let (b, _) = adf.first_crossing_by_descent(eye, dir, t0, t1, 0.0);
        let same = match (a, b) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-9 * adf.root_box().size().x,
            (None, None) => true,
            _ => false,
        };
        differ += !same as u64;
    }
    let both_s = start.elapsed().as_secs_f64();
    println!(
        "{{\"cells\":{},\"walk_index_bytes\":{},\"walk_index_build_s\":{:.4},\"walk_cpu_s_one_thread\":{:.4},\"us_per_ray\":{:.4},\"steps_per_ray\":{:.3},\"hits\":{},\"rays_differing_from_reference\":{},\"both_walks_s\":{:.3}}}",
        adf.cell_count(),
        index_bytes,
        index_s,
        times[times.len() / 2],
        times[times.len() / 2] * 1e6 / (size * size) as f64,
        steps as f64 / (size * size) as f64,
        hits,
        differ,
        both_s,
    );
}
