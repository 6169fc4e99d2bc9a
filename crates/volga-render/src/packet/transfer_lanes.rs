//! A 1D transfer function as `f32` lane tables for the packed loop.

use glam::Vec4;

use super::LANES;

/// Most control points [`TransferLanes`] takes (more classify on the general path).
pub(super) const MAX_LANE_POINTS: usize = 8;

/// A 1D transfer function in `f32` for the packed loop, as tables of at most eight
/// entries: with control values `c₀ < … < c_{n−1}`, colours `q₀ … q_{n−1}` and slopes
/// `s_k = (q_{k+1} − q_k) / (c_{k+1} − c_k)`, a value `v` is clamped to `[c₀, c_{n−1}]`,
/// its segment `k` is the number of control values `c₁ … c_{n−1}` at most `v` (the
/// last, `k = n − 1`, is the constant `q_{n−1}` with slope 0), and
///
/// `tf(v) = q_k + s_k · (v − c_k)`,
///
/// the same piecewise-linear function (constant below `c₀` and from `c_{n−1}` on) as
/// [`TransferFunction::eval`](crate::TransferFunction::eval). Every lane runs the same
/// instructions whatever segment its value falls in: `n − 1` comparisons, then one
/// table look-up per quantity (in AVX2 a lane permutation, [`TransferLanes::classify_avx2`]).
/// Every control point's own value gives its colour exactly (`q_k + s_k · 0`), so a
/// value in a segment transparent at both ends is transparent exactly, as empty-space
/// skipping assumes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TransferLanes {
    /// Control points, `1 ..= MAX_LANE_POINTS`.
    pub(super) points: usize,
    /// The control values (entries from `points` on repeat the last).
    pub(super) value: [f32; MAX_LANE_POINTS],
    /// Per channel (RGBA): the colour at each control value.
    pub(super) colour: [[f32; MAX_LANE_POINTS]; 4],
    /// Per channel: the slope of the segment starting at each control value (0 from
    /// the last on).
    pub(super) slope: [[f32; MAX_LANE_POINTS]; 4],
}

impl TransferLanes {
    /// The `f32` form of sorted control points, or `None` if there are more than
    /// [`MAX_LANE_POINTS`] or a value or a segment's slope is not finite in `f32`, or
    /// two values round to one `f32` (the general path then classifies).
    pub(crate) fn new(values: &[f64], rgba: &[Vec4]) -> Option<TransferLanes> {
        let n = values.len();
        if n == 0 || n > MAX_LANE_POINTS || values.iter().any(|v| !(*v as f32).is_finite()) {
            return None;
        }
        let mut lanes = TransferLanes {
            points: n,
            value: [values[n - 1] as f32; MAX_LANE_POINTS],
            colour: [[0.0; MAX_LANE_POINTS]; 4],
            slope: [[0.0; MAX_LANE_POINTS]; 4],
        };
        for k in 0..n {
            lanes.value[k] = values[k] as f32;
            for (ch, colour) in lanes.colour.iter_mut().enumerate() {
                colour[k] = rgba[k][ch];
            }
            if k + 1 < n {
                let (lo, hi) = (values[k] as f32, values[k + 1] as f32);
                let slope = ((rgba[k + 1] - rgba[k]).as_dvec4() / (values[k + 1] - values[k])).as_vec4();
                if !(hi > lo && slope.is_finite()) {
                    return None;
                }
                for ch in 0..4 {
                    lanes.slope[ch][k] = slope[ch];
                }
            }
        }
        Some(lanes)
    }

    /// RGBA (unclamped) of eight values, per channel. NaN values classify as `c₀`.
    // Index loops over the lanes on purpose: they are what the compiler vectorizes.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    pub(super) fn classify(&self, v: &[f32; LANES]) -> [[f32; LANES]; 4] {
        let (first, last) = (self.value[0], self.value[self.points - 1]);
        let mut rgba = [[0.0f32; LANES]; 4];
        for l in 0..LANES {
            // `f32::max` returns the other operand for NaN, as `maxps` does.
            let x = v[l].max(first).min(last);
            let mut k = 0;
            for inner in 1..self.points {
                k += (x >= self.value[inner]) as usize;
            }
            let d = x - self.value[k];
            for ch in 0..4 {
                rgba[ch][l] = self.colour[ch][k] + self.slope[ch][k] * d;
            }
        }
        rgba
    }

    /// [`TransferLanes::classify`] in AVX2 vectors, the table look-ups as lane
    /// permutations: the same operations, the same bits.
    ///
    /// # Safety
    /// As [`PackedVolume::sample_lanes_avx2`]: the CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) unsafe fn classify_avx2(&self, v: &[f32; LANES]) -> [[f32; LANES]; 4] {
        use std::arch::x86_64::*;
        // SAFETY: every load and store below is of an `[f32; 8]`, 32 bytes, unaligned.
        unsafe {
            let x = _mm256_loadu_ps(v.as_ptr());
            // `maxps` returns its second operand when either is NaN: NaN → `c₀`.
            let x = _mm256_max_ps(x, _mm256_set1_ps(self.value[0]));
            let x = _mm256_min_ps(x, _mm256_set1_ps(self.value[self.points - 1]));
            let mut k = _mm256_setzero_si256();
            for inner in 1..self.points {
                let at_least = _mm256_cmp_ps::<_CMP_GE_OQ>(x, _mm256_set1_ps(self.value[inner]));
                // A true comparison is all ones, −1 as an integer.
                k = _mm256_sub_epi32(k, _mm256_castps_si256(at_least));
            }
            let table = |t: &[f32; LANES]| _mm256_permutevar8x32_ps(_mm256_loadu_ps(t.as_ptr()), k);
            let d = _mm256_sub_ps(x, table(&self.value));
            let mut rgba = [[0.0f32; LANES]; 4];
            for ((out, colour), slope) in rgba.iter_mut().zip(&self.colour).zip(&self.slope) {
                let c = _mm256_add_ps(table(colour), _mm256_mul_ps(table(slope), d));
                _mm256_storeu_ps(out.as_mut_ptr(), c);
            }
            rgba
        }
    }
}
