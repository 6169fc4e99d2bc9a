//! Accuracy of an ADF against its source at random points near the surface.

use glam::DVec3;
use rayon::prelude::*;
use volga_core::Aabb;

use crate::{Adf, DistanceSource};

/// Errors of an ADF against an exact source ([`measure_errors`]), in world units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    /// Points measured.
    pub points: usize,
    /// Largest `|reconstruction − exact|` over every point.
    pub max: f64,
    /// Root mean square of `reconstruction − exact` over every point.
    pub rms: f64,
    /// Largest error over points whose leaf is below the maximum depth (where the
    /// tolerance applies; maximum-depth leaves hold the distance's creases and a hole's
    /// rim).
    pub max_below_max_depth: f64,
    /// Points in maximum-depth leaves.
    pub points_at_max_depth: usize,
    /// Candidates within the band that fell in pruned leaves (not measured: the tolerance
    /// does not hold there; build with `AdfOptions::band` to have none).
    pub points_pruned: usize,
    /// Points whose reconstructed sign differs from the source's.
    pub sign_differences: usize,
}

/// One measured point ([`measure_errors_with_probes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// The point (world space).
    pub world_pos: DVec3,
    /// The source's signed distance (world units, negative inside).
    pub exact: f64,
    /// The ADF's reconstruction there.
    pub reconstructed: f64,
    /// Whether the point lies in a maximum-depth leaf.
    pub at_max_depth: bool,
}

/// The i-th point of the 3D R-sequence in the unit cube (low-discrepancy, deterministic).
fn r3(i: u64) -> DVec3 {
    const G: f64 = 1.220_744_084_605_759_5; // plastic constant in 3D
    let a = DVec3::new(1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G));
    (DVec3::splat(0.5) + a * (i as f64 + 1.0)).fract()
}

/// Measures `adf` against `source` at `count` points of `region` whose exact distance is
/// within `band` of the surface and whose leaf is not pruned (low-discrepancy points, rejected outside the band; at
/// most 200 candidates per kept point), in parallel and deterministically.
pub fn measure_errors<S: DistanceSource + ?Sized>(
    adf: &Adf,
    source: &S,
    region: &Aabb,
    band: f64,
    count: usize,
) -> ErrorStats {
    measure(adf, source, region, band, count, None)
}

/// [`measure_errors`], also returning every measured point (for comparisons with other
/// tools at the same points: `volga bench adf --probes-out`).
pub fn measure_errors_with_probes<S: DistanceSource + ?Sized>(
    adf: &Adf,
    source: &S,
    region: &Aabb,
    band: f64,
    count: usize,
) -> (ErrorStats, Vec<Probe>) {
    let mut probes = Vec::with_capacity(count);
    let stats = measure(adf, source, region, band, count, Some(&mut probes));
    (stats, probes)
}

fn measure<S: DistanceSource + ?Sized>(
    adf: &Adf,
    source: &S,
    region: &Aabb,
    band: f64,
    count: usize,
    mut probes: Option<&mut Vec<Probe>>,
) -> ErrorStats {
    let mut stats = ErrorStats::default();
    let mut sum = 0.0;
    let mut next = 0u64;
    let limit = count as u64 * 200;
    while stats.points < count && next < limit {
        let chunk: Vec<u64> = (next..(next + 4096).min(limit)).collect();
        next += chunk.len() as u64;
        let measured: Vec<Option<(Probe, bool, bool)>> = chunk
            .par_iter()
            .map(|&i| {
                let p = region.min + r3(i) * region.size();
                let exact = source.distance(p);
                if exact.abs() > band {
                    return None;
                }
                let got = adf.distance(p);
                let leaf = adf.leaf_at(p);
                let probe = Probe {
                    world_pos: p,
                    exact,
                    reconstructed: got,
                    at_max_depth: leaf.depth >= adf.options.max_depth,
                };
                Some((probe, (got <= 0.0) != (exact <= 0.0), leaf.pruned))
            })
            .collect();
        for (probe, sign, pruned) in measured.into_iter().flatten() {
            let (err, at_max) = ((probe.reconstructed - probe.exact).abs(), probe.at_max_depth);
            if pruned {
                stats.points_pruned += 1;
                continue;
            }
            if stats.points == count {
                break;
            }
            stats.points += 1;
            stats.max = stats.max.max(err);
            sum += err * err;
            if at_max {
                stats.points_at_max_depth += 1;
            } else {
                stats.max_below_max_depth = stats.max_below_max_depth.max(err);
            }
            stats.sign_differences += sign as usize;
            if let Some(p) = probes.as_deref_mut() {
                p.push(probe);
            }
        }
    }
    stats.rms = (sum / stats.points.max(1) as f64).sqrt();
    stats
}
