//! ADF → sculpt: an ADF is a signed-distance `Field`, so `Sculpt::from_field` samples it
//! into a sculpt through the oriented box filter (density `½ − d/(2W)`), like any
//! distance field. The sculpt's densities are the filter of the exact distance to within
//! the ADF's tolerance over the filter's slope, at every voxel centre.

use glam::{DVec3, IVec3};
use volga::adf::{Adf, AdfOptions, ShapeSource};
use volga::core::Field;
use volga::sculpt::{Sculpt, SculptGrid};
use volga::shapes::{OrientedBoxFilter, SignedDistance, Torus};

#[test]
fn adf_samples_into_a_sculpt_within_its_tolerance() {
    let torus = Torus::new(DVec3::splat(16.0), DVec3::new(0.2, 1.0, 0.3), 9.0, 3.5).unwrap();
    let tolerance = 0.01;
    let adf = Adf::build(
        &ShapeSource(torus),
        AdfOptions {
            tolerance,
            max_depth: 8,
            band: 2.0, // the filter's ramp (|d| ≤ 2W = 2√3 voxels) lies in tested leaves
            ..AdfOptions::default()
        },
    )
    .unwrap();
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 2).unwrap(); // 32³ voxels
    let sculpt = Sculpt::from_field(grid, &adf, [1.0, 1.0, 1.0]);
    let filter = OrientedBoxFilter::for_spacing(DVec3::ONE);
    let slope = 1.0 / (2.0 * filter.half_width());
    let mut ramp = 0;
    for k in 0..32 {
        for j in 0..32 {
            for i in 0..32 {
                let p = grid.voxel_center(IVec3::new(i, j, k));
                let expected = filter.density(torus.signed_distance(p));
                let got = sculpt.value(p);
                ramp += (expected > 0.0 && expected < 1.0) as usize;
                // The ADF's error times the slope, and the f32 payload.
                assert!(
                    (got - expected).abs() <= tolerance * slope + 1e-6,
                    "{p}: sculpt {got}, filter of the exact distance {expected}"
                );
            }
        }
    }
    assert!(ramp > 1000, "{ramp} voxels on the filter's ramp");
}
