//! Ray marching building blocks shared by the integrators: the empty-space grid,
//! the sample lattices, and the iso-surface search with its refinement. Everything here is
//! generic over the field type so per-sample loops are monomorphized (no dynamic
//! dispatch, no allocation).

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use volga_core::{fast_floor, Aabb, Field, Line};

use crate::settings::MAX_SAMPLES_PER_RAY;
use crate::{Ray, RenderStats};

/// Samples read per [`Field::values_along`] call: a run of samples inside one macro
/// cell, at most this many.
pub(crate) const BATCH: usize = 32;

/// Samples per run of the iso march: shorter, since a run's samples past the first
/// crossing are read for nothing.
const ISO_BATCH: usize = 8;

/// Upper bound on lattice samples along one ray; the renderer rejects settings that
/// would exceed it and [`first_hit`] coarsens its step to stay under it.
pub(crate) const MAX_STEPS_PER_RAY: f64 = MAX_SAMPLES_PER_RAY as f64;

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
        let [nx, ny, _] = self.dims;
        [lin % nx, (lin / nx) % ny, lin / (nx * ny)]
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

/// The first lattice index `j` (sample at `t0 + (j + offset)·dt`) beyond `t_exit`,
/// clamped to `[i + 1, end]` so marching always advances. Rounding can only make
/// the skipped samples overshoot the cell by a few ulps, inside the cell's margin.
#[inline]
pub(crate) fn index_after(t_exit: f64, t0: f64, dt: f64, offset: f64, i: u64, end: u64) -> u64 {
    let x = fast_floor((t_exit - t0) / dt - offset) + 1.0;
    let j = if x.is_nan() || x <= 0.0 {
        0
    } else if x >= end as f64 {
        end
    } else {
        x as u64
    };
    j.max(i + 1).min(end)
}

/// Number of iso lattice samples `t0 + i·dt < t1` (the march then adds one at `t1`).
fn iso_lattice_len(t0: f64, t1: f64, dt: f64) -> u64 {
    let guess = -fast_floor(-(t1 - t0) / dt); // ceil
    let mut k = if guess.is_nan() || guess < 0.0 {
        0
    } else {
        guess.min(MAX_STEPS_PER_RAY) as u64
    };
    while k > 0 && t0 + (k - 1) as f64 * dt >= t1 {
        k -= 1;
    }
    while (k as f64) < MAX_STEPS_PER_RAY && t0 + k as f64 * dt < t1 {
        k += 1;
    }
    k
}

/// Number of mid-point samples `t0 + (i + ½)·dt ≤ t1`.
pub(crate) fn midpoint_lattice_len(t0: f64, t1: f64, dt: f64) -> u64 {
    let guess = fast_floor((t1 - t0) / dt + 0.5);
    // Counts stay within `[0, 2²⁴]`: converted through `i64`, one instruction each way
    // (`u64` takes a dozen without AVX-512).
    let mut n = if guess.is_nan() || guess < 0.0 {
        0
    } else {
        guess.min(MAX_STEPS_PER_RAY) as i64 as u64
    };
    // The guess is right or one off; the loops settle anything else. Kept out of line:
    // inlined, the compiler vectorized them 32 wide, some 400 instructions per ray.
    let f = |n: u64| n as i64 as f64;
    let too_many = |n: u64| n > 0 && t0 + (f(n) - 0.5) * dt > t1;
    let too_few = |n: u64| f(n) < MAX_STEPS_PER_RAY && t0 + (f(n) + 0.5) * dt <= t1;
    if too_many(n) {
        n -= 1;
    } else if too_few(n) {
        n += 1;
    }
    if too_many(n) || too_few(n) {
        return settle_lattice_len(n, t0, t1, dt);
    }
    n
}

/// [`midpoint_lattice_len`] from a guess more than one off.
#[cold]
#[inline(never)]
fn settle_lattice_len(mut n: u64, t0: f64, t1: f64, dt: f64) -> u64 {
    while n > 0 && t0 + (n as f64 - 0.5) * dt > t1 {
        n -= 1;
    }
    while (n as f64) < MAX_STEPS_PER_RAY && t0 + (n as f64 + 0.5) * dt <= t1 {
        n += 1;
    }
    n
}

/// Refines a bracket `[lo, hi]` of the crossing, `s·value(lo) < s·iso ≤ s·value(hi)`
/// (`s = inward`, ±1), down to width `tol` and returns its midpoint.
///
/// Regula falsi with the Illinois modification (the end kept twice in a row has its
/// value halved), safeguarded by bisection whenever a step fails to halve the bracket,
/// so the bracket at least halves every two evaluations (at most 128). It reads the
/// ends' values itself, so the result depends on `(lo, hi)` alone. NaN values count as
/// outside.
#[allow(clippy::too_many_arguments)]
fn refine<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    inward: f64,
    iso: f64,
    mut lo: f64,
    mut hi: f64,
    tol: f64,
    stats: &mut RenderStats,
) -> f64 {
    // g = s·value − s·iso: < 0 outside, ≥ 0 inside.
    let g = |t: f64, stats: &mut RenderStats| {
        stats.samples += 1;
        inward * field.value(ray.at(t)) - iso
    };
    let mut g_lo = g(lo, stats);
    let mut g_hi = g(hi, stats);
    let mut kept = 0i8; // +1: `lo` kept by the last step, −1: `hi`
    let mut bisect_next = false;
    for _ in 0..128 {
        let width = hi - lo;
        if width <= tol {
            break;
        }
        let secant = g_lo < 0.0 && g_hi >= 0.0 && !bisect_next;
        let mut mid = if secant {
            lo + width * (g_lo / (g_lo - g_hi))
        } else {
            0.5 * (lo + hi)
        };
        if !(mid > lo && mid < hi) {
            mid = 0.5 * (lo + hi);
            if !(mid > lo && mid < hi) {
                break;
            }
        }
        let gm = g(mid, stats);
        if gm >= 0.0 {
            hi = mid;
            g_hi = gm;
            if kept == 1 {
                g_lo *= 0.5;
            }
            kept = 1;
        } else {
            lo = mid;
            g_lo = if gm.is_nan() { f64::NAN } else { gm };
            if kept == -1 {
                g_hi *= 0.5;
            }
            kept = -1;
        }
        bisect_next = hi - lo > 0.5 * width;
    }
    0.5 * (lo + hi)
}

/// First crossing from outside to inside the `iso` level set along `ray` within
/// `[t0, t1]`: with `inward = s` (±1, [`FieldKind::inward_sign`](volga_core::FieldKind::inward_sign)),
/// from `s·v < s·iso` to `s·v ≥ s·iso` — for a density from below to above, for a
/// signed distance from above to below. Multiplying by `s = 1` is exact, so
/// densities march exactly as without the factor.
///
/// Samples the lattice `t0 + i·dt` (and a last sample at `t1`) through
/// [`Field::values_along`], a run of samples per macro cell; a ray entering the
/// bounds from outside starts from the field's background value, so content touching
/// the bounds yields a hit at `t0`. NaN samples are ignored. With a macro grid,
/// samples in cells whose range excludes `iso` are skipped but their side of the iso
/// value is kept, so the bracket handed to [`refine`] — and the hit — are exactly
/// those found without skipping.
#[allow(clippy::too_many_arguments)]
pub(crate) fn march_iso<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    inward: f64,
    iso: f64,
    (t0, t1): (f64, f64),
    dt: f64,
    tol: f64,
    grid: Option<&MacroGrid>,
    stats: &mut RenderStats,
) -> Option<f64> {
    // Oriented so that inside is `≥ iso`.
    let iso = inward * iso;
    let k_end = iso_lattice_len(t0, t1, dt);
    let lattice_t = |i: u64| if i >= k_end { t1 } else { t0 + i as f64 * dt };
    let line = Line {
        origin: ray.at(t0),
        step: ray.dir * dt,
    };
    let bg = field.background();
    // (ray parameter, value below iso) of the previous sample.
    let mut prev: Option<(f64, bool)> = (t0 > 0.0 && !bg.is_nan()).then_some((t0, inward * bg < iso));
    let mut values = [0.0f64; ISO_BATCH];
    let mut walk = grid.map(|g| g.walk(ray, t0));
    let mut i = 0u64;
    while i <= k_end {
        let t = lattice_t(i);
        // The run of samples [i, end) to read: those in the current macro cell.
        let mut end = k_end + 1;
        if let Some(w) = &mut walk {
            let (class, t_exit) = w.class_at(t);
            let next = index_after(t_exit, t0, dt, 0.0, i, k_end + 1);
            if class != CellClass::Active {
                let below = class == CellClass::Outside;
                if let (false, Some((tp, true))) = (below, prev) {
                    // The skipped sample at `t` is inside: the crossing is in [tp, t].
                    return Some(refine(field, ray, inward, iso, tp, t, tol, stats));
                }
                stats.cells_skipped += 1;
                prev = Some((lattice_t(next - 1), below));
                i = next;
                continue;
            }
            end = next;
        }
        let run = if i == k_end {
            // The last sample, at `t1` (off the lattice).
            values[0] = field.value(ray.at(t1));
            1
        } else {
            let n = (end.min(k_end) - i).min(ISO_BATCH as u64) as usize;
            field.values_along(&line, i, &mut values[..n]);
            n
        };
        stats.samples += run as u64;
        for (k, &v) in values[..run].iter().enumerate() {
            if v.is_nan() {
                continue;
            }
            let t = lattice_t(i + k as u64);
            let below = inward * v < iso;
            if let (false, Some((tp, true))) = (below, prev) {
                return Some(refine(field, ray, inward, iso, tp, t, tol, stats));
            }
            prev = Some((t, below));
        }
        i += run as u64;
    }
    None
}

/// A surface point found by [`first_hit`].
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter: `world_pos = ray.origin + t·ray.dir`.
    pub t: f64,
    pub world_pos: DVec3,
}

/// The first crossing of `iso` from outside to inside along `ray` inside
/// `field.bounds()`, the inside decided by [`Field::kind`]: for a density from
/// below to `≥ iso`, for a signed distance from above to `≤ iso`.
///
/// Samples every `step_world` world units (the ray's `dir` need not be unit; `t`
/// is in units of `|dir|`), starting at the bounds entry, then refines the
/// bracketing interval (regula falsi safeguarded by bisection) until it is narrower than
/// `1e-9 · field.sample_spacing()` (at most 64 halvings). `None` if there is no
/// crossing, the ray misses the bounds, or the inputs are degenerate (non-finite
/// ray, zero direction, `step_world ≤ 0`). The step is coarsened if it would take
/// more than 2²⁴ samples to cross the bounds.
pub fn first_hit<F: Field + ?Sized>(field: &F, ray: &Ray, iso: f64, step_world: f64) -> Option<Hit> {
    let len = ray.dir.length();
    let valid = len > 0.0 && len.is_finite() && ray.origin.is_finite() && step_world.is_finite() && step_world > 0.0;
    if !valid {
        return None;
    }
    let bounds = field.bounds();
    if !(bounds.min.is_finite() && bounds.max.is_finite()) || bounds.is_empty() {
        return None;
    }
    let (t0, t1) = bounds.ray_interval(ray.origin, ray.dir)?;
    if !(t0.is_finite() && t1.is_finite()) {
        return None;
    }
    let spacing = field.sample_spacing();
    let tol = if spacing > 0.0 && spacing.is_finite() {
        1e-9 * spacing
    } else {
        1e-9 * step_world
    } / len;
    let dt = (step_world / len).max((t1 - t0) / MAX_STEPS_PER_RAY);
    if !(dt > 0.0 && dt.is_finite()) {
        return None;
    }
    let mut stats = RenderStats::default();
    let inward = field.kind().inward_sign();
    let t = march_iso(field, ray, inward, iso, (t0, t1), dt, tol, None, &mut stats)?;
    Some(Hit {
        t,
        world_pos: ray.at(t),
    })
}

/// Colour of the field at `p`, white where it has none (or a non-finite one).
#[inline]
pub(crate) fn field_colour<F: Field + ?Sized>(field: &F, p: DVec3) -> Vec3 {
    match field.colour(p) {
        Some(c) if c.is_finite() => c.clamp(Vec3::ZERO, Vec3::ONE),
        _ => Vec3::ONE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_lengths() {
        assert_eq!(midpoint_lattice_len(0.0, 10.0, 0.5), 20);
        assert_eq!(midpoint_lattice_len(0.0, 10.0, 0.25), 40);
        assert_eq!(midpoint_lattice_len(0.0, 0.2, 0.5), 0);
        assert_eq!(midpoint_lattice_len(3.0, 3.0, 0.5), 0);
        assert_eq!(iso_lattice_len(0.0, 10.0, 0.5), 20);
        assert_eq!(iso_lattice_len(0.0, 10.1, 0.5), 21);
        assert_eq!(iso_lattice_len(2.0, 2.0, 0.5), 0);
        assert_eq!(index_after(2.6, 0.0, 1.0, 0.0, 0, 100), 3);
        assert_eq!(index_after(2.6, 0.0, 1.0, 0.5, 0, 100), 3);
        assert_eq!(index_after(2.4, 0.0, 1.0, 0.5, 0, 100), 2);
        assert_eq!(index_after(-5.0, 0.0, 1.0, 0.5, 7, 100), 8);
        assert_eq!(index_after(1e300, 0.0, 1.0, 0.5, 7, 100), 100);
        assert_eq!(index_after(f64::NAN, 0.0, 1.0, 0.5, 7, 100), 8);
    }
}
