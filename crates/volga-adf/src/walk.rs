//! The ray walk's index: what makes an ADF render at interactive rates.
//!
//! The reference walk ([`Adf::first_crossing_by_descent`]) reads 36-byte cells on every
//! descent and visits every leaf the ray crosses, however far from the surface. The
//! indexed walk ([`Adf::first_crossing_between`]) adds, built once on the first ray
//! ([`WalkIndex`]):
//!
//! * a **uniform grid** over the root cube at depth `G = min(7, depth reached)` (128³
//!   cells at most) holding, per grid cell, the index and depth of the tree node that
//!   covers it (the node at depth `G`, or the shallower leaf that contains it), so a
//!   leaf is found by descending at most `depth − G` levels instead of from the root;
//! * per grid cell a **conservative minimum** of the reconstruction (the smallest corner
//!   value of every leaf that meets it; `−max |c|` for a jump leaf): a ray crosses a grid
//!   cell whose minimum is above the iso value in one step, without locating its leaves;
//! * per grid cell its **reach** (module `reach`): the chessboard distance in grid cells
//!   to the nearest cell whose minimum is ≤ 0, so for an iso value ≤ 0 a ray crosses the
//!   whole cube of `(2r − 1)³` empty cells around its cell in one step (sphere tracing on
//!   the grid, with a bound that is exact for the grid's classification); iso values
//!   above 0 use 4³ blocks of cells instead;
//! * a **compact copy of the child links** (4 bytes per cell; the 8 siblings' links in one
//!   32-byte run), so the descent touches a cache line per level instead of a 36-byte
//!   cell, and the leaf's corners are read once.
//!
//! In a leaf with a corner at or below the iso value the trilinear restriction to the
//! ray is a cubic; its coefficients come from the leaf's corners (module `cubic`), a
//! segment with positive Bernstein coefficients is rejected at once, and otherwise the
//! first downward root is refined on the polynomial by safeguarded Newton steps. (Jump
//! leaves fit the cubic through 4 samples of their sign field, as the reference walk.)
//!
//! The index is a function of the tree alone (deterministic, the same for any thread
//! count); it is not part of the ADF's value (`PartialEq` ignores it, a clone rebuilds it
//! when needed) and its size is [`Adf::walk_index_bytes`].

use std::sync::OnceLock;

use glam::DVec3;

use crate::reach::chessboard_reach;
use crate::tree::Cell;
use crate::Adf;

mod rays;

pub use rays::WALK_WINDOW;

/// Deepest level of the walk grid: 128³ cells, 10 bytes each (20 MB) beside the links.
/// Against 64³ (2.5 MB) it cut the bunny's walk at 1e-4 by about 8 % (one thread, all
/// pixel-centre rays of `volga bench adf`; `examples/walk_profile.rs`).
const GRID_DEPTH: u8 = 7;

/// The walk index of an ADF, built lazily (see the module doc).
#[derive(Default)]
pub(crate) struct WalkCache(pub(crate) OnceLock<WalkIndex>);

impl Clone for WalkCache {
    /// A clone starts without an index (built again on its first ray).
    fn clone(&self) -> Self {
        WalkCache::default()
    }
}

impl PartialEq for WalkCache {
    /// Derived data: never part of an ADF's value.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for WalkCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "WalkCache(built: {})", self.0.get().is_some())
    }
}

/// The grid and compact links of the indexed walk.
pub(crate) struct WalkIndex {
    /// `cells[i].children` for every cell.
    links: Vec<u32>,
    /// Grid depth `G`; the grid has `n = 2^G` cells per axis, index `x + n(y + n z)`.
    depth: u8,
    n: usize,
    /// The node covering each grid cell and its depth (≤ `G`).
    node: Vec<u32>,
    level: Vec<u8>,
    /// Conservative minimum of the reconstruction over each grid cell.
    lo: Vec<f32>,
    /// The world box of the grid cells whose minimum is ≤ 0 (padded by 1e-6 of the root),
    /// `None` if there are none: for an iso value ≤ 0 the reconstruction is above it
    /// everywhere else, so a ray's interval is clipped to this box first.
    active: Option<(DVec3, DVec3)>,
    /// A coarser grid of `(n / 4)³` blocks of 4³ grid cells (when `G ≥ 2`): the minimum
    /// of their minima, so a ray crosses an empty block in one step (iso values > 0).
    block_lo: Vec<f32>,
    /// Per grid cell, the chessboard distance in grid cells to the nearest cell whose
    /// minimum is ≤ 0 (module `reach`): for an iso value ≤ 0 a ray crosses the
    /// `(2k − 1)³` cube of empty cells around its cell in one step.
    reach: Vec<u8>,
}

impl WalkIndex {
    fn build(adf: &Adf) -> WalkIndex {
        let depth = adf.stats.depth_reached.min(GRID_DEPTH);
        let n = 1usize << depth;
        let mut index = WalkIndex {
            links: adf.cells.iter().map(|c| c.children).collect(),
            depth,
            n,
            node: vec![0; n * n * n],
            level: vec![0; n * n * n],
            lo: vec![0.0; n * n * n],
            active: None,
            block_lo: Vec::new(),
            reach: Vec::new(),
        };
        index.fill(adf, 0, 0, [0; 3]);
        index.reach = chessboard_reach(n, |k| index.lo[k] <= 0.0);
        if depth >= 2 {
            let m = n / 4;
            index.block_lo = vec![f32::INFINITY; m * m * m];
            for z in 0..n {
                for y in 0..n {
                    for x in 0..n {
                        let b = &mut index.block_lo[x / 4 + m * (y / 4 + m * (z / 4))];
                        *b = b.min(index.lo[x + n * (y + n * z)]);
                    }
                }
            }
        }
        let mut box_lo = [usize::MAX; 3];
        let mut box_hi = [0usize; 3];
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    if index.lo[x + n * (y + n * z)] <= 0.0 {
                        for (a, v) in [x, y, z].into_iter().enumerate() {
                            box_lo[a] = box_lo[a].min(v);
                            box_hi[a] = box_hi[a].max(v + 1);
                        }
                    }
                }
            }
        }
        if box_lo[0] != usize::MAX {
            let g = adf.cell_size(depth);
            let pad = adf.root_size * 1e-6;
            let corner = |c: [usize; 3]| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * g + adf.root_min;
            index.active = Some((corner(box_lo) - DVec3::splat(pad), corner(box_hi) + DVec3::splat(pad)));
        }
        index
    }

    /// Fills the grid cells under node `i` (depth `d`, integer position `ijk` at its depth).
    fn fill(&mut self, adf: &Adf, i: usize, d: u8, ijk: [usize; 3]) {
        let c = &adf.cells[i];
        if d == self.depth || c.is_leaf() {
            let lo = subtree_lo(&adf.cells, i);
            let span = 1usize << (self.depth - d);
            let n = self.n;
            for z in ijk[2] * span..(ijk[2] + 1) * span {
                for y in ijk[1] * span..(ijk[1] + 1) * span {
                    for x in ijk[0] * span..(ijk[0] + 1) * span {
                        let k = x + n * (y + n * z);
                        self.node[k] = i as u32;
                        self.level[k] = d;
                        self.lo[k] = lo;
                    }
                }
            }
            return;
        }
        for o in 0..8 {
            let child = [
                ijk[0] * 2 + (o & 1),
                ijk[1] * 2 + ((o >> 1) & 1),
                ijk[2] * 2 + ((o >> 2) & 1),
            ];
            self.fill(adf, c.children as usize + o, d + 1, child);
        }
    }

    fn bytes(&self) -> usize {
        self.links.len() * 4
            + self.node.len() * 4
            + self.level.len()
            + self.lo.len() * 4
            + self.block_lo.len() * 4
            + self.reach.len()
    }
}

/// The smallest value the reconstruction takes in the subtree of cell `i` (a lower bound:
/// each leaf's value is a convex combination of its corners, or of their magnitudes with
/// a sign).
fn subtree_lo(cells: &[Cell], i: usize) -> f32 {
    let c = &cells[i];
    if c.is_leaf() {
        if c.jump().is_some() {
            -c.corners.iter().fold(0.0f32, |a, &v| a.max(v.abs()))
        } else {
            c.corners.iter().fold(f32::INFINITY, |a, &v| a.min(v))
        }
    } else {
        (0..8).fold(f32::INFINITY, |a, o| a.min(subtree_lo(cells, c.children as usize + o)))
    }
}

impl Adf {
    /// The walk index, built on first use.
    pub(crate) fn walk_index(&self) -> &WalkIndex {
        self.walk.0.get_or_init(|| WalkIndex::build(self))
    }

    /// Builds the ray walk's index now (otherwise the first ray does) and returns its
    /// size in bytes: the render layout's memory on top of [`Adf::memory_bytes`].
    pub fn walk_index_bytes(&self) -> usize {
        self.walk_index().bytes()
    }

    /// The part of [`Adf::walk_index_bytes`] that the empty-space reach takes (one byte
    /// per walk grid cell, module `reach`); builds the index if needed.
    pub fn walk_reach_bytes(&self) -> usize {
        self.walk_index().reach.len()
    }

    /// The leaf containing `q` (a point of the root cube), found from the walk grid: the
    /// same leaf as [`Adf::locate`].
    #[inline]
    pub(crate) fn locate_indexed(&self, ix: &WalkIndex, q: DVec3) -> (usize, DVec3, f64) {
        let n = ix.n;
        // Truncation is the floor for the non-negative offsets of a point in the root.
        let g = (q - self.root_min) * (n as f64 / self.root_size);
        let cell = |v: f64| (v.max(0.0) as usize).min(n - 1);
        let (gx, gy, gz) = (cell(g.x), cell(g.y), cell(g.z));
        let k = gx + n * (gy + n * gz);
        let level = ix.level[k];
        let shift = ix.depth - level;
        let size = self.cell_size(level);
        let mut min =
            self.root_min + DVec3::new((gx >> shift) as f64, (gy >> shift) as f64, (gz >> shift) as f64) * size;
        let max = min + DVec3::splat(size);
        let root_max = self.root_min + DVec3::splat(self.root_size);
        let contains = q.cmpge(min).all() && (q.cmplt(max) | max.cmpge(root_max)).all();
        if !contains {
            // Rounding put `q` in a neighbouring grid cell: descend from the root.
            let (i, min, size, _) = self.locate(q);
            return (i, min, size);
        }
        let mut index = ix.node[k] as usize;
        let mut size = size;
        loop {
            let link = ix.links[index];
            if link >= crate::tree::JUMP_FLAG {
                return (index, min, size);
            }
            size *= 0.5;
            index = link as usize + crate::tree::child_octant(q, &mut min, size);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Rng;
    use crate::{AdfOptions, ShapeSource};
    use volga_core::Aabb;
    use volga_shapes::Torus;

    fn torus_adf(centre: DVec3, max_depth: u8) -> Adf {
        let torus = Torus::new(centre, DVec3::new(0.3, 1.0, 0.2).normalize(), 0.55, 0.18).unwrap();
        let options = AdfOptions {
            tolerance: 1e-3,
            max_depth,
            ..AdfOptions::default()
        };
        Adf::build(&ShapeSource(torus), options).unwrap()
    }

    /// The grid cell `(x, y, z)`'s world box.
    fn cell_box(adf: &Adf, ix: &WalkIndex, x: isize, y: isize, z: isize) -> Aabb {
        let g = adf.cell_size(ix.depth);
        let min = adf.root_min + DVec3::new(x as f64, y as f64, z as f64) * g;
        Aabb::new(min, min + DVec3::splat(g))
    }

    /// The reach against brute force: each cell's conservative minimum recomputed from the
    /// leaves in its interior (`Adf::range` over the cell shrunk by 1e-9 of it), and the
    /// chessboard distance to the nearest cell whose minimum is ≤ 0 by scanning all cells.
    #[test]
    fn the_reach_is_the_brute_force_distance_to_cells_that_may_hold_the_surface() {
        let adf = torus_adf(DVec3::new(0.05, -0.1, 0.02), 5);
        let ix = adf.walk_index();
        let n = ix.n as isize;
        assert_eq!(ix.n, 32, "grid at the depth reached");
        let mut occupied = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let b = cell_box(&adf, ix, x, y, z);
                    let shrink = DVec3::splat(b.size().x * 1e-9);
                    let (lo, _) = adf.range(&Aabb::new(b.min + shrink, b.max - shrink));
                    if lo <= 0.0 {
                        occupied.push((x, y, z));
                    }
                }
            }
        }
        assert!(occupied.len() > 100, "{}", occupied.len());
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let brute = occupied
                        .iter()
                        .map(|&(a, b, c)| (a - x).abs().max((b - y).abs()).max((c - z).abs()))
                        .min()
                        .unwrap();
                    let k = (x + n * (y + n * z)) as usize;
                    assert_eq!(ix.reach[k] as isize, brute, "cell {x} {y} {z}");
                }
            }
        }
    }

    /// What a step relies on: in the cube of `(2r − 1)³` cells around a cell of reach `r`,
    /// the reconstruction is positive at random points (a bound that claimed more than
    /// the true minimum would let a ray step over the surface). At the 128³ grid of a
    /// deeper tree, near the origin and at 1e6.
    #[test]
    fn the_reconstruction_is_positive_in_every_cube_a_ray_crosses_in_one_step() {
        for centre in [DVec3::new(0.05, -0.1, 0.02), DVec3::new(1e6, -1e6, 1e6)] {
            let adf = torus_adf(centre, 8);
            let ix = adf.walk_index();
            assert_eq!(ix.depth, GRID_DEPTH);
            let n = ix.n;
            let mut rng = Rng(41);
            let mut checked = 0;
            // Every 7th cell (all of them at 128³ would take too long), 3 points each.
            for k in (0..n * n * n).step_by(7) {
                let r = ix.reach[k] as isize;
                if r == 0 {
                    continue;
                }
                let (x, y, z) = ((k % n) as isize, ((k / n) % n) as isize, (k / (n * n)) as isize);
                let lo = cell_box(&adf, ix, x - (r - 1), y - (r - 1), z - (r - 1)).min;
                let size = (2 * r - 1) as f64 * adf.cell_size(ix.depth);
                for _ in 0..3 {
                    let u = DVec3::new(rng.next(), rng.next(), rng.next());
                    let p = lo + u * size;
                    if adf.root_box().contains(p) {
                        let d = adf.distance(p);
                        assert!(d > 0.0, "reach {r} at cell {x} {y} {z}: value {d} at {p:?}");
                        checked += 1;
                    }
                }
            }
            assert!(checked > 100_000, "{checked}");
        }
    }
}
