//! 6-, 18- and 26-adjacency (survey §17.2): the one definition of voxel neighbourhoods.
//!
//! Binary voxelization (separability), line voxelization (connectivity of a digital
//! line) and discrete topology (components, simple voxels) all speak of the same three
//! neighbourhoods; their offsets live here only.

use std::fmt;

use glam::{DVec3, IVec3};

/// Adjacency between voxels (survey §17.2): two distinct voxels are
/// * **6-adjacent** if they share a face (differ by 1 in exactly one coordinate),
/// * **18-adjacent** if they share a face or an edge (differ by ≤ 1 in every
///   coordinate and in at most two coordinates),
/// * **26-adjacent** if they share a face, an edge or a vertex (differ by ≤ 1 in every
///   coordinate).
///
/// The same type says which white paths a binary surface blocks (its *separability*)
/// and through which neighbours a voxel set is connected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Adjacency {
    /// Face neighbours only: 6 per voxel.
    Six,
    /// Face and edge neighbours: 18 per voxel.
    Eighteen,
    /// Face, edge and vertex neighbours: 26 per voxel.
    TwentySix,
}

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
    // Compile-time check (these are evaluated in `static` initializers).
    assert!(n == K);
    out
}

/// The second half (in (z, y, x) order) of a symmetric offset table: the offsets
/// after the origin, one of each `±d` pair.
const fn upper_half<const K: usize, const H: usize>(all: [IVec3; K]) -> [IVec3; H] {
    assert!(2 * H == K);
    let mut out = [IVec3::ZERO; H];
    let mut i = 0;
    while i < H {
        out[i] = all[H + i];
        i += 1;
    }
    out
}

static OFFSETS_6: [IVec3; 6] = offsets(1);
static OFFSETS_18: [IVec3; 18] = offsets(2);
static OFFSETS_26: [IVec3; 26] = offsets(3);
static HALF_6: [IVec3; 3] = upper_half(offsets::<6>(1));
static HALF_18: [IVec3; 9] = upper_half(offsets::<18>(2));
static HALF_26: [IVec3; 13] = upper_half(offsets::<26>(3));

impl Adjacency {
    /// The three adjacencies, smallest neighbourhood first (6, 18, 26).
    pub const ALL: [Adjacency; 3] = [Adjacency::Six, Adjacency::Eighteen, Adjacency::TwentySix];

    /// 6, 18 or 26: the number of neighbours of a voxel.
    pub fn number(self) -> u32 {
        match self {
            Adjacency::Six => 6,
            Adjacency::Eighteen => 18,
            Adjacency::TwentySix => 26,
        }
    }

    /// The adjacency with `number` neighbours, if it is 6, 18 or 26.
    pub fn from_number(number: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.number() == number)
    }

    /// The "opposite" type used for the other colour (survey §17.2: 6 is opposite to
    /// 26 or to 18): 26 for 6, and 6 for 18 and 26.
    pub fn opposite(self) -> Self {
        match self {
            Adjacency::Six => Adjacency::TwentySix,
            Adjacency::Eighteen | Adjacency::TwentySix => Adjacency::Six,
        }
    }

    /// Offsets to the N-neighbours, in (z, y, x) lexicographic order.
    pub fn offsets(self) -> &'static [IVec3] {
        match self {
            Adjacency::Six => &OFFSETS_6,
            Adjacency::Eighteen => &OFFSETS_18,
            Adjacency::TwentySix => &OFFSETS_26,
        }
    }

    /// One offset of each `±d` pair of [`Adjacency::offsets`]: those after the origin in
    /// (z, y, x) order (N/2 of them). Walking these from every voxel visits each
    /// adjacent pair once.
    pub fn half_offsets(self) -> &'static [IVec3] {
        match self {
            Adjacency::Six => &HALF_6,
            Adjacency::Eighteen => &HALF_18,
            Adjacency::TwentySix => &HALF_26,
        }
    }

    /// Most coordinates in which two adjacent voxels may differ (1, 2 or 3).
    pub fn max_nonzero(self) -> i32 {
        match self {
            Adjacency::Six => 1,
            Adjacency::Eighteen => 2,
            Adjacency::TwentySix => 3,
        }
    }

    /// Whether voxels `a` and `b` are N-adjacent (a voxel is not adjacent to itself).
    pub fn adjacent(self, a: IVec3, b: IVec3) -> bool {
        let d = (b - a).abs();
        let nonzero = d.cmpne(IVec3::ZERO).bitmask().count_ones() as i32;
        d.max_element() <= 1 && nonzero >= 1 && nonzero <= self.max_nonzero()
    }

    /// Support function `max_{x ∈ K_N} a·x` of `K_N`, the convex hull of the half-steps
    /// `±o/2` of the N-neighbourhood: the octahedron `|x|+|y|+|z| ≤ ½` (6), the
    /// cuboctahedron (18), the cube `[−½, ½]³` (26). Half the largest change of `a·v`
    /// along one N-step: the plane thresholds of binary voxelization.
    #[inline]
    pub fn support(self, a: DVec3) -> f64 {
        let m = a.abs();
        match self {
            Adjacency::Six => 0.5 * m.max_element(),
            Adjacency::Eighteen => 0.5 * (m.x + m.y + m.z - m.min_element()),
            Adjacency::TwentySix => 0.5 * (m.x + m.y + m.z),
        }
    }
}

impl fmt::Display for Adjacency {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Offsets by definition: every `d ∈ {−1,0,1}³ \ 0` with at most `k` non-zero
    /// components, independent of the const tables.
    fn by_definition(c: Adjacency) -> Vec<IVec3> {
        let mut out = Vec::new();
        for z in -1..=1 {
            for y in -1..=1 {
                for x in -1..=1 {
                    let d = IVec3::new(x, y, z);
                    let k = (x != 0) as i32 + (y != 0) as i32 + (z != 0) as i32;
                    if k >= 1 && k <= c.max_nonzero() {
                        out.push(d);
                    }
                }
            }
        }
        out
    }

    #[test]
    fn offset_tables_match_the_survey_counts() {
        for c in Adjacency::ALL {
            let o = c.offsets();
            assert_eq!(o.len() as u32, c.number());
            assert_eq!(o, by_definition(c).as_slice());
            assert!(o.iter().all(|&d| c.adjacent(IVec3::ZERO, d)));
            assert_eq!(Adjacency::from_number(c.number()), Some(c));
            let half = c.half_offsets();
            assert_eq!(2 * half.len(), o.len());
            assert!(half.iter().all(|&d| (d.z, d.y, d.x) > (0, 0, 0) && o.contains(&-d)));
        }
        // 6 face, 12 edge, 8 vertex neighbours.
        let d = |x, y, z| IVec3::new(x, y, z);
        assert!(Adjacency::Six.adjacent(d(0, 0, 0), d(0, 0, 1)));
        assert!(!Adjacency::Six.adjacent(d(0, 0, 0), d(0, 1, 1)));
        assert!(Adjacency::Eighteen.adjacent(d(0, 0, 0), d(0, 1, 1)));
        assert!(!Adjacency::Eighteen.adjacent(d(0, 0, 0), d(1, 1, 1)));
        assert!(Adjacency::TwentySix.adjacent(d(0, 0, 0), d(1, 1, 1)));
        assert!(!Adjacency::TwentySix.adjacent(d(0, 0, 0), d(0, 0, 0)));
        assert!(!Adjacency::TwentySix.adjacent(d(0, 0, 0), d(2, 0, 0)));
        assert_eq!(Adjacency::from_number(8), None);
        assert_eq!(Adjacency::Eighteen.to_string(), "18");
        assert_eq!(Adjacency::Six.opposite(), Adjacency::TwentySix);
    }

    #[test]
    fn support_is_the_largest_half_step_projection() {
        // K_N is the hull of the half-steps, so its support is the largest projection
        // of a half-step.
        let dirs = [
            DVec3::new(0.3, -0.5, 0.8),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(-2.0, 0.25, 0.0),
            DVec3::Z,
        ];
        for c in Adjacency::ALL {
            for a in dirs {
                let best = c
                    .offsets()
                    .iter()
                    .map(|o| a.dot(o.as_dvec3() * 0.5))
                    .fold(f64::MIN, f64::max);
                assert!((c.support(a) - best).abs() < 1e-15, "{c} {a}");
            }
        }
    }
}
