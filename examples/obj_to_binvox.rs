//! Voxelize a mesh into a 26-separating surface `.binvox` (`solid: true` also fills the
//! inside: winding number ≥ ½, proven per voxel, open meshes too).
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
    // `resolution` voxels along the mesh's longest side; a 26-separating surface.
    let mode = MeshJobMode::Binary {
        separability: Separability::TwentySix,
        solid: false,
    };
    let job = MeshJob { resolution, mode };
    job.check()?;
    let grid = job.layout(&mesh.bounds())?;
    let needed = job.estimate(&mesh, &grid).peak_bytes;
    println!(
        "{} triangles, grid {}, peak ≤ {} MB",
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
