//! Triangle–box overlap by the separating axis theorem.

use glam::DVec3;
use volga_core::Aabb;

/// Whether the closed triangle and the closed box share a point; touching counts.
///
/// Separating axis test of Akenine-Möller, "Fast 3D Triangle-Box Overlap Testing"
/// (JGT 2001): the two convex sets are disjoint iff their projections are disjoint on
/// one of 13 axes — the 3 box normals, the triangle normal, and the 9 cross products
/// of a box axis with a triangle edge. An axis separates only if the projected
/// intervals are *strictly* apart, so boundary contact is overlap.
///
/// Precision choices:
/// * The box-normal axes compare vertex coordinates with the box bounds directly, with
///   no arithmetic, so a triangle lying exactly on a box face (or touching it with a
///   vertex) always overlaps, at any coordinate magnitude.
/// * The other axes work relative to `aabb.min` (not the centre: `min + (max−min)/2`
///   rounds), so a vertex coordinate equal to a bound still maps to exactly the box's
///   own `0` or `max − min`, keeping those ties exact, and far coordinates (1e6) keep
///   the precision of the box's size.
///
/// Degenerate triangles need no special case: a zero normal or a zero edge gives a
/// zero axis, on which nothing separates, and the remaining axes are exactly those of
/// the segment–box (box normals and segment × box axes) or point–box test. An empty
/// box overlaps nothing.
pub fn triangle_box_overlap(triangle: [DVec3; 3], aabb: &Aabb) -> bool {
    if aabb.is_empty() {
        return false;
    }
    separating_axes(triangle, aabb.min, aabb.max, Contact::Overlaps)
}

/// Whether the closed triangle meets the **open** box `(min, max)` (a point strictly
/// inside): the same separating-axis test with contact allowed on a separating plane
/// (`tri_hi ≤ box_lo` or `tri_lo ≥ box_hi`), so a triangle that only touches the box's
/// boundary misses it. Same precision choices as [`triangle_box_overlap`].
pub fn triangle_meets_open_box(triangle: [DVec3; 3], min: DVec3, max: DVec3) -> bool {
    separating_axes(triangle, min, max, Contact::Separates)
}

/// Whether boundary contact counts as overlap (closed box) or separation (open box).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Contact {
    Overlaps,
    Separates,
}

fn separating_axes(triangle: [DVec3; 3], min: DVec3, max: DVec3, contact: Contact) -> bool {
    let lo = triangle[0].min(triangle[1]).min(triangle[2]);
    let hi = triangle[0].max(triangle[1]).max(triangle[2]);
    let apart = match contact {
        Contact::Overlaps => lo.cmpgt(max).any() || hi.cmplt(min).any(),
        Contact::Separates => lo.cmpge(max).any() || hi.cmple(min).any(),
    };
    if apart {
        return false;
    }
    let extent = max - min;
    let v = triangle.map(|p| p - min);
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    if separates(edges[0].cross(edges[1]), &v, extent, contact) {
        return false;
    }
    for edge in edges {
        // Unit axis × edge, written out so the zero components are exact zeros.
        let axes = [
            DVec3::new(0.0, -edge.z, edge.y),
            DVec3::new(edge.z, 0.0, -edge.x),
            DVec3::new(-edge.y, edge.x, 0.0),
        ];
        if axes.into_iter().any(|axis| separates(axis, &v, extent, contact)) {
            return false;
        }
    }
    true
}

/// Whether `axis` separates the triangle `v` from the box `[0, extent]`: strictly apart
/// for closed boxes, touching allowed for open ones. A zero axis (of a degenerate
/// triangle) separates nothing.
#[inline]
fn separates(axis: DVec3, v: &[DVec3; 3], extent: DVec3, contact: Contact) -> bool {
    if axis == DVec3::ZERO {
        return false;
    }
    let p = v.map(|x| axis.dot(x));
    let (tri_lo, tri_hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
    let corner = axis * extent;
    let box_lo = corner.min(DVec3::ZERO).element_sum();
    let box_hi = corner.max(DVec3::ZERO).element_sum();
    match contact {
        Contact::Overlaps => tri_lo > box_hi || tri_hi < box_lo,
        Contact::Separates => tri_lo >= box_hi || tri_hi <= box_lo,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::new(DVec3::ZERO, DVec3::ONE)
    }

    #[test]
    fn clear_cases() {
        let t = [
            DVec3::new(0.5, 0.5, 0.5),
            DVec3::new(3.0, 0.5, 0.5),
            DVec3::new(0.5, 3.0, 0.5),
        ];
        assert!(triangle_box_overlap(t, &unit()));
        // Large triangle cutting through the box with all vertices outside.
        let big = [
            DVec3::new(-10.0, -10.0, 0.5),
            DVec3::new(10.0, -10.0, 0.5),
            DVec3::new(0.0, 10.0, 0.5),
        ];
        assert!(triangle_box_overlap(big, &unit()));
        // Triangle near the corner, separated only by its own normal.
        let corner = [
            DVec3::new(1.6, 0.0, 0.0),
            DVec3::new(0.0, 1.6, 0.0),
            DVec3::new(0.0, 0.0, 1.6),
        ]
        .map(|p| p + DVec3::splat(1.0));
        assert!(!triangle_box_overlap(corner, &unit()));
        // Separated only by an edge cross product.
        // (x + z ≥ 2.2 on the triangle, ≤ 2 on the box: the axis is Y × edge.)
        let skew = [
            DVec3::new(-1.0, 0.5, 3.2),
            DVec3::new(3.2, 0.5, -1.0),
            DVec3::new(3.0, 3.0, 3.0),
        ];
        assert!(!triangle_box_overlap(skew, &unit()));
    }

    #[test]
    fn touching_counts() {
        let b = Aabb::new(DVec3::splat(0.1), DVec3::splat(0.7));
        // Lying exactly on the top face (0.7 is not representable; ties stay exact).
        let on_face = [
            DVec3::new(0.2, 0.2, 0.7),
            DVec3::new(0.9, 0.2, 0.7),
            DVec3::new(0.2, 0.9, 0.7),
        ];
        assert!(triangle_box_overlap(on_face, &b));
        let above = on_face.map(|p| p + DVec3::Z * 1e-12);
        assert!(!triangle_box_overlap(above, &b));
        // A single vertex touching a corner.
        let at_corner = [DVec3::splat(0.7), DVec3::new(2.0, 0.7, 0.7), DVec3::new(2.0, 2.0, 0.7)];
        assert!(triangle_box_overlap(at_corner, &b));
    }

    #[test]
    fn degenerate_triangles() {
        let point_in = [DVec3::splat(0.5); 3];
        assert!(triangle_box_overlap(point_in, &unit()));
        assert!(!triangle_box_overlap([DVec3::splat(1.5); 3], &unit()));
        // A segment passing diagonally near a box edge: misses, then hits.
        let miss = [
            DVec3::new(1.2, -0.5, 0.5),
            DVec3::new(1.6, 0.2, 0.5),
            DVec3::new(1.2, -0.5, 0.5),
        ];
        assert!(!triangle_box_overlap(miss, &unit()));
        let hit = [
            DVec3::new(1.2, 0.5, 0.5),
            DVec3::new(0.5, 1.2, 0.5),
            DVec3::new(0.85, 0.85, 0.5),
        ];
        assert!(triangle_box_overlap(hit, &unit()));
        let beside = [
            DVec3::new(1.5, 0.6, 0.5),
            DVec3::new(0.6, 1.5, 0.5),
            DVec3::new(1.05, 1.05, 0.5),
        ];
        assert!(!triangle_box_overlap(beside, &unit()));
    }
}
