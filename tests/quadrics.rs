//! Quadrics: exact distances against brute force, volumes and surface areas of
//! anti-aliased solids and shells against analytic values, separating binary surfaces,
//! narrow-band distance fields, and the hard cases (cone apex, far origin) without NaN.

use std::f64::consts::PI;

use glam::{DMat3, DQuat, DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga::voxelize::measure::{density_integral, occupied_volume};
use volga::voxelize::shapes::{AxisBox, Cone, Cylinder, Ellipsoid, Quadric, Sphere};
use volga::voxelize::{voxelize_shapes, Separability, Shape, SignedDistance, SurfaceMode};
use volga::{Grid, NoProgress, Transform};

mod common;
use common::{black, flood_from_border};

/// Minimum distance from `p` to points sampled on a surface given by a parametrization
/// over [0,1]², refined around the best sample (a brute-force reference).
fn brute_min(p: DVec3, surf: impl Fn(f64, f64) -> DVec3) -> f64 {
    let n = 400;
    let (mut best, mut bu, mut bv) = (f64::INFINITY, 0.0, 0.0);
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let d = (surf(u, v) - p).length();
            if d < best {
                (best, bu, bv) = (d, u, v);
            }
        }
    }
    let m = 200;
    for i in 0..=m {
        for j in 0..=m {
            let u = (bu + (i as f64 / m as f64 - 0.5) * 2.0 / n as f64).clamp(0.0, 1.0);
            let v = (bv + (j as f64 / m as f64 - 0.5) * 2.0 / n as f64).clamp(0.0, 1.0);
            best = best.min((surf(u, v) - p).length());
        }
    }
    best
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn ellipsoid_distance_matches_brute_force(p in (-6.0f64..6.0, -6.0f64..6.0, -6.0f64..6.0), r in (0.5f64..4.0, 0.5f64..4.0, 0.5f64..4.0), angle in 0.0f64..3.0) {
        let (p, radii) = (DVec3::new(p.0, p.1, p.2), DVec3::new(r.0, r.1, r.2));
        let rot = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), angle);
        let c = DVec3::new(0.3, -0.2, 0.1);
        let e = Ellipsoid::new(c, radii, rot).unwrap();
        let d = e.signed_distance(p);
        let brute = brute_min(p, |u, v| {
            let (th, ph) = (u * PI, v * 2.0 * PI);
            c + rot * (radii * DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()))
        });
        prop_assert!(d.is_finite());
        // The exact distance never exceeds a sampled distance, and agrees to sampling accuracy.
        prop_assert!(d.abs() <= brute + 1e-9, "{} > {}", d.abs(), brute);
        prop_assert!(brute - d.abs() < 1e-3, "{} vs {}", d.abs(), brute);
        let local = rot.inverse() * (p - c);
        prop_assert_eq!(d < 0.0, (local / radii).length_squared() < 1.0);
    }

    #[test]
    fn finite_cylinder_and_cone_distances_match_brute_force(p in (-5.0f64..5.0, -5.0f64..5.0, -5.0f64..5.0)) {
        let p = DVec3::new(p.0, p.1, p.2);
        let axis = DVec3::new(0.3, 0.9, -0.2).normalize();
        let (u, w) = (axis.any_orthonormal_vector(), axis.cross(axis.any_orthonormal_vector()));
        let ring = |t: f64| u * (2.0 * PI * t).cos() + w * (2.0 * PI * t).sin();
        let cyl = Cylinder::new(DVec3::ZERO, axis, 1.5, Some(2.0)).unwrap();
        // Surface of the capped cylinder: side, then the two caps, parametrized over [0,1]².
        let d_side = brute_min(p, |s, t| ring(t) * 1.5 + axis * (4.0 * s - 2.0));
        let d_caps = brute_min(p, |s, t| ring(t) * 1.5 * s + axis * 2.0).min(brute_min(p, |s, t| ring(t) * 1.5 * s - axis * 2.0));
        let d = cyl.signed_distance(p);
        prop_assert!((d.abs() - d_side.min(d_caps)).abs() < 1e-3, "cylinder {} vs {}", d, d_side.min(d_caps));

        let apex = DVec3::new(0.2, -1.0, 0.1);
        let (theta, height) = (0.5f64, 3.0);
        let cone = Cone::new(apex, axis, theta, Some(height)).unwrap();
        let rim = height * theta.tan();
        let d_slant = brute_min(p, |s, t| apex + (axis * height + ring(t) * rim) * s);
        let d_cap = brute_min(p, |s, t| apex + axis * height + ring(t) * rim * s);
        let d = cone.signed_distance(p);
        prop_assert!((d.abs() - d_slant.min(d_cap)).abs() < 1e-3, "cone {} vs {}", d, d_slant.min(d_cap));
    }
}

#[test]
fn sphere_like_ellipsoid_equals_sphere() {
    let e = Ellipsoid::new(DVec3::ONE, DVec3::splat(2.0), DQuat::IDENTITY).unwrap();
    let s = Sphere::new(DVec3::ONE, 2.0).unwrap();
    for p in [
        DVec3::ZERO,
        DVec3::new(5.0, 1.0, 1.0),
        DVec3::new(1.0, 1.5, 1.2),
        DVec3::ONE,
        DVec3::new(3.0, 1.0, 1.0),
    ] {
        assert!((e.signed_distance(p) - s.signed_distance(p)).abs() < 1e-12, "{p}");
    }
}

#[test]
fn cone_apex_and_degenerate_points_stay_finite() {
    let cone = Cone::new(DVec3::splat(4.0), DVec3::Z, 0.4, None).unwrap();
    for p in [
        DVec3::splat(4.0),
        DVec3::new(4.0, 4.0, 3.0),
        DVec3::new(4.0, 4.0, 100.0),
        DVec3::new(1e6, 1e6, 1e6),
    ] {
        let d = cone.signed_distance(p);
        assert!(d.is_finite(), "{p}: {d}");
        assert!(cone.gradient(p).is_finite());
    }
    assert_eq!(cone.signed_distance(DVec3::splat(4.0)), 0.0);
    // Below the apex on the axis: the distance is to the apex.
    assert!((cone.signed_distance(DVec3::new(4.0, 4.0, 1.0)) - 3.0).abs() < 1e-12);
}

fn grid(n: u32, h: f64, origin: DVec3) -> Grid {
    Grid::new(Transform::new(origin, DVec3::splat(h)).unwrap(), UVec3::splat(n)).unwrap()
}

#[test]
fn volumes_of_sphere_and_cylinder_at_several_resolutions() {
    // r in voxels: 8, 16, 32 for the same world sphere (radius 1).
    for n_r in [8.0, 16.0, 32.0] {
        let h = 1.0 / n_r;
        let n = (2.0 * n_r + 10.0) as u32;
        let g = grid(n, h, DVec3::splat(-(n as f64 - 1.0) * h / 2.0 + 0.013));
        let sphere = Shape::Sphere(Sphere::new(DVec3::ZERO, 1.0).unwrap());
        let v = voxelize_shapes(&g, &[sphere], SurfaceMode::Solid, &NoProgress);
        let rel = occupied_volume(&v) / (4.0 / 3.0 * PI) - 1.0;
        assert!(rel.abs() < 5e-3, "sphere r = {n_r} voxels: {rel:+e}");

        let cyl = Shape::Cylinder(Cylinder::new(DVec3::ZERO, DVec3::new(0.2, 0.3, 1.0), 0.5, Some(0.8)).unwrap());
        let v = voxelize_shapes(&g, &[cyl], SurfaceMode::Solid, &NoProgress);
        let exact = PI * 0.25 * 1.6;
        let rel = occupied_volume(&v) / exact - 1.0;
        // Edges of the caps are sharp: the filter rounds them, an O(h) effect.
        let tol = if n_r >= 16.0 { 1e-2 } else { 3e-2 };
        assert!(rel.abs() < tol, "cylinder r = {} voxels: {rel:+e}", n_r / 2.0);
    }
}

#[test]
fn surface_areas_from_shells() {
    // ∫ filter(|d| − τ/2) = τ·A·(1 + K·W²/6) for τ = W = 2√3 voxels (second-order
    // curvature term K = 1/r² for a sphere): within 0.2 % of that, and 1 % of 4πr².
    for n_r in [16.0, 32.0] {
        let h = 1.0 / n_r;
        let n = (2.0 * n_r + 16.0) as u32;
        let g = grid(n, h, DVec3::splat(-(n as f64 - 1.0) * h / 2.0 + 0.021));
        let w = 2.0 * 3f64.sqrt() * h;
        let sphere = Shape::Sphere(Sphere::new(DVec3::ZERO, 1.0).unwrap());
        let v = voxelize_shapes(&g, &[sphere], SurfaceMode::Shell { thickness: w }, &NoProgress);
        let area = density_integral(&v) / w;
        let exact = 4.0 * PI;
        assert!(
            (area / (exact * (1.0 + w * w / 6.0)) - 1.0).abs() < 2e-3,
            "r = {n_r}: {area} vs {exact}"
        );
        assert!((area / exact - 1.0).abs() < 1e-2, "r = {n_r}: {area} vs {exact}");
        // Infinite cylinder clipped by the grid: lateral area per unit length 2πr.
        let cyl = Shape::Cylinder(Cylinder::new(DVec3::ZERO, DVec3::Z, 0.7, None).unwrap());
        let v = voxelize_shapes(&g, &[cyl], SurfaceMode::Shell { thickness: w }, &NoProgress);
        let length = n as f64 * h;
        let area = density_integral(&v) / w / length;
        assert!((area / (2.0 * PI * 0.7) - 1.0).abs() < 1e-2, "cylinder: {area}");
    }
}

#[test]
fn binary_quadric_surfaces_separate() {
    let g = grid(28, 1.0, DVec3::ZERO);
    let c = DVec3::new(13.6, 13.3, 13.9);
    let shapes = [
        Shape::Sphere(Sphere::new(c, 9.3).unwrap()),
        Shape::Ellipsoid(Ellipsoid::new(c, DVec3::new(11.0, 7.5, 6.2), DQuat::from_rotation_y(0.6)).unwrap()),
        Shape::Cylinder(Cylinder::new(c, DVec3::new(0.3, 0.2, 1.0), 7.0, Some(8.0)).unwrap()),
        Shape::Cone(
            Cone::new(
                c - DVec3::new(0.0, 0.0, 9.0),
                DVec3::new(0.1, 0.0, 1.0),
                0.6,
                Some(18.0),
            )
            .unwrap(),
        ),
    ];
    for shape in shapes {
        for sep in [Separability::Six, Separability::Eighteen, Separability::TwentySix] {
            let v = voxelize_shapes(&g, &[shape], SurfaceMode::Binary(sep), &NoProgress)
                .to_dense()
                .unwrap();
            let inside = IVec3::new(14, 14, 14);
            let reached = flood_from_border(&v, sep);
            assert!(!black(&v, inside), "{shape:?} {sep:?}");
            assert!(!reached[v.density.shape().linearize(inside)], "{shape:?} {sep:?}: leak");
            assert!(v.density.as_slice().iter().all(|d| *d == 0.0 || *d == 1.0));
        }
    }
}

#[test]
fn binary_plane_quadric_is_one_layer_at_ties() {
    // F = z − 8.5: a plane exactly on voxel faces, as a general quadric.
    let g = grid(16, 1.0, DVec3::ZERO);
    let clip = AxisBox::new(DVec3::splat(-5.0), DVec3::splat(25.0)).unwrap();
    let q = Shape::Quadric(Quadric::new(DMat3::ZERO, DVec3::Z, -8.5, clip).unwrap());
    for sep in [Separability::Six, Separability::TwentySix] {
        let v = voxelize_shapes(&g, &[q], SurfaceMode::Binary(sep), &NoProgress)
            .to_dense()
            .unwrap();
        for y in 0..16 {
            for x in 0..16 {
                let count = (0..16).filter(|&z| black(&v, IVec3::new(x, y, z))).count();
                assert_eq!(count, 1);
            }
        }
    }
}

#[test]
fn narrow_band_distance_field_is_exact_in_band() {
    let g = grid(40, 0.5, DVec3::splat(1e6));
    let c = DVec3::splat(1e6 + 9.7);
    let sphere = Sphere::new(c, 6.3).unwrap();
    let v = voxelize_shapes(
        &g,
        &[Shape::Sphere(sphere)],
        SurfaceMode::Distance {
            half_width_voxels: 3.0,
            signed: true,
        },
        &NoProgress,
    );
    let d = v.to_dense().unwrap();
    let band = 1.5;
    assert_eq!(v.density.background(), band as f32);
    for ijk in g.index_box().iter() {
        let exact = sphere.signed_distance(g.transform.voxel_center(ijk)).clamp(-band, band);
        let got = d.density.get(ijk) as f64;
        assert!((got - exact).abs() < 1e-5, "{ijk}: {got} vs {exact}");
    }
    // The interior is stored as uniform bricks of −band, not voxel by voxel.
    assert!(v.density.dense_brick_count() < v.density.brick_count());
}

#[test]
fn quadric_sphere_matches_exact_sphere() {
    // x·x − 2c·x + |c|² − r² as a general quadric: first-order distance, same solid.
    let g = grid(32, 1.0, DVec3::ZERO);
    let (c, r) = (DVec3::new(15.2, 15.7, 15.4), 10.0);
    let clip = AxisBox::new(DVec3::splat(-1.0), DVec3::splat(33.0)).unwrap();
    let q = Shape::Quadric(Quadric::new(DMat3::IDENTITY, -2.0 * c, c.length_squared() - r * r, clip).unwrap());
    let s = Shape::Sphere(Sphere::new(c, r).unwrap());
    let vq = voxelize_shapes(&g, &[q], SurfaceMode::Solid, &NoProgress)
        .to_dense()
        .unwrap();
    let vs = voxelize_shapes(&g, &[s], SurfaceMode::Solid, &NoProgress)
        .to_dense()
        .unwrap();
    let worst = vq
        .density
        .as_slice()
        .iter()
        .zip(vs.density.as_slice())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    // First-order distance (|x|² − r²)/(2|x|) = d − d²/(2(r + d)); its largest error
    // in the filter band is at d = −√3 voxels: 3/(2(r − √3)) = 0.181 voxel, through the
    // filter slope 1/(2√3): 0.052 in density.
    assert!(worst < 0.053, "{worst}");
}

#[test]
fn binary_quadric_solids_are_exactly_the_inside() {
    let g = grid(30, 1.0, DVec3::ZERO);
    let shapes = [
        Shape::Ellipsoid(
            Ellipsoid::new(
                DVec3::splat(14.5),
                DVec3::new(11.0, 7.0, 5.0),
                DQuat::from_rotation_z(0.4),
            )
            .unwrap(),
        ),
        Shape::Cone(Cone::new(DVec3::new(15.0, 15.0, 2.0), DVec3::Z, 0.5, Some(20.0)).unwrap()),
        Shape::Cylinder(Cylinder::new(DVec3::splat(15.0), DVec3::new(1.0, 1.0, 0.0), 4.0, None).unwrap()),
    ];
    for shape in shapes {
        let v = voxelize_shapes(&g, &[shape], SurfaceMode::Inside, &NoProgress)
            .to_dense()
            .unwrap();
        for ijk in g.index_box().iter() {
            let inside = shape.signed_distance(g.transform.voxel_center(ijk)) <= 0.0;
            assert_eq!(v.density.get(ijk) == 1.0, inside, "{shape:?} at {ijk}");
        }
    }
}
