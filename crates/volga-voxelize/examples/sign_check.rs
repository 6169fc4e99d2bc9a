//! Holds volga's inside/outside against a brute-force float64 generalized winding
//! number, on a mesh file or on the generated unclean corpus, in the three modes that
//! use the sign (signed distance, anti-aliased solid, binary inside):
//!
//! ```sh
//! cargo run --release -p volga-voxelize --features testing --example sign_check -- corpus 64 128
//! cargo run --release -p volga-voxelize --features testing --example sign_check -- tests/data/teapot.obj 64 128
//! ```
//!
//! Every voxel of the 3-voxel distance band is checked, plus 20,000 random voxels of the
//! grid, on the grid `volga voxelize --resolution N --distance 3` uses and on the same
//! grid moved by half a voxel (voxel centres on the planes the first one has faces on).
//! `--one-grid` checks only the first grid. Prints one line per (mesh, N, grid, mode) and
//! exits 1 if any sign is wrong.

use glam::DVec3;
use volga_mesh::{load_mesh, unclean, TriMesh};
use volga_voxelize::check::{check_signs, grid_for};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(what) = args.first() else {
        eprintln!("usage: sign_check (corpus | MESH) N...");
        std::process::exit(2);
    };
    let sizes: Vec<u32> = args[1..].iter().filter_map(|a| a.parse().ok()).collect();
    // `--one-grid`: only the first grid (the one `volga voxelize` uses), for big meshes.
    let shifts: &[f64] = if args.iter().any(|a| a == "--one-grid") {
        &[0.0]
    } else {
        &[0.0, 0.5]
    };
    let meshes: Vec<(String, TriMesh)> = if what == "corpus" {
        unclean::corpus().into_iter().map(|(n, m)| (n.to_string(), m)).collect()
    } else {
        vec![(what.clone(), load_mesh(std::path::Path::new(what)).expect("mesh"))]
    };
    let mut failed = false;
    for (name, mesh) in &meshes {
        for &n in &sizes {
            for &shift in shifts {
                let grid = grid_for(mesh, n, 4.0, DVec3::splat(shift));
                let start = std::time::Instant::now();
                for c in check_signs(mesh, &grid, 3.0, 20_000, n as u64) {
                    failed |= c.wrong > 0;
                    println!(
                        "{name} | N {n} | shift {shift} | {} | checked {} | wrong {} | ties {} | worst |w-1/2| {:.3e} | fast {} cap {} exact {} ({} triangles) region queries {} | unclean triangles {} | cycle edges {}",
                        c.mode, c.checked, c.wrong, c.ties, c.worst, c.stats.fast_voxels, c.stats.cap_voxels,
                        c.stats.exact_voxels, c.stats.exact_triangles, c.stats.region_queries,
                        c.stats.unclean_triangles, c.stats.boundary_cycle_edges
                    );
                }
                eprintln!("  ({:.1} s)", start.elapsed().as_secs_f64());
            }
        }
    }
    std::process::exit(failed as i32);
}
