//! `mesh_to_sdf` (0.4) asked for exactly volga's band voxels: the centres of the voxels
//! whose value in volga's NRRD is not ±background, as `[f32; 3]` query points, by its
//! per-point R-tree query (`AccelerationMethod::RtreeBvh`: R-tree nearest triangle, sign
//! by ray casting through a BVH; and `Rtree`: sign from the nearest triangle's normal).
//! Prints JSON: per method the median seconds of `--repeat` calls after one warm-up,
//! seconds per band voxel, and how many signs disagree with volga's (volga's are proven:
//! `docs/VOXELIZE.md`), counting only voxels where both magnitudes exceed 1e-3 voxels.
//!
//!   volga-bench-mesh-to-sdf MESH.obj VOLGA.nrrd [REPEAT]

use std::time::Instant;

use mesh_to_sdf::{generate_sdf, AccelerationMethod, SignMethod, Topology};

struct Nrrd {
    dims: [usize; 3],
    origin: [f64; 3],
    spacing: [f64; 3],
    background: f32,
    data: Vec<f32>,
}

fn read_nrrd(path: &str) -> Nrrd {
    let header = std::fs::read_to_string(path).expect("read NRRD header");
    let field = |key: &str| -> String {
        header
            .lines()
            .find_map(|l| l.strip_prefix(key).map(|v| v.trim().to_string()))
            .unwrap_or_else(|| panic!("{path}: no `{key}`"))
    };
    let numbers = |s: &str| -> Vec<f64> {
        s.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e' || c == 'E' || c == '+'))
            .filter(|t| !t.is_empty())
            .map(|t| t.parse().expect("number"))
            .collect()
    };
    let sizes = numbers(&field("sizes:"));
    let origin = numbers(&field("space origin:"));
    let directions = numbers(&field("space directions:"));
    let background: f32 = field("volga_background:=").parse().expect("background");
    let raw = std::path::Path::new(path).with_file_name(field("data file:"));
    let bytes = std::fs::read(&raw).expect("read raw");
    let data = bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    Nrrd {
        dims: [sizes[0] as usize, sizes[1] as usize, sizes[2] as usize],
        origin: [origin[0], origin[1], origin[2]],
        spacing: [directions[0], directions[4], directions[8]],
        background,
        data,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (mesh_path, nrrd_path) = (&args[1], &args[2]);
    let repeat: usize = args.get(3).map_or(5, |r| r.parse().expect("REPEAT"));
    let (models, _) = tobj::load_obj(mesh_path, &tobj::LoadOptions { triangulate: true, ..Default::default() })
        .expect("load OBJ");
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    for m in &models {
        let base = vertices.len() as u32;
        vertices.extend(m.mesh.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        indices.extend(m.mesh.indices.iter().map(|i| base + i));
    }
    let volume = read_nrrd(nrrd_path);
    let [nx, ny, _] = volume.dims;
    let (mut points, mut volga) = (Vec::new(), Vec::new());
    for (o, &v) in volume.data.iter().enumerate() {
        if v.abs() != volume.background {
            let ijk = [o % nx, o / nx % ny, o / (nx * ny)];
            points.push([0, 1, 2].map(|a| (volume.origin[a] + ijk[a] as f64 * volume.spacing[a]) as f32));
            volga.push(v);
        }
    }
    let h = volume.spacing[0] as f32;
    let mut results = Vec::new();
    for (name, method) in [
        ("RtreeBvh (ray-cast sign)", AccelerationMethod::RtreeBvh),
        ("Rtree (normal sign)", AccelerationMethod::Rtree),
        ("Bvh (ray-cast sign)", AccelerationMethod::Bvh(SignMethod::Raycast)),
    ] {
        let call = || generate_sdf(&vertices, Topology::TriangleList(Some(&indices)), &points, method);
        let sdf = call();
        let mut times: Vec<f64> = (0..repeat)
            .map(|_| {
                let start = Instant::now();
                std::hint::black_box(call());
                start.elapsed().as_secs_f64()
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        let wrong = sdf
            .iter()
            .zip(&volga)
            .filter(|(m, v)| m.abs() > 1e-3 * h && v.abs() > 1e-3 * h && (m.is_sign_negative() != v.is_sign_negative()))
            .count();
        let max_error = sdf
            .iter()
            .zip(&volga)
            .filter(|(_, v)| v.abs() < 3.0 * h * 0.999)
            .map(|(m, v)| ((m.abs() - v.abs()).abs() / h) as f64)
            .fold(0.0, f64::max);
        results.push(serde_json::json!({
            "method": name,
            "median_s": median,
            "s_per_band_voxel": median / points.len() as f64,
            "wrong_signs": wrong,
            "max_abs_distance_difference_voxels": max_error,
        }));
    }
    let report = serde_json::json!({
        "mesh": mesh_path,
        "band_voxels": points.len(),
        "threads": std::thread::available_parallelism().map_or(1, |n| n.get()),
        "mesh_to_sdf": results,
    });
    println!("{}", serde_json::to_string_pretty(&report).expect("json"));
}
