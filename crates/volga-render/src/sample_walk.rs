//! The macro-cell walk of the packed DVR loop, in units of the ray's sample lattice.
//!
//! [`CellWalk`](crate::macro_grid::CellWalk) answers "which cell holds the sample at ray
//! parameter `t`, and where does the ray leave it" with a division per face crossed,
//! and the packed loop then turns that exit parameter back into a sample index with
//! another division ([`index_after`](crate::march::index_after)). Callgrind measured
//! the pair at 46 of the packed DVR loop's 227 instructions per sample (ct phantom,
//! 128³, 256²), with about 5 samples per query.
//!
//! Here the ray is written in the grid's own coordinates as a function of the sample
//! index `j` (`u(j) = u₀ + j·du`, one unit per macro cell), so a face crossing is one
//! multiplication by the precomputed `1/du` and the walk hands back the first sample
//! index beyond the cell directly. Faces are computed from the cell index each time
//! (no accumulated increments). Rounding can attribute a sample on a face to either
//! cell, as in `CellWalk`: the cells' value ranges carry a one-spacing margin
//! (`MacroGrid::build`), which covers it, so skipping still never drops a visible
//! sample (`render::empty_space_skipping_never_changes_the_image`).

use crate::camera::Ray;
use crate::macro_grid::{CellClass, MacroGrid};

/// See the [module docs](self).
pub(crate) struct SampleWalk<'g> {
    grid: &'g MacroGrid,
    dims: [usize; 3],
    /// Per axis, the change of the cell index (`±1`) and of the linear index (`±stride`)
    /// when the ray crosses a face.
    step: [isize; 3],
    lin_step: [isize; 3],
    /// Per axis, the offset from a slab's index to its far face in the ray's direction
    /// (1 going up, 0 going down), and the slab whose far face is never crossed (the
    /// grid's last one in the ray's direction).
    far: [f64; 3],
    last: [usize; 3],
    /// Per axis, whether the ray is parallel to it (never crosses its faces).
    parallel: [bool; 3],
    /// Grid coordinates (cells from the grid's minimum) of sample 0, their change per
    /// sample, and its reciprocal.
    u0: [f64; 3],
    du: [f64; 3],
    inv_du: [f64; 3],
    ijk: [usize; 3],
    lin: usize,
    /// Per axis, the (continuous) sample index where the ray leaves the current cell's
    /// slab through its far face; ∞ for the grid's last slab in the ray's direction
    /// and for an axis the ray is parallel to.
    exit: [f64; 3],
    /// Set after a jump over a block of Outside cells: the next query locates its cell.
    relocate: bool,
}

impl<'g> SampleWalk<'g> {
    /// A walk along the samples `t_first + j·step` (`j = 0, 1, …`) of `ray`, starting
    /// at the cell of sample `first_sample` (queries then start there).
    pub(crate) fn new(grid: &'g MacroGrid, ray: &Ray, t_first: f64, step: f64, first_sample: u64) -> SampleWalk<'g> {
        let (min, _, cell, dims) = grid.layout();
        let first = ray.at(t_first);
        let stride = [1, dims[0], dims[0] * dims[1]];
        let mut walk = SampleWalk {
            grid,
            dims,
            step: [0; 3],
            lin_step: [0; 3],
            far: [0.0; 3],
            last: [0; 3],
            parallel: [true; 3],
            u0: [0.0; 3],
            du: [0.0; 3],
            inv_du: [0.0; 3],
            ijk: [0; 3],
            lin: 0,
            exit: [f64::INFINITY; 3],
            relocate: false,
        };
        for a in 0..3 {
            walk.u0[a] = (first[a] - min[a]) / cell[a];
            walk.du[a] = step * ray.dir[a] / cell[a];
            walk.inv_du[a] = 1.0 / walk.du[a];
            let up = walk.du[a] > 0.0;
            walk.parallel[a] = !(up || walk.du[a] < 0.0);
            walk.step[a] = if up { 1 } else { -1 };
            walk.lin_step[a] = walk.step[a] * stride[a] as isize;
            walk.far[a] = if up { 1.0 } else { 0.0 };
            walk.last[a] = if up { dims[a] - 1 } else { 0 };
        }
        walk.locate(first_sample as i64 as f64);
        walk
    }

    /// Moves to the cell holding sample `j` (clamped to the grid).
    ///
    /// Here and below, integers convert to and from `f64` through `i64` (one
    /// instruction; `u64` and `usize` take a dozen without AVX-512): sample indices stay
    /// below 2²⁴ and cell indices below 64, and a saturated `i64` still clamps.
    fn locate(&mut self, j: f64) {
        for a in 0..3 {
            let u = self.u0[a] + j * self.du[a];
            self.ijk[a] = if u.is_finite() && u > 0.0 {
                (u as i64 as usize).min(self.dims[a] - 1)
            } else {
                0
            };
        }
        self.lin = self.ijk[0] + self.dims[0] * (self.ijk[1] + self.dims[1] * self.ijk[2]);
        for a in 0..3 {
            self.exit[a] = self.face(a, self.ijk[a]);
        }
    }

    /// The sample index where the ray leaves slab `index` of axis `a` (∞ if the slab is
    /// the last one the ray meets along `a`, or the ray is parallel to the axis).
    #[inline(always)]
    fn face(&self, a: usize, index: usize) -> f64 {
        if self.parallel[a] || index == self.last[a] {
            return f64::INFINITY;
        }
        // `index + far` is exact: the far face's grid coordinate.
        (index as i64 as f64 + self.far[a] - self.u0[a]) * self.inv_du[a]
    }

    /// The class of the cell holding sample `i` (queries in non-decreasing order) and
    /// the first sample index beyond that cell, clamped to `[i + 1, n]`; for an Active
    /// cell, beyond the run of Active cells the ray crosses from it. In an Outside
    /// cell whose whole block of reach `r ≥ 2` is Outside, the index is that beyond the
    /// block (`r` cells on every side, clipped to the grid), as
    /// [`CellWalk::class_at`](crate::macro_grid::CellWalk::class_at) does.
    #[inline(always)]
    pub(crate) fn class_at(&mut self, i: u64, n: u64) -> (CellClass, u64) {
        let j = i as i64 as f64;
        let end = n as i64 as f64;
        if self.relocate {
            self.relocate = false;
            self.locate(j);
        }
        // The walk's state in locals, each axis's step with a constant index: through
        // `self` with the axis as a variable index, every step stored an exit and
        // loaded all three back (a store-forwarding stall per macro cell, perf).
        let [mut e0, mut e1, mut e2] = self.exit;
        let [mut i0, mut i1, mut i2] = self.ijk;
        let mut lin = self.lin;
        let mut exit = e0.min(e1).min(e2);
        // Into the next cell along the ray: the axis whose face is crossed first. A
        // finite exit is never the last slab's (`face`), so the step stays inside.
        macro_rules! step {
            () => {
                if e0 == exit {
                    i0 = i0.wrapping_add_signed(self.step[0]);
                    lin = lin.wrapping_add_signed(self.lin_step[0]);
                    e0 = self.face(0, i0);
                } else if e1 == exit {
                    i1 = i1.wrapping_add_signed(self.step[1]);
                    lin = lin.wrapping_add_signed(self.lin_step[1]);
                    e1 = self.face(1, i1);
                } else {
                    i2 = i2.wrapping_add_signed(self.step[2]);
                    lin = lin.wrapping_add_signed(self.lin_step[2]);
                    e2 = self.face(2, i2);
                }
            };
        }
        // `exit < j` is false for NaN: a NaN exit keeps the cell.
        while exit < j {
            step!();
            exit = e0.min(e1).min(e2);
        }
        let (class, reach) = self.grid.class_and_reach(lin);
        // An Active cell's run goes on through the Active cells after it, and an
        // Outside cell's whose block cannot be jumped (reach < 2, next to Active ones)
        // through the like cells after it: one answer per run, so the caller's loop
        // turns once per run, not per cell. The walk stops in the first cell after the
        // run (an Outside cell there with reach ≥ 2 is jumped by the next query).
        let in_run = |(c, r): (CellClass, u8)| match class {
            CellClass::Active => c == CellClass::Active,
            _ => c == CellClass::Outside && r < 2,
        };
        if in_run((class, reach)) {
            while exit < end {
                let run_end = exit;
                step!();
                exit = e0.min(e1).min(e2);
                if !in_run(self.grid.class_and_reach(lin)) {
                    exit = run_end;
                    break;
                }
            }
        }
        self.exit = [e0, e1, e2];
        self.ijk = [i0, i1, i2];
        self.lin = lin;
        let r = reach as usize;
        if class == CellClass::Outside && r >= 2 {
            let mut block = f64::INFINITY;
            for a in 0..3 {
                let index = if self.du[a] > 0.0 {
                    (self.ijk[a] + r).min(self.dims[a] - 1)
                } else {
                    self.ijk[a].saturating_sub(r)
                };
                block = block.min(self.face(a, index));
            }
            exit = exit.max(block);
            self.relocate = true;
        }
        // The first whole sample index beyond `exit` (a NaN exit moves one sample on,
        // as `index_after` does).
        let next = if exit.is_nan() || exit < 0.0 {
            0
        } else if exit >= end {
            n
        } else {
            // In `[0, n)`, `n ≤ 2²⁴`: exact through `i64` (one instruction; `u64` is a
            // dozen without AVX-512).
            exit as i64 as u64 + 1
        };
        (class, next.max(i + 1).min(n))
    }
}

/// The samples `t0 + (j + ½)·step`, `j` in `[first, last)` ⊆ `[0, n)`, that can lie in
/// the box of `grid`'s cells that are not Outside ([`MacroGrid::non_outside_box`]), or
/// `None` if the ray misses that box. The samples outside the span are in Outside
/// cells, which hold no visible sample (their value ranges carry a one-spacing
/// margin), so a loop may start and end there. One sample more on each side absorbs
/// the rounding of the positions; NaN bounds keep the whole lattice.
///
/// Inlined into the AVX2 loop, so its `floor` and `ceil` are one instruction each, not
/// library calls; counts (`n ≤ 2²⁴`) convert through `i64`.
#[inline(always)]
pub(crate) fn non_outside_span(grid: &MacroGrid, ray: &Ray, t0: f64, step: f64, n: u64) -> Option<(u64, u64)> {
    let (ta, tb) = crate::integrators::clip(&grid.non_outside_box()?, ray)?;
    let lo = ((ta - t0) / step - 0.5).floor() - 1.0;
    let hi = ((tb - t0) / step - 0.5).ceil() + 2.0;
    let end = n as i64 as f64;
    let first = if lo > 0.0 { lo.min(end) as i64 as u64 } else { 0 };
    let last = if hi < end {
        (hi.max(0.0) as i64 as u64).max(first)
    } else {
        n
    };
    Some((first, last))
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, UVec3};
    use volga_core::{Aabb, Field, Filter, Grid, Sampled, SparseVolume, Transform};

    use super::SampleWalk;
    use crate::macro_grid::{CellClass, MacroGrid};
    use crate::march::midpoint_lattice_len;
    use crate::Ray;

    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Ray `k` of the walk tests: from outside through a random interior point,
    /// axis-parallel (on a macro-cell face plane for some), grazing (almost parallel
    /// to a face), or starting inside and going backwards.
    fn test_ray(k: usize, next: &mut impl FnMut() -> f64, bounds: &Aabb, min: DVec3, cell: DVec3) -> Ray {
        let centre = bounds.center();
        let random_dir = DVec3::new(2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0);
        let (from, dir) = match k % 4 {
            0 => {
                let target = bounds.min + bounds.size() * DVec3::new(next(), next(), next());
                let from = centre + random_dir.normalize() * 400.0;
                (from, target - from)
            }
            1 => {
                let a = k / 4 % 3;
                let mut from = bounds.min + bounds.size() * DVec3::new(next(), next(), next());
                if k % 8 == 1 {
                    from[(a + 1) % 3] = min[(a + 1) % 3] + cell[(a + 1) % 3] * 3.0;
                }
                from[a] = bounds.min[a] - 10.0;
                let mut dir = DVec3::ZERO;
                dir[a] = 1.0;
                (from, dir)
            }
            2 => {
                let from = bounds.min + bounds.size() * DVec3::new(next(), next(), 0.0) - DVec3::Z * 5.0;
                (from, DVec3::new(1.0, 0.5, 1e-7 * next()))
            }
            _ => {
                let from = bounds.min + bounds.size() * DVec3::new(next(), next(), next());
                (from, -random_dir)
            }
        };
        Ray {
            origin: from,
            dir: dir.normalize(),
        }
    }

    /// The blobs volume of the walk tests (grid origin `origin`), its field's macro
    /// grid with cells Active where the range's maximum exceeds `threshold`.
    fn blobs(origin: DVec3) -> SparseVolume {
        let dims = UVec3::new(150, 90, 120);
        let grid = Grid::new(Transform::new(origin, DVec3::ONE).unwrap(), dims).unwrap();
        let mut v = SparseVolume::new(grid, 0.0, false);
        let blobs = [
            DVec3::new(30.0, 20.0, 40.0),
            DVec3::new(110.0, 70.0, 30.0),
            DVec3::new(75.0, 45.0, 100.0),
        ];
        for ijk in grid.index_box().iter() {
            let p = ijk.as_dvec3();
            let d = blobs.iter().map(|b| (p - *b).length()).fold(f64::INFINITY, f64::min);
            v.density.set(ijk, (1.0 - d / 12.0).max(0.0) as f32);
        }
        v
    }

    fn threshold_grid<F: Field>(field: &F, threshold: f64) -> MacroGrid {
        MacroGrid::build(field, field.bounds(), 1.0, |_lo, hi| {
            if hi > threshold {
                CellClass::Active
            } else {
                CellClass::Outside
            }
        })
    }

    /// `non_outside_span` keeps every sample inside the box of the cells that are not
    /// Outside (beyond rounding) and every sample above the skip threshold, and starts
    /// and ends within three samples of the box: rays from outside, axis-parallel,
    /// grazing and starting inside, with the grid at the origin and at 1e6.
    #[test]
    fn the_span_keeps_every_sample_in_the_non_outside_box() {
        for origin in [DVec3::new(-3.0, 0.5, 2.0), DVec3::splat(1e6)] {
            let v = blobs(origin);
            let field = Sampled::new(&v, Filter::Trilinear);
            let bounds = field.bounds();
            let threshold = 0.05;
            let macro_grid = threshold_grid(&field, threshold);
            let (min, _, cell, _) = macro_grid.layout();
            let active = macro_grid.non_outside_box().unwrap();
            assert!(active.size().x < bounds.size().x - 20.0, "{active:?} {bounds:?}");
            // Signed distance of `p` outside `active` (negative inside), by the largest
            // per-axis excess.
            let outside_by = |p: DVec3| -> f64 {
                (0..3)
                    .map(|a| (active.min[a] - p[a]).max(p[a] - active.max[a]))
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            let mut next = uniform(11);
            let (mut clipped_front, mut clipped_back, mut missed) = (0, 0, 0);
            for k in 0..800 {
                let ray = test_ray(k, &mut next, &bounds, min, cell);
                let Some((t0, t1)) = bounds.ray_interval(ray.origin, ray.dir) else {
                    continue;
                };
                let step = 0.5;
                let n = midpoint_lattice_len(t0, t1, step);
                let at = |j: u64| ray.at(t0 + (j as f64 + 0.5) * step);
                let inside: Vec<u64> = (0..n).filter(|&j| outside_by(at(j)) < -1e-6).collect();
                let Some((first, last)) = super::non_outside_span(&macro_grid, &ray, t0, step, n) else {
                    assert!(inside.is_empty(), "ray {k} missed the box");
                    missed += 1;
                    continue;
                };
                assert!(first <= last && last <= n);
                for &j in &inside {
                    assert!(first <= j && j < last, "ray {k}: sample {j} outside [{first}, {last})");
                }
                for j in (0..first).chain(last..n) {
                    assert!(field.value(at(j)) <= threshold, "ray {k}: visible sample {j} dropped");
                }
                if let (Some(&a), Some(&b)) = (inside.first(), inside.last()) {
                    assert!(
                        first + 3 >= a && last <= b + 4,
                        "ray {k}: [{first}, {last}) against [{a}, {b}]"
                    );
                }
                clipped_front += (first > 0) as u32;
                clipped_back += (last < n) as u32;
            }
            assert!(
                clipped_front > 100 && clipped_back > 100 && missed > 10,
                "{clipped_front} {clipped_back} {missed}"
            );
            // Every cell Outside (a threshold above every value): no box, and every
            // ray misses it.
            let empty = threshold_grid(&field, 2.0);
            assert!(empty.non_outside_box().is_none());
            let ray = test_ray(0, &mut next, &bounds, min, cell);
            assert_eq!(super::non_outside_span(&empty, &ray, 0.0, 0.5, 100), None);
        }
    }

    /// Every sample of every ray gets the class of the macro cell that holds it, except
    /// within rounding of a cell face, and a skipped sample never sees a value above
    /// the skip threshold: random, axis-parallel, grazing and inside-starting rays over
    /// a volume with scattered blobs (so cells of every class and reach occur), with the
    /// grid at the origin and at 1e6.
    #[test]
    fn each_sample_gets_its_cells_class() {
        for origin in [DVec3::new(-3.0, 0.5, 2.0), DVec3::splat(1e6)] {
            let v = blobs(origin);
            let field = Sampled::new(&v, Filter::Trilinear);
            let bounds = field.bounds();
            let spacing = 1.0;
            let threshold = 0.05;
            let macro_grid = threshold_grid(&field, threshold);
            let (min, _, cell, mdims) = macro_grid.layout();
            let true_cell = |p: DVec3| -> (usize, f64) {
                let mut lin = 0;
                let mut stride = 1;
                let mut near_face = f64::INFINITY;
                for a in 0..3 {
                    let u = (p[a] - min[a]) / cell[a];
                    let k = (u.max(0.0) as usize).min(mdims[a] - 1);
                    near_face = near_face.min((u - u.round()).abs());
                    lin += k * stride;
                    stride *= mdims[a];
                }
                (lin, near_face)
            };
            let mut next = uniform(7);
            let (mut checked, mut skipped, mut near) = (0u64, 0u64, 0u64);
            for k in 0..600 {
                let ray = test_ray(k, &mut next, &bounds, min, cell);
                let Some((t0, t1)) = bounds.ray_interval(ray.origin, ray.dir) else {
                    continue;
                };
                let step = 0.5 * spacing;
                let n = midpoint_lattice_len(t0, t1, step);
                let t_first = t0 + 0.5 * step;
                let mut walk = SampleWalk::new(&macro_grid, &ray, t_first, step, 0);
                let mut i = 0;
                while i < n {
                    let (class, end) = walk.class_at(i, n);
                    assert!(end > i && end <= n);
                    for j in i..end {
                        let p = ray.at(t_first + j as f64 * step);
                        let (lin, face) = true_cell(p);
                        let (truth, _) = macro_grid.class_and_reach(lin);
                        if face > 1e-6 {
                            assert_eq!(class, truth, "ray {k}, sample {j} of {n} at {p}");
                        } else {
                            near += 1;
                        }
                        if class != CellClass::Active {
                            assert!(field.value(p) <= threshold, "ray {k}, sample {j} skipped at {p}");
                            skipped += 1;
                        }
                        checked += 1;
                    }
                    i = end;
                }
            }
            assert!(
                checked > 50_000 && skipped > checked / 4 && checked - skipped > 1_000 && near > 0,
                "{checked} {skipped} {near}"
            );
        }
    }
}
