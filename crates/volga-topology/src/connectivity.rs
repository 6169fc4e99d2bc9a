//! 6-, 18- and 26-adjacency (survey 17.2): `volga-core`'s [`Adjacency`], under the name
//! the validator uses, plus what only the run labelling needs.

use serde::Serializer;
use volga_core::Adjacency;

/// Adjacency between voxels (survey 17.2): the one [`Adjacency`] type of `volga-core`
/// (offsets, `opposite`, `adjacent`, `from_number` live there). Serialized in reports
/// as the number `6`, `18` or `26`.
pub type Connectivity = Adjacency;

/// Serializes a [`Connectivity`] as its number (`#[serde(serialize_with)]`).
pub(crate) fn serialize_number<S: Serializer>(c: &Connectivity, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.serialize_u32(c.number())
}

/// Forward neighbour rows of the run labelling: `(dy, dz, x_reach)`. A run in row
/// `(y, z)` touches a run in row `(y + dy, z + dz)` when their x ranges overlap after
/// widening one of them by `x_reach` voxels on each side. Only rows after `(y, z)` in
/// (z, y) order are listed, so every pair of rows is visited once.
///
/// Derivation: a voxel pair differs by `(dx, dy, dz)` with `|d| ≤ 1`. Across a face row
/// (one of dy, dz non-zero) 18- and 26-adjacency allow `dx = ±1` (two coordinates
/// differ), 6 does not. Across a diagonal row (both non-zero) 26 allows `dx = ±1`,
/// 18 needs `dx = 0` (already two coordinates differ), 6 has no diagonal rows.
type RowStep = (i32, i32, u32);
const ROWS_6: [RowStep; 2] = [(1, 0, 0), (0, 1, 0)];
const ROWS_18: [RowStep; 4] = [(1, 0, 1), (-1, 1, 0), (0, 1, 1), (1, 1, 0)];
const ROWS_26: [RowStep; 4] = [(1, 0, 1), (-1, 1, 1), (0, 1, 1), (1, 1, 1)];

/// Forward neighbour rows for the run labelling (see `RowStep`).
pub(crate) fn row_steps(connectivity: Connectivity) -> &'static [RowStep] {
    match connectivity {
        Adjacency::Six => &ROWS_6,
        Adjacency::Eighteen => &ROWS_18,
        Adjacency::TwentySix => &ROWS_26,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::IVec3;

    #[test]
    fn row_steps_cover_exactly_the_offsets_with_dy_or_dz() {
        // Every offset with (dy, dz) ≠ 0 is reached by a forward row step (or the
        // mirror of one), with |dx| ≤ x_reach; no other offset is.
        for c in Connectivity::ALL {
            let mut covered = Vec::new();
            for &(dy, dz, reach) in row_steps(c) {
                for dx in -(reach as i32)..=reach as i32 {
                    covered.push(IVec3::new(dx, dy, dz));
                    covered.push(-IVec3::new(dx, dy, dz));
                }
            }
            covered.sort_by_key(|d| (d.z, d.y, d.x));
            let mut expected: Vec<IVec3> = c.offsets().iter().copied().filter(|d| d.y != 0 || d.z != 0).collect();
            expected.sort_by_key(|d| (d.z, d.y, d.x));
            assert_eq!(covered, expected, "{c}");
        }
    }
}
