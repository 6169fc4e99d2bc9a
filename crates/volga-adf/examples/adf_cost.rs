use glam::DVec3;
use std::time::Instant;
use volga_mesh::CappedWinding;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mesh = volga_mesh::load_mesh(&args[1]).unwrap();
    let bvh = volga_mesh::Bvh::build(&mesh);
    let cw = CappedWinding::new(&mesh);
    println!("caps {}", cw.cap_triangle_count());
    let b = mesh.bounds();
    let mut s = 1u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let pts: Vec<DVec3> = (0..20000)
        .map(|_| {
            let i = (rnd() * mesh.triangles.len() as f64) as usize;
            let t = mesh.triangle(i);
            (t[0] + t[1] + t[2]) / 3.0 + DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.004
        })
        .collect();
    let _ = b;
    let t = Instant::now();
    let mut acc = 0.0;
    for p in &pts {
        acc += bvh.closest(*p).unwrap().distance;
    }
    println!("closest {:.2} us", t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6);
    let t = Instant::now();
    for p in &pts {
        acc += cw.cap_distance(*p);
    }
    println!(
        "cap_distance {:.2} us",
        t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6
    );
    let t = Instant::now();
    let mut terms = 0;
    for p in &pts {
        let (i, _, c) = cw.inside_with(*p, None);
        terms += c.terms;
        acc += i as u8 as f64;
    }
    println!(
        "inside {:.2} us terms {}",
        t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6,
        terms / pts.len() as u64
    );
    let t = Instant::now();
    let mut terms = 0;
    for p in &pts {
        let (i, _, c) = cw.inside_with(*p, Some(1));
        terms += c.terms;
        acc += i as u8 as f64;
    }
    println!(
        "inside known I {:.2} us terms {}",
        t.elapsed().as_secs_f64() / pts.len() as f64 * 1e6,
        terms / pts.len() as u64
    );
    println!("{acc}");
}
