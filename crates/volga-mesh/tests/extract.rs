//! The shared iso-surface extractor: closed and manifold outputs (sphere, torus, two
//! spheres touching at a point, a ball far from the origin), vertices on the surface
//! within the stated tolerance, and identical meshes for 1 and 2 threads.

use std::collections::HashMap;

use glam::DVec3;
use volga_core::{Aabb, Field};
mod common;
use common::{check_closed_manifold, Sdf};
use volga_mesh::{extract_surface, extract_surface_with, Extraction, Surface, TriMesh, VertexPlacement};

fn euler_characteristic(mesh: &TriMesh) -> i64 {
    let edges = mesh.triangles.len() * 3 / 2;
    mesh.positions.len() as i64 - edges as i64 + mesh.triangles.len() as i64
}

fn ball(c: DVec3, r: f64) -> Sdf<impl Fn(DVec3) -> f64 + Sync> {
    Sdf(
        move |p: DVec3| (p - c).length() - r,
        Aabb::new(c - r - 1.0, c + r + 1.0),
    )
}

#[test]
fn sphere_vertices_lie_on_the_surface_within_1e_9() {
    let (c, r) = (DVec3::new(0.3, -0.2, 0.1), 5.0);
    let field = ball(c, r);
    let s = extract_surface(&field, Aabb::new(DVec3::splat(-7.0), DVec3::splat(7.0)), 0.37, 0.0).unwrap();
    check_closed_manifold(&s.mesh, "");
    assert_eq!(euler_characteristic(&s.mesh), 2);
    for (p, n) in s.mesh.positions.iter().zip(&s.normals) {
        // Stated tolerance: |distance| ≤ 1e-9 (the refinement's value tolerance).
        assert!(((*p - c).length() - r).abs() <= 1e-9, "{p}");
        assert!((*n - (*p - c).normalize()).length() < 1e-6, "normal {n} at {p}");
    }
    // Linear placement (marching-cubes style) is off by O(cell²/r), but not more.
    let linear = extract_surface_with(
        &field,
        &Extraction::new(Aabb::new(DVec3::splat(-7.0), DVec3::splat(7.0)), 0.37, 0.0)
            .with_placement(VertexPlacement::Linear),
    )
    .unwrap();
    assert_eq!(
        linear.mesh.triangles, s.mesh.triangles,
        "placement moves vertices, never topology"
    );
    let worst = linear
        .mesh
        .positions
        .iter()
        .map(|p| ((*p - c).length() - r).abs())
        .fold(0.0, f64::max);
    assert!(worst > 1e-6 && worst < 0.37 * 0.37 * 3.0 / r, "{worst}");
}

#[test]
fn torus_is_closed_manifold_with_genus_one() {
    let (big, small) = (4.0, 1.3);
    let torus = Sdf(
        move |p: DVec3| {
            let q = glam::DVec2::new(glam::DVec2::new(p.x, p.y).length() - big, p.z);
            q.length() - small
        },
        Aabb::new(DVec3::splat(-6.0), DVec3::splat(6.0)),
    );
    let s = extract_surface(&torus, Aabb::new(DVec3::splat(-6.0), DVec3::splat(6.0)), 0.29, 0.0).unwrap();
    check_closed_manifold(&s.mesh, "");
    assert_eq!(euler_characteristic(&s.mesh), 0);
}

#[test]
fn two_touching_spheres_stay_manifold_by_index() {
    // Spheres of radius 2 touching at the origin, which is a lattice point: the surface
    // pinches to a point there, where surface nets would put a non-manifold edge.
    let (a, b) = (DVec3::new(-2.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0));
    let pair = Sdf(
        move |p: DVec3| ((p - a).length() - 2.0).min((p - b).length() - 2.0),
        Aabb::new(DVec3::new(-5.0, -3.0, -3.0), DVec3::new(5.0, 3.0, 3.0)),
    );
    for cell in [0.25, 0.3] {
        let s = extract_surface(
            &pair,
            Aabb::new(DVec3::new(-5.0, -3.0, -3.0), DVec3::new(5.0, 3.0, 3.0)),
            cell,
            0.0,
        )
        .unwrap();
        check_closed_manifold(&s.mesh, "");
        // Two spheres (the half-open rule puts the touching point inside, so they join
        // through it as one component of genus 0, or stay two): χ is 2 or 4.
        let chi = euler_characteristic(&s.mesh);
        assert!(chi == 2 || chi == 4, "χ = {chi} at cell {cell}");
    }
}

#[test]
fn far_from_the_origin_and_identical_for_1_and_2_threads() {
    let c = DVec3::new(1e6, -1e6, 1e6);
    let field = ball(c, 3.0);
    let region = Aabb::new(c - 4.0, c + 4.0);
    let run = |threads: usize| -> Surface {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| extract_surface(&field, region, 0.11, 0.0).unwrap())
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one, two);
    check_closed_manifold(&one.mesh, "");
    for p in &one.mesh.positions {
        assert!(((*p - c).length() - 3.0).abs() < 1e-8);
    }
}

#[test]
fn a_surface_cut_by_the_region_has_a_rim_and_density_fields_work() {
    // A density field (rises inwards, iso ½): the ball clipped by the region is open.
    struct Density;
    impl Field for Density {
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(-3.0), DVec3::splat(3.0))
        }
        fn value(&self, p: DVec3) -> f64 {
            (0.5 - (p.length() - 2.0) / 2.0).clamp(0.0, 1.0)
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::splat(1e-4)
        }
        fn value_range(&self, _: &Aabb) -> (f64, f64) {
            (0.0, 1.0)
        }
    }
    let s = extract_surface(
        &Density,
        Aabb::new(DVec3::splat(-3.0), DVec3::new(3.0, 3.0, 0.5)),
        0.2,
        0.5,
    )
    .unwrap();
    // By index: rim edges in one face, every other edge in two, none in more. (Welding by
    // position would merge the vertices that a lattice point exactly at the iso value puts
    // on each of its edges; the module documents manifoldness by index.)
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &s.mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    assert!(uses.values().any(|&n| n == 1), "the cut leaves a rim");
    assert!(uses.values().all(|&n| n <= 2));
    for (p, n) in s.mesh.positions.iter().zip(&s.normals) {
        assert!((p.length() - 2.0).abs() < 1e-8);
        assert!(n.dot(*p) > 0.99 * p.length(), "density normals point outward");
    }
}
