//! Voxelize a mesh into a 26-separating solid and save it as `.binvox`; works on open
//! and self-intersecting meshes too (inside = winding number ≥ ½, proven per voxel).
//!
//! `cargo run --release --example obj_to_binvox -- tests/data/spot.obj 128 spot.binvox`

use std::path::PathBuf;

use volga::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mesh_path = args.next().unwrap_or_else(|| "tests/data/spot.obj".into());
    let resolution: u32 = args.next().map_or(Ok(128), |n| n.parse())?;
    let out = PathBuf::from(args.next().unwrap_or_else(|| "spot.binvox".into()));

    let mesh = load_mesh(&mesh_path)?;
    let job = MeshJob {
        resolution, // voxels along the mesh's longest side
        mode: MeshJobMode::Binary {
            separability: Separability::TwentySix,
            solid: true,
        },
    };
    job.check()?;
    let grid = job.layout(&mesh.bounds())?;
    let needed = job.estimate(&mesh, &grid).peak_bytes;
    println!(
        "{} triangles, grid {}, about {} MB at the peak",
        mesh.triangle_count(),
        grid.dims(),
        needed >> 20
    );

    let run = job.run(&mesh, &grid, &NoProgress);
    save_voxel_model(&out, &run.volume)?;
    println!(
        "{} voxels filled, wrote {}",
        run.volume.active_voxel_count(),
        out.display()
    );
    Ok(())
}
