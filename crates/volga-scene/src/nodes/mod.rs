//! The scene as a tree of nodes: operators (today the fuzzy union; intersection,
//! difference, blend and the CVG operators slot in beside it) over leaves (analytic
//! shapes, meshes, the torus; later volumes, noise, hypertextures, sculpts, ADFs).
//!
//! Each node kind lives in one file and implements [`Node`]: it is validated from its
//! spec (no I/O), resolves the files it names in the resolve stage, estimates the memory
//! its baking needs, offers itself as a lazy [`Field`] the raycaster samples directly,
//! and bakes itself into a sparse volume.
//!
//! **How to add a node kind**: write `nodes/<kind>.rs` with its spec (serde, deny unknown
//! fields) and a type implementing [`Node`]; register it with its variant (its fields) in
//! `model::ShapeSpec` (a leaf) or `model::NodeSpec` (an operator) and one arm in
//! [`leaf`] (or `union::from_spec`). `nodes/torus.rs` is the worked example.

pub mod adf;
pub mod cvg;
pub mod fuzzy;
pub mod hypertexture;
pub mod mesh;
pub mod procedural;
pub mod sculpt;
pub mod shape;
pub mod textured;
pub mod torus;
pub mod union;
pub mod volume;

use std::path::Path;

use glam::{DVec3, Vec3};
use volga_core::{Aabb, Field, FieldKind, Grid, IndexBox, Progress, Rgb, SparseVolume};
use volga_shapes::OrientedBoxFilter;
use volga_voxelize::Solid;

use crate::ctx::Ctx;
use crate::model::{ObjectSpec, ShapeSpec};
use crate::SceneError;

/// Upper bound on what baking a node allocates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Estimate {
    /// Bricks of 8³ voxels its volume may hold.
    pub bricks: u64,
    /// Other bytes held while baking (meshes: BVH, per-triangle data, feature regions).
    pub extra_bytes: u64,
}

impl Estimate {
    /// The two estimates added (saturating): what baking both nodes allocates at most.
    pub fn plus(self, o: Estimate) -> Estimate {
        Estimate {
            bricks: self.bricks.saturating_add(o.bricks),
            extra_bytes: self.extra_bytes.saturating_add(o.extra_bytes),
        }
    }
}

/// What the resolve stage gives nodes: where relative paths start.
pub struct Resolve<'a> {
    /// The scene file (errors name it).
    pub scene: &'a Path,
    /// Its folder: paths in the scene are relative to it.
    pub dir: &'a Path,
    /// Bytes a file may take to parse (checked from its size before parsing).
    pub memory_limit: u64,
    /// Whether paths may leave `dir` (see [`crate::BuildOptions::allow_outside_paths`]).
    pub allow_outside: bool,
}

impl Resolve<'_> {
    /// The file a scene path names: inside the scene's folder unless `allow_outside`;
    /// errors name the scene file and `field`.
    pub fn file(&self, field: &str, path: &str) -> Result<std::path::PathBuf, SceneError> {
        scene_file(self.scene, self.dir, field, path, self.allow_outside)
    }
}

/// The file `path` (from `field` of the file `scene`) names, relative to `dir`, refused
/// when it leaves `dir` unless `allow_outside`.
pub fn scene_file(
    scene: &Path,
    dir: &Path,
    field: &str,
    path: &str,
    allow_outside: bool,
) -> Result<std::path::PathBuf, SceneError> {
    if allow_outside {
        return Ok(dir.join(path));
    }
    volga_core::input::confine(dir, path).map_err(|why| SceneError::Invalid {
        path: scene.to_owned(),
        field: field.to_owned(),
        message: format!(
            "`{path}` {why}: a scene reads only files in its own folder (pass --allow-outside-paths to allow others)"
        ),
    })
}

/// One node of a validated scene. Fields are world space `f64`; baked volumes hold
/// `f32` densities in \[0, 1\] (the oriented box filter's profile) and, when asked,
/// colour.
pub trait Node: std::fmt::Debug + Send + Sync {
    /// The kind's name, as in the report (`shape`, `mesh`, `torus`, `union`).
    fn kind(&self) -> &'static str;
    /// The object's name in the scene (`objects[3]` when unnamed).
    fn name(&self) -> &str;
    /// Operands of an operator; leaves have none.
    fn children(&self) -> &[Box<dyn Node>] {
        &[]
    }
    /// Loads the files the node names. Validation does no I/O; this stage does.
    fn resolve(&mut self, _cx: &Resolve) -> Result<(), SceneError> {
        Ok(())
    }
    /// World box outside which the node's solid is empty (may be infinite).
    fn bounds(&self) -> Aabb;
    /// Colour of the voxels this node wins in a union, when its baked volume carries
    /// no colour channel of its own.
    fn colour(&self) -> Rgb {
        [1.0; 3]
    }
    /// Analytic leaves: the solid, so a union voxelizes all of them in one pass.
    fn as_solid(&self) -> Option<Solid> {
        None
    }
    /// Upper bound on what [`Node::bake`] allocates on `grid`.
    fn estimate(&self, grid: &Grid) -> Estimate;
    /// The node as a procedural density field, filtered as if voxelized on `grid` (the
    /// same oriented box filter), clipped to the grid's world bounds: at a voxel centre
    /// it equals the baked value up to the `f32` rounding of the payload.
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError>;
    /// The node voxelized on `grid` (density, and colour when `colour`).
    fn bake(&self, grid: &Grid, colour: bool, progress: &dyn Progress) -> Result<SparseVolume, SceneError> {
        self.bake_in(grid, colour, &grid.index_box(), progress)
    }
    /// [`Node::bake`] on the bricks of `grid` that meet `clip` (voxel indices) only: each
    /// of them bit for bit the whole bake's brick, no other brick stored or computed.
    /// Chunked and out-of-core bakes are made of these. By default the node's lazy field
    /// is baked ([`procedural::bake_field_in`]); nodes with a voxelizer of their own
    /// (shapes, meshes, unions, sculpts) override it.
    fn bake_in(
        &self,
        grid: &Grid,
        colour: bool,
        clip: &IndexBox,
        _progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        Ok(procedural::bake_field_in(
            self.lazy_field(grid)?.as_ref(),
            grid,
            colour,
            clip,
        ))
    }
    /// Where this node's procedural work (noise) runs, for the plan; `None` when it has
    /// none.
    fn procedural_plan(&self) -> Option<String> {
        None
    }
    /// This node's counters (samples, noise evaluations) so far, for the report; not
    /// its children's.
    fn counters(&self) -> Vec<procedural::NodeCounters> {
        Vec::new()
    }
}

/// The counters of a node and all nodes below it, depth first.
pub fn all_counters(node: &dyn Node) -> Vec<procedural::NodeCounters> {
    let mut out = node.counters();
    for c in node.children() {
        out.extend(all_counters(c.as_ref()));
    }
    out
}

/// The procedural plans of a node and all nodes below it, as `(node, plan)`.
pub fn all_procedural_plans(node: &dyn Node) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = node
        .procedural_plan()
        .map(|p| (node.name().to_string(), p))
        .into_iter()
        .collect();
    for c in node.children() {
        out.extend(all_procedural_plans(c.as_ref()));
    }
    out
}

/// The filter a grid's voxels are sampled with (half-width = voxel diagonal).
pub fn grid_filter(grid: &Grid) -> OrientedBoxFilter {
    OrientedBoxFilter::for_spacing(grid.transform.spacing())
}

/// The node for one object of the scene (a leaf: its shape decides the kind).
pub fn leaf(cx: &Ctx, f: &str, index: usize, o: &ObjectSpec) -> Result<Box<dyn Node>, SceneError> {
    let colour = cx.colour(&format!("{f}.colour"), o.colour)?;
    let name = o.name.clone().unwrap_or_else(|| format!("object{index}"));
    let sf = format!("{f}.shape");
    Ok(match &o.shape {
        ShapeSpec::Mesh { .. } | ShapeSpec::Triangles { .. } => {
            Box::new(mesh::MeshNode::validate(cx, &sf, name, &o.shape, colour)?)
        }
        ShapeSpec::Torus { .. } => Box::new(torus::TorusNode::validate(cx, &sf, name, &o.shape, colour)?),
        analytic => Box::new(shape::ShapeNode::validate(cx, &sf, name, analytic, colour)?),
    })
}

/// A leaf's lazy field: restricted to a world box (outside it, the background) and,
/// when tinted, painted one colour.
#[derive(Debug)]
pub struct Clipped<F> {
    field: F,
    bounds: Aabb,
    colour: Option<Rgb>,
}

impl<F: Field> Clipped<F> {
    /// `field` restricted to `world_box` (its bounds become their intersection), with the
    /// field's own colour.
    pub fn new(field: F, world_box: Aabb) -> Self {
        let bounds = field.bounds().intersection(&world_box);
        Clipped {
            field,
            bounds,
            colour: None,
        }
    }

    /// The same field with this colour everywhere.
    pub fn tinted(mut self, colour: Rgb) -> Self {
        self.colour = Some(colour);
        self
    }
}

impl<F: Field> Field for Clipped<F> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn kind(&self) -> FieldKind {
        self.field.kind()
    }
    fn background(&self) -> f64 {
        self.field.background()
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.field.value(world_pos)
    }
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        self.field.gradient(world_pos)
    }
    fn gradient_step(&self) -> DVec3 {
        self.field.gradient_step()
    }
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        self.field.value_range(world_box)
    }
    fn has_colour(&self) -> bool {
        self.colour.is_some() || self.field.has_colour()
    }
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        match self.colour {
            Some(c) => Some(Vec3::from(c)),
            None => self.field.colour(world_pos),
        }
    }
    fn sample_spacing(&self) -> f64 {
        self.field.sample_spacing()
    }
}

/// Bricks of `grid` within the filter band of a world box (the box grown by the
/// filter's half-width), clipped to the grid: an upper bound on what voxelizing a
/// solid inside that box allocates.
pub fn bricks_within(grid: &Grid, world_box: &Aabb) -> u64 {
    let band = world_box.expanded(DVec3::splat(grid_filter(grid).half_width()));
    let clipped = band.intersection(&grid.world_bounds());
    if clipped.is_empty() {
        return 0;
    }
    let t = &grid.transform;
    let lo = t.world_to_index(clipped.min).floor().max(DVec3::ZERO);
    let hi = t.world_to_index(clipped.max).ceil().min(grid.dims().as_dvec3() - 1.0);
    let brick = volga_core::BRICK_DIM as f64;
    let n = ((hi / brick).floor() - (lo / brick).floor() + 1.0).max(DVec3::ZERO);
    (n.x * n.y * n.z) as u64
}
