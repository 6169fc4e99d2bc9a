fn main() {
    let path = std::env::args().nth(1).unwrap();
    let mesh = volga_mesh::load_mesh(std::path::Path::new(&path)).unwrap();
    for _ in 0..12 {
        let t = std::time::Instant::now();
        let _v = volga_voxelize::MeshVoxelizer::new(&mesh);
        eprintln!("TOTAL {:.2}", t.elapsed().as_secs_f64() * 1e3);
    }
}
