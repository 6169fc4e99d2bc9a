//! Fuzzy primitives whose density falls linearly from the centre (figure 41's fuzzy
//! sphere, "opacity `1 − r`"): `max(0, 1 − dist/radius)`, with `dist` the distance to a
//! point (sphere), or for a cylinder the larger of the distance to its axis and the
//! distance past `half_length − radius` along it (flat caps, density ramping to 0 at
//! `half_length`, continuous everywhere).

use glam::DVec3;
use volga_core::{Aabb, Field};

use crate::CvgError;

/// Where the density is measured from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Core {
    /// A point: a fuzzy sphere.
    Point(DVec3),
    /// An axis through `center` along the unit `axis`: a fuzzy cylinder reaching
    /// `half_length` along the axis (density 0 beyond the caps).
    Axis {
        /// The cylinder's centre (world space).
        center: DVec3,
        /// Its direction (normalized by [`Radial::new`]).
        axis: DVec3,
        /// Half its length along the axis (world units).
        half_length: f64,
    },
}

/// Density `max(0, 1 − dist/radius)`.
#[derive(Debug, Clone)]
pub struct Radial {
    core: Core,
    radius: f64,
    step: f64,
}

impl Radial {
    /// The primitive of `core` whose density reaches 0 at `radius` (world units) from
    /// it; `sample_spacing` (world units) is the central-difference step of its gradient.
    /// Everything must be finite, `radius`, `sample_spacing` and a cylinder's
    /// `half_length` > 0 and its `axis` non-zero (it is normalized); the first argument
    /// that is not is refused, named with its value ([`CvgError`]).
    pub fn new(core: Core, radius: f64, sample_spacing: f64) -> Result<Self, CvgError> {
        let core = match core {
            Core::Point(c) => {
                if !c.is_finite() {
                    return Err(CvgError::Center(c));
                }
                Core::Point(c)
            }
            Core::Axis {
                center,
                axis,
                half_length,
            } => {
                let unit = axis.try_normalize().ok_or(CvgError::Axis(axis))?;
                if !center.is_finite() {
                    return Err(CvgError::Center(center));
                }
                if !(half_length > 0.0 && half_length.is_finite()) {
                    return Err(CvgError::HalfLength(half_length));
                }
                Core::Axis {
                    center,
                    axis: unit,
                    half_length,
                }
            }
        };
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(CvgError::Radius(radius));
        }
        if !(sample_spacing > 0.0 && sample_spacing.is_finite()) {
            return Err(CvgError::SampleSpacing(sample_spacing));
        }
        Ok(Radial {
            core,
            radius,
            step: sample_spacing,
        })
    }

    /// The distance `dist`: 1-Lipschitz (a max of 1-Lipschitz functions).
    fn dist(&self, p: DVec3) -> f64 {
        match self.core {
            Core::Point(c) => p.distance(c),
            Core::Axis {
                center,
                axis,
                half_length,
            } => {
                let q = p - center;
                let t = q.dot(axis);
                let radial = (q - axis * t).length();
                radial.max(t.abs() - (half_length - self.radius))
            }
        }
    }
}

impl Field for Radial {
    fn bounds(&self) -> Aabb {
        match self.core {
            Core::Point(c) => Aabb::new(c - self.radius, c + self.radius),
            Core::Axis {
                center,
                axis,
                half_length,
            } => {
                let ends = [center - axis * half_length, center + axis * half_length];
                // A disc of radius r around the axis reaches r·sqrt(1 − a_i²) along axis i.
                let r =
                    self.radius * DVec3::from((DVec3::ONE - axis * axis).max(DVec3::ZERO).to_array().map(f64::sqrt));
                Aabb::new(ends[0].min(ends[1]) - r, ends[0].max(ends[1]) + r)
            }
        }
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        (1.0 - self.dist(world_pos) / self.radius).max(0.0)
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.step)
    }
    /// `dist` is 1-Lipschitz: over a box it lies within the centre's value ± the half
    /// diagonal.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let d = self.dist(world_box.center());
        let r = world_box.size().length() * 0.5;
        let density = |dist: f64| (1.0 - dist / self.radius).clamp(0.0, 1.0);
        (density(d + r), density(d - r))
    }
}
