//! Grid symmetries of volume-sampled solids: integer voxel shifts and 90° rotations
//! move the result exactly (bit for bit), and the result is the same for 1 and 2
//! threads. Parameters are dyadic (multiples of 1/8) so that the exact arithmetic of
//! the shifted or rotated problem is the same arithmetic, not merely close.

use glam::{DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga::voxelize::shapes::{AxisBox, Sphere};
use volga::voxelize::{voxelize_solids, Shape, Solid};
use volga::{DenseVolume, Grid, NoProgress, Transform};

const N: i32 = 40;

fn grid() -> Grid {
    Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(N as u32)).unwrap()
}

fn dyadic(v: (i32, i32, i32)) -> DVec3 {
    DVec3::new(v.0 as f64, v.1 as f64, v.2 as f64) / 8.0
}

fn voxelize(solids: &[Solid]) -> DenseVolume {
    voxelize_solids(&grid(), solids, false, &NoProgress).to_dense().unwrap()
}

/// The solids mapped by `f` (a point map that is an isometry of the lattice).
fn map(solids: &[Solid], f: impl Fn(DVec3) -> DVec3) -> Vec<Solid> {
    solids
        .iter()
        .map(|s| {
            let shape = match s.shape {
                Shape::Sphere(sp) => Shape::Sphere(Sphere::new(f(sp.center()), sp.radius()).unwrap()),
                Shape::AxisBox(b) => {
                    let bb = volga::voxelize::SignedDistance::bounds(&b);
                    let (p, q) = (f(bb.min), f(bb.max));
                    Shape::AxisBox(AxisBox::new(p.min(q), p.max(q)).unwrap())
                }
                other => other,
            };
            Solid::new(shape, s.colour)
        })
        .collect()
}

fn scene() -> impl Strategy<Value = Vec<Solid>> {
    let sphere = ((80..240, 80..240, 80..240), 16..80)
        .prop_map(|(c, r)| Solid::new(Shape::Sphere(Sphere::new(dyadic(c), r as f64 / 8.0).unwrap()), [1.0; 3]));
    let abox = ((80..200, 80..200, 80..200), (8..80, 8..80, 8..80)).prop_map(|(lo, size)| {
        let lo = dyadic(lo);
        Solid::new(Shape::AxisBox(AxisBox::new(lo, lo + dyadic(size)).unwrap()), [1.0; 3])
    });
    prop::collection::vec(prop_oneof![sphere, abox], 1..3)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn integer_shift_moves_result_exactly(solids in scene(), s in (-4i32..5, -4i32..5, -4i32..5)) {
        let shift = IVec3::new(s.0, s.1, s.2);
        let a = voxelize(&solids);
        let b = voxelize(&map(&solids, |p| p + shift.as_dvec3()));
        for ijk in grid().index_box().iter() {
            let moved = ijk + shift;
            // Solids stay ≥ 4 voxels inside the grid, so nothing is clipped either way.
            if grid().contains(moved) {
                prop_assert_eq!(a.density.get(ijk), b.density.get(moved), "at {}", ijk);
            }
        }
    }

    #[test]
    fn quarter_turns_move_result_exactly(solids in scene(), axis in 0usize..3) {
        let m = (N - 1) as f64;
        // A 90° turn of the lattice about the grid's centre line along `axis`.
        let rot = |p: DVec3| match axis {
            0 => DVec3::new(p.x, m - p.z, p.y),
            1 => DVec3::new(p.z, p.y, m - p.x),
            _ => DVec3::new(m - p.y, p.x, p.z),
        };
        let a = voxelize(&solids);
        let b = voxelize(&map(&solids, rot));
        for ijk in grid().index_box().iter() {
            let r = rot(ijk.as_dvec3()).as_ivec3();
            prop_assert_eq!(a.density.get(ijk), b.density.get(r), "at {}", ijk);
        }
    }
}

#[test]
fn same_volume_for_one_and_two_threads() {
    let solids = vec![
        Solid::new(
            Shape::Sphere(Sphere::new(DVec3::splat(19.3), 13.7).unwrap()),
            [1.0, 0.0, 0.0],
        ),
        Solid::new(
            Shape::AxisBox(AxisBox::new(DVec3::splat(4.1), DVec3::new(30.2, 12.9, 20.0)).unwrap()),
            [0.0, 1.0, 0.0],
        ),
    ];
    let run = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| voxelize_solids(&grid(), &solids, true, &NoProgress).to_dense().unwrap())
    };
    assert_eq!(run(1), run(2));
}
