//! Property tests of the triangle predicates against brute force, on generic,
//! degenerate and sliver triangles, at the origin and at 1e6.

use glam::DVec3;
use proptest::prelude::*;
use volga_core::Aabb;
use volga_mesh::{
    closest_point_on_segment, closest_point_on_triangle, point_triangle_distance_squared, segment_crosses_triangle,
    triangle_box_overlap, winding_number, Bvh, Feature, TriMesh,
};

fn coord() -> impl Strategy<Value = f64> {
    -1.0..1.0f64
}

fn point() -> impl Strategy<Value = DVec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

/// Generic triangles and the hard cases: collinear, a point, two equal corners, and
/// slivers (a corner a tiny distance off the opposite edge).
fn triangle() -> impl Strategy<Value = [DVec3; 3]> {
    prop_oneof![
        4 => (point(), point(), point()).prop_map(|(a, b, c)| [a, b, c]),
        1 => (point(), point(), -0.5..1.5f64).prop_map(|(a, b, t)| [a, b, a + (b - a) * t]),
        1 => point().prop_map(|a| [a; 3]),
        1 => (point(), point()).prop_map(|(a, b)| [a, b, a]),
        1 => (point(), point(), 0.0..1.0f64, point(), -12.0..-6.0f64).prop_map(|(a, b, t, off, e)| {
            [a, b, a + (b - a) * t + off * 10f64.powf(e)]
        }),
    ]
}

/// Points anywhere, and exactly on the triangle's corners and edges.
fn query_for(tri: [DVec3; 3]) -> impl Strategy<Value = DVec3> {
    prop_oneof![
        3 => point().prop_map(|p| p * 2.0),
        1 => (0..3usize).prop_map(move |k| tri[k]),
        1 => (0..3usize, 0.0..1.0f64).prop_map(move |(k, t)| tri[k] + (tri[(k + 1) % 3] - tri[k]) * t),
    ]
}

fn triangle_and_query() -> impl Strategy<Value = ([DVec3; 3], DVec3)> {
    triangle().prop_flat_map(|tri| (Just(tri), query_for(tri)))
}

/// Points on a barycentric grid of `n` steps per side: every point of the triangle
/// is within `longest edge / n` of one of them.
fn samples(tri: [DVec3; 3], n: usize) -> impl Iterator<Item = DVec3> {
    (0..=n).flat_map(move |i| {
        (0..=n - i).map(move |j| {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v
        })
    })
}

fn longest_edge(tri: [DVec3; 3]) -> f64 {
    (0..3).map(|k| (tri[(k + 1) % 3] - tri[k]).length()).fold(0.0, f64::max)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn closest_point_matches_dense_sampling((tri, p) in triangle_and_query()) {
        let n = 120;
        let (q, feature) = closest_point_on_triangle(p, tri);
        let d = (p - q).length();
        prop_assert!(d.is_finite() && q.is_finite());
        let sampled = samples(tri, n).map(|s| (p - s).length()).fold(f64::INFINITY, f64::min);
        let spacing = longest_edge(tri) / n as f64;
        // Within the documented bound (3e-8 of the longest edge) of the true distance.
        prop_assert!(d <= sampled + 3e-8 * longest_edge(tri) + 1e-15, "exact {d} above sampled {sampled}");
        prop_assert!(sampled <= d + spacing + 1e-12, "exact {d} far below sampled {sampled}");
        // The point lies on the triangle, and on the feature it names.
        let on_triangle = samples(tri, n).map(|s| (q - s).length()).fold(f64::INFINITY, f64::min);
        prop_assert!(on_triangle <= spacing + 1e-12);
        match feature {
            Feature::Vertex(k) => prop_assert_eq!(q, tri[k]),
            Feature::Edge(k) => {
                let (on_edge, _) = closest_point_on_segment(q, tri[k], tri[(k + 1) % 3]);
                prop_assert!((on_edge - q).length() <= 1e-12);
            }
            Feature::Face => prop_assert!((tri[1] - tri[0]).cross(tri[2] - tri[0]) != DVec3::ZERO),
        }
        prop_assert_eq!(point_triangle_distance_squared(p, tri), (p - q).length_squared());
    }

    #[test]
    fn closest_point_far_from_the_origin((tri, p) in triangle_and_query()) {
        let offset = DVec3::new(1e6, -1e6, 1e6);
        let near = point_triangle_distance_squared(p, tri).sqrt();
        let far = point_triangle_distance_squared(p + offset, tri.map(|v| v + offset)).sqrt();
        prop_assert!((near - far).abs() <= 1e-6 * (1.0 + near), "{near} vs {far}");
    }

    #[test]
    fn box_overlap_matches_sampling(tri in triangle(), lo in point(), size in (0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64)) {
        let aabb = Aabb::new(lo, lo + DVec3::new(size.0, size.1, size.2));
        let n = 80;
        let spacing = longest_edge(tri) / n as f64;
        let overlap = triangle_box_overlap(tri, &aabb);
        let shrunk = Aabb::new(aabb.min + 1e-9, aabb.max - 1e-9);
        let box_distance = |s: DVec3| (aabb.min - s).max(s - aabb.max).max(DVec3::ZERO).length();
        if samples(tri, n).any(|s| shrunk.contains(s)) {
            prop_assert!(overlap, "a sample is inside the box");
        } else if samples(tri, n).all(|s| box_distance(s) > spacing + 1e-9) {
            prop_assert!(!overlap, "every sample is clear of the box");
        }
        // Far from the origin the same answer, wherever it was clear.
        let offset = DVec3::splat(1e6);
        let far_box = Aabb::new(aabb.min + offset, aabb.max + offset);
        if samples(tri, n).any(|s| shrunk.contains(s)) {
            prop_assert!(triangle_box_overlap(tri.map(|v| v + offset), &far_box));
        }
    }

    #[test]
    fn triangles_on_a_box_face_overlap(
        lo in point(), size in (0.1..1.0f64, 0.1..1.0f64, 0.1..1.0f64),
        axis in 0..3usize, upper in any::<bool>(),
        inside in (0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64), others in (point(), point()),
        offset in prop_oneof![Just(0.0), Just(1e6)],
    ) {
        let aabb = Aabb::new(lo + offset, lo + offset + DVec3::new(size.0, size.1, size.2));
        let face = if upper { aabb.max[axis] } else { aabb.min[axis] };
        // One corner inside the face rectangle (a box point moved onto the face's plane),
        // the others anywhere on that plane.
        let a = (aabb.min + aabb.size() * DVec3::new(inside.0, inside.1, inside.2)).clamp(aabb.min, aabb.max);
        let mut tri = [a, others.0 * 3.0 + offset, others.1 * 3.0 + offset];
        for v in &mut tri {
            v[axis] = face;
        }
        prop_assert!(triangle_box_overlap(tri, &aabb));
    }

    #[test]
    fn segments_through_the_interior_cross(
        tri in (point(), point(), point()).prop_map(|(a, b, c)| [a, b, c]),
        bary in (0.05..1.0f64, 0.05..1.0f64, 0.05..1.0f64),
        direction in point(), before in 0.01..2.0f64, after in 0.01..2.0f64,
    ) {
        let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        prop_assume!(normal.length() > 1e-3 && direction.normalize_or_zero().dot(normal.normalize()).abs() > 0.1);
        let sum = bary.0 + bary.1 + bary.2;
        let x = (tri[0] * bary.0 + tri[1] * bary.1 + tri[2] * bary.2) / sum;
        prop_assert!(segment_crosses_triangle(x - direction * before, x + direction * after, tri));
        // Both ends strictly above the plane: no crossing.
        let up = normal.normalize();
        let tangent = direction - up * direction.dot(up);
        prop_assert!(!segment_crosses_triangle(x + up * before, x + up * after + tangent, tri));
        // Through a point outside the triangle (one barycentric coordinate negative): no crossing.
        let outside = (tri[0] * -0.2 + tri[1] * bary.1 + tri[2] * bary.2) / (bary.1 + bary.2 - 0.2);
        if bary.1 + bary.2 > 0.4 {
            prop_assert!(!segment_crosses_triangle(outside - direction * before, outside + direction * after, tri));
        }
        // Ending exactly on a corner touches.
        prop_assert!(segment_crosses_triangle(tri[1] + direction, tri[1], tri));
    }

    #[test]
    fn cube_winding_number_is_exact(lo in point(), size in (0.1..2.0f64, 0.1..2.0f64, 0.1..2.0f64),
                                    t in (0.01..0.99f64, 0.01..0.99f64, 0.01..0.99f64), out in point(),
                                    offset in prop_oneof![Just(0.0), Just(1e3)]) {
        let aabb = Aabb::new(lo + offset, lo + offset + DVec3::new(size.0, size.1, size.2));
        let cube = TriMesh::from_aabb(&aabb);
        let inside = aabb.min + aabb.size() * DVec3::new(t.0, t.1, t.2);
        prop_assert!((winding_number(&cube, inside) - 1.0).abs() < 1e-9);
        let outside = aabb.max + 0.01 + out.abs();
        prop_assert!(winding_number(&cube, outside).abs() < 1e-9);
        let bvh = Bvh::build(&cube);
        prop_assert!((bvh.winding_number(inside) - 1.0).abs() < 1e-9);
    }
}

#[test]
fn closest_on_random_soups_matches_brute_force() {
    // Small soups so the BVH has several levels; every query checked against all triangles.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut unit = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..20 {
        let mut mesh = TriMesh::default();
        for t in 0..60u32 {
            let centre = DVec3::new(unit(), unit(), unit()) * 3.0;
            for _ in 0..3 {
                mesh.positions.push(centre + DVec3::new(unit(), unit(), unit()) * 0.3);
            }
            mesh.triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        let bvh = Bvh::build(&mesh);
        for _ in 0..50 {
            let p = DVec3::new(unit(), unit(), unit()) * 4.0;
            let brute = (0..mesh.triangle_count())
                .map(|i| point_triangle_distance_squared(p, mesh.triangle(i)))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(bvh.closest(p).unwrap().distance, brute.sqrt());
        }
    }
}
