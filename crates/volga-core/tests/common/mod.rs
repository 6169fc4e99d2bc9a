//! Test volumes shared by the sampling tests.

use glam::{DVec3, UVec3};
use volga_core::{DenseVolume, Grid, SparseVolume, Transform};

/// A `dims` volume on an anisotropic grid, dense and sparse copies of the same voxels: a
/// uniform region (x < 8, value 0.75), then empty voxels with probability `empty` and
/// noise elsewhere (a linear congruential stream from `seed`), so uniform, dense and
/// absent bricks all occur; dims that are not multiples of 8 cut bricks at the grid's end.
pub fn random_volumes(seed: u64, dims: UVec3, empty: f32) -> (DenseVolume, SparseVolume) {
    let transform = Transform::new(DVec3::new(-3.0, 1.0, 0.5), DVec3::new(0.5, 0.25, 1.0)).unwrap();
    let g = Grid::new(transform, dims).unwrap();
    let mut dense = DenseVolume::new(g, 0.0, false).unwrap();
    let mut state = seed;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for ijk in g.index_box().iter() {
        let v = if ijk.x < 8 {
            0.75
        } else if next() < empty {
            0.0
        } else {
            next()
        };
        dense.density.set(ijk, v);
    }
    let sparse = SparseVolume::from_dense(&dense);
    (dense, sparse)
}
