//! Binary surface voxelization of triangles with a chosen separability (survey §17.2–17.3).
//!
//! ## The rule
//! Work in **index space** (voxel `ijk` is the unit cube centred on the integer point).
//! For separability `N`, let `K_N` be the convex hull of the half-steps `±o/2` of the
//! `N`-neighbourhood: the octahedron `|x|+|y|+|z| ≤ ½` for 6, the cuboctahedron for 18,
//! the cube `[−½, ½]³` for 26. A voxel `v` is black when the triangle `T` meets `v + K_N`.
//!
//! *Why it separates.* If two white `N`-adjacent voxels `v`, `v + o` had a connecting
//! segment crossing `T` at `q = v + λo`, then `q ∈ v + K_N` (λ ≤ ½) or `q ∈ v + o + K_N`
//! (λ ≥ ½), since `K_N` contains `±o/2`; so one of them would be black. Hence no
//! `N`-path of white voxels crosses the triangle, and a closed mesh voxelized this way is
//! `N`-separating (checked by flood fill in the tests).
//!
//! *The plane thresholds.* Inside the triangle, `T ∩ (v + K_N) ≠ ∅` reduces to
//! `|n̂·(v − a)| ≤ h_N(n̂)` with `h_N` the support function of `K_N`: `½‖n‖∞` (6),
//! half the sum of the two largest `|nᵢ|` (18), `½‖n‖₁` (26) — half the largest change
//! of `n̂·v` along one `N`-step, which is the largest step an `N`-path can take across the
//! plane. Near edges and vertices the same test is the exact Minkowski sum `T ⊕ K_N`,
//! which Huang, Yagel, Filippov & Kurzion (1998) approximate by edge cylinders and
//! vertex spheres of radius `max |K_N|` (the circumscribed ball); the exact sum is
//! contained in theirs, so it is never thicker and equally separating.
//!
//! *Rounding.* The arguments above assume exact arithmetic. Every closed interval is
//! widened by a relative ε (64 ulps of the coordinates' magnitude) and the half-open window
//! is shifted by −ε, so rounded near-ties err towards separating and covering; inputs on a
//! dyadic lattice never come within ε of a threshold and are decided exactly.
//!
//! *Ties.* A plane lying exactly on voxel faces touches two layers of closed
//! neighbourhoods. We use one half-open rule: orient the normal so its largest component
//! (lowest axis among equals) is positive, and keep `−h ≤ n·(v − a) < h`. An axis-aligned
//! plane through voxel centres or exactly on voxel faces then gives one layer. No tie rule
//! is invariant under reflections (the face plane `z = ½` must pick `z = 0` or `z = 1`), so
//! exact ties follow this orientation; everything else is symmetric under the grid's
//! symmetries, and all comparisons use the unnormalized normal so inputs on a dyadic
//! lattice are decided in exact arithmetic.
//!
//! *Minimality.* For a plane the slab `−h ≤ n·(v − a) < h` has width exactly the largest
//! `N`-step, so every voxel has white `N`-neighbours on both sides: removing any one opens
//! a tunnel, the slab is `N`-minimal. Where triangles meet at an angle the union of their
//! neighbourhoods can hold `N`-simple voxels, so a mesh is minimal only where it is flat;
//! the topology validator reports the simple voxels.
//!
//! Degenerate triangles (zero area) are handled by the same separating-axis test with the
//! normal axis dropped: a segment or a point is voxelized as the voxels whose
//! neighbourhood it meets.

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::{
    Adjacency, Brick, ChannelKind, Grid, IndexBox, Progress, Shape3, SparseVolume, BRICK_DIM, BRICK_VOXELS,
};

use crate::mask::BrickMask;
use crate::tri_distance::{ceil_i32, floor_i32};

/// Which white paths a voxelized surface must block (survey §17.2): the one
/// [`Adjacency`] type of `volga-core`, under the name the binary voxelizer has always
/// used (the CLI and tests name it so). The plane thresholds are
/// [`Adjacency::support`].
pub type Separability = Adjacency;

/// Face normals and edge directions of `K_N` (the hull of the half-steps of the
/// N-neighbourhood, see the module doc): the separating-axis candidates.
fn polytope(sep: Separability) -> (&'static [DVec3], &'static [DVec3]) {
    {
        const AXES: [DVec3; 3] = [DVec3::X, DVec3::Y, DVec3::Z];
        const DIAGONALS: [DVec3; 4] = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, 1.0, -1.0),
            DVec3::new(1.0, -1.0, 1.0),
            DVec3::new(-1.0, 1.0, 1.0),
        ];
        const AXES_AND_DIAGONALS: [DVec3; 7] = [
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, 1.0, -1.0),
            DVec3::new(1.0, -1.0, 1.0),
            DVec3::new(-1.0, 1.0, 1.0),
        ];
        const FACE_DIAGONALS: [DVec3; 6] = [
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, -1.0),
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(0.0, 1.0, -1.0),
        ];
        match sep {
            Separability::Six => (&DIAGONALS, &FACE_DIAGONALS),
            Separability::Eighteen => (&AXES_AND_DIAGONALS, &FACE_DIAGONALS),
            Separability::TwentySix => (&AXES, &AXES),
        }
    }
}

/// One separating axis with the triangle's projection widened by `K_N`'s support:
/// voxel `v` passes when `lo ≤ axis·v ≤ hi`.
#[derive(Debug, Clone, Copy)]
struct Axis {
    dir: DVec3,
    lo: f64,
    hi: f64,
}

/// A triangle in index space prepared for the voxel test.
#[derive(Debug, Clone)]
struct PreparedTriangle {
    /// At most 4 + 7 polytope faces + 6·3 edge crossings; `axis_count` are used.
    axes: [Axis; 26],
    axis_count: u8,
    /// Canonically oriented normal and its half-open slab `lo ≤ n·v < hi`, or `None` for
    /// a degenerate triangle.
    plane: Option<Axis>,
    /// Voxel range that can pass (bounding box grown by ½), inclusive.
    min: IVec3,
    max: IVec3,
}

impl PreparedTriangle {
    fn new(tri: [DVec3; 3], sep: Separability) -> Self {
        let [a, b, c] = tri;
        let edges = [b - a, c - b, a - c];
        // Rounding guard: the separation and cover arguments assume exact arithmetic. On
        // inputs that are not on a dyadic lattice (a non-dyadic grid origin, say) a near-tie
        // can be decided either way by rounding, so every closed interval is widened by a
        // relative ε, and the half-open normal window is shifted by −ε (one layer at face
        // ties still). Dyadic inputs never come within ε of a threshold, so for them the
        // decisions stay exact.
        let scale = a.abs().max(b.abs()).max(c.abs()).max_element() + 1.0;
        let eps_of = |dir: DVec3| 64.0 * f64::EPSILON * scale * (dir.x.abs() + dir.y.abs() + dir.z.abs());
        let mut axes = [Axis {
            dir: DVec3::ZERO,
            lo: 0.0,
            hi: 0.0,
        }; 26];
        let mut axis_count = 0usize;
        let mut push = |dir: DVec3| {
            if dir != DVec3::ZERO {
                let p = [dir.dot(a), dir.dot(b), dir.dot(c)];
                let h = sep.support(dir);
                let eps = eps_of(dir);
                axes[axis_count] = Axis {
                    dir,
                    lo: p[0].min(p[1]).min(p[2]) - h - eps,
                    hi: p[0].max(p[1]).max(p[2]) + h + eps,
                };
                axis_count += 1;
            }
        };
        let (faces, kedges) = polytope(sep);
        for &f in faces {
            push(f);
        }
        for &k in kedges {
            for e in edges {
                push(e.cross(k));
            }
        }
        let n = edges[0].cross(c - a);
        let plane = (n != DVec3::ZERO).then(|| {
            let n = canonical(n);
            let h = sep.support(n);
            let d = n.dot(a);
            let eps = eps_of(n);
            Axis {
                dir: n,
                lo: d - h - eps,
                hi: d + h - eps,
            }
        });
        let (min, max) = voxel_range(a, b, c);
        PreparedTriangle {
            axes,
            axis_count: axis_count as u8,
            plane,
            min,
            max,
        }
    }

    #[inline]
    fn contains(&self, v: DVec3) -> bool {
        if let Some(p) = &self.plane {
            let s = p.dir.dot(v);
            if !(p.lo <= s && s < p.hi) {
                return false;
            }
        }
        self.axes[..self.axis_count as usize].iter().all(|ax| {
            let s = ax.dir.dot(v);
            ax.lo <= s && s <= ax.hi
        })
    }

    /// Calls `f` for every voxel of `region` that passes, scanning columns along the
    /// normal's dominant axis so the work is proportional to the triangle's area.
    fn for_each_voxel(&self, region: &IndexBox, mut f: impl FnMut(IVec3)) {
        let lo = self.min.max(region.min);
        let hi = self.max.min(region.max - IVec3::ONE);
        if lo.cmpgt(hi).any() {
            return;
        }
        let Some(plane) = &self.plane else {
            for ijk in IndexBox::new(lo, hi + IVec3::ONE).iter() {
                if self.contains(ijk.as_dvec3()) {
                    f(ijk);
                }
            }
            return;
        };
        let n = plane.dir;
        let d = dominant_axis(n);
        let (u, w) = ((d + 1) % 3, (d + 2) % 3);
        for cu in lo[u]..=hi[u] {
            for cw in lo[w]..=hi[w] {
                // Along axis d the slab is lo ≤ n_d·x + r < hi (n_d > 0 after
                // canonicalisation); widen by one voxel and let the exact test decide.
                let r = n[u] * cu as f64 + n[w] * cw as f64;
                let (lo_d, hi_d) = (lo[d] as f64, hi[d] as f64);
                let x0 = (floor_i32(((plane.lo - r) / n[d]).max(lo_d).min(hi_d)) - 1).max(lo[d]);
                let x1 = (ceil_i32(((plane.hi - r) / n[d]).max(lo_d).min(hi_d)) + 1).min(hi[d]);
                for cd in x0..x1 + 1 {
                    let mut ijk = IVec3::ZERO;
                    ijk[d] = cd;
                    ijk[u] = cu;
                    ijk[w] = cw;
                    if self.contains(ijk.as_dvec3()) {
                        f(ijk);
                    }
                }
            }
        }
    }
}

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

/// Where the binary voxelizer puts black voxels. `is_set` lets a triangle skip a voxel
/// an earlier triangle made black (the union does not change); a sink that cannot
/// answer cheaply says `false`.
trait VoxelSink {
    fn is_set(&self, ijk: IVec3) -> bool;
    fn set(&mut self, ijk: IVec3);
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
/// matters more than the cost per voxel. Two shortcuts, neither of which changes a
/// decision:
/// - A voxel already black (set by an earlier triangle of the chunk) is not tested
///   again.
/// - For a triangle whose voxel range holds at most [`SMALL_RANGE`] voxels, the range
///   is tested voxel by voxel instead of column by column, and the nine edge axes are
///   computed only when a voxel first needs them (at N = 128 on the bunny, 45% of the
///   triangles never do).
///
/// (A third was measured and dropped: accepting a voxel whose box holds a vertex of
/// the triangle without its edge axes. It is exact, but testing the vertices cost more
/// instructions than the axes it saved.)
#[derive(Debug, Clone)]
struct Prepared26 {
    tri: [DVec3; 3],
    /// The widening unit, 64 ulp of the largest coordinate (see [`PreparedTriangle::new`]).
    unit: f64,
    plane: Axis,
    /// Voxel range, which decides the cube's three face axes: a voxel `v` of
    /// `min..=max` has `v ≥ ⌈fl(lo − ½)⌉ ≥ fl(fl(lo − ½) − ε)`, the general path's face
    /// bound, by the monotonicity of rounding (and likewise above). The clamp of
    /// [`round_clamped`] at ±2²⁹ only moves bounds outside every region rasterized
    /// here (this path's grids are at most 2²⁴ voxels a side).
    min: IVec3,
    max: IVec3,
}

/// Voxel ranges up to this many voxels take [`Prepared26::test_range`].
const SMALL_RANGE: i64 = 12;

impl Prepared26 {
    /// `None` for a degenerate triangle (the general path handles it).
    #[inline]
    fn new(tri: [DVec3; 3]) -> Option<Self> {
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
        let d = n.dot(a);
        let eps_n = unit * (n.x.abs() + n.y.abs() + n.z.abs());
        let (min, max) = voxel_range(a, b, c);
        Some(Prepared26 {
            tri,
            unit,
            plane: Axis {
                dir: n,
                lo: d - h - eps_n,
                hi: d + h - eps_n,
            },
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
    fn rasterize(&self, region: &IndexBox, sink: &mut impl VoxelSink) {
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
        let inv_nd = 1.0 / n[D]; // the range is widened by one voxel: rounding is harmless
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
                let r = n[u] * vu + n[w] * vw;
                let x0 = (floor_i32(((plane.lo - r) * inv_nd).max(lo_d).min(hi_d)) - 1).max(lo[D]);
                let x1 = (ceil_i32(((plane.hi - r) * inv_nd).max(lo_d).min(hi_d)) + 1).min(hi[D]);
                for cd in x0..x1 + 1 {
                    let mut ijk = IVec3::ZERO;
                    ijk[D] = cd;
                    ijk[u] = cu;
                    ijk[w] = cw;
                    if sink.is_set(ijk) {
                        continue;
                    }
                    v[D] = cd as f64;
                    // n·v in glam's order: (x·x' + y·y') + z·z'.
                    let s = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
                    let in_slab = plane.lo <= s && s < plane.hi;
                    if in_slab && pass(u, &v) && pass(w, &v) {
                        sink.set(ijk);
                    }
                }
            }
        }
    }
}

/// Inclusive voxel range a triangle's neighbourhood test can pass: its bounding box grown
/// by ½ (every `K_N` fits in the cube `[−½, ½]³`).
fn voxel_range(a: DVec3, b: DVec3, c: DVec3) -> (IVec3, IVec3) {
    (
        round_clamped(lower(lower(a, b), c) - 0.5, ceil_i32),
        round_clamped(upper(upper(a, b), c) + 0.5, floor_i32),
    )
}

/// Lane-wise minimum and maximum of finite vectors by plain comparisons (the same
/// values as `DVec3::min`/`max`, without their NaN handling, which costs more than
/// the rest of a small triangle's preparation).
#[inline(always)]
fn lower(p: DVec3, q: DVec3) -> DVec3 {
    DVec3::select(p.cmplt(q), p, q)
}

#[inline(always)]
fn upper(p: DVec3, q: DVec3) -> DVec3 {
    DVec3::select(p.cmpgt(q), p, q)
}

#[inline(always)]
fn upper_f(p: f64, q: f64) -> f64 {
    if p > q {
        p
    } else {
        q
    }
}

/// The axis of the largest-magnitude component, the lowest axis among equals.
pub(crate) fn dominant_axis(n: DVec3) -> usize {
    let a = n.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// The normal with its largest-magnitude component (lowest axis among equals) positive.
fn canonical(n: DVec3) -> DVec3 {
    let d = dominant_axis(n);
    if n[d] < 0.0 {
        -n
    } else {
        n
    }
}

pub(crate) fn clamp_i(v: DVec3) -> IVec3 {
    let lim = DVec3::splat((i32::MAX / 4) as f64);
    let c = upper(lower(v, lim), -lim);
    IVec3::new(c.x as i32, c.y as i32, c.z as i32)
}

/// `v` clamped to ±2²⁹ and rounded per component with `round` (`ceil_i32` or
/// `floor_i32`; without SSE4.1 `f64::ceil` is a libm call, and this is per triangle).
fn round_clamped(v: DVec3, round: fn(f64) -> i32) -> IVec3 {
    let lim = DVec3::splat((i32::MAX / 4) as f64);
    let c = upper(lower(v, lim), -lim);
    IVec3::new(round(c.x), round(c.y), round(c.z))
}

/// Is voxel `ijk` black for this single triangle (index-space coordinates)? The
/// reference predicate behind [`voxelize_triangles`], exposed for validators and tests.
pub fn triangle_covers_voxel(tri_index: [DVec3; 3], separability: Separability, ijk: IVec3) -> bool {
    PreparedTriangle::new(tri_index, separability).contains(ijk.as_dvec3())
}

/// Binary surface voxelization of world-space triangles on `grid` with the given
/// separability. Black voxels get density 1; the result is the union over triangles.
///
/// Triangles are bucketed by a coarse cell of the grid; chunks of spatially consecutive
/// triangles, each triangle prepared once, collect their black voxels as bit masks per
/// brick, which are then merged by brick (sorted in storage order). A union does not
/// depend on the order in which it is formed, so the result is identical for any
/// thread count. Non-finite triangles are skipped (callers validate input; the mesh
/// loader refuses them).
pub fn voxelize_triangles(
    grid: &Grid,
    triangles: &[[DVec3; 3]],
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    voxelize_indexed(
        grid,
        triangles.len(),
        |i| triangles[i].map(|p| t.world_to_index(p)),
        separability,
        progress,
    )
}

/// [`voxelize_triangles`] for the triangles of a mesh, without gathering them first
/// (its vertices are moved to index space once, not once per corner).
pub fn voxelize_mesh_surface(
    grid: &Grid,
    mesh: &volga_mesh::TriMesh,
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    let index_positions: Vec<DVec3> = mesh.positions.par_iter().map(|&p| t.world_to_index(p)).collect();
    voxelize_indexed(
        grid,
        mesh.triangles.len(),
        |i| mesh.triangles[i].map(|v| index_positions[v as usize]),
        separability,
        progress,
    )
}

/// The union over `count` triangles, given in index space by `index_triangle`.
/// Triangles with a non-finite coordinate are skipped.
fn voxelize_indexed(
    grid: &Grid,
    count: usize,
    index_triangle: impl Fn(usize) -> [DVec3; 3] + Sync,
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let grid_box = grid.index_box();
    let finite = |i: usize| {
        let tri = index_triangle(i);
        tri.iter().all(|p| p.is_finite()).then_some(tri)
    };
    if grid_box.max.cmpgt(IVec3::splat(1 << (21 + BRICK_LOG2))).any() {
        let index_triangles: Vec<[DVec3; 3]> = (0..count).into_par_iter().filter_map(finite).collect();
        return voxelize_triangles_by_bricks(grid, &index_triangles, separability, progress);
    }
    // Triangles in coarse spatial order: bucketed (a counting sort) by the cell of
    // their first vertex, cells of 2^s bricks a side in storage order, at most
    // `MAX_CELLS` of them. Non-finite triangles are dropped here. On the bunny at
    // N = 128 this cuts the brick masks the chunks hand over from 13,829 to 2,514 (mesh
    // order scatters a chunk over ~200 bricks) and lets more voxels be found black
    // already; it costs two passes over the triangles.
    const MAX_CELLS: i64 = 1 << 16;
    let cells = (grid_box.max + IVec3::splat(BRICK_DIM - 1)) >> BRICK_LOG2;
    let shift = (0..21)
        .find(|&s: &i32| {
            let c = ((cells + IVec3::splat((1 << s) - 1)) >> s).max(IVec3::ONE).as_i64vec3();
            c.x * c.y * c.z <= MAX_CELLS
        })
        .unwrap_or(21);
    let cells = ((cells + IVec3::splat((1 << shift) - 1)) >> shift).max(IVec3::ONE);
    let Ok(cell_shape) = Shape3::new(cells.as_uvec3()) else {
        // Not reached (at most `MAX_CELLS` cells of ≥ 1 per axis); the per-brick path
        // handles any grid.
        let index_triangles: Vec<[DVec3; 3]> = (0..count).into_par_iter().filter_map(finite).collect();
        return voxelize_triangles_by_bricks(grid, &index_triangles, separability, progress);
    };
    let cell_of: Vec<u32> = (0..count)
        .into_par_iter()
        .map(|i| match finite(i) {
            Some([a, ..]) => {
                let c = (clamp_i(a).clamp(grid_box.min, grid_box.max - IVec3::ONE) >> (BRICK_LOG2 + shift))
                    .clamp(IVec3::ZERO, cells - IVec3::ONE);
                cell_shape.linearize(c) as u32
            }
            None => u32::MAX,
        })
        .collect();
    let mut start = vec![0u32; cell_shape.len() + 1];
    for &c in cell_of.iter().filter(|&&c| c != u32::MAX) {
        start[c as usize + 1] += 1;
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let mut order = vec![0u32; start[start.len() - 1] as usize];
    for (i, &c) in cell_of.iter().enumerate().filter(|(_, &c)| c != u32::MAX) {
        order[start[c as usize] as usize] = i as u32;
        start[c as usize] += 1;
    }
    drop(cell_of);

    // Chunks of spatially consecutive triangles collect their voxels as 512-bit brick
    // masks (a voxel is hit by ~5 small triangles; setting a bit costs nothing),
    // merged by brick at the end. A chunk touches few bricks: they are kept in a dense
    // array over the chunk's box of bricks, or, for a chunk spread wider than
    // `DENSE_BRICKS`, in a hash map.
    const CHUNK: usize = 1024;
    const DENSE_BRICKS: i64 = 4096; // 256 KiB of masks
    progress.start("voxelize", order.len().div_ceil(CHUNK) as u64);
    let chunks: Vec<Vec<(u64, BrickMask)>> = order
        .par_chunks(CHUNK)
        .map(|chunk| {
            let tris: Vec<[DVec3; 3]> = chunk.iter().map(|&i| index_triangle(i as usize)).collect();
            // The chunk's bricks: the union of its triangles' voxel ranges (the range of
            // their bounding box, rounding being monotonic), clipped to the grid.
            let Some(&[first, ..]) = tris.first() else {
                progress.inc(1);
                return Vec::new();
            };
            let (lo, hi) = tris
                .iter()
                .flatten()
                .fold((first, first), |(lo, hi), &p| (lower(lo, p), upper(hi, p)));
            let (lo, hi) = voxel_range(lo, hi, hi);
            let lo = lo.max(grid_box.min) >> BRICK_LOG2;
            let hi = hi.min(grid_box.max - IVec3::ONE) >> BRICK_LOG2;
            let size = (hi - lo + IVec3::ONE).max(IVec3::ZERO);
            // A dense array of masks over the chunk's box of bricks when it is small
            // (an empty box has no layout and takes the map, which stays empty).
            let dense = (size.as_i64vec3().element_product() <= DENSE_BRICKS)
                .then(|| Shape3::new(size.as_uvec3()).ok())
                .flatten();
            let masks: Vec<(u64, BrickMask)> = if let Some(shape) = dense {
                let mut sink = DenseMasks {
                    lo,
                    shape,
                    masks: vec![BrickMask::EMPTY; shape.len()],
                };
                rasterize(&tris, separability, &grid_box, &mut sink);
                sink.masks
                    .into_iter()
                    .enumerate()
                    .filter(|(_, m)| !m.is_empty())
                    .map(|(i, m)| (brick_key(lo + shape.delinearize(i)), m))
                    .collect()
            } else {
                let mut sink = MapMasks {
                    masks: FxHashMap::default(),
                    last_key: u64::MAX,
                    last: BrickMask::EMPTY,
                };
                rasterize(&tris, separability, &grid_box, &mut sink);
                sink.flush();
                sink.masks.into_iter().collect()
            };
            progress.inc(1);
            masks
        })
        .collect();
    let mut masks: Vec<(u64, BrickMask)> = chunks.concat();
    masks.par_sort_unstable_by_key(|(k, _)| *k);
    progress.finish();

    let runs: Vec<&[(u64, BrickMask)]> = masks.chunk_by(|a, b| a.0 == b.0).collect();
    let bricks: Vec<(IVec3, Brick<f32>)> = runs
        .par_iter()
        .map(|run| {
            let mask = run.iter().fold(BrickMask::EMPTY, |m, (_, r)| m.or(r));
            let mut data = [0.0f32; BRICK_VOXELS];
            let mut left = mask;
            while let Some(o) = left.first() {
                data[o] = 1.0;
                left.remove(o);
            }
            (brick_of_key(run[0].0), Brick::from_voxels(&data))
        })
        .collect();
    let mut volume = SparseVolume::new(*grid, 0.0, false).with_density_kind(ChannelKind::Binary);
    for (b, brick) in bricks {
        volume.density.insert_brick(b, brick);
    }
    volume
}

/// Sets every voxel of `region` that one of `index_triangles` covers.
#[inline]
fn rasterize(index_triangles: &[[DVec3; 3]], separability: Separability, region: &IndexBox, sink: &mut impl VoxelSink) {
    for &tri in index_triangles {
        let fast = (separability == Separability::TwentySix)
            .then(|| Prepared26::new(tri))
            .flatten();
        match fast {
            Some(p) => p.rasterize(region, sink),
            None => PreparedTriangle::new(tri, separability).for_each_voxel(region, |ijk| sink.set(ijk)),
        }
    }
}

/// A chunk's voxels as brick masks in a dense array over its box of bricks.
struct DenseMasks {
    lo: IVec3,
    /// Layout of the box of bricks from `lo`.
    shape: Shape3,
    masks: Vec<BrickMask>,
}

impl DenseMasks {
    #[inline]
    fn slot(&self, ijk: IVec3) -> (usize, usize) {
        let b = (ijk >> BRICK_LOG2) - self.lo;
        (self.shape.linearize(b), Brick::<f32>::local_offset(ijk))
    }
}

impl VoxelSink for DenseMasks {
    #[inline]
    fn is_set(&self, ijk: IVec3) -> bool {
        let (i, o) = self.slot(ijk);
        self.masks[i].contains(o)
    }

    #[inline]
    fn set(&mut self, ijk: IVec3) {
        let (i, o) = self.slot(ijk);
        self.masks[i].insert(o);
    }
}

/// A chunk's voxels as brick masks in a hash map, for chunks spread over many bricks.
/// Consecutive voxels mostly share a brick: they are gathered before touching the map.
struct MapMasks {
    masks: FxHashMap<u64, BrickMask>,
    last_key: u64,
    last: BrickMask,
}

impl MapMasks {
    fn flush(&mut self) {
        if self.last_key != u64::MAX {
            let entry = self.masks.entry(self.last_key).or_default();
            *entry = entry.or(&self.last);
        }
    }
}

impl VoxelSink for MapMasks {
    #[inline]
    fn is_set(&self, ijk: IVec3) -> bool {
        brick_key(ijk >> BRICK_LOG2) == self.last_key && self.last.contains(Brick::<f32>::local_offset(ijk))
    }

    #[inline]
    fn set(&mut self, ijk: IVec3) {
        let key = brick_key(ijk >> BRICK_LOG2);
        if key != self.last_key {
            self.flush();
            self.last_key = key;
            self.last = BrickMask::EMPTY;
        }
        self.last.insert(Brick::<f32>::local_offset(ijk));
    }
}

/// Packs a brick of a grid (non-negative, below 2²¹ per axis) as z, y, x: sorting keys
/// sorts bricks in storage order.
#[inline]
fn brick_key(b: IVec3) -> u64 {
    let b = b.as_uvec3();
    ((b.z as u64) << 42) | ((b.y as u64) << 21) | b.x as u64
}

#[inline]
fn brick_of_key(key: u64) -> IVec3 {
    let mask = (1u64 << 21) - 1;
    IVec3::new((key & mask) as i32, ((key >> 21) & mask) as i32, (key >> 42) as i32)
}

const BRICK_LOG2: i32 = volga_core::BRICK_LOG2;

/// The same union for grids too large for packed keys: triangles binned into bricks
/// (prepared again in every brick they touch), bricks processed in parallel and stored
/// in sorted order.
fn voxelize_triangles_by_bricks(
    grid: &Grid,
    index_triangles: &[[DVec3; 3]],
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    // (brick, triangle) pairs for every brick a triangle's voxel range touches.
    let grid_box = grid.index_box();
    let mut pairs: Vec<(IVec3, u32)> = index_triangles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, [a, b, c])| {
            let (lo, hi) = voxel_range(*a, *b, *c);
            let (lo, hi) = (lo.max(grid_box.min), hi.min(grid_box.max - IVec3::ONE));
            let bricks = if lo.cmpgt(hi).any() {
                IndexBox::new(IVec3::ZERO, IVec3::ZERO)
            } else {
                IndexBox::new(
                    lo.div_euclid(IVec3::splat(BRICK_DIM)),
                    hi.div_euclid(IVec3::splat(BRICK_DIM)) + 1,
                )
            };
            bricks.iter().map(move |b| (b, i as u32)).collect::<Vec<_>>()
        })
        .collect();
    crate::pairs::sort_brick_pairs(&mut pairs);
    let groups: Vec<&[(IVec3, u32)]> = pairs.chunk_by(|a, b| a.0 == b.0).collect();

    progress.start("voxelize", groups.len() as u64);
    let bricks: Vec<(IVec3, Brick<f32>)> = groups
        .par_iter()
        .filter_map(|group| {
            let brick = group[0].0;
            let region = IndexBox::new(brick * BRICK_DIM, (brick + 1) * BRICK_DIM).intersection(&grid_box);
            let mut data = [0.0f32; BRICK_VOXELS];
            let mut any = false;
            for &(_, i) in group.iter() {
                PreparedTriangle::new(index_triangles[i as usize], separability).for_each_voxel(&region, |ijk| {
                    data[Brick::<f32>::local_offset(ijk)] = 1.0;
                    any = true;
                });
            }
            progress.inc(1);
            any.then(|| (brick, Brick::from_voxels(&data)))
        })
        .collect();
    progress.finish();

    let mut volume = SparseVolume::new(*grid, 0.0, false).with_density_kind(ChannelKind::Binary);
    for (b, brick) in bricks {
        volume.density.insert_brick(b, brick);
    }
    volume
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn support_functions_match_polytope_vertices() {
        let n = DVec3::new(0.3, -0.9, 0.5);
        assert_eq!(Separability::Six.support(n), 0.45);
        assert!((Separability::Eighteen.support(n) - 0.7).abs() < 1e-15);
        assert!((Separability::TwentySix.support(n) - 0.85).abs() < 1e-15);
    }

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

    #[test]
    fn canonical_normal_orientation() {
        assert_eq!(canonical(DVec3::new(0.0, 0.0, -2.0)), DVec3::new(0.0, 0.0, 2.0));
        assert_eq!(canonical(DVec3::new(-1.0, 1.0, 0.0)), DVec3::new(1.0, -1.0, 0.0));
        assert_eq!(canonical(DVec3::new(0.5, -1.0, 0.2)), DVec3::new(-0.5, 1.0, -0.2));
    }
}
