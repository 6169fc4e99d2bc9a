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
pub fn solid_angle(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    if numerator == 0.0 {
        return 0.0;
    }
    2.0 * numerator.atan2(denominator)
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
}
