//! The reference voxel test of the binary rule: a separating-axis test of a triangle
//! (index space) against the neighbourhood `v + K_N` of a voxel, for any separability,
//! degenerate triangles included (see the module doc of `binary`).

use glam::{DVec3, IVec3};
use volga_core::IndexBox;

use super::{canonical, dominant_axis, plane_window, voxel_range, Separability};
use crate::tri_distance::{ceil_i32, floor_i32};

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
pub(super) struct Axis {
    pub(super) dir: DVec3,
    pub(super) lo: f64,
    pub(super) hi: f64,
}

/// A triangle in index space prepared for the voxel test.
#[derive(Debug, Clone)]
pub(super) struct PreparedTriangle {
    /// At most 4 + 7 polytope faces + 6·3 edge crossings; `axis_count` are used.
    axes: [Axis; 26],
    axis_count: u8,
    /// Canonically oriented normal and its half-open slab `lo ≤ n·v < hi`, or `None` for
    /// a degenerate triangle.
    plane: Option<Axis>,
    /// Voxel range that can pass (bounding box grown by ½), inclusive.
    pub(super) min: IVec3,
    pub(super) max: IVec3,
}

impl PreparedTriangle {
    pub(super) fn new(tri: [DVec3; 3], sep: Separability) -> Self {
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
            let (lo, hi) = plane_window(tri, n, sep.support(n), eps_of(n));
            Axis { dir: n, lo, hi }
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
    pub(super) fn contains(&self, v: DVec3) -> bool {
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
    pub(super) fn for_each_voxel(&self, region: &IndexBox, mut f: impl FnMut(IVec3)) {
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
