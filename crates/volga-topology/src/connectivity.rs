//! 6-, 18- and 26-adjacency (survey 17.2).

use std::fmt;

use glam::IVec3;
use serde::{Serialize, Serializer};

/// Adjacency between voxels (survey 17.2): two distinct voxels are
/// * **6-adjacent** if they share a face (differ by 1 in exactly one coordinate),
/// * **18-adjacent** if they share a face or an edge (differ by ≤ 1 in every
///   coordinate and in at most two coordinates),
/// * **26-adjacent** if they share a face, an edge or a vertex (differ by ≤ 1 in every
///   coordinate).
///
/// Serialized as the number `6`, `18` or `26`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Connectivity {
    Six,
    Eighteen,
    TwentySix,
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

/// All offsets `d ≠ 0` with `|dᵢ| ≤ 1` and at most `max_nonzero` non-zero components,
/// in (z, y, x) lexicographic order.
const fn offsets<const K: usize>(max_nonzero: i32) -> [IVec3; K] {
    let mut out = [IVec3::ZERO; K];
    let mut n = 0;
    let mut z = -1;
    while z <= 1 {
        let mut y = -1;
        while y <= 1 {
            let mut x = -1;
            while x <= 1 {
                let nonzero = (x != 0) as i32 + (y != 0) as i32 + (z != 0) as i32;
                if nonzero >= 1 && nonzero <= max_nonzero {
                    out[n] = IVec3::new(x, y, z);
                    n += 1;
                }
                x += 1;
            }
            y += 1;
        }
        z += 1;
    }
    assert!(n == K);
    out
}

static OFFSETS_6: [IVec3; 6] = offsets(1);
static OFFSETS_18: [IVec3; 18] = offsets(2);
static OFFSETS_26: [IVec3; 26] = offsets(3);

impl Connectivity {
    pub const ALL: [Connectivity; 3] = [Connectivity::Six, Connectivity::Eighteen, Connectivity::TwentySix];

    /// 6, 18 or 26: the number of neighbours of a voxel.
    pub fn number(self) -> u32 {
        match self {
            Connectivity::Six => 6,
            Connectivity::Eighteen => 18,
            Connectivity::TwentySix => 26,
        }
    }

    /// The connectivity with `number` neighbours, if it is 6, 18 or 26.
    pub fn from_number(number: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.number() == number)
    }

    /// The "opposite" type used for the other colour (survey 17.2: 6 is opposite to
    /// 26 or to 18): 26 for 6, and 6 for 18 and 26.
    pub fn opposite(self) -> Self {
        match self {
            Connectivity::Six => Connectivity::TwentySix,
            Connectivity::Eighteen | Connectivity::TwentySix => Connectivity::Six,
        }
    }

    /// Offsets to the N-neighbours, in (z, y, x) lexicographic order.
    pub fn offsets(self) -> &'static [IVec3] {
        match self {
            Connectivity::Six => &OFFSETS_6,
            Connectivity::Eighteen => &OFFSETS_18,
            Connectivity::TwentySix => &OFFSETS_26,
        }
    }

    /// Most coordinates in which two adjacent voxels may differ (1, 2 or 3).
    fn max_nonzero(self) -> i32 {
        match self {
            Connectivity::Six => 1,
            Connectivity::Eighteen => 2,
            Connectivity::TwentySix => 3,
        }
    }

    /// Whether voxels `a` and `b` are N-adjacent (a voxel is not adjacent to itself).
    pub fn adjacent(self, a: IVec3, b: IVec3) -> bool {
        let d = (b - a).abs();
        let nonzero = d.cmpne(IVec3::ZERO).bitmask().count_ones() as i32;
        d.max_element() <= 1 && nonzero >= 1 && nonzero <= self.max_nonzero()
    }

    /// Forward neighbour rows for the run labelling (see `RowStep`).
    pub(crate) fn row_steps(self) -> &'static [RowStep] {
        match self {
            Connectivity::Six => &ROWS_6,
            Connectivity::Eighteen => &ROWS_18,
            Connectivity::TwentySix => &ROWS_26,
        }
    }
}

impl fmt::Display for Connectivity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

impl Serialize for Connectivity {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_u32(self.number())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_tables_match_the_survey_counts() {
        for c in Connectivity::ALL {
            let o = c.offsets();
            assert_eq!(o.len() as u32, c.number());
            assert!(o.iter().all(|&d| c.adjacent(IVec3::ZERO, d)));
            assert!(o
                .windows(2)
                .all(|w| (w[0].z, w[0].y, w[0].x) < (w[1].z, w[1].y, w[1].x)));
            assert_eq!(Connectivity::from_number(c.number()), Some(c));
        }
        // 6 face, 12 edge, 8 vertex neighbours.
        let d = |x, y, z| IVec3::new(x, y, z);
        assert!(Connectivity::Six.adjacent(d(0, 0, 0), d(0, 0, 1)));
        assert!(!Connectivity::Six.adjacent(d(0, 0, 0), d(0, 1, 1)));
        assert!(Connectivity::Eighteen.adjacent(d(0, 0, 0), d(0, 1, 1)));
        assert!(!Connectivity::Eighteen.adjacent(d(0, 0, 0), d(1, 1, 1)));
        assert!(Connectivity::TwentySix.adjacent(d(0, 0, 0), d(1, 1, 1)));
        assert!(!Connectivity::TwentySix.adjacent(d(0, 0, 0), d(0, 0, 0)));
        assert!(!Connectivity::TwentySix.adjacent(d(0, 0, 0), d(2, 0, 0)));
        assert_eq!(Connectivity::from_number(8), None);
    }

    #[test]
    fn row_steps_cover_exactly_the_offsets_with_dy_or_dz() {
        // Every offset with (dy, dz) ≠ 0 is reached by a forward row step (or the
        // mirror of one), with |dx| ≤ x_reach; no other offset is.
        for c in Connectivity::ALL {
            let mut covered = Vec::new();
            for &(dy, dz, reach) in c.row_steps() {
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
