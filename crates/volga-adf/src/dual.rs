//! An ADF meshed on its own leaves: the tree's dual grid for
//! [`volga_mesh::extract_tree_cells`] (Schaefer & Warren 2004). A flat stretch of surface
//! in large leaves comes out as large triangles, with no lattice at the finest level.

use glam::DVec3;
use rayon::prelude::*;
use volga_mesh::{CellExtraction, ExtractError, ExtractMethod, Surface, TreeLeaf};

use crate::Adf;

/// A leaf met by the traversal: its cell, minimum corner in units of the finest leaf, and
/// depth.
struct LeafAt {
    cell: usize,
    index_min: [u64; 3],
    depth: u8,
}

impl Adf {
    /// The tree's leaves (centre and reconstruction there) and its dual cells: for every
    /// leaf corner strictly inside the root cube, the eight leaves around it, leaf `b` on
    /// the `+` side of axis `a` when bit `a` of `b` is set (indices into the leaves).
    /// Both are in a fixed order (depth-first over octants; corners sorted by z, y, x), so
    /// identical for any thread count.
    pub fn dual_grid(&self) -> (Vec<TreeLeaf>, Vec<[u32; 8]>) {
        self.dual_grid_crossing(None)
    }

    /// [`dual_grid`](Adf::dual_grid), keeping only the dual cells whose leaves' centre
    /// values lie on both sides of `iso` (when given): subtrees whose leaves are all on one
    /// side are not descended.
    pub fn dual_grid_crossing(&self, iso: Option<f64>) -> (Vec<TreeLeaf>, Vec<[u32; 8]>) {
        let (found, finest_depth) = self.leaves_in_order();
        let finest = self.cell_size(finest_depth);
        let mut leaf_of_cell = vec![u32::MAX; self.cells.len()];
        for (k, l) in found.iter().enumerate() {
            leaf_of_cell[l.cell] = k as u32;
        }
        let leaves: Vec<TreeLeaf> = found
            .par_iter()
            .map(|l| {
                let units = (1u64 << (finest_depth - l.depth)) as f64;
                let index_centre = DVec3::new(
                    l.index_min[0] as f64 + 0.5 * units,
                    l.index_min[1] as f64 + 0.5 * units,
                    l.index_min[2] as f64 + 0.5 * units,
                );
                TreeLeaf {
                    world_centre: self.root_min + index_centre * finest,
                    value: self.leaf_value(l.cell, DVec3::splat(0.5)),
                }
            })
            .collect();
        drop(found);
        // Per cell, the range of its leaves' centre values (for pruning).
        let mut range = vec![(f64::INFINITY, f64::NEG_INFINITY); self.cells.len()];
        if iso.is_some() {
            self.fill_ranges(0, &leaf_of_cell, &leaves, &mut range);
        }
        let mut walk = DualWalk {
            adf: self,
            leaf_of_cell: &leaf_of_cell,
            range: &range,
            iso,
            cells: Vec::new(),
        };
        walk.cell(0);
        let cells = walk.cells;
        (leaves, cells)
    }

    /// Post-order: `range[i]` = (min, max) of the centre values of cell `i`'s leaves.
    fn fill_ranges(&self, i: usize, leaf_of_cell: &[u32], leaves: &[TreeLeaf], range: &mut [(f64, f64)]) -> (f64, f64) {
        let c = &self.cells[i];
        let r = if c.is_leaf() {
            let v = leaves[leaf_of_cell[i] as usize].value;
            (v, v)
        } else {
            (0..8).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), o| {
                let (a, b) = self.fill_ranges(c.children as usize + o, leaf_of_cell, leaves, range);
                (lo.min(a), hi.max(b))
            })
        };
        range[i] = r;
        r
    }

    /// The zero iso-surface on the ADF's own leaves ([`dual_grid`](Adf::dual_grid) through
    /// `volga_mesh::extract_tree_cells`, by marching cubes or tetrahedra): no lattice, so a
    /// leaf of any size is meshed at its own size. Vertices are refined onto the reconstruction (tolerance `1e-9`), normals
    /// are its gradient. `adaptivity` (world units) then merges vertices within that
    /// distance of the planes of the triangles they replace (0 keeps every triangle);
    /// [`ExtractError::TooManyTriangles`] past `max_triangles`. Closed and manifold
    /// wherever the surface lies farther than half a boundary leaf inside the root cube.
    pub fn to_mesh_on_leaves(
        &self,
        method: ExtractMethod,
        adaptivity: f64,
        max_triangles: u64,
    ) -> Result<Surface, ExtractError> {
        if !(adaptivity.is_finite() && adaptivity >= 0.0) {
            return Err(ExtractError::Adaptivity(adaptivity));
        }
        let (leaves, cells) = self.dual_grid_crossing(Some(0.0));
        let job = CellExtraction {
            adaptivity,
            method,
            ..CellExtraction::new(0.0)
        };
        volga_mesh::extract_tree_cells(self, &leaves, &cells, &job, max_triangles)
    }

    /// Every leaf, depth-first in octant order, and the deepest leaf's depth.
    fn leaves_in_order(&self) -> (Vec<LeafAt>, u8) {
        let mut found = Vec::new();
        let mut stack = vec![(0usize, [0u64; 3], 0u8)];
        let mut finest = 0u8;
        while let Some((i, index_min, depth)) = stack.pop() {
            let c = &self.cells[i];
            if c.is_leaf() {
                finest = finest.max(depth);
                found.push(LeafAt {
                    cell: i,
                    index_min,
                    depth,
                });
                continue;
            }
            // Children pushed in reverse, so octant 0 is met first.
            for o in (0..8).rev() {
                let child_min: [u64; 3] = std::array::from_fn(|a| 2 * index_min[a] + ((o >> a) & 1) as u64);
                stack.push((c.children as usize + o, child_min, depth + 1));
            }
        }
        // Minimum corners were counted in units of each leaf's own level; to the finest.
        for l in &mut found {
            let shift = finest - l.depth;
            l.index_min = l.index_min.map(|m| m << shift);
        }
        (found, finest)
    }
}

/// The other two axes of axis `a`, in order.
const fn others(a: usize) -> (usize, usize) {
    ((a + 1) % 3, (a + 2) % 3)
}

/// The dual cells of a tree by Schaefer & Warren's recursion: a cell's vertices strictly
/// inside it (`cell`), on a face between two cells (`face`), on an edge among four
/// (`edge`), and each vertex once (`vertex`), so no vertex is met twice; a leaf stands in
/// for its own children. With `iso`, a call whose cells' leaves all lie on one side of it
/// returns at once.
struct DualWalk<'a> {
    adf: &'a Adf,
    leaf_of_cell: &'a [u32],
    range: &'a [(f64, f64)],
    iso: Option<f64>,
    cells: Vec<[u32; 8]>,
}

impl DualWalk<'_> {
    /// Child `o` of cell `i`, or the leaf itself.
    #[inline]
    fn child(&self, i: usize, o: usize) -> usize {
        let c = &self.adf.cells[i];
        if c.is_leaf() {
            i
        } else {
            c.children as usize + o
        }
    }

    #[inline]
    fn leaf(&self, i: usize) -> bool {
        self.adf.cells[i].is_leaf()
    }

    /// Whether the leaves under `cells` may lie on both sides of `iso`.
    #[inline]
    fn may_cross(&self, cells: &[usize]) -> bool {
        let Some(iso) = self.iso else {
            return true;
        };
        let (lo, hi) = cells.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &i| {
            (lo.min(self.range[i].0), hi.max(self.range[i].1))
        });
        lo <= iso && hi > iso
    }

    fn cell(&mut self, n: usize) {
        if self.leaf(n) || !self.may_cross(&[n]) {
            return;
        }
        let c: [usize; 8] = std::array::from_fn(|o| self.child(n, o));
        for &k in &c {
            self.cell(k);
        }
        for a in 0..3 {
            for o in (0..8).filter(|o| o >> a & 1 == 0) {
                self.face([c[o], c[o | 1 << a]], a);
            }
            let (p, q) = others(a);
            for h in 0..2 {
                let e: [usize; 4] = std::array::from_fn(|k| c[h << a | (k & 1) << p | (k >> 1) << q]);
                self.edge(e, a);
            }
        }
        self.vertex(c);
    }

    /// The face between `n[0]` (below along `a`) and `n[1]` (above).
    fn face(&mut self, n: [usize; 2], a: usize) {
        if (self.leaf(n[0]) && self.leaf(n[1])) || !self.may_cross(&n) {
            return;
        }
        let bit = 1 << a;
        for o in (0..8).filter(|o| o & bit == 0) {
            self.face([self.child(n[0], o | bit), self.child(n[1], o)], a);
        }
        // The four half-lines from the face's centre, along each in-plane axis `e`.
        for e in (0..3).filter(|&e| e != a) {
            let (p, q) = others(e);
            for h in 0..2 {
                let ring: [usize; 4] = std::array::from_fn(|k| {
                    let side = [k & 1, k >> 1];
                    let (side_a, side_r, r) = if p == a {
                        (side[0], side[1], q)
                    } else {
                        (side[1], side[0], p)
                    };
                    self.child(n[side_a], (1 - side_a) << a | side_r << r | h << e)
                });
                self.edge(ring, e);
            }
        }
        let around: [usize; 8] = std::array::from_fn(|o| self.child(n[o >> a & 1], o ^ bit));
        self.vertex(around);
    }

    /// The edge along `a` among `n[k]`, node `k` on the `+` side of the other axes
    /// `(p, q)` by its bits 0 and 1.
    fn edge(&mut self, n: [usize; 4], a: usize) {
        if n.iter().all(|&i| self.leaf(i)) || !self.may_cross(&n) {
            return;
        }
        let (p, q) = others(a);
        for h in 0..2 {
            let half: [usize; 4] =
                std::array::from_fn(|k| self.child(n[k], (1 - (k & 1)) << p | (1 - (k >> 1)) << q | h << a));
            self.edge(half, a);
        }
        let around: [usize; 8] =
            std::array::from_fn(|o| self.child(n[(o >> p & 1) | (o >> q & 1) << 1], o ^ (1 << p | 1 << q)));
        self.vertex(around);
    }

    /// The vertex with `n[o]` in octant `o` around it.
    fn vertex(&mut self, n: [usize; 8]) {
        if !self.may_cross(&n) {
            return;
        }
        if n.iter().all(|&i| self.leaf(i)) {
            self.cells.push(n.map(|i| self.leaf_of_cell[i]));
            return;
        }
        let inner: [usize; 8] = std::array::from_fn(|o| self.child(n[o], 7 - o));
        self.vertex(inner);
    }
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeSet, HashMap};

    use glam::DVec3;
    use volga_shapes::Torus;

    use crate::{Adf, AdfOptions, ShapeSource};

    /// The dual cells by brute force: every leaf corner strictly inside the root, once,
    /// with the leaves holding the points a quarter of the finest leaf away in each octant.
    fn brute_force(adf: &Adf) -> BTreeSet<[u32; 8]> {
        let (leaves, _) = adf.dual_grid();
        let id: HashMap<[u64; 3], u32> = leaves
            .iter()
            .enumerate()
            .map(|(k, l)| (l.world_centre.to_array().map(f64::to_bits), k as u32))
            .collect();
        let finest = adf.cell_size(adf.stats().depth_reached);
        let root = adf.root_box();
        let mut corners = BTreeSet::new();
        for l in &leaves {
            let info = adf.leaf_at(l.world_centre);
            for b in 0..8 {
                let v = info.world_min + crate::tree::octant(b) * info.size;
                if v.cmpgt(root.min).all() && v.cmplt(root.max).all() {
                    corners.insert(v.to_array().map(f64::to_bits));
                }
            }
        }
        corners
            .into_iter()
            .map(|v| {
                let v = DVec3::from_array(v.map(f64::from_bits));
                std::array::from_fn(|b| {
                    let p = v + (crate::tree::octant(b) - 0.5) * 0.5 * finest;
                    let info = adf.leaf_at(p);
                    let centre = info.world_min + DVec3::splat(0.5 * info.size);
                    id[&centre.to_array().map(f64::to_bits)]
                })
            })
            .collect()
    }

    #[test]
    fn the_recursive_walk_finds_every_dual_cell_once_and_prunes_only_one_sided_ones() {
        let torus = Torus::new(DVec3::new(0.1, 0.0, -0.05), DVec3::new(0.0, 0.3, 1.0), 0.7, 0.25).unwrap();
        let options = AdfOptions {
            tolerance: 1e-3,
            max_depth: 7,
            max_cells: 10_000_000,
            margin: None,
            band: 0.0,
        };
        let adf = Adf::build(&ShapeSource(torus), options).unwrap();
        let (leaves, cells) = adf.dual_grid();
        let set: BTreeSet<[u32; 8]> = cells.iter().copied().collect();
        assert_eq!(set.len(), cells.len(), "a dual cell met twice");
        assert_eq!(set, brute_force(&adf));
        let depths: BTreeSet<u8> = leaves.iter().map(|l| adf.leaf_at(l.world_centre).depth).collect();
        assert!(depths.len() >= 3, "leaves of one size only: {depths:?}");
        let crossing = |c: &[u32; 8]| {
            let v = c.map(|i| leaves[i as usize].value);
            v.iter().any(|&x| x <= 0.0) && v.iter().any(|&x| x > 0.0)
        };
        let (_, pruned) = adf.dual_grid_crossing(Some(0.0));
        let expected: Vec<[u32; 8]> = cells.iter().copied().filter(crossing).collect();
        assert!(!expected.is_empty());
        assert_eq!(pruned, expected);
    }
}
