//! The caps' certified winding number near the holes of the Stanford bunny (five cones,
//! 223 boundary edges): the caps' BVH against `ConeCaps`, the same queries the sign
//! proofs ask (the side of `I − ½`, and a value to 1e-6).
//!
//!     cargo bench -p volga-mesh --bench cap_winding

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::DVec3;
use volga_mesh::{cap_triangles, Bvh, ConeCaps, TriMesh};

fn caps_near_points() -> (Bvh, ConeCaps, Vec<DVec3>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/stanford-bunny.obj");
    let mesh = volga_mesh::load_obj(&path).expect("tests/data/stanford-bunny.obj");
    let caps = cap_triangles(&mesh);
    let tree = Bvh::build(&TriMesh {
        positions: caps.iter().flatten().copied().collect(),
        triangles: (0..caps.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
    });
    let cones = ConeCaps::build(&caps).expect("five cones");
    // Points along the cap triangles' medians, up to 3 mm (about 10 voxels at N = 512)
    // off them: where the voxelizer's flood and the ADF's cells ask the caps.
    let mut state = 1u64;
    let points = (0..2000)
        .map(|k| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let t = caps[(state % caps.len() as u64) as usize];
            let f = (state >> 20) as f64 / (1u64 << 44) as f64;
            t[0].lerp(t[2], f) + DVec3::new(0.001, -0.0007, 0.0009) * ((k % 7) as f64 - 3.0)
        })
        .collect();
    (tree, cones, points)
}

fn bench(c: &mut Criterion) {
    let (tree, cones, points) = caps_near_points();
    let side = |w: f64, e: f64| (w - 0.5).abs() > e;
    let mut group = c.benchmark_group("cap_winding_2000_points");
    group.bench_function("side_tree", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&p| tree.winding_number_bounded(black_box(p), None, side).value)
                .sum::<f64>()
        })
    });
    group.bench_function("side_cones", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&p| cones.winding_number_bounded(black_box(p), side).value)
                .sum::<f64>()
        })
    });
    group.bench_function("value_1e-6_tree", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&p| tree.winding_number_bounded(black_box(p), None, |_, e| e <= 1e-6).value)
                .sum::<f64>()
        })
    });
    group.bench_function("value_1e-6_cones", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&p| cones.winding_number_bounded(black_box(p), |_, e| e <= 1e-6).value)
                .sum::<f64>()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
