//! `volga validate`: is a voxel model a sound discrete surface? Components,
//! N-separability, N-simple voxels and minimality, Euler characteristic, and with a
//! reference mesh N-tunnels, cover and minimal cover (docs/VALIDATE.md).
//!
//! Every property that can be computed is reported; the exit code follows only the
//! required ones: 0 all hold, 1 one fails, 2 bad input.

use crate::failure::{bad_input, Failure};
use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use glam::{DVec3, IVec3};
use serde::Serialize;
use volga_core::Transform;
use volga_io::{VoxelModel, VoxelValues};
use volga_topology::{
    analyze_with, analyze_with_mesh, AnalyzeOptions, Connectivity, SurfaceMesh, TopologyReport, VoxelSet,
};

#[derive(Args)]
pub struct ValidateArgs {
    /// Voxel model: .binvox (black = filled) or .nrrd of densities (black = density ≥ 0.5;
    /// a NRRD of distances is refused).
    model: PathBuf,
    /// Reference surface (.obj, .gltf, .glb) in the model's world space: N-tunnels
    /// through it, cover and minimal cover.
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// N, the adjacency of white paths: 6, 18 or 26 (black uses the opposite type).
    #[arg(long, default_value = "26", value_parser = parse_connectivity)]
    connectivity: Connectivity,
    /// Properties the exit code follows, comma-separated. `separating`: no N-tunnels
    /// through the mesh with --mesh, else ≥ 2 white N-components; `minimal`: separating
    /// into white N-components with no N-simple voxel; `cover`: every point of the mesh
    /// lies in a black voxel (needs --mesh).
    #[arg(long, value_delimiter = ',', default_value = "separating")]
    require: Vec<Requirement>,
    /// Add one white layer around the grid, so the outside counts as one white region
    /// touching everything (voxel coordinates in the report are then shifted by +1).
    #[arg(long)]
    pad: bool,
    /// Print the report as JSON (schema in docs/VALIDATE.md) instead of a summary.
    #[arg(long)]
    json: bool,
    /// Entries kept in each list of the report (counts are always total).
    #[arg(long, default_value_t = 32)]
    listed: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
enum Requirement {
    Separating,
    Minimal,
    Cover,
}

fn parse_connectivity(s: &str) -> Result<Connectivity, String> {
    s.parse::<u32>()
        .ok()
        .and_then(Connectivity::from_number)
        .ok_or_else(|| format!("`{s}`: connectivity must be 6, 18 or 26"))
}

#[derive(Serialize)]
struct Output {
    model: PathBuf,
    format: &'static str,
    /// What the model's values are: `occupancy` (binvox, or a NRRD of 0 and 1) or
    /// `density` (a NRRD thresholded at 0.5).
    values: &'static str,
    padded: bool,
    /// World position of voxel (0, 0, 0)'s centre and the voxel spacing of the grid
    /// analysed (the padded grid with --pad).
    origin: [f64; 3],
    spacing: [f64; 3],
    mesh: Option<MeshInfo>,
    report: TopologyReport,
    requirements: Vec<RequirementResult>,
    passed: bool,
}

#[derive(Serialize)]
struct MeshInfo {
    path: PathBuf,
    triangles: usize,
    boundary_edges: usize,
    closed: bool,
}

#[derive(Serialize)]
struct RequirementResult {
    name: Requirement,
    holds: bool,
    /// What was tested.
    criterion: String,
}

/// Runs the validation; `Ok(true)` when every required property holds.
pub fn run(args: ValidateArgs) -> Result<bool, Failure> {
    let mut required: Vec<Requirement> = Vec::new();
    for &r in &args.require {
        if !required.contains(&r) {
            required.push(r);
        }
    }
    if required.contains(&Requirement::Cover) && args.mesh.is_none() {
        return Err(bad_input(format!(
            "{}: --require cover needs a reference surface: add --mesh MESH",
            args.model.display()
        )));
    }
    let (format, values, set, transform) = read_model(&args.model)?;
    let (set, transform) = if args.pad {
        let padded = set
            .padded(1)
            .map_err(|e| bad_input(format!("{}: --pad: {e}", args.model.display())))?;
        let t = Transform::new(transform.origin() - transform.spacing(), transform.spacing())
            .map_err(|e| bad_input(format!("{}: --pad: {e}", args.model.display())))?;
        (padded, t)
    } else {
        (set, transform)
    };

    let options = AnalyzeOptions { listed: args.listed };
    let n = args.connectivity;
    let (report, mesh_info) = match &args.mesh {
        None => (analyze_with(&set, n, &options), None),
        Some(path) => {
            let mesh = volga_mesh::load_mesh(path).map_err(|e| bad_input(e.to_string()))?;
            let boundary_edges = mesh.boundary_edge_count();
            let surface = SurfaceMesh::from_world((0..mesh.triangles.len()).map(|i| mesh.triangle(i)), &transform);
            let info = MeshInfo {
                path: path.clone(),
                triangles: mesh.triangles.len(),
                boundary_edges,
                closed: boundary_edges == 0 && mesh.non_manifold_edge_count() == 0,
            };
            (analyze_with_mesh(&set, n, &surface, &options), Some(info))
        }
    };

    let requirements: Vec<RequirementResult> = required.iter().map(|&r| evaluate(r, &report, n)).collect();
    let passed = requirements.iter().all(|r| r.holds);
    let output = Output {
        model: args.model.clone(),
        format,
        values: values.name(),
        padded: args.pad,
        origin: transform.origin().to_array(),
        spacing: transform.spacing().to_array(),
        mesh: mesh_info,
        report,
        requirements,
        passed,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&output).expect("report serializes"));
    } else {
        print!("{}", summary(&output));
    }
    Ok(passed)
}

fn evaluate(r: Requirement, report: &TopologyReport, n: Connectivity) -> RequirementResult {
    let (holds, criterion) = match (r, &report.mesh) {
        (Requirement::Separating, Some(m)) => (m.separating, format!("no {n}-tunnels through the mesh")),
        (Requirement::Separating, None) => (report.separating, format!("white splits into ≥ 2 {n}-components")),
        (Requirement::Minimal, _) => (
            report.minimal,
            format!("white splits into ≥ 2 {n}-components and no black voxel is {n}-simple"),
        ),
        (Requirement::Cover, m) => (
            m.as_ref().is_some_and(|m| m.covers),
            "every point of the mesh lies in a black voxel's closed cell".to_string(),
        ),
    };
    RequirementResult {
        name: r,
        holds,
        criterion,
    }
}

/// The black voxels of a `.binvox` or `.nrrd` model, its format, what its values mean
/// and its world transform. A NRRD of densities is thresholded at 0.5 (black =
/// density ≥ 0.5); a NRRD of distances is refused (bad input): its inside is `d ≤ 0`,
/// not a density, and validating it as one would report nothing black.
fn read_model(path: &Path) -> Result<(&'static str, VoxelValues, VoxelSet, Transform), Failure> {
    let named = |e: &dyn std::fmt::Display| bad_input(format!("{}: {e}", path.display()));
    match volga_io::read_voxel_model(path).map_err(|e| bad_input(e.to_string()))? {
        VoxelModel::Binvox(model) => {
            let transform = model.transform().map_err(|e| named(&e))?;
            let set =
                VoxelSet::from_voxels(model.dims(), model.filled().map(|v| v.as_ivec3())).map_err(|e| named(&e))?;
            Ok(("binvox", VoxelValues::Occupancy, set, transform))
        }
        VoxelModel::Nrrd {
            values: VoxelValues::Distance { min, max, background },
            ..
        } => Err(bad_input(format!(
            "{}: the file holds distances, not occupancy (values {min} … {max}, background {background}): \
             validate checks binary models; write one with `volga voxelize --separability 6|18|26 --out X.binvox`, \
             or threshold the field yourself (black = distance ≤ 0) into a .binvox",
            path.display()
        ))),
        VoxelModel::Nrrd { volume, values } => {
            let set = VoxelSet::from_dense(&volume, 0.5).map_err(|e| named(&e))?;
            Ok(("nrrd", values, set, volume.grid.transform))
        }
    }
}

fn v3(v: IVec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

fn w3(v: DVec3) -> String {
    format!("({:.6}, {:.6}, {:.6})", v.x, v.y, v.z)
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// The readable summary: one line per property, the first offending voxel where there
/// is one.
fn summary(o: &Output) -> String {
    use std::fmt::Write;
    let r = &o.report;
    let n = r.connectivity;
    let mut s = String::new();
    let d = r.dims;
    let _ = writeln!(
        s,
        "{} ({}{}{}): {}×{}×{} grid, {} black voxels, white {n}-adjacency, black {}",
        o.model.display(),
        o.format,
        if o.values == "density" {
            ", densities: black = density ≥ 0.5"
        } else {
            ""
        },
        if o.padded { ", padded by one white layer" } else { "" },
        d.x,
        d.y,
        d.z,
        r.voxels,
        r.black_connectivity
    );
    let _ = writeln!(
        s,
        "  black {}-components: {}",
        r.black_connectivity, r.black_component_count
    );
    let separation = r
        .checks
        .iter()
        .find(|c| c.name == "separating")
        .map_or("", |c| c.message.as_str());
    let _ = writeln!(
        s,
        "  white {n}-components: {} — {}: {separation}",
        r.white_component_count,
        if r.separating { "separating" } else { "not separating" }
    );
    match r.simple_voxel_count {
        None => {
            let _ = writeln!(s, "  {n}-simple voxels: undefined (not separating); not minimal");
        }
        Some(0) => {
            let _ = writeln!(s, "  {n}-simple voxels: 0 — minimal");
        }
        Some(c) => {
            let _ = writeln!(
                s,
                "  {n}-simple voxels: {c} (first {}) — not minimal",
                r.simple_voxels.first().map_or(String::new(), |v| v3(*v))
            );
        }
    }
    let _ = writeln!(
        s,
        "  Euler characteristic {}, cavities {}, handles {}",
        r.euler_characteristic, r.cavities, r.handles
    );
    if let (Some(m), Some(info)) = (&r.mesh, &o.mesh) {
        let _ = writeln!(
            s,
            "  mesh {} ({} triangles, {}):",
            info.path.display(),
            info.triangles,
            if info.closed {
                "closed".to_string()
            } else {
                format!("{} boundary edges", info.boundary_edges)
            }
        );
        match m.tunnels.first() {
            None => {
                let _ = writeln!(s, "    {n}-tunnels: 0 — {n}-separating with respect to the mesh");
            }
            Some(t) => {
                let _ = writeln!(
                    s,
                    "    {n}-tunnels: {} — first between {} and {}, crossing triangle {} at {}",
                    m.tunnel_count,
                    v3(t.a),
                    v3(t.b),
                    t.triangle,
                    w3(t.world)
                );
            }
        }
        match m.uncovered.first() {
            None => {
                let _ = writeln!(s, "    cover: yes");
            }
            Some(u) => {
                let _ = writeln!(
                    s,
                    "    cover: no — {} triangles uncovered; first triangle {} in white voxel {}{}",
                    m.uncovered_triangle_count,
                    u.triangle,
                    v3(u.voxel),
                    if u.in_grid { "" } else { " (outside the grid)" }
                );
            }
        }
        let _ = writeln!(
            s,
            "    black voxels the mesh does not touch: {}",
            m.untouched_voxel_count
        );
        let _ = writeln!(
            s,
            "    minimal cover: {}{}",
            m.minimal_cover.map_or("undefined (not a cover)", yes),
            if m.redundant_voxel_count > 0 {
                format!(" ({} black voxels removable one at a time)", m.redundant_voxel_count)
            } else {
                String::new()
            }
        );
    }
    for req in &o.requirements {
        let name = serde_json::to_value(req.name).expect("name serializes");
        let _ = writeln!(
            s,
            "required {}: {} ({})",
            name.as_str().unwrap_or_default(),
            if req.holds { "holds" } else { "FAILS" },
            req.criterion
        );
    }
    let _ = writeln!(s, "{}", if o.passed { "valid" } else { "invalid" });
    s
}
