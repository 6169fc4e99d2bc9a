//! Times the mesh extraction methods on a mesh's anti-aliased solid, repeatedly (for
//! profilers): `cargo run --release --example extract_profile -- MESH RESOLUTION METHOD REPEAT`.

use volga::core::{Aabb, Filter, NoProgress, Sampled};
use volga::mesh::{ExtractMethod, Extraction, VertexPlacement};
use volga::voxelize::{MeshJob, MeshJobMode};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .map(String::as_str)
        .unwrap_or("tests/data/stanford-bunny.obj");
    let resolution: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let method = args
        .get(3)
        .and_then(|s| ExtractMethod::from_name(s))
        .unwrap_or(ExtractMethod::Cubes);
    let repeat: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(10);
    let mesh = volga::mesh::load_mesh(path).expect("mesh");
    let job = MeshJob {
        resolution,
        mode: MeshJobMode::AntiAliased {
            thickness_voxels: 1.0,
            solid: true,
        },
    };
    let grid = job.layout(&mesh.bounds()).expect("grid");
    let volume = job.run(&mesh, &grid, &NoProgress).volume;
    let field = Sampled::new(&volume, Filter::Trilinear);
    let h = volume.grid.transform.spacing().x;
    let b = volume.grid.center_bounds();
    let extraction = Extraction::new(Aabb::new(b.min - h, b.max + h), h, 0.5)
        .with_method(method)
        .with_placement(VertexPlacement::Linear);
    let mut times = Vec::new();
    for _ in 0..repeat {
        let t = std::time::Instant::now();
        let s = volga::mesh::extract_surface_with(&field, &extraction).expect("extraction");
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(s);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{} at {resolution}: median {:.4} s",
        method.name(),
        times[times.len() / 2]
    );
}
