use glam::Vec4;

use crate::RenderError;

/// A piecewise-linear map from field value to straight (un-premultiplied) RGBA in
/// \[0, 1\] — the density-to-colour mapping `C_o`, α of survey eq. 15, applied after
/// interpolation (post-classification).
///
/// Opacities are defined for a ray step of
/// [`Sampling::reference_step_voxels`](crate::Sampling::reference_step_voxels);
/// the renderer corrects them for the actual step.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    /// Strictly increasing control-point values.
    values: Vec<f64>,
    rgba: Vec<Vec4>,
    /// The `f32` form the packed path classifies with (`None` if not representable).
    lanes: Option<Box<crate::packet::TransferLanes>>,
}

impl TransferFunction {
    /// Builds the function from `(value, rgba)` control points in any order (they
    /// are sorted here).
    ///
    /// Errors: an empty list, a non-finite value, an rgba channel outside \[0, 1\]
    /// (or NaN), two points with the same value.
    pub fn new(mut points: Vec<(f64, Vec4)>) -> Result<Self, RenderError> {
        if points.is_empty() {
            return Err(RenderError::EmptyTransferFunction);
        }
        for &(value, rgba) in &points {
            if !value.is_finite() {
                return Err(RenderError::NonFiniteTransferValue(value));
            }
            if !rgba.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
                return Err(RenderError::TransferColourOutOfRange {
                    value,
                    rgba: rgba.to_array(),
                });
            }
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        if let Some(w) = points.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(RenderError::DuplicateTransferValue(w[0].0));
        }
        let values: Vec<f64> = points.iter().map(|p| p.0).collect();
        let rgba: Vec<Vec4> = points.iter().map(|p| p.1).collect();
        let lanes = crate::packet::TransferLanes::new(&values, &rgba).map(Box::new);
        Ok(TransferFunction { values, rgba, lanes })
    }

    /// The `f32` segments of the packed path.
    pub(crate) fn lanes(&self) -> Option<&crate::packet::TransferLanes> {
        self.lanes.as_deref()
    }

    /// The control points, sorted by value.
    pub fn points(&self) -> impl Iterator<Item = (f64, Vec4)> + '_ {
        self.values.iter().copied().zip(self.rgba.iter().copied())
    }

    /// RGBA at `value`: linear between neighbouring control points, the end points'
    /// RGBA outside their range. NaN maps to fully transparent black.
    #[inline]
    pub fn eval(&self, value: f64) -> Vec4 {
        let n = self.values.len();
        if value.is_nan() {
            return Vec4::ZERO;
        }
        if value <= self.values[0] {
            return self.rgba[0];
        }
        if value >= self.values[n - 1] {
            return self.rgba[n - 1];
        }
        // values[0] < value < values[n-1], so 1 <= k <= n-1.
        let k = self.values.partition_point(|v| *v <= value);
        let (v0, v1) = (self.values[k - 1], self.values[k]);
        // Halved operands cannot overflow for any finite control points.
        let f = (value * 0.5 - v0 * 0.5) / (v1 * 0.5 - v0 * 0.5);
        let f = if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) } as f32;
        let (a, b) = (self.rgba[k - 1], self.rgba[k]);
        (a + (b - a) * f).clamp(Vec4::ZERO, Vec4::ONE)
    }

    /// A conservative maximum of the opacity over values in `[lo, hi]` (order of the
    /// bounds does not matter): the larger of the control-point alphas inside and
    /// the alphas evaluated at both ends. Exact for piecewise-linear functions, and
    /// `0` only if [`eval`](Self::eval) returns alpha `0` for every value in range.
    /// A NaN bound gives the maximum over all control points.
    pub fn max_alpha(&self, lo: f64, hi: f64) -> f32 {
        if lo.is_nan() || hi.is_nan() {
            return self.rgba.iter().map(|c| c.w).fold(0.0, f32::max);
        }
        let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        let first = self.values.partition_point(|v| *v < lo);
        let last = self.values.partition_point(|v| *v <= hi);
        let inside = self.rgba[first..last.max(first)].iter().map(|c| c.w);
        inside.fold(self.eval(lo).w.max(self.eval(hi).w), f32::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn tf() -> TransferFunction {
        TransferFunction::new(vec![
            (1.0, Vec4::new(1.0, 0.0, 0.0, 1.0)),
            (0.0, Vec4::new(0.0, 0.0, 1.0, 0.0)),
            (0.5, Vec4::new(0.0, 1.0, 0.0, 0.5)),
        ])
        .unwrap()
    }

    #[test]
    fn interpolates_and_clamps() {
        let t = tf();
        assert_eq!(t.points().map(|p| p.0).collect::<Vec<_>>(), vec![0.0, 0.5, 1.0]);
        assert_eq!(t.eval(-3.0), Vec4::new(0.0, 0.0, 1.0, 0.0));
        assert_eq!(t.eval(0.0), Vec4::new(0.0, 0.0, 1.0, 0.0));
        assert_eq!(t.eval(0.5), Vec4::new(0.0, 1.0, 0.0, 0.5));
        assert_eq!(t.eval(7.0), Vec4::new(1.0, 0.0, 0.0, 1.0));
        assert_eq!(t.eval(f64::INFINITY), Vec4::new(1.0, 0.0, 0.0, 1.0));
        assert_eq!(t.eval(f64::NAN), Vec4::ZERO);
        let m = t.eval(0.25);
        assert!((m - Vec4::new(0.0, 0.5, 0.5, 0.25)).abs().max_element() < 1e-6);
        let m = t.eval(0.75);
        assert!((m - Vec4::new(0.5, 0.5, 0.0, 0.75)).abs().max_element() < 1e-6);
        let single = TransferFunction::new(vec![(2.0, Vec4::splat(0.3))]).unwrap();
        assert_eq!(single.eval(-1e300), Vec4::splat(0.3));
        assert_eq!(single.eval(1e300), Vec4::splat(0.3));
    }

    #[test]
    fn max_alpha_is_conservative() {
        let t = TransferFunction::new(vec![
            (0.0, Vec4::new(0.0, 0.0, 0.0, 0.0)),
            (0.2, Vec4::new(0.0, 0.0, 0.0, 0.0)),
            (0.4, Vec4::new(1.0, 1.0, 1.0, 0.8)),
            (0.6, Vec4::new(1.0, 1.0, 1.0, 0.1)),
        ])
        .unwrap();
        assert_eq!(t.max_alpha(-1.0, 0.2), 0.0);
        assert_eq!(t.max_alpha(0.05, 0.15), 0.0);
        assert!(t.max_alpha(0.1, 0.3) > 0.0);
        assert!((t.max_alpha(0.1, 0.3) - 0.4).abs() < 1e-6);
        assert_eq!(t.max_alpha(0.3, 0.7), 0.8);
        assert_eq!(t.max_alpha(0.7, 0.3), 0.8);
        assert!((t.max_alpha(0.5, 0.55) - 0.45).abs() < 1e-6);
        assert_eq!(t.max_alpha(0.9, 5.0), 0.1);
        assert_eq!(t.max_alpha(f64::NEG_INFINITY, f64::INFINITY), 0.8);
        assert_eq!(t.max_alpha(f64::NAN, 0.0), 0.8);
    }

    #[test]
    fn rejects_bad_points() {
        assert_eq!(TransferFunction::new(vec![]), Err(RenderError::EmptyTransferFunction));
        assert!(matches!(
            TransferFunction::new(vec![(f64::NAN, Vec4::ZERO)]),
            Err(RenderError::NonFiniteTransferValue(_))
        ));
        assert!(matches!(
            TransferFunction::new(vec![(f64::INFINITY, Vec4::ZERO)]),
            Err(RenderError::NonFiniteTransferValue(_))
        ));
        for bad in [
            Vec4::new(1.5, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 0.0, -0.1),
            Vec4::splat(f32::NAN),
        ] {
            assert!(matches!(
                TransferFunction::new(vec![(0.0, bad)]),
                Err(RenderError::TransferColourOutOfRange { .. })
            ));
        }
        assert_eq!(
            TransferFunction::new(vec![(0.5, Vec4::ZERO), (0.1, Vec4::ONE), (0.5, Vec4::ONE)]),
            Err(RenderError::DuplicateTransferValue(0.5))
        );
        // Extreme but finite values interpolate without overflow.
        let t = TransferFunction::new(vec![(-f64::MAX, Vec4::ZERO), (f64::MAX, Vec4::ONE)]).unwrap();
        assert!((t.eval(0.0) - Vec4::splat(0.5)).abs().max_element() < 1e-6);
    }

    proptest! {
        #[test]
        fn eval_stays_in_range_and_under_max_alpha(
            pts in proptest::collection::vec((-10.0f64..10.0, 0.0f32..=1.0), 1..8),
            a in -12.0f64..12.0,
            b in -12.0f64..12.0,
            s in 0.0f64..=1.0,
        ) {
            let mut seen = Vec::new();
            let points: Vec<(f64, Vec4)> = pts
                .into_iter()
                .filter(|(v, _)| { let new = !seen.contains(v); seen.push(*v); new })
                .map(|(v, al)| (v, Vec4::new(al, 1.0 - al, 0.5, al)))
                .collect();
            let t = TransferFunction::new(points).unwrap();
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            let v = lo + (hi - lo) * s;
            let c = t.eval(v);
            prop_assert!(c.cmpge(Vec4::ZERO).all() && c.cmple(Vec4::ONE).all());
            prop_assert!(c.w <= t.max_alpha(lo, hi));
        }
    }
}
