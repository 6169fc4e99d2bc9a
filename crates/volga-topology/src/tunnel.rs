//! N-tunnels: white voxel pairs that pass through a continuous surface.

use glam::IVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::components::ivec3;
use crate::{Connectivity, VoxelSet};

/// Two N-adjacent white voxels whose connecting segment crosses the continuous
/// surface: a place where a white N-path passes through the surface without meeting
/// a black voxel. `a` precedes `b` in (z, y, x) order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Tunnel {
    /// The first voxel of the pair (index space).
    #[serde(serialize_with = "ivec3")]
    pub a: IVec3,
    /// The second voxel, N-adjacent to `a`.
    #[serde(serialize_with = "ivec3")]
    pub b: IVec3,
}

/// The N-tunnels through a continuous surface described by `crosses(a, b)`: whether
/// the segment between the centres of voxels `a` and `b` (index space) crosses the
/// surface — a sign change of an implicit function, a segment–triangle test against
/// a mesh.
///
/// Every white voxel of `candidates` (duplicates and black or out-of-grid voxels are
/// ignored) is paired with each of its white N-neighbours. Candidates should cover the
/// voxels near the surface (a narrow band around it): the cost follows them, not the
/// grid. With a complete band, no tunnel means the set is N-separating with respect to
/// that surface. Result sorted by `(a, b)` in (z, y, x) order, each pair once.
pub fn tunnels(
    set: &VoxelSet,
    connectivity: Connectivity,
    candidates: impl IntoIterator<Item = IVec3>,
    crosses: impl Fn(IVec3, IVec3) -> bool + Sync,
) -> Vec<Tunnel> {
    let key = |v: IVec3| (v.z, v.y, v.x);
    let mut candidates: Vec<IVec3> = candidates
        .into_iter()
        .filter(|&v| set.in_grid(v) && !set.contains(v))
        .collect();
    candidates.par_sort_unstable_by_key(|&v| key(v));
    candidates.dedup();
    let mut found: Vec<Tunnel> = candidates
        .par_iter()
        .flat_map_iter(|&a| {
            let crosses = &crosses;
            connectivity.offsets().iter().filter_map(move |&d| {
                let b = a + d;
                let white = set.in_grid(b) && !set.contains(b);
                if !white || !crosses(a, b) {
                    return None;
                }
                let (a, b) = if key(a) < key(b) { (a, b) } else { (b, a) };
                Some(Tunnel { a, b })
            })
        })
        .collect();
    found.par_sort_unstable_by_key(|t| (key(t.a), key(t.b)));
    found.dedup();
    found
}
