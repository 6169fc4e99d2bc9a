//! Leaf node: an adaptively sampled distance field (`volga-adf`, docs/ADF.md) built from
//! a mesh or an analytic shape, seen through the grid's oriented box filter like every
//! other solid. RON: `Adf((source: Mesh(path: "bunny.obj"), tolerance: 1e-3))`.
//!
//! The ADF is built once, on first use (a lazy render or a bake), from the source as the
//! scene places it; its tolerance is a fraction of the source's bounding-box diagonal and
//! holds everywhere within the filter's half-width of the surface (the ADF's `band`).
//! The density at a point is `filter.density(d)` of the ADF's reconstructed distance `d`,
//! so the baked voxels and the lazy field agree to the `f32` payload, and both differ
//! from the source's own voxelization by at most the tolerance over the filter's slope.

use std::sync::OnceLock;

use glam::DVec3;
use serde::{Deserialize, Serialize};
use volga_adf::{Adf, AdfOptions, MeshSource, ShapeSource, MAX_SUPPORTED_DEPTH};
use volga_core::{Aabb, Field, Grid, Progress, Rgb, SparseVolume};
use volga_shapes::{OrientedBoxFilter, Shape, SignedDistance};

use super::mesh::MeshNode;
use super::shape::validate_shape;
use super::{bricks_within, grid_filter, Clipped, Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::{ShapeSpec, V3};
use crate::SceneError;

/// `Adf(...)` in a scene tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdfSpec {
    /// A label for reports; default `objectN`, N counting the tree's leaf nodes (objects,
    /// `Fuzzy`, `Volume`, `Hypertexture`, `Adf`) in file order from 0.
    #[serde(default)]
    pub name: Option<String>,
    /// What the distance field is built from: a mesh (`Mesh(path: ..)`, `Triangles(..)`)
    /// or an analytic shape (`Sphere`, `Box`, `Cylinder`, …).
    pub source: ShapeSpec,
    /// Largest reconstruction error at the cells' test points, as a fraction of the
    /// source's bounding-box diagonal (0 < tolerance < 1).
    pub tolerance: f64,
    /// Deepest octree level (the root cube is level 0); default 10.
    #[serde(default = "default_depth")]
    pub max_depth: u8,
    /// Linear RGB in \[0, 1\]; white when absent.
    #[serde(default)]
    pub colour: Option<V3>,
}

fn default_depth() -> u8 {
    10
}

/// What the ADF is built from.
#[derive(Debug)]
enum Source {
    Mesh(Box<MeshNode>),
    Shape(Shape),
}

/// Leaf node: an adaptively sampled distance field of a mesh or an analytic shape, built on
/// first use and seen through the grid's oriented box filter.
#[derive(Debug)]
pub struct AdfNode {
    name: String,
    field: String,
    colour: Rgb,
    source: Source,
    tolerance_fraction: f64,
    max_depth: u8,
    adf: OnceLock<Result<Adf, String>>,
}

impl AdfNode {
    /// `f` is the node's field path (`root.Adf`).
    pub fn validate(cx: &Ctx, f: &str, spec: &AdfSpec, index: usize) -> Result<Self, SceneError> {
        let colour = cx.colour(&format!("{f}.colour"), spec.colour)?;
        let name = spec.name.clone().unwrap_or_else(|| format!("object{index}"));
        let tolerance = cx.positive(&format!("{f}.tolerance"), spec.tolerance)?;
        if tolerance >= 1.0 {
            return Err(cx.err(
                format!("{f}.tolerance"),
                format!("is a fraction of the source's bounding-box diagonal and must be below 1, got {tolerance}"),
            ));
        }
        if spec.max_depth == 0 || spec.max_depth > MAX_SUPPORTED_DEPTH {
            return Err(cx.err(
                format!("{f}.max_depth"),
                format!("must be 1 to {MAX_SUPPORTED_DEPTH}, got {}", spec.max_depth),
            ));
        }
        let sf = format!("{f}.source");
        let source = match &spec.source {
            ShapeSpec::Mesh { .. } | ShapeSpec::Triangles { .. } => Source::Mesh(Box::new(MeshNode::validate(
                cx,
                &sf,
                name.clone(),
                &spec.source,
                colour,
            )?)),
            ShapeSpec::Torus { .. } => {
                return Err(cx.err(sf, "a torus is not an ADF source yet (meshes and the other shapes are)"))
            }
            analytic => Source::Shape(validate_shape(cx, &sf, analytic)?),
        };
        Ok(AdfNode {
            name,
            field: f.to_owned(),
            colour,
            source,
            tolerance_fraction: tolerance,
            max_depth: spec.max_depth,
            adf: OnceLock::new(),
        })
    }

    /// The source's bounds (the placed mesh once resolved).
    fn source_bounds(&self) -> Aabb {
        match &self.source {
            Source::Mesh(m) => m.bounds(),
            Source::Shape(s) => s.bounds(),
        }
    }

    /// The ADF, built on first use, with the tolerance holding in the whole ramp of
    /// `grid`'s filter (`band` = its half-width): the density reads the distance there.
    pub fn adf(&self, grid: &Grid) -> Result<&Adf, SceneError> {
        let built = self.adf.get_or_init(|| {
            let bounds = self.source_bounds();
            let options = AdfOptions {
                max_depth: self.max_depth,
                band: grid_filter(grid).half_width(),
                ..AdfOptions::relative(self.tolerance_fraction, &bounds)
            };
            match &self.source {
                Source::Mesh(m) => {
                    let mesh = m.mesh().ok_or("the mesh was not loaded (resolve the scene first)")?;
                    let source = MeshSource::new(mesh).map_err(|e| e.to_string())?;
                    Adf::build(&source, options).map_err(|e| e.to_string())
                }
                Source::Shape(s) => Adf::build(&ShapeSource(*s), options).map_err(|e| e.to_string()),
            }
        });
        built.as_ref().map_err(|message| SceneError::Invalid {
            path: Default::default(),
            field: self.field.clone(),
            message: message.clone(),
        })
    }
}

impl Node for AdfNode {
    fn kind(&self) -> &'static str {
        "adf"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        match &mut self.source {
            Source::Mesh(m) => m.resolve(cx),
            Source::Shape(_) => Ok(()),
        }
    }
    fn bounds(&self) -> Aabb {
        self.source_bounds()
    }
    fn colour(&self) -> Rgb {
        self.colour
    }
    /// The bricks around the source; the ADF's own cells are refused by its build beyond
    /// the memory available (`AdfError::TooManyCells`).
    fn estimate(&self, grid: &Grid) -> Estimate {
        Estimate {
            bricks: bricks_within(grid, &self.source_bounds()),
            extra_bytes: 0,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let density = AdfDensity {
            adf: self.adf(grid)?,
            filter: grid_filter(grid),
        };
        Ok(Box::new(Clipped::new(density, grid.world_bounds()).tinted(self.colour)))
    }
    fn bake(&self, grid: &Grid, colour: bool, _progress: &dyn Progress) -> Result<SparseVolume, SceneError> {
        let field = self.lazy_field(grid)?;
        Ok(super::procedural::bake_field(&*field, grid, colour))
    }
}

/// An ADF through the oriented box filter: `filter.density(d)`.
#[derive(Debug)]
struct AdfDensity<'a> {
    adf: &'a Adf,
    filter: OrientedBoxFilter,
}

impl Field for AdfDensity<'_> {
    /// The root cube (the source's box with a margin) grown by the filter.
    fn bounds(&self) -> Aabb {
        self.adf.root_box().expanded(DVec3::splat(self.filter.half_width()))
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.filter.density(self.adf.distance(world_pos))
    }
    /// A third of the filter's half-width (one voxel of the grid it was made for).
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.filter.half_width() / 3f64.sqrt())
    }
    /// The profile is monotone decreasing in the distance; the ADF's ranges are
    /// conservative per leaf.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let (lo, hi) = self.adf.range(world_box);
        (self.filter.density(hi), self.filter.density(lo))
    }
}
