//! `volga validate`: is a voxel model a sound discrete surface? Components,
//! N-separability, N-simple voxels and minimality, Euler characteristic, and with a
//! reference mesh N-tunnels, cover and minimal cover (docs/VALIDATE.md).
//!
//! Every property that can be computed is reported; the exit code follows only the
//! required ones: 0 all hold, 1 one fails, 2 bad input.

use crate::failure::{bad_input, Failure};
use std::path::{Path, PathBuf};

use clap::Args;
use glam::{DVec3, IVec3};
use volga_core::Transform;
use volga_io::{VoxelModel, VoxelValues};
use volga_topology::{verdict, Connectivity, Requirement, Verdict, VerdictError, VerdictInput, VoxelSet};

#[derive(Args)]
pub struct ValidateArgs {
    /// Voxel model: .binvox (black = filled), .nrrd of densities (black = density ≥ 0.5;
    /// a NRRD of distances is refused) or .vdb (a fog volume's density ≥ 0.5, a level
    /// set's distance ≤ 0).
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
    #[arg(long, value_delimiter = ',', default_value = "separating", value_parser = parse_requirement)]
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

fn parse_requirement(s: &str) -> Result<Requirement, String> {
    s.parse()
}

fn parse_connectivity(s: &str) -> Result<Connectivity, String> {
    s.parse::<u32>()
        .ok()
        .and_then(Connectivity::from_number)
        .ok_or_else(|| format!("`{s}`: connectivity must be 6, 18 or 26"))
}

/// Runs the validation; `Ok(true)` when every required property holds.
pub fn run(args: ValidateArgs) -> Result<bool, Failure> {
    if args.require.contains(&Requirement::Cover) && args.mesh.is_none() {
        return Err(bad_input(format!(
            "{}: --require cover needs a reference surface: add --mesh MESH",
            args.model.display()
        )));
    }
    let (format, values, set, transform) = read_model(&args.model)?;
    let mesh = match &args.mesh {
        Some(path) => Some(volga_mesh::load_mesh(path).map_err(|e| bad_input(e.to_string()))?),
        None => None,
    };
    let output = verdict(VerdictInput {
        model: Some(args.model.clone()),
        format,
        values: values.name(),
        set,
        transform,
        connectivity: args.connectivity,
        mesh: mesh.as_ref().map(|m| (m, args.mesh.clone())),
        requirements: &args.require,
        pad: args.pad,
        listed: args.listed,
    })
    .map_err(|e| match e {
        VerdictError::Pad(m) => bad_input(format!("{}: --pad: {m}", args.model.display())),
        e => bad_input(format!("{}: {e}", args.model.display())),
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&output).expect("report serializes"));
    } else {
        print!("{}", summary(&output));
    }
    Ok(output.passed)
}

/// The black voxels of a `.binvox`, `.nrrd` or `.vdb` model, its format, what its values mean
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
        VoxelModel::Vdb { grid, values } if grid.class == volga_io::VdbClass::LevelSet => {
            // Black = inside: distance ≤ 0, i.e. −distance ≥ 0.
            let v = &grid.volume;
            let set = VoxelSet::from_sparse(&v.map_density(|d| -d), 0.0).map_err(|e| named(&e))?;
            Ok(("vdb", values, set, v.grid.transform))
        }
        VoxelModel::Vdb {
            values: VoxelValues::Distance { min, max, background },
            grid,
        } => Err(bad_input(format!(
            "{}: grid {:?} holds values {min} … {max} over background {background}, neither occupancy nor \
             densities in [0, 1] nor a level set (class {})",
            path.display(),
            grid.name,
            grid.class.name()
        ))),
        VoxelModel::Vdb { grid, values } => {
            let set = VoxelSet::from_sparse(&grid.volume, 0.5).map_err(|e| named(&e))?;
            Ok(("vdb", values, set, grid.volume.grid.transform))
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
fn summary(o: &Verdict) -> String {
    use std::fmt::Write;
    let r = &o.report;
    let n = r.connectivity;
    let mut s = String::new();
    let d = r.dims;
    let _ = writeln!(
        s,
        "{} ({}{}{}): {}×{}×{} grid, {} black voxels, white {n}-adjacency, black {}",
        o.model.as_deref().unwrap_or(Path::new("<array>")).display(),
        o.format,
        match o.values {
            "density" => ", densities: black = density ≥ 0.5",
            "distance" => ", level set: black = distance ≤ 0",
            _ => "",
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
            info.path.as_deref().unwrap_or(Path::new("<mesh>")).display(),
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
        let _ = writeln!(
            s,
            "required {}: {} ({})",
            req.name.name(),
            if req.holds { "holds" } else { "FAILS" },
            req.criterion
        );
    }
    let _ = writeln!(s, "{}", if o.passed { "valid" } else { "invalid" });
    s
}
