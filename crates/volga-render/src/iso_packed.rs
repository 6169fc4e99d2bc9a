//! The packed iso-surface path: the first crossing of a trilinear, central-difference
//! sampled volume's iso-surface found **exactly**, cell by cell, instead of by samples
//! along the ray.
//!
//! Taken by [`Iso`](crate::Iso) when [`iso_packed`] holds: the renderer samples a packed
//! copy of the field (`PackedVolume`, made when
//! [`packet_path_allowed`](crate::packet) holds — no shadows, no point lights) and the
//! shading needs no shadow rays. Every other field (cubic filters, analytic gradients,
//! octrees, ADFs, CVG trees, analytic fields) and every image with shadows or point
//! lights keeps the general [`march_iso`](crate::march) path.
//!
//! **The walk.** The ray, clipped to the field's bounds, is walked through the voxel
//! cells (the unit cubes between eight voxel centres) with a 3D DDA in index space
//! (Amanatides and Woo). Each cell's parameter interval is computed from its own face
//! planes, never accumulated, so a cell and its polynomial are a function of the ray
//! and the cell alone. With empty-space skipping on, the cell mask of `iso_skip.rs`
//! passes cells whose corners are all outside without reading them, a ray that misses
//! the box of the other cells ends at once, and a ray entering a block of 4³ cells
//! around which a cube of blocks is all outside jumps to the cube's exit: the walk is
//! put in the cell it would be in just before that exit by the same plane comparisons
//! a step makes ([`Dda::advance_to`]), so it goes on exactly as if it had stepped
//! through every cell (skipping on = off bit for bit, any thread count).
//!
//! **The root.** Along a ray the trilinear interpolant of one cell is a cubic in the ray
//! parameter (survey §5: trilinear reconstruction is the tensor product of three linear
//! filters, each linear in `t` along a line). A cell whose eight corners lie on one side
//! of the iso value holds no crossing (the interpolant is a convex combination of the
//! corners) and is decided by one min/max; otherwise the cubic's coefficients are
//! formed, split at its critical points (roots of the derivative, a quadratic) into
//! monotone pieces, and the first piece that goes from outside to inside is refined by
//! regula falsi (Illinois) safeguarded by bisection to the renderer's tolerance
//! (`1e-9` sample spacing), on the polynomial — no further field reads.
//!
//! **How it differs from the general path.** The general path samples every `step` and
//! refines between the first two samples that bracket a crossing; it misses a crossing
//! whose inside part lies between two samples (a surface grazed, a sliver thinner than
//! the step). This path cannot miss one: it finds the first crossing of the same
//! trilinear reconstruction of the same `f32` densities. Where a ray crosses the surface
//! cleanly both find the same root to well below `1e-6` voxel; the images differ only at
//! grazing silhouettes and thin features (measured in `tests/iso_packed.rs`).
//!
//! Work counters: `samples` counts voxel cells whose corners were read (eight voxels
//! each), `cells_skipped` the skips (a jump over a cube of outside blocks, a ray ended
//! or advanced by the active box), `gradient_evaluations` the one packed gradient per
//! hit.

use glam::{DVec3, IVec3};
use volga_core::Field;

use crate::packed::PackedVolume;

use crate::integrators::March;
use crate::{Camera, Ray, RenderStats};

// The cell mask and the skip structure over it.
#[path = "iso_skip.rs"]
mod skip;
pub(crate) use skip::IsoCellMask;

// Per view: where each ray can first meet a cell that is not outside.
#[path = "iso_starts.rs"]
mod starts;
pub(crate) use starts::IsoStarts;

/// Least block reach worth a jump: a block of reach 1 is crossed in a few cell steps,
/// each cheaper than placing the walk after a jump.
const MIN_JUMP_REACH: u8 = 2;

/// The packed volume to find iso crossings in, when this path applies to `m`: the field
/// is a packed view and the shading casts no shadow rays and has no point lights (the
/// renderer hands out a packed view only when [`packet_path_allowed`](crate::packet)
/// holds; this repeats the shading part so the path never shades what it cannot).
#[inline]
pub(crate) fn iso_packed<'m, F: Field + ?Sized>(m: &'m March<'_, F>) -> Option<&'m PackedVolume> {
    if m.shader.is_general() {
        return None;
    }
    m.packed
}

impl<F: Field + ?Sized> March<'_, F> {
    /// Whether every ray through the pixels `x0..x1 × y0..y1` of `camera`'s
    /// `width × height` image is known to miss the iso-surface on the packed iso path
    /// (its view's [`IsoStarts`] covers the tile with no active box), so the renderer
    /// can fill the tile with the background: what each of those rays would give.
    pub(crate) fn iso_tile_misses(&self, camera: &Camera, tile: (u32, u32, u32, u32), image: (u32, u32)) -> bool {
        match (self.iso_starts, iso_packed(self)) {
            (Some(starts), Some(_)) => starts.misses_pixels(camera, tile, image),
            _ => false,
        }
    }
}

/// The exact first crossing from outside to inside of the oriented iso level
/// (`inward·v ≥ inward·iso` is inside) of `packed`'s trilinear reconstruction along
/// `ray` within `[t0, t1]`, or `None`. `background_below` is whether the ray, when it
/// enters the bounds from outside (`t0 > 0`), comes from outside the surface (`None`:
/// unknown, the first cell decides, as for a camera inside the volume). `tol` is the
/// refinement tolerance in `t`. `mask` (empty-space skipping, `iso_skip.rs`) passes
/// cells known to be outside without reading them, and `start` (with a mask only: from
/// the view's [`IsoStarts`], `−∞` when unknown) is a ray parameter before which every
/// cell is outside (`+∞`: every cell); the hit is the same bits with and without them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn march_iso_packed(
    packed: &PackedVolume,
    ray: &Ray,
    inward: f64,
    iso: f64,
    (t0, t1): (f64, f64),
    tol: f64,
    mask: Option<&IsoCellMask>,
    start: f64,
    background_below: Option<bool>,
    stats: &mut RenderStats,
) -> Option<f64> {
    if !(t0.is_finite() && t1.is_finite() && t1 >= t0) {
        return None;
    }
    let iso = inward * iso;
    let transform = &packed.grid().transform;
    // Index position at local parameter τ = t − t0: a0 + τ·d.
    let a0 = transform.world_to_index(ray.at(t0));
    let d = ray.dir / transform.spacing();
    if !(a0.is_finite() && d.is_finite()) {
        return None;
    }
    let tau_end = t1 - t0;
    // Past `limit` every cell is outside: the walk ends there without a hit.
    let mut limit = tau_end;
    let mut below = background_below;
    let inv = DVec3::ONE / d;
    // The active box: a ray that misses it meets only outside cells.
    let mut enter_box = 0.0;
    if let Some(m) = mask {
        let Some((lo, hi)) = m.active_index_box() else {
            stats.cells_skipped += 1;
            return None;
        };
        let (box_in, box_out) = box_interval(a0, inv, lo, hi);
        // The view's start bound, local (NaN-safe: only a comparison true moves it).
        let box_in = if start - t0 > box_in { start - t0 } else { box_in };
        if !(box_in <= box_out && box_in <= tau_end && box_out >= 0.0) {
            stats.cells_skipped += 1;
            return None;
        }
        limit = limit.min(box_out);
        enter_box = box_in;
    }
    let mut v = Dda::new(a0, d, inv, 0.0);
    // Skip a cell the start only touches (its exit at or before it).
    while v.exit_min() <= 0.0 {
        v.step();
    }
    if enter_box > v.exit_min() {
        // Every cell before the grown box is outside: continue from the one the ray is
        // in just before entering it (outside too), as the walk would have reached it.
        stats.cells_skipped += 1;
        below = Some(true);
        v.advance_to(enter_box);
        v.step();
    }
    // A safety bound on the walk (a ray crosses at most Σ|Δijk| + 3 cells).
    let max_cells = {
        let span = (d * tau_end).abs();
        (span.x + span.y + span.z) as u64 + 8
    };
    let mut visited = 0u64;
    let bg = inward * packed.background() as f64;
    // The mask word of the last cell whose block was considered for a jump.
    let mut word = usize::MAX;
    loop {
        let (tau_a, tau_b) = v.segment(tau_end);
        if tau_a > limit || visited > max_cells {
            return None;
        }
        visited += 1;
        let outside = match mask.and_then(|m| m.slot(v.base).map(|s| (m, s))) {
            None => false,
            Some((m, slot)) => {
                if slot.word != word {
                    word = slot.word;
                    let r = m.reach(word);
                    if r >= MIN_JUMP_REACH {
                        // A cube of outside blocks around this one: jump to its exit.
                        let tau_x = v.cube_exit(IsoCellMask::cube_planes(v.base, r));
                        if tau_x > v.exit_min() {
                            stats.cells_skipped += 1;
                            below = Some(true);
                            if tau_x.is_nan() || tau_x >= limit {
                                return None;
                            }
                            v.advance_to(tau_x);
                            // The cell just before the exit is in the cube (outside).
                            word = m.slot(v.base).map_or(usize::MAX, |s| s.word);
                            v.step();
                            continue;
                        }
                    }
                }
                m.outside_at(slot)
            }
        };
        if outside {
            // All eight corners outside (what `cell_crossing` would find reading them).
            below = Some(true);
        } else if tau_b >= tau_a {
            stats.samples += 1;
            let c = cell_corners(packed, v.base, inward, bg);
            match cell_crossing(&c, v.base, a0, d, iso, tau_a, tau_b, tol, below) {
                Crossing::At(tau) => return Some(t0 + tau),
                Crossing::End(b) => below = b,
            }
        }
        if tau_b >= tau_end {
            return None;
        }
        v.step();
    }
}

/// The parameter interval `(enter, exit)` of the line `a0 + τ·d` (`inv = 1/d`) in the
/// box `[lo, hi]` (empty when `enter > exit`; NaN-free for finite inputs: an axis the
/// line is parallel to either holds it throughout or excludes it).
#[inline(always)]
fn box_interval(a0: DVec3, inv: DVec3, lo: DVec3, hi: DVec3) -> (f64, f64) {
    let (mut enter, mut exit) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if inv[a].is_finite() {
            let (p, q) = ((lo[a] - a0[a]) * inv[a], (hi[a] - a0[a]) * inv[a]);
            enter = enter.max(p.min(q));
            exit = exit.min(p.max(q));
        } else if !(a0[a] >= lo[a] && a0[a] <= hi[a]) {
            return (f64::INFINITY, f64::NEG_INFINITY);
        }
    }
    (enter, exit)
}

/// The oriented corner values (`inward·v`, x fastest) of the voxel cell at `base`.
#[inline(always)]
fn cell_corners(packed: &PackedVolume, base: IVec3, inward: f64, bg: f64) -> [f64; 8] {
    match packed.offset(base) {
        None => [bg; 8],
        Some(o) => packed.corners(o).map(|c| inward * c.x as f64),
    }
}

/// What a cell says about the crossing.
enum Crossing {
    /// The first crossing, at this local parameter.
    At(f64),
    /// None in the cell; whether the ray leaves it outside (`None`: still unknown).
    End(Option<bool>),
}

/// The first outside-to-inside crossing of `iso` by the trilinear interpolant of
/// corners `c` (cell `base`) along `a0 + τ·d` for `τ ∈ [tau_a, tau_b]`, given whether
/// the ray arrives from outside (`below`).
#[allow(clippy::too_many_arguments)]
#[inline]
fn cell_crossing(
    c: &[f64; 8],
    base: IVec3,
    a0: DVec3,
    d: DVec3,
    iso: f64,
    tau_a: f64,
    tau_b: f64,
    tol: f64,
    below: Option<bool>,
) -> Crossing {
    let mut lo = c[0];
    let mut hi = c[0];
    let mut sum = 0.0;
    for &v in c {
        lo = lo.min(v);
        hi = hi.max(v);
        sum += v;
    }
    if sum.is_nan() {
        // NaN corners: ignored, as the general path ignores NaN samples.
        return Crossing::End(below);
    }
    if hi < iso {
        return Crossing::End(Some(true));
    }
    if lo >= iso {
        return if below == Some(true) {
            Crossing::At(tau_a)
        } else {
            Crossing::End(Some(false))
        };
    }
    let g = Cubic::along(c, (a0 + d * tau_a) - base.as_dvec3(), d, iso);
    let len = tau_b - tau_a;
    // Pieces split at the critical points inside (0, len), in order.
    let mut knots = [0.0, len, len, len];
    let mut n = 1;
    for r in g.critical_points() {
        if r > 0.0 && r < len {
            knots[n] = r;
            n += 1;
        }
    }
    knots[n] = len;
    let mut s0 = 0.0;
    let mut g0 = g.eval(0.0);
    let mut state = below.unwrap_or(g0 < 0.0);
    if state && g0 >= 0.0 {
        return Crossing::At(tau_a);
    }
    for &s1 in &knots[1..=n] {
        let g1 = g.eval(s1);
        if state && g1 >= 0.0 {
            return Crossing::At(tau_a + g.refine(s0, s1, g0, g1, tol));
        }
        state = g1 < 0.0;
        s0 = s1;
        g0 = g1;
    }
    Crossing::End(Some(state))
}

/// `k0 + k1·s + k2·s² + k3·s³`: the trilinear interpolant minus the iso value along a
/// line through a cell.
#[derive(Clone, Copy, Debug)]
struct Cubic {
    k: [f64; 4],
}

impl Cubic {
    /// Corners `c` (x fastest), fractions `f` at `s = 0` and their rate `d` per unit `s`.
    /// Interpolates along x, then y, then z as polynomials, so `k0` is the trilinear
    /// value at `f` computed exactly as [`PackedVolume::value_at_index`] does, minus `iso`.
    #[inline(always)]
    fn along(c: &[f64; 8], f: DVec3, d: DVec3, iso: f64) -> Cubic {
        // x: four lines a + b·s.
        let lx = |c0: f64, c1: f64| (c0 + (c1 - c0) * f.x, (c1 - c0) * d.x);
        let (a00, b00) = lx(c[0], c[1]);
        let (a10, b10) = lx(c[2], c[3]);
        let (a01, b01) = lx(c[4], c[5]);
        let (a11, b11) = lx(c[6], c[7]);
        // y: two quadratics m0 + m1·s + m2·s².
        let ly = |a0: f64, b0: f64, a1: f64, b1: f64| {
            let (da, db) = (a1 - a0, b1 - b0);
            (a0 + da * f.y, b0 + da * d.y + db * f.y, db * d.y)
        };
        let (m0, m1, m2) = ly(a00, b00, a10, b10);
        let (n0, n1, n2) = ly(a01, b01, a11, b11);
        // z: one cubic.
        let (e0, e1, e2) = (n0 - m0, n1 - m1, n2 - m2);
        Cubic {
            k: [
                m0 + e0 * f.z - iso,
                m1 + e1 * f.z + e0 * d.z,
                m2 + e2 * f.z + e1 * d.z,
                e2 * d.z,
            ],
        }
    }

    #[inline(always)]
    fn eval(&self, s: f64) -> f64 {
        let [k0, k1, k2, k3] = self.k;
        ((k3 * s + k2) * s + k1) * s + k0
    }

    /// The real roots of the derivative `3k3·s² + 2k2·s + k1`, ascending (NaN where
    /// there is none: never inside an interval).
    #[inline]
    fn critical_points(&self) -> [f64; 2] {
        let [_, k1, k2, k3] = self.k;
        let (a, b, c) = (3.0 * k3, 2.0 * k2, k1);
        if a == 0.0 {
            return [if b != 0.0 { -c / b } else { f64::NAN }, f64::NAN];
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return [f64::NAN; 2];
        }
        // The stable pair: q = −(b + sign(b)·√disc)/2, roots q/a and c/q.
        let q = -0.5 * (b + disc.sqrt().copysign(b));
        let (r0, r1) = (q / a, if q != 0.0 { c / q } else { q / a });
        if r0 <= r1 {
            [r0, r1]
        } else {
            [r1, r0]
        }
    }

    /// The value and the slope at `s`.
    #[inline(always)]
    fn eval_with_slope(&self, s: f64) -> (f64, f64) {
        let [_, k1, k2, k3] = self.k;
        (self.eval(s), (3.0 * k3 * s + 2.0 * k2) * s + k1)
    }

    /// A root in `[lo, hi]` where `g(lo) < 0 ≤ g(hi)` and `g` is monotone, bracketed to
    /// within `tol`: Newton's method from the regula falsi point, every evaluated point
    /// narrowing the bracket, a bisection where a step would leave it; once a Newton
    /// step is below `tol/4`, the next point is `tol/4` past the new estimate, on the
    /// other side of the root from the last point, which closes the bracket (to at most
    /// `tol/2`) when the estimate is that close. Returns the bracket's midpoint, within
    /// `tol/2` of the root. (Regula falsi with bisections took 23 evaluations per hit
    /// on the benchmark volumes, this 4–5: quadratic convergence from the first step.)
    #[inline]
    fn refine(&self, mut lo: f64, mut hi: f64, g_lo: f64, g_hi: f64, tol: f64) -> f64 {
        let mut x = lo + (hi - lo) * (g_lo / (g_lo - g_hi));
        for _ in 0..128 {
            if hi - lo <= tol {
                break;
            }
            if !(x > lo && x < hi) {
                x = 0.5 * (lo + hi);
                if !(x > lo && x < hi) {
                    break;
                }
            }
            let (g, slope) = self.eval_with_slope(x);
            if g >= 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            let step = g / slope;
            x -= step;
            if step.abs() <= 0.25 * tol {
                x += if g >= 0.0 { -0.25 * tol } else { 0.25 * tol };
            }
        }
        0.5 * (lo + hi)
    }
}

/// A 3D DDA over the unit voxel cells of index space along `a0 + τ·d`: the current cell
/// `base` and, per axis, the parameters of its entry and exit face planes, each computed
/// from the plane (`(plane − a0)/d`), so a cell's interval never depends on the path.
struct Dda {
    base: IVec3,
    a0: DVec3,
    d: DVec3,
    inv: DVec3,
    /// Per axis `+1`, `−1` or `0` (parallel).
    dir: IVec3,
    enter: DVec3,
    exit: DVec3,
}

impl Dda {
    /// The cell holding the point at `tau` (a point on a face belongs to the cell the
    /// ray enters there).
    #[inline]
    fn new(a0: DVec3, d: DVec3, inv: DVec3, tau: f64) -> Dda {
        let p = a0 + d * tau;
        let dir = IVec3::new(sign(d.x), sign(d.y), sign(d.z));
        let mut base = IVec3::ZERO;
        for a in 0..3 {
            // Clamped far outside any grid (the packed volume serves the background there).
            let x = p[a].clamp(-1e9, 1e9);
            // floor(x) through one conversion (NaN → 0, as `cell_at_index`).
            let t = x as i32;
            let mut b = t - ((t as f64) > x) as i32;
            if dir[a] < 0 && b as f64 == x {
                b -= 1; // on a face, moving down: the cell below
            }
            base[a] = b;
        }
        let mut dda = Dda {
            base,
            a0,
            d,
            inv,
            dir,
            enter: DVec3::ZERO,
            exit: DVec3::ZERO,
        };
        for a in 0..3 {
            // Parallel to an axis: its entry plane never limits, its exit is never reached.
            (dda.enter[a], dda.exit[a]) = match dir[a] {
                0 => (f64::NEG_INFINITY, f64::INFINITY),
                _ => (
                    dda.plane(a, base[a] + (dir[a] < 0) as i32),
                    dda.plane(a, base[a] + (dir[a] > 0) as i32),
                ),
            };
        }
        dda
    }

    /// Parameter where the ray crosses index plane `x_a = k` (not parallel to it).
    #[inline(always)]
    fn plane(&self, a: usize, k: i32) -> f64 {
        (k as f64 - self.a0[a]) * self.inv[a]
    }

    /// The current cell's parameter interval, clipped to `[0, tau_end]`.
    #[inline(always)]
    fn segment(&self, tau_end: f64) -> (f64, f64) {
        let e = self.enter.max_element().max(0.0);
        (e, self.exit_min().min(tau_end))
    }

    #[inline(always)]
    fn exit_min(&self) -> f64 {
        self.exit.min_element()
    }

    /// The parameter where the ray leaves the box of cells between index planes
    /// `low` and `high` (the faces ahead of it, per axis; parallel axes never limit).
    #[inline(always)]
    fn cube_exit(&self, (low, high): (IVec3, IVec3)) -> f64 {
        let mut t = f64::INFINITY;
        for a in 0..3 {
            match self.dir[a] {
                0 => {}
                s => t = t.min(self.plane(a, if s > 0 { high[a] } else { low[a] })),
            }
        }
        t
    }

    /// Puts the walk in the cell it is in just before parameter `tau` (finite, ahead
    /// of the current cell): per axis the cell whose entry plane is crossed before
    /// `tau` and whose exit plane at or after it, by the same plane parameters
    /// [`Dda::step`] compares, so the walk then goes on exactly as if it had stepped
    /// through every cell in between (ties included: `tau` on several planes at once
    /// leaves those steps to `step`, in its order).
    #[inline]
    fn advance_to(&mut self, tau: f64) {
        let p = self.a0 + self.d * tau;
        for a in 0..3 {
            let s = self.dir[a];
            if s == 0 {
                continue;
            }
            // A first guess within rounding of the answer, then the exact plane tests
            // (`plane` is monotone in `k`, so each loop ends; bounded all the same).
            let x = p[a].clamp(-1e9, 1e9);
            let mut k = x as i32 - ((x as i32 as f64) > x) as i32;
            // The planes of cell k's faces at index k (`low`) and k + 1 (`high`).
            let (mut low, mut high) = (self.plane(a, k), self.plane(a, k + 1));
            if s > 0 {
                // The cell with plane(k) < tau ≤ plane(k + 1).
                for _ in 0..64 {
                    if high >= tau {
                        break;
                    }
                    k += 1;
                    (low, high) = (high, self.plane(a, k + 1));
                }
                for _ in 0..64 {
                    if low < tau {
                        break;
                    }
                    k -= 1;
                    (low, high) = (self.plane(a, k), low);
                }
                (self.enter[a], self.exit[a]) = (low, high);
            } else {
                // Planes fall as k rises: the cell with plane(k + 1) < tau ≤ plane(k).
                for _ in 0..64 {
                    if high < tau {
                        break;
                    }
                    k += 1;
                    (low, high) = (high, self.plane(a, k + 1));
                }
                for _ in 0..64 {
                    if low >= tau {
                        break;
                    }
                    k -= 1;
                    (low, high) = (self.plane(a, k), low);
                }
                (self.enter[a], self.exit[a]) = (high, low);
            }
            self.base[a] = k;
        }
    }

    /// Steps into the next cell through the face crossed first.
    #[inline(always)]
    fn step(&mut self) {
        let m = self.exit_min();
        let a = if self.exit.x == m {
            0
        } else if self.exit.y == m {
            1
        } else {
            2
        };
        self.base[a] += self.dir[a];
        self.enter[a] = self.exit[a];
        self.exit[a] = self.plane(a, self.base[a] + (self.dir[a] > 0) as i32);
    }
}

#[inline(always)]
fn sign(x: f64) -> i32 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

#[cfg(test)]
#[path = "iso_packed_tests.rs"]
mod accuracy_tests;

#[cfg(test)]
mod tests {
    use super::*;

    /// The cubic equals the trilinear interpolant along the line at many points.
    #[test]
    fn cubic_is_the_trilinear_interpolant_along_the_line() {
        let c = [0.1, -0.7, 0.4, 0.9, -0.2, 0.3, 0.8, -0.5];
        let f = DVec3::new(0.2, 0.7, 0.1);
        let d = DVec3::new(0.3, -0.4, 0.6);
        let g = Cubic::along(&c, f, d, 0.25);
        for i in 0..=10 {
            let s = i as f64 * 0.1;
            let p = f + d * s;
            let tri = |x: f64, y: f64, z: f64| {
                let l = |a: f64, b: f64, t: f64| a + (b - a) * t;
                let y0 = l(l(c[0], c[1], x), l(c[2], c[3], x), y);
                let y1 = l(l(c[4], c[5], x), l(c[6], c[7], x), y);
                l(y0, y1, z)
            };
            let want = tri(p.x, p.y, p.z) - 0.25;
            assert!((g.eval(s) - want).abs() < 1e-14, "{s}: {} vs {want}", g.eval(s));
        }
    }

    /// Critical points are where the derivative vanishes.
    #[test]
    fn critical_points_zero_the_derivative() {
        let g = Cubic {
            k: [0.1, -3.0, 1.0, 1.0],
        };
        let [r0, r1] = g.critical_points();
        assert!(r0 < r1);
        for r in [r0, r1] {
            let dg = 3.0 * r * r + 2.0 * r - 3.0;
            assert!(dg.abs() < 1e-12, "{r}: {dg}");
        }
    }

    /// Two crossings inside one cell, between which a sampler with a coarse step would
    /// see nothing: the first is found.
    #[test]
    fn a_thin_sliver_inside_one_cell_is_found() {
        // g(s) = (s − 0.3)(s − 0.32)·(−1) … inside only on [0.3, 0.32].
        let k = [-(0.3 * 0.32), 0.62, -1.0, 0.0];
        let g = Cubic { k };
        let [r0, r1] = g.critical_points();
        assert!(r0.is_nan() || r1.is_nan() || (0.0..1.0).contains(&r0));
        let s = g.refine(0.0, 0.31, g.eval(0.0), g.eval(0.31), 1e-12);
        assert!((s - 0.3).abs() < 1e-10, "{s}");
    }
}
