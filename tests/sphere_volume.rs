//! The volume-sampled sphere's volume, against exact references.
//!
//! One would like Σ density × voxel volume to lie within 0.5 % of 4/3·π·r³ for
//! r ≥ 8 voxels. With the prescribed profile (linear over ±√3 voxels, 0.5 on the
//! surface) that is impossible: the outer half of the ramp lies on a larger sphere than
//! the inner half, so the sum is exactly 4/3·π·r³·(1 + w²/r²) with w = √3 voxels
//! (+4.7 % at r = 8). The tests check that prediction to 0.1 %, check the 0.5 % bound
//! where the theory allows it (r ≥ 25), and check `occupied_volume`, which removes most
//! of the bias (0.39 % at r = 8), within 0.5 % for every r ≥ 8.

use glam::{DVec3, UVec3};
use proptest::prelude::*;
use volga::voxelize::measure::{density_integral, occupied_volume};
use volga::voxelize::{shapes::Sphere, voxelize_solids, Shape, Solid};
use volga::{Grid, NoProgress, SparseVolume, Transform};

fn sphere_volume(r_voxels: f64, offset: DVec3, spacing: f64) -> (SparseVolume, f64) {
    let n = (2.0 * r_voxels + 8.0).ceil() as u32;
    let grid = Grid::new(
        Transform::new(DVec3::splat(1e3), DVec3::splat(spacing)).unwrap(),
        UVec3::splat(n),
    )
    .unwrap();
    let center = grid
        .transform
        .index_to_world(DVec3::splat(n as f64 / 2.0 - 0.5) + offset);
    let r = r_voxels * spacing;
    let solid = Solid::new(Shape::Sphere(Sphere::new(center, r).unwrap()), [1.0; 3]);
    let v = voxelize_solids(&grid, &[solid], false, &NoProgress);
    (v, 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn density_sum_matches_the_filtered_prediction(r in 8.0f64..40.0, o in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0)) {
        let (v, exact) = sphere_volume(r, DVec3::new(o.0, o.1, o.2), 0.01);
        let predicted = exact * (1.0 + 3.0 / (r * r));
        let rel = density_integral(&v) / predicted - 1.0;
        prop_assert!(rel.abs() < 1e-3, "r = {r}: sum is {rel:+e} off the prediction");
    }

    #[test]
    fn occupied_volume_within_half_percent_for_r_at_least_8(r in 8.0f64..40.0, o in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0)) {
        let (v, exact) = sphere_volume(r, DVec3::new(o.0, o.1, o.2), 0.01);
        let rel = occupied_volume(&v) / exact - 1.0;
        prop_assert!(rel.abs() < 5e-3, "r = {r}: occupied volume off by {rel:+e}");
    }
}

#[test]
fn density_sum_within_half_percent_where_theory_allows() {
    // w²/r² < 0.5 % needs r > √3 / √0.005 ≈ 24.5 voxels.
    for r in [25.0, 32.0, 48.0] {
        let (v, exact) = sphere_volume(r, DVec3::new(0.31, 0.47, 0.13), 1.0);
        let rel = density_integral(&v) / exact - 1.0;
        assert!(rel.abs() < 5e-3, "r = {r}: {rel:+e}");
    }
    // And the bias at r = 8 is what the theory says, not an implementation error.
    let (v, exact) = sphere_volume(8.0, DVec3::new(0.31, 0.47, 0.13), 1.0);
    let rel = density_integral(&v) / exact - 1.0;
    assert!((rel - 3.0 / 64.0).abs() < 1e-3, "{rel}");
}
