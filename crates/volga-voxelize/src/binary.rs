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
use volga_core::{Brick, Grid, IndexBox, Progress, SparseVolume, BRICK_DIM, BRICK_VOXELS};

use crate::mask::BrickMask;
use crate::tri_distance::{ceil_i32, floor_i32};

/// Which white paths a voxelized surface must block (survey §17.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Separability {
    Six,
    Eighteen,
    TwentySix,
}

impl Separability {
    /// Parses 6, 18 or 26.
    pub fn from_number(n: u32) -> Option<Self> {
        match n {
            6 => Some(Separability::Six),
            18 => Some(Separability::Eighteen),
            26 => Some(Separability::TwentySix),
            _ => None,
        }
    }

    pub fn number(self) -> u32 {
        match self {
            Separability::Six => 6,
            Separability::Eighteen => 18,
            Separability::TwentySix => 26,
        }
    }

    /// Support function of `K_N` (see the module doc): `max_{x ∈ K_N} a·x`.
    #[inline]
    pub fn support(self, a: DVec3) -> f64 {
        let m = a.abs();
        match self {
            Separability::Six => 0.5 * m.max_element(),
            Separability::Eighteen => 0.5 * (m.x + m.y + m.z - m.min_element()),
            Separability::TwentySix => 0.5 * (m.x + m.y + m.z),
        }
    }

    /// Face normals and edge directions of `K_N`: the separating-axis candidates.
    fn polytope(self) -> (&'static [DVec3], &'static [DVec3]) {
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
        match self {
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
        let (faces, kedges) = sep.polytope();
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
                for cd in x0..=x1 {
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

/// A separating axis with one zero component: `lo ≤ ci·v_i + cj·v_j ≤ hi`, the two
/// other components in increasing order (`lo = −∞, hi = ∞` when the axis is zero).
#[derive(Debug, Clone, Copy)]
struct Axis2 {
    ci: f64,
    cj: f64,
    lo: f64,
    hi: f64,
}

/// [`PreparedTriangle`] specialised to 26-separability (`K_26` is the unit cube, the
/// classic conservative box test) for non-degenerate triangles. It makes exactly the
/// same decisions: the edge axes `e × x̂_k` have a zero component `k`, and every
/// value here is computed as the general path's dot product with that zero term
/// dropped (adding ±0 changes nothing), in the same order. Axes without a component
/// along the column are tested once per column instead of once per voxel.
#[derive(Debug, Clone)]
struct Prepared26 {
    /// `edge[k][m]`: edge `m` crossed with axis `k`.
    edge: [[Axis2; 3]; 3],
    /// The cube's face axes: `face_lo ≤ v ≤ face_hi` per component.
    face_lo: DVec3,
    face_hi: DVec3,
    plane: Axis,
    min: IVec3,
    max: IVec3,
}

impl Prepared26 {
    /// `None` for a degenerate triangle (the general path handles it).
    #[inline]
    fn new(tri: [DVec3; 3]) -> Option<Self> {
        let [a, b, c] = tri;
        let edges = [b - a, c - b, a - c];
        let n = edges[0].cross(c - a);
        if n == DVec3::ZERO {
            return None;
        }
        let scale = a.abs().max(b.abs()).max(c.abs()).max_element() + 1.0;
        let unit = 64.0 * f64::EPSILON * scale;
        let axis2 = |ci: f64, cj: f64, i: usize, j: usize| {
            if ci == 0.0 && cj == 0.0 {
                return Axis2 {
                    ci,
                    cj,
                    lo: f64::NEG_INFINITY,
                    hi: f64::INFINITY,
                };
            }
            let p = [ci * a[i] + cj * a[j], ci * b[i] + cj * b[j], ci * c[i] + cj * c[j]];
            let l1 = ci.abs() + cj.abs();
            let (h, eps) = (0.5 * l1, unit * l1);
            // Finite values: plain comparisons instead of `f64::min`'s NaN handling.
            let (lo, hi) = if p[0] < p[1] { (p[0], p[1]) } else { (p[1], p[0]) };
            let (lo, hi) = (if p[2] < lo { p[2] } else { lo }, if p[2] > hi { p[2] } else { hi });
            Axis2 {
                ci,
                cj,
                lo: lo - h - eps,
                hi: hi + h + eps,
            }
        };
        let [e0, e1, e2] = edges;
        let edge = [
            [
                axis2(e0.z, -e0.y, 1, 2),
                axis2(e1.z, -e1.y, 1, 2),
                axis2(e2.z, -e2.y, 1, 2),
            ],
            [
                axis2(-e0.z, e0.x, 0, 2),
                axis2(-e1.z, e1.x, 0, 2),
                axis2(-e2.z, e2.x, 0, 2),
            ],
            [
                axis2(e0.y, -e0.x, 0, 1),
                axis2(e1.y, -e1.x, 0, 1),
                axis2(e2.y, -e2.x, 0, 1),
            ],
        ];
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        let eps = unit;
        let n = canonical(n);
        let h = Separability::TwentySix.support(n);
        let d = n.dot(a);
        let eps_n = unit * (n.x.abs() + n.y.abs() + n.z.abs());
        let (min, max) = voxel_range(a, b, c);
        Some(Prepared26 {
            edge,
            face_lo: lo - 0.5 - eps,
            face_hi: hi + 0.5 + eps,
            plane: Axis {
                dir: n,
                lo: d - h - eps_n,
                hi: d + h - eps_n,
            },
            min,
            max,
        })
    }

    /// Calls `f` for every voxel of `region` that passes (columns along the normal's
    /// dominant axis, as [`PreparedTriangle::for_each_voxel`]).
    #[inline]
    fn for_each_voxel(&self, region: &IndexBox, f: impl FnMut(IVec3)) {
        match dominant_axis(self.plane.dir) {
            0 => self.scan::<0>(region, f),
            1 => self.scan::<1>(region, f),
            _ => self.scan::<2>(region, f),
        }
    }

    /// [`Prepared26::for_each_voxel`] with the column axis `D` known at compile time.
    #[inline]
    fn scan<const D: usize>(&self, region: &IndexBox, mut f: impl FnMut(IVec3)) {
        let lo = self.min.max(region.min);
        let hi = self.max.min(region.max - IVec3::ONE);
        if lo.cmpgt(hi).any() {
            return;
        }
        let (u, w) = ((D + 1) % 3, (D + 2) % 3);
        let plane = &self.plane;
        let n = plane.dir.to_array();
        let inv_nd = 1.0 / n[D]; // the range is widened by one voxel: rounding is harmless
        let (face_lo, face_hi) = (self.face_lo.to_array(), self.face_hi.to_array());
        // Each axis `e × x̂_k` reads the two components other than k, in increasing order.
        let pass = |ax: &Axis2, v: &[f64; 3], k: usize| {
            let (i, j) = if k == 0 {
                (1, 2)
            } else if k == 1 {
                (0, 2)
            } else {
                (0, 1)
            };
            let s = ax.ci * v[i] + ax.cj * v[j];
            ax.lo <= s && s <= ax.hi
        };
        let (lo_d, hi_d) = (lo[D] as f64, hi[D] as f64);
        for cu in lo[u]..=hi[u] {
            let vu = cu as f64;
            if !(face_lo[u] <= vu && vu <= face_hi[u]) {
                continue;
            }
            'column: for cw in lo[w]..=hi[w] {
                let vw = cw as f64;
                if !(face_lo[w] <= vw && vw <= face_hi[w]) {
                    continue;
                }
                let mut v = [0.0; 3];
                v[u] = vu;
                v[w] = vw;
                for ax in &self.edge[D] {
                    if !pass(ax, &v, D) {
                        continue 'column;
                    }
                }
                let r = n[u] * vu + n[w] * vw;
                let x0 = (floor_i32(((plane.lo - r) * inv_nd).max(lo_d).min(hi_d)) - 1).max(lo[D]);
                let x1 = (ceil_i32(((plane.hi - r) * inv_nd).max(lo_d).min(hi_d)) + 1).min(hi[D]);
                for cd in x0..=x1 {
                    v[D] = cd as f64;
                    // n·v in glam's order: (x·x' + y·y') + z·z'.
                    let s = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
                    let in_slab = plane.lo <= s && s < plane.hi;
                    if !(in_slab && face_lo[D] <= v[D] && v[D] <= face_hi[D]) {
                        continue;
                    }
                    if self.edge[u].iter().all(|ax| pass(ax, &v, u)) && self.edge[w].iter().all(|ax| pass(ax, &v, w)) {
                        let mut ijk = IVec3::ZERO;
                        ijk[D] = cd;
                        ijk[u] = cu;
                        ijk[w] = cw;
                        f(ijk);
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
        round_clamped(a.min(b).min(c) - 0.5, ceil_i32),
        round_clamped(a.max(b).max(c) + 0.5, floor_i32),
    )
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
    let lim = (i32::MAX / 4) as f64;
    let c = v.clamp(DVec3::splat(-lim), DVec3::splat(lim));
    IVec3::new(c.x as i32, c.y as i32, c.z as i32)
}

/// `v` clamped to ±2²⁹ and rounded per component with `round` (`ceil_i32` or
/// `floor_i32`; without SSE4.1 `f64::ceil` is a libm call, and this is per triangle).
fn round_clamped(v: DVec3, round: fn(f64) -> i32) -> IVec3 {
    let lim = (i32::MAX / 4) as f64;
    let c = v.clamp(DVec3::splat(-lim), DVec3::splat(lim));
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
/// Each triangle is prepared once; chunks of consecutive triangles collect their black
/// voxels as bit masks per brick, which are then merged by brick (sorted in storage
/// order). A union does not depend on the order in which it is formed, so the
/// result is identical for any thread count. Non-finite triangles
/// are skipped (callers validate input; the mesh loader refuses them).
pub fn voxelize_triangles(
    grid: &Grid,
    triangles: &[[DVec3; 3]],
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    voxelize_indexed(grid, triangles.len(), |i| triangles[i], separability, progress)
}

/// [`voxelize_triangles`] for the triangles of a mesh, without gathering them first.
pub fn voxelize_mesh_surface(
    grid: &Grid,
    mesh: &volga_mesh::TriMesh,
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    voxelize_indexed(grid, mesh.triangles.len(), |i| mesh.triangle(i), separability, progress)
}

fn voxelize_indexed(
    grid: &Grid,
    count: usize,
    triangle: impl Fn(usize) -> [DVec3; 3] + Sync,
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    let grid_box = grid.index_box();
    let finite = |i: usize| {
        let tri = triangle(i);
        tri.iter().all(|p| p.is_finite()).then_some(tri)
    };
    if grid_box.max.cmpgt(IVec3::splat(1 << (21 + BRICK_LOG2))).any() {
        let index_triangles: Vec<[DVec3; 3]> = (0..count)
            .into_par_iter()
            .filter_map(|i| finite(i).map(|tri| tri.map(|p| t.world_to_index(p))))
            .collect();
        return voxelize_triangles_by_bricks(grid, &index_triangles, separability, progress);
    }
    // Chunks of consecutive triangles collect their voxels as 512-bit brick masks (a
    // voxel is hit by ~10 small triangles; setting a bit costs nothing), merged by brick
    // at the end. Meshes list neighbouring triangles near each other, so a chunk touches
    // few bricks; sorting the triangles spatially first cost more than it saved.
    const CHUNK: usize = 1024;
    progress.start("voxelize", count.div_ceil(CHUNK) as u64);
    let chunks: Vec<Vec<(u64, BrickMask)>> = (0..count.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut masks: FxHashMap<u64, BrickMask> = FxHashMap::default();
            let flush = |masks: &mut FxHashMap<u64, BrickMask>, key: u64, mask: &BrickMask| {
                let entry = masks.entry(key).or_default();
                *entry = entry.or(mask);
            };
            // Consecutive voxels mostly share a brick: gather them before touching the map.
            let (mut last_key, mut last) = (u64::MAX, BrickMask::EMPTY);
            let mut emit = |ijk: IVec3| {
                let key = brick_key(ijk >> BRICK_LOG2);
                if key != last_key {
                    if last_key != u64::MAX {
                        flush(&mut masks, last_key, &last);
                    }
                    last_key = key;
                    last = BrickMask::EMPTY;
                }
                last.insert(Brick::<f32>::local_offset(ijk));
            };
            for i in c * CHUNK..((c + 1) * CHUNK).min(count) {
                let Some(tri) = finite(i) else { continue };
                let tri = tri.map(|p| t.world_to_index(p));
                let fast = (separability == Separability::TwentySix)
                    .then(|| Prepared26::new(tri))
                    .flatten();
                match fast {
                    Some(p) => p.for_each_voxel(&grid_box, &mut emit),
                    None => PreparedTriangle::new(tri, separability).for_each_voxel(&grid_box, &mut emit),
                }
            }
            if last_key != u64::MAX {
                flush(&mut masks, last_key, &last);
            }
            progress.inc(1);
            masks.into_iter().collect()
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
            let mut data = Box::new([0.0f32; BRICK_VOXELS]);
            let mut left = mask;
            while let Some(o) = left.first() {
                data[o] = 1.0;
                left.remove(o);
            }
            (brick_of_key(run[0].0), Brick::Dense(data).collapsed())
        })
        .collect();
    let mut volume = SparseVolume::new(*grid, 0.0, false);
    for (b, brick) in bricks {
        volume.density.insert_brick(b, brick);
    }
    volume
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
            let mut data = Box::new([0.0f32; BRICK_VOXELS]);
            let mut any = false;
            for &(_, i) in group.iter() {
                PreparedTriangle::new(index_triangles[i as usize], separability).for_each_voxel(&region, |ijk| {
                    data[Brick::<f32>::local_offset(ijk)] = 1.0;
                    any = true;
                });
            }
            progress.inc(1);
            any.then(|| (brick, Brick::Dense(data).collapsed()))
        })
        .collect();
    progress.finish();

    let mut volume = SparseVolume::new(*grid, 0.0, false);
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
        /// triangles and on dyadic ones with vertices on voxel centres and faces.
        #[test]
        fn fast_26_path_matches_the_general_test(
            raw in proptest::collection::vec((-6.0f64..6.0, -6.0f64..6.0, -6.0f64..6.0), 3),
            dyadic in proptest::bool::ANY,
            offset in proptest::prop_oneof![proptest::strategy::Just(0.0), proptest::strategy::Just(1e6)],
        ) {
            let tri = [0, 1, 2].map(|k| {
                let p = DVec3::new(raw[k].0, raw[k].1, raw[k].2);
                let p = if dyadic { (p * 2.0).round() * 0.5 } else { p };
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
