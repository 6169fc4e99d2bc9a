//! The validator's verdict on a voxel model: the topology report, with a reference mesh
//! the tunnels and cover, and which required properties hold. One pipeline for `volga
//! validate` and the Python package's `volga.validate`, so both print the same JSON
//! (schema in docs/VALIDATE.md).

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use serde::Serialize;
use volga_core::Transform;
use volga_mesh::TriMesh;

use crate::{analyze_with, analyze_with_mesh, AnalyzeOptions, Connectivity, SurfaceMesh, TopologyReport, VoxelSet};

/// A property the verdict's `passed` follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Requirement {
    /// No N-tunnels through the mesh (with a mesh), else ≥ 2 white N-components.
    Separating,
    /// Separating, and no black voxel is N-simple.
    Minimal,
    /// Every point of the mesh lies in a black voxel's closed cell (needs a mesh).
    Cover,
}

impl Requirement {
    /// The name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Requirement::Separating => "separating",
            Requirement::Minimal => "minimal",
            Requirement::Cover => "cover",
        }
    }
}

impl FromStr for Requirement {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "separating" => Ok(Requirement::Separating),
            "minimal" => Ok(Requirement::Minimal),
            "cover" => Ok(Requirement::Cover),
            _ => Err(format!("`{s}`: a requirement is separating, minimal or cover")),
        }
    }
}

impl fmt::Display for Requirement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The reference mesh a verdict was checked against.
#[derive(Debug, Clone, Serialize)]
pub struct MeshInfo {
    /// Its file, when it came from one.
    pub path: Option<PathBuf>,
    /// Number of triangles.
    pub triangles: usize,
    /// Edges used by exactly one triangle (after welding).
    pub boundary_edges: usize,
    /// No boundary and no non-manifold edge.
    pub closed: bool,
}

/// One required property and whether it holds.
#[derive(Debug, Clone, Serialize)]
pub struct RequirementResult {
    /// The property.
    pub name: Requirement,
    /// Whether it holds.
    pub holds: bool,
    /// What was tested.
    pub criterion: String,
}

/// The verdict (`volga validate --json`).
#[derive(Debug, Clone, Serialize)]
pub struct Verdict {
    /// The model's file (absent for an in-memory model).
    pub model: Option<PathBuf>,
    /// `binvox`, `nrrd`, or `array` for an in-memory model.
    pub format: &'static str,
    /// What the model's values are: `occupancy` (0 and 1) or `density` (thresholded at 0.5).
    pub values: &'static str,
    /// A white layer was added around the grid before the analysis.
    pub padded: bool,
    /// World position of voxel (0, 0, 0)'s centre and the voxel spacing of the grid
    /// analysed (the padded grid when padded).
    pub origin: [f64; 3],
    /// The voxel spacing (world units per axis) of the grid analysed.
    pub spacing: [f64; 3],
    /// The reference mesh, when one was given.
    pub mesh: Option<MeshInfo>,
    /// Everything computed about the set (and against the mesh).
    pub report: TopologyReport,
    /// The required properties, each once, in the order first given.
    pub requirements: Vec<RequirementResult>,
    /// Every required property holds.
    pub passed: bool,
}

/// What to validate and how.
pub struct VerdictInput<'a> {
    /// The model's file, reported as given (`None` for an in-memory model).
    pub model: Option<PathBuf>,
    /// The model's format, reported as given ([`Verdict::format`]).
    pub format: &'static str,
    /// What the model's values were, reported as given ([`Verdict::values`]).
    pub values: &'static str,
    /// The black voxels.
    pub set: VoxelSet,
    /// Index space (voxel centres) to world space of the set.
    pub transform: Transform,
    /// N: the adjacency of white paths.
    pub connectivity: Connectivity,
    /// The reference surface in the model's world space, and its file.
    pub mesh: Option<(&'a TriMesh, Option<PathBuf>)>,
    /// The properties `passed` follows (repeats are ignored).
    pub requirements: &'a [Requirement],
    /// Add one white layer around the grid (voxel coordinates shift by +1).
    pub pad: bool,
    /// Entries kept in each list of the report.
    pub listed: usize,
}

/// Why a verdict cannot be given.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum VerdictError {
    /// Cover was required without a reference mesh.
    #[error("requiring cover needs a reference surface (a mesh)")]
    CoverNeedsMesh,
    /// The padded grid could not be made (too large, or its transform is invalid).
    #[error("padding: {0}")]
    Pad(String),
}

/// Validates a voxel set: every property is computed, `passed` follows the required ones
/// (each listed once, in the order first given).
pub fn verdict(input: VerdictInput<'_>) -> Result<Verdict, VerdictError> {
    let mut required: Vec<Requirement> = Vec::new();
    for &r in input.requirements {
        if !required.contains(&r) {
            required.push(r);
        }
    }
    if required.contains(&Requirement::Cover) && input.mesh.is_none() {
        return Err(VerdictError::CoverNeedsMesh);
    }
    let (set, transform) = if input.pad {
        let padded = input.set.padded(1).map_err(|e| VerdictError::Pad(e.to_string()))?;
        let t = Transform::new(
            input.transform.origin() - input.transform.spacing(),
            input.transform.spacing(),
        )
        .map_err(|e| VerdictError::Pad(e.to_string()))?;
        (padded, t)
    } else {
        (input.set, input.transform)
    };
    let options = AnalyzeOptions { listed: input.listed };
    let n = input.connectivity;
    let (report, mesh_info) = match input.mesh {
        None => (analyze_with(&set, n, &options), None),
        Some((mesh, path)) => {
            let boundary_edges = mesh.boundary_edge_count();
            let surface = SurfaceMesh::from_world((0..mesh.triangles.len()).map(|i| mesh.triangle(i)), &transform);
            let info = MeshInfo {
                path,
                triangles: mesh.triangles.len(),
                boundary_edges,
                closed: boundary_edges == 0 && mesh.non_manifold_edge_count() == 0,
            };
            (analyze_with_mesh(&set, n, &surface, &options), Some(info))
        }
    };
    let requirements: Vec<RequirementResult> = required.iter().map(|&r| evaluate(r, &report, n)).collect();
    let passed = requirements.iter().all(|r| r.holds);
    Ok(Verdict {
        model: input.model,
        format: input.format,
        values: input.values,
        padded: input.pad,
        origin: transform.origin().to_array(),
        spacing: transform.spacing().to_array(),
        mesh: mesh_info,
        report,
        requirements,
        passed,
    })
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
