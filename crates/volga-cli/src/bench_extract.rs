//! `volga bench extract MESH --resolution N --json`: every extraction method on the mesh's
//! anti-aliased solid (the volume `volga voxelize MESH --resolution N --anti-aliased
//! --solid` writes, so a peer can read the same NRRD), timed and scored against the exact
//! mesh; peers' meshes of the same volume are scored the same way (`--score`).

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use glam::DVec3;
use rayon::prelude::*;
use serde_json::{json, Value};
use volga_core::{Aabb, Filter, Sampled};
use volga_mesh::{Bvh, ExtractMethod, Extraction, IsoIndex, TriMesh};

use crate::bench_sculpt::{time_median, voxelize};
use crate::failure::{bad_input, failed, Failure};

#[derive(Args)]
pub struct ExtractBenchArgs {
    /// The mesh (.obj, .gltf, .glb).
    mesh: PathBuf,
    /// Voxels along the longest side of the mesh's box (8 to 2048).
    #[arg(long, default_value_t = 256)]
    resolution: u32,
    /// Timed runs per method; the median is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..))]
    repeat: u64,
    /// Adaptivities (voxels) to time besides 0, comma-separated.
    #[arg(long, default_value = "0.1,0.25", value_delimiter = ',')]
    adaptivity: Vec<f64>,
    /// Score these meshes too (a peer's extraction of the same volume, world coordinates,
    /// .obj): the same figures, without timing.
    #[arg(long)]
    score: Vec<PathBuf>,
    /// Print one JSON object (the only output format).
    #[arg(long)]
    json: bool,
}

/// Feature edges of the exact mesh: edges whose two faces meet at more than this angle.
const SHARP_DEGREES: f64 = 30.0;

pub fn run(args: ExtractBenchArgs) -> Result<(), Failure> {
    if !(8..=2048).contains(&args.resolution) {
        return Err(bad_input(format!(
            "--resolution {}: must be 8 to 2048",
            args.resolution
        )));
    }
    if let Some(a) = args
        .adaptivity
        .iter()
        .find(|a| !(a.is_finite() && (0.0..=10.0).contains(*a)))
    {
        return Err(bad_input(format!("--adaptivity {a}: must be 0 to 10 voxels")));
    }
    let mesh = volga_mesh::load_mesh(&args.mesh).map_err(|e| bad_input(e.to_string()))?;
    let start = Instant::now();
    let volume = voxelize(&mesh, args.resolution)?;
    let voxelize_s = start.elapsed().as_secs_f64();
    let field = Sampled::new(&volume, Filter::Trilinear);
    let h = volume.grid.transform.spacing().x;
    let b = volume.grid.center_bounds();
    let region = Aabb::new(b.min - h, b.max + h);
    let reference = Reference::new(&mesh, h);

    let mut methods = Vec::new();
    let mut adaptivities = vec![0.0];
    adaptivities.extend(args.adaptivity.iter().copied().filter(|&a| a > 0.0));
    for method in ExtractMethod::ALL {
        for &adaptivity in &adaptivities {
            let job = Extraction::new(region, h, 0.5)
                .with_method(method)
                .with_adaptivity(adaptivity)
                .with_placement(volga_mesh::VertexPlacement::Linear);
            let (seconds, surface) =
                time_median(args.repeat as usize, || volga_mesh::extract_surface_with(&field, &job));
            let surface = surface.map_err(|e| failed(e.to_string()))?;
            let mut entry = reference.score(&surface.mesh);
            entry["method"] = json!(method.name());
            entry["adaptivity"] = json!(adaptivity);
            entry["seconds"] = json!(seconds);
            entry["bytes"] = json!(surface.mesh.positions.len() * 24 + surface.mesh.triangles.len() * 12);
            entry["tubes"] = json!(surface.tubes);
            methods.push(entry);
        }
    }
    let mut scored = Vec::new();
    for path in &args.score {
        let peer = volga_mesh::load_mesh(path).map_err(|e| bad_input(e.to_string()))?;
        let mut entry = reference.score(&peer);
        entry["file"] = json!(path.display().to_string());
        scored.push(entry);
    }
    let slider = iso_slider(&field, region, h)?;
    let d = volume.grid.dims();
    let value = json!({
        "mesh": args.mesh.display().to_string(),
        "resolution": args.resolution,
        "dims": [d.x, d.y, d.z],
        "voxel_size": h,
        "voxelize_s": voxelize_s,
        "threads": rayon::current_num_threads(),
        "placement": "linear",
        "methods": methods,
        "scored": scored,
        "iso_slider": slider,
        "loadavg": std::fs::read_to_string("/proc/loadavg").unwrap_or_default().trim(),
    });
    println!("{}", serde_json::to_string_pretty(&value).expect("json"));
    Ok(())
}

/// The exact mesh, for scoring: its BVH, samples on it, points along its sharp edges.
struct Reference<'a> {
    mesh: &'a TriMesh,
    bvh: Bvh,
    voxel: f64,
    samples: Vec<DVec3>,
    sharp: Vec<DVec3>,
}

impl<'a> Reference<'a> {
    fn new(mesh: &'a TriMesh, voxel: f64) -> Reference<'a> {
        let bvh = Bvh::build(mesh);
        // About 200 k points on the surface, area-weighted, deterministic (a 2-D lattice
        // per triangle scaled to its area).
        let area: f64 = (0..mesh.triangle_count()).map(|t| tri_area(mesh.triangle(t))).sum();
        let per_area = 200_000.0 / area.max(f64::MIN_POSITIVE);
        let mut samples = Vec::new();
        let mut carry = 0.0;
        for t in 0..mesh.triangle_count() {
            let tri = mesh.triangle(t);
            carry += tri_area(tri) * per_area;
            while carry >= 1.0 {
                carry -= 1.0;
                let k = samples.len() as f64;
                let (u, v) = ((k * 0.618_033_988_75).fract(), (k * 0.754_877_666_25).fract());
                let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                samples.push(tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v);
            }
        }
        let sharp = mesh.sharp_edge_points(SHARP_DEGREES, 0.5 * voxel);
        Reference {
            mesh,
            bvh,
            voxel,
            samples,
            sharp,
        }
    }

    /// Distances (voxels) from the extracted mesh to the exact one (vertices and triangle
    /// centroids), back (exact samples to the extracted mesh), sharp-edge points to the
    /// extracted mesh, normal error, and the edge–face manifold check.
    fn score(&self, out: &TriMesh) -> Value {
        if out.triangles.is_empty() {
            return json!({"triangles": 0, "manifold": false});
        }
        let h = self.voxel;
        let to_exact: Vec<f64> = out
            .positions
            .par_iter()
            .copied()
            .chain(
                out.triangles
                    .par_iter()
                    .map(|t| t.iter().map(|&v| out.positions[v as usize]).sum::<DVec3>() / 3.0),
            )
            .map(|p| self.bvh.closest(p).map_or(f64::INFINITY, |c| c.distance) / h)
            .collect();
        let out_bvh = Bvh::build(out);
        let back: Vec<f64> = self
            .samples
            .par_iter()
            .map(|&p| out_bvh.closest(p).map_or(f64::INFINITY, |c| c.distance) / h)
            .collect();
        let sharp: Vec<f64> = self
            .sharp
            .par_iter()
            .map(|&p| out_bvh.closest(p).map_or(f64::INFINITY, |c| c.distance) / h)
            .collect();
        // Normal error at triangle centroids, area-weighted: the output's face normal against
        // the nearest exact triangle's (either orientation: scans and peers differ in winding).
        let normal: Vec<(f64, f64)> = out
            .triangles
            .par_iter()
            .filter_map(|t| {
                let [a, b, c] = t.map(|v| out.positions[v as usize]);
                let cross = (b - a).cross(c - a);
                let n = cross.normalize_or_zero();
                let near = self.bvh.closest((a + b + c) / 3.0)?;
                let [p, q, r] = self.mesh.triangle(near.triangle as usize);
                let m = (q - p).cross(r - p).normalize_or_zero();
                (n != DVec3::ZERO && m != DVec3::ZERO)
                    .then(|| (n.dot(m).abs().min(1.0).acos().to_degrees(), cross.length()))
            })
            .collect();
        let area: f64 = normal.iter().map(|(_, w)| w).sum();
        let normal_rms = (normal.iter().map(|(d, w)| d * d * w).sum::<f64>() / area.max(f64::MIN_POSITIVE)).sqrt();
        let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
        let (to_max, back_max) = (max(&to_exact), max(&back));
        let check = manifold(out);
        json!({
            "triangles": out.triangles.len(),
            "vertices": out.positions.len(),
            "hausdorff": to_max.max(back_max),
            "to_mesh_max": to_max,
            "to_mesh_rms": rms(&to_exact),
            "from_mesh_max": back_max,
            "from_mesh_rms": rms(&back),
            "sharp_edge_points": self.sharp.len(),
            "sharp_edge_max": max(&sharp),
            "sharp_edge_rms": rms(&sharp),
            "normal_rms_degrees": normal_rms,
            "manifold": check.0 == 0 && check.1 == 0,
            "edges_not_in_two_faces": check.0,
            "inconsistent_edges": check.1,
        })
    }
}

fn tri_area(t: [DVec3; 3]) -> f64 {
    0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()
}

/// The edge–face check from the triangles alone: undirected edges not in exactly two
/// triangles, and edges whose two triangles run them in the same direction.
pub fn manifold(mesh: &TriMesh) -> (u64, u64) {
    let mut directed: Vec<(u32, u32)> = mesh
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .collect();
    directed.par_sort_unstable();
    let mut undirected: Vec<(u32, u32)> = directed.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    undirected.par_sort_unstable();
    let mut not_two = 0;
    let mut i = 0;
    while i < undirected.len() {
        let mut j = i;
        while j < undirected.len() && undirected[j] == undirected[i] {
            j += 1;
        }
        if j - i != 2 {
            not_two += 1;
        }
        i = j;
    }
    let repeated = directed.windows(2).filter(|w| w[0] == w[1]).count() as u64;
    (not_two, repeated)
}

/// Re-extraction on a slider of iso-values through the span-space index, against fresh
/// extractions, marching cubes.
fn iso_slider<F: volga_core::Field>(field: &F, region: Aabb, h: f64) -> Result<Value, Failure> {
    let base = Extraction::new(region, h, 0.5).with_placement(volga_mesh::VertexPlacement::Linear);
    let start = Instant::now();
    let index = IsoIndex::build(field, &base, (0.2, 0.8), 8 << 30).map_err(|e| failed(e.to_string()))?;
    let build_s = start.elapsed().as_secs_f64();
    let mut values = Vec::new();
    for k in 0..7 {
        let iso = 0.2 + 0.1 * k as f64;
        let t = Instant::now();
        let again = index.extract(iso).map_err(|e| failed(e.to_string()))?;
        let index_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let fresh =
            volga_mesh::extract_surface_with(field, &Extraction { iso, ..base }).map_err(|e| failed(e.to_string()))?;
        let fresh_s = t.elapsed().as_secs_f64();
        values.push(json!({
            "iso": iso,
            "candidate_blocks": index.candidates(iso),
            "index_s": index_s,
            "fresh_s": fresh_s,
            "triangles": again.mesh.triangles.len(),
            "identical": again.mesh == fresh.mesh,
        }));
    }
    Ok(json!({
        "method": "cubes",
        "iso_range": [0.2, 0.8],
        "build_s": build_s,
        "blocks": index.blocks(),
        "bytes": index.bytes(),
        "values": values,
    }))
}
