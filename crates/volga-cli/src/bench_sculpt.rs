//! `volga bench sculpt MESH --resolution N --json`: sculpting speed and memory on the
//! voxelized mesh, against OpenVDB and scikit-image measured in the same run.
//!
//! 1. The mesh is voxelized as an anti-aliased solid with `N` voxels along its longest side
//!    (`volga voxelize`'s job) and loaded into a [`Sculpt`] octree on the same voxel grid.
//! 2. **Carve latency**: `--edits` sphere carves of radius `--radius-voxels` at random
//!    triangle centroids (the same protocol as the OpenVDB peer), each timed alone;
//!    `carve_ms_median` is their median.
//! 3. **Memory**: from the freshly loaded octree, 100 random strokes (carve, add, spray,
//!    paint, smooth; radius 4–32 voxels, at random triangle centroids), history cleared;
//!    `octree_bytes_after_100_strokes` against `dense_bytes` = N³ f32 densities.
//! 4. **Re-render**: a full iso frame of the sculpt (`--render-size`²) against the
//!    localized re-render of one carve ([`Renderer::rerender_box`]; its renderer
//!    preparation is timed apart).
//! 5. **Extraction**: the ½ iso-surface of the mesh voxelized at `--extract-resolution`
//!    by volga's shared extractor (linear placement, as marching cubes places vertices;
//!    and refined) against scikit-image's `marching_cubes` on the same dense array.
//!
//! Peers run only when given: `--openvdb-peer BIN` (the compiled
//! `../shared/peers/openvdb_csg_carve.cpp`) and `--skimage-python PY` (a Python with
//! scikit-image); `bench/sculpt/run.sh` builds and passes both. Keys of the printed JSON
//! object are stable: `carve_ms_median`, `octree_bytes_after_100_strokes`, `dense_bytes`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use clap::Args;
use glam::{DVec3, Vec3};
use serde_json::{json, Value};
use volga_core::{Filter, NoProgress, Sampled, SparseVolume};
use volga_mesh::{extract_surface_with, Extraction, TriMesh, VertexPlacement};
use volga_render::{Camera, Iso, Projection, RenderSettings, Renderer, SurfaceColour};
use volga_sculpt::{Operation, Sculpt, SculptGrid, Stroke, Tool};
use volga_voxelize::{MeshJob, MeshJobMode};

use crate::failure::{bad_input, failed, Failure};

#[derive(Args)]
pub struct SculptBenchArgs {
    /// The mesh to voxelize and sculpt (OBJ or glTF).
    mesh: PathBuf,
    /// Voxels along the mesh's longest side.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=2048))]
    resolution: u32,
    /// Print one JSON object (the only output format).
    #[arg(long)]
    json: bool,
    /// Carve radius in voxels.
    #[arg(long, default_value_t = 16.0)]
    radius_voxels: f64,
    /// Timed carves; the median is reported.
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u64).range(1..))]
    edits: u64,
    /// Image side for the re-render comparison (0 skips it).
    #[arg(long, default_value_t = 256)]
    render_size: u32,
    /// Resolution of the extraction comparison (0 skips it).
    #[arg(long, default_value_t = 256)]
    extract_resolution: u32,
    /// The compiled OpenVDB CSG peer (`openvdb_csg_carve`).
    #[arg(long)]
    openvdb_peer: Option<PathBuf>,
    /// A Python interpreter with scikit-image, for the marching-cubes peer.
    #[arg(long)]
    skimage_python: Option<PathBuf>,
}

/// xorshift64*: a fixed, seedable sequence (results do not depend on a crate's RNG).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn centroid(&mut self, mesh: &TriMesh) -> DVec3 {
        let t = mesh.triangle((self.next() % mesh.triangle_count() as u64) as usize);
        (t[0] + t[1] + t[2]) / 3.0
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

pub(crate) fn voxelize(mesh: &TriMesh, resolution: u32) -> Result<SparseVolume, Failure> {
    let job = MeshJob {
        resolution,
        mode: MeshJobMode::AntiAliased {
            thickness_voxels: 1.0,
            solid: true,
        },
    };
    job.check().map_err(|e| bad_input(e.to_string()))?;
    let grid = job.layout(&mesh.bounds()).map_err(|e| bad_input(e.to_string()))?;
    Ok(job.run(mesh, &grid, &NoProgress).volume)
}

/// The octree on the volume's own voxel grid (same origin and spacing, padded to 8·2^L).
fn load(volume: &SparseVolume) -> Result<Sculpt, Failure> {
    let dims = volume.grid.dims().max_element();
    let mut levels = 0;
    while (8u32 << levels) < dims {
        levels += 1;
    }
    let t = volume.grid.transform;
    let grid = SculptGrid::new(t.origin(), t.spacing().x, levels).map_err(|e| failed(e.to_string()))?;
    Ok(Sculpt::from_field(
        grid,
        &Sampled::new(volume, Filter::Nearest),
        [0.8, 0.75, 0.7],
    ))
}

pub fn run(args: SculptBenchArgs) -> Result<(), Failure> {
    let mesh = volga_mesh::load_mesh(&args.mesh).map_err(|e| bad_input(e.to_string()))?;
    if !(args.radius_voxels.is_finite() && args.radius_voxels > 0.0) {
        return Err(bad_input("--radius-voxels must be positive"));
    }
    let t = Instant::now();
    let volume = voxelize(&mesh, args.resolution)?;
    let voxelize_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let start = load(&volume)?;
    let octree_build_s = t.elapsed().as_secs_f64();
    let h = start.grid().spacing();
    drop(volume);

    // Carve latency.
    let mut sculpt = start.clone();
    let mut rng = Rng(1);
    let mut times = Vec::new();
    let mut changed_voxels = 0u64;
    for _ in 0..args.edits {
        let c = rng.centroid(&mesh);
        let stroke = Stroke::new(
            Tool::sphere(c, args.radius_voxels * h).map_err(|e| failed(e.to_string()))?,
            Operation::Carve,
        )
        .map_err(|e| failed(e.to_string()))?;
        let t = Instant::now();
        let report = sculpt.apply(&stroke);
        times.push(t.elapsed().as_secs_f64() * 1e3);
        changed_voxels += report.changed_voxels.map_or(0, |b| b.volume());
    }
    let (carve_min, carve_max) = times.iter().fold((f64::MAX, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    let carve_ms_median = median(&mut times);
    drop(sculpt);

    // Memory after 100 random strokes.
    let mut sculpt = start.clone();
    let mut rng = Rng(7);
    let t = Instant::now();
    for k in 0..100 {
        let c = rng.centroid(&mesh);
        let r = (4.0 + 28.0 * rng.unit()) * h;
        let op = match k % 5 {
            0 | 1 => Operation::Carve,
            2 => Operation::Spray {
                strength: 0.5,
                falloff_world: 4.0 * h,
            },
            3 => Operation::Paint {
                colour: [rng.unit() as f32, 0.4, 0.3],
                strength: 0.8,
            },
            _ => Operation::Smooth { strength: 0.7 },
        };
        let stroke = Stroke::new(Tool::sphere(c, r).map_err(|e| failed(e.to_string()))?, op)
            .map_err(|e| failed(e.to_string()))?;
        sculpt.apply(&stroke);
    }
    let strokes_s = t.elapsed().as_secs_f64();
    let history_bytes = sculpt.history_bytes();
    sculpt.clear_history();
    let stats = sculpt.stats();
    let dense_bytes = (args.resolution as u64).pow(3) * 4;

    let render = if args.render_size > 0 {
        rerender(&sculpt, &mesh, args.render_size, args.radius_voxels * h)?
    } else {
        Value::Null
    };
    drop(sculpt);
    let start_stats = start.stats();
    drop(start);

    let extraction = if args.extract_resolution > 0 {
        extraction(&mesh, args.extract_resolution, args.skimage_python.as_deref())?
    } else {
        Value::Null
    };
    let openvdb = match &args.openvdb_peer {
        Some(bin) => peer_openvdb(bin, &args.mesh, args.resolution, args.radius_voxels, args.edits)?,
        None => Value::Null,
    };
    let out = json!({
        "mesh": args.mesh.display().to_string(),
        "resolution": args.resolution,
        "radius_voxels": args.radius_voxels,
        "threads": rayon::current_num_threads(),
        "voxelize_s": voxelize_s,
        "octree_build_s": octree_build_s,
        "octree_levels": start_stats_levels(args.resolution),
        "octree_nodes_start": start_stats.nodes(),
        "octree_bytes_start": start_stats.bytes,
        "edits": args.edits,
        "carve_ms_median": carve_ms_median,
        "carve_ms_min": carve_min,
        "carve_ms_max": carve_max,
        "carve_changed_voxels_mean": changed_voxels as f64 / args.edits as f64,
        "strokes_100_s": strokes_s,
        "octree_bytes_after_100_strokes": stats.bytes,
        "octree_nodes_after_100_strokes": stats.nodes(),
        "octree_bricks_after_100_strokes": stats.bricks,
        "history_bytes_100_strokes": history_bytes,
        "dense_bytes": dense_bytes,
        "octree_over_dense": stats.bytes as f64 / dense_bytes as f64,
        "render": render,
        "extraction": extraction,
        "openvdb": openvdb,
        "carve_speedup_vs_openvdb": openvdb.get("edit_ms_median").and_then(Value::as_f64).map(|o| o / carve_ms_median),
    });
    println!("{out}");
    Ok(())
}

fn start_stats_levels(resolution: u32) -> u32 {
    let mut levels = 0;
    while (8u32 << levels) < resolution {
        levels += 1;
    }
    levels
}

fn rerender(sculpt: &Sculpt, mesh: &TriMesh, size: u32, radius: f64) -> Result<Value, Failure> {
    let bounds = mesh.bounds();
    let centre = bounds.center();
    let distance = bounds.size().length() * 0.5 / (15f64.to_radians()).sin();
    let camera = Camera::look_at(
        centre + DVec3::new(0.3, 0.35, 1.0).normalize() * distance,
        centre,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 30.0 },
    )
    .map_err(|e| failed(e.to_string()))?;
    let settings = RenderSettings::new(size, size);
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(Vec3::new(0.85, 0.8, 0.75)),
    };
    let t = Instant::now();
    let renderer = Renderer::new(sculpt, &iso, &settings).map_err(|e| failed(e.to_string()))?;
    let prepare_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (mut image, _) = renderer.render(&camera, &NoProgress);
    let full_s = t.elapsed().as_secs_f64();
    let mut edited = sculpt.clone();
    // A carve on the visible side: the first triangle centroid facing the camera.
    let c = (0..mesh.triangle_count())
        .map(|i| mesh.triangle(i))
        .find(|t| (t[1] - t[0]).cross(t[2] - t[0]).dot(camera.eye() - t[0]) > 0.0)
        .map_or(centre, |t| (t[0] + t[1] + t[2]) / 3.0);
    let stroke = Stroke::new(
        Tool::sphere(c, radius).map_err(|e| failed(e.to_string()))?,
        Operation::Carve,
    )
    .map_err(|e| failed(e.to_string()))?;
    let changed = edited.apply(&stroke).changed_world;
    // What a viewer does after an edit: update the renderer where the edit reached
    // (`Renderer::after_edit`), then re-render the pixels whose rays pass through it.
    let t = Instant::now();
    let renderer = match changed {
        Some(b) => renderer.after_edit(&edited, &b),
        None => Renderer::new(&edited, &iso, &settings),
    }
    .map_err(|e| failed(e.to_string()))?;
    let re_prepare_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (pixels, _) = match changed {
        Some(b) => renderer.rerender_box(&camera, &b, &mut image),
        None => (0, Default::default()),
    };
    let rerender_s = t.elapsed().as_secs_f64();
    // The same edit with a renderer prepared from scratch, for comparison.
    let t = Instant::now();
    drop(Renderer::new(&edited, &iso, &settings).map_err(|e| failed(e.to_string()))?);
    let fresh_prepare_s = t.elapsed().as_secs_f64();
    Ok(json!({
        "size": size,
        "prepare_s": prepare_s,
        "full_frame_s": full_s,
        "rerender_prepare_s": re_prepare_s,
        "fresh_prepare_s": fresh_prepare_s,
        "rerender_s": rerender_s,
        "rerender_pixels": pixels,
        "pixels": size as u64 * size as u64,
    }))
}

pub(crate) fn time_median<T>(repeat: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = f(); // warm-up
    let mut times = Vec::new();
    for _ in 0..repeat {
        let t = Instant::now();
        out = f();
        times.push(t.elapsed().as_secs_f64());
    }
    (median(&mut times), out)
}

fn extraction(mesh: &TriMesh, resolution: u32, python: Option<&Path>) -> Result<Value, Failure> {
    let volume = voxelize(mesh, resolution)?;
    let field = Sampled::new(&volume, Filter::Trilinear);
    let region = volume.grid.center_bounds();
    let h = volume.grid.transform.spacing().x;
    let job = |placement| Extraction::new(region, h, 0.5).with_placement(placement);
    let (linear_s, linear) = time_median(3, || extract_surface_with(&field, &job(VertexPlacement::Linear)));
    let linear = linear.map_err(|e| failed(e.to_string()))?;
    let refined_job = job(VertexPlacement::Refined {
        tolerance: 1e-6,
        max_iterations: 16,
    });
    let (refined_s, refined) = time_median(3, || extract_surface_with(&field, &refined_job));
    let refined = refined.map_err(|e| failed(e.to_string()))?;
    let closed = linear.mesh.edge_stats();
    let mut out = json!({
        "resolution": resolution,
        "dims": volume.grid.dims().to_array(),
        "volga_linear_s": linear_s,
        "volga_refined_s": refined_s,
        "volga_triangles": linear.mesh.triangle_count(),
        "volga_vertices": linear.mesh.positions.len(),
        "volga_boundary_edges_by_index": boundary_by_index(&linear.mesh),
        "volga_welded_non_manifold_edges": closed.non_manifold_edges,
        "volga_refined_triangles": refined.mesh.triangle_count(),
    });
    if let Some(py) = python {
        let dense = volume.to_dense().map_err(|e| failed(e.to_string()))?;
        let dir = std::env::temp_dir().join(format!("volga-bench-sculpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| failed(e.to_string()))?;
        let raw = dir.join("volume.raw");
        let bytes: Vec<u8> = dense.density.as_slice().iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(&raw, bytes).map_err(|e| failed(e.to_string()))?;
        let d = volume.grid.dims();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/sculpt/skimage_mc.py");
        let peer = Command::new(py)
            .arg(&script)
            .arg(&raw)
            .args([d.x, d.y, d.z].map(|v| v.to_string()))
            .args(["0.5", "3"])
            .output()
            .map_err(|e| failed(format!("--skimage-python: {e}")))?;
        let _ = std::fs::remove_dir_all(&dir);
        let text = String::from_utf8_lossy(&peer.stdout);
        let v: Value = serde_json::from_str(text.trim()).map_err(|e| {
            failed(format!(
                "skimage peer output {text:?}: {e}; stderr {}",
                String::from_utf8_lossy(&peer.stderr)
            ))
        })?;
        if let Some(s) = v.get("median_s").and_then(Value::as_f64) {
            out["skimage_s"] = json!(s);
            out["volga_linear_speedup_vs_skimage"] = json!(s / linear_s);
        }
        out["skimage"] = v;
    }
    Ok(out)
}

fn boundary_by_index(mesh: &TriMesh) -> u64 {
    let mut uses = std::collections::HashMap::<(u32, u32), u32>::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses.values().filter(|&&n| n != 2).count() as u64
}

fn peer_openvdb(bin: &Path, mesh: &Path, resolution: u32, radius: f64, edits: u64) -> Result<Value, Failure> {
    let out = Command::new(bin)
        .arg(mesh)
        .arg(resolution.to_string())
        .arg(radius.to_string())
        .arg(edits.to_string())
        .output()
        .map_err(|e| failed(format!("--openvdb-peer {}: {e}", bin.display())))?;
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.trim()).map_err(|e| failed(format!("openvdb peer output {text:?}: {e}")))
}
