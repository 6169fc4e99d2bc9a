//! The empty-space skipping grid: macro cells classified from the field's conservative
//! value ranges ([`CellClass`]), each with its Chebyshev reach to the nearest cell that
//! is not empty, and the 3D DDA ([`CellWalk`]) that jumps across empty blocks.

use glam::{DVec3, UVec3};
use rayon::prelude::*;
use volga_core::{Aabb, Field, Shape3};

use crate::Ray;

/// What empty-space skipping may do with a macro cell, decided by the integrator
/// from the field's conservative value range over the cell
/// ([`Integrator::classify_cell`](crate::Integrator::classify_cell)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellClass {
    /// The cell holds samples that matter: march through it.
    Active,
    /// Skip: no sample in the cell contributes (transparent), and for iso-surfaces
    /// every sample is outside.
    Outside,
    /// Skip: every sample in the cell is inside the iso-surface.
    Inside,
}

/// A coarse grid over the field bounds for empty-space skipping. Each cell keeps the
/// field's conservative value range over the cell grown by one sample spacing on
/// every side (so trilinear and gradient stencils of samples inside, and rounding of
/// sample positions, are covered), reduced to a skip class and the range maximum.
#[derive(Debug)]
pub(crate) struct MacroGrid {
    min: DVec3,
    max: DVec3,
    cell: DVec3,
    dims: [usize; 3],
    class: Vec<CellClass>,
    hi: Vec<f64>,
    /// Per cell, the largest `r ≤ MAX_REACH` such that every cell within Chebyshev
    /// distance `r` (the `(2r + 1)³` block around it, clipped to the grid) is
    /// [`CellClass::Outside`]: a ray in the cell may jump to the block's exit at once.
    reach: Vec<u8>,
    /// The world box of the cells that are not [`CellClass::Outside`] (a union of
    /// whole cells), `None` if every cell is Outside: rays and their parts outside it
    /// meet Outside cells only.
    non_outside: Option<Aabb>,
}

/// Largest jump of [`MacroGrid::reach`], in cells.
const MAX_REACH: u8 = 8;

/// Target macro cell edge in sample spacings, and the cap per axis (≤ 64³ cells).
const CELL_SPACINGS: f64 = 8.0;
const MAX_CELLS_PER_AXIS: usize = 64;

impl MacroGrid {
    pub(crate) fn build<F: Field + ?Sized>(
        field: &F,
        bounds: Aabb,
        spacing: f64,
        classify: impl Fn(f64, f64) -> CellClass + Sync,
    ) -> MacroGrid {
        let size = bounds.size();
        let dims = [0, 1, 2].map(|a| {
            let n = (size[a] / (CELL_SPACINGS * spacing)).ceil();
            if n.is_nan() || n < 1.0 {
                1
            } else {
                (n.min(MAX_CELLS_PER_AXIS as f64) as usize).max(1)
            }
        });
        let cell = size / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
        let mut grid = MacroGrid {
            min: bounds.min,
            max: bounds.max,
            cell,
            dims,
            class: Vec::new(),
            hi: Vec::new(),
            reach: Vec::new(),
            non_outside: None,
        };
        let margin = DVec3::splat(spacing);
        let cells: Vec<(CellClass, f64)> = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|lin| {
                let (lo, hi) = grid.cell_box(grid.delinearize(lin));
                let (lo, hi) = field.value_range(&Aabb::new(lo, hi).expanded(margin));
                let (lo, hi) = if lo.is_nan() || hi.is_nan() {
                    (f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    (lo, hi)
                };
                (classify(lo, hi), hi)
            })
            .collect();
        grid.class = cells.iter().map(|c| c.0).collect();
        grid.hi = cells.iter().map(|c| c.1).collect();
        grid.reach = grid.outside_reach();
        grid.non_outside = grid.non_outside_cells_box();
        grid
    }

    /// Recomputes the cells whose sampled region meets `changed` (the only place where
    /// `field` differs from the field the grid was built for); the others keep their
    /// conservative ranges, which still hold there. Then the reach is recomputed.
    pub(crate) fn update<F: Field + ?Sized>(
        &mut self,
        field: &F,
        spacing: f64,
        changed: &Aabb,
        classify: impl Fn(f64, f64) -> CellClass + Sync,
    ) {
        let margin = DVec3::splat(spacing);
        let touched = changed.expanded(margin);
        let lins: Vec<usize> = (0..self.len())
            .filter(|&lin| {
                let (lo, hi) = self.cell_box(self.delinearize(lin));
                let cell = Aabb::new(lo, hi).expanded(margin);
                cell.min.cmple(touched.max).all() && touched.min.cmple(cell.max).all()
            })
            .collect();
        let cells: Vec<(CellClass, f64)> = lins
            .par_iter()
            .map(|&lin| {
                let (lo, hi) = self.cell_box(self.delinearize(lin));
                let (lo, hi) = field.value_range(&Aabb::new(lo, hi).expanded(margin));
                let (lo, hi) = if lo.is_nan() || hi.is_nan() {
                    (f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    (lo, hi)
                };
                (classify(lo, hi), hi)
            })
            .collect();
        for (&lin, (class, hi)) in lins.iter().zip(cells) {
            self.class[lin] = class;
            self.hi[lin] = hi;
        }
        self.reach = self.outside_reach();
        self.non_outside = self.non_outside_cells_box();
    }

    /// Computes [`MacroGrid::non_outside_box`] from the cells' classes.
    fn non_outside_cells_box(&self) -> Option<Aabb> {
        let mut lo = [usize::MAX; 3];
        let mut hi = [0usize; 3];
        for (lin, class) in self.class.iter().enumerate() {
            if *class != CellClass::Outside {
                let ijk = self.delinearize(lin);
                for a in 0..3 {
                    lo[a] = lo[a].min(ijk[a]);
                    hi[a] = hi[a].max(ijk[a]);
                }
            }
        }
        (lo[0] != usize::MAX).then(|| Aabb::new(self.cell_box(lo).0, self.cell_box(hi).1))
    }

    /// The world box of the cells that are not [`CellClass::Outside`], `None` if there
    /// are none.
    pub(crate) fn non_outside_box(&self) -> Option<Aabb> {
        self.non_outside
    }

    /// [`MacroGrid::reach`] by repeated erosion of the Outside cells with a 3×3×3
    /// block (separable: a window of 3 along each axis in turn); cells beyond the grid
    /// hold no samples and count as Outside.
    fn outside_reach(&self) -> Vec<u8> {
        let [nx, ny, nz] = self.dims;
        let mut full: Vec<bool> = self.class.iter().map(|c| *c == CellClass::Outside).collect();
        let mut reach = vec![0u8; full.len()];
        for r in 1..=MAX_REACH {
            for (axis, n, stride) in [(0, nx, 1), (1, ny, nx), (2, nz, nx * ny)] {
                let prev = full.clone();
                for (lin, f) in full.iter_mut().enumerate() {
                    let i = [lin % nx, (lin / nx) % ny, lin / (nx * ny)][axis];
                    let below = i == 0 || prev[lin - stride];
                    let above = i + 1 >= n || prev[lin + stride];
                    *f = prev[lin] && below && above;
                }
            }
            let mut any = false;
            for (re, f) in reach.iter_mut().zip(&full) {
                if *f {
                    *re = r;
                    any = true;
                }
            }
            if !any {
                break;
            }
        }
        reach
    }

    /// The grid's box minimum and maximum, cell size and cells per axis (for walks
    /// written elsewhere: `sample_walk.rs`).
    pub(crate) fn layout(&self) -> (DVec3, DVec3, DVec3, [usize; 3]) {
        (self.min, self.max, self.cell, self.dims)
    }

    /// The class and Outside reach of cell `lin` (`x + nx·(y + ny·z)`).
    #[inline(always)]
    pub(crate) fn class_and_reach(&self, lin: usize) -> (CellClass, u8) {
        (self.class[lin], self.reach[lin])
    }

    /// Number of macro cells.
    pub(crate) fn len(&self) -> usize {
        self.class.len()
    }

    fn delinearize(&self, lin: usize) -> [usize; 3] {
        let shape = Shape3::new(UVec3::from_array(self.dims.map(|d| d as u32))).expect("1 to 64 cells per axis");
        shape.delinearize(lin).as_uvec3().to_array().map(|c| c as usize)
    }

    /// World box of cell `ijk`; the last cell on each axis ends exactly at the bounds.
    fn cell_box(&self, ijk: [usize; 3]) -> (DVec3, DVec3) {
        let mut lo = DVec3::ZERO;
        let mut hi = DVec3::ZERO;
        for a in 0..3 {
            lo[a] = self.min[a] + ijk[a] as f64 * self.cell[a];
            hi[a] = if ijk[a] + 1 >= self.dims[a] {
                self.max[a]
            } else {
                self.min[a] + (ijk[a] + 1) as f64 * self.cell[a]
            };
        }
        (lo, hi)
    }

    /// The cell containing `p` (clamped to the grid) and its linear index.
    #[inline]
    fn locate(&self, p: DVec3) -> ([usize; 3], usize) {
        let mut ijk = [0usize; 3];
        for (a, c) in ijk.iter_mut().enumerate() {
            let f = (p[a] - self.min[a]) / self.cell[a];
            *c = if f.is_finite() && f > 0.0 {
                (f as usize).min(self.dims[a] - 1)
            } else {
                0
            };
        }
        let lin = ijk[0] + self.dims[0] * (ijk[1] + self.dims[1] * ijk[2]);
        (ijk, lin)
    }

    /// Ray parameter where the ray leaves cell `ijk` (its far slab planes).
    #[inline]
    fn exit_t(&self, ijk: [usize; 3], ray: &Ray) -> f64 {
        let (lo, hi) = self.cell_box(ijk);
        let mut t = f64::INFINITY;
        for a in 0..3 {
            let d = ray.dir[a];
            if d != 0.0 {
                let plane = if d > 0.0 { hi[a] } else { lo[a] };
                t = t.min((plane - ray.origin[a]) / d);
            }
        }
        t
    }

    /// A walk along `ray` through the cells, starting at the cell holding the point
    /// at `t`.
    #[inline]
    pub(crate) fn walk<'g>(&'g self, ray: &'g Ray, t: f64) -> CellWalk<'g> {
        let (ijk, lin) = self.locate(ray.at(t));
        let mut walk = CellWalk {
            grid: self,
            ray,
            ijk,
            lin,
            t_exit: [f64::INFINITY; 3],
            inside: true,
            relocate: false,
        };
        walk.start_at(ijk, lin);
        walk
    }
}

/// A 3D digital differential analyser over the macro cells along one ray
/// (Amanatides and Woo): each step crosses one cell face, so a ray pays a few
/// operations per cell instead of locating every sample. Exit parameters are
/// computed from the cell's face planes like [`MacroGrid::cell_at`] would (no
/// accumulated increments); a sample on a face may be attributed to either cell,
/// which the cells' one-spacing margin covers.
pub(crate) struct CellWalk<'g> {
    grid: &'g MacroGrid,
    ray: &'g Ray,
    ijk: [usize; 3],
    lin: usize,
    /// Per axis, the ray parameter where it leaves the current cell through that axis'
    /// far face (∞ for an axis the ray is parallel to).
    t_exit: [f64; 3],
    /// False once the walk has left the grid (rounding at the bounds): cells are then
    /// located point by point.
    inside: bool,
    /// Set after a jump over a block of Outside cells: the next query locates its cell.
    relocate: bool,
}

impl CellWalk<'_> {
    fn start_at(&mut self, ijk: [usize; 3], lin: usize) {
        self.ijk = ijk;
        self.lin = lin;
        for a in 0..3 {
            self.t_exit[a] = self.plane_t(a);
        }
    }

    /// Ray parameter where the ray leaves, through its far face along `a`, the slab of
    /// cells `index` on that axis.
    #[inline]
    fn face_t(&self, a: usize, index: usize) -> f64 {
        let g = self.grid;
        let d = self.ray.dir[a];
        if d > 0.0 {
            let plane = if index + 1 >= g.dims[a] {
                g.max[a]
            } else {
                g.min[a] + (index + 1) as f64 * g.cell[a]
            };
            (plane - self.ray.origin[a]) / d
        } else if d < 0.0 {
            (g.min[a] + index as f64 * g.cell[a] - self.ray.origin[a]) / d
        } else {
            f64::INFINITY
        }
    }

    /// Ray parameter where the ray crosses the far face of the current cell along `a`.
    #[inline]
    fn plane_t(&self, a: usize) -> f64 {
        self.face_t(a, self.ijk[a])
    }

    /// The cell holding the sample at `t` (non-decreasing from call to call): its
    /// linear index and the ray parameter where the ray leaves it.
    #[inline]
    fn cell(&mut self, t: f64) -> (usize, f64) {
        let g = self.grid;
        if self.relocate && self.inside {
            self.relocate = false;
            let (ijk, lin) = g.locate(self.ray.at(t));
            self.start_at(ijk, lin);
        }
        loop {
            let exit = self.t_exit[0].min(self.t_exit[1]).min(self.t_exit[2]);
            if !self.inside {
                let (ijk, lin) = g.locate(self.ray.at(t));
                return (lin, g.exit_t(ijk, self.ray));
            }
            if exit >= t || exit.is_nan() {
                return (self.lin, exit);
            }
            // Step through the face crossed first.
            let a = if self.t_exit[0] == exit {
                0
            } else if self.t_exit[1] == exit {
                1
            } else {
                2
            };
            let forward = self.ray.dir[a] > 0.0;
            if (forward && self.ijk[a] + 1 >= g.dims[a]) || (!forward && self.ijk[a] == 0) {
                self.inside = false;
                continue;
            }
            if forward {
                self.ijk[a] += 1;
            } else {
                self.ijk[a] -= 1;
            }
            self.lin = self.ijk[0] + g.dims[0] * (self.ijk[1] + g.dims[1] * self.ijk[2]);
            self.t_exit[a] = self.plane_t(a);
        }
    }

    /// The class of the cell holding the sample at `t` and the ray parameter where the
    /// ray leaves that cell.
    ///
    /// In an Outside cell whose whole block of reach `r ≥ 2` is Outside, the exit is
    /// that of the block (`r` cells on every side, clipped to the grid): every point of
    /// the ray between the sample and it lies in the block, so the samples there are
    /// Outside too, and the walk locates its cell afresh at the next query.
    #[inline]
    pub(crate) fn class_at(&mut self, t: f64) -> (CellClass, f64) {
        let (lin, exit) = self.cell(t);
        let class = self.grid.class[lin];
        let r = self.grid.reach[lin] as usize;
        if class != CellClass::Outside || r < 2 || !self.inside {
            return (class, exit);
        }
        let g = self.grid;
        let mut block_exit = f64::INFINITY;
        for a in 0..3 {
            let index = if self.ray.dir[a] > 0.0 {
                (self.ijk[a] + r).min(g.dims[a] - 1)
            } else {
                self.ijk[a].saturating_sub(r)
            };
            block_exit = block_exit.min(self.face_t(a, index));
        }
        self.relocate = true;
        (class, block_exit.max(exit))
    }

    /// The maximum of the conservative value range of the cell holding the sample at
    /// `t`, and the ray parameter where the ray leaves that cell.
    #[inline]
    pub(crate) fn hi_at(&mut self, t: f64) -> (f64, f64) {
        let (lin, exit) = self.cell(t);
        (self.grid.hi[lin], exit)
    }
}
