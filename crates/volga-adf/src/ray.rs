//! Ray intersection with the cell structure.

use glam::DVec3;

use crate::tree::{corner_position, trilinear};
use crate::Adf;

/// The first point where a ray meets the reconstructed surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Ray parameter (world distance for a unit direction).
    pub t: f64,
    pub world_pos: DVec3,
    /// Unit outward normal (the reconstruction's gradient).
    pub normal: DVec3,
    /// Leaves visited.
    pub steps: u32,
}

impl Adf {
    /// The first `t ∈ [0, t_max]` where the reconstruction along `origin + t·dir` reaches 0
    /// (`dir` need not be unit; `t` is in its units).
    ///
    /// Walks the leaves the ray crosses. In a leaf whose corners are all positive the
    /// reconstruction has no zero, and the ray advances by the larger of the leaf's exit
    /// and a sphere-tracing step: the 1-Lipschitz lower bound `max_b (d_b − |p − x_b|)`
    /// of the distance from the corners (a conservative step, also valid for pruned
    /// leaves whose reconstruction is not within the tolerance). In a leaf with a sign
    /// change the reconstruction along the ray is a cubic polynomial; it is split into
    /// monotone pieces at its critical points and the first downward crossing is
    /// bisected to the last bit, so no crossing that the reconstruction has is stepped
    /// over. A ray starting inside reports `t = 0`.
    pub fn ray_hit(&self, origin: DVec3, dir: DVec3, t_max: f64) -> Option<RayHit> {
        if !(origin.is_finite() && dir.is_finite()) || dir == DVec3::ZERO {
            return None;
        }
        let (t0, t1) = self.root_box().ray_interval(origin, dir)?;
        let end = t1.min(t_max);
        let mut t = t0;
        let mut steps = 0u32;
        let scale = dir.length();
        while t <= end {
            steps += 1;
            // Locate a point slightly inside the leaf ahead so a ray on a cell face
            // resolves to the leaf it is entering.
            let (index, min, size, _) = self.locate(origin + dir * t);
            let leaf_box = volga_core::Aabb::new(min, min + DVec3::splat(size));
            let exit = match leaf_box.ray_interval(origin, dir) {
                Some((_, b)) => b.min(end),
                None => t,
            };
            let corners = self.cells[index].corners;
            // The sign of the reconstruction along the segment: the trilinear corners, or a
            // jump leaf's sign field (its magnitude is positive: no surface passes here).
            let signs = match self.cells[index].jump() {
                None => corners,
                Some(k) => self.jumps[k],
            };
            let at = |s: f64| trilinear(&signs, ((origin + dir * s - min) / size).clamp(DVec3::ZERO, DVec3::ONE));
            let (lo, _) = self.cells[index].corner_range();
            if lo > 0.0 {
                let p = origin + dir * t;
                let mut bound = f64::NEG_INFINITY;
                for (b, &c) in corners.iter().enumerate() {
                    bound = bound.max(c as f64 * (1.0 - 1e-7) - (p - corner_position(min, size, b)).length());
                }
                let step = bound / scale;
                t = next_t(t, exit.max(t + step), size / scale);
                continue;
            }
            if let Some(hit_t) = first_root(&at, t, exit) {
                let world_pos = origin + dir * hit_t;
                let g = self.gradient(world_pos);
                let normal = if g.length() > 0.0 { g.normalize() } else { -dir / scale };
                return Some(RayHit {
                    t: hit_t,
                    world_pos,
                    normal,
                    steps,
                });
            }
            t = next_t(t, exit, size / scale);
        }
        None
    }
}

/// The next ray parameter: `candidate`, but always past `t` by a sliver of the cell so a
/// ray exactly on a cell corner cannot stall.
#[inline]
fn next_t(t: f64, candidate: f64, cell_t: f64) -> f64 {
    let nudge = (cell_t * 1e-9).max(t.abs() * f64::EPSILON * 4.0);
    if candidate > t + nudge {
        candidate
    } else {
        t + nudge
    }
}

/// The first `s ∈ [a, b]` with `g(s) ≤ 0` for a cubic `g` (the trilinear reconstruction
/// along a segment), or `None`.
fn first_root(g: &impl Fn(f64) -> f64, a: f64, b: f64) -> Option<f64> {
    let ga = g(a);
    if ga <= 0.0 {
        return Some(a);
    }
    if b <= a {
        return None;
    }
    // The cubic through 4 samples (exact up to rounding: the restriction is a cubic).
    let h = b - a;
    let (g0, g1, g2, g3) = (ga, g(a + h / 3.0), g(a + 2.0 * h / 3.0), g(b));
    // Coefficients of p(u) = c0 + c1 u + c2 u² + c3 u³ on u ∈ [0, 1] (Lagrange at 0, ⅓, ⅔, 1).
    let c1 = (-11.0 * g0 + 18.0 * g1 - 9.0 * g2 + 2.0 * g3) / 2.0;
    let c2 = (18.0 * g0 - 45.0 * g1 + 36.0 * g2 - 9.0 * g3) / 2.0;
    let c3 = (-9.0 * g0 + 27.0 * g1 - 27.0 * g2 + 9.0 * g3) / 2.0;
    // Critical points: 3 c3 u² + 2 c2 u + c1 = 0.
    let mut cuts = vec![0.0, 1.0];
    let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, c1);
    if qa.abs() > 1e-300 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let r = disc.sqrt();
            let q = -0.5 * (qb + qb.signum() * r);
            for u in [q / qa, if q != 0.0 { qc / q } else { f64::NAN }] {
                if u > 0.0 && u < 1.0 {
                    cuts.push(u);
                }
            }
        }
    } else if qb.abs() > 1e-300 {
        let u = -qc / qb;
        if u > 0.0 && u < 1.0 {
            cuts.push(u);
        }
    }
    cuts.sort_by(f64::total_cmp);
    for w in cuts.windows(2) {
        let (lo, hi) = (a + w[0] * h, a + w[1] * h);
        if g(hi) <= 0.0 {
            // g(lo) > 0 (checked at the previous piece's end) and g(hi) ≤ 0: bisect.
            let (mut l, mut r) = (lo, hi);
            for _ in 0..200 {
                let m = 0.5 * (l + r);
                if m <= l || m >= r {
                    break;
                }
                if g(m) <= 0.0 {
                    r = m;
                } else {
                    l = m;
                }
            }
            return Some(r);
        }
    }
    None
}
