//! A ring torus: the solid within `minor_radius` of a circle of `major_radius`.
//!
//! Added in its own file as the worked example of a new shape: implementing
//! [`SignedDistance`] is all it takes for the voxelizers (`voxelize_shapes`) and, through
//! [`crate::FilteredDensity`] / [`crate::DistanceField`], the raycaster to handle it.

use glam::DVec3;
use volga_core::Aabb;

use crate::{InvalidShape, SignedDistance};

/// A ring torus around `axis` through `center`: exact signed distance
/// `‖(ρ − R, h)‖ − r`, with `h` the height along the axis and `ρ` the distance from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Torus {
    center: DVec3,
    axis: DVec3,
    major_radius: f64,
    minor_radius: f64,
}

impl Torus {
    /// `axis` need not be unit length (non-zero); `0 < minor_radius < major_radius` (a
    /// ring torus: with `r ≥ R` the tube overlaps itself round the axis, and
    /// `‖(ρ − R, h)‖ − r` is no longer the exact distance inside).
    pub fn new(center: DVec3, axis: DVec3, major_radius: f64, minor_radius: f64) -> Result<Self, InvalidShape> {
        if !center.is_finite() {
            return Err(InvalidShape("center must be finite"));
        }
        let axis = axis
            .try_normalize()
            .ok_or(InvalidShape("axis must be finite and non-zero"))?;
        if !(minor_radius.is_finite() && minor_radius > 0.0) {
            return Err(InvalidShape("minor radius must be finite and > 0"));
        }
        if !(major_radius.is_finite() && major_radius > minor_radius) {
            return Err(InvalidShape("major radius must be finite and > the minor radius"));
        }
        Ok(Torus {
            center,
            axis,
            major_radius,
            minor_radius,
        })
    }

    /// The centre (world space).
    pub fn center(&self) -> DVec3 {
        self.center
    }

    /// The unit axis of revolution.
    pub fn axis(&self) -> DVec3 {
        self.axis
    }

    /// Distance from the centre to the tube's centre circle (world units).
    pub fn major_radius(&self) -> f64 {
        self.major_radius
    }

    /// The tube's radius (world units).
    pub fn minor_radius(&self) -> f64 {
        self.minor_radius
    }

    /// `(ρ − R, h)`: the position relative to the core circle, in the meridian plane.
    #[inline]
    fn meridian(&self, world_pos: DVec3) -> (f64, f64, DVec3) {
        let v = world_pos - self.center;
        let h = v.dot(self.axis);
        let radial = v - h * self.axis;
        (radial.length() - self.major_radius, h, radial)
    }
}

impl SignedDistance for Torus {
    #[inline]
    fn signed_distance(&self, world_pos: DVec3) -> f64 {
        let (q, h, _) = self.meridian(world_pos);
        q.hypot(h) - self.minor_radius
    }

    /// Exact: a circle's bounding box grows by `R·√(1 − aᵢ²)` per axis, the tube by `r`.
    fn bounds(&self) -> Aabb {
        let ring = (DVec3::ONE - self.axis * self.axis).max(DVec3::ZERO);
        let ext = DVec3::new(ring.x.sqrt(), ring.y.sqrt(), ring.z.sqrt()) * self.major_radius + self.minor_radius;
        Aabb::new(self.center - ext, self.center + ext)
    }

    /// Away from the core circle: the direction from its nearest point. On the circle
    /// itself (the tube's centre line) any direction in the meridian plane is a
    /// gradient; the radial one is returned. On the axis, the axis.
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        let (q, h, radial) = self.meridian(world_pos);
        match radial.try_normalize() {
            Some(e) if q != 0.0 || h != 0.0 => q * e + h * self.axis,
            Some(e) => e,
            None => self.axis * if h >= 0.0 { 1.0 } else { -1.0 },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: the distance to the solid torus is the distance to the core circle
    /// minus the tube radius; the circle is sampled at `n` points. The nearest sample is
    /// at most `Δφ = π/n` from the nearest point, and the squared distance grows by
    /// `2ρR(1 − cos Δφ) ≤ ρRΔφ²` (ρ: the point's distance from the axis), so the sampled
    /// distance overestimates by at most `√(ρR)·Δφ`.
    fn brute(t: &Torus, p: DVec3) -> f64 {
        let a = t.axis;
        let u = a.any_orthonormal_vector();
        let w = a.cross(u);
        let n = 20_000;
        let near = (0..n)
            .map(|k| {
                let phi = k as f64 / n as f64 * std::f64::consts::TAU;
                let c = t.center + t.major_radius * (phi.cos() * u + phi.sin() * w);
                (p - c).length()
            })
            .fold(f64::INFINITY, f64::min);
        near - t.minor_radius
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn distance_matches_brute_force(
            c in prop::array::uniform3(-5.0f64..5.0),
            a in prop::array::uniform3(-1.0f64..1.0),
            big in 1.0f64..4.0, ratio in 0.05f64..0.95,
            p in prop::array::uniform3(-8.0f64..8.0),
        ) {
            prop_assume!(DVec3::from_array(a).length() > 0.1);
            let t = Torus::new(DVec3::from_array(c), DVec3::from_array(a), big, big * ratio).unwrap();
            let p = DVec3::from_array(p);
            let exact = t.signed_distance(p);
            let v = p - t.center();
            let rho = (v - v.dot(t.axis()) * t.axis()).length();
            let tol = (rho * big).sqrt() * std::f64::consts::PI / 20_000.0 + 1e-12;
            let sampled = brute(&t, p);
            prop_assert!(exact <= sampled + 1e-12 && sampled - exact <= tol, "{exact} vs {sampled} (tol {tol})");
            let b = t.bounds();
            prop_assert!(exact > 0.0 || (b.min.cmple(p).all() && p.cmple(b.max).all()));
        }
    }

    #[test]
    fn bounds_are_tight_and_gradient_points_out() {
        let t = Torus::new(DVec3::new(1e6, 0.0, 0.0), DVec3::Z, 3.0, 1.0).unwrap();
        let b = t.bounds();
        assert!((b.max - DVec3::new(1e6 + 4.0, 4.0, 1.0)).abs().max_element() < 1e-9);
        assert_eq!(t.signed_distance(DVec3::new(1e6 + 3.0, 0.0, 0.0)), -1.0);
        assert_eq!(t.signed_distance(DVec3::new(1e6, 0.0, 0.0)), 3f64.hypot(0.0) - 1.0);
        let g = t.gradient(DVec3::new(1e6 + 5.0, 0.0, 0.0));
        assert!((g.normalize() - DVec3::X).length() < 1e-12);
        assert!(t.gradient(DVec3::new(1e6, 0.0, 2.0)).is_finite());
        assert!(t.gradient(DVec3::new(1e6 + 3.0, 0.0, 0.0)).is_finite());
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(Torus::new(DVec3::ZERO, DVec3::ZERO, 2.0, 1.0).is_err());
        assert!(Torus::new(DVec3::ZERO, DVec3::Z, 1.0, 1.0).is_err());
        assert!(Torus::new(DVec3::ZERO, DVec3::Z, 2.0, 0.0).is_err());
        assert!(Torus::new(DVec3::splat(f64::NAN), DVec3::Z, 2.0, 1.0).is_err());
    }
}
