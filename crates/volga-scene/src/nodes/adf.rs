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
//!
//! Bounds, before any work: an unbounded source (an infinite cylinder) is refused at
//! validation; the ADF's estimated cells ([`Adf::estimate`], from the tolerance, the depth
//! and the source's area and curvature) are refused at resolve when they alone exceed
//! the memory limit, and counted in the plan's memory estimate with the grid's band; the
//! build stops at the cells the memory limit holds, should the estimate be low.

use std::sync::OnceLock;

use glam::DVec3;
use serde::{Deserialize, Serialize};
use volga_adf::{Adf, AdfError, AdfOptions, AdfSource, BuildEstimate, MeshSource, ShapeSource, MAX_SUPPORTED_DEPTH};
use volga_core::memory::Bytes;
use volga_core::{Aabb, Field, Grid, IndexBox, NoProgress, Progress, Rgb, SparseVolume};
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
    /// The memory limit given at resolve: the build stops at the cells it holds.
    memory_limit: u64,
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
            analytic => {
                let shape = validate_shape(cx, &sf, analytic)?;
                let b = shape.bounds();
                if !(b.min.is_finite() && b.max.is_finite()) {
                    return Err(cx.err(
                        sf,
                        "is unbounded (e.g. a cylinder without half_length): an ADF covers a finite cube around its source; give the shape finite bounds",
                    ));
                }
                Source::Shape(shape)
            }
        };
        Ok(AdfNode {
            name,
            field: f.to_owned(),
            colour,
            source,
            tolerance_fraction: tolerance,
            max_depth: spec.max_depth,
            memory_limit: u64::MAX,
            adf: OnceLock::new(),
        })
    }

    /// The build's options with the tolerance holding within `band` of the surface.
    fn options(&self, band: f64) -> AdfOptions {
        AdfOptions {
            max_depth: self.max_depth,
            band,
            max_cells: BuildEstimate::cells_within(self.memory_limit),
            ..AdfOptions::relative(self.tolerance_fraction, &self.source_bounds())
        }
    }

    /// Runs `f` on the node's source (the mesh's once resolved).
    fn with_source<T>(&self, f: impl FnOnce(&dyn AdfSource) -> Result<T, AdfError>) -> Result<T, String> {
        match &self.source {
            Source::Mesh(m) => {
                let mesh = m.mesh().ok_or("the mesh was not loaded (resolve the scene first)")?;
                let source = MeshSource::new(mesh).map_err(|e| e.to_string())?;
                f(&source).map_err(|e| e.to_string())
            }
            Source::Shape(s) => f(&ShapeSource(*s)).map_err(|e| e.to_string()),
        }
    }

    /// The build's estimate within `band` of the surface (0 when unknown).
    fn build_estimate(&self, band: f64) -> Option<BuildEstimate> {
        self.with_source(|s| Adf::estimate(s, &self.options(band))).ok()
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
    /// Its progress is told to `progress` (cells built).
    pub fn adf(&self, grid: &Grid, progress: &dyn Progress) -> Result<&Adf, SceneError> {
        let built = self.adf.get_or_init(|| {
            let options = self.options(grid_filter(grid).half_width());
            self.with_source(|s| Adf::build_with_progress(s, options, progress))
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
    /// Loads a mesh source, then refuses an ADF whose estimated build alone (without the
    /// grid's band, which only adds cells) exceeds the memory limit.
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        if let Source::Mesh(m) = &mut self.source {
            m.resolve(cx)?;
        }
        self.memory_limit = cx.memory_limit;
        let options = self.options(0.0);
        let estimate = self
            .with_source(|s| Adf::estimate(s, &options))
            .map_err(|message| SceneError::Invalid {
                path: cx.scene.to_owned(),
                field: format!("{}.source", self.field),
                message,
            })?;
        if estimate.build_bytes > cx.memory_limit {
            return Err(SceneError::TooLarge {
                path: cx.scene.to_owned(),
                needed: Bytes(u128::from(estimate.build_bytes)),
                limit: Bytes(u128::from(cx.memory_limit)),
                detail: format!(
                    "field `{}.tolerance`: an ADF of tolerance {} at max_depth {} needs about {} cells ({} per cell while building); raise the tolerance or lower max_depth",
                    self.field,
                    self.tolerance_fraction,
                    self.max_depth,
                    estimate.cells,
                    volga_adf::BUILD_BYTES_PER_CELL
                ),
            });
        }
        Ok(())
    }
    fn bounds(&self) -> Aabb {
        self.source_bounds()
    }
    fn colour(&self) -> Rgb {
        self.colour
    }
    /// The bricks around the source, and the ADF's build ([`Adf::estimate`] with the
    /// grid's band) as the node's own bytes; the build also stops at the memory limit
    /// (`AdfError::TooManyCells`), should the estimate be low.
    fn estimate(&self, grid: &Grid) -> Estimate {
        let adf = self
            .build_estimate(grid_filter(grid).half_width())
            .map_or(0, |e| e.build_bytes);
        Estimate {
            bricks: bricks_within(grid, &self.source_bounds()),
            extra_bytes: adf,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        self.lazy_field_with(grid, &NoProgress)
    }
    fn bake_in(
        &self,
        grid: &Grid,
        colour: bool,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        let field = self.lazy_field_with(grid, progress)?;
        Ok(super::procedural::bake_field_in(&*field, grid, colour, clip))
    }
}

impl AdfNode {
    /// [`Node::lazy_field`], the ADF's build (on first use) told to `progress`.
    fn lazy_field_with(&self, grid: &Grid, progress: &dyn Progress) -> Result<Box<dyn Field + '_>, SceneError> {
        let density = AdfDensity {
            adf: self.adf(grid, progress)?,
            filter: grid_filter(grid),
        };
        Ok(Box::new(Clipped::new(density, grid.world_bounds()).tinted(self.colour)))
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
