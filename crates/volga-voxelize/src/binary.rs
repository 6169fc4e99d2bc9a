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
use volga_core::{Brick, Grid, IndexBox, Progress, SparseVolume, BRICK_DIM, BRICK_VOXELS};

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
                let x0 = ((plane.lo - r) / n[d]).floor() as i64 - 1;
                let x1 = ((plane.hi - r) / n[d]).ceil() as i64 + 1;
                let x0 = x0.max(lo[d] as i64) as i32;
                let x1 = x1.min(hi[d] as i64) as i32;
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

/// Inclusive voxel range a triangle's neighbourhood test can pass: its bounding box grown
/// by ½ (every `K_N` fits in the cube `[−½, ½]³`).
fn voxel_range(a: DVec3, b: DVec3, c: DVec3) -> (IVec3, IVec3) {
    (
        clamp_i((a.min(b).min(c) - 0.5).ceil()),
        clamp_i((a.max(b).max(c) + 0.5).floor()),
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

/// Is voxel `ijk` black for this single triangle (index-space coordinates)? The
/// reference predicate behind [`voxelize_triangles`], exposed for validators and tests.
pub fn triangle_covers_voxel(tri_index: [DVec3; 3], separability: Separability, ijk: IVec3) -> bool {
    PreparedTriangle::new(tri_index, separability).contains(ijk.as_dvec3())
}

/// Binary surface voxelization of world-space triangles on `grid` with the given
/// separability. Black voxels get density 1; the result is the union over triangles.
///
/// Triangles are binned into 8³ bricks; bricks are processed in parallel and stored in
/// sorted order, so the result is identical for any thread count. Non-finite triangles
/// are skipped (callers validate input; the mesh loader refuses them).
pub fn voxelize_triangles(
    grid: &Grid,
    triangles: &[[DVec3; 3]],
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    // Triangles in index space; each is prepared (its separating axes) on the stack in
    // every brick that uses it, which costs less than storing ~1 KB of axes per triangle.
    let index_triangles: Vec<[DVec3; 3]> = triangles
        .par_iter()
        .filter(|tri| tri.iter().all(|p| p.is_finite()))
        .map(|tri| tri.map(|p| t.world_to_index(p)))
        .collect();

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

    #[test]
    fn canonical_normal_orientation() {
        assert_eq!(canonical(DVec3::new(0.0, 0.0, -2.0)), DVec3::new(0.0, 0.0, 2.0));
        assert_eq!(canonical(DVec3::new(-1.0, 1.0, 0.0)), DVec3::new(1.0, -1.0, 0.0));
        assert_eq!(canonical(DVec3::new(0.5, -1.0, 0.2)), DVec3::new(-0.5, 1.0, -0.2));
    }
}
