//! Euler characteristic and Betti numbers of the black set as a union of cubes.

use rayon::prelude::*;
use serde::Serialize;

use crate::{black_components, white_components, Connectivity, VoxelSet};

/// Contribution of one lattice point to `χ = V − E + F − C`, indexed by the 8-bit
/// configuration of the voxels around it.
///
/// Every vertex, edge, face and cube of the cubical complex is *owned* by its
/// smallest corner `p`. Voxel `v` is the closed cube `[v, v + 1]³`; the voxels around
/// lattice point `p` are `p − 1 + (a, b, c)`, `a, b, c ∈ {0, 1}`, bit `a + 2b + 4c`.
/// Owned by `p`: the vertex `p` (present if any of the 8 voxels is black), the edge
/// from `p` along x (present if a black voxel has `a = 1`; likewise y with `b = 1`, z
/// with `c = 1`), the face spanning x and y at `p` (a black voxel with `a = b = 1`;
/// likewise xz, yz) and the cube `p` itself (bit 7).
const fn euler_table() -> [i8; 256] {
    let mut table = [0i8; 256];
    let mut config = 1;
    while config < 256 {
        let mut any = [false; 8]; // vertex, ex, ey, ez, fxy, fxz, fyz, cube
        let mut bit = 0;
        while bit < 8 {
            if config & (1 << bit) != 0 {
                let (a, b, c) = (bit & 1 != 0, bit & 2 != 0, bit & 4 != 0);
                any[0] = true;
                any[1] |= a;
                any[2] |= b;
                any[3] |= c;
                any[4] |= a && b;
                any[5] |= a && c;
                any[6] |= b && c;
                any[7] |= a && b && c;
            }
            bit += 1;
        }
        // Signs of vertex, 3 edges, 3 faces, cube.
        let signs = [1i8, -1, -1, -1, 1, 1, 1, -1];
        let mut sum = 0i8;
        let mut i = 0;
        while i < 8 {
            sum += signs[i] * any[i] as i8;
            i += 1;
        }
        table[config] = sum;
        config += 1;
    }
    table
}

static EULER_TABLE: [i8; 256] = euler_table();

/// Euler characteristic `χ = V − E + F − C` of the black voxels as a union of closed
/// unit cubes (distinct vertices, edges, faces and cubes of the cubical complex).
///
/// Sparse: only lattice points at corners of black voxels are visited, row by row,
/// lattice planes in parallel; the integer sum is exact, so the result does not
/// depend on the thread count.
pub fn euler_characteristic(set: &VoxelSet) -> i64 {
    let dims = set.dims().as_ivec3();
    (0..=dims.z)
        .into_par_iter()
        .map(|pz| {
            let mut candidates = Vec::new();
            let mut sum = 0i64;
            for py in 0..=dims.y {
                // The four voxel rows around lattice row (py, pz): index b + 2c.
                let rows = [
                    set.row(py - 1, pz - 1),
                    set.row(py, pz - 1),
                    set.row(py - 1, pz),
                    set.row(py, pz),
                ];
                candidates.clear();
                for row in rows {
                    candidates.extend(row.iter().flat_map(|&x| [x, x + 1]));
                }
                candidates.sort_unstable();
                candidates.dedup();
                let mut cursors = [0usize; 4];
                for &px in &candidates {
                    let mut config = 0usize;
                    for (k, row) in rows.iter().enumerate() {
                        // Queries px − 1, px rise monotonically over the candidates.
                        let cursor = &mut cursors[k];
                        while *cursor < row.len() && row[*cursor] + 1 < px {
                            *cursor += 1;
                        }
                        let here = &row[*cursor..];
                        let left = px > 0 && here.first() == Some(&(px - 1));
                        let right = here.iter().take(2).any(|&x| x == px);
                        let shift = 2 * k; // bit a + 2b + 4c with k = b + 2c
                        config |= (left as usize) << shift | (right as usize) << (shift + 1);
                    }
                    sum += EULER_TABLE[config] as i64;
                }
            }
            sum
        })
        .sum()
}

/// Betti numbers of the black voxels as a union of closed unit cubes.
///
/// They hold for the (26, 6) adjacency pair, whatever connectivity a caller analyses
/// separability with: closed cubes meet exactly when their voxels are 26-adjacent,
/// and the open complement connects exactly through shared faces (6-adjacency).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Betti {
    /// Connected pieces: 26-components of black.
    pub b0: u64,
    /// Handles (tunnels through the solid, as in a torus): `b0 + b2 − χ`.
    pub b1: u64,
    /// Cavities: white 6-components not touching the grid border (the outside of the
    /// grid counts as white here, so every border component is part of the
    /// unbounded complement).
    pub b2: u64,
    /// `χ = b0 − b1 + b2`.
    pub euler_characteristic: i64,
}

/// [`Betti`] numbers of `set` (computes `χ`, black 26- and white 6-components).
pub fn betti_numbers(set: &VoxelSet) -> Betti {
    let b0 = black_components(set, Connectivity::TwentySix).len() as u64;
    let b2 = white_components(set, Connectivity::Six).interior().count() as u64;
    betti_from(b0, b2, euler_characteristic(set))
}

pub(crate) fn betti_from(b0: u64, b2: u64, euler_characteristic: i64) -> Betti {
    let b1 = b0 as i64 + b2 as i64 - euler_characteristic;
    debug_assert!(b1 >= 0, "b1 = {b1} < 0: χ inconsistent with b0 = {b0}, b2 = {b2}");
    Betti {
        b0,
        b1: b1.max(0) as u64,
        b2,
        euler_characteristic,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{IVec3, UVec3};

    #[test]
    fn table_of_single_cube_configurations() {
        // A lone cube has 8 corners; summing the table over its corners gives χ = 1.
        let total: i64 = (0..8).map(|bit| EULER_TABLE[1 << bit] as i64).sum();
        assert_eq!(total, 1);
        assert_eq!(EULER_TABLE[0], 0);
    }

    #[test]
    fn cursor_handles_adjacent_voxels() {
        // A 1×1×4 bar and a 4×1×1 bar: χ = 1 each.
        let bar_x = VoxelSet::from_voxels(UVec3::new(4, 1, 1), (0..4).map(|x| IVec3::new(x, 0, 0))).unwrap();
        assert_eq!(euler_characteristic(&bar_x), 1);
        let bar_z = VoxelSet::from_voxels(UVec3::new(1, 1, 4), (0..4).map(|z| IVec3::new(0, 0, z))).unwrap();
        assert_eq!(euler_characteristic(&bar_z), 1);
    }
}
