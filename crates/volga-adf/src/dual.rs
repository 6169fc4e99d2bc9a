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
        let (found, finest_depth) = self.leaves_in_order();
        let finest = self.cell_size(finest_depth);
        let mut leaf_of_cell = vec![u32::MAX; self.cells.len()];
        let leaves: Vec<TreeLeaf> = found
            .iter()
            .enumerate()
            .map(|(k, l)| {
                leaf_of_cell[l.cell] = k as u32;
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
        // The leaves' corners strictly inside the root, once each (packed x | y | z in
        // 32-bit fields: coordinates are at most 2^24).
        let side = 1u64 << finest_depth;
        let mut corners: Vec<u128> = Vec::with_capacity(found.len() * 8);
        for l in &found {
            let units = 1u64 << (finest_depth - l.depth);
            for b in 0..8 {
                let v: [u64; 3] = std::array::from_fn(|a| l.index_min[a] + ((b >> a) & 1) as u64 * units);
                if v.iter().all(|&c| c > 0 && c < side) {
                    corners.push(v[0] as u128 | (v[1] as u128) << 32 | (v[2] as u128) << 64);
                }
            }
        }
        drop(found);
        corners.par_sort_unstable_by_key(|&c| (c >> 64, (c >> 32) as u32, c as u32));
        corners.dedup();
        let cells: Vec<[u32; 8]> = corners
            .par_iter()
            .map(|&c| {
                let v = [c as u32 as u64, (c >> 32) as u32 as u64, (c >> 64) as u32 as u64];
                std::array::from_fn(|b| {
                    // The octant's point half a finest leaf from the corner, in half units.
                    let half: [u64; 3] = std::array::from_fn(|a| 2 * v[a] + 2 * ((b >> a) & 1) as u64 - 1);
                    leaf_of_cell[self.cell_containing(half, finest_depth)]
                })
            })
            .collect();
        (leaves, cells)
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
        let (leaves, cells) = self.dual_grid();
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

    /// The cell of the leaf holding the point at `half` (units of half a leaf at
    /// `finest_depth`; odd coordinates, so never on a cell face).
    fn cell_containing(&self, half: [u64; 3], finest_depth: u8) -> usize {
        let mut i = 0usize;
        let mut depth = 0u8;
        loop {
            let c = &self.cells[i];
            if c.is_leaf() {
                return i;
            }
            let shift = finest_depth - depth;
            let o = ((half[0] >> shift) & 1) | ((half[1] >> shift) & 1) << 1 | ((half[2] >> shift) & 1) << 2;
            i = c.children as usize + o as usize;
            depth += 1;
        }
    }
}
