//! Segment–triangle intersection by signed volumes.

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
/// triple products `((u − p) × (v − p)) · (q − p)` for edge `uv`. That product is
/// exactly antisymmetric in `u, v` in floating point, so two triangles sharing an edge
/// see it with exactly opposite signs. When everything is coplanar the question is
/// answered in 2D by orientation tests on a projection that keeps the triangle
/// non-degenerate; a zero-area triangle is its longest side, met in 2D on the common
/// plane or in 1D on a common line. Signs are those of plain `f64` determinants, not
/// an adaptive-precision predicate, so only exact contact at a corner is guaranteed to
/// count; contact along an edge or the face is decided up to rounding.
pub fn segment_crosses_triangle(p: DVec3, q: DVec3, [a, b, c]: [DVec3; 3]) -> bool {
    // An endpoint on a corner touches; decided here exactly, since the rounded triple
    // products below need not vanish for it.
    if [a, b, c].contains(&p) || [a, b, c].contains(&q) {
        return true;
    }
    let normal = (b - a).cross(c - a);
    if normal == DVec3::ZERO {
        let (u, v) = longest_side([a, b, c]);
        return segments_meet(p, q, u, v);
    }
    let side_p = orient_3d(a, b, c, p);
    let side_q = orient_3d(a, b, c, q);
    if (side_p > 0.0 && side_q > 0.0) || (side_p < 0.0 && side_q < 0.0) {
        return false;
    }
    if side_p == 0.0 && side_q == 0.0 {
        let k = largest_axis(normal);
        return segment_meets_triangle_2d(drop_axis(p, k), drop_axis(q, k), [a, b, c].map(|x| drop_axis(x, k)));
    }
    let edge_sides = [line_side(p, q, a, b), line_side(p, q, b, c), line_side(p, q, c, a)];
    edge_sides.iter().all(|&s| s >= 0.0) || edge_sides.iter().all(|&s| s <= 0.0)
}

/// Six times the signed volume of the tetrahedron `(a, b, c, d)`, anchored at `d` so
/// it is exactly zero when `d` is one of the corners.
#[inline]
fn orient_3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (a - d).dot((b - d).cross(c - d))
}

/// Six times the signed volume of `(u, v, q)` seen from `p`: the side of the directed
/// line `p → q` on which edge `u → v` passes. Exactly antisymmetric in `u, v`.
#[inline]
fn line_side(p: DVec3, q: DVec3, u: DVec3, v: DVec3) -> f64 {
    (u - p).cross(v - p).dot(q - p)
}

/// The two corners farthest apart: a degenerate triangle is that segment.
fn longest_side(t: [DVec3; 3]) -> (DVec3, DVec3) {
    let sides = [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    sides.into_iter().fold((t[0], t[0]), |best, (u, v)| {
        if (v - u).length_squared() > (best.1 - best.0).length_squared() {
            (u, v)
        } else {
            best
        }
    })
}

/// Whether two closed 3D segments share a point.
fn segments_meet(p: DVec3, q: DVec3, u: DVec3, v: DVec3) -> bool {
    if line_side(p, q, u, v) != 0.0 {
        return false; // not coplanar
    }
    let normal = (q - p).cross(v - u);
    if normal != DVec3::ZERO {
        let k = largest_axis(normal);
        return segments_meet_2d(drop_axis(p, k), drop_axis(q, k), drop_axis(u, k), drop_axis(v, k));
    }
    // Parallel, or one or both segments are points: they meet only on a common line.
    let (origin, direction) = if (q - p).length_squared() >= (v - u).length_squared() {
        (p, q - p)
    } else {
        (u, v - u)
    };
    if direction == DVec3::ZERO {
        return p == u;
    }
    if [p, q, u, v]
        .iter()
        .any(|&x| (x - origin).cross(direction) != DVec3::ZERO)
    {
        return false;
    }
    let k = largest_axis(direction);
    p[k].min(q[k]) <= u[k].max(v[k]) && u[k].min(v[k]) <= p[k].max(q[k])
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

/// Twice the signed area of `(a, b, c)`.
#[inline]
fn orient_2d(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
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
