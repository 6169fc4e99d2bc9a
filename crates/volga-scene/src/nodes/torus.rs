//! Leaf node: a ring torus (the worked example of adding a node kind; its geometry is
//! `volga_shapes::Torus`, one file of the geometry layer).

use volga_core::{Aabb, Field, Grid, IndexBox, Progress, Rgb, SparseVolume};
use volga_shapes::{FilteredDensity, SignedDistance, Torus};
use volga_voxelize::{voxelize_shapes_in, SurfaceMode};

use super::{bricks_within, grid_filter, Clipped, Estimate, Node};
use crate::ctx::Ctx;
use crate::model::ShapeSpec;
use crate::SceneError;

/// Leaf node: a ring torus (`ShapeSpec::Torus`) with a colour, voxelized through its exact
/// signed distance.
#[derive(Debug, Clone)]
pub struct TorusNode {
    name: String,
    torus: Torus,
    colour: Rgb,
}

impl TorusNode {
    /// `spec` is `ShapeSpec::Torus`; `f` its field path.
    pub fn validate(cx: &Ctx, f: &str, name: String, spec: &ShapeSpec, colour: Rgb) -> Result<Self, SceneError> {
        let ShapeSpec::Torus {
            center,
            axis,
            major_radius,
            minor_radius,
        } = spec
        else {
            return Err(cx.err(f, "not a torus (dispatched by `nodes::leaf`)"));
        };
        let center = cx.finite3(&format!("{f}.center"), *center)?;
        let axis = cx.nonzero3(&format!("{f}.axis"), *axis)?;
        let minor = cx.positive(&format!("{f}.minor_radius"), *minor_radius)?;
        let major = cx.positive(&format!("{f}.major_radius"), *major_radius)?;
        if major <= minor {
            return Err(cx.err(
                format!("{f}.major_radius"),
                format!("must exceed minor_radius ({minor}) for a ring torus, got {major}"),
            ));
        }
        let torus = Torus::new(center, axis, major, minor).map_err(|e| cx.err(f, e.to_string()))?;
        Ok(TorusNode { name, torus, colour })
    }
}

impl Node for TorusNode {
    fn kind(&self) -> &'static str {
        "torus"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn bounds(&self) -> Aabb {
        self.torus.bounds()
    }
    fn colour(&self) -> Rgb {
        self.colour
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        Estimate {
            bricks: bricks_within(grid, &self.torus.bounds()),
            extra_bytes: 0,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let density = FilteredDensity::new(self.torus, grid_filter(grid));
        Ok(Box::new(Clipped::new(density, grid.world_bounds()).tinted(self.colour)))
    }
    fn bake_in(
        &self,
        grid: &Grid,
        _colour: bool,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        Ok(voxelize_shapes_in(
            grid,
            &[self.torus],
            SurfaceMode::Solid,
            clip,
            progress,
        ))
    }
}
