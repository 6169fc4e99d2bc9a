use glam::DVec3;
use std::time::Instant;
use volga_mesh::{load_mesh, Bvh};
fn main() {
    let mesh = load_mesh(std::path::Path::new(&std::env::args().nth(1).unwrap())).unwrap();
    let bvh = Bvh::build(&mesh);
    let b = mesh.bounds();
    let mut s = 1u64;
    let mut rnd = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let pts: Vec<DVec3> = (0..20000)
        .map(|_| b.min + (b.max - b.min) * DVec3::new(rnd(), rnd(), rnd()))
        .collect();
    let t = Instant::now();
    let mut acc = 0.0;
    for &p in &pts {
        acc += bvh.winding_number(p);
    }
    println!(
        "fast {:.2} us {acc}",
        t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6
    );
    let t = Instant::now();
    let (mut ex, mut rf) = (0u64, 0u64);
    for &p in &pts {
        let w = bvh.winding_number_bounded(p, None, |w, e| (w - 0.5).abs() > e);
        ex += w.exact_triangles as u64;
        rf += w.refinements as u64;
    }
    println!(
        "decided {:.2} us exact {} refinements {}",
        t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6,
        ex / pts.len() as u64,
        rf / pts.len() as u64
    );
    let t = Instant::now();
    for &p in &pts {
        let w = bvh.winding_number_bounded(p, None, |w, e| (w - w.round()).abs() + e < 0.5);
        ex += w.exact_triangles as u64;
    }
    println!("rounded {:.2} us", t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6);
}
