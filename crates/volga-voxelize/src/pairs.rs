//! Binning work items into bricks: (brick, item) pairs in a fixed order.

use glam::IVec3;
use rayon::prelude::*;
use volga_core::{IndexBox, Shape3};

/// Bits per axis of a packed brick key (2²¹ bricks = 16.7M voxels per axis).
const KEY_BITS: u32 = 21;

/// Sorts `(brick, item)` pairs by brick (z, y, x), then item: the order bricks are
/// processed and stored in, independent of thread count. Bricks of a grid are
/// non-negative; packed into one `u64` key the sort compares plain integers (several
/// times faster than comparing tuples), with the tuple sort as fallback for bricks that
/// do not fit the key.
pub(crate) fn sort_brick_pairs(pairs: &mut Vec<(IVec3, u32)>) {
    let limit = 1i32 << KEY_BITS;
    if pairs
        .par_iter()
        .any(|(b, _)| b.cmplt(IVec3::ZERO).any() || b.cmpge(IVec3::splat(limit)).any())
    {
        pairs.par_sort_unstable_by_key(|(b, i)| (b.z, b.y, b.x, *i));
        return;
    }
    let mut keyed: Vec<(u64, u32)> = pairs
        .par_iter()
        .map(|(b, i)| {
            (
                ((b.z as u64) << (2 * KEY_BITS)) | ((b.y as u64) << KEY_BITS) | b.x as u64,
                *i,
            )
        })
        .collect();
    keyed.par_sort_unstable();
    let mask = (1u64 << KEY_BITS) - 1;
    pairs.clear();
    pairs.par_extend(keyed.into_par_iter().map(|(k, i)| {
        let b = IVec3::new(
            (k & mask) as i32,
            ((k >> KEY_BITS) & mask) as i32,
            (k >> (2 * KEY_BITS)) as i32,
        );
        (b, i)
    }));
}

/// Items binned by the bricks (or larger cells, [`bin_by_cell`]) their index ranges
/// touch, bricks in storage order (z, y, x) with their items ascending.
pub(crate) struct BrickBins {
    pub(crate) bricks: Vec<IVec3>,
    /// Items of brick `k`: `items[starts[k]..starts[k + 1]]`.
    starts: Vec<usize>,
    items: Vec<u32>,
}

impl BrickBins {
    pub(crate) fn items(&self, k: usize) -> &[u32] {
        &self.items[self.starts[k]..self.starts[k + 1]]
    }
}

/// Bins item `i` into every cubic cell of `cell_dim` voxels (a brick, or a block of
/// bricks) its (index-space) range `ranges[i]` touches, `cell_extent` cells along each
/// axis; `bricks` then holds cell coordinates. Pairs are packed as `linear cell index <<
/// 32 | item` and sorted as plain integers; grids of 2³² cells or more take the tuple
/// sort.
pub(crate) fn bin_by_cell(ranges: &[IndexBox], cell_dim: i32, cell_extent: IVec3) -> BrickBins {
    let dim = IVec3::splat(cell_dim);
    let bricks_of = |r: &IndexBox| {
        if r.is_empty() {
            (IVec3::ZERO, IVec3::ZERO)
        } else {
            (r.min.div_euclid(dim), (r.max - 1).div_euclid(dim) + 1)
        }
    };
    // Packed keys need the cell layout to index fewer than 2³² cells.
    let packed = Shape3::new(cell_extent.max(IVec3::ONE).as_uvec3())
        .ok()
        .filter(|shape| shape.len() <= u32::MAX as usize && ranges.len() <= u32::MAX as usize);
    let Some(shape) = packed else {
        let mut pairs: Vec<(IVec3, u32)> = ranges
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, r)| {
                let (lo, hi) = bricks_of(r);
                IndexBox::new(lo, hi)
                    .iter()
                    .map(move |b| (b, i as u32))
                    .collect::<Vec<_>>()
            })
            .collect();
        sort_brick_pairs(&mut pairs);
        let mut bins = BrickBins {
            bricks: Vec::new(),
            starts: vec![0],
            items: pairs.iter().map(|p| p.1).collect(),
        };
        for group in pairs.chunk_by(|a, b| a.0 == b.0) {
            bins.bricks.push(group[0].0);
            bins.starts.push(bins.starts.last().copied().unwrap_or(0) + group.len());
        }
        return bins;
    };
    let mut keys: Vec<u64> = ranges
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, r)| {
            let (lo, hi) = bricks_of(r);
            (lo.z..hi.z).flat_map(move |z| {
                (lo.y..hi.y).flat_map(move |y| {
                    (lo.x..hi.x).map(move |x| (shape.linearize(IVec3::new(x, y, z)) as u64) << 32 | i as u64)
                })
            })
        })
        .collect();
    keys.par_sort_unstable();
    let mut bins = BrickBins {
        bricks: Vec::new(),
        starts: vec![0],
        items: keys.par_iter().map(|k| *k as u32).collect(),
    };
    let mut start = 0;
    for group in keys.chunk_by(|a, b| a >> 32 == b >> 32) {
        bins.bricks.push(shape.delinearize((group[0] >> 32) as usize));
        start += group.len();
        bins.starts.push(start);
    }
    bins
}

/// Interleaves the low 21 bits of `x`, `y`, `z` (x lowest): a Morton (Z-order) code.
pub(crate) fn morton3(x: u64, y: u64, z: u64) -> u64 {
    let spread = |v: u64| {
        let mut x = v & 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    spread(x) | spread(y) << 1 | spread(z) << 2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_order_as_the_tuple_sort() {
        let mut state = 12345u64;
        let mut next = |m: i32| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((state >> 33) % m as u64) as i32
        };
        let pairs: Vec<(IVec3, u32)> = (0..5000)
            .map(|_| (IVec3::new(next(40), next(40), next(40)), next(100) as u32))
            .collect();
        let mut a = pairs.clone();
        sort_brick_pairs(&mut a);
        let mut b = pairs;
        b.sort_unstable_by_key(|(b, i)| (b.z, b.y, b.x, *i));
        assert_eq!(a, b);
        // Negative bricks take the fallback and still sort.
        let mut c = vec![(IVec3::new(-1, 0, 0), 1), (IVec3::new(0, 0, 0), 0)];
        sort_brick_pairs(&mut c);
        assert_eq!(c[0].0, IVec3::new(-1, 0, 0));
    }

    #[test]
    fn bins_match_the_pair_sort() {
        let mut state = 99u64;
        let mut next = |m: i32| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((state >> 33) % m as u64) as i32
        };
        let extent = IVec3::new(5, 7, 3);
        let ranges: Vec<IndexBox> = (0..300)
            .map(|_| {
                let lo = IVec3::new(next(40), next(56), next(24));
                IndexBox::new(lo, lo + IVec3::new(next(12), next(12), next(12)))
                    .intersection(&IndexBox::new(IVec3::ZERO, extent * 8))
            })
            .collect();
        let mut pairs: Vec<(IVec3, u32)> = Vec::new();
        for (i, r) in ranges.iter().enumerate() {
            if !r.is_empty() {
                for b in IndexBox::new(
                    r.min.div_euclid(IVec3::splat(8)),
                    (r.max - 1).div_euclid(IVec3::splat(8)) + 1,
                )
                .iter()
                {
                    pairs.push((b, i as u32));
                }
            }
        }
        sort_brick_pairs(&mut pairs);
        // The packed keys, and a brick extent of 2⁴⁰ bricks that takes the tuple sort.
        for extent in [extent, IVec3::new(1 << 20, 1 << 20, 3)] {
            let bins = bin_by_cell(&ranges, volga_core::BRICK_DIM, extent);
            let mut flat: Vec<(IVec3, u32)> = Vec::new();
            for (k, &brick) in bins.bricks.iter().enumerate() {
                flat.extend(bins.items(k).iter().map(|&i| (brick, i)));
            }
            assert_eq!(flat, pairs, "extent {extent}");
        }
    }

    #[test]
    fn morton_interleaves_bits() {
        assert_eq!(morton3(1, 0, 0), 1);
        assert_eq!(morton3(0, 1, 0), 2);
        assert_eq!(morton3(0, 0, 1), 4);
        assert_eq!(morton3(3, 0, 0), 0b1001);
        let m = (1u64 << 21) - 1;
        assert_eq!(morton3(m, m, m), (1u64 << 63) - 1);
    }
}
