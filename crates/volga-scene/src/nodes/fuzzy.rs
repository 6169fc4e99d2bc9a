//! Leaf node: a fuzzy primitive whose density falls linearly from its core (figure 41's
//! fuzzy sphere, "opacity `1 − r`", and cylinder), coloured by a ramp from `colour`
//! (density 0) to `inner_colour` (density 1).

use glam::Vec3;
use serde::{Deserialize, Serialize};
use volga_core::{Aabb, Field, Grid};
use volga_cvg::{Core, Cvg, CvgField, LeafColour, Radial};

use super::{bricks_within, Estimate, Node};
use crate::ctx::Ctx;
use crate::model::V3;
use crate::SceneError;

/// `Fuzzy(core: Sphere(center: ..) | Cylinder(center: .., axis: .., half_length: ..),
/// radius: .., colour: .., inner_colour: ..)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FuzzySpec {
    /// A label for the report; default `fuzzyN`, N counting the tree's leaf nodes (objects,
    /// `Fuzzy`, `Volume`, `Hypertexture`, `Adf`) in file order from 0.
    #[serde(default)]
    pub name: Option<String>,
    /// What the distance is measured from: a point or a segment.
    pub core: FuzzyCore,
    /// Distance from the core at which the density reaches 0 (world units, finite and > 0).
    pub radius: f64,
    /// Colour at density 0 (white when absent).
    #[serde(default)]
    pub colour: Option<V3>,
    /// Colour at density 1 (`colour` when absent).
    #[serde(default)]
    pub inner_colour: Option<V3>,
}

/// The core of a fuzzy primitive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum FuzzyCore {
    /// A point: a fuzzy ball of radius `radius`.
    Sphere {
        /// World position of the point.
        center: V3,
    },
    /// A segment along an axis: a fuzzy cylinder of radius `radius` with soft caps.
    Cylinder {
        /// World position of the segment's middle.
        center: V3,
        /// Direction of the axis (any length, not zero).
        axis: V3,
        /// Half the cylinder's length along the axis (world units, finite and > 0): the
        /// density falls to 0 at the caps, `half_length` from `center`, and is 1 on the
        /// axis only within `half_length − radius` of it.
        half_length: f64,
    },
}

/// Leaf node: a fuzzy primitive, density `max(0, 1 − dist/radius)` from its core, coloured
/// by a ramp from `colour` to `inner_colour`.
#[derive(Debug)]
pub struct FuzzyNode {
    name: String,
    radial: Radial,
    outer: Vec3,
    inner: Vec3,
}

impl FuzzyNode {
    /// Checks a `Fuzzy` spec at field path `f` (`root.Fuzzy`); `index` numbers its default
    /// name `fuzzy{index}`.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field refused, e.g. `{f}.radius` or
    /// `{f}.core.Cylinder.axis`.
    pub fn validate(cx: &Ctx, f: &str, spec: &FuzzySpec, index: usize) -> Result<Self, SceneError> {
        let radius = cx.positive(&format!("{f}.radius"), spec.radius)?;
        let core = match &spec.core {
            FuzzyCore::Sphere { center } => Core::Point(cx.finite3(&format!("{f}.core.Sphere.center"), *center)?),
            FuzzyCore::Cylinder {
                center,
                axis,
                half_length,
            } => Core::Axis {
                center: cx.finite3(&format!("{f}.core.Cylinder.center"), *center)?,
                axis: cx.nonzero3(&format!("{f}.core.Cylinder.axis"), *axis)?,
                half_length: cx.positive(&format!("{f}.core.Cylinder.half_length"), *half_length)?,
            },
        };
        let outer = Vec3::from(cx.colour(&format!("{f}.colour"), spec.colour)?);
        let inner = match spec.inner_colour {
            Some(c) => Vec3::from(cx.colour(&format!("{f}.inner_colour"), Some(c))?),
            None => outer,
        };
        // The fields were validated above; what the kernel still refuses (an axis too
        // small to normalize, a radius whose 1/64 underflows) is named by its argument.
        let radial = Radial::new(core, radius, radius / 64.0).map_err(|e| cx.err(f, e.to_string()))?;
        Ok(FuzzyNode {
            name: spec.name.clone().unwrap_or_else(|| format!("fuzzy{index}")),
            radial,
            outer,
            inner,
        })
    }
}

impl Node for FuzzyNode {
    fn kind(&self) -> &'static str {
        "fuzzy"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn bounds(&self) -> Aabb {
        self.radial.bounds()
    }
    fn colour(&self) -> volga_core::Rgb {
        self.inner.to_array()
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        Estimate {
            bricks: bricks_within(grid, &self.bounds()),
            extra_bytes: 0,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let leaf = volga_cvg::Leaf::new(Box::new(self.radial.clone())).with_colour(LeafColour::Ramp {
            outer: self.outer,
            inner: self.inner,
        });
        let mut field = CvgField::new(Cvg::Leaf(leaf), &grid.world_bounds());
        field.set_gradient_step(grid.transform.spacing());
        Ok(Box::new(field))
    }
}
