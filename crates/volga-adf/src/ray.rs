//! Ray intersection with the cell structure.

use glam::DVec3;

use crate::tree::{corner_position, trilinear, MAX_SUPPORTED_DEPTH};
use crate::Adf;

/// The first point where a ray meets the reconstructed surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Ray parameter (world distance for a unit direction).
    pub t: f64,
    /// The point `origin + t·dir` (world space).
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
    /// Walks the leaves the ray crosses ([`Adf::first_crossing_between`]). A ray
    /// starting inside reports `t = 0`.
    pub fn ray_hit(&self, origin: DVec3, dir: DVec3, t_max: f64) -> Option<RayHit> {
        if !(origin.is_finite() && dir.is_finite()) || dir == DVec3::ZERO {
            return None;
        }
        let (t0, t1) = self.root_box().ray_interval(origin, dir)?;
        let (hit_t, steps) = self.first_crossing_between(origin, dir, t0, t1.min(t_max), 0.0);
        let hit_t = hit_t?;
        let world_pos = origin + dir * hit_t;
        let g = self.gradient(world_pos);
        let normal = if g.length() > 0.0 {
            g.normalize()
        } else {
            -dir / dir.length()
        };
        Some(RayHit {
            t: hit_t,
            world_pos,
            normal,
            steps,
        })
    }

    /// The reference walk of [`Adf::first_crossing_between`] without the walk index: the
    /// first `t ∈ [t_start, t_end]` where the reconstruction along `origin + t·dir`
    /// falls to `iso` or below, and the number of leaves visited. The tests compare the
    /// indexed walk against it.
    ///
    /// Walks the leaves the ray crosses, keeping the path of ancestors so each next leaf
    /// is found from the nearest common ancestor, not from the root. In a leaf whose
    /// corners are all above `iso` the reconstruction has no crossing, and the ray
    /// advances by the larger of the leaf's exit and a sphere-tracing step: the
    /// 1-Lipschitz lower bound `max_b (d_b − iso − |p − x_b|)` of the distance to the
    /// level set from the corners (also valid for pruned leaves, whose reconstruction is
    /// not within the tolerance). In a leaf with a corner at or below `iso` the
    /// reconstruction along the ray is a cubic polynomial; it is split into monotone
    /// pieces at its critical points and the first downward crossing is refined (regula
    /// falsi safeguarded by bisection) to 1e-12 of the piece, so no crossing that the
    /// reconstruction has is stepped over.
    pub fn first_crossing_by_descent(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_start: f64,
        t_end: f64,
        iso: f64,
    ) -> (Option<f64>, u32) {
        let mut t = t_start;
        let mut steps = 0u32;
        let scale = dir.length();
        let mut walk = LeafWalk::new(self);
        while t <= t_end {
            steps += 1;
            let (index, min, size) = walk.locate(origin + dir * t);
            let inv = 1.0 / size;
            let exit = leaf_exit(origin, dir, min, size).min(t_end).max(t);
            let cell = &self.cells[index];
            let corners = cell.corners;
            let lo = corners.iter().fold(f32::INFINITY, |a, &c| a.min(c)) as f64;
            if lo > iso {
                let candidate = sphere_step(&corners, iso, origin + dir * t, min, size, t, exit, scale);
                t = next_t(t, candidate, size / scale);
                continue;
            }
            let found = match cell.jump() {
                // The trilinear reconstruction, shifted by `iso`.
                None => {
                    let at = |s: f64| {
                        trilinear(
                            &corners,
                            ((origin + dir * s - min) * inv).clamp(DVec3::ZERO, DVec3::ONE),
                        ) - iso
                    };
                    first_root(&at, t, exit)
                }
                // A jump leaf: the trilinear magnitude with the sign field's sign.
                Some(k) => {
                    let magnitudes = corners.map(f32::abs);
                    let signs = &self.jumps[k];
                    let at = |s: f64| {
                        let u = ((origin + dir * s - min) * inv).clamp(DVec3::ZERO, DVec3::ONE);
                        let m = trilinear(&magnitudes, u);
                        (if trilinear(signs, u) > 0.0 { m } else { -m }) - iso
                    };
                    if iso == 0.0 {
                        // The sign field's own cubic places the jump.
                        let sign_at =
                            |s: f64| trilinear(signs, ((origin + dir * s - min) * inv).clamp(DVec3::ZERO, DVec3::ONE));
                        first_root(&sign_at, t, exit)
                    } else {
                        first_root_sampled(&at, t, exit)
                    }
                }
            };
            if let Some(hit_t) = found {
                return (Some(hit_t), steps);
            }
            t = next_t(t, exit, size / scale);
        }
        (None, steps)
    }
}

/// The leaf walk's state: the path from the root to the current leaf.
struct LeafWalk<'a> {
    adf: &'a Adf,
    /// `(cell index, world min, size)` from the root down; `path[..len]` is live.
    path: [(usize, DVec3, f64); MAX_SUPPORTED_DEPTH as usize + 1],
    len: usize,
}

impl<'a> LeafWalk<'a> {
    fn new(adf: &'a Adf) -> Self {
        let mut path = [(0, DVec3::ZERO, 0.0); MAX_SUPPORTED_DEPTH as usize + 1];
        path[0] = (0, adf.root_min, adf.root_size);
        LeafWalk { adf, path, len: 1 }
    }

    /// The leaf containing `p`: the same leaf as [`Adf::locate`] (a point outside the
    /// root goes to the leaf it would clamp to), found from the deepest ancestor on the
    /// current path whose half-open box contains `p`.
    fn locate(&mut self, p: DVec3) -> (usize, DVec3, f64) {
        while self.len > 1 {
            let (_, min, size) = self.path[self.len - 1];
            if p.cmpge(min).all() && p.cmplt(min + DVec3::splat(size)).all() {
                break;
            }
            self.len -= 1;
        }
        let (mut index, mut min, mut size) = self.path[self.len - 1];
        loop {
            let c = &self.adf.cells[index];
            if c.is_leaf() {
                return (index, min, size);
            }
            size *= 0.5;
            index = c.children as usize + crate::tree::child_octant(p, &mut min, size);
            self.path[self.len] = (index, min, size);
            self.len += 1;
        }
    }
}

/// Where the ray leaves the box `min + [0, size]³` (the largest `t` inside it).
#[inline]
fn leaf_exit(origin: DVec3, dir: DVec3, min: DVec3, size: f64) -> f64 {
    let mut exit = f64::INFINITY;
    for a in 0..3 {
        let d = dir[a];
        if d > 0.0 {
            exit = exit.min((min[a] + size - origin[a]) / d);
        } else if d < 0.0 {
            exit = exit.min((min[a] - origin[a]) / d);
        }
    }
    exit
}

/// The first `s ∈ [a, b]` with `g(s) ≤ 0` for a function that is not a cubic (a jump
/// leaf's signed magnitude at a non-zero iso value): 16 samples, then bisection.
pub(crate) fn first_root_sampled(g: &impl Fn(f64) -> f64, a: f64, b: f64) -> Option<f64> {
    if g(a) <= 0.0 {
        return Some(a);
    }
    let n = 16;
    let mut prev = a;
    for k in 1..=n {
        let s = if k == n { b } else { a + (b - a) * k as f64 / n as f64 };
        if g(s) <= 0.0 {
            return Some(bisect(g, prev, s));
        }
        prev = s;
    }
    None
}

/// The crossing in `[l, r]` with `g(l) > 0 ≥ g(r)` on a monotone piece, to within a
/// sliver of the interval (1e-12 of its width, or the last bit): regula falsi with the
/// Illinois modification, safeguarded by bisection whenever a step fails to halve the
/// bracket. Returns the inside end of the final bracket (`g ≤ 0` there).
pub(crate) fn bisect(g: &impl Fn(f64) -> f64, mut l: f64, mut r: f64) -> f64 {
    let tol = (r - l) * 1e-12;
    let (mut gl, mut gr) = (g(l), g(r));
    let mut kept = 0i8;
    let mut bisect_next = false;
    for _ in 0..200 {
        let width = r - l;
        if width <= tol {
            break;
        }
        let mut m = if !bisect_next && gl > 0.0 && gr <= 0.0 && gl != gr {
            l + width * (gl / (gl - gr))
        } else {
            0.5 * (l + r)
        };
        if !(m > l && m < r) {
            m = 0.5 * (l + r);
            if !(m > l && m < r) {
                break;
            }
        }
        let gm = g(m);
        if gm <= 0.0 {
            r = m;
            gr = gm;
            if kept == 1 {
                gl *= 0.5;
            }
            kept = 1;
        } else {
            l = m;
            gl = gm;
            if kept == -1 {
                gr *= 0.5;
            }
            kept = -1;
        }
        bisect_next = r - l > 0.5 * width;
    }
    r
}

/// Where a walk at `t` (point `p`) in a leaf entirely above `iso` (corners `corners`,
/// box `min + [0, size]³`) may go next: the leaf's `exit`, or farther by the
/// sphere-tracing bound of its corners, `max_b (d_b − iso)(1 − 1e-7) − |p − corner_b|`,
/// computed only when it could reach past the exit (it is at most `max_b d_b − iso`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn sphere_step(
    corners: &[f32; 8],
    iso: f64,
    p: DVec3,
    min: DVec3,
    size: f64,
    t: f64,
    exit: f64,
    scale: f64,
) -> f64 {
    let hi = corners.iter().fold(f32::NEG_INFINITY, |a, &c| a.max(c)) as f64;
    // Negated so a NaN comparison keeps the exit.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(hi - iso > (exit - t) * scale) {
        return exit;
    }
    let mut bound = f64::NEG_INFINITY;
    for (b, &c) in corners.iter().enumerate() {
        bound = bound.max((c as f64 - iso) * (1.0 - 1e-7) - (p - corner_position(min, size, b)).length());
    }
    exit.max(t + bound / scale)
}

/// The next ray parameter: `candidate`, but always past `t` by a sliver of the cell so a
/// ray exactly on a cell corner cannot stall.
#[inline]
pub(crate) fn next_t(t: f64, candidate: f64, cell_t: f64) -> f64 {
    let nudge = (cell_t * 1e-9).max(t.abs() * f64::EPSILON * 4.0);
    if candidate > t + nudge {
        candidate
    } else {
        t + nudge
    }
}

/// The first `s ∈ [a, b]` with `g(s) ≤ 0` for a cubic `g` (the trilinear reconstruction
/// along a segment), or `None`.
pub(crate) fn first_root(g: &impl Fn(f64) -> f64, a: f64, b: f64) -> Option<f64> {
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
    let [_, c1, c2, c3] = cubic_coefficients(g0, g1, g2, g3);
    // Critical points: 3 c3 u² + 2 c2 u + c1 = 0.
    let (cuts, n) = monotone_cuts(c1, c2, c3);
    let cuts = &cuts[..n];
    for w in cuts.windows(2) {
        let (lo, hi) = (a + w[0] * h, a + w[1] * h);
        if g(hi) <= 0.0 {
            // g(lo) > 0 (checked at the previous piece's end) and g(hi) ≤ 0: bisect.
            return Some(bisect(g, lo, hi));
        }
    }
    None
}

/// Coefficients `[c0, c1, c2, c3]` of the cubic `p(u) = c0 + c1 u + c2 u² + c3 u³` on
/// `u ∈ [0, 1]` through the samples `p(0), p(⅓), p(⅔), p(1)` (Lagrange).
pub(crate) fn cubic_coefficients(g0: f64, g1: f64, g2: f64, g3: f64) -> [f64; 4] {
    [
        g0,
        (-11.0 * g0 + 18.0 * g1 - 9.0 * g2 + 2.0 * g3) / 2.0,
        (18.0 * g0 - 45.0 * g1 + 36.0 * g2 - 9.0 * g3) / 2.0,
        (-9.0 * g0 + 27.0 * g1 - 27.0 * g2 + 9.0 * g3) / 2.0,
    ]
}

/// `0`, `1` and the critical points in `(0, 1)` of the cubic `c0 + c1 u + c2 u² + c3 u³`
/// (roots of `3 c3 u² + 2 c2 u + c1`, by the cancellation-free quadratic formula), sorted:
/// the cubic is monotone between consecutive cuts. Returns the cuts and their count.
pub(crate) fn monotone_cuts(c1: f64, c2: f64, c3: f64) -> ([f64; 4], usize) {
    let mut cuts = [0.0, 1.0, 2.0, 2.0];
    let mut n = 2;
    let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, c1);
    if qa.abs() > 1e-300 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let r = disc.sqrt();
            let q = -0.5 * (qb + qb.signum() * r);
            for u in [q / qa, if q != 0.0 { qc / q } else { f64::NAN }] {
                if u > 0.0 && u < 1.0 {
                    cuts[n] = u;
                    n += 1;
                }
            }
        }
    } else if qb.abs() > 1e-300 {
        let u = -qc / qb;
        if u > 0.0 && u < 1.0 {
            cuts[n] = u;
            n += 1;
        }
    }
    cuts[..n].sort_by(f64::total_cmp);
    (cuts, n)
}
