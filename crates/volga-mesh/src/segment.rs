//! Segment–triangle intersection by signed volumes, with exact signs.

use glam::{DVec2, DVec3};

/// Whether the closed segment `[p, q]` and the closed triangle share a point.
///
/// **Tie rule: touching counts.** An endpoint on the triangle, a segment through an
/// edge or a vertex, and a segment lying in the triangle's plane and meeting it all
/// return `true`. (Counting crossings for a parity inside test would therefore count a
/// ray through a shared edge twice; volga's inside test is the winding number.)
///
/// Method: the signed-volume form of the segment–triangle test (Ericson, *Real-Time
/// Collision Detection*, §5.3.4–5.3.6; the orientation reading of Möller–Trumbore):
/// `p` and `q` must not lie strictly on one side of the triangle's plane, and the line
/// `pq` must pass on the same side (or on) each of the three edges, measured by the
/// triple products `((u − p) × (v − p)) · (q − p)` for edge `uv`. Two triangles sharing
/// an edge see it with exactly opposite signs. When everything is coplanar the question
/// is answered in 2D on a projection that keeps the triangle non-degenerate; a
/// zero-area triangle is the segment between its extreme corners, met where the two
/// segments are coplanar and meet in every axis projection.
///
/// **Exact.** Every sign comes from Shewchuk's adaptive orientation predicates (the
/// `robust` crate; Shewchuk 1997), which return the sign of the exact determinant of
/// the `f64` inputs, and every other decision is a comparison of input coordinates. So
/// the answer is the exact one for the given coordinates: contact along an edge or the
/// face, or a segment a few ulps off the triangle's plane, is decided without rounding.
pub fn segment_crosses_triangle(p: DVec3, q: DVec3, [a, b, c]: [DVec3; 3]) -> bool {
    if [a, b, c].contains(&p) || [a, b, c].contains(&q) {
        return true;
    }
    let Some(k) = plane_axis([a, b, c]) else {
        let (u, v) = extreme_corners([a, b, c]);
        return segments_meet(p, q, u, v);
    };
    let side_p = orient_3d(a, b, c, p);
    let side_q = orient_3d(a, b, c, q);
    if (side_p > 0.0 && side_q > 0.0) || (side_p < 0.0 && side_q < 0.0) {
        return false;
    }
    if side_p == 0.0 && side_q == 0.0 {
        return segment_meets_triangle_2d(drop_axis(p, k), drop_axis(q, k), [a, b, c].map(|x| drop_axis(x, k)));
    }
    let edge_sides = [line_side(p, q, a, b), line_side(p, q, b, c), line_side(p, q, c, a)];
    edge_sides.iter().all(|&s| s >= 0.0) || edge_sides.iter().all(|&s| s <= 0.0)
}

fn coord3(x: DVec3) -> robust::Coord3D<f64> {
    robust::Coord3D { x: x.x, y: x.y, z: x.z }
}

/// A value with the exact sign of `(a − d)·((b − d) × (c − d))`, six times the signed
/// volume of the tetrahedron `(a, b, c, d)`.
#[inline]
fn orient_3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    robust::orient3d(coord3(a), coord3(b), coord3(c), coord3(d))
}

/// A value with the exact sign of `((u − p) × (v − p)) · (q − p)`: the side of the
/// directed line `p → q` on which edge `u → v` passes. Exactly antisymmetric in `u, v`.
#[inline]
fn line_side(p: DVec3, q: DVec3, u: DVec3, v: DVec3) -> f64 {
    orient_3d(u, v, q, p)
}

/// An axis along which the triangle projects to a triangle of non-zero area (exactly),
/// trying the axis of the largest rounded normal component first; `None` when the
/// three corners are collinear.
fn plane_axis(t: [DVec3; 3]) -> Option<usize> {
    let first = largest_axis((t[1] - t[0]).cross(t[2] - t[0]));
    [first, (first + 1) % 3, (first + 2) % 3]
        .into_iter()
        .find(|&k| orient_2d(drop_axis(t[0], k), drop_axis(t[1], k), drop_axis(t[2], k)) != 0.0)
}

/// The lexicographically smallest and largest corners: for collinear corners, the
/// segment that is their union.
fn extreme_corners(t: [DVec3; 3]) -> (DVec3, DVec3) {
    let key = |x: &DVec3| x.to_array();
    let lt = |x: &DVec3, y: &DVec3| key(x).partial_cmp(&key(y)) == Some(std::cmp::Ordering::Less);
    let (mut lo, mut hi) = (t[0], t[0]);
    for x in &t[1..] {
        if lt(x, &lo) {
            lo = *x;
        }
        if lt(&hi, x) {
            hi = *x;
        }
    }
    (lo, hi)
}

/// Whether two closed 3D segments share a point: they must be coplanar (an exact zero
/// volume), and then they meet exactly when their projections along all three axes
/// meet. (Meeting segments meet in every projection; segments that do not meet stay
/// apart in a projection that is one-to-one on a plane holding both, and one of the
/// three axis projections is.)
fn segments_meet(p: DVec3, q: DVec3, u: DVec3, v: DVec3) -> bool {
    orient_3d(p, q, u, v) == 0.0
        && (0..3).all(|k| segments_meet_2d(drop_axis(p, k), drop_axis(q, k), drop_axis(u, k), drop_axis(v, k)))
}

/// The axis of the largest `|component|` (the first on ties).
#[inline]
fn largest_axis(v: DVec3) -> usize {
    let a = v.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

#[inline]
fn drop_axis(x: DVec3, axis: usize) -> DVec2 {
    match axis {
        0 => DVec2::new(x.y, x.z),
        1 => DVec2::new(x.z, x.x),
        _ => DVec2::new(x.x, x.y),
    }
}

/// A value with the exact sign of twice the signed area of `(a, b, c)`.
#[inline]
fn orient_2d(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    let coord = |x: DVec2| robust::Coord { x: x.x, y: x.y };
    robust::orient2d(coord(a), coord(b), coord(c))
}

/// Closed 2D segment against a closed 2D triangle of non-zero area.
fn segment_meets_triangle_2d(p: DVec2, q: DVec2, t: [DVec2; 3]) -> bool {
    let inside = |x: DVec2| {
        let s = [
            orient_2d(t[0], t[1], x),
            orient_2d(t[1], t[2], x),
            orient_2d(t[2], t[0], x),
        ];
        s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
    };
    inside(p) || inside(q) || (0..3).any(|k| segments_meet_2d(p, q, t[k], t[(k + 1) % 3]))
}

/// Closed 2D segments `[p1, p2]` and `[p3, p4]` share a point (Cormen et al.,
/// *Introduction to Algorithms*, §33.1, SEGMENTS-INTERSECT; handles points as segments).
fn segments_meet_2d(p1: DVec2, p2: DVec2, p3: DVec2, p4: DVec2) -> bool {
    let d1 = orient_2d(p3, p4, p1);
    let d2 = orient_2d(p3, p4, p2);
    let d3 = orient_2d(p1, p2, p3);
    let d4 = orient_2d(p1, p2, p4);
    let straddles = |x: f64, y: f64| (x > 0.0 && y < 0.0) || (x < 0.0 && y > 0.0);
    if straddles(d1, d2) && straddles(d3, d4) {
        return true;
    }
    let on_segment = |a: DVec2, b: DVec2, x: DVec2| a.min(b).cmple(x).all() && x.cmple(a.max(b)).all();
    (d1 == 0.0 && on_segment(p3, p4, p1))
        || (d2 == 0.0 && on_segment(p3, p4, p2))
        || (d3 == 0.0 && on_segment(p1, p2, p3))
        || (d4 == 0.0 && on_segment(p1, p2, p4))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [DVec3; 3] = [DVec3::ZERO, DVec3::X, DVec3::Y];

    fn check(p: DVec3, q: DVec3, tri: [DVec3; 3], expected: bool) {
        assert_eq!(segment_crosses_triangle(p, q, tri), expected, "[{p}, {q}] vs {tri:?}");
        assert_eq!(segment_crosses_triangle(q, p, tri), expected, "reversed [{q}, {p}]");
        assert_eq!(
            segment_crosses_triangle(p, q, [tri[1], tri[2], tri[0]]),
            expected,
            "rotated"
        );
        assert_eq!(
            segment_crosses_triangle(p, q, [tri[0], tri[2], tri[1]]),
            expected,
            "flipped"
        );
    }

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn proper_crossings_and_misses() {
        check(v(0.2, 0.2, -1.0), v(0.2, 0.2, 1.0), TRI, true);
        check(v(0.2, 0.2, 0.5), v(0.2, 0.2, 1.0), TRI, false); // one side
        check(v(0.8, 0.8, -1.0), v(0.8, 0.8, 1.0), TRI, false); // outside the hypotenuse
        check(v(-1.0, -1.0, -1.0), v(1.0, 1.0, 1.0), TRI, true); // through a vertex
    }

    #[test]
    fn touching_counts() {
        check(v(0.2, 0.2, 0.0), v(0.2, 0.2, 1.0), TRI, true); // endpoint on the face
        check(v(0.5, 0.0, -1.0), v(0.5, 0.0, 1.0), TRI, true); // through an edge
        check(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), TRI, true); // starts at a vertex
        check(v(0.5, 0.5, -1.0), v(0.5, 0.5, 1.0), TRI, true); // through the hypotenuse
    }

    #[test]
    fn coplanar_segments() {
        check(v(-1.0, 0.2, 0.0), v(2.0, 0.2, 0.0), TRI, true); // across, endpoints outside
        check(v(0.1, 0.1, 0.0), v(0.2, 0.2, 0.0), TRI, true); // inside
        check(v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0), TRI, false);
        check(v(-1.0, 0.0, 0.0), v(-0.5, 0.0, 0.0), TRI, false); // on the edge's line, short of it
        check(v(-1.0, 0.0, 0.0), v(0.0, 0.0, 0.0), TRI, true); // reaching the vertex
    }

    #[test]
    fn signs_follow_the_triple_product() {
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        assert!(orient_3d(x, y, z, DVec3::ZERO) > 0.0); // x · (y × z) = 1
        assert!(orient_3d(y, x, z, DVec3::ZERO) < 0.0);
        assert!(line_side(DVec3::ZERO, z, x, y) > 0.0); // (x × y) · z = 1
        assert!(orient_2d(DVec2::ZERO, DVec2::X, DVec2::Y) > 0.0);
    }

    /// Segments in the plane of a triangle whose corner sits one ulp off the lattice
    /// (a lattice triangle carried to a non-dyadic grid and back): the rounded triple
    /// products of the segment are not zero, and their signs say "crosses". Exactly,
    /// the segments lie in the plane on the line `x = 1, z = 0`, which holds only the
    /// corner: the segment through it touches, the one beside it does not.
    #[test]
    fn coplanar_up_to_rounding_is_decided_exactly() {
        let corner = v(1.0, 1.0000000000000002, 0.0);
        let tri = [v(5.5, 0.0, 3.25), v(5.5, 4.0, 3.25), corner];
        assert_eq!(orient_3d(tri[0], tri[1], tri[2], v(1.0, 2.0, 0.0)), 0.0);
        check(v(1.0, 2.0, 0.0), v(1.0, 3.0, 0.0), tri, false);
        check(v(1.0, 3.0, 0.0), v(1.0, 4.0, 0.0), tri, false);
        check(v(1.0, 1.0, 0.0), v(1.0, 2.0, 0.0), tri, true);
        check(v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0), tri, false); // stops one ulp short
                                                               // Off the plane by one ulp in z: a crossing near the corner, decided exactly.
        let up = v(1.0, 1.0000000000000002, f64::EPSILON);
        check(up, v(1.0, 1.0000000000000002, -1.0), tri, true);
    }

    /// Exactly collinear corners (`a`, `4a`, `2a`: doubling is exact) whose rounded
    /// cross product is not zero: the triangle is the segment between its extremes.
    #[test]
    fn collinear_corners_that_round_to_an_area() {
        let a = v(0.1, 0.2, 0.3);
        let tri = [a, 4.0 * a, 2.0 * a];
        assert_ne!((tri[1] - tri[0]).cross(tri[2] - tri[0]), DVec3::ZERO);
        assert_eq!(plane_axis(tri), None);
        // Vertical through the middle corner (0.2, 0.4, 0.6), and one ulp beside it.
        check(v(0.2, 0.4, 1.6), v(0.2, 0.4, -0.4), tri, true);
        let beside = f64::from_bits(0.2f64.to_bits() + 1);
        check(v(beside, 0.4, 1.6), v(beside, 0.4, -0.4), tri, false);
        // Along the common line: overlapping, and beyond the far corner.
        check(8.0 * a, -8.0 * a, tri, true);
        check(8.0 * a, 16.0 * a, tri, false);
    }

    #[test]
    fn degenerate_triangles_and_segments() {
        let segment = [v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(1.0, 0.0, 0.0)];
        check(v(1.5, -1.0, 0.0), v(1.5, 1.0, 0.0), segment, true);
        check(v(1.5, -1.0, 1.0), v(1.5, 1.0, 1.0), segment, false); // skew
        check(v(3.0, 0.0, 0.0), v(4.0, 0.0, 0.0), segment, false); // collinear, apart
        check(v(2.0, 0.0, 0.0), v(4.0, 0.0, 0.0), segment, true); // collinear, touching
        let point = [v(1.0, 1.0, 1.0); 3];
        check(v(0.0, 0.0, 0.0), v(2.0, 2.0, 2.0), point, true);
        check(v(0.0, 0.0, 0.0), v(2.0, 2.0, 2.1), point, false);
        // A zero-length segment is a point.
        check(v(0.2, 0.2, 0.0), v(0.2, 0.2, 0.0), TRI, true);
        check(v(0.2, 0.2, 0.1), v(0.2, 0.2, 0.1), TRI, false);
    }
}
