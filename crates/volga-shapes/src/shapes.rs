//! Analytic shapes with exact signed distances (world space, negative inside).
//!
//! A shape knows only its geometry; sampling it into voxels is `voxelize_solids`'s job
//! (shapes apart from queries, as in parry).

use glam::{DMat3, DQuat, DVec3};
use volga_core::Aabb;

/// An exact Euclidean signed distance: `|d(p) − d(q)| ≤ |p − q|` (1-Lipschitz), which
/// the brick classifier relies on.
pub trait SignedDistance {
    /// Signed distance from `world_pos` to the surface (world units, negative inside).
    fn signed_distance(&self, world_pos: DVec3) -> f64;
    /// Tight world bounds of the solid (may be infinite for unbounded quadrics).
    fn bounds(&self) -> Aabb;
    /// Whether `signed_distance` is the exact Euclidean distance (hence 1-Lipschitz).
    /// Approximate distances (first order, `F/‖∇F‖`) return false, and voxelizers do not
    /// use Lipschitz bounds on them.
    fn is_exact(&self) -> bool {
        true
    }
    /// Direction of increasing distance (need not be unit length); central differences
    /// unless a shape knows better.
    fn gradient(&self, p: DVec3) -> DVec3 {
        let h = 1e-6 * (1.0 + p.abs().max_element());
        let d = |e: DVec3| self.signed_distance(p + e * h) - self.signed_distance(p - e * h);
        DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z)) / (2.0 * h)
    }
}

/// Why a shape's parameters were refused.
#[derive(Debug, Clone, PartialEq)]
pub struct InvalidShape(
    /// Which parameter and what it must be (`"radius must be finite and > 0"`).
    pub &'static str,
);

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

/// A ball of `radius` around `center`. Exact distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    center: DVec3,
    radius: f64,
}

impl Sphere {
    /// A sphere; `center` finite, `radius` finite and > 0.
    pub fn new(center: DVec3, radius: f64) -> Result<Self, InvalidShape> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(InvalidShape("radius must be finite and > 0"));
        }
        Ok(Sphere {
            center: finite(center, "center must be finite")?,
            radius,
        })
    }
    /// The centre (world space).
    pub fn center(&self) -> DVec3 {
        self.center
    }
    /// The radius (world units).
    pub fn radius(&self) -> f64 {
        self.radius
    }
}

impl SignedDistance for Sphere {
    #[inline]
    fn signed_distance(&self, p: DVec3) -> f64 {
        (p - self.center).length() - self.radius
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        let v = p - self.center;
        if v == DVec3::ZERO {
            DVec3::Z
        } else {
            v
        }
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
    /// The box between `min` and `max` (finite, `min < max` on every axis).
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
    /// A box; `center` finite, `half_extents` finite and > 0, `rotation` a finite
    /// non-zero quaternion (normalized here).
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
    /// A [`Sphere`].
    Sphere(Sphere),
    /// An [`AxisBox`].
    AxisBox(AxisBox),
    /// An [`OrientedBox`].
    OrientedBox(OrientedBox),
    /// An [`Ellipsoid`].
    Ellipsoid(Ellipsoid),
    /// A [`Cylinder`].
    Cylinder(Cylinder),
    /// A [`Cone`].
    Cone(Cone),
    /// A [`Quadric`] (first-order distance: not exact).
    Quadric(Quadric),
    /// A [`Capsule`].
    Capsule(Capsule),
}

impl SignedDistance for Shape {
    #[inline]
    fn signed_distance(&self, p: DVec3) -> f64 {
        match self {
            Shape::Sphere(s) => s.signed_distance(p),
            Shape::AxisBox(s) => s.signed_distance(p),
            Shape::OrientedBox(s) => s.signed_distance(p),
            Shape::Ellipsoid(s) => s.signed_distance(p),
            Shape::Cylinder(s) => s.signed_distance(p),
            Shape::Cone(s) => s.signed_distance(p),
            Shape::Quadric(s) => s.signed_distance(p),
            Shape::Capsule(s) => s.signed_distance(p),
        }
    }
    fn bounds(&self) -> Aabb {
        match self {
            Shape::Sphere(s) => s.bounds(),
            Shape::AxisBox(s) => s.bounds(),
            Shape::OrientedBox(s) => s.bounds(),
            Shape::Ellipsoid(s) => s.bounds(),
            Shape::Cylinder(s) => s.bounds(),
            Shape::Cone(s) => s.bounds(),
            Shape::Quadric(s) => s.bounds(),
            Shape::Capsule(s) => s.bounds(),
        }
    }
    fn is_exact(&self) -> bool {
        !matches!(self, Shape::Quadric(_))
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        match self {
            Shape::Sphere(s) => s.gradient(p),
            Shape::AxisBox(s) => s.gradient(p),
            Shape::OrientedBox(s) => s.gradient(p),
            Shape::Ellipsoid(s) => s.gradient(p),
            Shape::Cylinder(s) => s.gradient(p),
            Shape::Cone(s) => s.gradient(p),
            Shape::Quadric(s) => s.gradient(p),
            Shape::Capsule(s) => s.gradient(p),
        }
    }
}

/// An ellipsoid with semi-axes `radii` along its own axes, rotated by `rotation` about
/// its centre. Exact distance by Eberly's robust bisection ("Distance from a Point to
/// an Ellipse, an Ellipsoid, or a Hyperellipsoid", 2013), accurate to f64 rounding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    center: DVec3,
    radii: DVec3,
    to_local: DMat3,
    to_world: DMat3,
}

impl Ellipsoid {
    /// An ellipsoid; `center` finite, `radii` finite and > 0, `rotation` a finite non-zero
    /// quaternion (normalized here).
    pub fn new(center: DVec3, radii: DVec3, rotation: DQuat) -> Result<Self, InvalidShape> {
        finite(center, "center must be finite")?;
        if !radii.is_finite() || radii.cmple(DVec3::ZERO).any() {
            return Err(InvalidShape("radii must be finite and > 0"));
        }
        if !rotation.is_finite() || rotation.length_squared() == 0.0 {
            return Err(InvalidShape("rotation must be a finite non-zero quaternion"));
        }
        let to_world = DMat3::from_quat(rotation.normalize());
        Ok(Ellipsoid {
            center,
            radii,
            to_local: to_world.transpose(),
            to_world,
        })
    }
}

impl SignedDistance for Ellipsoid {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let local = self.to_local * (p - self.center);
        // Sort the axes by decreasing radius, work in the first octant.
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&i, &j| self.radii[j].total_cmp(&self.radii[i]));
        let e = [self.radii[idx[0]], self.radii[idx[1]], self.radii[idx[2]]];
        let y = [local[idx[0]].abs(), local[idx[1]].abs(), local[idx[2]].abs()];
        let dist = ellipsoid_distance(e, y);
        let inside = (y[0] / e[0]).powi(2) + (y[1] / e[1]).powi(2) + (y[2] / e[2]).powi(2) < 1.0;
        if inside {
            -dist
        } else {
            dist
        }
    }
    fn bounds(&self) -> Aabb {
        let m = self.to_world;
        // Extent along world axis a of a rotated ellipsoid: sqrt(Σ_b (R_ab r_b)²).
        let e = DVec3::new(
            (m.row(0) * self.radii).length(),
            (m.row(1) * self.radii).length(),
            (m.row(2) * self.radii).length(),
        );
        Aabb::new(self.center - e, self.center + e)
    }
}

fn robust_length(v: &[f64]) -> f64 {
    let m = v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    if m == 0.0 {
        0.0
    } else {
        m * v.iter().map(|x| (x / m).powi(2)).sum::<f64>().sqrt()
    }
}

/// Bisection for the root of Σ (nᵢ/(s + rᵢ))² − 1 on [s0, s1] (Eberly's GetRoot).
fn bisect_root(n: &[f64], r: &[f64], mut s0: f64, mut s1: f64) -> f64 {
    let mut s = s0;
    for _ in 0..1100 {
        s = 0.5 * (s0 + s1);
        if s == s0 || s == s1 {
            break;
        }
        let g: f64 = n.iter().zip(r).map(|(ni, ri)| (ni / (s + ri)).powi(2)).sum::<f64>() - 1.0;
        if g > 0.0 {
            s0 = s;
        } else if g < 0.0 {
            s1 = s;
        } else {
            break;
        }
    }
    s
}

/// Distance from `y` (first octant) to the ellipse with semi-axes e0 ≥ e1.
fn ellipse_distance([e0, e1]: [f64; 2], [y0, y1]: [f64; 2]) -> f64 {
    if y1 > 0.0 {
        if y0 > 0.0 {
            let (z0, z1) = (y0 / e0, y1 / e1);
            let g = z0 * z0 + z1 * z1 - 1.0;
            if g == 0.0 {
                return 0.0;
            }
            let r0 = (e0 / e1).powi(2);
            let n0 = r0 * z0;
            let s = bisect_root(
                &[n0, z1],
                &[r0, 1.0],
                z1 - 1.0,
                if g < 0.0 { 0.0 } else { robust_length(&[n0, z1]) - 1.0 },
            );
            let x0 = r0 * y0 / (s + r0);
            let x1 = y1 / (s + 1.0);
            ((x0 - y0).powi(2) + (x1 - y1).powi(2)).sqrt()
        } else {
            (y1 - e1).abs()
        }
    } else {
        let (numer0, denom0) = (e0 * y0, e0 * e0 - e1 * e1);
        if numer0 < denom0 {
            let xde0 = numer0 / denom0;
            let x0 = e0 * xde0;
            let x1 = e1 * (1.0 - xde0 * xde0).max(0.0).sqrt();
            ((x0 - y0).powi(2) + x1 * x1).sqrt()
        } else {
            (y0 - e0).abs()
        }
    }
}

/// Distance from `y` (first octant) to the ellipsoid with semi-axes e0 ≥ e1 ≥ e2.
fn ellipsoid_distance(e: [f64; 3], y: [f64; 3]) -> f64 {
    let [e0, e1, e2] = e;
    let [y0, y1, y2] = y;
    if y2 > 0.0 {
        if y1 > 0.0 {
            if y0 > 0.0 {
                let z = [y0 / e0, y1 / e1, y2 / e2];
                let g = z[0] * z[0] + z[1] * z[1] + z[2] * z[2] - 1.0;
                if g == 0.0 {
                    return 0.0;
                }
                let (r0, r1) = ((e0 / e2).powi(2), (e1 / e2).powi(2));
                let n = [r0 * z[0], r1 * z[1], z[2]];
                let s = bisect_root(
                    &n,
                    &[r0, r1, 1.0],
                    z[2] - 1.0,
                    if g < 0.0 { 0.0 } else { robust_length(&n) - 1.0 },
                );
                let x = [r0 * y0 / (s + r0), r1 * y1 / (s + r1), y2 / (s + 1.0)];
                ((x[0] - y0).powi(2) + (x[1] - y1).powi(2) + (x[2] - y2).powi(2)).sqrt()
            } else {
                ellipse_distance([e1, e2], [y1, y2]).hypot(y0)
            }
        } else if y0 > 0.0 {
            ellipse_distance([e0, e2], [y0, y2]).hypot(y1)
        } else {
            (y2 - e2).abs()
        }
    } else {
        let (denom0, denom1) = (e0 * e0 - e2 * e2, e1 * e1 - e2 * e2);
        let (numer0, numer1) = (e0 * y0, e1 * y1);
        if numer0 < denom0 && numer1 < denom1 {
            let (xde0, xde1) = (numer0 / denom0, numer1 / denom1);
            let discr = 1.0 - xde0 * xde0 - xde1 * xde1;
            if discr > 0.0 {
                let x = [e0 * xde0, e1 * xde1, e2 * discr.sqrt()];
                return ((x[0] - y0).powi(2) + (x[1] - y1).powi(2) + x[2] * x[2]).sqrt();
            }
        }
        ellipse_distance([e0, e1], [y0, y1])
    }
}

/// A circular cylinder around the axis through `center` with unit direction `axis`;
/// `half_length: None` makes it infinite. Exact distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    center: DVec3,
    axis: DVec3,
    radius: f64,
    half_length: Option<f64>,
}

impl Cylinder {
    /// A cylinder; `center` and `axis` finite, `axis` non-zero (normalized here),
    /// `radius` and a given `half_length` finite and > 0.
    pub fn new(center: DVec3, axis: DVec3, radius: f64, half_length: Option<f64>) -> Result<Self, InvalidShape> {
        finite(center, "center must be finite")?;
        let axis = finite(axis, "axis must be finite")?;
        if axis.length_squared() == 0.0 {
            return Err(InvalidShape("axis must not be the zero vector"));
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(InvalidShape("radius must be finite and > 0"));
        }
        if let Some(l) = half_length {
            if !(l.is_finite() && l > 0.0) {
                return Err(InvalidShape("half_length must be finite and > 0"));
            }
        }
        Ok(Cylinder {
            center,
            axis: axis.normalize(),
            radius,
            half_length,
        })
    }
}

impl SignedDistance for Cylinder {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let v = p - self.center;
        let h = v.dot(self.axis);
        let radial = (v - self.axis * h).length();
        match self.half_length {
            None => radial - self.radius,
            Some(l) => {
                let q = glam::DVec2::new(radial - self.radius, h.abs() - l);
                q.max(glam::DVec2::ZERO).length() + q.max_element().min(0.0)
            }
        }
    }
    fn bounds(&self) -> Aabb {
        match self.half_length {
            None => Aabb::new(DVec3::NEG_INFINITY, DVec3::INFINITY),
            Some(l) => {
                let disk = (DVec3::ONE - self.axis * self.axis).max(DVec3::ZERO).powf(0.5) * self.radius;
                let (a, b) = (self.center - self.axis * l, self.center + self.axis * l);
                Aabb::new(a.min(b) - disk, a.max(b) + disk)
            }
        }
    }
}

/// A solid circular cone with its apex at `apex`, opening along the unit `axis` with
/// half-angle `half_angle_rad` ∈ (0, π/2); capped at `height` or infinite. Exact
/// distance (computed in the cone's meridian half-plane).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    apex: DVec3,
    axis: DVec3,
    half_angle_rad: f64,
    height: Option<f64>,
}

impl Cone {
    /// A cone; `apex` and `axis` finite, `axis` non-zero (normalized here),
    /// `half_angle_rad` in (0, π/2), a given `height` finite and > 0.
    pub fn new(apex: DVec3, axis: DVec3, half_angle_rad: f64, height: Option<f64>) -> Result<Self, InvalidShape> {
        finite(apex, "apex must be finite")?;
        let axis = finite(axis, "axis must be finite")?;
        if axis.length_squared() == 0.0 {
            return Err(InvalidShape("axis must not be the zero vector"));
        }
        if !(half_angle_rad > 0.0 && half_angle_rad < std::f64::consts::FRAC_PI_2) {
            return Err(InvalidShape("half angle must lie in (0°, 90°)"));
        }
        if let Some(hh) = height {
            if !(hh.is_finite() && hh > 0.0) {
                return Err(InvalidShape("height must be finite and > 0"));
            }
        }
        Ok(Cone {
            apex,
            axis: axis.normalize(),
            half_angle_rad,
            height,
        })
    }
}

/// Distance from `p` to the segment `a b` in the plane.
fn segment_distance_2d(p: glam::DVec2, a: glam::DVec2, b: glam::DVec2) -> f64 {
    let ab = b - a;
    let t = if ab == glam::DVec2::ZERO {
        0.0
    } else {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    };
    (p - (a + ab * t)).length()
}

impl SignedDistance for Cone {
    fn signed_distance(&self, p: DVec3) -> f64 {
        use glam::DVec2;
        let v = p - self.apex;
        let h = v.dot(self.axis);
        let radial = (v - self.axis * h).length();
        let q = DVec2::new(radial, h);
        let (s, c) = self.half_angle_rad.sin_cos();
        let slant = DVec2::new(s, c);
        let inside_slant = radial * c <= h * s;
        match self.height {
            None => {
                let t = q.dot(slant).max(0.0);
                let d = (q - slant * t).length();
                if inside_slant {
                    -d
                } else {
                    d
                }
            }
            Some(height) => {
                let rim = DVec2::new(height * s / c, height);
                let d =
                    segment_distance_2d(q, DVec2::ZERO, rim).min(segment_distance_2d(q, DVec2::new(0.0, height), rim));
                if inside_slant && h <= height {
                    -d
                } else {
                    d
                }
            }
        }
    }
    fn bounds(&self) -> Aabb {
        match self.height {
            None => Aabb::new(DVec3::NEG_INFINITY, DVec3::INFINITY),
            Some(h) => {
                let r = h * self.half_angle_rad.tan();
                let disk = (DVec3::ONE - self.axis * self.axis).max(DVec3::ZERO).powf(0.5) * r;
                let cap = self.apex + self.axis * h;
                Aabb::new(self.apex.min(cap - disk), self.apex.max(cap + disk))
            }
        }
    }
}

/// A tube of `radius` around the segment `a b` (a capsule): the anti-aliased line of
/// survey §17.4. Exact distance; `a = b` gives a sphere (zero-length segments are fine).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    a: DVec3,
    b: DVec3,
    radius: f64,
}

impl Capsule {
    /// A capsule; `a` and `b` finite, `radius` finite and > 0.
    pub fn new(a: DVec3, b: DVec3, radius: f64) -> Result<Self, InvalidShape> {
        finite(a, "a must be finite")?;
        finite(b, "b must be finite")?;
        if !(radius.is_finite() && radius > 0.0) {
            return Err(InvalidShape("radius must be finite and > 0"));
        }
        Ok(Capsule { a, b, radius })
    }
}

impl SignedDistance for Capsule {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let ab = self.b - self.a;
        let l = ab.length_squared();
        let t = if l > 0.0 {
            ((p - self.a).dot(ab) / l).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (self.a + ab * t)).length() - self.radius
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(self.a.min(self.b) - self.radius, self.a.max(self.b) + self.radius)
    }
}

/// The general quadric solid `F(x) = xᵀAx + bᵀx + c ≤ 0` clipped by a box.
/// Distance is first order, `F/‖∇F‖`: exact for planes, with an error of order
/// `d²·κ` (κ the surface curvature) elsewhere; it is intersected with the box's exact
/// distance by `max`. Not 1-Lipschitz, so voxelizers sample every voxel of its box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadric {
    a: DMat3,
    b: DVec3,
    c: f64,
    clip: AxisBox,
}

impl Quadric {
    /// The quadric `xᵀAx + bᵀx + c ≤ 0` clipped by `clip`; `A`, `b`, `c` finite, not
    /// both `A` and `b` zero (only `A`'s symmetric part is kept).
    pub fn new(a: DMat3, b: DVec3, c: f64, clip: AxisBox) -> Result<Self, InvalidShape> {
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            return Err(InvalidShape("A, b and c must be finite"));
        }
        if a == DMat3::ZERO && b == DVec3::ZERO {
            return Err(InvalidShape("A and b must not both be zero"));
        }
        // Only the symmetric part of A contributes to xᵀAx.
        let a = (a + a.transpose()) * 0.5;
        Ok(Quadric { a, b, c, clip })
    }

    /// F(p).
    pub fn value(&self, p: DVec3) -> f64 {
        p.dot(self.a * p) + self.b.dot(p) + self.c
    }
}

impl SignedDistance for Quadric {
    fn signed_distance(&self, p: DVec3) -> f64 {
        let f = self.value(p);
        let g = (2.0 * (self.a * p) + self.b).length();
        let d = if g > 0.0 { f / g } else { f64::MAX.copysign(f) };
        d.max(self.clip.signed_distance(p))
    }
    fn bounds(&self) -> Aabb {
        self.clip.bounds()
    }
    fn is_exact(&self) -> bool {
        false
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        2.0 * (self.a * p) + self.b
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
