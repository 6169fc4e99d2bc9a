//! Solid angles and the exact generalized winding number.

use std::f64::consts::PI;

use glam::DVec3;

use crate::TriMesh;

/// Signed solid angle (steradians, in `[−2π, 2π]`) that the triangle subtends at `p`.
///
/// Van Oosterom & Strackee, "The Solid Angle of a Plane Triangle" (IEEE Trans. Biomed.
/// Eng. 1983): with `a, b, c` relative to `p` and `|·|` their lengths,
/// `tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|)`, evaluated with
/// `atan2` so every octant is right. Positive when `p` sees the triangle's back (the
/// normal `(b−a)×(c−a)` points away from `p`), so a closed outward-facing mesh sums to
/// `4π` around an inside point. Finite for every input: `p` on a corner or in the
/// triangle's plane gives `atan2(0, ·)`, and degenerate triangles give 0 away from them.
///
/// **On the triangle** (`p` in its plane, inside it: the numerator is exactly 0 and the
/// denominator negative) the result is the principal value 0, the mean of the two
/// one-sided limits ±2π, not whichever limit the sign of the zero picks; on an edge or
/// a corner it is 0 as well. So the winding number of a mesh at a point of its surface
/// is the principal value, the mean of the two sides.
#[inline]
pub fn solid_angle(p: DVec3, triangle: [DVec3; 3]) -> f64 {
    let (numerator, denominator) = half_angle_tangent(p, triangle);
    if numerator == 0.0 {
        return 0.0;
    }
    2.0 * numerator.atan2(denominator)
}

/// Van Oosterom & Strackee's numerator and denominator: `Ω/2 = arg(den + i·num)`.
#[inline]
fn half_angle_tangent(p: DVec3, [a, b, c]: [DVec3; 3]) -> (f64, f64) {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    (numerator, denominator)
}

/// A sum of triangles' solid angles that takes one `atan2` for many triangles.
///
/// `Ω_i/2 = arg z_i` with `z_i = den_i + i·num_i` ([`solid_angle`]'s terms), so a run of
/// terms sums to `arg Π z_i`, provided the true sum stays inside the principal range.
/// (The factors are taken as `1 + i·num/den`, of the same argument.) The product is kept only while its argument is proven in the open right half-plane
/// (`Re > 2⁻²⁰ |Im|`, an angle below `π/2 − 2⁻²⁰`) and each factor is too: the next
/// product's argument is then the exact sum of two angles in `(−π/2, π/2)`, at least
/// `2⁻¹⁹` from `±π`, which the product's rounding (a few units in the last place of its
/// modulus per factor, far below that margin and below the 1e-13 per term that certified
/// sums allow) cannot carry across the branch cut. A product that leaves the half-plane
/// is settled by one `atan2`; a factor outside it takes its own, as [`solid_angle`] does.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SolidAngleSum {
    /// Settled steradians.
    pub(crate) total: f64,
    re: f64,
    im: f64,
}

impl Default for SolidAngleSum {
    fn default() -> SolidAngleSum {
        SolidAngleSum {
            total: 0.0,
            re: 1.0,
            im: 0.0,
        }
    }
}

/// `2⁻²⁰`: how far inside the right half-plane a kept product and its factors must be.
const HALF_PLANE: f64 = 1.0 / 1_048_576.0;

impl SolidAngleSum {
    /// Adds the solid angle of `triangle` at `p` (as [`solid_angle`] evaluates it).
    #[inline]
    pub(crate) fn add(&mut self, p: DVec3, triangle: [DVec3; 3]) {
        let (numerator, denominator) = half_angle_tangent(p, triangle);
        self.add_half_angle(numerator, denominator);
    }

    /// Adds the solid angle `2 arg(denominator + i·numerator)`: [`half_angle_tangent`]'s
    /// terms, computed by the caller.
    #[inline]
    pub(crate) fn add_half_angle(&mut self, numerator: f64, denominator: f64) {
        self.add_half_angle_with(numerator, denominator, numerator / denominator);
    }

    /// [`SolidAngleSum::add_half_angle`] given `tangent = numerator / denominator`
    /// (computed by the caller, e.g. for many terms at once).
    #[inline]
    pub(crate) fn add_half_angle_with(&mut self, numerator: f64, denominator: f64, tangent: f64) {
        if numerator == 0.0 {
            return;
        }
        let in_half_plane = denominator > HALF_PLANE * numerator.abs();
        if !in_half_plane {
            self.total += 2.0 * numerator.atan2(denominator);
            return;
        }
        // The factor `1 + i·tan(Ω/2)`: of modulus 1 to 2²⁰ whatever the scale of the
        // coordinates, so the product neither underflows nor (rescaled) overflows.
        let re = self.re - self.im * tangent;
        let im = self.re * tangent + self.im;
        if re > HALF_PLANE * im.abs() {
            if re > 1e100 {
                // One rounding: an angle change of an ulp.
                (self.re, self.im) = (1.0, im / re);
            } else {
                (self.re, self.im) = (re, im);
            }
        } else {
            self.total += 2.0 * im.atan2(re);
            (self.re, self.im) = (1.0, 0.0);
        }
    }

    /// Moves the pending product into `total` and returns it.
    #[inline]
    pub(crate) fn settle(&mut self) -> f64 {
        if self.im != 0.0 {
            self.total += 2.0 * self.im.atan2(self.re);
        }
        (self.re, self.im) = (1.0, 0.0);
        self.total
    }
}

/// Generalized winding number of `mesh` at `p`: `Σ Ω_i / 4π` over all triangles
/// (Jacobson, Kavan & Sorkine-Hornung, "Robust Inside-Outside Segmentation using
/// Generalized Winding Numbers", SIGGRAPH 2013).
///
/// For a closed, consistently outward-oriented mesh it is 1 inside and 0 outside (up
/// to rounding); for an open mesh it varies smoothly and `≥ ½` is volga's documented
/// meaning of "inside". Undefined on the surface itself. Exact but `O(n)` per query;
/// [`crate::Bvh::winding_number`] is the fast approximation.
pub fn winding_number(mesh: &TriMesh, p: DVec3) -> f64 {
    let total: f64 = (0..mesh.triangles.len())
        .map(|i| solid_angle(p, mesh.triangle(i)))
        .sum();
    total / (4.0 * PI)
}

#[cfg(test)]
mod tests {
    use super::*;
    use volga_core::Aabb;

    #[test]
    fn octant_triangle_is_an_eighth_of_the_sphere() {
        // Seen from the origin, the triangle on the three unit axes covers one octant.
        let tri = [DVec3::X, DVec3::Y, DVec3::Z];
        assert!((solid_angle(DVec3::ZERO, tri) - 4.0 * PI / 8.0).abs() < 1e-14);
        assert!((solid_angle(DVec3::ZERO, [DVec3::X, DVec3::Z, DVec3::Y]) + 4.0 * PI / 8.0).abs() < 1e-14);
    }

    #[test]
    fn on_the_triangle_the_principal_value_is_zero() {
        let tri = [DVec3::ZERO, DVec3::X, DVec3::Y];
        for p in [DVec3::new(0.25, 0.25, 0.0), DVec3::new(0.5, 0.0, 0.0), DVec3::ZERO] {
            assert_eq!(solid_angle(p, tri), 0.0, "{p}");
            assert_eq!(solid_angle(p, [tri[0], tri[2], tri[1]]), 0.0, "{p}");
        }
        // Just off it: the one-sided limits ±2π.
        assert!((solid_angle(DVec3::new(0.25, 0.25, -1e-12), tri) - 2.0 * PI).abs() < 1e-9);
        assert!((solid_angle(DVec3::new(0.25, 0.25, 1e-12), tri) + 2.0 * PI).abs() < 1e-9);
    }

    #[test]
    fn cube_inside_outside() {
        let cube = TriMesh::from_aabb(&Aabb::new(DVec3::splat(-1.0), DVec3::ONE));
        for p in [DVec3::ZERO, DVec3::new(0.9, -0.9, 0.99), DVec3::new(-0.999, 0.5, 0.0)] {
            assert!((winding_number(&cube, p) - 1.0).abs() < 1e-12, "{p}");
        }
        for p in [
            DVec3::splat(2.0),
            DVec3::new(1.001, 0.0, 0.0),
            DVec3::new(0.0, -50.0, 3.0),
        ] {
            assert!(winding_number(&cube, p).abs() < 1e-12, "{p}");
        }
        // On a corner or a face: finite.
        assert!(winding_number(&cube, DVec3::ONE).is_finite());
        assert!(winding_number(&cube, DVec3::new(1.0, 0.2, 0.3)).is_finite());
        // On a face the principal value: the mean of inside (1) and outside (0).
        assert!((winding_number(&cube, DVec3::new(1.0, 0.2, 0.3)) - 0.5).abs() < 1e-12);
        assert!((winding_number(&cube, DVec3::new(0.25, -1.0, 0.5)) - 0.5).abs() < 1e-12);
    }

    /// Triangles seen from `p` at every solid angle: tiny and far, near the plane (`±2π`
    /// limits, denominators near 0 and negative), wrapping `p` many times over (the sum
    /// far beyond the principal range), at every scale from 1e-90 to 1e90.
    fn hard_fans(seed: u64) -> Vec<(DVec3, Vec<[DVec3; 3]>)> {
        let mut state = seed;
        let mut unit = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut cases = Vec::new();
        for case in 0..300 {
            let scale = 10f64.powi([0, -90, 90, -3, 6][case % 5]);
            let p = DVec3::new(unit(), unit(), unit()) * scale;
            let mut triangles = Vec::new();
            // A closed octahedron around `p`, several times over: 4π each.
            let r = scale * (0.01 + unit());
            let axes = [DVec3::X, DVec3::Y, DVec3::Z];
            for _ in 0..1 + case % 4 {
                for octant in 0..8 {
                    let s = |k: usize| if octant >> k & 1 == 1 { -1.0 } else { 1.0 };
                    let mut t = [p + axes[0] * s(0) * r, p + axes[1] * s(1) * r, p + axes[2] * s(2) * r];
                    if s(0) * s(1) * s(2) < 0.0 {
                        t.swap(1, 2);
                    }
                    triangles.push(t);
                }
            }
            // Triangles just above or below `p`'s plane (solid angles near ±2π), far and
            // small ones, and random ones.
            for _ in 0..case % 13 {
                let lift = scale * (unit() - 0.5) * 10f64.powi(-(unit() * 14.0) as i32);
                let w = scale * (0.5 + unit());
                let base = p + DVec3::new(0.0, 0.0, lift);
                triangles.push([
                    base + DVec3::new(-w, -w, 0.0),
                    base + DVec3::new(w, -w * unit(), 0.0),
                    base + DVec3::new(-w * unit(), w, 0.0),
                ]);
                let far = p + DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5) * scale * 100.0;
                let tiny = scale * 1e-3;
                triangles.push([far, far + DVec3::X * tiny, far + DVec3::Y * tiny * unit()]);
                let q = |u: f64, v: f64, w: f64| p + (DVec3::new(u, v, w) - 0.5) * 2.0 * scale;
                triangles.push([
                    q(unit(), unit(), unit()),
                    q(unit(), unit(), unit()),
                    q(unit(), unit(), unit()),
                ]);
            }
            cases.push((p, triangles));
        }
        cases
    }

    #[test]
    fn a_product_of_half_angles_sums_as_the_atan2s_do() {
        let mut worst = 0.0f64;
        for (p, triangles) in hard_fans(7) {
            let one_by_one: f64 = triangles.iter().map(|&t| solid_angle(p, t)).sum();
            let mut sum = SolidAngleSum::default();
            for (k, &t) in triangles.iter().enumerate() {
                sum.add(p, t);
                if k % 5 == 4 {
                    // Settling midway changes nothing either.
                    let _ = sum.settle();
                }
            }
            let product = sum.settle();
            // The certified sums allow 1e-13 per term; stay well inside it.
            let allowed = 1e-14 * triangles.len() as f64;
            let off = (product - one_by_one).abs();
            assert!(
                off <= allowed,
                "{p}: {product} vs {one_by_one} ({} triangles)",
                triangles.len()
            );
            worst = worst.max(off / triangles.len() as f64);
        }
        assert!(worst > 0.0, "the cases must exercise rounding");
    }
}
