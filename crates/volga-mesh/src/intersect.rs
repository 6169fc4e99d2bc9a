//! Conservative triangle–triangle intersection by separating axes.

use glam::DVec3;

/// Whether two closed triangles may share a point: `false` only when a separating axis
/// proves a gap wider than `tolerance` (world units) between them, so touching and
/// nearly touching pairs count as intersecting.
///
/// The candidate axes are both normals, the nine cross products of an edge of each
/// (Möller's test; Eberly, "Intersection of Convex Objects: The Method of Separating
/// Axes") and, for (nearly) coplanar pairs, the six in-plane edge normals. Every
/// coordinate is taken relative to `t[0]`, so the test keeps its precision far from
/// the origin. Degenerate triangles (zero-length axes) are handled: an axis of zero
/// length is skipped, never trusted.
pub fn triangles_may_intersect(t: [DVec3; 3], s: [DVec3; 3], tolerance: f64) -> bool {
    let o = t[0];
    let t = t.map(|v| v - o);
    let s = s.map(|v| v - o);
    let te = [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
    let se = [s[1] - s[0], s[2] - s[1], s[0] - s[2]];
    let tn = te[0].cross(te[1]);
    let sn = se[0].cross(se[1]);
    let separates = |axis: DVec3| -> bool {
        let length = axis.length();
        if length.is_nan() || length <= 0.0 || !length.is_finite() {
            return false;
        }
        let project = |tri: &[DVec3; 3]| {
            let d = [axis.dot(tri[0]), axis.dot(tri[1]), axis.dot(tri[2])];
            (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]))
        };
        let (t_lo, t_hi) = project(&t);
        let (s_lo, s_hi) = project(&s);
        let gap = tolerance * length;
        s_lo > t_hi + gap || t_lo > s_hi + gap
    };
    if separates(tn) || separates(sn) {
        return false;
    }
    for a in te {
        for b in se {
            if separates(a.cross(b)) {
                return false;
            }
        }
    }
    for e in te {
        if separates(tn.cross(e)) {
            return false;
        }
    }
    for e in se {
        if separates(sn.cross(e)) {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: [DVec3; 3] = [DVec3::ZERO, DVec3::X, DVec3::Y];

    #[test]
    fn crossing_touching_and_apart() {
        // A triangle piercing T.
        let pierce = [
            DVec3::new(0.2, 0.2, -1.0),
            DVec3::new(0.2, 0.2, 1.0),
            DVec3::new(0.3, 0.1, 1.0),
        ];
        assert!(triangles_may_intersect(T, pierce, 0.0));
        // Touching at one point.
        let touch = [
            DVec3::new(0.2, 0.2, 0.0),
            DVec3::new(0.2, 0.2, 1.0),
            DVec3::new(0.3, 0.1, 1.0),
        ];
        assert!(triangles_may_intersect(T, touch, 0.0));
        // Above it, 0.1 apart: separated unless the tolerance covers the gap.
        let above = [
            DVec3::new(0.2, 0.2, 0.1),
            DVec3::new(0.2, 0.2, 1.0),
            DVec3::new(0.3, 0.1, 1.0),
        ];
        assert!(!triangles_may_intersect(T, above, 0.0));
        assert!(triangles_may_intersect(T, above, 0.2));
        // Coplanar: overlapping, and side by side with a gap.
        let overlap = [
            DVec3::new(0.1, 0.1, 0.0),
            DVec3::new(2.0, 0.1, 0.0),
            DVec3::new(0.1, 2.0, 0.0),
        ];
        assert!(triangles_may_intersect(T, overlap, 0.0));
        let beside = [
            DVec3::new(0.6, 0.6, 0.0),
            DVec3::new(2.0, 0.6, 0.0),
            DVec3::new(0.6, 2.0, 0.0),
        ];
        assert!(!triangles_may_intersect(T, beside, 0.0));
    }

    #[test]
    fn far_from_the_origin() {
        let o = DVec3::splat(1e6);
        let t = T.map(|v| v + o);
        let apart = [
            DVec3::new(0.2, 0.2, 1e-6),
            DVec3::new(0.2, 0.2, 1.0),
            DVec3::new(0.3, 0.1, 1.0),
        ]
        .map(|v| v + o);
        assert!(!triangles_may_intersect(t, apart, 1e-9));
        let pierce = [
            DVec3::new(0.2, 0.2, -1e-6),
            DVec3::new(0.2, 0.2, 1.0),
            DVec3::new(0.3, 0.1, 1.0),
        ]
        .map(|v| v + o);
        assert!(triangles_may_intersect(t, pierce, 0.0));
    }

    #[test]
    fn degenerate_triangles_are_never_proven_apart_by_a_zero_axis() {
        let point = [DVec3::new(0.2, 0.2, 0.0); 3];
        assert!(triangles_may_intersect(T, point, 0.0));
        let far_point = [DVec3::new(5.0, 5.0, 5.0); 3];
        assert!(!triangles_may_intersect(T, far_point, 0.0));
    }
}
