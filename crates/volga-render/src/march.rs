//! Ray marching kernels: the empty-space grid, iso-surface search with bisection
//! and the per-mode integrators. Everything here is generic over the field type so
//! the per-sample loop is monomorphized (no dynamic dispatch, no allocation).

use glam::{DVec3, Vec3, Vec4};
use rayon::prelude::*;
use volga_core::{Aabb, Field};

use crate::{Mode, Ray, RenderStats, Shader, SurfaceColour, TransferFunction};

/// Upper bound on lattice samples along one ray; the renderer rejects settings that
/// would exceed it and [`first_hit`] coarsens its step to stay under it.
pub(crate) const MAX_STEPS_PER_RAY: f64 = (1u64 << 24) as f64;

/// Macro cell holds samples that matter.
pub(crate) const ACTIVE: u8 = 0;
/// Macro cell can be skipped: transparent (volume mode) or every value below the
/// iso value (iso mode).
pub(crate) const EMPTY_BELOW: u8 = 1;
/// Macro cell can be skipped in iso mode: every value above the iso value.
pub(crate) const EMPTY_ABOVE: u8 = 2;

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
    class: Vec<u8>,
    hi: Vec<f64>,
}

/// Target macro cell edge in sample spacings, and the cap per axis (≤ 64³ cells).
const CELL_SPACINGS: f64 = 8.0;
const MAX_CELLS_PER_AXIS: usize = 64;

impl MacroGrid {
    pub(crate) fn build<F: Field + ?Sized>(
        field: &F,
        bounds: Aabb,
        spacing: f64,
        classify: impl Fn(f64, f64) -> u8 + Sync,
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
        };
        let margin = DVec3::splat(spacing);
        let cells: Vec<(u8, f64)> = (0..dims[0] * dims[1] * dims[2])
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
        grid
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

    /// If the sample at `t` lies in a skippable cell: its class and the ray
    /// parameter where the ray leaves that cell.
    #[inline]
    fn skip_at(&self, ray: &Ray, t: f64) -> Option<(u8, f64)> {
        let (ijk, lin) = self.locate(ray.at(t));
        let class = self.class[lin];
        (class != ACTIVE).then(|| (class, self.exit_t(ijk, ray)))
    }

    /// Maximum of the conservative value range of the cell holding the sample at
    /// `t`, and the ray parameter where the ray leaves that cell.
    #[inline]
    fn hi_at(&self, ray: &Ray, t: f64) -> (f64, f64) {
        let (ijk, lin) = self.locate(ray.at(t));
        (self.hi[lin], self.exit_t(ijk, ray))
    }
}

/// The first lattice index `j` (sample at `t0 + (j + offset)·dt`) beyond `t_exit`,
/// clamped to `[i + 1, end]` so marching always advances. Rounding can only make
/// the skipped samples overshoot the cell by a few ulps, inside the cell's margin.
#[inline]
fn index_after(t_exit: f64, t0: f64, dt: f64, offset: f64, i: u64, end: u64) -> u64 {
    let x = ((t_exit - t0) / dt - offset).floor() + 1.0;
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
    let guess = ((t1 - t0) / dt).ceil();
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
fn midpoint_lattice_len(t0: f64, t1: f64, dt: f64) -> u64 {
    let guess = ((t1 - t0) / dt + 0.5).floor();
    let mut n = if guess.is_nan() || guess < 0.0 {
        0
    } else {
        guess.min(MAX_STEPS_PER_RAY) as u64
    };
    while n > 0 && t0 + (n as f64 - 0.5) * dt > t1 {
        n -= 1;
    }
    while (n as f64) < MAX_STEPS_PER_RAY && t0 + (n as f64 + 0.5) * dt <= t1 {
        n += 1;
    }
    n
}

/// Bisection of a bracket `[lo, hi]` with `value(lo) < iso ≤ value(hi)` down to
/// width `tol` (at most 64 halvings); returns the bracket's midpoint. NaN values
/// count as below.
fn bisect<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    iso: f64,
    mut lo: f64,
    mut hi: f64,
    tol: f64,
    stats: &mut RenderStats,
) -> f64 {
    for _ in 0..64 {
        if hi - lo <= tol {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if !(mid > lo && mid < hi) {
            break;
        }
        stats.samples += 1;
        if field.value(ray.at(mid)) >= iso {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// First crossing from below `iso` to `≥ iso` along `ray` within `[t0, t1]`.
///
/// Samples at `t0 + i·dt` (and a last one at `t1`); a ray entering the bounds from
/// outside starts from the field's background value, so content touching the
/// bounds yields a hit at `t0`. NaN samples are ignored. With a macro grid, samples
/// in cells whose range excludes `iso` are skipped but their side of the iso value
/// is kept, so the bracket handed to bisection — and the hit — are exactly those
/// found without skipping.
#[allow(clippy::too_many_arguments)]
pub(crate) fn march_iso<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    iso: f64,
    (t0, t1): (f64, f64),
    dt: f64,
    tol: f64,
    grid: Option<&MacroGrid>,
    stats: &mut RenderStats,
) -> Option<f64> {
    let k_end = iso_lattice_len(t0, t1, dt);
    let lattice_t = |i: u64| if i >= k_end { t1 } else { t0 + i as f64 * dt };
    let bg = field.background();
    // (ray parameter, value below iso) of the previous sample.
    let mut prev: Option<(f64, bool)> = (t0 > 0.0 && !bg.is_nan()).then_some((t0, bg < iso));
    let mut i = 0u64;
    while i <= k_end {
        let t = lattice_t(i);
        if let Some((class, t_exit)) = grid.and_then(|g| g.skip_at(ray, t)) {
            let below = class == EMPTY_BELOW;
            if let (false, Some((tp, true))) = (below, prev) {
                // The skipped sample at `t` is above: the crossing is in [tp, t].
                return Some(bisect(field, ray, iso, tp, t, tol, stats));
            }
            let next = index_after(t_exit, t0, dt, 0.0, i, k_end + 1);
            stats.cells_skipped += 1;
            prev = Some((lattice_t(next - 1), below));
            i = next;
            continue;
        }
        stats.samples += 1;
        let v = field.value(ray.at(t));
        if !v.is_nan() {
            let below = v < iso;
            if let (false, Some((tp, true))) = (below, prev) {
                return Some(bisect(field, ray, iso, tp, t, tol, stats));
            }
            prev = Some((t, below));
        }
        i += 1;
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

/// The first crossing of `iso` (from below to above) along `ray` inside
/// `field.bounds()`.
///
/// Samples every `step_world` world units (the ray's `dir` need not be unit; `t`
/// is in units of `|dir|`), starting at the bounds entry, then refines the
/// bracketing interval by bisection until it is narrower than
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
    let t = march_iso(field, ray, iso, (t0, t1), dt, tol, None, &mut stats)?;
    Some(Hit {
        t,
        world_pos: ray.at(t),
    })
}

/// Colour of the field at `p`, white where it has none (or a non-finite one).
#[inline]
fn field_colour<F: Field + ?Sized>(field: &F, p: DVec3) -> Vec3 {
    match field.colour(p) {
        Some(c) if c.is_finite() => c.clamp(Vec3::ZERO, Vec3::ONE),
        _ => Vec3::ONE,
    }
}

/// Per-render constants shared by every ray.
pub(crate) struct Tracer<'a, F: ?Sized> {
    pub field: &'a F,
    pub bounds: Aabb,
    /// Ray step in world units (rays are unit length, so also in `t`).
    pub step: f64,
    /// Bisection tolerance in `t`.
    pub tol: f64,
    /// `step / reference_step` for opacity correction.
    pub alpha_exponent: f64,
    pub early_termination_alpha: f32,
    pub background: Vec4,
    pub shader: Shader,
    pub grid: Option<MacroGrid>,
}

impl<F: Field + ?Sized> Tracer<'_, F> {
    /// The final straight-alpha pixel of one ray.
    #[inline]
    pub(crate) fn trace(&self, mode: &Mode, ray: &Ray, stats: &mut RenderStats) -> Vec4 {
        stats.rays += 1;
        let interval = self
            .bounds
            .ray_interval(ray.origin, ray.dir)
            .filter(|(t0, t1)| t0.is_finite() && t1.is_finite());
        let (c, a) = match interval {
            None => (Vec3::ZERO, 0.0),
            Some(ti) => match mode {
                Mode::Iso { value, colour } => self.iso(ray, ti, *value, colour, stats),
                Mode::Volume {
                    transfer,
                    colour_from_field,
                } => self.volume(ray, ti, transfer, *colour_from_field, stats),
                Mode::Mip => self.mip(ray, ti, stats),
                Mode::XRay => self.xray(ray, ti, stats),
            },
        };
        self.over_background(c, a)
    }

    /// Composites premultiplied `(c, a)` over the background and returns straight
    /// RGBA clamped to \[0, 1\]: `c + (1 − a)·background`, alpha exactly 1 for an
    /// opaque background.
    fn over_background(&self, c: Vec3, a: f32) -> Vec4 {
        let bg = self.background;
        let (c, a) = if c.is_finite() && a.is_finite() {
            (c, a.clamp(0.0, 1.0))
        } else {
            (Vec3::ZERO, 0.0)
        };
        let premult = c + bg.truncate() * (bg.w * (1.0 - a));
        let out = if bg.w >= 1.0 {
            premult.extend(1.0)
        } else {
            let alpha = a + (1.0 - a) * bg.w;
            if alpha > 0.0 {
                (premult / alpha).extend(alpha)
            } else {
                Vec4::ZERO
            }
        };
        out.clamp(Vec4::ZERO, Vec4::ONE)
    }

    #[inline]
    fn shade_at(&self, colour: Vec3, p: DVec3, ray: &Ray, stats: &mut RenderStats) -> Vec3 {
        if self.shader.is_lit() {
            stats.gradient_evaluations += 1;
            self.shader.shade(colour, self.field.gradient(p), ray.dir)
        } else {
            colour
        }
    }

    fn iso(&self, ray: &Ray, ti: (f64, f64), iso: f64, colour: &SurfaceColour, stats: &mut RenderStats) -> (Vec3, f32) {
        let hit = march_iso(self.field, ray, iso, ti, self.step, self.tol, self.grid.as_ref(), stats);
        match hit {
            None => (Vec3::ZERO, 0.0),
            Some(t) => {
                let p = ray.at(t);
                let co = match colour {
                    SurfaceColour::Constant(c) => *c,
                    SurfaceColour::FromField => field_colour(self.field, p),
                };
                (self.shade_at(co, p, ray, stats), 1.0)
            }
        }
    }

    /// Opacity correction for the actual step: `α' = 1 − (1 − α)^(Δs/Δs_ref)`.
    #[inline]
    fn correct_alpha(&self, alpha: f32) -> f32 {
        if self.alpha_exponent == 1.0 || alpha >= 1.0 {
            alpha
        } else {
            (1.0 - (1.0 - alpha as f64).powf(self.alpha_exponent)) as f32
        }
    }

    /// Post-classified (survey eq. 15) front-to-back compositing (survey eq. 13):
    /// `c += C·α'·(1 − a)`, `a += α'·(1 − a)` at `t0 + (i + ½)·Δs`, stopping once
    /// `a ≥ early_termination_alpha`. Returns premultiplied colour and alpha.
    fn volume(
        &self,
        ray: &Ray,
        (t0, t1): (f64, f64),
        tf: &TransferFunction,
        colour_from_field: bool,
        stats: &mut RenderStats,
    ) -> (Vec3, f32) {
        let n = midpoint_lattice_len(t0, t1, self.step);
        let mut c = Vec3::ZERO;
        let mut a = 0.0f32;
        let mut i = 0u64;
        while i < n {
            let t = t0 + (i as f64 + 0.5) * self.step;
            if let Some((_, t_exit)) = self.grid.as_ref().and_then(|g| g.skip_at(ray, t)) {
                // Transparent cell: every sample in it has α = 0 and would be skipped.
                stats.cells_skipped += 1;
                i = index_after(t_exit, t0, self.step, 0.5, i, n);
                continue;
            }
            i += 1;
            stats.samples += 1;
            let p = ray.at(t);
            let v = self.field.value(p);
            if v.is_nan() {
                continue;
            }
            let rgba = tf.eval(v);
            if rgba.w.is_nan() || rgba.w <= 0.0 {
                continue;
            }
            let alpha = self.correct_alpha(rgba.w);
            let co = if colour_from_field {
                field_colour(self.field, p)
            } else {
                rgba.truncate()
            };
            let rgb = self.shade_at(co, p, ray, stats);
            let w = (1.0 - a) * alpha;
            c += rgb * w;
            a += w;
            if a >= self.early_termination_alpha {
                stats.rays_terminated_early += 1;
                break;
            }
        }
        (c, a)
    }

    /// Maximum intensity projection: grey level `max v` clamped to \[0, 1\], drawn as
    /// white with that opacity. Cells whose range maximum cannot raise the current
    /// maximum are skipped.
    fn mip(&self, ray: &Ray, (t0, t1): (f64, f64), stats: &mut RenderStats) -> (Vec3, f32) {
        let n = midpoint_lattice_len(t0, t1, self.step);
        let mut m = f64::NEG_INFINITY;
        let mut i = 0u64;
        while i < n {
            let t = t0 + (i as f64 + 0.5) * self.step;
            if let Some(g) = &self.grid {
                let (hi, t_exit) = g.hi_at(ray, t);
                if hi <= m {
                    stats.cells_skipped += 1;
                    i = index_after(t_exit, t0, self.step, 0.5, i, n);
                    continue;
                }
            }
            i += 1;
            stats.samples += 1;
            let v = self.field.value(ray.at(t));
            if v > m {
                m = v;
            }
        }
        grey(m)
    }

    /// X-ray: the mean value of the samples inside the bounds, clamped to \[0, 1\],
    /// drawn as white with that opacity. Never skips (the mean needs every sample).
    fn xray(&self, ray: &Ray, (t0, t1): (f64, f64), stats: &mut RenderStats) -> (Vec3, f32) {
        let n = midpoint_lattice_len(t0, t1, self.step);
        let (mut sum, mut count) = (0.0f64, 0u64);
        for i in 0..n {
            stats.samples += 1;
            let v = self.field.value(ray.at(t0 + (i as f64 + 0.5) * self.step));
            if !v.is_nan() {
                sum += v;
                count += 1;
            }
        }
        if count == 0 {
            return (Vec3::ZERO, 0.0);
        }
        grey(sum / count as f64)
    }
}

/// White at opacity `g` (premultiplied), `g` clamped to \[0, 1\]; nothing for −∞/NaN.
fn grey(g: f64) -> (Vec3, f32) {
    if g.is_nan() || g == f64::NEG_INFINITY {
        return (Vec3::ZERO, 0.0);
    }
    let g = g.clamp(0.0, 1.0) as f32;
    (Vec3::splat(g), g)
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
