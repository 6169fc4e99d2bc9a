//! [`analyze`]: every property this crate computes, as one serializable report.

use glam::{IVec3, UVec3};
use serde::Serialize;

use crate::euler::betti_from;
use crate::simple::count_simple_voxels;
use crate::surface::{check_mesh, MeshReport, SurfaceMesh};
use crate::{black_components, euler_characteristic, white_components, Component, Components, Connectivity, VoxelSet};

/// Where a white component lies relative to the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Region {
    /// Touches the grid border: the outside, when the set is padded (or a region cut
    /// off by a surface that reaches the border, such as one side of a plane).
    Outside,
    /// Enclosed by black voxels: the inside of a closed surface, or a cavity.
    Inside,
}

/// A white component and its region.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct WhiteComponent {
    /// Outside (touches the border) or inside (enclosed).
    pub region: Region,
    /// The component itself (flattened into this object in JSON).
    #[serde(flatten)]
    pub component: Component,
}

/// One numbered check, in the order they run (cheap to expensive), naming its
/// failure and the first offending voxel when there is one (OpenVDB Diagnostics'
/// habit).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Check {
    /// The check's name in snake case (`non_empty`, `separating`, `minimal`, …).
    pub name: &'static str,
    /// Whether the property holds.
    pub passed: bool,
    /// What was found, in words.
    pub message: String,
    /// The first offending voxel (index space), when the check points at one.
    #[serde(serialize_with = "optional_ivec3")]
    pub voxel: Option<IVec3>,
}

fn optional_ivec3<S: serde::Serializer>(v: &Option<IVec3>, serializer: S) -> Result<S::Ok, S::Error> {
    v.map(|v| v.to_array()).serialize(serializer)
}

/// Everything [`analyze`] computes about a voxel set for one connectivity N.
///
/// `connectivity` is N, the adjacency of white paths in separability and simplicity
/// (survey 17.2); black components use the opposite type (`black_connectivity`: 26
/// for N = 6, 6 for N = 18 or 26). The Euler characteristic, cavities and handles are
/// those of the black voxels as a union of closed cubes, which is the (26, 6) pair
/// whatever N is.
///
/// `mesh` holds the checks against a reference surface ([`analyze_with_mesh`]) and is
/// `None` (`null` in JSON) without one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TopologyReport {
    /// Voxels per axis of the grid analysed.
    #[serde(serialize_with = "uvec3")]
    pub dims: UVec3,
    /// Black voxels.
    pub voxels: u64,
    /// N: the adjacency of white paths (separability, simplicity, white components).
    #[serde(serialize_with = "crate::connectivity::serialize_number")]
    pub connectivity: Connectivity,
    /// The adjacency of black components, the opposite type of N.
    #[serde(serialize_with = "crate::connectivity::serialize_number")]
    pub black_connectivity: Connectivity,
    /// Black components (under `black_connectivity`).
    pub black_component_count: u64,
    /// The first [`AnalyzeOptions::listed`] black components in label order.
    pub black_components: Vec<Component>,
    /// White N-components.
    pub white_component_count: u64,
    /// The first [`AnalyzeOptions::listed`] white components in label order.
    pub white_components: Vec<WhiteComponent>,
    /// White splits into ≥ 2 N-components (survey 17.2: N-separating in `Σ`).
    pub separating: bool,
    /// Number of N-simple voxels; `None` when the set is not separating (N-simple is
    /// defined for N-separating sets only).
    pub simple_voxel_count: Option<u64>,
    /// The first [`AnalyzeOptions::listed`] N-simple voxels in (z, y, x) order.
    #[serde(serialize_with = "ivec3_list")]
    pub simple_voxels: Vec<IVec3>,
    /// N-separating and without N-simple voxels.
    pub minimal: bool,
    /// `χ = V − E + F − C` of the black cubes.
    pub euler_characteristic: i64,
    /// Bounded white 6-components.
    pub cavities: u64,
    /// `b1 = b0 + b2 − χ` with `b0` the black 26-components.
    pub handles: u64,
    /// The numbered checks, in the order they ran.
    pub checks: Vec<Check>,
    /// Tunnels, cover and minimal cover against a reference mesh.
    pub mesh: Option<MeshReport>,
}

fn uvec3<S: serde::Serializer>(v: &UVec3, serializer: S) -> Result<S::Ok, S::Error> {
    v.to_array().serialize(serializer)
}

fn ivec3_list<S: serde::Serializer>(v: &[IVec3], serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_seq(v.iter().map(|v| v.to_array()))
}

/// How much of each list [`analyze_with`] keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnalyzeOptions {
    /// Components and simple voxels listed in the report (counts are always total).
    pub listed: usize,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        AnalyzeOptions { listed: 32 }
    }
}

/// [`analyze_with`] with default options.
pub fn analyze(set: &VoxelSet, connectivity: Connectivity) -> TopologyReport {
    analyze_with(set, connectivity, &AnalyzeOptions::default())
}

/// Runs every check on `set` for white N-connectivity `connectivity`, cheap to
/// expensive: voxel count, black components, white components and separation,
/// Euler characteristic and Betti numbers, N-simple voxels and minimality. Deterministic:
/// the same report for any thread count.
pub fn analyze_with(set: &VoxelSet, connectivity: Connectivity, options: &AnalyzeOptions) -> TopologyReport {
    let listed = options.listed;
    let black_connectivity = connectivity.opposite();
    let mut checks = vec![check_non_empty(set)];

    let black = black_components(set, black_connectivity);
    checks.push(check_black_connected(&black));

    let white = white_components(set, connectivity);
    let separating = white.len() >= 2;
    checks.push(check_separating(&white));

    let euler_characteristic = euler_characteristic(set);
    let black_26 = if black_connectivity == Connectivity::TwentySix {
        black.len()
    } else {
        black_components(set, Connectivity::TwentySix).len()
    };
    let cavities = if connectivity == Connectivity::Six {
        white.interior().count()
    } else {
        white_components(set, Connectivity::Six).interior().count()
    };
    let betti = betti_from(black_26 as u64, cavities as u64, euler_characteristic);

    let (simple_voxel_count, simple_voxels) = if separating {
        let (count, first) = count_simple_voxels(set, &white, listed);
        (Some(count), first)
    } else {
        (None, Vec::new())
    };
    let minimal = simple_voxel_count == Some(0);
    checks.push(check_minimal(
        connectivity,
        simple_voxel_count,
        simple_voxels.first().copied(),
    ));

    TopologyReport {
        dims: set.dims(),
        voxels: set.len(),
        connectivity,
        black_connectivity,
        black_component_count: black.len() as u64,
        black_components: black.components().iter().take(listed).cloned().collect(),
        white_component_count: white.len() as u64,
        white_components: white
            .components()
            .iter()
            .take(listed)
            .map(|c| WhiteComponent {
                region: if c.touches_border {
                    Region::Outside
                } else {
                    Region::Inside
                },
                component: c.clone(),
            })
            .collect(),
        separating,
        simple_voxel_count,
        simple_voxels,
        minimal,
        euler_characteristic,
        cavities: betti.b2,
        handles: betti.b1,
        checks,
        mesh: None,
    }
}

/// [`analyze_with`] plus the checks against a reference surface ([`check_mesh`]):
/// N-tunnels through it, cover and minimal cover. Three checks join the list:
/// `tunnels`, `cover` and `minimal_cover`.
pub fn analyze_with_mesh(
    set: &VoxelSet,
    connectivity: Connectivity,
    mesh: &SurfaceMesh,
    options: &AnalyzeOptions,
) -> TopologyReport {
    let mut report = analyze_with(set, connectivity, options);
    let m = check_mesh(set, connectivity, mesh, options.listed);
    let n = connectivity;
    report.checks.push(Check {
        name: "tunnels",
        passed: m.separating,
        message: if m.separating {
            format!("no {n}-tunnels through the mesh: {n}-separating with respect to it")
        } else {
            format!(
                "{} {n}-tunnels through the mesh (white {n}-adjacent pairs whose segment meets it); the first starts at the voxel given",
                m.tunnel_count
            )
        },
        voxel: m.tunnels.first().map(|t| t.a),
    });
    report.checks.push(Check {
        name: "cover",
        passed: m.covers,
        message: if m.covers {
            format!(
                "every point of the mesh lies in a black voxel; {} black voxels untouched by it",
                m.untouched_voxel_count
            )
        } else {
            format!(
                "{} triangles have points in no black voxel; the first such white voxel is given",
                m.uncovered_triangle_count
            )
        },
        voxel: m.uncovered.first().map(|u| u.voxel),
    });
    report.checks.push(Check {
        name: "minimal_cover",
        passed: m.minimal_cover == Some(true),
        message: match m.minimal_cover {
            None => "not a cover, so not a minimal cover".to_string(),
            Some(true) => "every black voxel is the only black voxel for some point of the mesh".to_string(),
            Some(false) => format!(
                "{} black voxels can each be removed with the mesh still covered; the first is given",
                m.redundant_voxel_count
            ),
        },
        voxel: m.redundant_voxels.first().copied(),
    });
    report.mesh = Some(m);
    report
}

fn check_non_empty(set: &VoxelSet) -> Check {
    Check {
        name: "non_empty",
        passed: !set.is_empty(),
        message: format!("{} black voxels in a {} grid", set.len(), dims_text(set.dims())),
        voxel: set.iter().next(),
    }
}

fn check_black_connected(black: &Components) -> Check {
    let n = black.connectivity();
    let count = black.len();
    Check {
        name: "black_connected",
        passed: count == 1,
        message: match count {
            0 => format!("no black {n}-components"),
            1 => format!("one black {n}-component"),
            _ => format!("{count} black {n}-components; the second starts at the voxel given"),
        },
        voxel: black.components().get(1).map(|c| c.first_voxel),
    }
}

fn check_separating(white: &Components) -> Check {
    let n = white.connectivity();
    let count = white.len();
    let inside = white.interior().count();
    Check {
        name: "separating",
        passed: count >= 2,
        message: if count >= 2 {
            format!(
                "white splits into {count} {n}-components ({} touching the border, {inside} enclosed)",
                count - inside
            )
        } else {
            format!("white is {count} {n}-component(s): the set is not {n}-separating")
        },
        voxel: None,
    }
}

fn check_minimal(n: Connectivity, simple_count: Option<u64>, first: Option<IVec3>) -> Check {
    Check {
        name: "minimal",
        passed: simple_count == Some(0),
        message: match simple_count {
            None => format!("not {n}-separating, so not {n}-minimal"),
            Some(0) => format!("no {n}-simple voxels"),
            Some(c) => format!("{c} {n}-simple voxels (removable without merging white regions); the first is given"),
        },
        voxel: first,
    }
}

fn dims_text(d: UVec3) -> String {
    format!("{}×{}×{}", d.x, d.y, d.z)
}
