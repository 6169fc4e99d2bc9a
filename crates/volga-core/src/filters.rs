//! Reconstruction filters and their derivatives (survey §5): the weights [`Sampled`]
//! applies to the voxels around a point, and the two ways it takes gradients.
//!
//! Every filter here is separable: a 3D weight is the product of 1D weights along the
//! index axes, evaluated at the point's fractions `f ∈ [0, 1)³` inside the cell of its
//! base voxel `floor(index_pos)`. The cubic filters read the 4×4×4 block
//! `base − 1 ..= base + 2` (`block[x + 4y + 16z]`, x fastest).
//!
//! [`Sampled`]: crate::Sampled

use glam::DVec3;

/// Reconstruction filter used between voxel centres (survey §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Filter {
    /// The value of the voxel whose cell contains the point (half-open rule).
    Nearest,
    /// Trilinear interpolation of the eight surrounding voxel centres.
    #[default]
    Trilinear,
    /// Cubic Catmull–Rom spline (Keys' cubic convolution with a = −½): interpolating
    /// (passes through the voxel values), C¹, reads 4×4×4 voxels; may overshoot the
    /// voxel values by up to (1.25³ − 1)/2 of their spread.
    CatmullRom,
    /// Cubic B-spline: approximating (smooths the voxel values), C², reads 4×4×4
    /// voxels; its weights are non-negative, so it never leaves the voxels' range.
    BSpline,
}

impl Filter {
    /// Every filter, in the order the experiments show them.
    pub const ALL: [Filter; 4] = [Filter::Nearest, Filter::Trilinear, Filter::CatmullRom, Filter::BSpline];

    /// A short lowercase name (`nearest`, `trilinear`, `catmull-rom`, `b-spline`).
    pub fn name(self) -> &'static str {
        match self {
            Filter::Nearest => "nearest",
            Filter::Trilinear => "trilinear",
            Filter::CatmullRom => "catmull-rom",
            Filter::BSpline => "b-spline",
        }
    }

    /// Whether the filter is one of the 4×4×4 cubics.
    pub fn is_cubic(self) -> bool {
        matches!(self, Filter::CatmullRom | Filter::BSpline)
    }

    /// How far (in voxel spacings) beyond the outermost voxel centres a reconstruction
    /// can still differ from the background: 1 for nearest and trilinear, 2 for cubics.
    pub fn reach_voxels(self) -> f64 {
        if self.is_cubic() {
            2.0
        } else {
            1.0
        }
    }

    /// The largest sum of absolute 3D weights: a reconstruction lies within
    /// `mid ± overshoot·(max − min)/2` of the values it combines (1 for filters with
    /// non-negative weights; `1.25³` for Catmull–Rom, whose 1D weights at `t = ½` are
    /// −1/16, 9/16, 9/16, −1/16).
    pub fn overshoot(self) -> f64 {
        match self {
            Filter::CatmullRom => 1.25 * 1.25 * 1.25,
            _ => 1.0,
        }
    }
}

/// How [`Sampled`](crate::Sampled) takes gradients (survey §5's gradient estimators).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum GradientMethod {
    /// Central differences of the reconstruction one voxel apart along each index axis,
    /// divided by the world distance.
    #[default]
    CentralDifference,
    /// The filter's own analytic derivative (the survey's third method: the derivative
    /// of the reconstruction kernel convolved with the voxels). Zero for nearest (a
    /// piecewise-constant reconstruction), piecewise constant along each axis for
    /// trilinear, continuous for the cubics.
    Analytic,
}

impl GradientMethod {
    /// Both methods, in the order the experiments show them (central differences first).
    pub const ALL: [GradientMethod; 2] = [GradientMethod::CentralDifference, GradientMethod::Analytic];

    /// A short lowercase name (`central`, `analytic`).
    pub fn name(self) -> &'static str {
        match self {
            GradientMethod::CentralDifference => "central",
            GradientMethod::Analytic => "analytic",
        }
    }
}

/// The four 1D weights of voxels `−1, 0, 1, 2` at fraction `t` for a cubic filter.
#[inline(always)]
pub(crate) fn cubic_weights(filter: Filter, t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    match filter {
        Filter::CatmullRom => [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ],
        _ => {
            let s = 1.0 - t;
            [
                s * s * s / 6.0,
                (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
                (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
                t3 / 6.0,
            ]
        }
    }
}

/// The derivatives `d/dt` of [`cubic_weights`].
#[inline(always)]
pub(crate) fn cubic_derivatives(filter: Filter, t: f64) -> [f64; 4] {
    let t2 = t * t;
    match filter {
        Filter::CatmullRom => [
            0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
            0.5 * (9.0 * t2 - 10.0 * t),
            0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
            0.5 * (3.0 * t2 - 2.0 * t),
        ],
        _ => {
            let s = 1.0 - t;
            [
                -0.5 * s * s,
                0.5 * (3.0 * t2 - 4.0 * t),
                0.5 * (-3.0 * t2 + 2.0 * t + 1.0),
                0.5 * t2,
            ]
        }
    }
}

/// `Σ wx[i]·wy[j]·wz[k]·block[i + 4j + 16k]`, summed x innermost.
#[inline(always)]
pub(crate) fn separable_sum(block: &[f32; 64], wx: &[f64; 4], wy: &[f64; 4], wz: &[f64; 4]) -> f64 {
    let mut sum = 0.0;
    for (k, wz) in wz.iter().enumerate() {
        let mut plane = 0.0;
        for (j, wy) in wy.iter().enumerate() {
            let row = &block[4 * j + 16 * k..4 * j + 16 * k + 4];
            let line = wx[0] * row[0] as f64 + wx[1] * row[1] as f64 + wx[2] * row[2] as f64 + wx[3] * row[3] as f64;
            plane += wy * line;
        }
        sum += wz * plane;
    }
    sum
}

#[inline(always)]
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

#[inline(always)]
fn at(b: &[f32; 64], x: usize, y: usize, z: usize) -> f64 {
    b[x + 4 * y + 16 * z] as f64
}

/// Bilinear-by-linear interpolation over the cell `(1..=2)³` of the block of a
/// per-voxel quantity `d(x, y, z)`, at fractions `(u, v, w)`.
#[inline(always)]
fn trilerp_of(d: impl Fn(usize, usize, usize) -> f64, u: f64, v: f64, w: f64) -> f64 {
    let x00 = lerp(d(1, 1, 1), d(2, 1, 1), u);
    let x10 = lerp(d(1, 2, 1), d(2, 2, 1), u);
    let x01 = lerp(d(1, 1, 2), d(2, 1, 2), u);
    let x11 = lerp(d(1, 2, 2), d(2, 2, 2), u);
    lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
}

/// Central differences one voxel apart, along each index axis, of the trilinear
/// reconstruction at fractions `f` of the block's voxel `(1, 1, 1)`, divided by the
/// world distance `2·spacing`: per axis, the differences `v[i + 1] − v[i − 1]` at the
/// cell's corners, interpolated like a trilinear sample (equal to
/// `(T(p + e) − T(p − e)) / 2h` up to rounding; the one formula every path uses).
#[inline(always)]
pub(crate) fn trilinear_central_gradient(b: &[f32; 64], f: DVec3, spacing: DVec3) -> DVec3 {
    let dx = |x: usize, y: usize, z: usize| at(b, x + 1, y, z) - at(b, x - 1, y, z);
    let dy = |x: usize, y: usize, z: usize| at(b, x, y + 1, z) - at(b, x, y - 1, z);
    let dz = |x: usize, y: usize, z: usize| at(b, x, y, z + 1) - at(b, x, y, z - 1);
    DVec3::new(
        trilerp_of(dx, f.x, f.y, f.z) / (2.0 * spacing.x),
        trilerp_of(dy, f.x, f.y, f.z) / (2.0 * spacing.y),
        trilerp_of(dz, f.x, f.y, f.z) / (2.0 * spacing.z),
    )
}

/// The exact derivative of the trilinear reconstruction inside the cell (one-sided
/// differences across the cell, interpolated along the other two axes), in world units.
#[inline(always)]
pub(crate) fn trilinear_analytic_gradient(b: &[f32; 64], f: DVec3, spacing: DVec3) -> DVec3 {
    let bilerp =
        |d: &dyn Fn(usize, usize) -> f64, u: f64, v: f64| lerp(lerp(d(1, 1), d(2, 1), u), lerp(d(1, 2), d(2, 2), u), v);
    let gx = bilerp(&|y, z| at(b, 2, y, z) - at(b, 1, y, z), f.y, f.z);
    let gy = bilerp(&|x, z| at(b, x, 2, z) - at(b, x, 1, z), f.x, f.z);
    let gz = bilerp(&|x, y| at(b, x, y, 2) - at(b, x, y, 1), f.x, f.y);
    DVec3::new(gx / spacing.x, gy / spacing.y, gz / spacing.z)
}

/// The exact derivative of a cubic reconstruction: each axis' weights replaced by
/// their derivatives, in world units.
#[inline]
pub(crate) fn cubic_analytic_gradient(filter: Filter, b: &[f32; 64], f: DVec3, spacing: DVec3) -> DVec3 {
    let (wx, wy, wz) = (
        cubic_weights(filter, f.x),
        cubic_weights(filter, f.y),
        cubic_weights(filter, f.z),
    );
    let (dx, dy, dz) = (
        cubic_derivatives(filter, f.x),
        cubic_derivatives(filter, f.y),
        cubic_derivatives(filter, f.z),
    );
    DVec3::new(
        separable_sum(b, &dx, &wy, &wz) / spacing.x,
        separable_sum(b, &wx, &dy, &wz) / spacing.y,
        separable_sum(b, &wx, &wy, &dz) / spacing.z,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Partition of unity, interpolation (Catmull–Rom), the B-spline's non-negativity,
    /// derivatives against finite differences, and the Catmull–Rom overshoot bound.
    #[test]
    fn cubic_weights_have_their_defining_properties() {
        for filter in [Filter::CatmullRom, Filter::BSpline] {
            for i in 0..=64 {
                let t = i as f64 / 64.0;
                let w = cubic_weights(filter, t);
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15, "{filter:?} {t}");
                let d = cubic_derivatives(filter, t);
                assert!(d.iter().sum::<f64>().abs() < 1e-14, "{filter:?} {t}");
                let h = 1e-6;
                let (wp, wm) = (cubic_weights(filter, t + h), cubic_weights(filter, t - h));
                for k in 0..4 {
                    assert!(((wp[k] - wm[k]) / (2.0 * h) - d[k]).abs() < 1e-8, "{filter:?} {t} {k}");
                }
                // Linear functions are reproduced: Σ w_k·(k − 1) = t.
                let mean: f64 = w.iter().enumerate().map(|(k, w)| w * (k as f64 - 1.0)).sum();
                assert!((mean - t).abs() < 1e-14, "{filter:?} {t}");
                let abs_sum: f64 = w.iter().map(|w| w.abs()).sum();
                assert!(abs_sum <= filter.overshoot().cbrt() + 1e-15, "{filter:?} {t}");
                if filter == Filter::BSpline {
                    assert!(w.iter().all(|w| *w >= 0.0));
                }
            }
        }
        assert_eq!(cubic_weights(Filter::CatmullRom, 0.0), [0.0, 1.0, 0.0, 0.0]);
        let half = cubic_weights(Filter::CatmullRom, 0.5);
        assert_eq!(half, [-1.0 / 16.0, 9.0 / 16.0, 9.0 / 16.0, -1.0 / 16.0]);
        let b0 = cubic_weights(Filter::BSpline, 0.0);
        assert!((b0[0] - 1.0 / 6.0).abs() < 1e-15 && (b0[1] - 4.0 / 6.0).abs() < 1e-15);
    }
}
