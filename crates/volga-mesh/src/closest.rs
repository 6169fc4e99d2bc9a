//! Closest point on a triangle, with the feature (vertex, edge or face) it lies on.

use glam::DVec3;

/// Which part of a triangle `[a, b, c]` a closest point lies on.
///
/// Corners are numbered 0, 1, 2 as given; edge `k` runs from corner `k` to corner
/// `(k + 1) % 3` (0 = ab, 1 = bc, 2 = ca). The feature decides the sign of a distance
/// near the surface and which cylinder or sphere a voxelizer uses (Huang et al. 1998).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feature {
    /// Corner `k` (0, 1 or 2) itself. Where corners coincide, the first edge (in the order
    /// 0, 1, 2) that reaches the point names it: a triangle collapsed to a point gives
    /// `Vertex(0)`.
    Vertex(usize),
    /// The interior of edge `k` (0 = ab, 1 = bc, 2 = ca), strictly between its corners.
    /// Degenerate triangles, which have no face, answer with edges and vertices only.
    Edge(usize),
    /// Strictly inside the triangle: the point is the orthogonal projection onto its
    /// plane. Never reported for a degenerate triangle (sine of its largest angle
    /// `≤ 3e-8`).
    Face,
}

/// The point of the closed segment `[start, end]` nearest to `p`, and its parameter
/// `t ∈ [0, 1]` (`start + t·(end − start)`). A zero-length segment gives `t = 0`.
#[inline]
pub fn closest_point_on_segment(p: DVec3, start: DVec3, end: DVec3) -> (DVec3, f64) {
    let direction = end - start;
    let length_squared = direction.length_squared();
    if length_squared == 0.0 {
        return (start, 0.0);
    }
    let t = ((p - start).dot(direction) / length_squared).clamp(0.0, 1.0);
    // Land exactly on the corners at the ends, so Vertex features carry exact points.
    let point = if t == 0.0 {
        start
    } else if t == 1.0 {
        end
    } else {
        start + direction * t
    };
    (point, t)
}

/// Below this sine of its largest angle a triangle counts as degenerate (collinear up
/// to rounding) and is answered from its edges: ≈ 2√ε, which balances the two errors
/// described in [`closest_point_on_triangle`].
const DEGENERATE_SINE: f64 = 3e-8;

/// The point of the closed triangle `[a, b, c]` nearest to `p` and the feature it lies on.
///
/// This is the direct formulation of Ericson, *Real-Time Collision Detection* (2005),
/// §5.1.5: if `p` projects inside the triangle the answer is the projection (face);
/// otherwise it is the nearest of the closest points on the three edges. We prefer it
/// to the Voronoi-region version of the same section because it degrades gracefully:
/// the region tests there divide by `|n|²`, which is zero or swamped by cancellation
/// for degenerate and sliver triangles, whereas here a degenerate triangle simply has
/// no face candidate and its answer comes from the edges (segments or a point), with no
/// NaN. The inside test uses the signs of `n · ((v_{k+1} − v_k) × (p − v_k))`, which
/// equal those of the projection's barycentric coordinates; a projection exactly on an
/// edge is left to the edge candidate, so `Face` means strictly inside.
///
/// **Accuracy.** Vertex and edge answers are exact up to rounding. The face answer
/// depends on the normal, computed at the corner of the largest angle θ (the best
/// conditioned choice), whose direction is good to about `ε / sin θ`: the distance is
/// off by at most about `ε·L / sin θ` for a triangle of longest edge `L`. When
/// `sin θ ≤ 3e-8` the triangle is treated as degenerate and answered from its edges,
/// which is off by at most its height (below `1e-8·L`). So every answer is within
/// about `3e-8·L` of exact, and within rounding for well-shaped triangles.
///
/// Differences are taken relative to a corner, so a triangle far from the origin (1e6)
/// keeps the precision of its own size.
pub fn closest_point_on_triangle(p: DVec3, triangle: [DVec3; 3]) -> (DVec3, Feature) {
    closest_point_with_frame(p, triangle, FaceFrame::new(triangle).as_ref())
}

/// [`closest_point_on_triangle`] given the triangle's [`FaceFrame`] (`None` for a
/// degenerate triangle), prepared once for many queries: the same arithmetic on the
/// same values, so the same answer bit for bit.
#[inline]
pub fn closest_point_with_frame(p: DVec3, triangle: [DVec3; 3], frame: Option<&FaceFrame>) -> (DVec3, Feature) {
    if let Some(point) = frame.and_then(|f| f.project(p)) {
        return (point, Feature::Face);
    }
    let mut best = (triangle[0], Feature::Vertex(0));
    let mut best_distance_squared = f64::INFINITY;
    for edge in 0..3 {
        let (point, t) = closest_point_on_segment(p, triangle[edge], triangle[(edge + 1) % 3]);
        let distance_squared = (p - point).length_squared();
        if distance_squared < best_distance_squared {
            best_distance_squared = distance_squared;
            let feature = if t == 0.0 {
                Feature::Vertex(edge)
            } else if t == 1.0 {
                Feature::Vertex((edge + 1) % 3)
            } else {
                Feature::Edge(edge)
            };
            best = (point, feature);
        }
    }
    best
}

/// The per-triangle part of [`closest_point_on_triangle`]'s face test: the corner
/// opposite the longest edge, the two edges from it (in cyclic order) and their cross
/// product. A triangle has one unless it is degenerate (sine of its largest angle
/// `≤ 3e-8`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceFrame {
    origin: DVec3,
    u: DVec3,
    v: DVec3,
    v_minus_u: DVec3,
    normal: DVec3,
    normal_length_squared: f64,
}

impl FaceFrame {
    /// The frame of `triangle`; `None` when it is degenerate.
    #[inline]
    pub fn new(triangle: [DVec3; 3]) -> Option<FaceFrame> {
        // Work from the corner opposite the longest edge, keeping the cyclic order.
        let edge_length_squared = |k: usize| (triangle[(k + 1) % 3] - triangle[k]).length_squared();
        let (l0, l1, l2) = (edge_length_squared(0), edge_length_squared(1), edge_length_squared(2));
        let longest = if l0 >= l1 && l0 >= l2 {
            0
        } else if l1 >= l2 {
            1
        } else {
            2
        };
        let origin = triangle[(longest + 2) % 3];
        let u = triangle[longest] - origin;
        let v = triangle[(longest + 1) % 3] - origin;
        let normal = u.cross(v);
        let normal_length_squared = normal.length_squared();
        let scale = u.length_squared() * v.length_squared();
        (normal_length_squared > DEGENERATE_SINE * DEGENERATE_SINE * scale && normal_length_squared.is_finite())
            .then_some(FaceFrame {
                origin,
                u,
                v,
                v_minus_u: v - u,
                normal,
                normal_length_squared,
            })
    }

    /// The projection of `p` onto the triangle's plane if it lies strictly inside.
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<DVec3> {
        let FaceFrame {
            origin,
            u,
            v,
            v_minus_u,
            normal,
            normal_length_squared,
        } = *self;
        let po = p - origin;
        let inside = normal.dot(u.cross(po)) > 0.0
            && normal.dot(v_minus_u.cross(po - u)) > 0.0
            && normal.dot((-v).cross(po - v)) > 0.0;
        inside.then(|| origin + (po - normal * (normal.dot(po) / normal_length_squared)))
    }
}

/// Squared distance from `p` to the closed triangle (see [`closest_point_on_triangle`]).
#[inline]
pub fn point_triangle_distance_squared(p: DVec3, triangle: [DVec3; 3]) -> f64 {
    let (q, _) = closest_point_on_triangle(p, triangle);
    (p - q).length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [DVec3; 3] = [DVec3::ZERO, DVec3::X, DVec3::Y];

    fn check(p: DVec3, tri: [DVec3; 3], expected_point: DVec3, expected_feature: Feature) {
        let (q, f) = closest_point_on_triangle(p, tri);
        assert_eq!(f, expected_feature, "feature for {p}");
        assert!((q - expected_point).length() < 1e-12, "{q} != {expected_point} for {p}");
    }

    #[test]
    fn regions_of_a_right_triangle() {
        check(
            DVec3::new(0.25, 0.25, 1.0),
            TRI,
            DVec3::new(0.25, 0.25, 0.0),
            Feature::Face,
        );
        check(DVec3::new(-1.0, -1.0, 0.5), TRI, DVec3::ZERO, Feature::Vertex(0));
        check(DVec3::new(2.0, -1.0, 0.0), TRI, DVec3::X, Feature::Vertex(1));
        check(DVec3::new(-0.5, 3.0, 0.0), TRI, DVec3::Y, Feature::Vertex(2));
        check(
            DVec3::new(0.5, -1.0, 0.0),
            TRI,
            DVec3::new(0.5, 0.0, 0.0),
            Feature::Edge(0),
        );
        check(
            DVec3::new(1.0, 1.0, -2.0),
            TRI,
            DVec3::new(0.5, 0.5, 0.0),
            Feature::Edge(1),
        );
        check(
            DVec3::new(-1.0, 0.5, 0.0),
            TRI,
            DVec3::new(0.0, 0.5, 0.0),
            Feature::Edge(2),
        );
        // Exactly on an edge and on a vertex.
        check(
            DVec3::new(0.5, 0.0, 0.0),
            TRI,
            DVec3::new(0.5, 0.0, 0.0),
            Feature::Edge(0),
        );
        check(DVec3::X, TRI, DVec3::X, Feature::Vertex(1));
    }

    #[test]
    fn degenerate_triangles_fall_back_to_segments() {
        let point = [DVec3::ONE; 3];
        check(DVec3::ZERO, point, DVec3::ONE, Feature::Vertex(0));
        let collinear = [DVec3::ZERO, DVec3::X * 2.0, DVec3::X];
        check(
            DVec3::new(1.5, 1.0, 0.0),
            collinear,
            DVec3::new(1.5, 0.0, 0.0),
            Feature::Edge(0),
        );
        check(DVec3::new(3.0, 0.0, 0.0), collinear, DVec3::X * 2.0, Feature::Vertex(1));
        let repeated = [DVec3::ZERO, DVec3::ZERO, DVec3::Y];
        let (q, _) = closest_point_on_triangle(DVec3::new(1.0, 0.5, 0.0), repeated);
        assert_eq!(q, DVec3::new(0.0, 0.5, 0.0));
    }

    #[test]
    fn face_frames_exist_only_for_triangles_with_a_face_and_keep_their_precision_far_away() {
        let nan = DVec3::splat(f64::NAN);
        for degenerate in [
            [DVec3::ONE; 3],
            [DVec3::ZERO, DVec3::X * 2.0, DVec3::X],
            [DVec3::ZERO, DVec3::ZERO, DVec3::Y],
            [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-9, 0.0)], // sine ≈ 4e-9
            [DVec3::ZERO, DVec3::X, nan],
            [DVec3::ZERO, DVec3::X * f64::INFINITY, DVec3::Y],
        ] {
            assert!(FaceFrame::new(degenerate).is_none(), "{degenerate:?}");
        }
        assert!(FaceFrame::new([DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-6, 0.0)]).is_some());

        // One frame prepared far from the origin answers many points as at the origin.
        let offset = DVec3::new(1e6, -2e6, 3e6);
        let tri = [DVec3::ZERO, DVec3::new(1.0, 0.2, 0.0), DVec3::new(0.3, 1.0, 0.4)];
        let far = tri.map(|v| v + offset);
        let frame = FaceFrame::new(far).expect("a face");
        let mut faces = 0;
        for k in 0..200 {
            let t = k as f64;
            // Barycentric weights in [−0.2, 1.2] (inside and outside the face), lifted off it.
            let (u, v) = (0.7 * (t * 0.37).sin().abs() - 0.2, 0.7 * (t * 0.71).cos().abs() - 0.2);
            let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            let p = tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v + normal * (t * 0.13).sin();
            let (q_near, f_near) = closest_point_on_triangle(p, tri);
            let (q_far, f_far) = closest_point_with_frame(p + offset, far, Some(&frame));
            assert_eq!((q_far, f_far), closest_point_on_triangle(p + offset, far));
            assert!(
                (q_far - offset - q_near).length() < 1e-8,
                "{p}: {q_far} against {q_near}"
            );
            if f_near == Feature::Face {
                faces += 1;
                assert_eq!(f_far, Feature::Face, "{p}");
            }
        }
        assert!(faces > 20, "{faces} face answers");
    }
}
