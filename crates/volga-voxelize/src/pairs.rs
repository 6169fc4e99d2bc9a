//! Binning work items into bricks: (brick, item) pairs in a fixed order.

use glam::IVec3;
use rayon::prelude::*;

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
    fn morton_interleaves_bits() {
        assert_eq!(morton3(1, 0, 0), 1);
        assert_eq!(morton3(0, 1, 0), 2);
        assert_eq!(morton3(0, 0, 1), 4);
        assert_eq!(morton3(3, 0, 0), 0b1001);
        let m = (1u64 << 21) - 1;
        assert_eq!(morton3(m, m, m), (1u64 << 63) - 1);
    }
}
