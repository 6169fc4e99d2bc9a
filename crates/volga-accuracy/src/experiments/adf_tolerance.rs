//! ADF tolerance: cells, memory, build time and distance error of adaptively sampled
//! distance fields of meshes, beside a uniform grid and a 3-colour octree of the same
//! maximum error (Frisken et al. 2000 report ADFs needing far fewer cells than 3-colour
//! octrees; this measures our ratio).
//!
//! * **ADF**: `volga_adf::Adf::build` of the mesh (exact distance, certified winding
//!   sign) at the tolerance (a fraction of the bounding-box diagonal), timed, with the
//!   maximum depth following the tolerance ([`max_depth_for`]: 12 down to 1e-4, one level
//!   more per halving below, 16 at 1e-5);
//!   errors measured against the exact signed distance at 20,000 points within 2 % of the
//!   diagonal of the surface, in leaves the tolerance applies to (not pruned).
//! * **Uniform grid of the same maximum error**: the ADF's largest errors sit in its
//!   finest cells (the distance's creases at sharp edges and rims, which only cell size
//!   resolves), so a uniform grid needs the ADF's finest cell size everywhere:
//!   `(2^depth)³` cells.
//! * **3-colour octree of the same maximum error**: every cell the surface passes through
//!   (`|d(centre)| ≤ half the cell's diagonal`) split down to the same finest size, the
//!   rest leaves: counted exactly down to level 9 and extrapolated by ×4 per level below
//!   (a surface's cell count quadruples per halving), with the count's exact levels
//!   recorded.

use glam::DVec3;
use volga_adf::{measure_errors, Adf, AdfOptions, MeshSource};
use volga_mesh::{Bvh, TriMesh};

use super::{Context, Experiment};
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment {
    id: "adf_tolerance",
    run,
};

/// The maximum depth for a tolerance (a fraction of the diagonal): 12 for tolerances
/// ≥ 1e-4, one more level per halving of the tolerance below (16 at 1e-5). The largest
/// errors sit in maximum-depth cells on the distance's creases (sharp edges, the bunny's
/// hole rims), where the trilinear error falls like the cell size, not its square: at
/// 1e-4 depth 12 leaves them at 0.9× the tolerance, so a tolerance 2^-k smaller needs k
/// more levels. `error_points_at_max_depth` and `max_error_below_max_depth` in the table
/// show whether it was enough.
pub fn max_depth_for(tolerance: f64) -> u8 {
    let halvings = (1e-4 / tolerance).log2().ceil().max(0.0);
    (12.0 + halvings).min(volga_adf::MAX_SUPPORTED_DEPTH as f64) as u8
}

/// Levels counted exactly for the 3-colour octree.
const EXACT_LEVELS: u8 = 9;

/// Cells of a 3-colour octree over the cube `min + [0, size]³` whose boundary cells are
/// split to `depth`: `(cells counted, boundary cells at the deepest counted level, that
/// level)`.
fn three_colour(bvh: &Bvh, min: DVec3, size: f64, depth: u8) -> (f64, f64, u8) {
    let counted = depth.min(EXACT_LEVELS);
    let mut per_level = vec![0u64; counted as usize + 1];
    let mut stack = vec![(min, size, 0u8)];
    while let Some((m, s, level)) = stack.pop() {
        let half_diagonal = s * 3f64.sqrt() * 0.5;
        let centre = m + DVec3::splat(s * 0.5);
        let boundary = bvh.closest_within(centre, half_diagonal).is_some();
        if boundary {
            per_level[level as usize] += 1;
            if level < counted {
                let h = s * 0.5;
                for o in 0..8 {
                    let off = DVec3::new((o & 1) as f64, ((o >> 1) & 1) as f64, ((o >> 2) & 1) as f64);
                    stack.push((m + off * h, h, level + 1));
                }
            }
        }
    }
    // Every split boundary cell has 8 children; the root is one cell.
    let mut cells = 1.0 + 8.0 * per_level[..counted as usize].iter().sum::<u64>() as f64;
    let mut boundary = per_level[counted as usize] as f64;
    for _ in counted..depth {
        cells += 8.0 * boundary;
        boundary *= 4.0;
    }
    (cells, boundary, counted)
}

fn mesh_series(name: &str, mesh: &TriMesh, tolerances: &[f64], points: usize, ctx: &Context) -> Series {
    let source = MeshSource::new(mesh).expect("a non-empty mesh");
    let bounds = mesh.bounds();
    let diagonal = bounds.size().length();
    let settings = tolerances
        .iter()
        .map(|&tolerance| {
            let options = AdfOptions {
                max_depth: max_depth_for(tolerance),
                ..AdfOptions::relative(tolerance, &bounds)
            };
            let (adf, timing) = timed(|| Adf::build(&source, options).expect("ADF build"));
            let errors = measure_errors(&adf, &source, &bounds, 0.02 * diagonal, points);
            let depth = adf.stats().depth_reached;
            let root = adf.root_box();
            let (three, _, exact_levels) = three_colour(source.bvh(), root.min, root.size().x, depth);
            let uniform = 8f64.powi(depth as i32);
            ctx.setting_done();
            Setting::new(
                format!("{tolerance:e}"),
                &[
                    ("tolerance", tolerance),
                    ("max_depth", max_depth_for(tolerance) as f64),
                    ("depth_reached", depth as f64),
                    ("three_colour_exact_levels", exact_levels as f64),
                ],
                timing,
                adf.memory_bytes() as u64,
            )
            .error("max_error", errors.max / diagonal)
            .error("rms_error", errors.rms / diagonal)
            .error("max_error_below_max_depth", errors.max_below_max_depth / diagonal)
            .error(
                "points_at_max_depth",
                errors.points_at_max_depth as f64 / errors.points.max(1) as f64,
            )
            .error("adf_cells", adf.cell_count() as f64)
            .error("three_colour_cells", three)
            .error("uniform_cells", uniform)
            .error("three_colour_over_adf", three / adf.cell_count() as f64)
        })
        .collect();
    Series {
        name: format!("{name} ({} triangles)", mesh.triangle_count()),
        settings,
    }
}

fn shared_mesh(file: &str) -> TriMesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/").to_string() + file;
    volga_mesh::load_mesh(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn run(ctx: &Context) -> KnobResult {
    let series = match ctx.size {
        crate::experiments::Size::Quick => {
            let torus = crate::references::torus_mesh(24, 12);
            ctx.start("ADF tolerance", 2);
            vec![mesh_series("torus mesh", &torus, &[1e-2, 3e-3], 2000, ctx)]
        }
        crate::experiments::Size::Full => {
            let tolerances = [1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5];
            ctx.start("ADF tolerance", 2 * tolerances.len());
            // fandisk first: the smaller build, so its rows exist even if the bunny's 1e-5
            // row ran out of memory.
            let fandisk = mesh_series(
                "fandisk (sharp edges)",
                &shared_mesh("fandisk.obj"),
                &tolerances,
                20_000,
                ctx,
            );
            let bunny = mesh_series(
                "Stanford bunny (open)",
                &shared_mesh("stanford-bunny.obj"),
                &tolerances,
                20_000,
                ctx,
            );
            vec![bunny, fandisk]
        }
    };
    ctx.finish();
    KnobResult {
        id: "adf_tolerance",
        title: "ADF tolerance: cells, memory and time against distance error",
        knob: "ADF tolerance as a fraction of the bounding-box diagonal (labels), maximum depth 12 down to 1e-4 and one more level per halving below (16 at 1e-5)",
        reference: "exact signed distance to the mesh (nearest triangle; sign by the certified generalized winding number) at points within 2 % of the diagonal of the surface, in unpruned leaves",
        timed: "Adf::build from the mesh (BVH and caps built beforehand), all threads",
        metrics: vec![
            Metric { id: "max_error", label: "distance error, max (fraction of the diagonal)" },
            Metric { id: "rms_error", label: "distance error, RMS (fraction of the diagonal)" },
            Metric {
                id: "max_error_below_max_depth",
                label: "max error in leaves above the maximum depth (fraction of the diagonal)",
            },
            Metric { id: "points_at_max_depth", label: "fraction of error points in maximum-depth leaves" },
            Metric { id: "adf_cells", label: "ADF cells" },
            Metric { id: "three_colour_cells", label: "3-colour octree cells, same max error" },
            Metric { id: "uniform_cells", label: "uniform grid cells, same max error" },
            Metric { id: "three_colour_over_adf", label: "3-colour octree cells / ADF cells" },
        ],
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::max_depth_for;

    #[test]
    fn the_maximum_depth_follows_the_tolerance() {
        assert_eq!(max_depth_for(1e-2), 12);
        assert_eq!(max_depth_for(1e-4), 12);
        assert_eq!(max_depth_for(5e-5), 13);
        assert_eq!(max_depth_for(3e-5), 14);
        assert_eq!(max_depth_for(1e-5), 16);
        assert_eq!(max_depth_for(1e-12), volga_adf::MAX_SUPPORTED_DEPTH);
    }
}
