use glam::DVec3;
use volga_core::NoProgress;
use volga_mesh::load_mesh;
use volga_voxelize::{check::grid_for, MeshVoxelizer, SurfaceMode};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mesh = load_mesh(std::path::Path::new(&a[1])).unwrap();
    let n: u32 = a[2].parse().unwrap();
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let _ = MeshVoxelizer::new(&mesh);
        best = best.min(t.elapsed().as_secs_f64());
    }
    let v = MeshVoxelizer::new(&mesh);
    println!("new {best:.3}s (min of 5)");
    let grid = grid_for(&mesh, n, 4.0, DVec3::ZERO);
    let mut best = f64::INFINITY;
    let mut stats = None;
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let (_, s) = v.voxelize_with_stats(
            &grid,
            SurfaceMode::Distance {
                half_width_voxels: 3.0,
                signed: true,
            },
            &NoProgress,
        );
        best = best.min(t.elapsed().as_secs_f64());
        stats = Some(s);
    }
    println!("voxelize {best:.3}s (min of 5) {:?}", stats.unwrap());
}
