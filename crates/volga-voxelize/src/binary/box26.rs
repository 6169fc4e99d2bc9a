//! The binary rule specialised to 26-separability for non-degenerate triangles: the
//! same decisions as the reference test, with the edge axes evaluated lane-wise and
//! small triangles tested voxel by voxel.

use glam::{DVec3, IVec3};
use volga_core::IndexBox;

use super::raster::VoxelSink;
use super::separating::Axis;
use super::{canonical, dominant_axis, lower, plane_window, upper, upper_f, voxel_range, Separability};
use crate::tri_distance::ceil_i32;

/// The three edge axes `e_m × x̂_k` of one `k` (lane `m`), which have a zero component
/// `k`: voxel `v` passes axis `m` when `lo_m ≤ ci_m·v_i + cj_m·v_j ≤ hi_m`, with `i < j`
/// the two other components. An axis that is zero (an edge along `x̂_k`) has
/// `lo = hi = 0` and passes every finite voxel, as the general path skips it.
#[derive(Debug, Clone, Copy)]
struct EdgeAxes {
    ci: DVec3,
    cj: DVec3,
    lo: DVec3,
    hi: DVec3,
}

impl EdgeAxes {
    #[inline(always)]
    fn pass(&self, vi: f64, vj: f64) -> bool {
        let s = self.ci * vi + self.cj * vj;
        (self.lo.cmple(s) & s.cmple(self.hi)).all()
    }
}

/// A sink that only reports voxels (it never skips any).
#[cfg(test)]
struct Report<F>(F);

#[cfg(test)]
impl<F: FnMut(IVec3)> VoxelSink for Report<F> {
    #[inline]
    fn is_set(&self, _: IVec3) -> bool {
        false
    }

    #[inline]
    fn set(&mut self, ijk: IVec3) {
        (self.0)(ijk)
    }
}

/// [`PreparedTriangle`] specialised to 26-separability (`K_26` is the unit cube, the
/// classic conservative box test) for non-degenerate triangles. It makes exactly the
/// same decisions: the edge axes `e × x̂_k` have a zero component `k`, and every
/// value here is computed as the general path's dot product with that zero term
/// dropped (adding ±0 changes nothing), in the same order.
///
/// Most triangles of a mesh at coarse resolutions are smaller than a voxel (the
/// bunny at N = 128: 69K triangles for 56K voxels), so the fixed cost per triangle
/// matters more than the cost per voxel. Three shortcuts, none of which changes a
/// decision:
/// - For a triangle whose voxel range holds at most [`SMALL_RANGE`] voxels, the range
///   is tested voxel by voxel instead of column by column, and the nine edge axes are
///   computed only when a voxel first needs them (at N = 128 on the bunny, 45% of the
///   triangles never do). A voxel already black (set by an earlier triangle of the
///   chunk) is not tested again.
/// - Larger triangles are scanned by columns along the normal's dominant axis, and a
///   column's run of voxels in the plane's slab is found by the slab test itself at
///   its two ends, so no voxel outside the slab is tested (a rounded estimate with a
///   one-voxel margin would test about four more voxels per column, where the slab
///   holds one to three).
///
/// (A third was measured and dropped: accepting a voxel whose box holds a vertex of
/// the triangle without its edge axes. It is exact, but testing the vertices cost more
/// instructions than the axes it saved.)
///
/// [`PreparedTriangle`]: super::separating::PreparedTriangle
#[derive(Debug, Clone)]
pub(super) struct Prepared26 {
    tri: [DVec3; 3],
    /// The widening unit, 64 ulp of the largest coordinate (see
    /// [`PreparedTriangle::new`](super::separating::PreparedTriangle::new)).
    unit: f64,
    plane: Axis,
    /// Voxel range, which decides the cube's three face axes: an integer `v` has
    /// `v ≥ ⌈fl(fl(lo − ½) − ε)⌉` exactly when `v ≥ fl(fl(lo − ½) − ε)`, the general
    /// path's face bound (and likewise above); [`voxel_range`] computes that bound. The clamp of
    /// [`round_clamped`](super::round_clamped) at ±2²⁹ only moves bounds outside every
    /// region rasterized here (this path's grids are at most 2²⁴ voxels a side).
    min: IVec3,
    max: IVec3,
}

/// Voxel ranges up to this many voxels take [`Prepared26::test_range`].
const SMALL_RANGE: i64 = 12;

impl Prepared26 {
    /// `None` for a degenerate triangle (the general path handles it).
    #[inline]
    pub(super) fn new(tri: [DVec3; 3]) -> Option<Self> {
        let [a, b, c] = tri;
        let n = (b - a).cross(c - a);
        if n == DVec3::ZERO {
            return None;
        }
        let m = upper(upper(a.abs(), b.abs()), c.abs());
        let scale = upper_f(upper_f(m.x, m.y), m.z) + 1.0;
        let unit = 64.0 * f64::EPSILON * scale;
        let n = canonical(n);
        let h = Separability::TwentySix.support(n);
        let eps_n = unit * (n.x.abs() + n.y.abs() + n.z.abs());
        let (lo, hi) = plane_window(tri, n, h, eps_n);
        let (min, max) = voxel_range(a, b, c);
        Some(Prepared26 {
            tri,
            unit,
            plane: Axis { dir: n, lo, hi },
            min,
            max,
        })
    }

    /// The nine edge axes, `[k]` for the axes `e_m × x̂_k`. Each lane computes what the
    /// general path computes for that axis (the projections `a·(e × x̂_k)` with the zero
    /// term dropped, their extremes, the support `½‖·‖₁` and ε), without branches.
    #[inline]
    fn edge_axes(&self) -> [EdgeAxes; 3] {
        let [a, b, c] = self.tri;
        let unit = self.unit;
        let [e0, e1, e2] = [b - a, c - b, a - c];
        let axes = |ci: DVec3, cj: DVec3, i: usize, j: usize| {
            let (pa, pb, pc) = (ci * a[i] + cj * a[j], ci * b[i] + cj * b[j], ci * c[i] + cj * c[j]);
            let l1 = ci.abs() + cj.abs();
            let (h, eps) = (0.5 * l1, unit * l1);
            EdgeAxes {
                ci,
                cj,
                lo: lower(lower(pa, pb), pc) - h - eps,
                hi: upper(upper(pa, pb), pc) + h + eps,
            }
        };
        let ex = DVec3::new(e0.x, e1.x, e2.x);
        let ey = DVec3::new(e0.y, e1.y, e2.y);
        let ez = DVec3::new(e0.z, e1.z, e2.z);
        [axes(ez, -ey, 1, 2), axes(-ez, ex, 0, 2), axes(ey, -ex, 0, 1)]
    }

    /// Calls `f` for every voxel of `region` that passes.
    #[cfg(test)]
    fn for_each_voxel(&self, region: &IndexBox, f: impl FnMut(IVec3)) {
        self.rasterize(region, &mut Report(f));
    }

    /// Sets every voxel of `region` that passes and is not set yet.
    #[inline]
    pub(super) fn rasterize(&self, region: &IndexBox, sink: &mut impl VoxelSink) {
        let lo = self.min.max(region.min);
        let hi = self.max.min(region.max - IVec3::ONE);
        if lo.cmpgt(hi).any() {
            return;
        }
        let size = (hi - lo + IVec3::ONE).as_i64vec3();
        if size.x * size.y * size.z <= SMALL_RANGE {
            return self.test_range(lo, hi, sink);
        }
        match dominant_axis(self.plane.dir) {
            0 => self.scan::<0>(lo, hi, sink),
            1 => self.scan::<1>(lo, hi, sink),
            _ => self.scan::<2>(lo, hi, sink),
        }
    }

    /// Every voxel of the inclusive range `lo..=hi`, edge axes computed on demand.
    #[inline]
    fn test_range(&self, lo: IVec3, hi: IVec3, sink: &mut impl VoxelSink) {
        let plane = &self.plane;
        let n = plane.dir;
        let mut edge: Option<[EdgeAxes; 3]> = None;
        for z in lo.z..hi.z + 1 {
            for y in lo.y..hi.y + 1 {
                for x in lo.x..hi.x + 1 {
                    let ijk = IVec3::new(x, y, z);
                    if sink.is_set(ijk) {
                        continue;
                    }
                    let v = ijk.as_dvec3();
                    // n·v in glam's order: (x·x' + y·y') + z·z'.
                    let s = n.x * v.x + n.y * v.y + n.z * v.z;
                    if !(plane.lo <= s && s < plane.hi) {
                        continue;
                    }
                    let e = edge.get_or_insert_with(|| self.edge_axes());
                    let passes = e[0].pass(v.y, v.z) && e[1].pass(v.x, v.z) && e[2].pass(v.x, v.y);
                    if passes {
                        sink.set(ijk);
                    }
                }
            }
        }
    }

    /// The inclusive range `lo..=hi` by columns along the normal's dominant axis `D`
    /// (known at compile time), so the work is proportional to the triangle's area.
    #[inline]
    fn scan<const D: usize>(&self, lo: IVec3, hi: IVec3, sink: &mut impl VoxelSink) {
        let (u, w) = ((D + 1) % 3, (D + 2) % 3);
        let plane = &self.plane;
        let n = plane.dir.to_array();
        let inv_nd = 1.0 / n[D]; // only a first guess of the run's ends
        let edge = self.edge_axes();
        // Each axis `e × x̂_k` reads the two components other than k, in increasing order.
        let pass = |k: usize, v: &[f64; 3]| match k {
            0 => edge[0].pass(v[1], v[2]),
            1 => edge[1].pass(v[0], v[2]),
            _ => edge[2].pass(v[0], v[1]),
        };
        let (lo_d, hi_d) = (lo[D] as f64, hi[D] as f64);
        // Exclusive ranges: `RangeInclusive` carries an exhaustion flag through every step.
        for cu in lo[u]..hi[u] + 1 {
            let vu = cu as f64;
            for cw in lo[w]..hi[w] + 1 {
                let vw = cw as f64;
                let mut v = [0.0; 3];
                v[u] = vu;
                v[w] = vw;
                if !pass(D, &v) {
                    continue;
                }
                // The slab test `lo ≤ s < hi` along the column: `s` (computed exactly as
                // everywhere else) never decreases as `v[D]` grows (`n[D] > 0`, and
                // rounded sums and products are monotonic), so the voxels in the slab
                // are one run. Its ends are found from the rounded estimate by the test
                // itself, so only the run's voxels (and one on each side) are tested.
                let s_at = |cd: i32, v: &mut [f64; 3]| {
                    v[D] = cd as f64;
                    // n·v in glam's order: (x·x' + y·y') + z·z'.
                    n[0] * v[0] + n[1] * v[1] + n[2] * v[2]
                };
                let r = n[u] * vu + n[w] * vw;
                let (lo_c, hi_c) = (lo[D], hi[D] + 1);
                let clamp = |x: f64| ceil_i32(x.max(lo_d).min(hi_d + 1.0));
                // First voxel with s ≥ lo, then first with s ≥ hi (exclusive end).
                let mut start = clamp((plane.lo - r) * inv_nd);
                while start > lo_c && s_at(start - 1, &mut v) >= plane.lo {
                    start -= 1;
                }
                while start < hi_c && s_at(start, &mut v) < plane.lo {
                    start += 1;
                }
                let mut end = clamp((plane.hi - r) * inv_nd).max(start);
                while end > start && s_at(end - 1, &mut v) >= plane.hi {
                    end -= 1;
                }
                while end < hi_c && s_at(end, &mut v) < plane.hi {
                    end += 1;
                }
                for cd in start..end {
                    let mut ijk = IVec3::ZERO;
                    ijk[D] = cd;
                    ijk[u] = cu;
                    ijk[w] = cw;
                    v[D] = cd as f64;
                    if pass(u, &v) && pass(w, &v) {
                        sink.set(ijk);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::separating::PreparedTriangle;
    use super::*;

    proptest::proptest! {
        /// The 26-separating fast path decides exactly like the general one, on random
        /// triangles (voxel-sized and sub-voxel) and on dyadic ones with vertices on
        /// voxel centres, faces and quarter points.
        #[test]
        fn fast_26_path_matches_the_general_test(
            raw in proptest::collection::vec((-6.0f64..6.0, -6.0f64..6.0, -6.0f64..6.0), 3),
            dyadic in proptest::bool::ANY,
            offset in proptest::prop_oneof![proptest::strategy::Just(0.0), proptest::strategy::Just(1e6)],
            size in proptest::prop_oneof![proptest::strategy::Just(1.0), proptest::strategy::Just(0.125)],
        ) {
            // Size 1/8: sub-voxel triangles, which take the small-range path.
            let tri = [0, 1, 2].map(|k| {
                let p = DVec3::new(raw[k].0, raw[k].1, raw[k].2) * size;
                let p = if dyadic { (p * 4.0).round() * 0.25 } else { p };
                p + offset
            });
            let Some(fast) = Prepared26::new(tri) else { return Ok(()) };
            let general = PreparedTriangle::new(tri, Separability::TwentySix);
            let region = IndexBox::new(general.min - 1, general.max + 2);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            fast.for_each_voxel(&region, |v| a.push(v));
            for v in region.iter() {
                if general.contains(v.as_dvec3()) {
                    b.push(v);
                }
            }
            a.sort_unstable_by_key(|v| (v.z, v.y, v.x));
            b.sort_unstable_by_key(|v| (v.z, v.y, v.x));
            proptest::prop_assert!(!b.is_empty());
            proptest::prop_assert_eq!(a, b);
        }
    }
}
