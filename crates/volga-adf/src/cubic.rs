//! The trilinear reconstruction along a ray segment inside one leaf, as a cubic, and its
//! first root: the inner step of the indexed walk (module `walk`) in every leaf that may
//! hold the surface.
//!
//! The reference walk (`Adf::first_crossing_by_descent`) samples the trilinear cell at 4
//! points of the segment and fits the cubic through them. Here the coefficients come from
//! the 8 corners directly (the products of the 3 linear coordinates, 4 linear then 2
//! quadratic then 1 cubic interpolation), and a segment whose cubic has positive
//! Bernstein coefficients is rejected without splitting it at its critical points: by the
//! convex hull property the cubic is positive on all of it.

use glam::DVec3;

use crate::ray::monotone_cuts;

/// Power coefficients `[c0, c1, c2, c3]` of `λ ↦ trilinear(c, u0 + λ·du)`, `λ ∈ [0, 1]`.
/// `c0` is computed with the operations of `tree::trilinear`, so it equals the
/// reconstruction at `u0` bit for bit.
pub(crate) fn trilinear_cubic(c: &[f32; 8], u0: DVec3, du: DVec3) -> [f64; 4] {
    let c = c.map(|v| v as f64);
    // Along x, the 4 edges (y, z) = 00, 10, 01, 11: linear in λ.
    let lin = |lo: f64, hi: f64| [lo + (hi - lo) * u0.x, (hi - lo) * du.x];
    let (x00, x10, x01, x11) = (lin(c[0], c[1]), lin(c[2], c[3]), lin(c[4], c[5]), lin(c[6], c[7]));
    // Along y: a + (b − a)(y0 + dy λ), quadratic.
    let quad = |a: [f64; 2], b: [f64; 2]| {
        let d = [b[0] - a[0], b[1] - a[1]];
        [a[0] + d[0] * u0.y, a[1] + d[0] * du.y + d[1] * u0.y, d[1] * du.y]
    };
    let (y0, y1) = (quad(x00, x10), quad(x01, x11));
    // Along z: cubic.
    let d = [y1[0] - y0[0], y1[1] - y0[1], y1[2] - y0[2]];
    [
        y0[0] + d[0] * u0.z,
        y0[1] + d[0] * du.z + d[1] * u0.z,
        y0[2] + d[1] * du.z + d[2] * u0.z,
        d[2] * du.z,
    ]
}

/// The first `s ∈ [a, b]` where the cubic `c0 + c1 λ + c2 λ² + c3 λ³`, `λ = (s − a)/(b − a)`,
/// is ≤ 0, or `None`. `a` itself when `c0 ≤ 0`. Positive Bernstein coefficients (beyond
/// a rounding margin) prove there is none; otherwise the cubic is split into monotone
/// pieces at its critical points and the first downward crossing refined
/// ([`newton_on_piece`]).
pub(crate) fn first_root_of_cubic(c: [f64; 4], a: f64, b: f64) -> Option<f64> {
    let [c0, c1, c2, c3] = c;
    if c0 <= 0.0 {
        return Some(a);
    }
    if b <= a {
        return None;
    }
    let margin = 1e-12 * (c0.abs() + c1.abs() + c2.abs() + c3.abs());
    let b1 = c0 + c1 / 3.0;
    let b2 = c0 + (2.0 * c1 + c2) / 3.0;
    let b3 = c0 + c1 + c2 + c3;
    if b1 > margin && b2 > margin && b3 > margin {
        return None;
    }
    let poly = |u: f64| c0 + u * (c1 + u * (c2 + u * c3));
    let (cuts, m) = monotone_cuts(c1, c2, c3);
    let h = b - a;
    for w in cuts[..m].windows(2) {
        if poly(w[1]) <= 0.0 {
            let u = newton_on_piece(&poly, |u| c1 + u * (2.0 * c2 + u * 3.0 * c3), w[0], w[1]);
            return Some((a + u * h).min(b));
        }
    }
    None
}

/// The crossing of a monotone piece `[l, r]` of a polynomial `p` with `p(l) > 0 ≥ p(r)`, to
/// within 1e-12 of the piece: Newton steps from the regula falsi point, kept inside the
/// bracket (bisection when a step leaves it), and, once a step is below the tolerance, one
/// probe just past it on the other side to close the bracket. Returns the inside end of
/// the final bracket (`p ≤ 0` there), like `ray::bisect`, in fewer evaluations (quadratic
/// convergence on a simple root).
pub(crate) fn newton_on_piece(p: &impl Fn(f64) -> f64, dp: impl Fn(f64) -> f64, mut l: f64, mut r: f64) -> f64 {
    let tol = (r - l) * 1e-12;
    let (pl, pr) = (p(l), p(r));
    let mut x = if pl > 0.0 && pr <= 0.0 && pl != pr {
        l + (r - l) * (pl / (pl - pr))
    } else {
        0.5 * (l + r)
    };
    for _ in 0..100 {
        if !(x > l && x < r) {
            x = 0.5 * (l + r);
            if !(x > l && x < r) {
                break;
            }
        }
        let v = p(x);
        if v <= 0.0 {
            r = x;
        } else {
            l = x;
        }
        if r - l <= tol {
            break;
        }
        let step = v / dp(x);
        let mut next = x - step;
        if !(next > l && next < r && step.is_finite()) {
            next = 0.5 * (l + r);
        } else if step.abs() < tol {
            // Converged: probe one tolerance past the root to close the bracket.
            next = if v > 0.0 { (x + tol).min(r) } else { (x - tol).max(l) };
        }
        x = next;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Rng;
    use crate::tree::trilinear;

    #[test]
    fn the_cubic_is_the_trilinear_cell_along_the_segment() {
        let mut rng = Rng(77);
        for _ in 0..2000 {
            let c: [f32; 8] = std::array::from_fn(|_| (rng.next() * 2.0 - 1.0) as f32);
            let (u0, u1) = (rng.point(), rng.point());
            let k = trilinear_cubic(&c, u0, u1 - u0);
            assert_eq!(k[0], trilinear(&c, u0), "c0 is the reconstruction at u0 bit for bit");
            for j in 0..=8 {
                let l = j as f64 / 8.0;
                let exact = trilinear(&c, u0 + (u1 - u0) * l);
                let poly = k[0] + l * (k[1] + l * (k[2] + l * k[3]));
                assert!((poly - exact).abs() < 1e-12, "{poly} vs {exact}");
            }
        }
    }

    /// The first root against dense sampling: no root is missed, none is invented, and
    /// the root found is the first one.
    #[test]
    fn the_first_root_against_dense_sampling() {
        let mut rng = Rng(1234);
        let samples = 20_000;
        for case in 0..3000 {
            // Cubics through random values at 0, ⅓, ⅔, 1 with every sign pattern,
            // some barely touching zero.
            let v: [f64; 4] = std::array::from_fn(|_| rng.next() * 2.0 - 0.6);
            let k = crate::ray::cubic_coefficients(v[0], v[1], v[2], v[3]);
            let p = |l: f64| k[0] + l * (k[1] + l * (k[2] + l * k[3]));
            let (a, b) = (1.0 + case as f64, 3.0 + case as f64);
            let found = first_root_of_cubic(k, a, b);
            let first = (0..=samples).map(|j| j as f64 / samples as f64).find(|&l| p(l) <= 0.0);
            match (found, first) {
                (Some(s), Some(l)) => {
                    let u = (s - a) / (b - a);
                    assert!(p(u) <= 1e-12, "case {case}: p({u}) = {}", p(u));
                    // No sample before the root found is ≤ 0 (up to one sample's width).
                    assert!(u <= l + 1.0 / samples as f64, "case {case}: root {u} after sample {l}");
                }
                (None, None) => {}
                (Some(s), None) => {
                    // Only a root between samples: the cubic dips below 0 there.
                    let u = (s - a) / (b - a);
                    assert!(p(u) <= 0.0, "case {case}: invented root at {u}");
                }
                (None, Some(l)) => panic!("case {case}: missed the root near {l}"),
            }
        }
    }

    #[test]
    fn newton_refines_to_the_tolerance_of_the_piece() {
        // (u − 0.3)(u + 2)(u + 3) on [0, 1]: one root, 0.3.
        let p = |u: f64| (u - 0.3) * (u + 2.0) * (u + 3.0);
        let dp = |u: f64| (u + 2.0) * (u + 3.0) + (u - 0.3) * (2.0 * u + 5.0);
        // Decreasing through the root: negate so p(l) > 0 ≥ p(r).
        let r = newton_on_piece(&|u| -p(u), |u| -dp(u), 0.0, 1.0);
        assert!(-p(r) <= 0.0 && (r - 0.3).abs() <= 1e-12, "{r}");
    }
}
