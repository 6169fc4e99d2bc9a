//! Pre-integrated transfer functions (Engel, Kraus & Ertl 2001; Röttger et al.; the
//! survey's §7 on transfer functions: "pre-computing a 2D table that stores the
//! analytical volume rendering integration for all possible density pairs
//! `(d_f, d_b)`").
//!
//! Between two consecutive ray samples the value is taken to vary linearly from
//! `s_front` to `s_back` over one ray step. [`PreIntegrated`] tabulates, for a grid
//! of `(s_front, s_back)` pairs, the front-to-back composited colour and opacity of
//! that segment classified by the transfer function at every value it passes, so a
//! narrow peak of the transfer function between two samples is not missed (the slab
//! artefacts of post-classification at large steps). The renderer looks a segment up
//! by bilinear interpolation in the table.
//!
//! **The integral of one entry.** With `τ(s) = −ln(1 − α(s))` the extinction per
//! reference step of the transfer function's opacity `α(s)`, a segment of length `e`
//! reference steps has transmittance `exp(−e·∫₀¹ τ(s(x)) dx)` and premultiplied colour
//! `∫₀¹ C(s(x))·e·τ(s(x))·exp(−e·∫₀ˣ τ) dx`. Each entry evaluates it by compositing
//! `M = 2·|j − i|` sub-segments (one for a constant segment, where compositing is
//! exact) whose values are the transfer function at their mid-points: the mid-points
//! fall on a lattice twice as fine as the table, precomputed once. The result is what
//! front-to-back compositing at a step of `e/M` reference steps would give, the brute
//! force the tests compare against.
//!
//! **Domain.** The table spans the transfer function's control points and the field's
//! value range over its bounds (where finite), so a segment whose values lie outside
//! the control points is integrated with the clamped end colours over the right
//! fraction of its length. Values outside the table are clamped to it.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use crate::TransferFunction;

/// Table entries per axis.
pub const PRE_INTEGRATION_TABLE_SIZE: usize = 256;

/// Sub-segments per table cell of value change.
const SUB_STEPS_PER_CELL: usize = 2;

/// A pre-integrated transfer function: the colour and opacity of a ray segment of
/// one fixed length as a function of the values at its two ends. See the module doc.
#[derive(Clone, Debug, PartialEq)]
pub struct PreIntegrated {
    lo: f64,
    hi: f64,
    n: usize,
    /// `(n − 1)/(hi − lo)`: table index per unit value.
    scale: f64,
    /// Row-major `[front][back]`: premultiplied RGB and opacity.
    table: Vec<Vec4>,
    /// Summed-area table of "opacity > 0" flags, `(n + 1)²`, for [`PreIntegrated::max_alpha`].
    nonzero: Vec<u32>,
}

impl PreIntegrated {
    /// The table of `tf` over the value domain `[lo, hi]` (widened to contain the
    /// control points; a degenerate domain is widened by 1) for a segment of
    /// `step_over_reference` reference steps (`Sampling::step_voxels /
    /// Sampling::reference_step_voxels`), with `size ≥ 2` entries per axis. Rows are
    /// built in parallel; every entry is a function of its indices alone.
    pub fn new(tf: &TransferFunction, domain: (f64, f64), step_over_reference: f64, size: usize) -> Self {
        let n = size.max(2);
        let (mut lo, mut hi) = tf.points().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (v, _)| {
            (a.min(v), b.max(v))
        });
        if domain.0.is_finite() && domain.1.is_finite() {
            lo = lo.min(domain.0);
            hi = hi.max(domain.1);
        }
        if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) || !(hi - lo).is_finite() {
            lo -= 0.5;
            hi += 0.5;
        }
        let cell = (hi - lo) / (n - 1) as f64;
        let value = |i: usize| if i + 1 == n { hi } else { lo + i as f64 * cell };
        // The transfer function at the table's nodes and at the mid-points of a lattice
        // `SUB_STEPS_PER_CELL` times finer: (straight colour, −ln(1 − α)).
        let classify = |v: f64| {
            let c = tf.eval(v);
            let tau = -(1.0 - c.w as f64).max(1e-12).ln();
            (c.truncate(), tau)
        };
        let nodes: Vec<(Vec3, f64)> = (0..n).map(|i| classify(value(i))).collect();
        let fine = cell / SUB_STEPS_PER_CELL as f64;
        let mids: Vec<(Vec3, f64)> = (0..(n - 1) * SUB_STEPS_PER_CELL)
            .map(|k| classify(lo + (k as f64 + 0.5) * fine))
            .collect();
        let e = step_over_reference;
        let table: Vec<Vec4> = (0..n * n)
            .into_par_iter()
            .map(|lin| {
                let (i, j) = (lin / n, lin % n);
                if i == j {
                    let (c, tau) = nodes[i];
                    let alpha = 1.0 - (-e * tau).exp();
                    return (c * alpha as f32).extend(alpha as f32);
                }
                let m = SUB_STEPS_PER_CELL * i.abs_diff(j);
                let sub = e / m as f64;
                let (mut c, mut a) = (Vec3::ZERO, 0.0f64);
                for k in 0..m {
                    let idx = if j > i {
                        SUB_STEPS_PER_CELL * i + k
                    } else {
                        SUB_STEPS_PER_CELL * i - k - 1
                    };
                    let (ck, tau) = mids[idx];
                    if tau > 0.0 {
                        let alpha = 1.0 - (-sub * tau).exp();
                        let w = (1.0 - a) * alpha;
                        c += ck * w as f32;
                        a += w;
                    }
                }
                c.extend(a.min(1.0) as f32)
            })
            .collect();
        let mut nonzero = vec![0u32; (n + 1) * (n + 1)];
        for i in 0..n {
            for j in 0..n {
                let f = (table[i * n + j].w > 0.0) as u32;
                nonzero[(i + 1) * (n + 1) + j + 1] =
                    f + nonzero[i * (n + 1) + j + 1] + nonzero[(i + 1) * (n + 1) + j] - nonzero[i * (n + 1) + j];
            }
        }
        PreIntegrated {
            lo,
            hi,
            n,
            scale: (n - 1) as f64 / (hi - lo),
            table,
            nonzero,
        }
    }

    /// The value domain `[lo, hi]` the table spans.
    pub fn domain(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    /// Continuous table coordinate of `v`, clamped to the table.
    #[inline]
    fn coord(&self, v: f64) -> f64 {
        let x = (v - self.lo) * self.scale;
        if x > 0.0 {
            x.min((self.n - 1) as f64)
        } else {
            0.0
        }
    }

    /// Premultiplied RGB and opacity of the segment from `front` to `back`
    /// (bilinear in the table). NaN values give a transparent segment.
    #[inline]
    pub fn lookup(&self, front: f64, back: f64) -> Vec4 {
        if front.is_nan() || back.is_nan() {
            return Vec4::ZERO;
        }
        let (x, y) = (self.coord(front), self.coord(back));
        let (i, j) = ((x as usize).min(self.n - 2), (y as usize).min(self.n - 2));
        let (fx, fy) = ((x - i as f64) as f32, (y - j as f64) as f32);
        let row = i * self.n + j;
        let (a, b) = (self.table[row], self.table[row + 1]);
        let (c, d) = (self.table[row + self.n], self.table[row + self.n + 1]);
        let top = a + (b - a) * fy;
        let bottom = c + (d - c) * fy;
        (top + (bottom - top) * fx).clamp(Vec4::ZERO, Vec4::ONE)
    }

    /// A conservative maximum of the opacity of segments whose both ends lie in
    /// `[lo, hi]`: `0` only if every such [`lookup`](Self::lookup) is transparent
    /// (the table entries the lookups interpolate are all zero). Empty-space
    /// skipping with pre-integration skips cells where it is `0`.
    pub fn max_alpha(&self, lo: f64, hi: f64) -> f32 {
        if lo.is_nan() || hi.is_nan() {
            return 1.0;
        }
        let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        let i0 = (self.coord(lo) as usize).min(self.n - 2);
        let i1 = (self.coord(hi).ceil() as usize).clamp(i0 + 1, self.n - 1);
        // Entries [i0, i1]² inclusive.
        let w = self.n + 1;
        let s = |i: usize, j: usize| self.nonzero[i * w + j];
        let count = s(i1 + 1, i1 + 1) + s(i0, i0) - s(i0, i1 + 1) - s(i1 + 1, i0);
        if count > 0 {
            1.0
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sharp peak: red, opacity up to 0.9, only within ±0.02 of 0.5 (ten table
    /// cells of the default table).
    fn spike() -> TransferFunction {
        TransferFunction::new(vec![
            (0.0, Vec4::ZERO),
            (0.48, Vec4::new(1.0, 0.0, 0.0, 0.0)),
            (0.5, Vec4::new(1.0, 0.0, 0.0, 0.9)),
            (0.52, Vec4::new(1.0, 0.0, 0.0, 0.0)),
            (1.0, Vec4::ZERO),
        ])
        .unwrap()
    }

    /// Front-to-back compositing of the segment from `a` to `b` of `e` reference
    /// steps with `m` mid-point sub-steps, each opacity corrected for its length.
    fn brute(tf: &TransferFunction, a: f64, b: f64, e: f64, m: usize) -> Vec4 {
        let (mut c, mut al) = (Vec3::ZERO, 0.0f64);
        for k in 0..m {
            let v = a + (b - a) * (k as f64 + 0.5) / m as f64;
            let s = tf.eval(v);
            let alpha = 1.0 - (1.0 - s.w as f64).powf(e / m as f64);
            c += s.truncate() * ((1.0 - al) * alpha) as f32;
            al += (1.0 - al) * alpha;
        }
        c.extend(al as f32)
    }

    #[test]
    fn constant_segments_equal_post_classification() {
        let tf = spike();
        let t = PreIntegrated::new(&tf, (0.0, 1.0), 2.0, 101);
        for v in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let got = t.lookup(v, v);
            let s = tf.eval(v);
            let alpha = 1.0 - (1.0 - s.w).powf(2.0);
            let want = (s.truncate() * alpha).extend(alpha);
            assert!((got - want).abs().max_element() < 1e-5, "{v}: {got} vs {want}");
        }
    }

    #[test]
    fn segments_across_a_sharp_peak_match_fine_integration() {
        // Tolerance: 2e-2 on every channel, from the table's bilinear interpolation
        // (cell 1/255 of a peak 0.04 wide) and its two sub-steps per cell.
        let tf = spike();
        let t = PreIntegrated::new(&tf, (0.0, 1.0), 4.0, PRE_INTEGRATION_TABLE_SIZE);
        for (a, b) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (0.3, 0.7),
            (0.45, 0.55),
            (0.2, 0.4),
            (0.5, 0.53),
            (0.49, 0.51),
        ] {
            let got = t.lookup(a, b);
            let want = brute(&tf, a, b, 4.0, 20_000);
            assert!((got - want).abs().max_element() < 2e-2, "({a}, {b}): {got} vs {want}");
        }
        // Post-classification of the ends alone misses the peak entirely.
        assert_eq!(tf.eval(0.3).w + tf.eval(0.7).w, 0.0);
        assert!(t.lookup(0.3, 0.7).w > 0.2);
    }

    #[test]
    fn max_alpha_is_conservative() {
        let tf = spike();
        let t = PreIntegrated::new(&tf, (0.0, 1.0), 1.0, 64);
        assert_eq!(t.max_alpha(0.0, 0.4), 0.0);
        assert_eq!(t.max_alpha(0.6, 1.0), 0.0);
        assert_eq!(t.max_alpha(0.3, 0.7), 1.0);
        for k in 0..=300 {
            for l in 0..=30 {
                let (a, b) = (k as f64 / 300.0, l as f64 / 30.0);
                let (lo, hi) = (a.min(b), a.max(b));
                if t.max_alpha(lo, hi) == 0.0 {
                    assert_eq!(t.lookup(a, b).w, 0.0, "({a}, {b})");
                    assert_eq!(t.lookup(b, a).w, 0.0, "({b}, {a})");
                }
            }
        }
    }
}
