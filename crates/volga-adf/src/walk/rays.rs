//! The indexed walk of one ray ([`Adf::first_crossing_between`]) and of a batch
//! ([`Adf::first_crossings_between`]) on the walk index of the parent module: grid
//! cells, reach cubes and blocks crossed in one step, leaves found from the grid, the
//! cubic of a leaf's corners solved exactly.

use glam::DVec3;
use volga_core::CrossingRay;

use super::WalkIndex;
use crate::cubic::{first_root_of_cubic, newton_on_piece, trilinear_cubic};
use crate::ray::{cubic_coefficients, first_root_sampled, monotone_cuts, next_t, sphere_step};
use crate::tree::{trilinear, LEAF};
use crate::Adf;

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
/// docs/ADF.md, the batched walk).
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

/// Asks for the cache line holding `x` (a hint: no effect on any result). The crate's
/// only `unsafe` code (the crate denies it elsewhere).
#[inline(always)]
#[allow(unsafe_code)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults and reads nothing architecturally; `x` is a live
    // reference. Measured reason: docs/ADF.md (the batched walk).
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
