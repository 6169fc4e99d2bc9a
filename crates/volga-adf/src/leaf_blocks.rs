//! A ray-coherent copy of the leaves the indexed walk reads (part of the walk index,
//! module `walk`).
//!
//! The walk spends its leaf steps in the grid cells that may hold the surface (minimum
//! ≤ 0, reach 0). There, the tree's layout costs a cache miss per level of the descent
//! (the 4-byte links of [`crate::walk`]) and one or two more for the leaf's 36-byte cell
//! (its corners straddle cache lines), in a 250 MB array at the bunny's 1e-4: at that
//! tolerance the surface leaves are smaller than a pixel's footprint, so neighbouring rays
//! rarely share a leaf and every load goes to memory (docs/ADF.md, "Where the remaining
//! time goes").
//!
//! Here each such grid cell's subtree is copied into one contiguous run, grid cells in
//! Morton order:
//! * **entries** (`u32`): the 8 children of an internal node, contiguous; an entry is an
//!   internal node (`INTERNAL` | the offset of its own 8 entries), a plain leaf (the slot of
//!   its corners) or a jump leaf ([`JUMP`]: the walk asks the tree, which holds its sign
//!   field). A node's children come first, then their subtrees in octant order, as in the
//!   tree.
//! * **corners**: each plain leaf's 8 `f32` distances in one 32-byte aligned record (one
//!   cache line holds two), in the order their parents were laid out, so siblings and
//!   the leaves of one grid cell sit side by side and the rays of a tile that cross that
//!   grid cell read neighbouring memory.
//!
//! The copy holds exactly the tree's values (tested leaf by leaf and through the walk,
//! which finds the same leaf, with the same box, as [`Adf::locate`]).

use glam::DVec3;

use crate::tree::{child_octant, Cell};
use crate::Adf;

/// An entry that is an internal node: or'ed with the offset of its 8 children.
const INTERNAL: u32 = 1 << 31;
/// An entry that is a jump leaf (read from the tree).
pub(crate) const JUMP: u32 = INTERNAL - 1;
/// A plain leaf entry whose 8 corners are all > 0: or'ed with its slot, so a walk for an
/// iso value ≤ 0 crosses it without reading its corners.
const POSITIVE: u32 = 1 << 30;
/// A grid cell without a block.
const NONE: u32 = u32::MAX;

/// 8 corner distances on a 32-byte boundary (two per cache line, never straddling one).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Corners(pub [f32; 8]);

/// The leaf a block gives for a point.
pub(crate) enum BlockLeaf {
    /// A plain leaf: its corners, world minimum and size.
    Plain(Corners, DVec3, f64),
    /// A plain leaf whose corners are all > 0 (not read): its world minimum and size.
    Positive(DVec3, f64),
    /// A jump leaf, or no block for this grid cell: ask the tree.
    Tree,
}

/// The ray-coherent copy of the surface grid cells' subtrees (see the module doc).
#[derive(Default)]
pub(crate) struct LeafBlocks {
    /// Per walk grid cell (index `x + n(y + n z)`): the entry of its node, or `NONE`.
    root: Vec<u32>,
    entries: Vec<u32>,
    corners: Vec<Corners>,
}

/// The 3D Morton code of `(x, y, z)`, 10 bits each.
fn morton(x: usize, y: usize, z: usize) -> u64 {
    fn spread(v: usize) -> u64 {
        let mut v = v as u64 & 0x3ff;
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    }
    spread(x) | (spread(y) << 1) | (spread(z) << 2)
}

impl LeafBlocks {
    /// Blocks for the grid cells (`n` per axis, depth `depth`) where `wanted(k)` holds
    /// and the covering node `node[k]` is at the grid's depth (`level[k] == depth`;
    /// cells inside a larger leaf keep the tree's path). Grid cells are laid out in Morton
    /// order. Stops adding blocks (the rest use the tree) if the entries would overflow
    /// the 31-bit offsets.
    pub(crate) fn build(
        cells: &[Cell],
        n: usize,
        depth: u8,
        node: &[u32],
        level: &[u8],
        wanted: impl Fn(usize) -> bool,
    ) -> LeafBlocks {
        let mut order: Vec<(u64, usize)> = (0..n * n * n)
            .filter(|&k| level[k] == depth && wanted(k))
            .map(|k| (morton(k % n, (k / n) % n, k / (n * n)), k))
            .collect();
        order.sort_unstable();
        let mut blocks = LeafBlocks {
            root: vec![NONE; n * n * n],
            entries: Vec::new(),
            corners: Vec::new(),
        };
        let limit = (POSITIVE - 8) as usize;
        for (_, k) in order {
            if blocks.entries.len() >= limit || blocks.corners.len() >= limit {
                break;
            }
            blocks.root[k] = blocks.entry_of(cells, node[k] as usize);
        }
        blocks
    }

    /// The entry for tree cell `i`: a leaf's slot (its corners pushed now) or [`JUMP`],
    /// or an internal node with its subtree copied.
    fn entry_of(&mut self, cells: &[Cell], i: usize) -> u32 {
        let c = &cells[i];
        if c.jump().is_some() {
            JUMP
        } else if c.is_leaf() {
            self.corners.push(Corners(c.corners));
            let positive = if c.corners.iter().all(|&v| v > 0.0) { POSITIVE } else { 0 };
            (self.corners.len() - 1) as u32 | positive
        } else {
            let at = self.entries.len();
            self.entries.extend_from_slice(&[0; 8]);
            // Leaves first, so the 8 siblings' corners are contiguous…
            for o in 0..8 {
                let child = &cells[c.children as usize + o];
                if child.is_leaf() {
                    self.entries[at + o] = self.entry_of(cells, c.children as usize + o);
                }
            }
            // …then the internal children's subtrees, in octant order.
            for o in 0..8 {
                let child = c.children as usize + o;
                if !cells[child].is_leaf() {
                    self.entries[at + o] = self.entry_of(cells, child);
                }
            }
            INTERNAL | at as u32
        }
    }

    /// The leaf containing `q` in grid cell `k` (whose world minimum is `min` and size
    /// `size`; `q` inside it): the same leaf, box and corners as the tree's descent; with
    /// `skip_positive`, a leaf whose corners are all > 0 as [`BlockLeaf::Positive`].
    #[inline]
    pub(crate) fn leaf(&self, k: usize, q: DVec3, mut min: DVec3, mut size: f64, skip_positive: bool) -> BlockLeaf {
        let mut e = self.root[k];
        if e == NONE {
            return BlockLeaf::Tree;
        }
        while e & INTERNAL != 0 {
            size *= 0.5;
            let o = child_octant(q, &mut min, size);
            e = self.entries[(e & !INTERNAL) as usize + o];
        }
        if e == JUMP {
            return BlockLeaf::Tree;
        }
        if e & POSITIVE != 0 && skip_positive {
            return BlockLeaf::Positive(min, size);
        }
        BlockLeaf::Plain(self.corners[(e & !POSITIVE) as usize], min, size)
    }

    /// Grid cells with a block.
    pub(crate) fn block_count(&self) -> usize {
        self.root.iter().filter(|&&e| e != NONE).count()
    }

    /// Leaves copied (plain leaves with their corners).
    pub(crate) fn leaf_count(&self) -> usize {
        self.corners.len()
    }

    pub(crate) fn bytes(&self) -> usize {
        self.root.len() * 4 + self.entries.len() * 4 + self.corners.len() * std::mem::size_of::<Corners>()
    }
}

impl Adf {
    /// The part of [`Adf::walk_index_bytes`] that the ray-coherent copy of the surface
    /// leaves takes (module `leaf_blocks`); builds the index if needed.
    pub fn walk_leaf_blocks_bytes(&self) -> usize {
        self.walk_index().blocks.bytes()
    }

    /// Leaves in the ray-coherent copy (module `leaf_blocks`); builds the index if needed.
    pub fn walk_leaf_blocks_leaves(&self) -> usize {
        self.walk_index().blocks.leaf_count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Rng;
    use crate::{AdfOptions, ShapeSource};
    use volga_shapes::Torus;

    /// The tree node at `depth` containing `q` (descending from the root).
    fn node_at_depth(adf: &Adf, q: DVec3, depth: u8) -> usize {
        let (mut index, mut min, mut size) = (0usize, adf.root_min, adf.root_size);
        for _ in 0..depth {
            let c = &adf.cells[index];
            assert!(!c.is_leaf(), "a block's grid cell is covered by a node at the grid depth");
            size *= 0.5;
            index = c.children as usize + child_octant(q, &mut min, size);
        }
        index
    }

    #[test]
    fn morton_interleaves_the_bits() {
        assert_eq!(morton(1, 0, 0), 1);
        assert_eq!(morton(0, 1, 0), 2);
        assert_eq!(morton(0, 0, 1), 4);
        assert_eq!(morton(3, 0, 0), 9);
        assert_eq!(morton(1023, 1023, 1023), (1 << 30) - 1);
    }

    /// Every point of every block's grid cell finds the tree's own leaf: the same box
    /// (bit for bit) and the same corners, and every copied leaf is reached.
    #[test]
    fn the_blocks_hold_the_tree_leaves() {
        for centre in [DVec3::new(0.05, -0.1, 0.02), DVec3::new(1e6, -1e6, 1e6)] {
            let torus = Torus::new(centre, DVec3::new(0.3, 1.0, 0.2).normalize(), 0.55, 0.18).unwrap();
            let options = AdfOptions {
                tolerance: 3e-4,
                max_depth: 10,
                ..AdfOptions::default()
            };
            let adf = Adf::build(&ShapeSource(torus), options).unwrap();
            let ix = adf.walk_index();
            let blocks = &ix.blocks;
            assert!(blocks.block_count() > 1000, "{}", blocks.block_count());
            let n = ix.n;
            let g = adf.cell_size(ix.depth);
            let mut rng = Rng(5);
            let mut seen = vec![false; blocks.corners.len()];
            let (mut plain, mut points) = (0usize, 0usize);
            for k in 0..n * n * n {
                if blocks.root[k] == NONE {
                    continue;
                }
                let min = adf.root_min + DVec3::new((k % n) as f64, ((k / n) % n) as f64, (k / (n * n)) as f64) * g;
                // Random points, and the cell's corner (a leaf's minimum).
                for j in 0..24 {
                    let u = if j == 0 { DVec3::ZERO } else { rng.point() };
                    let q = min + u * g;
                    if !(q.cmpge(min).all() && q.cmplt(min + DVec3::splat(g)).all()) {
                        continue;
                    }
                    points += 1;
                    let (i, tmin, tsize, _) = adf.locate(q);
                    if let BlockLeaf::Positive(bmin, bsize) = blocks.leaf(k, q, min, g, true) {
                        assert!(adf.cells[i].corners.iter().all(|&v| v > 0.0));
                        assert_eq!((bmin, bsize), (tmin, tsize));
                    }
                    match blocks.leaf(k, q, min, g, false) {
                        BlockLeaf::Plain(c, bmin, bsize) => {
                            plain += 1;
                            assert_eq!(c.0, adf.cells[i].corners);
                            assert_eq!((bmin, bsize), (tmin, tsize));
                            assert!(adf.cells[i].children == crate::tree::LEAF);
                        }
                        BlockLeaf::Tree => assert!(adf.cells[i].jump().is_some(), "a plain leaf not copied"),
                        BlockLeaf::Positive(..) => panic!("asked for the corners"),
                    }
                }
            }
            assert!(plain > 10_000 && points > 10_000, "{plain} {points}");
            // Every copied leaf, reached from the grid through its entries, is a tree leaf
            // whose corners it holds (walking both structures together).
            let mut stack: Vec<(u32, usize)> = Vec::new();
            for k in 0..n * n * n {
                let e = blocks.root[k];
                if e != NONE {
                    let (x, y, z) = (k % n, (k / n) % n, k / (n * n));
                    let q = adf.root_min + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * g;
                    stack.push((e, node_at_depth(&adf, q, ix.depth)));
                }
            }
            while let Some((e, i)) = stack.pop() {
                let c = &adf.cells[i];
                if e & INTERNAL != 0 && e != NONE {
                    assert!(!c.is_leaf());
                    for o in 0..8 {
                        stack.push((blocks.entries[(e & !INTERNAL) as usize + o], c.children as usize + o));
                    }
                } else if e == JUMP {
                    assert!(c.jump().is_some());
                } else {
                    assert_eq!(c.children, crate::tree::LEAF);
                    assert_eq!(e & POSITIVE != 0, c.corners.iter().all(|&v| v > 0.0));
                    let slot = (e & !POSITIVE) as usize;
                    assert_eq!(blocks.corners[slot].0, c.corners);
                    assert!(!seen[slot], "slot {slot} reached twice");
                    seen[slot] = true;
                }
            }
            assert!(seen.iter().all(|&s| s), "every copied leaf is reached");
        }
    }
}
