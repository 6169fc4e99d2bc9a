//! CSG of ADFs and sculpting edits that regenerate only the cells they can change.
//!
//! The result of `op(A, B)` (A this ADF's reconstruction, B another ADF or any source) is
//! computed over A's tree. For each cell, conservative ranges of A (its leaves' corners)
//! and of B (B's own ranges, or the 1-Lipschitz ball around the cell centre for an exact
//! source) decide:
//! * the result provably equals A throughout the cell (a union where `A ≤ B`, an
//!   intersection where `A ≥ B`, a difference where `A ≥ −B`): A's subtree is **kept**,
//!   copied as it is;
//! * otherwise an internal cell gets its corners recomputed and its children visited,
//!   and a leaf is **regenerated**: rebuilt top-down from the combined distance with the
//!   usual tolerance test (Perry & Frisken's Kizamu rebuilds only the cells an edit
//!   touches in the same way).
//!
//! Cells far from both surfaces whose distance changes (the new object is nearer) are
//! regenerated too, so the result stays a distance field everywhere, not only near the
//! edit; they are few and coarse. Regenerated cells lose a jump leaf's sign field (the
//! combined distance has none).

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use glam::DVec3;
use volga_core::Aabb;

use crate::source::{AdfSource, CsgOp, Sample};
use crate::tree::build::{join, Builder, LocalStats, Subtree};
use crate::tree::{corner_position, octant, Cell, JUMP_FLAG, LEAF};
use crate::DistanceSource;
use crate::{Adf, AdfError};

/// What a CSG operation or an edit did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EditStats {
    /// Cells built from the combined distance (regenerated subtrees and internal cells
    /// whose corners were recomputed).
    pub cells_regenerated: usize,
    /// Cells copied unchanged from this ADF.
    pub cells_kept: usize,
    /// Distance evaluations of the combined field.
    pub evaluations: u64,
}

/// `op(A, B)` as a distance source, A an ADF.
struct Combined<'a, B: ?Sized> {
    a: &'a Adf,
    b: &'a B,
    op: CsgOp,
}

impl<B: DistanceSource + ?Sized> DistanceSource for Combined<'_, B> {
    fn distance(&self, p: DVec3) -> f64 {
        self.op.apply(self.a.distance(p), self.b.distance(p))
    }
    fn bounds(&self) -> Aabb {
        self.a.root_box()
    }
    fn is_exact(&self) -> bool {
        false
    }
}

impl<B: DistanceSource + ?Sized> AdfSource for Combined<'_, B> {}

/// Conservative ranges of an operand over a box.
trait Ranged {
    fn range_over(&self, cell: &Aabb) -> (f64, f64);
}

/// Any source: exact ones by the 1-Lipschitz ball around the box centre; others have no
/// bound (so every cell they reach is regenerated).
struct SourceRange<'a, S: ?Sized>(&'a S);

impl<S: DistanceSource + ?Sized> Ranged for SourceRange<'_, S> {
    fn range_over(&self, cell: &Aabb) -> (f64, f64) {
        if !self.0.is_exact() {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let centre = cell.center();
        let radius = cell.size().length() * 0.5 * (1.0 + 1e-12);
        let d = self.0.distance(centre);
        (d - radius, d + radius)
    }
}

impl<T: Ranged + ?Sized> Ranged for &T {
    fn range_over(&self, cell: &Aabb) -> (f64, f64) {
        (**self).range_over(cell)
    }
}

impl Ranged for Adf {
    fn range_over(&self, cell: &Aabb) -> (f64, f64) {
        self.range(cell)
    }
}

/// Whether `op(a, b) = a` for every `a ∈ ra`, `b ∈ rb`.
fn keeps_a(op: CsgOp, (a0, a1): (f64, f64), (b0, b1): (f64, f64)) -> bool {
    match op {
        CsgOp::Union => a1 <= b0,
        CsgOp::Intersection => a0 >= b1,
        CsgOp::Difference => a0 >= -b0,
    }
}

struct Editor<'a, B: ?Sized, R> {
    builder: Builder<'a, Combined<'a, B>>,
    ranges: R,
    kept: AtomicUsize,
    regenerated: AtomicUsize,
}

impl Adf {
    /// The ADF of `op(self, other)` (union `min`, intersection `max`, difference
    /// `max(a, −b)`), built over this ADF's cells with its options, regenerating only the
    /// cells the operation can change (see the module doc). `other` must share the root
    /// cube (build it with [`Adf::build_like`]).
    pub fn combine(&self, other: &Adf, op: CsgOp) -> Result<(Adf, EditStats), AdfError> {
        if other.root_min != self.root_min || other.root_size != self.root_size {
            return Err(AdfError::Mismatched);
        }
        self.apply(other, other, op)
    }

    /// Applies a tool (any source: a shape, a mesh, a CSG tree) with `op` in place: carve
    /// with [`CsgOp::Difference`], add with [`CsgOp::Union`]. Only cells the tool can
    /// change are regenerated ([`EditStats`]); the rest are kept bit for bit.
    pub fn edit<S: AdfSource + ?Sized>(&mut self, tool: &S, op: CsgOp) -> Result<EditStats, AdfError> {
        let (result, stats) = self.apply(tool, SourceRange(tool), op)?;
        *self = result;
        Ok(stats)
    }

    /// An ADF of `source` on this ADF's root cube and options (so the two can be combined).
    pub fn build_like<S: AdfSource + ?Sized>(&self, source: &S) -> Result<Adf, AdfError> {
        Adf::build_in(
            source,
            self.options,
            self.root_min,
            self.root_size,
            &volga_core::NoProgress,
        )
    }

    fn apply<B: AdfSource + ?Sized, R: Ranged + Sync>(
        &self,
        b: &B,
        ranges: R,
        op: CsgOp,
    ) -> Result<(Adf, EditStats), AdfError> {
        let editor = Editor {
            builder: Builder {
                source: &Combined { a: self, b, op },
                tolerance: self.options.tolerance,
                max_depth: self.options.max_depth,
                max_cells: self.options.max_cells,
                band: self.options.band,
                may_jump: false,
                cells: AtomicUsize::new(0),
                evaluations: AtomicU64::new(0),
                progress: &volga_core::NoProgress,
                lattice_origin: self.root_min,
                lattice_unit: self.root_size / (1u64 << (self.options.max_depth + 1)) as f64,
            },
            ranges,
            kept: AtomicUsize::new(0),
            regenerated: AtomicUsize::new(0),
        };
        let mut local = LocalStats::default();
        let tree = self.edit_cell(&editor, 0, self.root_min, self.root_size, 0, &mut local)?;
        let stats = EditStats {
            cells_regenerated: editor.regenerated.load(Ordering::Relaxed),
            cells_kept: editor.kept.load(Ordering::Relaxed),
            evaluations: editor.builder.evaluations.load(Ordering::Relaxed),
        };
        let mut adf = Adf {
            root_min: self.root_min,
            root_size: self.root_size,
            cells: tree.cells,
            jumps: tree.jumps,
            options: self.options,
            stats: self.stats,
            walk: Default::default(),
        };
        adf.recount();
        Ok((adf, stats))
    }

    #[allow(clippy::only_used_in_recursion)]
    fn edit_cell<B: AdfSource + ?Sized, R: Ranged + Sync>(
        &self,
        editor: &Editor<'_, B, R>,
        index: usize,
        min: DVec3,
        size: f64,
        depth: u8,
        local: &mut LocalStats,
    ) -> Result<Subtree, AdfError> {
        let cell_box = Aabb::new(min, min + DVec3::splat(size));
        let range_a = self.range(&cell_box);
        let range_b = editor.ranges.range_over(&cell_box);
        if keeps_a(editor.builder.source.op, range_a, range_b) {
            let copy = self.copy_subtree(index);
            editor.kept.fetch_add(copy.cells.len(), Ordering::Relaxed);
            return Ok(copy);
        }
        let cell = self.cells[index];
        let samples: [Sample; 8] = {
            let mut s = [Sample {
                value: 0.0,
                region: None,
            }; 8];
            for (b, s) in s.iter_mut().enumerate() {
                *s = editor.builder.eval(corner_position(min, size, b), None)?;
            }
            s
        };
        if cell.is_leaf() {
            let (tree, stats) = editor.builder.build(min, size, depth, samples, None)?;
            local.merge(&stats);
            editor.regenerated.fetch_add(tree.cells.len(), Ordering::Relaxed);
            return Ok(tree);
        }
        editor.regenerated.fetch_add(1, Ordering::Relaxed);
        let half = size * 0.5;
        let mut children = Vec::with_capacity(8);
        for o in 0..8 {
            children.push(self.edit_cell(
                editor,
                cell.children as usize + o,
                min + octant(o) * half,
                half,
                depth + 1,
                local,
            )?);
        }
        let parent = Cell {
            corners: samples.map(|s| s.value as f32),
            children: LEAF,
        };
        Ok(join(parent, children))
    }

    /// A copy of the subtree at `index` as a standalone [`Subtree`].
    fn copy_subtree(&self, index: usize) -> Subtree {
        let c = self.cells[index];
        if c.is_leaf() {
            return match c.jump() {
                None => Subtree {
                    cells: vec![c],
                    jumps: Vec::new(),
                },
                Some(k) => Subtree {
                    cells: vec![Cell {
                        corners: c.corners,
                        children: JUMP_FLAG,
                    }],
                    jumps: vec![self.jumps[k]],
                },
            };
        }
        let children = (0..8).map(|o| self.copy_subtree(c.children as usize + o)).collect();
        join(c, children)
    }

    /// Recomputes [`crate::BuildStats`]' cell counts from the tree (after an edit).
    fn recount(&mut self) {
        let mut leaves = 0;
        let mut jumps = 0;
        let mut deepest = 0u8;
        let mut at_max = 0;
        let mut stack = vec![(0usize, 0u8)];
        while let Some((i, d)) = stack.pop() {
            let c = &self.cells[i];
            deepest = deepest.max(d);
            if c.is_leaf() {
                leaves += 1;
                jumps += c.jump().is_some() as usize;
                at_max += (d >= self.options.max_depth) as usize;
            } else {
                for o in 0..8 {
                    stack.push((c.children as usize + o, d + 1));
                }
            }
        }
        self.stats.cells = self.cells.len();
        self.stats.leaves = leaves;
        self.stats.jump_leaves = jumps;
        self.stats.max_depth_leaves = at_max;
        self.stats.depth_reached = deepest;
    }
}
