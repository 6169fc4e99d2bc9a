//! What a build will cost, decided before it runs: cells (so memory) and source
//! evaluations (so work), from the tolerance, the depth limit and the source's surface.
//!
//! The estimate follows the build's own rules, level by level:
//! * **Depth.** A cell splits only if its reconstruction misses the source by more than
//!   `tolerance · TEST_MARGIN` at a test point. The reconstruction at a test point is a
//!   convex combination of corner values, each corner within `√3/2 · h` of the point, so
//!   for a 1-Lipschitz distance it misses by at most `√3/2 · h` (plus the `f32` rounding of
//!   the corners). Levels where that is within the tolerance split nothing.
//! * **Near the surface.** A cell is split only if it is not pruned: some corner lies
//!   within its diagonal (plus the band) of the surface. Such cells of edge `h` lie in a
//!   shell of thickness about `2(√3 h + band) + 1.5 h` around a surface of area `A`, so
//!   there are at most about that shell's volume over `h³` of them (and at most `8^k`).
//! * **The tolerance.** A trilinear cell reproduces a linear distance exactly; where the
//!   surface curves, the error at a cell's centre is `h²/8 · Δd`, and `Δd = 2H` (mean
//!   curvature) on the surface, so a cell splits only where the curvature it holds,
//!   `∫|H| dA` over its piece of surface, is of order the tolerance; on an edge of a
//!   polyhedron (a crease of the distance) the same holds with `∫|H| dA = ½ L θ`. Cells of
//!   one level are disjoint, so at most `C / (α · tolerance · TEST_MARGIN)` of them split
//!   (`C` the total `∫|H| dA`). The centre alone gives `α = 4`; the face and edge test
//!   points of neighbouring cells see the same curvature, and `α = 2` bounds every build
//!   measured (see docs/ADF.md: the estimate is 1.3–2.7× the cells of the bunny and
//!   fandisk from 1e-2 to 1e-5).
//!
//! Split cells per level are the least of the three; cells are `1 + 8 Σ split`. The
//! estimate is a model, not a proof (an open mesh's hole rims and a non-convex source
//! without [`AdfSource::surface_measures`] can exceed it), so the build also stops at
//! [`AdfOptions::max_cells`].

use super::build::root_cube;
use super::{AdfOptions, Cell, TEST_MARGIN};
use crate::source::{AdfSource, SurfaceMeasures};
use crate::{Adf, AdfError};

/// Bytes a build holds per cell at its peak: the tree (36 bytes per cell) and, while the
/// parallel top levels join their subtrees, one copy of it.
pub const BUILD_BYTES_PER_CELL: u64 = 2 * std::mem::size_of::<Cell>() as u64;

/// Source evaluations per split cell: its 19 test points (the children's new corners).
const EVALUATIONS_PER_SPLIT: f64 = 19.0;

/// The curvature model's constant `α` (module docs).
const CURVATURE_CELLS: f64 = 2.0;

/// What a build of a source at some options will cost ([`Adf::estimate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildEstimate {
    /// Estimated cells of the tree.
    pub cells: u64,
    /// Estimated bytes of the finished tree (36 per cell).
    pub tree_bytes: u64,
    /// Estimated bytes the build holds at its peak ([`BUILD_BYTES_PER_CELL`] per cell).
    pub build_bytes: u64,
    /// Estimated source evaluations (the build's work).
    pub evaluations: u64,
    /// The deepest level any cell can be split at: below it, the tolerance holds by the
    /// 1-Lipschitz bound alone (or `max_depth` stops the build first).
    pub deepest_split: u8,
    /// The root cube's edge (world units).
    pub root_size: f64,
}

impl BuildEstimate {
    /// Cells that fit in `bytes` of memory while building.
    pub fn cells_within(bytes: u64) -> usize {
        usize::try_from(bytes / BUILD_BYTES_PER_CELL).unwrap_or(usize::MAX)
    }
}

fn saturating_u64(x: f64) -> u64 {
    if x >= u64::MAX as f64 {
        u64::MAX
    } else {
        x.max(0.0) as u64
    }
}

impl Adf {
    /// The cells, memory and source evaluations a build of `source` at `options` is
    /// expected to need, from the tolerance, the depth limit and the source's area and
    /// curvature ([`AdfSource::surface_measures`]), without sampling the source. The
    /// model and its measured accuracy are in `docs/ADF.md` (*Bounds*).
    ///
    /// # Errors
    /// The options' errors ([`AdfError::Tolerance`], …) and the source's
    /// ([`AdfError::Unbounded`], [`AdfError::EmptySource`]), as [`Adf::build`] gives them.
    pub fn estimate<S: AdfSource + ?Sized>(source: &S, options: &AdfOptions) -> Result<BuildEstimate, AdfError> {
        let bounds = source.bounds();
        let (_, root_size) = root_cube(&bounds, options.margin)?;
        options.check()?;
        let measures = source
            .surface_measures()
            .unwrap_or_else(|| SurfaceMeasures::of_box(bounds.size()));
        Ok(estimate_cells(measures, root_size, options))
    }
}

/// The level-by-level count of the module docs.
pub(crate) fn estimate_cells(measures: SurfaceMeasures, root_size: f64, options: &AdfOptions) -> BuildEstimate {
    let allowed = options.tolerance * TEST_MARGIN;
    let sqrt3 = 3f64.sqrt();
    // f32 rounding of corners within a non-pruned cell's reach (≤ 2√3 h + band).
    let rounding = |h: f64| f64::from(f32::EPSILON) * (2.0 * sqrt3 * h + options.band);
    let curvature_limit = measures.curvature / (CURVATURE_CELLS * allowed);
    let mut cells = 1.0f64;
    let mut evaluations = 8.0f64;
    let mut deepest_split = 0u8;
    let mut level_cells = 1.0f64; // 8^k
    for depth in 0..options.max_depth {
        let h = root_size / (1u64 << depth) as f64;
        if 0.5 * sqrt3 * h + rounding(h) <= allowed {
            break;
        }
        let shell = (2.0 * (sqrt3 * h + options.band) + 1.5 * h) * measures.area / (h * h * h);
        let split = level_cells.min(shell).min(curvature_limit).max(1.0);
        cells += 8.0 * split;
        evaluations += EVALUATIONS_PER_SPLIT * split;
        deepest_split = depth;
        level_cells *= 8.0;
    }
    let cells = saturating_u64(cells);
    BuildEstimate {
        cells,
        tree_bytes: cells.saturating_mul(std::mem::size_of::<Cell>() as u64),
        build_bytes: cells.saturating_mul(BUILD_BYTES_PER_CELL),
        evaluations: saturating_u64(evaluations),
        deepest_split,
        root_size,
    }
}

/// A sphere's measures, for tests.
#[cfg(test)]
pub(crate) fn sphere_measures(radius: f64) -> SurfaceMeasures {
    SurfaceMeasures {
        area: 4.0 * std::f64::consts::PI * radius * radius,
        curvature: 4.0 * std::f64::consts::PI * radius,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn options(tolerance: f64, max_depth: u8) -> AdfOptions {
        AdfOptions {
            tolerance,
            max_depth,
            ..AdfOptions::default()
        }
    }

    #[test]
    fn no_split_below_the_lipschitz_depth() {
        // Root 1, tolerance 0.01 (0.005 at the test points): √3/2 · h ≤ 0.005 from
        // h = 1/256 (level 8) on, so level 7 is the deepest that can split.
        let e = estimate_cells(sphere_measures(0.4), 1.0, &options(0.01, 24));
        assert_eq!(e.deepest_split, 7);
        let shallow = estimate_cells(sphere_measures(0.4), 1.0, &options(0.01, 5));
        assert_eq!(shallow.deepest_split, 4);
        assert!(shallow.cells < e.cells);
    }

    #[test]
    fn finer_tolerance_more_cells_and_saturation_at_the_depth_limit() {
        let m = sphere_measures(0.4);
        let coarse = estimate_cells(m, 1.0, &options(1e-3, 12));
        let fine = estimate_cells(m, 1.0, &options(1e-4, 12));
        assert!(fine.cells > 5 * coarse.cells, "{coarse:?} {fine:?}");
        // At 1e-12 the depth limit decides: every near-surface cell of levels 0..11.
        let finest = estimate_cells(m, 1.0, &options(1e-12, 12));
        let finer = estimate_cells(m, 1.0, &options(1e-15, 12));
        assert_eq!(finest.cells, finer.cells);
        assert!(finest.cells > 100 * fine.cells);
        assert_eq!(finest.build_bytes, finest.cells * BUILD_BYTES_PER_CELL);
    }

    #[test]
    fn box_measures() {
        let m = SurfaceMeasures::of_box(DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(m.area, 22.0);
        assert!((m.curvature - 6.0 * std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn overflow_saturates() {
        let e = estimate_cells(sphere_measures(1e6), 1.0, &options(1e-300, 24));
        assert!(e.cells > 1 << 60);
        assert_eq!(e.build_bytes, u64::MAX);
    }
}
