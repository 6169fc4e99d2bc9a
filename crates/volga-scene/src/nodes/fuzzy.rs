//! Leaf node: a fuzzy primitive whose density falls linearly from its core (figure 41's
//! fuzzy sphere, "opacity `1 − r`", and cylinder), coloured by a ramp from `colour`
//! (density 0) to `inner_colour` (density 1).

use glam::Vec3;
use serde::{Deserialize, Serialize};
use volga_core::{Aabb, Field, Grid, Progress, SparseVolume};
use volga_cvg::{Core, Cvg, CvgField, LeafColour, Radial};

use super::procedural::bake_field;
use super::{bricks_within, Estimate, Node};
use crate::ctx::Ctx;
use crate::model::V3;
use crate::SceneError;

/// `Fuzzy(core: Sphere(center: ..) | Cylinder(center: .., axis: .., half_length: ..),
/// radius: .., colour: .., inner_colour: ..)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FuzzySpec {
    #[serde(default)]
    pub name: Option<String>,
    pub core: FuzzyCore,
    pub radius: f64,
    /// Colour at density 0 (white when absent).
    #[serde(default)]
    pub colour: Option<V3>,
    /// Colour at density 1 (`colour` when absent).
    #[serde(default)]
    pub inner_colour: Option<V3>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum FuzzyCore {
    Sphere { center: V3 },
    Cylinder { center: V3, axis: V3, half_length: f64 },
}

#[derive(Debug)]
pub struct FuzzyNode {
    name: String,
    radial: Radial,
    outer: Vec3,
    inner: Vec3,
}

impl FuzzyNode {
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
    fn bake(&self, grid: &Grid, colour: bool, _progress: &dyn Progress) -> Result<SparseVolume, SceneError> {
        Ok(bake_field(self.lazy_field(grid)?.as_ref(), grid, colour))
    }
}
