//! Maximal x-runs of one colour per row: the unit the labelling works on.
//!
//! A black run is a maximal sequence of consecutive black voxels in a row; a white
//! run is a maximal gap between black voxels (a row without black voxels is one white
//! run over the whole row). Both kinds number at most `rows + black voxels`, so
//! anything linear in runs is linear in the size of the [`VoxelSet`], not in the
//! volume of its grid. Runs of the same row are separated by at least one voxel of the
//! other colour, which the adjacency sweep ([`touching_pairs`]) relies on.

use std::ops::Range;

use glam::{IVec3, UVec3};
use rayon::prelude::*;

use crate::VoxelSet;

/// Which voxels the runs cover.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Colour {
    Black,
    White,
}

/// Runs of one colour in compressed sparse rows, in (z, y, x) order: run `i` covers
/// `starts[i]..ends[i]` of its row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct RowRuns {
    pub dims: UVec3,
    /// `offsets[r]..offsets[r + 1]` are the runs of row `r = y + dims.y · z`.
    pub offsets: Vec<u32>,
    pub starts: Vec<u32>,
    pub ends: Vec<u32>,
}

impl RowRuns {
    /// The runs of `colour` in `set`, built slab by slab in parallel.
    pub fn new(set: &VoxelSet, colour: Colour) -> Self {
        let dims = set.dims();
        let (ny, nx) = (dims.y as usize, dims.x);
        let slabs: Vec<(Vec<u32>, Vec<u32>, Vec<u32>)> = (0..dims.z as usize)
            .into_par_iter()
            .map(|z| {
                let mut counts = Vec::with_capacity(ny);
                let (mut starts, mut ends) = (Vec::new(), Vec::new());
                for y in 0..ny {
                    let before = starts.len();
                    let xs = set.row_at(y + ny * z);
                    match colour {
                        Colour::Black => black_runs(xs, &mut starts, &mut ends),
                        Colour::White => white_runs(xs, nx, &mut starts, &mut ends),
                    }
                    counts.push((starts.len() - before) as u32);
                }
                (counts, starts, ends)
            })
            .collect();
        let total: usize = slabs.iter().map(|(_, s, _)| s.len()).sum();
        let mut runs = RowRuns {
            dims,
            offsets: Vec::with_capacity(set.row_count() + 1),
            starts: Vec::with_capacity(total),
            ends: Vec::with_capacity(total),
        };
        runs.offsets.push(0);
        let mut acc = 0u32;
        for (counts, starts, ends) in slabs {
            for c in counts {
                acc += c;
                runs.offsets.push(acc);
            }
            runs.starts.extend_from_slice(&starts);
            runs.ends.extend_from_slice(&ends);
        }
        runs
    }

    pub fn len(&self) -> usize {
        self.starts.len()
    }

    /// Run indices of row `r`.
    pub fn row(&self, r: usize) -> Range<usize> {
        self.offsets[r] as usize..self.offsets[r + 1] as usize
    }

    /// Run indices of slab `z` (all rows with that z).
    pub fn slab(&self, z: usize) -> Range<usize> {
        let ny = self.dims.y as usize;
        self.offsets[z * ny] as usize..self.offsets[(z + 1) * ny] as usize
    }

    /// The run containing voxel `ijk`, which must be inside the grid.
    pub fn find(&self, ijk: IVec3) -> Option<usize> {
        let r = ijk.y as usize + self.dims.y as usize * ijk.z as usize;
        let range = self.row(r);
        let x = ijk.x as u32;
        let i = range.start + self.starts[range.clone()].partition_point(|&s| s <= x);
        if i > range.start && x < self.ends[i - 1] {
            Some(i - 1)
        } else {
            None
        }
    }

    /// Calls `touch(a, b)` for every pair of runs `a` in row `ra`, `b` in row `rb`
    /// whose x ranges overlap once widened by `reach` voxels.
    #[inline]
    pub fn for_touching(&self, ra: usize, rb: usize, reach: u32, touch: impl FnMut(usize, usize)) {
        touching_pairs(self.row(ra), self.row(rb), &self.starts, &self.ends, reach, touch);
    }
}

/// Sweep over two rows of runs (each sorted, separated by gaps ≥ 1): calls `touch` on
/// every pair with `a.start < b.end + reach && b.start < a.end + reach`, `reach ≤ 1`.
///
/// After testing a pair, advance the run that ends first. If `a.end ≤ b.end`, every
/// later run `b'` starts at `b'.start ≥ b.end + 1 ≥ a.end + reach`, so `a` touches
/// nothing after `b`. Otherwise `b.end < a.end` and every later `a'` starts at
/// `a'.start ≥ a.end + 1 > b.end + reach`, so `b` is done.
fn touching_pairs(
    a: Range<usize>,
    b: Range<usize>,
    starts: &[u32],
    ends: &[u32],
    reach: u32,
    mut touch: impl FnMut(usize, usize),
) {
    let (mut i, mut j) = (a.start, b.start);
    while i < a.end && j < b.end {
        if starts[i] < ends[j] + reach && starts[j] < ends[i] + reach {
            touch(i, j);
        }
        if ends[i] <= ends[j] {
            i += 1;
        } else {
            j += 1;
        }
    }
}

fn black_runs(xs: &[u32], starts: &mut Vec<u32>, ends: &mut Vec<u32>) {
    let mut iter = xs.iter().copied();
    let Some(first) = iter.next() else { return };
    let (mut start, mut end) = (first, first + 1);
    for x in iter {
        if x != end {
            starts.push(start);
            ends.push(end);
            start = x;
        }
        end = x + 1;
    }
    starts.push(start);
    ends.push(end);
}

fn white_runs(xs: &[u32], nx: u32, starts: &mut Vec<u32>, ends: &mut Vec<u32>) {
    let mut cursor = 0;
    for &x in xs {
        if x > cursor {
            starts.push(cursor);
            ends.push(x);
        }
        cursor = x + 1;
    }
    if cursor < nx {
        starts.push(cursor);
        ends.push(nx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_of_both_colours() {
        let xs = [0, 1, 2, 5, 7, 8];
        let (mut s, mut e) = (vec![], vec![]);
        black_runs(&xs, &mut s, &mut e);
        assert_eq!((s, e), (vec![0, 5, 7], vec![3, 6, 9]));
        let (mut s, mut e) = (vec![], vec![]);
        white_runs(&xs, 10, &mut s, &mut e);
        assert_eq!((s, e), (vec![3, 6, 9], vec![5, 7, 10]));
        let (mut s, mut e) = (vec![], vec![]);
        white_runs(&[], 4, &mut s, &mut e);
        assert_eq!((s, e), (vec![0], vec![4]));
    }

    #[test]
    fn sweep_finds_every_touching_pair() {
        // Brute force over all pairs of two small rows.
        let rows: [(&[u32], &[u32]); 4] = [
            (&[0, 4, 8], &[2, 6, 10]),
            (&[0, 3], &[1, 9]),
            (&[5], &[0, 2, 4, 6]),
            (&[0, 2, 4], &[0, 2, 4]),
        ];
        for (a_starts, b_starts) in rows {
            for reach in 0..=1 {
                let starts: Vec<u32> = a_starts.iter().chain(b_starts).copied().collect();
                let ends: Vec<u32> = starts.iter().map(|s| s + 1).collect();
                let a = 0..a_starts.len();
                let b = a_starts.len()..starts.len();
                let mut found = vec![];
                touching_pairs(a.clone(), b.clone(), &starts, &ends, reach, |i, j| found.push((i, j)));
                found.sort();
                let mut expected = vec![];
                for i in a.clone() {
                    for j in b.clone() {
                        if starts[i] < ends[j] + reach && starts[j] < ends[i] + reach {
                            expected.push((i, j));
                        }
                    }
                }
                assert_eq!(found, expected, "{a_starts:?} {b_starts:?} reach {reach}");
            }
        }
    }
}
