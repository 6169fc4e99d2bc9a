//! The ADF octree: cells with 8 corner distances, built top-down (Frisken et al. 2000).

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;
use volga_core::Aabb;

use crate::source::{CellCandidates, DistanceSource, Sample};
use crate::AdfError;

/// `children` of a leaf.
pub(crate) const LEAF: u32 = u32::MAX;

/// `children` of a jump leaf: this flag or'ed with the index of its sign-field corners in
/// [`Adf::jumps`]. Internal cells have `children < JUMP_FLAG`.
pub(crate) const JUMP_FLAG: u32 = 1 << 31;

/// Levels below the root built as parallel tasks (8³ = 512 tasks at most); deeper
/// subtrees are built sequentially into one vector each.
const PARALLEL_DEPTH: u8 = 3;

/// The test points must meet this fraction of the tolerance. Frisken's criterion checks
/// only 19 points per cell; the reconstruction between them can miss by more (measured:
/// up to 1.1× the tolerance on a box's edges with a margin of 1). Half the tolerance at
/// the test points keeps every random point of the accuracy tests within the tolerance
/// (docs/ADF.md measures it), at about 1.4× the cells on curved surfaces.
pub const TEST_MARGIN: f64 = 0.5;

/// The deepest tree the cell arithmetic supports (cell sizes `root / 2^depth` stay exact
/// powers of two of the root size).
pub const MAX_SUPPORTED_DEPTH: u8 = 24;

/// One octree cell: the signed distances at its 8 corners (corner `b` is at
/// `min + size·(b&1, b>>1&1, b>>2&1)`), stored as `f32` payloads, and the index of its
/// first child (the 8 children are contiguous, in the same octant order) or [`LEAF`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cell {
    pub corners: [f32; 8],
    pub children: u32,
}

impl Cell {
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.children >= JUMP_FLAG
    }

    /// The index of a jump leaf's sign-field corners.
    #[inline]
    pub fn jump(&self) -> Option<usize> {
        (self.children != LEAF && self.children >= JUMP_FLAG).then_some((self.children & !JUMP_FLAG) as usize)
    }

    /// `(min, max)` of the corner values: bounds the trilinear reconstruction anywhere in
    /// the cell (a convex combination of the corners).
    #[inline]
    pub fn corner_range(&self) -> (f64, f64) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for &c in &self.corners {
            lo = lo.min(c);
            hi = hi.max(c);
        }
        (lo as f64, hi as f64)
    }
}

/// How to build an ADF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdfOptions {
    /// Largest accepted difference (world units) between the trilinear reconstruction and
    /// the source: a cell is split while it misses by more than `tolerance ·`
    /// [`TEST_MARGIN`] at any of its 19 test points (centre, 6 face centres, 12 edge
    /// midpoints).
    /// Must be finite and > 0 (0 would ask for exactness, which a trilinear cell reaches
    /// only on linear fields: the build would stop only at `max_depth` everywhere the
    /// surface is curved, so it is refused rather than silently bounded).
    pub tolerance: f64,
    /// Deepest level (the root is level 0); cells there are leaves whatever their error.
    pub max_depth: u8,
    /// Refuse the build (with the size needed) once it would hold more cells than this.
    pub max_cells: usize,
    /// Empty margin (world units) between the source's bounds and the root cube, so the
    /// reconstruction is defined around the whole surface. `None`: 5 % of the bounds'
    /// diagonal.
    pub margin: Option<f64>,
    /// Distance from the surface (world units) within which the tolerance must hold: a
    /// cell is pruned only if all its corners are of one sign and farther than its
    /// diagonal **plus** `band`, so every point within `band` of the surface lies in a
    /// tested leaf. 0 is Frisken's rule (accuracy at the surface only).
    pub band: f64,
}

impl AdfOptions {
    /// A tolerance given as a fraction of the bounds' diagonal (how the docs and the
    /// benchmarks state it), with the default depth 12 and a cell limit from the memory
    /// available.
    pub fn relative(tolerance_fraction: f64, bounds: &Aabb) -> Self {
        AdfOptions {
            tolerance: tolerance_fraction * bounds.size().length(),
            ..AdfOptions::default()
        }
    }

    fn check(&self) -> Result<(), AdfError> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(AdfError::Tolerance(self.tolerance));
        }
        if self.max_depth > MAX_SUPPORTED_DEPTH {
            return Err(AdfError::Depth(self.max_depth));
        }
        if !(self.band.is_finite() && self.band >= 0.0) {
            return Err(AdfError::Band(self.band));
        }
        if let Some(m) = self.margin {
            if !(m.is_finite() && m >= 0.0) {
                return Err(AdfError::Margin(m));
            }
        }
        Ok(())
    }
}

impl Default for AdfOptions {
    fn default() -> Self {
        AdfOptions {
            tolerance: 1e-3,
            max_depth: 12,
            max_cells: default_max_cells(),
            margin: None,
            band: 0.0,
        }
    }
}

/// Cells that fit in half the memory available now (at least 1 M).
fn default_max_cells() -> usize {
    let bytes = volga_core::memory::available_bytes().unwrap_or(8 << 30);
    ((bytes / 2) as usize / std::mem::size_of::<Cell>()).max(1 << 20)
}

/// What a build did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildStats {
    /// Cells in the tree (internal and leaves).
    pub cells: usize,
    pub leaves: usize,
    /// Leaves pruned as far from the surface (all corners of one sign, farther than the
    /// cell's diagonal): no test points were evaluated for them.
    pub pruned_leaves: usize,
    /// Leaves at `max_depth` (their error was not checked: the resolution limit).
    pub max_depth_leaves: usize,
    /// Leaves where the signed distance jumps away from any surface (an open mesh's
    /// inside changing across a hole): they store the source's sign field too.
    pub jump_leaves: usize,
    /// Deepest level reached.
    pub depth_reached: u8,
    /// Source distance evaluations.
    pub evaluations: u64,
}

/// Where a point falls in the tree ([`Adf::leaf_at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafInfo {
    pub world_min: DVec3,
    pub size: f64,
    pub depth: u8,
    /// A jump leaf (it stores the source's sign field).
    pub jump: bool,
    /// Pruned as far from the surface (no test points: the tolerance does not hold).
    pub pruned: bool,
}

/// An adaptively sampled distance field: an octree over a cube (the root), each cell
/// storing the signed distances at its corners; the distance anywhere is the trilinear
/// reconstruction in the leaf containing the point.
///
/// Geometry is `f64` world space (`world_*`); the root cube is `root_min + [0, root_size]³`
/// and a cell at depth `k` has size `root_size / 2^k` (exact). Stored distances are `f32`
/// payloads: their rounding (≤ 6e-8 of the value) is 100× below the smallest tolerance the
/// benchmarks use (1e-5 of the diagonal) and is included in every tolerance check, because
/// the build checks the reconstruction from the rounded corners.
#[derive(Clone, Debug, PartialEq)]
pub struct Adf {
    pub(crate) root_min: DVec3,
    pub(crate) root_size: f64,
    pub(crate) cells: Vec<Cell>,
    /// Sign-field corners of the jump leaves (see [`DistanceSource::sign_field`]).
    pub(crate) jumps: Vec<[f32; 8]>,
    pub(crate) options: AdfOptions,
    pub(crate) stats: BuildStats,
    /// The ray walk's index, built on the first ray ([`crate::walk`]).
    pub(crate) walk: crate::walk::WalkCache,
}

/// A subtree built apart: `cells[0]` is its root; child indices are relative to the vector.
pub(crate) struct Subtree {
    pub cells: Vec<Cell>,
    pub jumps: Vec<[f32; 8]>,
}

/// Shared state of one build.
pub(crate) struct Builder<'a, S: ?Sized> {
    pub source: &'a S,
    pub tolerance: f64,
    pub max_depth: u8,
    pub max_cells: usize,
    pub band: f64,
    /// The source's sign may jump away from any surface ([`DistanceSource::may_jump`]).
    pub may_jump: bool,
    pub cells: AtomicUsize,
    pub evaluations: AtomicU64,
    /// World position of lattice point `(0, 0, 0)` (the root's minimum) and the lattice
    /// step (half the finest cell): keys of the sample cache.
    pub lattice_origin: DVec3,
    pub lattice_unit: f64,
}

/// Samples already taken in one sequentially built subtree, by lattice point (integer
/// coordinates in half-finest-cell units from the root's minimum): a point shared by
/// sibling or cousin cells is evaluated once. Values are functions of the point alone, so
/// the cache changes the work, never the tree.
#[derive(Default)]
pub(crate) struct SampleCache {
    ///
    /// A test point is on the lattice of cells of its own depth only (at an odd multiple
    /// of their half size in one or two coordinates: every deeper cell has it as a corner,
    /// from its parent's lattice, and no shallower cell's lattice holds it), so it is
    /// looked up only by the other cells of that depth around it: one across a face
    /// centre, three around an edge midpoint. Each entry counts the lookups left and is
    /// dropped at the last, so the map holds the build's frontier, not every sample.
    samples: rustc_hash::FxHashMap<[u32; 3], (Sample, u8)>,
    /// Sign-field values at jump leaves' corners ([`DistanceSource::sign_field_at`]).
    sign_fields: rustc_hash::FxHashMap<[u32; 3], Option<f64>>,
}

/// A cell's candidate list ([`DistanceSource::candidates`]), `None` if the source does
/// not narrow.
type Candidates = Option<CellCandidates>;

/// The 27 points of a cell's 3×3×3 lattice, index `i + 3j + 9k`, in half-cell units.
#[inline]
fn lattice_index(i: usize, j: usize, k: usize) -> usize {
    i + 3 * j + 9 * k
}

#[inline]
fn corner_lattice(b: usize) -> usize {
    lattice_index((b & 1) * 2, ((b >> 1) & 1) * 2, ((b >> 2) & 1) * 2)
}

/// Trilinear reconstruction from 8 corners at unit-cube coordinates `t`.
#[inline]
pub(crate) fn trilinear(c: &[f32; 8], t: DVec3) -> f64 {
    let c = c.map(|v| v as f64);
    let x00 = c[0] + (c[1] - c[0]) * t.x;
    let x10 = c[2] + (c[3] - c[2]) * t.x;
    let x01 = c[4] + (c[5] - c[4]) * t.x;
    let x11 = c[6] + (c[7] - c[6]) * t.x;
    let y0 = x00 + (x10 - x00) * t.y;
    let y1 = x01 + (x11 - x01) * t.y;
    y0 + (y1 - y0) * t.z
}

/// Gradient of [`trilinear`] with respect to `t` (unit-cube coordinates).
#[inline]
pub(crate) fn trilinear_gradient(c: &[f32; 8], t: DVec3) -> DVec3 {
    let c = c.map(|v| v as f64);
    let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
    // d/dx: differences along x, interpolated in y and z
    let dx = lerp(
        lerp(c[1] - c[0], c[3] - c[2], t.y),
        lerp(c[5] - c[4], c[7] - c[6], t.y),
        t.z,
    );
    let dy = lerp(
        lerp(c[2] - c[0], c[3] - c[1], t.x),
        lerp(c[6] - c[4], c[7] - c[5], t.x),
        t.z,
    );
    let dz = lerp(
        lerp(c[4] - c[0], c[5] - c[1], t.x),
        lerp(c[6] - c[2], c[7] - c[3], t.x),
        t.y,
    );
    DVec3::new(dx, dy, dz)
}

impl<S: DistanceSource + ?Sized> Builder<'_, S> {
    pub fn eval(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Result<Sample, AdfError> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let s = self.source.sample(p, near);
        if s.value.is_finite() {
            Ok(s)
        } else {
            Err(AdfError::NonFinite(p.to_array()))
        }
    }

    fn eval_among(
        &self,
        p: DVec3,
        near: Option<(DVec3, &Sample)>,
        candidates: &CellCandidates,
    ) -> Result<Sample, AdfError> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let s = self.source.sample_among(p, near, candidates);
        if s.value.is_finite() {
            Ok(s)
        } else {
            Err(AdfError::NonFinite(p.to_array()))
        }
    }

    fn count(&self, n: usize) -> Result<(), AdfError> {
        let total = self.cells.fetch_add(n, Ordering::Relaxed) + n;
        if total > self.max_cells {
            return Err(AdfError::TooManyCells {
                limit: self.max_cells,
                bytes: (total as u64) * std::mem::size_of::<Cell>() as u64,
            });
        }
        Ok(())
    }

    /// The 27 samples of a cell's 3×3×3 lattice: its corners and its 19 test points (each
    /// given the nearest corner that knows its region), from `cache` when a neighbour
    /// took them already, among the cell's `candidates` when the source narrows.
    fn lattice(
        &self,
        min: DVec3,
        size: f64,
        samples: &[Sample; 8],
        candidates: Option<&CellCandidates>,
        mut cache: Option<&mut SampleCache>,
    ) -> Result<[Sample; 27], AdfError> {
        let mut lattice = [None; 27];
        for b in 0..8 {
            lattice[corner_lattice(b)] = Some(samples[b]);
        }
        let half = size * 0.5;
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    let l = lattice_index(i, j, k);
                    if lattice[l].is_some() {
                        continue;
                    }
                    let p = min + DVec3::new(i as f64, j as f64, k as f64) * half;
                    // The centre is strictly inside the cell and at an odd multiple of
                    // its children's half size: no other cell's lattice holds it (its
                    // descendants get it as a corner from this lattice), so it is neither
                    // looked up nor kept.
                    let centre = l == lattice_index(1, 1, 1);
                    let mut cache_here = if centre { None } else { cache.as_deref_mut() };
                    let key = self.lattice_key(p);
                    if let Some(c) = cache_here.as_deref_mut() {
                        if let std::collections::hash_map::Entry::Occupied(mut e) = c.samples.entry(key) {
                            let (s, left) = e.get_mut();
                            lattice[l] = Some(*s);
                            *left -= 1;
                            if *left == 0 {
                                e.remove();
                            }
                            continue;
                        }
                    }
                    // The nearest corner that knows its region (the shortest carry).
                    let near = (0..8)
                        .filter(|&b| samples[b].region.is_some())
                        .map(|b| (corner_position(min, size, b), &samples[b]))
                        .min_by(|a, b| (p - a.0).length_squared().total_cmp(&(p - b.0).length_squared()));
                    let s = match candidates {
                        Some(c) => self.eval_among(p, near, c)?,
                        None => self.eval(p, near)?,
                    };
                    if let Some(c) = cache_here {
                        // Other cells of this depth sharing the point: 1 across a face
                        // centre (one coordinate on the cell's boundary), 3 around an
                        // edge midpoint (two).
                        let on_boundary = [i, j, k].iter().filter(|&&x| x != 1).count();
                        c.samples.insert(key, (s, if on_boundary == 1 { 1 } else { 3 }));
                    }
                    lattice[l] = Some(s);
                }
            }
        }
        Ok(lattice.map(|s| s.expect("every lattice point is sampled")))
    }

    /// Whether the source proves cheaply that all 19 test points of a cell no surface
    /// meets have the corners' sign (`outside`: all positive): the same answer as sampling
    /// them ([`DistanceSource::inside_in_empty_cell`]); `false` when it cannot tell.
    fn signs_confirmed(
        &self,
        min: DVec3,
        size: f64,
        samples: &[Sample; 8],
        outside: bool,
        parent_candidates: Option<&CellCandidates>,
    ) -> bool {
        let cell = Aabb::new(min, min + DVec3::splat(size));
        if let Some(inside) = self
            .source
            .side_of_empty_cell_in(&cell, (min, &samples[0]), parent_candidates)
        {
            return inside != outside;
        }
        let half = size * 0.5;
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    if i % 2 == 0 && j % 2 == 0 && k % 2 == 0 {
                        continue; // a corner
                    }
                    let b = (i / 2) | ((j / 2) << 1) | ((k / 2) << 2);
                    let p = min + DVec3::new(i as f64, j as f64, k as f64) * half;
                    match self
                        .source
                        .inside_in_empty_cell(p, (corner_position(min, size, b), &samples[b]))
                    {
                        Some(inside) if inside != outside => {}
                        _ => return false,
                    }
                }
            }
        }
        true
    }

    /// Integer lattice coordinates of a lattice point (exact: points and origin are on
    /// the lattice of the finest cells).
    #[inline]
    fn lattice_key(&self, p: DVec3) -> [u32; 3] {
        let k = ((p - self.lattice_origin) / self.lattice_unit).round();
        [k.x as u32, k.y as u32, k.z as u32]
    }

    /// The cell's candidate list, narrowed from its parent's: the cell's distance is at
    /// most its nearest corner's plus its diagonal.
    fn candidates(&self, min: DVec3, size: f64, samples: &[Sample; 8], parent: Option<&CellCandidates>) -> Candidates {
        let nearest = samples.iter().map(|s| s.value.abs()).fold(f64::INFINITY, f64::min);
        let reach = nearest + size * 3f64.sqrt();
        self.source
            .candidates(&Aabb::new(min, min + DVec3::splat(size)), reach, parent)
    }

    /// Decides one cell: a leaf (with its sign-field corners if it is a jump leaf), or
    /// the 3×3×3 lattice of samples its children take their corners from.
    #[allow(clippy::too_many_arguments)]
    fn decide(
        &self,
        min: DVec3,
        size: f64,
        depth: u8,
        samples: &[Sample; 8],
        stats: &mut LocalStats,
        parent_candidates: Option<&CellCandidates>,
        mut cache: Option<&mut SampleCache>,
    ) -> Result<Decision, AdfError> {
        let corners = samples.map(|s| s.value as f32);
        stats.depth = stats.depth.max(depth);
        let diagonal = size * 3f64.sqrt();
        let far = corners.iter().all(|&c| (c as f64).abs() > diagonal);
        let positive = corners.iter().filter(|&&c| c > 0.0).count();
        let one_sign = positive == 0 || positive == 8;
        // No surface passes through (1-Lipschitz); for a source whose sign can jump away
        // from any surface the test points must confirm the corners' sign too.
        let prunable = far && one_sign && corners.iter().all(|&c| (c as f64).abs() > diagonal + self.band);
        if prunable && (!self.may_jump || depth >= self.max_depth) {
            stats.leaf(depth >= self.max_depth, true, false);
            return Ok(Decision::Leaf(corners, None));
        }
        // Far from any surface yet of both signs: the distance jumps inside this cell.
        let jump = if far && !one_sign {
            let mut w = [0f32; 8];
            let mut known = true;
            for (b, w) in w.iter_mut().enumerate() {
                let p = corner_position(min, size, b);
                let value = match cache.as_deref_mut() {
                    Some(c) => *c
                        .sign_fields
                        .entry(self.lattice_key(p))
                        .or_insert_with(|| self.source.sign_field_at(p, &samples[b])),
                    None => self.source.sign_field_at(p, &samples[b]),
                };
                match value {
                    Some(v) if v.is_finite() => *w = v as f32,
                    _ => known = false,
                }
            }
            known.then_some(w)
        } else {
            None
        };
        if depth >= self.max_depth {
            stats.leaf(true, false, jump.is_some());
            return Ok(Decision::Leaf(corners, jump));
        }
        if prunable && self.signs_confirmed(min, size, samples, positive == 8, parent_candidates) {
            stats.leaf(false, true, false);
            return Ok(Decision::Leaf(corners, None));
        }
        let candidates = self.candidates(min, size, samples, parent_candidates);
        let lattice = self.lattice(min, size, samples, candidates.as_ref(), cache)?;
        if prunable && lattice.iter().all(|s| (s.value > 0.0) == (positive == 8)) {
            stats.leaf(false, true, false);
            return Ok(Decision::Leaf(corners, None));
        }
        let magnitudes = corners.map(f32::abs);
        let mut split = false;
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    let t = DVec3::new(i as f64, j as f64, k as f64) * 0.5;
                    let reconstructed = match &jump {
                        None => trilinear(&corners, t),
                        Some(w) => {
                            let u = trilinear(&magnitudes, t);
                            if trilinear(w, t) > 0.0 {
                                u
                            } else {
                                -u
                            }
                        }
                    };
                    if (reconstructed - lattice[lattice_index(i, j, k)].value).abs() > self.tolerance * TEST_MARGIN {
                        split = true;
                    }
                }
            }
        }
        if !split {
            stats.leaf(false, false, jump.is_some());
            return Ok(Decision::Leaf(corners, jump));
        }
        self.count(8)?;
        Ok(Decision::Split(Box::new(lattice), candidates))
    }

    /// Builds the subtree of one cell into `out[index]` and onwards (sequential).
    #[allow(clippy::too_many_arguments)]
    fn build_into(
        &self,
        out: &mut Vec<Cell>,
        jumps: &mut Vec<[f32; 8]>,
        index: usize,
        min: DVec3,
        size: f64,
        depth: u8,
        samples: [Sample; 8],
        stats: &mut LocalStats,
        parent_candidates: Option<&CellCandidates>,
        cache: &mut SampleCache,
    ) -> Result<(), AdfError> {
        match self.decide(min, size, depth, &samples, stats, parent_candidates, Some(&mut *cache))? {
            Decision::Leaf(corners, jump) => {
                out[index] = leaf_cell(corners, jump, jumps);
            }
            Decision::Split(lattice, candidates) => {
                let first = out.len();
                out[index] = Cell {
                    corners: samples.map(|s| s.value as f32),
                    children: first as u32,
                };
                out.resize(
                    first + 8,
                    Cell {
                        corners: [0.0; 8],
                        children: LEAF,
                    },
                );
                let half = size * 0.5;
                for o in 0..8 {
                    let (child_min, child_samples) = child_of(min, half, o, &lattice);
                    self.build_into(
                        out,
                        jumps,
                        first + o,
                        child_min,
                        half,
                        depth + 1,
                        child_samples,
                        stats,
                        candidates.as_ref(),
                        cache,
                    )?;
                }
            }
        }
        Ok(())
    }

    /// Builds the subtree of one cell, in parallel down to [`PARALLEL_DEPTH`].
    pub fn build(
        &self,
        min: DVec3,
        size: f64,
        depth: u8,
        samples: [Sample; 8],
        parent_candidates: Option<&CellCandidates>,
    ) -> Result<(Subtree, LocalStats), AdfError> {
        let mut stats = LocalStats::default();
        let mut jumps = Vec::new();
        if depth >= PARALLEL_DEPTH {
            let mut out = vec![Cell {
                corners: [0.0; 8],
                children: LEAF,
            }];
            let mut cache = SampleCache::default();
            self.build_into(
                &mut out,
                &mut jumps,
                0,
                min,
                size,
                depth,
                samples,
                &mut stats,
                parent_candidates,
                &mut cache,
            )?;
            return Ok((Subtree { cells: out, jumps }, stats));
        }
        match self.decide(min, size, depth, &samples, &mut stats, parent_candidates, None)? {
            Decision::Leaf(corners, jump) => {
                let cell = leaf_cell(corners, jump, &mut jumps);
                Ok((
                    Subtree {
                        cells: vec![cell],
                        jumps,
                    },
                    stats,
                ))
            }
            Decision::Split(lattice, candidates) => {
                let half = size * 0.5;
                let children: Vec<(Subtree, LocalStats)> = (0..8usize)
                    .into_par_iter()
                    .map(|o| {
                        let (child_min, child_samples) = child_of(min, half, o, &lattice);
                        self.build(child_min, half, depth + 1, child_samples, candidates.as_ref())
                    })
                    .collect::<Result<_, _>>()?;
                let (subtrees, child_stats): (Vec<Subtree>, Vec<LocalStats>) = children.into_iter().unzip();
                for s in child_stats {
                    stats.merge(&s);
                }
                let parent = Cell {
                    corners: samples.map(|s| s.value as f32),
                    children: LEAF,
                };
                Ok((join(parent, subtrees), stats))
            }
        }
    }
}

pub(crate) enum Decision {
    Leaf([f32; 8], Option<[f32; 8]>),
    /// The lattice the children take their corners from, and the cell's candidates.
    Split(Box<[Sample; 27]>, Candidates),
}

fn leaf_cell(corners: [f32; 8], jump: Option<[f32; 8]>, jumps: &mut Vec<[f32; 8]>) -> Cell {
    match jump {
        None => Cell {
            corners,
            children: LEAF,
        },
        Some(w) => {
            jumps.push(w);
            Cell {
                corners,
                children: JUMP_FLAG | (jumps.len() - 1) as u32,
            }
        }
    }
}

/// The corner values and minimum of child octant `o` (bits x, y, z) from the parent's
/// 3×3×3 lattice.
#[inline]
pub(crate) fn child_of<T: Copy>(min: DVec3, half: f64, o: usize, lattice: &[T; 27]) -> (DVec3, [T; 8]) {
    let (ox, oy, oz) = (o & 1, (o >> 1) & 1, (o >> 2) & 1);
    let child_min = min + DVec3::new(ox as f64, oy as f64, oz as f64) * half;
    let values =
        std::array::from_fn(|b| lattice[lattice_index(ox + (b & 1), oy + ((b >> 1) & 1), oz + ((b >> 2) & 1))]);
    (child_min, values)
}

/// Joins a parent and its 8 child subtrees into one vector: parent, the 8 child roots
/// (contiguous), then each child's remaining cells in octant order.
pub(crate) fn join(mut parent: Cell, subtrees: Vec<Subtree>) -> Subtree {
    let total = 1 + subtrees.iter().map(|s| s.cells.len()).sum::<usize>();
    let mut out = Vec::with_capacity(total);
    let mut jumps = Vec::with_capacity(subtrees.iter().map(|s| s.jumps.len()).sum());
    parent.children = 1;
    out.push(parent);
    let mut bases = [0usize; 8];
    let mut jump_bases = [0usize; 8];
    let mut next = 9;
    for (k, s) in subtrees.iter().enumerate() {
        bases[k] = next;
        next += s.cells.len() - 1;
        jump_bases[k] = jumps.len();
        jumps.extend_from_slice(&s.jumps);
    }
    let relocate = |k: usize, c: u32| {
        if c == LEAF {
            LEAF
        } else if c >= JUMP_FLAG {
            JUMP_FLAG | (jump_bases[k] + (c & !JUMP_FLAG) as usize) as u32
        } else {
            (bases[k] + c as usize - 1) as u32
        }
    };
    for (k, s) in subtrees.iter().enumerate() {
        let mut root = s.cells[0];
        root.children = relocate(k, root.children);
        out.push(root);
    }
    for (k, s) in subtrees.iter().enumerate() {
        out.extend(s.cells[1..].iter().map(|c| Cell {
            corners: c.corners,
            children: relocate(k, c.children),
        }));
    }
    Subtree { cells: out, jumps }
}

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct LocalStats {
    pub leaves: usize,
    pub pruned: usize,
    pub max_depth: usize,
    pub jumps: usize,
    pub depth: u8,
}

impl LocalStats {
    pub(crate) fn leaf(&mut self, at_max_depth: bool, pruned: bool, jump: bool) {
        self.leaves += 1;
        self.max_depth += at_max_depth as usize;
        self.pruned += pruned as usize;
        self.jumps += jump as usize;
    }
    pub fn merge(&mut self, o: &LocalStats) {
        self.leaves += o.leaves;
        self.pruned += o.pruned;
        self.jumps += o.jumps;
        self.max_depth += o.max_depth;
        self.depth = self.depth.max(o.depth);
    }
}

/// The root cube around a source's bounds: the bounds' centre, side = largest extent + 2
/// margins (at least the margin, so a point or a flat source gets a cube).
pub(crate) fn root_cube(bounds: &Aabb, margin: Option<f64>) -> Result<(DVec3, f64), AdfError> {
    if bounds.is_empty() || !(bounds.min.is_finite() && bounds.max.is_finite()) {
        return Err(AdfError::EmptySource(format!(
            "bounds {:?}..{:?} are empty or infinite",
            bounds.min, bounds.max
        )));
    }
    let diagonal = bounds.size().length();
    let margin = margin.unwrap_or(0.05 * diagonal);
    let side = (bounds.size().max_element() + 2.0 * margin) * (1.0 + 1e-9);
    if side.is_nan() || side <= 0.0 {
        return Err(AdfError::EmptySource(
            "the source is a single point and no margin was given".into(),
        ));
    }
    // A power-of-two side, and a minimum on the lattice of the finest supported cells
    // (side / 2^24): every cell corner `min + size·k` is then exact in f64, also far from
    // the origin.
    let side = side.log2().ceil().exp2();
    let finest = side / (1u64 << MAX_SUPPORTED_DEPTH) as f64;
    let min = ((bounds.center() - DVec3::splat(side * 0.5)) / finest).floor() * finest;
    Ok((min, side))
}

impl Adf {
    /// Builds an ADF of `source` (Frisken et al. 2000): top-down from the root cube, a cell
    /// is split while its trilinear reconstruction misses the source by more than
    /// `options.tolerance` at any of its 19 test points, down to `options.max_depth`;
    /// cells whose corners are all of one sign and farther than the cell's diagonal are
    /// leaves without tests (no surface can pass through them). The top levels are built
    /// in parallel (rayon); the tree is identical for any thread count.
    pub fn build<S: DistanceSource + ?Sized>(source: &S, options: AdfOptions) -> Result<Adf, AdfError> {
        options.check()?;
        let (root_min, root_size) = root_cube(&source.bounds(), options.margin)?;
        Adf::build_in(source, options, root_min, root_size)
    }

    /// [`Adf::build`] on a given root cube.
    pub(crate) fn build_in<S: DistanceSource + ?Sized>(
        source: &S,
        options: AdfOptions,
        root_min: DVec3,
        root_size: f64,
    ) -> Result<Adf, AdfError> {
        options.check()?;
        let builder = Builder {
            source,
            tolerance: options.tolerance,
            max_depth: options.max_depth,
            max_cells: options.max_cells,
            band: options.band,
            may_jump: source.may_jump(),
            cells: AtomicUsize::new(1),
            evaluations: AtomicU64::new(0),
            lattice_origin: root_min,
            lattice_unit: root_size / (1u64 << (options.max_depth + 1)) as f64,
        };
        let mut samples = Vec::with_capacity(8);
        for b in 0..8 {
            let p = corner_position(root_min, root_size, b);
            let near = samples
                .last()
                .map(|s: &Sample| (corner_position(root_min, root_size, b - 1), s));
            let s = builder.eval(p, near)?;
            samples.push(s);
        }
        let samples: [Sample; 8] = samples.try_into().expect("8 corners");
        let (tree, local) = builder.build(root_min, root_size, 0, samples, None)?;
        let stats = BuildStats {
            cells: tree.cells.len(),
            leaves: local.leaves,
            pruned_leaves: local.pruned,
            max_depth_leaves: local.max_depth,
            jump_leaves: local.jumps,
            depth_reached: local.depth,
            evaluations: builder.evaluations.load(Ordering::Relaxed),
        };
        Ok(Adf {
            root_min,
            root_size,
            cells: tree.cells,
            jumps: tree.jumps,
            options,
            stats,
            walk: Default::default(),
        })
    }

    /// The root cube (world space).
    pub fn root_box(&self) -> Aabb {
        Aabb::new(self.root_min, self.root_min + DVec3::splat(self.root_size))
    }

    /// The options it was built with.
    pub fn options(&self) -> &AdfOptions {
        &self.options
    }

    /// What the build (or the last edit) did.
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }

    /// Cells in the tree.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// Bytes of the cell storage (8 `f32` corners and a child index per cell, and 8 `f32`
    /// sign-field corners per jump leaf).
    pub fn memory_bytes(&self) -> usize {
        self.cells.len() * std::mem::size_of::<Cell>() + self.jumps.len() * std::mem::size_of::<[f32; 8]>()
    }

    /// Size of a cell at `depth`.
    #[inline]
    pub fn cell_size(&self, depth: u8) -> f64 {
        // `root_size · 2^−depth`: the same real number as `root_size / 2^depth`, so the same
        // rounding and bits, by a multiplication (the walk asks it once per leaf).
        self.root_size * f64::from_bits((1023 - depth as u64) << 52)
    }

    /// Leaves as `(world min, size, depth)`, in tree order.
    pub fn leaves(&self) -> Vec<(DVec3, f64, u8)> {
        let mut out = Vec::new();
        let mut stack = vec![(0u32, self.root_min, self.root_size, 0u8)];
        while let Some((i, min, size, depth)) = stack.pop() {
            let c = &self.cells[i as usize];
            if c.is_leaf() {
                out.push((min, size, depth));
            } else {
                let half = size * 0.5;
                for o in (0..8).rev() {
                    stack.push((c.children + o as u32, min + octant(o) * half, half, depth + 1));
                }
            }
        }
        out
    }

    /// The leaf containing `world_pos` (clamped into the root cube): its index, world
    /// minimum, size and depth.
    #[inline]
    pub(crate) fn locate(&self, world_pos: DVec3) -> (usize, DVec3, f64, u8) {
        let mut index = 0usize;
        let mut min = self.root_min;
        let mut size = self.root_size;
        let mut depth = 0u8;
        loop {
            let c = &self.cells[index];
            if c.is_leaf() {
                return (index, min, size, depth);
            }
            size *= 0.5;
            index = c.children as usize + crate::tree::child_octant(world_pos, &mut min, size);
            depth += 1;
        }
    }

    /// The leaf containing `world_pos` (clamped into the root cube).
    pub fn leaf_at(&self, world_pos: DVec3) -> LeafInfo {
        let (i, min, size, depth) = self.locate(self.clamp(world_pos));
        let c = &self.cells[i];
        let diagonal = size * 3f64.sqrt();
        let far = c
            .corners
            .iter()
            .all(|&v| (v as f64).abs() > diagonal + self.options.band);
        let positive = c.corners.iter().filter(|&&v| v > 0.0).count();
        LeafInfo {
            world_min: min,
            size,
            depth,
            jump: c.jump().is_some(),
            pruned: far && (positive == 0 || positive == 8) && depth < self.options.max_depth,
        }
    }

    fn clamp(&self, p: DVec3) -> DVec3 {
        p.clamp(self.root_min, self.root_min + DVec3::splat(self.root_size))
    }

    /// Reconstructed signed distance at `world_pos` (world units, negative inside). Outside
    /// the root cube: the value at the nearest point of the cube plus the distance to it
    /// (an upper bound of the true distance there, by the 1-Lipschitz property).
    pub fn distance(&self, world_pos: DVec3) -> f64 {
        let q = self.clamp(world_pos);
        let (i, min, size, _) = self.locate(q);
        let t = ((q - min) / size).clamp(DVec3::ZERO, DVec3::ONE);
        self.leaf_value(i, t) + (world_pos - q).length()
    }

    /// The reconstruction in leaf `i` at unit-cube coordinates `t`: trilinear, or, in a
    /// jump leaf, the trilinear magnitude with the sign of the trilinear sign field.
    #[inline]
    pub(crate) fn leaf_value(&self, i: usize, t: DVec3) -> f64 {
        let c = &self.cells[i];
        match c.jump() {
            None => trilinear(&c.corners, t),
            Some(k) => {
                let u = trilinear(&c.corners.map(f32::abs), t);
                if trilinear(&self.jumps[k], t) > 0.0 {
                    u
                } else {
                    -u
                }
            }
        }
    }

    /// Gradient (unit-cube coordinates) of [`Adf::leaf_value`].
    #[inline]
    fn leaf_gradient(&self, i: usize, t: DVec3) -> DVec3 {
        let c = &self.cells[i];
        match c.jump() {
            None => trilinear_gradient(&c.corners, t),
            Some(k) => {
                let g = trilinear_gradient(&c.corners.map(f32::abs), t);
                if trilinear(&self.jumps[k], t) > 0.0 {
                    g
                } else {
                    -g
                }
            }
        }
    }

    /// Gradient of the reconstruction (world units), the analytic derivative of the
    /// trilinear cell; outside the root cube, the gradient at the nearest cube point plus
    /// the direction away from the cube.
    pub fn gradient(&self, world_pos: DVec3) -> DVec3 {
        let q = self.clamp(world_pos);
        // The same leaf either way; the walk index (once a ray has built it) finds it faster.
        let (i, min, size) = match self.walk.0.get() {
            Some(ix) => self.locate_indexed(ix, q),
            None => {
                let (i, min, size, _) = self.locate(q);
                (i, min, size)
            }
        };
        let t = ((q - min) / size).clamp(DVec3::ZERO, DVec3::ONE);
        let g = self.leaf_gradient(i, t) / size;
        let away = world_pos - q;
        if away == DVec3::ZERO {
            g
        } else {
            g + away.normalize()
        }
    }

    /// The nearest surface point as the reconstruction sees it: `p − d·∇d/|∇d|` (exact for
    /// an exact distance field; `p` itself where the gradient vanishes).
    pub fn closest_point(&self, world_pos: DVec3) -> DVec3 {
        let d = self.distance(world_pos);
        let g = self.gradient(world_pos);
        let n = g.length();
        if n > 0.0 && n.is_finite() {
            world_pos - g * (d / n)
        } else {
            world_pos
        }
    }

    /// Whether `world_pos` is inside (reconstructed distance ≤ 0).
    pub fn inside(&self, world_pos: DVec3) -> bool {
        self.distance(world_pos) <= 0.0
    }

    /// `(min, max)` of the reconstruction over a world box (conservative: the true range
    /// lies inside). Leaves bound their reconstruction by their corner values; a box
    /// reaching outside the root cube gets `+∞` as its maximum.
    pub fn range(&self, world_box: &Aabb) -> (f64, f64) {
        let root = self.root_box();
        let clipped = world_box.intersection(&root);
        if clipped.is_empty() {
            // Entirely outside: at least the distance from the box to the cube's values.
            let gap = (world_box.min - root.max)
                .max(root.min - world_box.max)
                .max(DVec3::ZERO)
                .length();
            let (lo, _) = self.range(&Aabb::new(self.clamp(world_box.min), self.clamp(world_box.max)));
            return (lo + gap, f64::INFINITY);
        }
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        let mut stack = vec![(0u32, self.root_min, self.root_size)];
        while let Some((i, min, size)) = stack.pop() {
            let cell_box = Aabb::new(min, min + DVec3::splat(size));
            if !overlaps(&cell_box, &clipped) {
                continue;
            }
            let c = &self.cells[i as usize];
            if c.is_leaf() {
                let (a, b) = c.corner_range();
                let (a, b) = if c.jump().is_some() {
                    (-a.abs().max(b.abs()), a.abs().max(b.abs()))
                } else {
                    (a, b)
                };
                lo = lo.min(a);
                hi = hi.max(b);
            } else {
                let half = size * 0.5;
                for o in 0..8 {
                    stack.push((c.children + o as u32, min + octant(o) * half, half));
                }
            }
        }
        let outside = world_box.min.cmplt(root.min).any() || world_box.max.cmpgt(root.max).any();
        (lo, if outside { f64::INFINITY } else { hi })
    }
}

#[inline]
pub(crate) fn octant(o: usize) -> DVec3 {
    DVec3::new((o & 1) as f64, ((o >> 1) & 1) as f64, ((o >> 2) & 1) as f64)
}

#[inline]
pub(crate) fn corner_position(min: DVec3, size: f64, b: usize) -> DVec3 {
    min + octant(b) * size
}

/// Closed-box overlap (touching boxes overlap, so a query on a cell face sees both cells).
#[inline]
pub(crate) fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    a.min.cmple(b.max).all() && b.min.cmple(a.max).all()
}

/// The octant (bit 0: x, bit 1: y, bit 2: z) of the child of the cell at `min` with
/// children of edge `child_size` that holds `world_pos`, moving `min` to that child's
/// minimum corner. Points on a mid-plane go to the upper child.
#[inline]
pub(crate) fn child_octant(world_pos: DVec3, min: &mut DVec3, child_size: f64) -> usize {
    let mid = *min + DVec3::splat(child_size);
    let mut o = 0;
    if world_pos.x >= mid.x {
        o |= 1;
        min.x = mid.x;
    }
    if world_pos.y >= mid.y {
        o |= 2;
        min.y = mid.y;
    }
    if world_pos.z >= mid.z {
        o |= 4;
        min.z = mid.z;
    }
    o
}
