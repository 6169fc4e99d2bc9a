//! Signed distances of a mesh: exact values at a few points (certified sign, negative
//! inside), then a narrow band of ±3 voxels written as NRRD (`.nrrd` + `.raw`, readable
//! by 3D Slicer, ParaView or pynrrd).
//!
//! `cargo run --release --example signed_distance_nrrd -- tests/data/stanford-bunny.obj bunny_sdf.nrrd`

use std::path::PathBuf;

use volga::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mesh_path = args.next().unwrap_or_else(|| "tests/data/stanford-bunny.obj".into());
    let out = PathBuf::from(args.next().unwrap_or_else(|| "bunny_sdf.nrrd".into()));
    let mesh = load_mesh(&mesh_path)?;

    // Point queries: exact distance to the triangles, sign from the winding number.
    let queries = MeshQueries::new(&mesh);
    let b = mesh.bounds();
    for world_pos in [b.center(), b.min, b.center() + DVec3::new(0.0, 0.25 * b.size().y, 0.0)] {
        println!("d({world_pos:.4}) = {:+.6}", queries.signed_distance(world_pos));
    }

    // The band on a 128-voxel grid: distances in world units within 3 voxels.
    let job = MeshJob {
        resolution: 128,
        mode: MeshJobMode::Distance {
            half_width_voxels: 3.0,
            signed: true,
        },
    };
    let grid = job.layout(&b)?;
    let run = job.run(&mesh, &grid, &NoProgress);
    for path in save_voxel_model(&out, &run.volume)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}
