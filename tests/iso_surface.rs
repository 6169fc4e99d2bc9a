//! The raycaster's 0.5 iso-surface of a volume-sampled sphere lies within 0.05 voxel
//! of the true sphere, for rays in every direction (axis-parallel and grazing ones
//! included), at several radii, sub-voxel centres, anisotropy and far origins.

use glam::{DVec3, UVec3};
use proptest::prelude::*;
use volga::render::{first_hit, Ray};
use volga::voxelize::{shapes::Sphere, voxelize_solids, Shape, Solid};
use volga::{Filter, Grid, NoProgress, Sampled, Transform};

/// Max |‖hit − c‖ − r| in voxels over a fan of rays, and the number of hits.
fn worst_error(r_voxels: f64, offset: DVec3, origin: DVec3, spacing: DVec3, dirs: &[DVec3]) -> (f64, usize) {
    let h = spacing.max_element();
    let n = (2.0 * r_voxels * h / spacing.min_element() + 10.0).ceil() as u32;
    let grid = Grid::new(Transform::new(origin, spacing).unwrap(), UVec3::splat(n)).unwrap();
    let c = grid
        .transform
        .index_to_world(DVec3::splat(n as f64 / 2.0 - 0.5) + offset);
    let r = r_voxels * h;
    let solid = Solid::new(Shape::Sphere(Sphere::new(c, r).unwrap()), [1.0; 3]);
    let volume = voxelize_solids(&grid, &[solid], false, &NoProgress);
    let field = Sampled::new(&volume, Filter::Trilinear);
    let step = 0.25 * spacing.min_element();
    let (mut worst, mut hits) = (0.0f64, 0);
    for &d in dirs {
        let d = d.normalize();
        // A basis perpendicular to d; rays start 2r before the centre and sweep a disk
        // slightly larger than the sphere (the outer ones graze or miss).
        let u = d.any_orthonormal_vector();
        let v = d.cross(u);
        for i in -12..=12 {
            for j in -12..=12 {
                let lateral = (u * i as f64 + v * j as f64) * (r / 11.0);
                let ray = Ray {
                    origin: c - d * (2.0 * r) + lateral,
                    dir: d,
                };
                if let Some(hit) = first_hit(&field, &ray, 0.5, step) {
                    worst = worst.max(((hit.world_pos - c).length() - r).abs() / h);
                    hits += 1;
                }
            }
        }
    }
    (worst, hits)
}

const AXES: [DVec3; 6] = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z];

#[test]
fn axis_parallel_rays_through_voxel_centres() {
    // Offset 0: the sphere centre on a voxel centre, so rays run exactly along rows.
    for r in [8.0, 12.0] {
        let (worst, hits) = worst_error(r, DVec3::ZERO, DVec3::ZERO, DVec3::ONE, &AXES);
        assert!(hits > 6 * 300, "{hits}");
        assert!(worst < 0.05, "r = {r}: worst {worst} voxel");
    }
}

#[test]
fn far_origin_and_anisotropic_spacing() {
    let dirs = [DVec3::new(1.0, 0.3, 0.2), DVec3::new(-0.2, -1.0, 0.7), DVec3::Z];
    let (worst, _) = worst_error(
        10.0,
        DVec3::new(0.3, 0.1, 0.7),
        DVec3::splat(1e6),
        DVec3::splat(0.01),
        &dirs,
    );
    assert!(worst < 0.05, "far origin: {worst}");
    // On an anisotropic grid the error is measured in units of the largest spacing.
    let (worst, _) = worst_error(
        12.0,
        DVec3::new(0.3, 0.1, 0.7),
        DVec3::ZERO,
        DVec3::new(1.0, 1.0, 0.5),
        &dirs,
    );
    assert!(worst < 0.05, "anisotropic: {worst}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]
    #[test]
    fn random_directions_and_centres(r in 8.0f64..16.0, o in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0), d in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)) {
        let d = DVec3::new(d.0, d.1, d.2);
        prop_assume!(d.length() > 0.1);
        let (worst, hits) = worst_error(r, DVec3::new(o.0, o.1, o.2), DVec3::ZERO, DVec3::ONE, &[d]);
        prop_assert!(hits > 300);
        prop_assert!(worst < 0.05, "worst {} voxel", worst);
    }
}
