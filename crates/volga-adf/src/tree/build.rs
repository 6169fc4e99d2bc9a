//! Building an ADF top-down (Frisken et al. 2000): each cell is decided from its 8 corner
//! samples and the 19 test points of its 3×3×3 lattice, the top levels in parallel.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;
use volga_core::{Aabb, NoProgress, Progress};

use super::lattice::{child_of, lattice_index, SampleCache};
use super::{
    corner_position, trilinear, AdfOptions, BuildStats, Cell, JUMP_FLAG, LEAF, MAX_SUPPORTED_DEPTH, TEST_MARGIN,
};
use crate::source::{AdfSource, CellCandidates, Sample};
use crate::{Adf, AdfError};

/// Levels below the root built as parallel tasks (8³ = 512 tasks at most); deeper
/// subtrees are built sequentially into one vector each.
const PARALLEL_DEPTH: u8 = 3;

/// Cells between two progress reports (one lock of the progress bar each).
const PROGRESS_STEP: usize = 1 << 16;

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
    /// The source's sign may jump away from any surface ([`AdfSource::may_jump`]).
    pub may_jump: bool,
    pub cells: AtomicUsize,
    pub evaluations: AtomicU64,
    /// Told of every [`PROGRESS_STEP`] cells.
    pub progress: &'a dyn Progress,
    /// World position of lattice point `(0, 0, 0)` (the root's minimum) and the lattice
    /// step (half the finest cell): keys of the sample cache.
    pub lattice_origin: DVec3,
    pub lattice_unit: f64,
}

/// A cell's candidate list ([`AdfSource::candidates`]), `None` if the source does
/// not narrow.
type Candidates = Option<CellCandidates>;

impl<S: AdfSource + ?Sized> Builder<'_, S> {
    fn count(&self, n: usize) -> Result<(), AdfError> {
        let total = self.cells.fetch_add(n, Ordering::Relaxed) + n;
        let steps = total / PROGRESS_STEP - (total - n) / PROGRESS_STEP;
        if steps > 0 {
            self.progress.inc((steps * PROGRESS_STEP) as u64);
        }
        if total > self.max_cells {
            return Err(AdfError::TooManyCells {
                limit: self.max_cells,
                bytes: (total as u64).saturating_mul(super::BUILD_BYTES_PER_CELL),
            });
        }
        Ok(())
    }

    /// Whether the source proves cheaply that all 19 test points of a cell no surface
    /// meets have the corners' sign (`outside`: all positive): the same answer as sampling
    /// them (the parent's [`CellCandidates::sign_model`], else
    /// [`AdfSource::inside_in_empty_cell`]); `false` when it cannot tell.
    fn signs_confirmed(
        &self,
        min: DVec3,
        size: f64,
        samples: &[Sample; 8],
        outside: bool,
        parent_candidates: Option<&CellCandidates>,
        mut cache: Option<&mut SampleCache>,
    ) -> bool {
        let cell = Aabb::new(min, min + DVec3::splat(size));
        if let Some(inside) = self
            .source
            .side_of_empty_cell_in(&cell, (min, &samples[0]), parent_candidates)
        {
            return inside != outside;
        }
        let half = size * 0.5;
        // Keys as in `lattice`: a point's side is shared with the neighbours of this depth.
        let keys = self.cell_keys(min, size);
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    if i % 2 == 0 && j % 2 == 0 && k % 2 == 0 {
                        continue; // a corner
                    }
                    let key = keys(i, j, k);
                    let known = cache.as_deref_mut().and_then(|c| c.side(key));
                    let side = known.or_else(|| {
                        let b = (i / 2) | ((j / 2) << 1) | ((k / 2) << 2);
                        let p = min + DVec3::new(i as f64, j as f64, k as f64) * half;
                        // The parent's model of the sign's winding number, else the source.
                        let side = parent_candidates
                            .and_then(|c| c.sign_model.as_ref()?.side_at(p))
                            .or_else(|| {
                                self.source
                                    .inside_in_empty_cell(p, (corner_position(min, size, b), &samples[b]))
                            })?;
                        if let Some(c) = cache.as_deref_mut() {
                            c.keep_side(key, [i, j, k], side);
                        }
                        Some(side)
                    });
                    match side {
                        Some(inside) if inside != outside => {}
                        _ => return false,
                    }
                }
            }
        }
        true
    }
    /// The cell's candidate list, narrowed from its parent's: the cell's distance is at
    /// most its nearest corner's plus its diagonal.
    fn candidates(&self, min: DVec3, size: f64, samples: &[Sample; 8], parent: Option<&CellCandidates>) -> Candidates {
        let nearest = samples.iter().map(|s| s.value.abs()).fold(f64::INFINITY, f64::min);
        let reach = nearest + size * 3f64.sqrt();
        let cell = Aabb::new(min, min + DVec3::splat(size));
        let mut candidates = self.source.candidates(&cell, reach, parent)?;
        // The first corner that knows its region, if any (the source carries it).
        let b = (0..8).find(|&b| samples[b].region.is_some()).unwrap_or(0);
        candidates.sign_model =
            self.source
                .sign_model(&cell, (corner_position(min, size, b), &samples[b]), &candidates);
        Some(candidates)
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
            let keys = self.cell_keys(min, size);
            for (b, w) in w.iter_mut().enumerate() {
                let p = corner_position(min, size, b);
                let value = match cache.as_deref_mut() {
                    Some(c) => *c
                        .sign_fields
                        .entry(keys((b & 1) * 2, ((b >> 1) & 1) * 2, ((b >> 2) & 1) * 2))
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
        if prunable
            && self.signs_confirmed(
                min,
                size,
                samples,
                positive == 8,
                parent_candidates,
                cache.as_deref_mut(),
            )
        {
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
                cache.finish(depth);
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
            let mut cache = SampleCache::new(depth, self.max_depth);
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
            // The vector grew by doubling; the joins above copy it, so its slack would
            // double the build's peak (BUILD_BYTES_PER_CELL counts the tree twice).
            out.shrink_to_fit();
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
    if bounds.is_empty() || bounds.min.is_nan() || bounds.max.is_nan() {
        return Err(AdfError::EmptySource(format!(
            "bounds {:?}..{:?} are empty",
            bounds.min, bounds.max
        )));
    }
    if !(bounds.min.is_finite() && bounds.max.is_finite()) {
        return Err(AdfError::Unbounded {
            min: bounds.min.to_array(),
            max: bounds.max.to_array(),
        });
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
    // Finite bounds near f64's limit (1e308) round up to an infinite cube.
    if !(side.is_finite() && min.is_finite()) {
        return Err(AdfError::EmptySource(format!(
            "bounds {:?}..{:?} are too large: the root cube's side would be {side}",
            bounds.min, bounds.max
        )));
    }
    Ok((min, side))
}

impl Adf {
    /// Builds an ADF of `source` (Frisken et al. 2000): top-down from the root cube, a cell
    /// is split while its trilinear reconstruction misses the source by more than
    /// `options.tolerance` at any of its 19 test points, down to `options.max_depth`;
    /// cells whose corners are all of one sign and farther than the cell's diagonal are
    /// leaves without tests (no surface can pass through them). The top levels are built
    /// in parallel (rayon); the tree is identical for any thread count.
    ///
    /// # Errors
    /// Bad options and sources ([`AdfError`]); [`AdfError::TooManyCells`] as soon as the
    /// tree would pass `options.max_cells` (nothing is kept).
    pub fn build<S: AdfSource + ?Sized>(source: &S, options: AdfOptions) -> Result<Adf, AdfError> {
        Adf::build_with_progress(source, options, &NoProgress)
    }

    /// [`Adf::build`], telling `progress` of the cells built (one step, `adf cells`, whose
    /// total is [`Adf::estimate`]'s count, or `max_cells` if lower).
    pub fn build_with_progress<S: AdfSource + ?Sized>(
        source: &S,
        options: AdfOptions,
        progress: &dyn Progress,
    ) -> Result<Adf, AdfError> {
        let (root_min, root_size) = root_cube(&source.bounds(), options.margin)?;
        let estimate = Adf::estimate(source, &options)?;
        progress.start("adf cells", estimate.cells.min(options.max_cells as u64));
        let built = Adf::build_in(source, options, root_min, root_size, progress);
        progress.finish();
        built
    }

    /// [`Adf::build`] on a given root cube.
    pub(crate) fn build_in<S: AdfSource + ?Sized>(
        source: &S,
        options: AdfOptions,
        root_min: DVec3,
        root_size: f64,
        progress: &dyn Progress,
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
            progress,
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
}
