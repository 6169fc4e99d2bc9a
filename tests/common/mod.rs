//! Helpers shared by the integration tests: the brute-force discrete topology of
//! `volga_topology::brute` (one copy for the whole workspace) on dense volumes.
#![allow(dead_code)]

use glam::IVec3;
use volga::voxelize::Separability;
use volga::DenseVolume;

pub fn black(v: &DenseVolume, ijk: IVec3) -> bool {
    v.density.get(ijk) > 0.5
}

/// The N-neighbourhood offsets (half of them: one of each ±o pair).
pub fn half_steps(sep: Separability) -> Vec<IVec3> {
    sep.half_offsets().to_vec()
}

/// Which voxels an N-flood fill reaches from the white voxels on the grid border
/// (indexed by the density's `Shape3`).
pub fn flood_from_border(v: &DenseVolume, sep: Separability) -> Vec<bool> {
    volga_topology::brute::flood_from_border(v.density.shape(), |ijk| black(v, ijk), sep)
}
