//! A fast exact point–triangle squared distance for the voxelizers' inner loops:
//! Ericson's Voronoi-region method ("Real-Time Collision Detection" §5.1.5) with the
//! per-triangle quantities precomputed once. Degenerate triangles fall back to the
//! segment distances (the region tests divide by zero there).

use glam::{DVec2, DVec3, IVec3};
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
    /// A sliver (`|ab × ac| < 1e-3 · longest²`): Ericson's barycentric cancellations lose
    /// the interior case there (a 1e-8 sliver gave 1 % errors), so the distance is the
    /// plane's inside the triangle (sign tests on edge cross products, which misjudge
    /// only within rounding of an edge, where both answers agree) and the edges' outside.
    thin: bool,
}

/// Edge of the bricks the voxelizers fill (voxels).
const BRICK_DIM: usize = volga_core::BRICK_DIM as usize;

/// Per voxel of one brick: the squared distance to the nearest triangle so far and
/// that triangle's index (`u32::MAX` for none).
#[derive(Clone)]
pub(crate) struct Nearest {
    pub(crate) d2: [f64; volga_core::BRICK_VOXELS],
    pub(crate) id: [u32; volga_core::BRICK_VOXELS],
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
        let thin = !degenerate && n.length_squared() < 1e-6 * scale * scale;
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
            thin,
        }
    }

    /// The nearest-triangle update along one column of an 8³ brick: for the `count`
    /// voxels from `start` along `axis` (voxel centres `origin + ijk·spacing`), keeps
    /// `(d², id)` in `best` where this triangle is strictly nearer. The bounding-box
    /// and plane lower bounds are split into a per-column constant and one term along
    /// the column, so most voxels are rejected in a few operations.
    #[inline]
    pub(crate) fn column_min(
        &self,
        t: &volga_core::Transform,
        start: IVec3,
        axis: usize,
        count: i32,
        best: &mut Nearest,
        id: u32,
    ) {
        let (origin, spacing) = (t.origin(), t.spacing());
        match axis {
            0 => self.column_min_along::<0>(origin, spacing, start, count, best, id),
            1 => self.column_min_along::<1>(origin, spacing, start, count, best, id),
            _ => self.column_min_along::<2>(origin, spacing, start, count, best, id),
        }
    }

    #[inline]
    fn column_min_along<const AXIS: usize>(
        &self,
        origin: DVec3,
        spacing: DVec3,
        start: IVec3,
        count: i32,
        best: &mut Nearest,
        id: u32,
    ) {
        let mut p = origin + start.as_dvec3() * spacing;
        // Per column: the bounding-box excess and the plane offset of the fixed axes.
        let outside = (self.lo - p).max(p - self.hi).max(DVec3::ZERO);
        let mut lateral = outside * outside;
        lateral[AXIS] = 0.0;
        let lateral = lateral.x + lateral.y + lateral.z;
        let mut fixed = self.unit_normal * p;
        fixed[AXIS] = 0.0;
        let plane_base = fixed.x + fixed.y + fixed.z - self.plane;
        let (n_axis, lo, hi) = (self.unit_normal[AXIS], self.lo[AXIS], self.hi[AXIS]);
        let (o_axis, h) = (origin[AXIS], spacing[AXIS]);
        let stride = [1usize, BRICK_DIM, BRICK_DIM * BRICK_DIM][AXIS];
        let mut o = volga_core::Brick::<f32>::local_offset(start);
        for k in 0..count {
            let q = o_axis + (start[AXIS] + k) as f64 * h;
            let limit = best.d2[o];
            let e = (lo - q).max(q - hi).max(0.0);
            if e * e + lateral < limit {
                let plane = n_axis * q + plane_base;
                if plane * plane < limit {
                    p[AXIS] = q;
                    let d2 = self.distance_squared(p);
                    if d2 < limit {
                        best.d2[o] = d2;
                        best.id[o] = id;
                    }
                }
            }
            o += stride;
        }
    }

    #[inline]
    pub(crate) fn distance_squared(&self, p: DVec3) -> f64 {
        let TriDistance { a, b, c, ab, ac, .. } = *self;
        if self.degenerate {
            return segment_d2(p, a, b).min(segment_d2(p, b, c)).min(segment_d2(p, c, a));
        }
        if self.thin {
            let n = self.unit_normal;
            let inside = ab.cross(p - a).dot(n) >= 0.0
                && (c - b).cross(p - b).dot(n) >= 0.0
                && (a - c).cross(p - c).dot(n) >= 0.0;
            if inside {
                let plane = n.dot(p - a);
                return plane * plane;
            }
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
}

/// `ceil(x)` as an integer for finite `x` well inside `i32` (callers clamp first):
/// without SSE4.1 `f64::ceil` is a libm call, and it sat on the hot path.
#[inline]
pub(crate) fn ceil_i32(x: f64) -> i32 {
    let i = x as i32;
    i + ((i as f64) < x) as i32
}

/// Calls `f(start, axis, count)` for the integers within `[lo, hi]` (finite, within `i32`)
/// along axis `d` of the column at `(cu, cw)` on axes `u`, `w` (`axes = [d, u, w]`).
#[inline]
pub(crate) fn emit_run(lo: f64, hi: f64, axes: [usize; 3], cu: i32, cw: i32, f: &mut impl FnMut(IVec3, usize, i32)) {
    let (z0, z1) = (ceil_i32(lo), floor_i32(hi));
    if z1 >= z0 {
        let [d, u, w] = axes;
        let mut start = IVec3::ZERO;
        start[d] = z0;
        start[u] = cu;
        start[w] = cw;
        f(start, d, z1 - z0 + 1);
    }
}

/// `floor(x)` as an integer, under the same conditions as [`ceil_i32`].
#[inline]
pub(crate) fn floor_i32(x: f64) -> i32 {
    let i = x as i32;
    i - ((i as f64) > x) as i32
}

/// One triangle's band, prepared once for rasterizing into many bricks: runs of voxels
/// along the normal's dominant axis that may lie within `band_index` (index units) of
/// the triangle given in index space. Columns are limited to the slab
/// |n̂·(v − a)| ≤ band and to the ball-shaped band around the triangle's extent, and
/// skipped when their 2D distance to the projected triangle exceeds the band
/// (projection never increases distances). A superset of the band (callers test the
/// distance), never missing a voxel of it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BandColumns {
    /// Voxels the band can reach (inclusive), before clipping to a region.
    lo: IVec3,
    hi: IVec3,
    /// Column axis and the two lateral axes.
    d: usize,
    u: usize,
    w: usize,
    /// Whole columns of the box (degenerate or nearly edge-on triangles).
    whole: bool,
    /// Exact 2D triangle distance for the lateral test (large triangles); small ones
    /// use the distance to the projected bounding rectangle, nearly as tight.
    exact_lateral: bool,
    band2: f64,
    /// Slab along the column: `v_d ∈ (c_lo − r, c_hi − r)·inv_nd`, `r = n_u v_u + n_w v_w`.
    n_u: f64,
    n_w: f64,
    c_lo: f64,
    c_hi: f64,
    inv_nd: f64,
    /// The triangle's extent along the column axis.
    tri_lo_d: f64,
    tri_hi_d: f64,
    /// The triangle projected on the lateral plane, and its bounding rectangle.
    pa: DVec2,
    pb: DVec2,
    pc: DVec2,
    rect_lo: DVec2,
    rect_hi: DVec2,
}

impl BandColumns {
    pub(crate) fn new(tri_index: [DVec3; 3], band_index: f64) -> Self {
        let [a, b, c] = tri_index;
        let clip = |v: DVec3| v.clamp(DVec3::splat(-4.0e8), DVec3::splat(4.0e8));
        let lo = clip((a.min(b).min(c)) - band_index).ceil().as_ivec3();
        let hi = clip((a.max(b).max(c)) + band_index).floor().as_ivec3();
        let n = (b - a).cross(c - a);
        let len = n.length();
        let d = crate::binary::dominant_axis(n);
        let (u, w) = ((d + 1) % 3, (d + 2) % 3);
        // Degenerate, nearly edge-on, or not finite: whole columns of the box.
        let whole = !(len > 0.0 && n.abs()[d] >= 1e-3 * len && len.is_finite());
        let project = |p: DVec3| DVec2::new(p[u], p[w]);
        let (pa, pb, pc) = (project(a), project(b), project(c));
        let (rect_lo, rect_hi) = (pa.min(pb).min(pc), pa.max(pb).max(pc));
        let (slack, na_dot) = (band_index * len, n.dot(a));
        let (c_lo, c_hi) = if n[d] > 0.0 {
            (na_dot - slack, na_dot + slack)
        } else {
            (na_dot + slack, na_dot - slack)
        };
        BandColumns {
            lo,
            hi,
            d,
            u,
            w,
            whole,
            exact_lateral: (rect_hi - rect_lo).max_element() > 1.0,
            band2: band_index * band_index,
            n_u: n[u],
            n_w: n[w],
            c_lo,
            c_hi,
            inv_nd: 1.0 / n[d],
            tri_lo_d: a[d].min(b[d]).min(c[d]),
            tri_hi_d: a[d].max(b[d]).max(c[d]),
            pa,
            pb,
            pc,
            rect_lo,
            rect_hi,
        }
    }

    /// Calls `f(first_ijk, axis, count)` for the runs of `region` that may lie in the band.
    #[inline]
    pub(crate) fn for_each(&self, region: &IndexBox, mut f: impl FnMut(IVec3, usize, i32)) {
        let (lo, hi) = (self.lo.max(region.min), self.hi.min(region.max - IVec3::ONE));
        if lo.cmpgt(hi).any() {
            return;
        }
        let (d, u, w) = (self.d, self.u, self.w);
        if self.whole {
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
        let (lo_d, hi_d) = (lo[d] as f64, hi[d] as f64);
        for cu in lo[u]..=hi[u] {
            let qu = cu as f64;
            let du = (self.rect_lo.x - qu).max(qu - self.rect_hi.x).max(0.0);
            for cw in lo[w]..=hi[w] {
                let qw = cw as f64;
                let dw = (self.rect_lo.y - qw).max(qw - self.rect_hi.y).max(0.0);
                let mut lateral2 = du * du + dw * dw;
                if lateral2 > self.band2 {
                    continue;
                }
                if self.exact_lateral {
                    lateral2 = triangle_distance_squared_2d(DVec2::new(qu, qw), self.pa, self.pb, self.pc);
                    if lateral2 > self.band2 {
                        continue;
                    }
                }
                // A voxel at lateral distance L lies within the band only if its offset
                // along the column from the triangle's extent is at most √(band² − L²):
                // the candidates of a column shrink to the ball-shaped band.
                let reach = (self.band2 - lateral2).sqrt();
                let r = self.n_u * qu + self.n_w * qw;
                let z0 = ((self.c_lo - r) * self.inv_nd).max(self.tri_lo_d - reach).max(lo_d);
                let z1 = ((self.c_hi - r) * self.inv_nd).min(self.tri_hi_d + reach).min(hi_d);
                if z1 >= z0 {
                    emit_run(z0, z1, [d, u, w], cu, cw, &mut f);
                }
            }
        }
    }
}

/// Squared distance from `q` to the filled 2D triangle `abc` (0 inside).
#[inline]
fn triangle_distance_squared_2d(q: DVec2, a: DVec2, b: DVec2, c: DVec2) -> f64 {
    let cross = |o: DVec2, p: DVec2, r: DVec2| (p - o).perp_dot(r - o);
    let (s0, s1, s2) = (cross(a, b, q), cross(b, c, q), cross(c, a, q));
    if (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0) {
        return 0.0;
    }
    let seg = |p: DVec2, r: DVec2| {
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
