//! Analytic shapes with exact signed distances (world space, negative inside).
//!
//! A shape knows only its geometry; sampling it into voxels is `voxelize_solids`'s job
//! (shapes apart from queries, as in parry).

use glam::{DMat3, DQuat, DVec3};
use volga_core::Aabb;

/// An exact Euclidean signed distance: `|d(p) − d(q)| ≤ |p − q|` (1-Lipschitz), which
/// the brick classifier relies on.
pub trait SignedDistance {
    fn signed_distance(&self, world_pos: DVec3) -> f64;
    /// Tight world bounds of the solid.
    fn bounds(&self) -> Aabb;
}

/// Why a shape's parameters were refused.
#[derive(Debug, Clone, PartialEq)]
pub struct InvalidShape(pub &'static str);

impl std::fmt::Display for InvalidShape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

impl std::error::Error for InvalidShape {}

fn finite(v: DVec3, what: &'static str) -> Result<DVec3, InvalidShape> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(InvalidShape(what))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    center: DVec3,
    radius: f64,
}

impl Sphere {
    pub fn new(center: DVec3, radius: f64) -> Result<Self, InvalidShape> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(InvalidShape("radius must be finite and > 0"));
        }
        Ok(Sphere {
            center: finite(center, "center must be finite")?,
            radius,
        })
    }
    pub fn center(&self) -> DVec3 {
        self.center
    }
    pub fn radius(&self) -> f64 {
        self.radius
    }
}

impl SignedDistance for Sphere {
    #[inline]
    fn signed_distance(&self, p: DVec3) -> f64 {
        (p - self.center).length() - self.radius
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(self.center - self.radius, self.center + self.radius)
    }
}

/// Exact signed distance of a box centred at the origin with half extents `h`.
#[inline]
fn box_distance(local: DVec3, h: DVec3) -> f64 {
    let q = local.abs() - h;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

/// An axis-aligned box `min ≤ p ≤ max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisBox {
    min: DVec3,
    max: DVec3,
}

impl AxisBox {
    pub fn new(min: DVec3, max: DVec3) -> Result<Self, InvalidShape> {
        finite(min, "min must be finite")?;
        finite(max, "max must be finite")?;
        if min.cmpge(max).any() {
            return Err(InvalidShape("min must be < max on every axis"));
        }
        Ok(AxisBox { min, max })
    }
}

impl SignedDistance for AxisBox {
    #[inline]
    fn signed_distance(&self, p: DVec3) -> f64 {
        let c = (self.min + self.max) * 0.5;
        box_distance(p - c, (self.max - self.min) * 0.5)
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(self.min, self.max)
    }
}

/// A box with half extents `half_extents` in its own frame, rotated by `rotation`
/// about its centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    center: DVec3,
    half_extents: DVec3,
    /// World → local rotation (the inverse of the box's orientation).
    to_local: DMat3,
    to_world: DMat3,
}

impl OrientedBox {
    pub fn new(center: DVec3, half_extents: DVec3, rotation: DQuat) -> Result<Self, InvalidShape> {
        finite(center, "center must be finite")?;
        if !half_extents.is_finite() || half_extents.cmple(DVec3::ZERO).any() {
            return Err(InvalidShape("half_extents must be finite and > 0"));
        }
        if !rotation.is_finite() || rotation.length_squared() == 0.0 {
            return Err(InvalidShape("rotation must be a finite non-zero quaternion"));
        }
        let to_world = DMat3::from_quat(rotation.normalize());
        Ok(OrientedBox {
            center,
            half_extents,
            to_local: to_world.transpose(),
            to_world,
        })
    }
}

impl SignedDistance for OrientedBox {
    #[inline]
    fn signed_distance(&self, p: DVec3) -> f64 {
        box_distance(self.to_local * (p - self.center), self.half_extents)
    }
    fn bounds(&self) -> Aabb {
        // Extent of a rotated box along world axis a: Σ_b |R_ab| h_b.
        let m = self.to_world;
        let abs = DMat3::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
        let e = abs * self.half_extents;
        Aabb::new(self.center - e, self.center + e)
    }
}

/// The closed set of analytic shapes, dispatched once per brick (not per sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    Sphere(Sphere),
    AxisBox(AxisBox),
    OrientedBox(OrientedBox),
}

impl SignedDistance for Shape {
    #[inline]
    fn signed_distance(&self, p: DVec3) -> f64 {
        match self {
            Shape::Sphere(s) => s.signed_distance(p),
            Shape::AxisBox(s) => s.signed_distance(p),
            Shape::OrientedBox(s) => s.signed_distance(p),
        }
    }
    fn bounds(&self) -> Aabb {
        match self {
            Shape::Sphere(s) => s.bounds(),
            Shape::AxisBox(s) => s.bounds(),
            Shape::OrientedBox(s) => s.bounds(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_distances() {
        let s = Sphere::new(DVec3::new(1.0, 2.0, 3.0), 2.0).unwrap();
        assert_eq!(s.signed_distance(DVec3::new(1.0, 2.0, 3.0)), -2.0);
        assert_eq!(s.signed_distance(DVec3::new(5.0, 2.0, 3.0)), 2.0);
        let b = AxisBox::new(DVec3::ZERO, DVec3::new(2.0, 4.0, 6.0)).unwrap();
        assert_eq!(b.signed_distance(DVec3::new(1.0, 2.0, 3.0)), -1.0);
        assert_eq!(b.signed_distance(DVec3::new(3.0, 5.0, 3.0)), 2f64.sqrt());
        // A box rotated 90° about z swaps its x and y extents.
        let o = OrientedBox::new(
            DVec3::ZERO,
            DVec3::new(1.0, 3.0, 1.0),
            DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
        )
        .unwrap();
        assert!((o.signed_distance(DVec3::new(3.0, 0.0, 0.0))).abs() < 1e-12);
        assert!((o.signed_distance(DVec3::new(0.0, 2.0, 0.0)) - 1.0).abs() < 1e-12);
        let bb = o.bounds();
        assert!((bb.max - DVec3::new(3.0, 1.0, 1.0)).abs().max_element() < 1e-12);
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(Sphere::new(DVec3::ZERO, -1.0).is_err());
        assert!(Sphere::new(DVec3::ZERO, f64::NAN).is_err());
        assert!(AxisBox::new(DVec3::ONE, DVec3::ZERO).is_err());
        assert!(OrientedBox::new(DVec3::ZERO, DVec3::ONE, DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0)).is_err());
    }
}
