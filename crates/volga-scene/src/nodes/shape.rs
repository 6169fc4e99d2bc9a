//! Leaf node: one analytic shape of the geometry layer's closed set (sphere, boxes,
//! ellipsoid, cylinder, cone, general quadric, capsule) with a colour.
//!
//! Unions batch these leaves into one `voxelize_solids` pass (each brick classified once
//! against all of them) and one `AnalyticField` when rendered lazily.

use glam::{DQuat, DVec3, EulerRot};
use volga_core::{Aabb, Field, Grid, IndexBox, Progress, Rgb, SparseVolume};
use volga_shapes::{AxisBox, Capsule, Cone, Cylinder, Ellipsoid, OrientedBox, Quadric, Shape, SignedDistance, Sphere};
use volga_voxelize::{estimate_solid_bricks, voxelize_solids_in, AnalyticField, Solid};

use super::{grid_filter, Clipped, Estimate, Node};
use crate::ctx::Ctx;
use crate::model::ShapeSpec;
use crate::SceneError;

/// An analytic solid of the scene.
#[derive(Debug, Clone)]
pub struct ShapeNode {
    /// A label for reports (`objectN` when the scene gives none).
    pub name: String,
    /// The validated shape with its colour, as the voxelizer takes it.
    pub solid: Solid,
}

impl ShapeNode {
    /// Checks the analytic shape `spec` (not a torus or a mesh: they are nodes of their
    /// own) at field path `f` (`objects[1].shape`) and pairs it with `colour`; `name`
    /// labels it in reports.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field refused (`{f}.radius`: must be finite
    /// and > 0, …).
    pub fn validate(cx: &Ctx, f: &str, name: String, spec: &ShapeSpec, colour: Rgb) -> Result<Self, SceneError> {
        let shape = validate_shape(cx, f, spec)?;
        Ok(ShapeNode {
            name,
            solid: Solid::new(shape, colour),
        })
    }
}

impl Node for ShapeNode {
    fn kind(&self) -> &'static str {
        "shape"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn bounds(&self) -> Aabb {
        self.solid.shape.bounds()
    }
    fn colour(&self) -> Rgb {
        self.solid.colour
    }
    fn as_solid(&self) -> Option<Solid> {
        Some(self.solid)
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        Estimate {
            bricks: estimate_solid_bricks(grid, &[self.solid]),
            extra_bytes: 0,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let field = AnalyticField::new(vec![self.solid], grid_filter(grid));
        Ok(Box::new(Clipped::new(field, grid.world_bounds())))
    }
    fn bake_in(
        &self,
        grid: &Grid,
        colour: bool,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        Ok(voxelize_solids_in(grid, &[self.solid], colour, clip, progress))
    }
}

/// The analytic shape a spec describes (a sphere, box, oriented box, ellipsoid, bounded
/// cylinder or cone, capsule or quadric), validated with errors naming the field path
/// `field` of `origin` (a scene file, or a name for a spec made in memory).
pub fn shape_from_spec(origin: &std::path::Path, field: &str, spec: &ShapeSpec) -> Result<Shape, SceneError> {
    validate_shape(&Ctx { path: origin }, field, spec)
}

/// The analytic shape a spec describes; `f` is its field path.
pub(crate) fn validate_shape(cx: &Ctx, f: &str, s: &ShapeSpec) -> Result<Shape, SceneError> {
    Ok(match s {
        ShapeSpec::Sphere { center, radius } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let r = cx.positive(&format!("{f}.radius"), *radius)?;
            Shape::Sphere(Sphere::new(c, r).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Box { min, max } => {
            let lo = cx.finite3(&format!("{f}.min"), *min)?;
            let hi = cx.finite3(&format!("{f}.max"), *max)?;
            Shape::AxisBox(AxisBox::new(lo, hi).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::OrientedBox {
            center,
            half_extents,
            rotation_deg,
        } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let h = cx.finite3(&format!("{f}.half_extents"), *half_extents)?;
            for a in 0..3 {
                cx.positive(&format!("{f}.half_extents[{a}]"), h[a])?;
            }
            let r = cx.finite3(&format!("{f}.rotation_deg"), *rotation_deg)?;
            let q = DQuat::from_euler(EulerRot::XYZ, r.x.to_radians(), r.y.to_radians(), r.z.to_radians());
            Shape::OrientedBox(OrientedBox::new(c, h, q).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Ellipsoid {
            center,
            radii,
            rotation_deg,
        } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let r = cx.finite3(&format!("{f}.radii"), *radii)?;
            for a in 0..3 {
                cx.positive(&format!("{f}.radii[{a}]"), r[a])?;
            }
            let e = cx.finite3(&format!("{f}.rotation_deg"), *rotation_deg)?;
            let q = DQuat::from_euler(EulerRot::XYZ, e.x.to_radians(), e.y.to_radians(), e.z.to_radians());
            Shape::Ellipsoid(Ellipsoid::new(c, r, q).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Cylinder {
            center,
            axis,
            radius,
            half_length,
        } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let a = cx.nonzero3(&format!("{f}.axis"), *axis)?;
            let r = cx.positive(&format!("{f}.radius"), *radius)?;
            let l = half_length
                .map(|l| cx.positive(&format!("{f}.half_length"), l))
                .transpose()?;
            Shape::Cylinder(Cylinder::new(c, a, r, l).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Cone {
            apex,
            axis,
            half_angle_deg,
            height,
        } => {
            let p = cx.finite3(&format!("{f}.apex"), *apex)?;
            let a = cx.nonzero3(&format!("{f}.axis"), *axis)?;
            if !(half_angle_deg.is_finite() && *half_angle_deg > 0.0 && *half_angle_deg < 90.0) {
                return Err(cx.err(
                    format!("{f}.half_angle_deg"),
                    format!("must lie in (0, 90), got {half_angle_deg}"),
                ));
            }
            let h = height.map(|h| cx.positive(&format!("{f}.height"), h)).transpose()?;
            Shape::Cone(Cone::new(p, a, half_angle_deg.to_radians(), h).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Quadric { a, b, c, clip } => {
            let rows: Vec<DVec3> = (0..3)
                .map(|r| cx.finite3(&format!("{f}.a[{r}]"), a[r]))
                .collect::<Result<_, _>>()?;
            let bv = cx.finite3(&format!("{f}.b"), *b)?;
            if !c.is_finite() {
                return Err(cx.err(format!("{f}.c"), format!("must be finite, got {c}")));
            }
            let lo = cx.finite3(&format!("{f}.clip.min"), clip.min)?;
            let hi = cx.finite3(&format!("{f}.clip.max"), clip.max)?;
            let clip_box = AxisBox::new(lo, hi).map_err(|e| cx.err(format!("{f}.clip"), e.to_string()))?;
            let m = glam::DMat3::from_cols(rows[0], rows[1], rows[2]).transpose();
            Shape::Quadric(Quadric::new(m, bv, *c, clip_box).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Capsule { a, b, radius } => {
            let pa = cx.finite3(&format!("{f}.a"), *a)?;
            let pb = cx.finite3(&format!("{f}.b"), *b)?;
            let r = cx.positive(&format!("{f}.radius"), *radius)?;
            Shape::Capsule(Capsule::new(pa, pb, r).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Mesh { .. } | ShapeSpec::Triangles { .. } | ShapeSpec::Torus { .. } => {
            return Err(cx.err(
                f,
                "not an analytic shape of the closed set (dispatched by `nodes::leaf`)",
            ))
        }
    })
}
