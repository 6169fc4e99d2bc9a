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
use volga_core::CrossingRay;

use crate::cubic::{first_root_of_cubic, newton_on_piece, trilinear_cubic};
use crate::ray::{cubic_coefficients, first_root_sampled, monotone_cuts, next_t, sphere_step};
use crate::reach::chessboard_reach;
use crate::tree::{trilinear, Cell, LEAF};
use crate::Adf;

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

/// Just past a box's exit parameter, so the next point lies in the next box despite
/// rounding instead of costing a step with a nudge: by 1e-9 of the box (`cell_t` in ray
/// units), and at least by `ulp_t`, a few units in the last place of the world
/// coordinates in ray units (far from the origin, 1e-9 of a small cell is below the
/// rounding of a position, and the point would land in the same box again). A crossing in
/// that sliver is found at its end (the next box's start is already inside).
#[inline]
fn past(exit: f64, cell_t: f64, ulp_t: f64) -> f64 {
    exit + (cell_t * 1e-9).max(ulp_t)
}

/// Where a ray leaves the box `min + [0, size]³`, with `inv` the reciprocal direction
/// (only the signs of `dir` choose the faces).
#[inline]
fn box_exit(origin: DVec3, dir: DVec3, inv: DVec3, min: DVec3, size: f64) -> f64 {
    let mut exit = f64::INFINITY;
    for a in 0..3 {
        let d = dir[a];
        if d > 0.0 {
            exit = exit.min((min[a] + size - origin[a]) * inv[a]);
        } else if d < 0.0 {
            exit = exit.min((min[a] - origin[a]) * inv[a]);
        }
    }
    exit
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

    /// The first `t ∈ [t_start, t_end]` where the reconstruction along `origin + t·dir`
    /// falls to `iso` or below, and the number of steps taken (leaves visited, and grid
    /// cells crossed without visiting their leaves).
    ///
    /// The walk of [`Adf::first_crossing_by_descent`] (sphere-tracing steps in leaves
    /// above `iso`, the cubic restriction's first downward root in a leaf with a corner
    /// at or below it) on the walk index (see the module `walk`): leaves are found from a
    /// 128³ grid of nodes, and the empty cubes of grid cells around a ray's cell (its
    /// reach, for `iso ≤ 0`) or grid cells and blocks whose conservative minimum is above
    /// `iso` are crossed in one step. A value at `t_start` already at or below `iso` gives
    /// `t_start`.
    pub fn first_crossing_between(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_start: f64,
        t_end: f64,
        iso: f64,
    ) -> (Option<f64>, u32) {
        let ix = self.walk_index();
        let consts = WalkConsts::new(self, ix);
        let mut walk = match RayWalk::start(self, ix, &consts, origin, dir, t_start, t_end, iso) {
            Ok(walk) => walk,
            Err(done) => return done,
        };
        loop {
            if let Some(done) = walk.advance(self, ix, &consts, iso) {
                return done;
            }
        }
    }

    /// [`Adf::first_crossing_between`] for many rays at once, with the same answers bit
    /// for bit: `out[i]` is `first_crossing_between(rays[i].world_origin,
    /// rays[i].world_dir, rays[i].t0, rays[i].t1, iso)`.
    ///
    /// A ray's walk is a chain of dependent memory reads (the grid cell, the links of a
    /// descent, the leaf's corners), most of them cache misses in a large tree. Here
    /// [`WALK_WINDOW`] rays are walked in turn, each advanced up to its next read, which
    /// is prefetched, before the next ray's turn: the misses of different rays overlap
    /// instead of following one another.
    pub fn first_crossings_between(&self, rays: &[CrossingRay], iso: f64, out: &mut [(Option<f64>, u32)]) {
        assert_eq!(rays.len(), out.len(), "one answer per ray");
        let ix = self.walk_index();
        let consts = WalkConsts::new(self, ix);
        let mut slots: [Option<(usize, RayWalk)>; WALK_WINDOW] = [None; WALK_WINDOW];
        let mut next = 0usize;
        let mut active = 0usize;
        loop {
            for slot in slots.iter_mut() {
                if let Some((i, walk)) = slot {
                    match walk.advance(self, ix, &consts, iso) {
                        None => continue,
                        Some(done) => {
                            out[*i] = done;
                            *slot = None;
                            active -= 1;
                        }
                    }
                }
                // An empty slot takes the next ray that needs walking (rays answered at
                // their start are written at once).
                while next < rays.len() {
                    let i = next;
                    next += 1;
                    let r = &rays[i];
                    match RayWalk::start(self, ix, &consts, r.world_origin, r.world_dir, r.t0, r.t1, iso) {
                        Ok(walk) => {
                            *slot = Some((i, walk));
                            active += 1;
                            break;
                        }
                        Err(done) => out[i] = done,
                    }
                }
            }
            if active == 0 && next == rays.len() {
                return;
            }
        }
    }
}

/// Rays walked together by [`Adf::first_crossings_between`]: 12 was the fastest window
/// measured on the bunny (6: 0.080, 8: 0.076, 10 and 12: 0.072 CPU s per 512² pass;
/// docs/ADF.md, "Rendering: the leaf walk").
pub const WALK_WINDOW: usize = 12;

/// What every ray's walk of one ADF shares.
struct WalkConsts {
    root_max: DVec3,
    n: usize,
    grid_size: f64,
    to_grid: f64,
}

impl WalkConsts {
    fn new(adf: &Adf, ix: &WalkIndex) -> WalkConsts {
        WalkConsts {
            root_max: adf.root_min + DVec3::splat(adf.root_size),
            n: ix.n,
            grid_size: adf.cell_size(ix.depth),
            to_grid: ix.n as f64 / adf.root_size,
        }
    }
}

/// Where a ray's walk stands: the read it waits for (prefetched when it was set).
#[derive(Clone, Copy, Debug)]
enum Stage {
    /// The walk grid's entries of cell `k` (the ray is at `t`, `p`, `q`).
    Grid { k: usize, g: [usize; 3] },
    /// The link of node `index` (a cube at `min` of side `size` containing `q`).
    Descend { index: usize, min: DVec3, size: f64 },
    /// The corners of leaf `index`.
    Leaf { index: usize, min: DVec3, size: f64 },
}

/// One ray's walk of [`Adf::first_crossing_between`], advanced a read at a time
/// ([`RayWalk::advance`]). The steps and their arithmetic are those of a walk run in one
/// piece; only the moments between them differ.
#[derive(Clone, Copy, Debug)]
struct RayWalk {
    origin: DVec3,
    dir: DVec3,
    inv: DVec3,
    scale: f64,
    ulp_t: f64,
    t: f64,
    t_end: f64,
    steps: u32,
    /// The point at `t` and its clamp to the root cube.
    p: DVec3,
    q: DVec3,
    stage: Stage,
}

/// Asks for the cache line holding `x` (a hint: no effect on any result).
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults and reads nothing architecturally; `x` is a live
    // reference. Measured reason: docs/ADF.md ("Rendering: the leaf walk", the batched walk).
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(x as *const T as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

impl RayWalk {
    /// The walk of one ray from `t_start`, or its answer if it has none to walk (an
    /// iso value ≤ 0 and a ray missing the active box).
    #[allow(clippy::result_large_err, clippy::too_many_arguments)]
    fn start(
        adf: &Adf,
        ix: &WalkIndex,
        consts: &WalkConsts,
        origin: DVec3,
        dir: DVec3,
        t_start: f64,
        t_end: f64,
        iso: f64,
    ) -> Result<RayWalk, (Option<f64>, u32)> {
        let mut t = t_start;
        let mut t_end = t_end;
        if iso <= 0.0 {
            // Outside the active box the reconstruction is above `iso`.
            let Some((lo, hi)) = ix.active else {
                return Err((None, 0));
            };
            for a in 0..3 {
                let (o, d) = (origin[a], dir[a]);
                if d == 0.0 {
                    if o < lo[a] || o > hi[a] {
                        return Err((None, 0));
                    }
                    continue;
                }
                let (mut ta, mut tb) = ((lo[a] - o) / d, (hi[a] - o) / d);
                if ta > tb {
                    std::mem::swap(&mut ta, &mut tb);
                }
                t = t.max(ta);
                t_end = t_end.min(tb);
            }
            if t > t_end {
                return Err((None, 0));
            }
        }
        let scale = dir.length();
        let magnitude = origin
            .abs()
            .max_element()
            .max(adf.root_min.abs().max_element() + adf.root_size);
        let mut walk = RayWalk {
            origin,
            dir,
            inv: DVec3::ONE / dir,
            scale,
            ulp_t: 4.0 * f64::EPSILON * magnitude / scale,
            t,
            t_end,
            steps: 0,
            p: DVec3::ZERO,
            q: DVec3::ZERO,
            stage: Stage::Grid { k: 0, g: [0; 3] },
        };
        if !walk.enter_step(adf, ix, consts, iso) {
            return Err((None, walk.steps));
        }
        Ok(walk)
    }

    /// Takes the step at `t` (if `t ≤ t_end`): its point, its walk grid cell, and the
    /// prefetch of that cell's entries. `false` when the ray has left its interval.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    #[inline(always)]
    fn enter_step(&mut self, adf: &Adf, ix: &WalkIndex, c: &WalkConsts, iso: f64) -> bool {
        // Negated so a NaN `t` ends the walk (as `while t <= t_end` would).
        if !(self.t <= self.t_end) {
            return false;
        }
        self.steps += 1;
        self.p = self.origin + self.dir * self.t;
        self.q = self.p.clamp(adf.root_min, c.root_max);
        let g = (self.q - adf.root_min) * c.to_grid;
        let n = c.n;
        let cell = |v: f64| (v.max(0.0) as usize).min(n - 1);
        let (gx, gy, gz) = (cell(g.x), cell(g.y), cell(g.z));
        let k = gx + n * (gy + n * gz);
        if iso <= 0.0 {
            prefetch(&ix.reach[k]);
        } else {
            prefetch(&ix.lo[k]);
        }
        prefetch(&ix.level[k]);
        prefetch(&ix.node[k]);
        self.stage = Stage::Grid { k, g: [gx, gy, gz] };
        true
    }

    /// Moves the walk on past its pending read, up to and including the prefetch of the
    /// next one; `Some` with the answer (the crossing, if any, and the steps taken) once
    /// the walk ends.
    #[inline(always)]
    fn advance(&mut self, adf: &Adf, ix: &WalkIndex, c: &WalkConsts, iso: f64) -> Option<(Option<f64>, u32)> {
        match self.stage {
            Stage::Grid { k, g: [gx, gy, gz] } => {
                let n = c.n;
                let (t, t_end, scale, ulp_t) = (self.t, self.t_end, self.scale, self.ulp_t);
                let (origin, dir, inv) = (self.origin, self.dir, self.inv);
                let grid_size = c.grid_size;
                // Empty grid cells (minimum above `iso`) are crossed without locating their
                // leaves, except a lone cell inside one larger leaf, whose own exit may reach
                // farther.
                let whole_cell = || ix.level[k] == ix.depth && ix.links[ix.node[k] as usize] < crate::tree::JUMP_FLAG;
                let mut skip_to = None;
                if iso <= 0.0 {
                    // The cube of `(2r − 1)³` empty cells around this one, in one step.
                    let r = ix.reach[k];
                    if r >= 2 || (r == 1 && whole_cell()) {
                        let half = (r - 1) as f64;
                        let cube = (2.0 * half + 1.0) * grid_size;
                        let cmin = adf.root_min
                            + (DVec3::new(gx as f64, gy as f64, gz as f64) - DVec3::splat(half)) * grid_size;
                        let exit = box_exit(origin, dir, inv, cmin, cube).min(t_end).max(t);
                        skip_to = Some(next_t(t, past(exit, grid_size / scale, ulp_t), grid_size / scale));
                    }
                } else {
                    // A 4³ block whose minimum is above `iso`, or this grid cell, in one step.
                    if ix.depth >= 2 && ix.level[k] >= ix.depth - 2 {
                        let m = n / 4;
                        let (bx, by, bz) = (gx / 4, gy / 4, gz / 4);
                        if (ix.block_lo[bx + m * (by + m * bz)] as f64) > iso {
                            let block = 4.0 * grid_size;
                            let bmin = adf.root_min + DVec3::new(bx as f64, by as f64, bz as f64) * block;
                            let exit = box_exit(origin, dir, inv, bmin, block).min(t_end).max(t);
                            skip_to = Some(next_t(t, past(exit, block / scale, ulp_t), block / scale));
                        }
                    }
                    if skip_to.is_none() && (ix.lo[k] as f64) > iso && whole_cell() {
                        let gmin = adf.root_min + DVec3::new(gx as f64, gy as f64, gz as f64) * grid_size;
                        let exit = box_exit(origin, dir, inv, gmin, grid_size).min(t_end).max(t);
                        skip_to = Some(next_t(t, past(exit, grid_size / scale, ulp_t), grid_size / scale));
                    }
                }
                if let Some(t) = skip_to {
                    self.t = t;
                    return (!self.enter_step(adf, ix, c, iso)).then_some((None, self.steps));
                }
                // The leaf containing `q`, from the grid (as `Adf::locate_indexed`).
                let q = self.q;
                let level = ix.level[k];
                let shift = ix.depth - level;
                let size = adf.cell_size(level);
                let min =
                    adf.root_min + DVec3::new((gx >> shift) as f64, (gy >> shift) as f64, (gz >> shift) as f64) * size;
                let max = min + DVec3::splat(size);
                let contains = q.cmpge(min).all() && (q.cmplt(max) | max.cmpge(c.root_max)).all();
                if !contains {
                    // Rounding put `q` in a neighbouring grid cell: descend from the root.
                    let (index, min, size, _) = adf.locate(q);
                    self.wait_for_leaf(adf, index, min, size);
                    return None;
                }
                let index = ix.node[k] as usize;
                prefetch(&ix.links[index]);
                self.stage = Stage::Descend { index, min, size };
                None
            }
            Stage::Descend { index, mut min, size } => {
                let link = ix.links[index];
                if link >= crate::tree::JUMP_FLAG {
                    self.wait_for_leaf(adf, index, min, size);
                    return None;
                }
                let size = size * 0.5;
                let index = link as usize + crate::tree::child_octant(self.q, &mut min, size);
                prefetch(&ix.links[index]);
                self.stage = Stage::Descend { index, min, size };
                None
            }
            Stage::Leaf { index, min, size } => {
                let found = adf.leaf_step(self, index, min, size, iso);
                if found.is_some() {
                    return Some((found, self.steps));
                }
                (!self.enter_step(adf, ix, c, iso)).then_some((None, self.steps))
            }
        }
    }

    /// Waits next for the corners of leaf `index` (a 36-byte cell: its first and last byte's lines).
    #[inline(always)]
    fn wait_for_leaf(&mut self, adf: &Adf, index: usize, min: DVec3, size: f64) {
        let cell = &adf.cells[index];
        prefetch(cell);
        prefetch(&cell.children);
        self.stage = Stage::Leaf { index, min, size };
    }
}

impl Adf {
    /// The step of a walk in leaf `index` (at `min`, side `size`): the crossing if the
    /// leaf holds the ray's first one after `t`, else `None` with the walk's `t` moved past
    /// the leaf (or farther, by the sphere-tracing bound of its corners).
    #[inline(always)]
    fn leaf_step(&self, w: &mut RayWalk, index: usize, min: DVec3, size: f64, iso: f64) -> Option<f64> {
        let (origin, dir, inv, t, scale, ulp_t) = (w.origin, w.dir, w.inv, w.t, w.scale, w.ulp_t);
        let p = w.p;
        let exit = box_exit(origin, dir, inv, min, size).min(w.t_end).max(t);
        let cell = &self.cells[index];
        let corners = cell.corners;
        let lo = corners.iter().fold(f32::INFINITY, |a, &c| a.min(c)) as f64;
        if lo > iso {
            let candidate = sphere_step(&corners, iso, p, min, size, t, exit, scale);
            w.t = next_t(t, past(candidate, size / scale, ulp_t), size / scale);
            return None;
        }
        let inv_size = 1.0 / size;
        let found = if cell.children == LEAF {
            // The cubic from the corners (module `cubic`).
            let u0 = ((origin + dir * t - min) * inv_size).clamp(DVec3::ZERO, DVec3::ONE);
            let u1 = ((origin + dir * exit - min) * inv_size).clamp(DVec3::ZERO, DVec3::ONE);
            let mut c = trilinear_cubic(&corners, u0, u1 - u0);
            c[0] -= iso;
            first_root_of_cubic(c, t, exit)
        } else {
            // A jump leaf: as in the reference walk.
            let k = cell.jump().expect("a leaf that is not plain is a jump leaf");
            let magnitudes = corners.map(f32::abs);
            let signs = &self.jumps[k];
            if iso == 0.0 {
                let sign_at = |s: f64| {
                    trilinear(
                        signs,
                        ((origin + dir * s - min) * inv_size).clamp(DVec3::ZERO, DVec3::ONE),
                    )
                };
                first_root_cubic(&sign_at, t, exit)
            } else {
                let at = |s: f64| {
                    let u = ((origin + dir * s - min) * inv_size).clamp(DVec3::ZERO, DVec3::ONE);
                    let m = trilinear(&magnitudes, u);
                    (if trilinear(signs, u) > 0.0 { m } else { -m }) - iso
                };
                first_root_sampled(&at, t, exit)
            }
        };
        if found.is_none() {
            w.t = next_t(t, past(exit, size / scale, ulp_t), size / scale);
        }
        found
    }
}

/// The first `s ∈ [a, b]` with `g(s) ≤ 0` for a cubic `g` (the trilinear reconstruction
/// along a segment inside one cell), or `None`: the cubic through 4 samples, split into
/// monotone pieces at its critical points, the first downward crossing refined on the
/// polynomial (safeguarded Newton steps, [`newton_on_piece`]). Used for jump leaves at iso 0.
pub(crate) fn first_root_cubic(g: &impl Fn(f64) -> f64, a: f64, b: f64) -> Option<f64> {
    let ga = g(a);
    if ga <= 0.0 {
        return Some(a);
    }
    if b <= a {
        return None;
    }
    let h = b - a;
    let (g0, g1, g2, g3) = (ga, g(a + h / 3.0), g(a + 2.0 * h / 3.0), g(b));
    // p(u) = c0 + c1 u + c2 u² + c3 u³ on u ∈ [0, 1].
    let [c0, c1, c2, c3] = cubic_coefficients(g0, g1, g2, g3);
    // The end value is the sample itself (not the fit), so a root at the exit face is seen.
    let poly = |u: f64| {
        if u >= 1.0 {
            g3
        } else {
            c0 + u * (c1 + u * (c2 + u * c3))
        }
    };
    let (cuts, m) = monotone_cuts(c1, c2, c3);
    let cuts = &cuts[..m];
    for w in cuts.windows(2) {
        if poly(w[1]) <= 0.0 {
            let u = newton_on_piece(&poly, |u| c1 + u * (2.0 * c2 + u * 3.0 * c3), w[0], w[1]);
            return Some((a + u * h).min(b));
        }
    }
    None
}

/// A view of an ADF for same-run comparisons (`volga bench adf`) and tests: every
/// [`Field`](volga_core::Field) method is the ADF's except `first_crossing`, answered by
/// `$walk`, and `first_crossings`, left at its default (ray by ray).
macro_rules! walk_view {
    ($(#[$doc:meta])* $name:ident, $walk:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug)]
        pub struct $name<'a>(pub &'a Adf);

        impl volga_core::Field for $name<'_> {
            fn bounds(&self) -> volga_core::Aabb {
                volga_core::Field::bounds(self.0)
            }
            fn kind(&self) -> volga_core::FieldKind {
                volga_core::Field::kind(self.0)
            }
            fn background(&self) -> f64 {
                volga_core::Field::background(self.0)
            }
            fn value(&self, world_pos: DVec3) -> f64 {
                volga_core::Field::value(self.0, world_pos)
            }
            fn values_along(&self, line: &volga_core::Line, first: u64, out: &mut [f64]) {
                volga_core::Field::values_along(self.0, line, first, out)
            }
            fn gradient(&self, world_pos: DVec3) -> DVec3 {
                volga_core::Field::gradient(self.0, world_pos)
            }
            fn gradient_step(&self) -> DVec3 {
                volga_core::Field::gradient_step(self.0)
            }
            fn first_crossing(
                &self,
                world_origin: DVec3,
                world_dir: DVec3,
                t0: f64,
                t1: f64,
                iso: f64,
            ) -> volga_core::Crossing {
                let ray = CrossingRay {
                    world_origin,
                    world_dir,
                    t0,
                    t1,
                };
                crate::field::crossing(&ray, || self.0.$walk(world_origin, world_dir, t0, t1, iso).0)
            }
            fn value_range(&self, world_box: &volga_core::Aabb) -> (f64, f64) {
                volga_core::Field::value_range(self.0, world_box)
            }
            fn sample_spacing(&self) -> f64 {
                volga_core::Field::sample_spacing(self.0)
            }
        }
    };
}

walk_view!(
    /// An ADF rendered through the reference walk ([`Adf::first_crossing_by_descent`]):
    /// iso crossings are found without the walk index, ray by ray.
    DescentWalk,
    first_crossing_by_descent
);

walk_view!(
    /// An ADF rendered through the indexed walk one ray at a time
    /// ([`Adf::first_crossing_between`]) instead of the batched walk
    /// ([`Adf::first_crossings_between`]) the ADF's own `Field` gives a tile's rays: the
    /// same image, for measuring what batching gains.
    OneRayWalk,
    first_crossing_between
);

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
