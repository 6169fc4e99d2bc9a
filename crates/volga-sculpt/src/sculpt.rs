//! The editing session: the current tree, undo and redo.

use std::collections::HashSet;

use glam::IVec3;
use rayon::prelude::*;
use volga_core::{Field, FieldKind};
use volga_shapes::OrientedBoxFilter;

use crate::edit::{edit, EditReport, Prepared, Stroke};
use crate::octree::{child_offset, node_size, stats, Brick, Node, NodeStats, SculptGrid, Voxel, BRICK, BRICK_VOXELS};

/// A sculpt: a dynamic-resolution octree of volume-sampled densities and colours on a
/// [`SculptGrid`], with its undo and redo history.
///
/// Undo keeps the previous roots; since an edit shares every unchanged subtree with the
/// tree it came from, each history step costs only the subtrees that edit changed
/// ([`Sculpt::history_bytes`]).
#[derive(Debug, Clone)]
pub struct Sculpt {
    pub(crate) grid: SculptGrid,
    pub(crate) root: Node,
    undo: Vec<Node>,
    redo: Vec<Node>,
}

/// Nodes at or above this level are built in parallel.
const PARALLEL_BUILD_LEVEL: u32 = 3;

impl Sculpt {
    /// Empty space (density 0) everywhere, coloured `colour` (what later material shows
    /// until painted).
    pub fn empty(grid: SculptGrid, colour: [f32; 3]) -> Sculpt {
        Sculpt::from_root(grid, Node::Uniform(Voxel { density: 0.0, colour }))
    }

    pub(crate) fn from_root(grid: SculptGrid, root: Node) -> Sculpt {
        Sculpt {
            grid,
            root,
            undo: Vec::new(),
            redo: Vec::new(),
        }
    }

    /// Samples `field` at every voxel centre: densities are kept (clamped to \[0, 1\]);
    /// a signed distance is turned into a density by the grid's oriented box filter.
    /// Nodes whose voxels the field's `value_range` proves equal are built as one uniform
    /// node without sampling, so building costs the field's surface, not its volume.
    pub fn from_field<F: Field + ?Sized>(grid: SculptGrid, field: &F, colour: [f32; 3]) -> Sculpt {
        let filter = OrientedBoxFilter::for_spacing(glam::DVec3::splat(grid.spacing()));
        let to_density = |v: f64| -> f32 {
            match field.kind() {
                FieldKind::SignedDistance => filter.density(v) as f32,
                FieldKind::Density | FieldKind::Binary => {
                    if v >= 1.0 {
                        1.0
                    } else if v > 0.0 {
                        v as f32
                    } else {
                        0.0
                    }
                }
            }
        };
        let root = build(&grid, field, &to_density, colour, IVec3::ZERO, grid.levels());
        Sculpt::from_root(grid, root)
    }

    /// The grid the voxels live on.
    pub fn grid(&self) -> &SculptGrid {
        &self.grid
    }

    /// The voxel at `ijk` (`None` outside the grid).
    pub fn voxel(&self, ijk: IVec3) -> Option<Voxel> {
        self.grid
            .index_box()
            .contains(ijk)
            .then(|| self.root.voxel(ijk, IVec3::ZERO, self.grid.levels()))
    }

    /// Node counts and memory of the current tree.
    pub fn stats(&self) -> NodeStats {
        stats(&self.root)
    }

    /// Applies a stroke. The edit visits only nodes meeting the tool's box (grown by the
    /// filter's band), subdivides only where the tool's boundary passes, and collapses
    /// nodes that become homogeneous. If anything changed, the previous tree goes on the
    /// undo stack and the redo stack is cleared.
    pub fn apply(&mut self, stroke: &Stroke) -> EditReport {
        let prepared = Prepared::new(stroke, self.grid);
        let (new_root, changed) = edit(&prepared, &self.root, &self.root, IVec3::ZERO, self.grid.levels());
        if let Some(new_root) = new_root {
            let old = std::mem::replace(&mut self.root, new_root);
            self.undo.push(old);
            self.redo.clear();
        }
        EditReport::from_voxels(&self.grid, changed)
    }

    /// Undoes the last edit; false if there is none.
    pub fn undo(&mut self) -> bool {
        match self.undo.pop() {
            Some(prev) => {
                let cur = std::mem::replace(&mut self.root, prev);
                self.redo.push(cur);
                true
            }
            None => false,
        }
    }

    /// Redoes the last undone edit; false if there is none.
    pub fn redo(&mut self) -> bool {
        match self.redo.pop() {
            Some(next) => {
                let cur = std::mem::replace(&mut self.root, next);
                self.undo.push(cur);
                true
            }
            None => false,
        }
    }

    /// Edits [`Sculpt::undo`] can undo.
    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }

    /// Undone edits [`Sculpt::redo`] can redo.
    pub fn redo_len(&self) -> usize {
        self.redo.len()
    }

    /// Forgets the undo and redo history.
    pub fn clear_history(&mut self) {
        self.undo.clear();
        self.redo.clear();
    }

    /// Bytes held by the history beyond the current tree: nodes of undo/redo roots not
    /// shared with the current tree (each shared subtree is counted zero times).
    pub fn history_bytes(&self) -> u64 {
        let mut seen: HashSet<usize> = HashSet::new();
        mark(&self.root, &mut seen);
        let mut bytes = 0;
        for r in self.undo.iter().chain(&self.redo) {
            bytes += unshared_bytes(r, &mut seen);
        }
        bytes
    }

    /// Whether the tree is canonical: no brick whose voxels are all equal, no branch whose
    /// eight children are the same uniform voxel (what collapsing maintains).
    pub fn is_canonical(&self) -> bool {
        let mut ok = true;
        self.root.visit(&mut |n| match n {
            Node::Brick(b) => {
                let v = b.voxels();
                if v.iter().all(|x| *x == v[0]) {
                    ok = false;
                }
            }
            Node::Branch(c) => {
                if let Node::Uniform(first) = c[0] {
                    if c.iter().all(|k| matches!(k, Node::Uniform(v) if *v == first)) {
                        ok = false;
                    }
                }
            }
            Node::Uniform(_) => {}
        });
        ok
    }

    /// World box of the voxel centres of every node holding material (density > 0), at
    /// node precision (bricks and uniform nodes, never finer); `None` if the sculpt is empty.
    pub fn content_bounds(&self) -> Option<volga_core::Aabb> {
        fn walk(n: &Node, origin: IVec3, level: u32, out: &mut Option<volga_core::IndexBox>) {
            let mine = volga_core::IndexBox::new(origin, origin + node_size(level));
            let full = match n {
                Node::Uniform(v) => v.density > 0.0,
                Node::Brick(b) => b.max > 0.0,
                Node::Branch(children) => {
                    for (k, c) in children.iter().enumerate() {
                        walk(c, origin + child_offset(k, level), level - 1, out);
                    }
                    false
                }
            };
            if full {
                *out = crate::edit::union(*out, Some(mine));
            }
        }
        let mut b = None;
        walk(&self.root, IVec3::ZERO, self.grid.levels(), &mut b);
        b.map(|b| self.grid.centres_box(&b))
    }

    /// Whether two sculpts hold the same grid and the same voxels in the same tree
    /// structure (bitwise).
    pub fn same_tree(&self, other: &Sculpt) -> bool {
        self.grid == other.grid && self.root == other.root
    }
}

fn node_ptr(n: &Node) -> Option<usize> {
    match n {
        Node::Uniform(_) => None,
        Node::Brick(b) => Some(std::sync::Arc::as_ptr(b) as *const u8 as usize),
        Node::Branch(c) => Some(std::sync::Arc::as_ptr(c) as *const u8 as usize),
    }
}

fn mark(n: &Node, seen: &mut HashSet<usize>) {
    if let Some(p) = node_ptr(n) {
        if !seen.insert(p) {
            return;
        }
    }
    if let Node::Branch(c) = n {
        for k in c.iter() {
            mark(k, seen);
        }
    }
}

fn unshared_bytes(n: &Node, seen: &mut HashSet<usize>) -> u64 {
    let Some(p) = node_ptr(n) else { return 0 };
    if !seen.insert(p) {
        return 0;
    }
    match n {
        Node::Brick(_) => stats(n).bytes - std::mem::size_of::<Node>() as u64,
        Node::Branch(c) => {
            let own = std::mem::size_of::<[Node; 8]>() as u64 + 2 * std::mem::size_of::<usize>() as u64;
            own + c.iter().map(|k| unshared_bytes(k, seen)).sum::<u64>()
        }
        Node::Uniform(_) => 0,
    }
}

fn build<F: Field + ?Sized>(
    grid: &SculptGrid,
    field: &F,
    to_density: &(impl Fn(f64) -> f32 + Sync),
    colour: [f32; 3],
    origin: IVec3,
    level: u32,
) -> Node {
    let size = node_size(level);
    let centres = grid.centres_box(&volga_core::IndexBox::new(origin, origin + size));
    let (lo, hi) = field.value_range(&centres);
    let (dlo, dhi) = (to_density(lo), to_density(hi));
    // The conversions are monotone (decreasing for distances), so equal ends mean every
    // voxel rounds to the same density.
    if dlo.to_bits() == dhi.to_bits() && lo.is_finite() && hi.is_finite() {
        return Node::Uniform(Voxel { density: dlo, colour });
    }
    if level == 0 {
        let voxels: [Voxel; BRICK_VOXELS] = std::array::from_fn(|k| {
            let k = k as i32;
            let local = IVec3::new(k % BRICK, (k / BRICK) % BRICK, k / (BRICK * BRICK));
            Voxel {
                density: to_density(field.value(grid.voxel_center(origin + local))),
                colour,
            }
        });
        debug_assert_eq!(Brick::offset(IVec3::new(1, 2, 3)), 1 + 8 * 2 + 64 * 3);
        return Brick::from_voxels(&voxels);
    }
    let child = |k: usize| {
        build(
            grid,
            field,
            to_density,
            colour,
            origin + child_offset(k, level),
            level - 1,
        )
    };
    let children: Vec<Node> = if level >= PARALLEL_BUILD_LEVEL {
        (0..8).into_par_iter().map(child).collect()
    } else {
        (0..8).map(child).collect()
    };
    let children: [Node; 8] = children.try_into().expect("eight children");
    Node::branch(children)
}
