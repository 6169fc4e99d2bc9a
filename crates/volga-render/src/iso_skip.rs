//! Empty-space skipping for the packed iso path (`iso_packed.rs`), built once per
//! renderer from the iso value: which voxel cells hold no crossing, and how far a ray
//! may jump from any block of cells without meeting one.
//!
//! Three levels, all derived from one decision per voxel cell (the unit cube between
//! eight voxel centres): a cell is **outside** when its eight corners are finite and
//! below the oriented iso value, so the trilinear interpolant, a convex combination of
//! them, is below it everywhere in the cell and no crossing can lie there.
//!
//! * the cell bits, 4×4×4 cells per `u64` word (a ray's consecutive cells share words);
//! * per word (a **block** of 4³ cells) its **reach** `r`: every block within Chebyshev
//!   distance `r − 1` of it is wholly outside (blocks beyond the grid count as outside:
//!   a ray clipped to the field's bounds never reads them), so a ray in the block may
//!   jump to the exit of that `(2r − 1)³`-block cube at once — the proximity-cloud idea
//!   of Cohen and Sheffer (1994), on the cell mask instead of a distance field. `r` is
//!   the exact L∞ distance (in blocks) to the nearest block holding a cell that is not
//!   outside, capped at [`MAX_REACH`];
//! * the **active box**: the cell bases of every cell that is not outside, so a ray that
//!   misses the box (grown by [`ACTIVE_BOX_MARGIN`] cells) is decided by a box test.
//!
//! * the **front blocks**: per block holding a mixed cell (corners on both sides of the
//!   iso value, or NaN), the box of those cells, and the blocks of inside cells only:
//!   what a view's start map (`iso_starts.rs`) projects.
//!
//! None of these changes a hit: the walk over the cells is the same; they only pass
//! cells whose reading would say "outside" (tests: `iso_packed_tests.rs`).

use glam::{DVec3, IVec3, UVec3};
use rayon::prelude::*;
use volga_core::Shape3;

use crate::packed::PackedVolume;

/// Largest reach stored, in blocks of 4 cells (a 255-block cube spans 1020 cells
/// each way from its centre: more than any volume the packed copy holds per axis).
pub(crate) const MAX_REACH: u8 = 255;

/// Cells the active box is grown by on every side before a ray is tested against it,
/// so a ray that rounding places a little outside the box still walks it.
pub(crate) const ACTIVE_BOX_MARGIN: f64 = 2.0;

/// Per voxel cell of a packed volume, one bit: set when its eight corners are all
/// finite and outside the oriented iso value (`inward·v < inward·iso`), so the walk
/// passes it without reading them (the same decision `cell_crossing` takes from the
/// corners). Cells are grouped 4×4×4 per `u64` so a ray's consecutive cells share
/// words; with each word its block's reach and, for the volume, the active box (see
/// the [module docs](self)). Built once per renderer (iso value and orientation fixed).
pub(crate) struct IsoCellMask {
    /// Blocks of 4³ cells per axis; cell `base` is at `base + 1` (bases from −1 on).
    blocks: [u32; 3],
    words: Vec<u64>,
    /// Per word, the block's reach (0 unless every cell of the block is outside).
    reach: Vec<u8>,
    /// Smallest and largest base of a cell that is not outside; `None` when every
    /// cell is (no ray can cross the iso-surface).
    active: Option<(IVec3, IVec3)>,
    /// Per block holding a cell that is neither outside nor inside (corners on both
    /// sides of the iso value, or NaN), in word order: the least and largest base of
    /// those cells. What a view's start map (`iso_starts.rs`) projects.
    front_blocks: Vec<(IVec3, IVec3)>,
    /// The other blocks holding a cell that is not outside (all such cells inside):
    /// a walk meets one first only where it starts in it (see `iso_starts.rs`).
    inside_blocks: Vec<IVec3>,
}

/// Where cell `base` sits in the mask: its word and its bit in the word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct CellSlot {
    pub(crate) word: usize,
    pub(crate) bit: u32,
}

impl IsoCellMask {
    /// The mask of `packed` for the oriented iso level (in parallel; the same bits for
    /// any thread count).
    pub(crate) fn build(packed: &PackedVolume, inward: f64, iso: f64) -> IsoCellMask {
        let dims = packed.grid().dims();
        // Cells with bases −1 ..= dims − 1: dims + 1 per axis.
        let blocks = [dims.x, dims.y, dims.z].map(|n| (n + 1).div_ceil(4));
        let n = blocks[0] as usize * blocks[1] as usize * blocks[2] as usize;
        let iso = inward * iso;
        let bg = inward * packed.background() as f64;
        // Per word: its outside bits, and its mixed bits (cells neither outside nor
        // inside: some corner below the iso value and some not, or a NaN corner).
        let classified: Vec<(u64, u64)> = (0..n)
            .into_par_iter()
            .map(|w| {
                let (mut word, mut mixed) = (0u64, 0u64);
                for bit in 0..64u32 {
                    let c = super::cell_corners(packed, cell_base(blocks, w, bit), inward, bg);
                    if c.iter().all(|v| *v < iso) {
                        word |= 1 << bit;
                    } else if !c.iter().all(|v| *v >= iso) {
                        mixed |= 1 << bit;
                    }
                }
                (word, mixed)
            })
            .collect();
        let words: Vec<u64> = classified.iter().map(|c| c.0).collect();
        let reach = empty_reach(blocks, &words);
        let active = active_box(blocks, &words);
        let (mut front_blocks, mut inside_blocks) = (Vec::new(), Vec::new());
        for (w, &(word, mixed)) in classified.iter().enumerate() {
            match (word != u64::MAX, mixed != 0) {
                (false, _) => {}
                (true, true) => front_blocks.push(bases_box(blocks, w, mixed)),
                (true, false) => inside_blocks.push(delinearize(blocks, w)),
            }
        }
        IsoCellMask {
            blocks,
            words,
            reach,
            active,
            front_blocks,
            inside_blocks,
        }
    }

    /// Cell `base`'s word and bit (`None` outside the cells the mask covers).
    #[inline(always)]
    pub(crate) fn slot(&self, base: IVec3) -> Option<CellSlot> {
        let s = (base + IVec3::ONE).as_uvec3();
        let b: UVec3 = s >> 2u32;
        if !(b.x < self.blocks[0] && b.y < self.blocks[1] && b.z < self.blocks[2]) {
            return None;
        }
        let word = b.x as usize + self.blocks[0] as usize * (b.y as usize + self.blocks[1] as usize * b.z as usize);
        let bit = (s.x & 3) | ((s.y & 3) << 2) | ((s.z & 3) << 4);
        Some(CellSlot { word, bit })
    }

    /// Whether the cell in `slot` is outside.
    #[inline(always)]
    pub(crate) fn outside_at(&self, slot: CellSlot) -> bool {
        self.words[slot.word] >> slot.bit & 1 == 1
    }

    /// The reach of the block of word `word` (0: the block holds a cell that is not
    /// outside).
    #[inline(always)]
    pub(crate) fn reach(&self, word: usize) -> u8 {
        self.reach[word]
    }

    /// The index-space planes a ray in cell `base` (whose block has reach `r ≥ 1`)
    /// leaves the cube of outside blocks through, per axis and direction: along an
    /// axis, `(low, high)` such that every cell with bases in `low ..= high − 1` on every
    /// axis is outside.
    #[inline(always)]
    pub(crate) fn cube_planes(base: IVec3, r: u8) -> (IVec3, IVec3) {
        // Block b holds bases 4b − 1 ..= 4b + 2; its faces are the planes 4b − 1 and 4b + 3.
        let block = (base + IVec3::ONE) >> 2;
        let r = r as i32;
        ((block - (r - 1)) * 4 - 1, (block + r) * 4 - 1)
    }

    /// The active box grown by [`ACTIVE_BOX_MARGIN`] cells, in continuous index
    /// coordinates (a cell with base `b` spans `[b, b + 1]`); `None` when every cell is
    /// outside.
    pub(crate) fn active_index_box(&self) -> Option<(DVec3, DVec3)> {
        self.active.map(|(lo, hi)| {
            (
                lo.as_dvec3() - ACTIVE_BOX_MARGIN,
                (hi + IVec3::ONE).as_dvec3() + ACTIVE_BOX_MARGIN,
            )
        })
    }

    /// Per block holding a cell with corners on both sides of the iso value (or a
    /// NaN corner), the least and largest base of such cells: the index box
    /// `[lo, hi + 1]` holds every one of them (block `b` spans `[4b − 1, 4b + 3]`,
    /// the cells with bases `4b − 1 ..= 4b + 2`).
    pub(crate) fn front_blocks(&self) -> &[(IVec3, IVec3)] {
        &self.front_blocks
    }

    /// The blocks whose cells are all outside or inside, at least one inside.
    pub(crate) fn inside_blocks(&self) -> &[IVec3] {
        &self.inside_blocks
    }
}

/// The least and largest base of the cells of word `w` whose bits are set in `bits`
/// (not zero).
fn bases_box(blocks: [u32; 3], w: usize, bits: u64) -> (IVec3, IVec3) {
    let (mut lo, mut hi) = (IVec3::MAX, IVec3::MIN);
    let mut rest = bits;
    while rest != 0 {
        let base = cell_base(blocks, w, rest.trailing_zeros());
        rest &= rest - 1;
        (lo, hi) = (lo.min(base), hi.max(base));
    }
    (lo, hi)
}

/// The base of cell `bit` of word `w`.
fn cell_base(blocks: [u32; 3], w: usize, bit: u32) -> IVec3 {
    let b = delinearize(blocks, w);
    let local = IVec3::new((bit & 3) as i32, ((bit >> 2) & 3) as i32, (bit >> 4) as i32);
    b * 4 + local - IVec3::ONE
}

fn delinearize(blocks: [u32; 3], w: usize) -> IVec3 {
    Shape3::new(UVec3::from_array(blocks)).map_or(IVec3::ZERO, |s| s.delinearize(w))
}

/// Per block, the L∞ distance (in blocks, capped at [`MAX_REACH`]) to the nearest block
/// whose word is not all ones; blocks beyond the grid count as all ones.
///
/// Separable: with `f = 0` on the blocks that are not empty and `∞` elsewhere,
/// `D(x) = min_y max(|x₁ − y₁|, |x₂ − y₂|, |x₃ − y₃|)` is three nested 1D passes
/// `g(x) = min_y max(|x − y|, f(y))` (one per axis; `max` distributes over `min`). Each
/// pass scans outwards from `x` only while the offset is below the best found, so it
/// costs the distances it finds. Lines run in parallel; the result does not depend on
/// the thread count.
pub(crate) fn empty_reach(blocks: [u32; 3], words: &[u64]) -> Vec<u8> {
    let [nx, ny, nz] = blocks.map(|n| n as usize);
    let mut d: Vec<u8> = words
        .iter()
        .map(|w| if *w == u64::MAX { MAX_REACH } else { 0 })
        .collect();
    for axis in 0..3 {
        let (n, stride, lines) = [(nx, 1, ny * nz), (ny, nx, nx * nz), (nz, nx * ny, nx * ny)][axis];
        // The first element of every line along this axis.
        let starts: Vec<usize> = (0..lines)
            .map(|l| match axis {
                0 => l * nx,
                1 => (l % nx) + (l / nx) * nx * ny,
                _ => l,
            })
            .collect();
        let passes: Vec<Vec<u8>> = starts
            .par_iter()
            .map(|&start| {
                let f: Vec<u8> = (0..n).map(|i| d[start + i * stride]).collect();
                min_max_pass(&f)
            })
            .collect();
        for (start, line) in starts.iter().zip(passes) {
            for (i, v) in line.into_iter().enumerate() {
                d[start + i * stride] = v;
            }
        }
    }
    d
}

/// `g(x) = min_y max(|x − y|, f(y))` over one line (`f` capped at [`MAX_REACH`], which
/// stands for "none within reach").
fn min_max_pass(f: &[u8]) -> Vec<u8> {
    let n = f.len();
    (0..n)
        .map(|x| {
            let mut best = f[x] as usize;
            let mut o = 1usize;
            while o < best {
                let near = [x.checked_sub(o), Some(x + o).filter(|&y| y < n)]
                    .into_iter()
                    .flatten()
                    .map(|y| f[y] as usize)
                    .min();
                match near {
                    Some(v) => best = best.min(v.max(o)),
                    None => break, // beyond both ends: nothing nearer
                }
                o += 1;
            }
            best as u8
        })
        .collect()
}

/// The smallest and largest base of a cell whose bit is clear.
fn active_box(blocks: [u32; 3], words: &[u64]) -> Option<(IVec3, IVec3)> {
    let mut lo = IVec3::MAX;
    let mut hi = IVec3::MIN;
    for (w, &word) in words.iter().enumerate() {
        if word == u64::MAX {
            continue;
        }
        let mut clear = !word;
        while clear != 0 {
            let bit = clear.trailing_zeros();
            clear &= clear - 1;
            let base = cell_base(blocks, w, bit);
            lo = lo.min(base);
            hi = hi.max(base);
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(mut s: u64) -> impl FnMut() -> u64 {
        move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            s >> 33
        }
    }

    /// The reach against its definition, by brute force: 0 on blocks that are not
    /// empty, otherwise the least Chebyshev distance to one that is not (capped),
    /// so every block strictly nearer is empty; on random sparse masks and on the
    /// edge cases (all empty, none empty, one block).
    #[test]
    fn reach_is_the_chebyshev_distance_to_the_nearest_active_block() {
        let mut rng = lcg(7);
        let cases: Vec<([u32; 3], u32)> = vec![
            ([1, 1, 1], 0),
            ([1, 1, 1], 100),
            ([5, 3, 7], 100),
            ([5, 3, 7], 0),
            ([9, 8, 6], 3),
            ([12, 10, 11], 1),
            ([16, 2, 9], 10),
        ];
        for (blocks, percent_active) in cases {
            let n = (blocks[0] * blocks[1] * blocks[2]) as usize;
            let words: Vec<u64> = (0..n)
                .map(|_| {
                    if (rng() % 100) < percent_active as u64 {
                        u64::MAX ^ (1 << (rng() % 64))
                    } else {
                        u64::MAX
                    }
                })
                .collect();
            let reach = empty_reach(blocks, &words);
            for (w, &r) in reach.iter().enumerate() {
                let x = delinearize(blocks, w);
                let mut want = MAX_REACH as i32;
                for (v, &word) in words.iter().enumerate() {
                    if word != u64::MAX {
                        let y = delinearize(blocks, v);
                        want = want.min((x - y).abs().max_element());
                    }
                }
                assert_eq!(r as i32, want, "{blocks:?} block {x}");
            }
        }
    }

    /// The active box holds exactly the clear bits' cells.
    #[test]
    fn active_box_bounds_the_cells_that_are_not_outside() {
        let blocks = [3, 2, 4];
        let mut words = vec![u64::MAX; 24];
        assert_eq!(active_box(blocks, &words), None);
        words[1] &= !(1 << 5); // block (1, 0, 0), local (1, 1, 0): base (4, 0, −1)
        words[23] &= !(1 << 63); // block (2, 1, 3), local (3, 3, 3): base (10, 6, 14)
        assert_eq!(
            active_box(blocks, &words),
            Some((IVec3::new(4, 0, -1), IVec3::new(10, 6, 14)))
        );
    }

    /// The cube planes enclose only blocks within the reach.
    #[test]
    fn cube_planes_follow_the_block_layout() {
        // Base 2 is in block 0 (bases −1..=2); reach 1: the block itself, planes −1 and 3.
        assert_eq!(
            IsoCellMask::cube_planes(IVec3::splat(2), 1),
            (IVec3::splat(-1), IVec3::splat(3))
        );
        // Base 3 is in block 1 (bases 3..=6); reach 2: blocks 0..=2, planes −1 and 11.
        assert_eq!(
            IsoCellMask::cube_planes(IVec3::new(3, 3, 6), 2),
            (IVec3::splat(-1), IVec3::splat(11))
        );
    }
}
