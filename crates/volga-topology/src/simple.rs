//! N-simple voxels and N-minimality (survey 17.2), exact and local tests.

use glam::IVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::components::ivec3;
use crate::{white_components, Components, Connectivity, VoxelSet};

/// Whether black voxel `ijk` is N-simple: its white N-neighbours (inside the grid)
/// all belong to at most one white N-component, so making it white merges no two
/// white regions. `white` must be [`white_components`] of `set` (its connectivity is
/// N). Exact (see the crate doc). A voxel that is not black is not simple.
pub fn is_simple(set: &VoxelSet, white: &Components, ijk: IVec3) -> bool {
    set.contains(ijk) && merged_labels(white, ijk).is_none()
}

/// The first two distinct white labels among the N-neighbours of `ijk`, with a
/// witness voxel of each, or `None` if there are fewer than two.
fn merged_labels(white: &Components, ijk: IVec3) -> Option<[(u32, IVec3); 2]> {
    let mut first: Option<(u32, IVec3)> = None;
    for &d in white.connectivity().offsets() {
        let q = ijk + d;
        if let Some(label) = white.label_at(q) {
            match first {
                None => first = Some((label, q)),
                Some(f) if f.0 != label => return Some([f, (label, q)]),
                Some(_) => {}
            }
        }
    }
    None
}

/// The N-simple black voxels of `set` in (z, y, x) order (exact test, see
/// [`is_simple`]).
pub fn simple_voxels(set: &VoxelSet, connectivity: Connectivity) -> Vec<IVec3> {
    simple_voxels_with(set, &white_components(set, connectivity))
}

/// [`simple_voxels`] with the white components already computed.
pub fn simple_voxels_with(set: &VoxelSet, white: &Components) -> Vec<IVec3> {
    count_simple_voxels(set, white, usize::MAX).1
}

/// Whether `set` is N-minimal (survey 17.2): N-separating and without N-simple
/// voxels.
pub fn is_minimal(set: &VoxelSet, connectivity: Connectivity) -> bool {
    let white = white_components(set, connectivity);
    white.len() >= 2 && first_simple_voxel(set, &white).is_none()
}

/// The number of N-simple voxels and the first `listed` of them in (z, y, x) order,
/// without materializing the rest.
pub(crate) fn count_simple_voxels(set: &VoxelSet, white: &Components, listed: usize) -> (u64, Vec<IVec3>) {
    let dims = set.dims();
    let ny = dims.y as usize;
    let slabs: Vec<(u64, Vec<IVec3>)> = (0..dims.z as usize)
        .into_par_iter()
        .map(|z| {
            let (mut count, mut first) = (0u64, Vec::new());
            for y in 0..ny {
                for &x in set.row_at(y + ny * z) {
                    let ijk = IVec3::new(x as i32, y as i32, z as i32);
                    if merged_labels(white, ijk).is_none() {
                        count += 1;
                        if first.len() < listed {
                            first.push(ijk);
                        }
                    }
                }
            }
            (count, first)
        })
        .collect();
    let count = slabs.iter().map(|s| s.0).sum();
    let first = slabs.into_iter().flat_map(|s| s.1).take(listed).collect();
    (count, first)
}

/// The first N-simple voxel in (z, y, x) order, if any.
fn first_simple_voxel(set: &VoxelSet, white: &Components) -> Option<IVec3> {
    let ny = set.dims().y as usize;
    (0..set.row_count()).into_par_iter().find_map_first(|r| {
        let (y, z) = ((r % ny) as i32, (r / ny) as i32);
        set.row_at(r)
            .iter()
            .map(|&x| IVec3::new(x as i32, y, z))
            .find(|&ijk| merged_labels(white, ijk).is_none())
    })
}

/// Where making a black voxel white would join two white regions: the voxel and one
/// white N-neighbour in each of two different white components.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Leak {
    /// The black voxel whose removal opens the passage.
    #[serde(serialize_with = "ivec3")]
    pub voxel: IVec3,
    /// White labels of the two regions joined (the first two met in offset order).
    pub components: [u32; 2],
    /// A white N-neighbour of `voxel` in each of the two regions.
    #[serde(serialize_with = "ivec3_pair")]
    pub white_voxels: [IVec3; 2],
}

fn ivec3_pair<S: serde::Serializer>(v: &[IVec3; 2], serializer: S) -> Result<S::Ok, S::Error> {
    [v[0].to_array(), v[1].to_array()].serialize(serializer)
}

/// For each of `voxels` (in the given order) that is black and not N-simple, the
/// leak its removal would open, located by a white voxel on each side. `white` must
/// be [`white_components`] of `set`. This is how a tunnel is pinned to a spot: remove
/// the voxels in question from a separating set and ask where white regions meet.
pub fn leaks_if_removed(set: &VoxelSet, white: &Components, voxels: &[IVec3]) -> Vec<Leak> {
    voxels
        .iter()
        .filter(|&&v| set.contains(v))
        .filter_map(|&voxel| {
            merged_labels(white, voxel).map(|[(la, wa), (lb, wb)]| Leak {
                voxel,
                components: [la, lb],
                white_voxels: [wa, wb],
            })
        })
        .collect()
}

/// Index `0..27` of an offset `d ∈ {-1, 0, 1}³` in the 3×3×3 neighbourhood.
const fn cube_index(x: i32, y: i32, z: i32) -> usize {
    ((x + 1) + 3 * (y + 1) + 9 * (z + 1)) as usize
}
const CENTRE: usize = cube_index(0, 0, 0);

/// For every position of the 3×3×3 cube, the bit mask of the positions N-adjacent to
/// it inside the cube.
const fn cube_adjacency(max_nonzero: i32) -> [u32; 27] {
    let mut masks = [0u32; 27];
    let mut p: usize = 0;
    while p < 27 {
        let (px, py, pz) = ((p % 3) as i32, ((p / 3) % 3) as i32, (p / 9) as i32);
        let mut q: usize = 0;
        while q < 27 {
            let (qx, qy, qz) = ((q % 3) as i32, ((q / 3) % 3) as i32, (q / 9) as i32);
            let (dx, dy, dz) = ((qx - px).abs(), (qy - py).abs(), (qz - pz).abs());
            let nonzero = (dx != 0) as i32 + (dy != 0) as i32 + (dz != 0) as i32;
            if dx <= 1 && dy <= 1 && dz <= 1 && nonzero >= 1 && nonzero <= max_nonzero {
                masks[p] |= 1 << q;
            }
            q += 1;
        }
        p += 1;
    }
    masks
}

static CUBE_6: [u32; 27] = cube_adjacency(1);
static CUBE_18: [u32; 27] = cube_adjacency(2);
static CUBE_26: [u32; 27] = cube_adjacency(3);

/// Local 3×3×3 test: black voxel `ijk` is *locally* N-simple if its white
/// N-neighbours (inside the grid) are N-connected by white voxels of the 3×3×3
/// neighbourhood minus `ijk` itself.
///
/// Costs 26 look-ups, needs no global labelling, and is **sound**: locally simple
/// implies simple ([`is_simple`]), because a local white path is a white path. The
/// converse fails when the white neighbours are connected only by paths that leave
/// the neighbourhood (see the crate doc for where the two agree). A voxel that is not
/// black is not simple.
pub fn is_simple_local(set: &VoxelSet, ijk: IVec3, connectivity: Connectivity) -> bool {
    if !set.contains(ijk) {
        return false;
    }
    let adjacency = match connectivity {
        Connectivity::Six => &CUBE_6,
        Connectivity::Eighteen => &CUBE_18,
        Connectivity::TwentySix => &CUBE_26,
    };
    let mut white = 0u32;
    for z in -1..=1 {
        for y in -1..=1 {
            for x in -1..=1 {
                let q = ijk + IVec3::new(x, y, z);
                if set.in_grid(q) && !set.contains(q) {
                    white |= 1 << cube_index(x, y, z);
                }
            }
        }
    }
    let neighbours = white & adjacency[CENTRE];
    if neighbours.count_ones() <= 1 {
        return true;
    }
    let mut reached = neighbours & neighbours.wrapping_neg(); // lowest neighbour
    let mut frontier = reached;
    while frontier != 0 {
        let mut next = 0;
        let mut bits = frontier;
        while bits != 0 {
            next |= adjacency[bits.trailing_zeros() as usize];
            bits &= bits - 1;
        }
        frontier = next & white & !reached;
        reached |= frontier;
    }
    neighbours & !reached == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_tables_count_neighbours() {
        assert_eq!(CUBE_6[CENTRE].count_ones(), 6);
        assert_eq!(CUBE_18[CENTRE].count_ones(), 18);
        assert_eq!(CUBE_26[CENTRE].count_ones(), 26);
        // A corner of the cube has 3 face, 3 edge and 1 vertex neighbours inside it.
        assert_eq!(CUBE_6[0].count_ones(), 3);
        assert_eq!(CUBE_18[0].count_ones(), 6);
        assert_eq!(CUBE_26[0].count_ones(), 7);
    }
}
