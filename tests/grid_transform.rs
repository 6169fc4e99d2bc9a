//! World ↔ index transforms: round trips with anisotropic spacing and far origins.

use glam::{DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga::{Aabb, Grid, Transform};

fn v3(range: std::ops::Range<f64>) -> impl Strategy<Value = DVec3> {
    (range.clone(), range.clone(), range).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

proptest! {
    #[test]
    fn world_index_round_trip(origin in v3(-1e6..1e6), spacing in v3(1e-3..10.0), p in v3(-1e3..1e3)) {
        let t = Transform::new(origin, spacing).unwrap();
        let world = origin + p;
        let back = t.index_to_world(t.world_to_index(world));
        // Relative to the magnitude of the coordinates involved (f64 ulp ~ 1e-16).
        let scale = origin.abs().max_element().max(1.0);
        prop_assert!((back - world).abs().max_element() <= 4.0 * f64::EPSILON * scale);
        let index = t.world_to_index(world);
        let again = t.world_to_index(t.index_to_world(index));
        prop_assert!((again - index).abs().max_element() <= 4.0 * f64::EPSILON * scale / spacing.min_element());
    }

    #[test]
    fn voxel_centres_map_to_integers_at_1e6(ijk in (0i32..4096, 0i32..4096, 0i32..4096)) {
        // Far from the origin, voxel centres still land on their integer index
        // (to far better than a millionth of a voxel), anisotropic spacing included.
        let t = Transform::new(DVec3::new(1e6, -1e6, 1e6), DVec3::new(0.5, 0.25, 2.0)).unwrap();
        let ijk = IVec3::new(ijk.0, ijk.1, ijk.2);
        let index = t.world_to_index(t.voxel_center(ijk));
        prop_assert!((index - ijk.as_dvec3()).abs().max_element() < 1e-6);
        prop_assert_eq!(t.nearest_voxel(t.voxel_center(ijk)), ijk);
    }

    #[test]
    fn nearest_voxel_inside_its_cell(p in v3(-50.0..50.0)) {
        let t = Transform::new(DVec3::new(0.25, -3.0, 7.0), DVec3::new(0.5, 1.0, 2.0)).unwrap();
        let ijk = t.nearest_voxel(p);
        let c = t.voxel_center(ijk);
        let half = t.spacing() * 0.5;
        // Half-open cell: [c − h/2, c + h/2).
        prop_assert!((p - (c - half)).min_element() >= -1e-12);
        prop_assert!(((c + half) - p).min_element() > -1e-12);
    }
}

#[test]
fn grid_covering_bounds_and_voxel_count() {
    let b = Aabb::new(DVec3::new(1e6, 1e6, 1e6), DVec3::new(1e6 + 8.0, 1e6 + 4.0, 1e6 + 2.0));
    let g = Grid::covering(&b, UVec3::new(16, 8, 4)).unwrap();
    assert_eq!(g.world_bounds(), b);
    assert_eq!(g.voxel_count(), 512);
    let big = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(2048)).unwrap();
    assert_eq!(big.voxel_count(), 2048u64.pow(3));
}
