use glam::DVec3;
use std::time::Instant;
use volga_adf::{Adf, AdfOptions, DistanceSource, MeshSource};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mesh = volga_mesh::load_mesh(&args[1]).unwrap();
    let tol: f64 = args[2].parse().unwrap();
    let depth: u8 = args.get(3).map_or(12, |s| s.parse().unwrap());
    let src = MeshSource::new(&mesh).unwrap();
    let bounds = mesh.bounds();
    let mut opts = AdfOptions::relative(tol, &bounds);
    opts.max_depth = depth;
    let t = Instant::now();
    let adf = Adf::build(&src, opts).unwrap();
    let el = t.elapsed().as_secs_f64();
    println!(
        "build {el:.3}s stats {:?} bytes {} queries {} winding_terms {}",
        adf.stats(),
        adf.memory_bytes(),
        src.queries(),
        src.winding_terms()
    );
    // error near surface
    let diag = bounds.size().length();
    let mut s = 12345u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut maxe, mut sum, mut n) = (0.0f64, 0.0, 0);
    for _ in 0..20000 {
        let p = bounds.min + DVec3::new(rnd(), rnd(), rnd()) * bounds.size();
        let e = src.distance(p);
        if e.abs() > 0.02 * diag {
            continue;
        }
        let err = (adf.distance(p) - e).abs();
        maxe = maxe.max(err);
        sum += err * err;
        n += 1;
    }
    let leaves = adf.leaves();
    let mut hist = std::collections::BTreeMap::new();
    let mut far = 0;
    let mut cnt = 0;
    let mut sample = Vec::new();
    for (min, size, depth) in &leaves {
        if *depth as u8 == depth_max(&adf) {
            cnt += 1;
            let c = *min + DVec3::splat(size * 0.5);
            let d = src.bvh().closest(c).unwrap().distance;
            let k = ((d / size).log2().floor()) as i32;
            *hist.entry(k).or_insert(0) += 1;
            if d > size * 2.0 {
                far += 1;
                if sample.len() < 2 {
                    sample.push((c, d, src.distance(c)));
                    for b in 0..8 {
                        let q = *min + DVec3::new((b & 1) as f64, ((b >> 1) & 1) as f64, ((b >> 2) & 1) as f64) * *size;
                        println!(
                            "  corner {b} true {:.3e} adf {:.3e} W {:?}",
                            src.distance(q),
                            adf.distance(q),
                            src.sign_field(q)
                        );
                    }
                    for t in [DVec3::splat(0.5), DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.5, 0.0, 0.0)] {
                        let q = *min + t * *size;
                        println!(
                            "  test {t} true {:.3e} adf {:.3e} W {:?}",
                            src.distance(q),
                            adf.distance(q),
                            src.sign_field(q)
                        );
                    }
                }
            }
        }
    }
    println!("maxdepth leaves {cnt} far {far} hist log2(d/size) {hist:?} sample {sample:?}");
    println!(
        "band points {n} max err {:.3e} rms {:.3e} (rel diag)",
        maxe / diag,
        (sum / n as f64).sqrt() / diag
    );
}

fn depth_max(a: &Adf) -> u8 {
    a.options().max_depth
}
