//! Ray marching building blocks shared by the integrators: the empty-space grid,
//! the sample lattices, and the iso-surface search with its refinement. Everything here is
//! generic over the field type so per-sample loops are monomorphized (no dynamic
//! dispatch, no allocation).

use glam::{DVec3, Vec3};
use volga_core::{fast_floor, Field, Line};

use crate::macro_grid::{CellClass, MacroGrid};
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
    /// World position of the crossing, `ray.at(t)`.
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
