//! Validates a voxelized sphere shell and prints the report.
//!
//! `cargo run --release -p volga-topology --example sphere_shell -- [RESOLUTION] [--json]`
//!
//! The shell is the 26-boundary of the digital ball (voxels of the ball with a
//! 26-neighbour outside it), which is 26-separating by construction; the grid is
//! `RESOLUTION`³ (default 128). Prints the summary and the time the analysis took.

use std::time::Instant;

use glam::{IVec3, UVec3};
use volga_topology::{analyze, Connectivity, VoxelSet};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let resolution: i32 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(128).max(4);
    let json = args.iter().any(|a| a == "--json");

    let centre = resolution / 2;
    let radius = resolution as f64 * 0.4;
    // Half-width of the ball's row (y, z) in x, or -1 for an empty row.
    let half_width = |y: i32, z: i32| {
        let r2 = radius * radius - ((y - centre).pow(2) + (z - centre).pow(2)) as f64;
        if r2 < 0.0 {
            -1
        } else {
            r2.sqrt().floor() as i32
        }
    };
    let mut voxels = Vec::new();
    for z in 0..resolution {
        for y in 0..resolution {
            let a = half_width(y, z);
            if a < 0 {
                continue;
            }
            // A voxel at |dx| ≤ a is on the 26-boundary if some neighbour row
            // (dy, dz ∈ -1..=1) is shorter than |dx| + 1, or it is a row end.
            let mut inner = a - 1;
            for dz in -1..=1 {
                for dy in -1..=1 {
                    inner = inner.min(half_width(y + dy, z + dz) - 1);
                }
            }
            for dx in -a..=a {
                if dx.abs() > inner {
                    voxels.push(IVec3::new(centre + dx, y, z));
                }
            }
        }
    }
    let set = VoxelSet::from_voxels(UVec3::splat(resolution as u32), voxels).expect("shell inside its grid");

    let start = Instant::now();
    let report = analyze(&set, Connectivity::TwentySix);
    let elapsed = start.elapsed();
    if json {
        println!("{}", serde_json::to_string_pretty(&report).expect("report serializes"));
    } else {
        println!(
            "{resolution}³ sphere shell: {} voxels, {} white 26-components, separating {}, {} simple voxels, \
             χ = {}, cavities {}, handles {}",
            report.voxels,
            report.white_component_count,
            report.separating,
            report.simple_voxel_count.unwrap_or(0),
            report.euler_characteristic,
            report.cavities,
            report.handles
        );
    }
    eprintln!(
        "analyze: {:.3} s on {} threads",
        elapsed.as_secs_f64(),
        rayon::current_num_threads()
    );
}
