//! A fast exact point–triangle squared distance for the voxelizers' inner loops:
//! Ericson's Voronoi-region method ("Real-Time Collision Detection" §5.1.5) with the
//! per-triangle quantities precomputed once. Degenerate triangles fall back to the
//! segment distances (the region tests divide by zero there).

use glam::{DVec3, IVec3};
use volga_core::IndexBox;

#[derive(Debug, Clone, Copy)]
pub(crate) struct TriDistance {
    a: DVec3,
    b: DVec3,
    c: DVec3,
    ab: DVec3,
    ac: DVec3,
    /// Unit normal (zero when degenerate) and `n̂·a`.
    unit_normal: DVec3,
    plane: f64,
    /// Bounding box, for a second lower bound.
    lo: DVec3,
    hi: DVec3,
    degenerate: bool,
}

#[inline]
fn segment_d2(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l = ab.length_squared();
    let t = if l > 0.0 {
        ((p - a).dot(ab) / l).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).length_squared()
}

impl TriDistance {
    pub(crate) fn new([a, b, c]: [DVec3; 3]) -> Self {
        let (ab, ac) = (b - a, c - a);
        let n = ab.cross(ac);
        // Relative area test: slivers thinner than ~1e-12 of their size use segments.
        let scale = ab
            .length_squared()
            .max(ac.length_squared())
            .max((c - b).length_squared());
        // NaN-safe: a NaN area counts as degenerate.
        let degenerate = n.length_squared().partial_cmp(&(1e-24 * scale * scale)) != Some(std::cmp::Ordering::Greater);
        let unit_normal = if degenerate { DVec3::ZERO } else { n.normalize() };
        TriDistance {
            a,
            b,
            c,
            ab,
            ac,
            unit_normal,
            plane: unit_normal.dot(a),
            lo: a.min(b).min(c),
            hi: a.max(b).max(c),
            degenerate,
        }
    }

    /// Squared distance if it is below `best`, else `None`. Two cheap lower bounds reject
    /// most losers first: the distance to the triangle's bounding box (neighbours on a
    /// smooth surface are nearly coplanar, so the plane alone rarely rejects them) and
    /// the distance to its plane.
    #[inline]
    pub(crate) fn distance_squared_below(&self, p: DVec3, best: f64) -> Option<f64> {
        let outside = (self.lo - p).max(p - self.hi).max(DVec3::ZERO);
        if outside.length_squared() >= best {
            return None;
        }
        let h = self.unit_normal.dot(p) - self.plane;
        if h * h >= best {
            return None;
        }
        let d2 = self.distance_squared(p);
        (d2 < best).then_some(d2)
    }

    #[inline]
    pub(crate) fn distance_squared(&self, p: DVec3) -> f64 {
        let TriDistance { a, b, c, ab, ac, .. } = *self;
        if self.degenerate {
            return segment_d2(p, a, b).min(segment_d2(p, b, c)).min(segment_d2(p, c, a));
        }
        let ap = p - a;
        let d1 = ab.dot(ap);
        let d2 = ac.dot(ap);
        if d1 <= 0.0 && d2 <= 0.0 {
            return ap.length_squared();
        }
        let bp = p - b;
        let d3 = ab.dot(bp);
        let d4 = ac.dot(bp);
        if d3 >= 0.0 && d4 <= d3 {
            return bp.length_squared();
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            return (ap - ab * v).length_squared();
        }
        let cp = p - c;
        let d5 = ab.dot(cp);
        let d6 = ac.dot(cp);
        if d6 >= 0.0 && d5 <= d6 {
            return cp.length_squared();
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            return (ap - ac * w).length_squared();
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            return (bp - (c - b) * w).length_squared();
        }
        let denom = 1.0 / (va + vb + vc);
        let v = vb * denom;
        let w = vc * denom;
        (ap - ab * v - ac * w).length_squared()
    }

    /// Calls `f(first_ijk, axis, count)` for runs of voxels of `region` along `axis`
    /// that may lie within `band_index` (index units) of the triangle given in index
    /// space: columns along the normal's dominant axis, limited to the slab
    /// |n̂·(v − a)| ≤ band and skipped when their 2D distance to the projected triangle
    /// exceeds the band (projection never increases distances). A superset of the band
    /// (callers test the distance), never missing a voxel of it.
    pub(crate) fn for_each_column(
        tri_index: [DVec3; 3],
        band_index: f64,
        region: &IndexBox,
        mut f: impl FnMut(IVec3, usize, i32),
    ) {
        let [a, b, c] = tri_index;
        let lo = ((a.min(b).min(c)) - band_index).ceil();
        let hi = ((a.max(b).max(c)) + band_index).floor();
        let clip = |v: DVec3| v.clamp(DVec3::splat(-4.0e8), DVec3::splat(4.0e8)).as_ivec3();
        let (lo, hi) = (clip(lo).max(region.min), clip(hi).min(region.max - IVec3::ONE));
        if lo.cmpgt(hi).any() {
            return;
        }
        let n = (b - a).cross(c - a);
        let len = n.length();
        let na = n.abs();
        let d = crate::binary::dominant_axis(n);
        let (u, w) = ((d + 1) % 3, (d + 2) % 3);
        if len.is_nan() || len <= 0.0 || na[d] < 1e-3 * len {
            // Degenerate or nearly edge-on: whole columns of the box.
            for cu in lo[u]..=hi[u] {
                for cw in lo[w]..=hi[w] {
                    let mut start = IVec3::ZERO;
                    start[d] = lo[d];
                    start[u] = cu;
                    start[w] = cw;
                    f(start, d, hi[d] - lo[d] + 1);
                }
            }
            return;
        }
        // |n̂·(v − a)| ≤ band  ⇔  n_d v_d ∈ n·a − r ± band·|n|, r = n_u v_u + n_w v_w.
        let slack = band_index * len;
        let na_dot = n.dot(a);
        let project = |p: DVec3| glam::DVec2::new(p[u], p[w]);
        let (pa, pb, pc) = (project(a), project(b), project(c));
        let band2 = band_index * band_index;
        // The triangle's extent along the column axis.
        let (tri_lo_d, tri_hi_d) = (a[d].min(b[d]).min(c[d]), a[d].max(b[d]).max(c[d]));
        for cu in lo[u]..=hi[u] {
            for cw in lo[w]..=hi[w] {
                let q = glam::DVec2::new(cu as f64, cw as f64);
                let lateral2 = triangle_distance_squared_2d(q, pa, pb, pc);
                if lateral2 > band2 {
                    continue;
                }
                // A voxel at lateral distance L lies within the band only if its offset
                // along the column from the triangle's extent is at most √(band² − L²):
                // the candidates of a column shrink to the ball-shaped band.
                let reach = (band2 - lateral2).sqrt();
                let r = n[u] * cu as f64 + n[w] * cw as f64;
                let (fa, fb) = ((na_dot - r - slack) / n[d], (na_dot - r + slack) / n[d]);
                let z0 = fa.min(fb).max(tri_lo_d - reach).ceil().max(lo[d] as f64) as i32;
                let z1 = fa.max(fb).min(tri_hi_d + reach).floor().min(hi[d] as f64) as i32;
                if z1 >= z0 {
                    let mut start = IVec3::ZERO;
                    start[d] = z0;
                    start[u] = cu;
                    start[w] = cw;
                    f(start, d, z1 - z0 + 1);
                }
            }
        }
    }
}

/// Squared distance from `q` to the filled 2D triangle `abc` (0 inside).
#[inline]
fn triangle_distance_squared_2d(q: glam::DVec2, a: glam::DVec2, b: glam::DVec2, c: glam::DVec2) -> f64 {
    let cross = |o: glam::DVec2, p: glam::DVec2, r: glam::DVec2| (p - o).perp_dot(r - o);
    let (s0, s1, s2) = (cross(a, b, q), cross(b, c, q), cross(c, a, q));
    if (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0) {
        return 0.0;
    }
    let seg = |p: glam::DVec2, r: glam::DVec2| {
        let pr = r - p;
        let l = pr.length_squared();
        let t = if l > 0.0 {
            ((q - p).dot(pr) / l).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (q - (p + pr * t)).length_squared()
    };
    seg(a, b).min(seg(b, c)).min(seg(c, a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn matches_the_reference_closest_point(
            t in prop::collection::vec((-3.0f64..3.0, -3.0f64..3.0, -3.0f64..3.0), 3),
            p in (-5.0f64..5.0, -5.0f64..5.0, -5.0f64..5.0),
            degenerate in 0usize..3,
        ) {
            let mut tri = [0, 1, 2].map(|i| DVec3::new(t[i].0, t[i].1, t[i].2));
            match degenerate {
                1 => tri[2] = tri[0],
                2 => tri[2] = (tri[0] + tri[1]) * 0.5,
                _ => {}
            }
            let p = DVec3::new(p.0, p.1, p.2);
            let ours = TriDistance::new(tri).distance_squared(p);
            let reference = volga_mesh::point_triangle_distance_squared(p, tri);
            prop_assert!((ours - reference).abs() <= 1e-9 * (1.0 + reference), "{} vs {}", ours, reference);
        }
    }
}
