//! Loads a mesh and reports its topology and how far the fast winding number
//! (`Bvh::winding_number`) is from the exact sum of solid angles, at random points of
//! its bounding box padded by 10%. This is how the error figures in the docs of
//! `Bvh::winding_number` were measured:
//!
//! ```text
//! cargo run --release -p volga-mesh --example winding_accuracy -- tests/data/spot.obj [points]
//! ```

use std::time::Instant;

use glam::DVec3;
use volga_mesh::{load_mesh, Bvh};

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: winding_accuracy MESH [POINTS]");
        std::process::exit(2);
    };
    let count: usize = args.next().and_then(|n| n.parse().ok()).unwrap_or(1000);
    let mesh = match load_mesh(&path) {
        Ok(mesh) => mesh,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    println!("{path}: {} triangles, {:?}", mesh.triangle_count(), mesh.edge_stats());

    let started = Instant::now();
    let bvh = Bvh::build(&mesh);
    println!("BVH built in {:.1} ms", started.elapsed().as_secs_f64() * 1e3);

    let bounds = mesh.bounds();
    let sample_box = bounds.expanded(bounds.size() * 0.1);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let points: Vec<DVec3> = (0..count)
        .map(|_| sample_box.min + DVec3::new(unit(), unit(), unit()) * sample_box.size())
        .collect();

    let started = Instant::now();
    let fast: Vec<f64> = points.iter().map(|&p| bvh.winding_number(p)).collect();
    let fast_time = started.elapsed().as_secs_f64() / count as f64;
    let started = Instant::now();
    let exact: Vec<f64> = points.iter().map(|&p| bvh.winding_number_exact(p)).collect();
    let exact_time = started.elapsed().as_secs_f64() / count as f64;

    let mut errors: Vec<f64> = fast.iter().zip(&exact).map(|(f, e)| (f - e).abs()).collect();
    errors.sort_by(f64::total_cmp);
    let mean = errors.iter().sum::<f64>() / count as f64;
    let disagreements = fast
        .iter()
        .zip(&exact)
        .filter(|(f, e)| (**f >= 0.5) != (**e >= 0.5))
        .count();
    println!(
        "fast winding number over {count} points: error median {:.1e}, mean {mean:.1e}, p99 {:.1e}, max {:.1e}; \
         inside/outside disagreements {disagreements}",
        errors[count / 2],
        errors[count * 99 / 100],
        errors[count - 1],
    );
    println!(
        "per query: fast {:.1} µs, exact {:.1} µs",
        fast_time * 1e6,
        exact_time * 1e6
    );
}
