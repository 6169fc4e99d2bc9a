//! Operator node: the fuzzy union (max, survey eq. 17) of its operands.
//!
//! Colour goes with density: a voxel takes the colour of the operand that is strictly
//! densest there (the first on ties). Analytic leaves are voxelized together in one
//! `voxelize_solids` pass and rendered lazily through one `AnalyticField` (static
//! dispatch over the closed shape set); other operands follow in scene order.

use glam::{DVec3, Vec3};
use volga_core::{brick_index_box, Aabb, Field, Grid, IndexBox, Progress, Rgb, SparseVolume};
use volga_voxelize::{estimate_solid_bricks, merge_max, voxelize_solids_in, AnalyticField, Solid};

use super::{grid_filter, leaf, Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::{NodeSpec, ObjectSpec};
use crate::SceneError;

/// The union of its children.
#[derive(Debug)]
pub struct Union {
    name: String,
    children: Vec<Box<dyn Node>>,
}

impl Union {
    /// The union of `children` in order, labelled `name` in reports.
    pub fn new(name: impl Into<String>, children: Vec<Box<dyn Node>>) -> Self {
        Union {
            name: name.into(),
            children,
        }
    }

    /// Today's flat `objects` list: their union, in order.
    pub fn from_objects(cx: &Ctx, f: &str, objects: &[ObjectSpec]) -> Result<Self, SceneError> {
        if objects.is_empty() {
            return Err(cx.err(f, "the scene has no objects"));
        }
        let children = objects
            .iter()
            .enumerate()
            .map(|(i, o)| leaf(cx, &format!("{f}[{i}]"), i, o))
            .collect::<Result<_, _>>()?;
        Ok(Union::new("objects", children))
    }

    /// A scene's `root`: a union as it is, any other node wrapped in a union of one.
    pub fn from_root(cx: &Ctx, f: &str, root: &NodeSpec) -> Result<Self, SceneError> {
        match from_spec(cx, f, root, &mut 0)? {
            Spec::Union(u) => Ok(u),
            Spec::Other(n) => Ok(Union::new("root", vec![n])),
        }
    }

    fn solids(&self) -> Vec<Solid> {
        self.children.iter().filter_map(|c| c.as_solid()).collect()
    }

    fn others(&self) -> impl Iterator<Item = &dyn Node> {
        self.children
            .iter()
            .filter(|c| c.as_solid().is_none())
            .map(|c| c.as_ref())
    }
}

enum Spec {
    Union(Union),
    Other(Box<dyn Node>),
}

/// Validates a node spec; `leaves` numbers the objects for default names.
fn from_spec(cx: &Ctx, f: &str, spec: &NodeSpec, leaves: &mut usize) -> Result<Spec, SceneError> {
    Ok(match spec {
        NodeSpec::Object { name, shape, colour } => {
            *leaves += 1;
            let o = ObjectSpec {
                name: name.clone(),
                shape: shape.clone(),
                colour: *colour,
            };
            Spec::Other(leaf(cx, &format!("{f}.Object"), *leaves - 1, &o)?)
        }
        NodeSpec::Union(operands) => {
            if operands.is_empty() {
                return Err(cx.err(format!("{f}.Union"), "a union needs at least one operand"));
            }
            let mut children: Vec<Box<dyn Node>> = Vec::with_capacity(operands.len());
            for (i, o) in operands.iter().enumerate() {
                children.push(match from_spec(cx, &format!("{f}.Union[{i}]"), o, leaves)? {
                    Spec::Union(u) => Box::new(u),
                    Spec::Other(n) => n,
                });
            }
            Spec::Union(Union::new(f, children))
        }
        NodeSpec::Cvg(s) => Spec::Other(Box::new(super::cvg::CvgNode::validate(
            cx,
            &format!("{f}.Cvg"),
            s,
            leaves,
        )?)),
        NodeSpec::Fuzzy(s) => {
            *leaves += 1;
            Spec::Other(Box::new(super::fuzzy::FuzzyNode::validate(
                cx,
                &format!("{f}.Fuzzy"),
                s,
                *leaves - 1,
            )?))
        }
        NodeSpec::Volume(s) => {
            *leaves += 1;
            Spec::Other(Box::new(super::volume::VolumeNode::validate(
                cx,
                &format!("{f}.Volume"),
                s,
                *leaves - 1,
            )?))
        }
        NodeSpec::Textured(s) => Spec::Other(Box::new(super::textured::TexturedNode::validate(
            cx,
            &format!("{f}.Textured"),
            s,
            leaves,
        )?)),
        NodeSpec::Hypertexture(s) => {
            *leaves += 1;
            Spec::Other(Box::new(super::hypertexture::HypertextureNode::validate(
                cx,
                &format!("{f}.Hypertexture"),
                s,
                *leaves - 1,
            )?))
        }
        NodeSpec::Adf(s) => {
            *leaves += 1;
            Spec::Other(Box::new(super::adf::AdfNode::validate(
                cx,
                &format!("{f}.Adf"),
                s,
                *leaves - 1,
            )?))
        }
        NodeSpec::Sculpt { operand, strokes } => {
            let sf = format!("{f}.Sculpt");
            let child: Box<dyn Node> = match from_spec(cx, &format!("{sf}.operand"), operand, leaves)? {
                Spec::Union(u) => Box::new(u),
                Spec::Other(n) => n,
            };
            Spec::Other(Box::new(super::sculpt::SculptNode::new(&sf, child, strokes.clone())))
        }
    })
}

/// Any node spec as a node (a union stays a union); `leaves` numbers objects for
/// default names. What operator nodes call for their operands.
pub fn node(cx: &Ctx, f: &str, spec: &NodeSpec, leaves: &mut usize) -> Result<Box<dyn Node>, SceneError> {
    Ok(match from_spec(cx, f, spec, leaves)? {
        Spec::Union(u) => Box::new(u),
        Spec::Other(n) => n,
    })
}

impl Node for Union {
    fn kind(&self) -> &'static str {
        "union"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn children(&self) -> &[Box<dyn Node>] {
        &self.children
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        self.children.iter_mut().try_for_each(|c| c.resolve(cx))
    }
    fn bounds(&self) -> Aabb {
        self.children.iter().fold(Aabb::EMPTY, |b, c| b.union(&c.bounds()))
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        let solids = Estimate {
            bricks: estimate_solid_bricks(grid, &self.solids()),
            extra_bytes: 0,
        };
        self.others().fold(solids, |e, c| e.plus(c.estimate(grid)))
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let solids = self.solids();
        let analytic = (!solids.is_empty()).then(|| AnalyticField::new(solids, grid_filter(grid)));
        let others = self
            .others()
            .map(|c| Ok((c.lazy_field(grid)?, c.colour())))
            .collect::<Result<Vec<_>, SceneError>>()?;
        let content = analytic
            .iter()
            .map(|a| a.bounds())
            .chain(others.iter().map(|(f, _)| f.bounds()))
            .fold(Aabb::EMPTY, |b, c| b.union(&c));
        Ok(Box::new(UnionField {
            analytic,
            others,
            bounds: content.intersection(&grid.world_bounds()),
            step: grid.transform.spacing(),
        }))
    }
    fn bake_in(
        &self,
        grid: &Grid,
        colour: bool,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        let mut volume = voxelize_solids_in(grid, &self.solids(), colour, clip, progress);
        for c in self.others() {
            let part = c.bake_in(grid, colour, clip, progress)?;
            if part.colour.is_some() {
                merge_max_coloured(&mut volume, &part);
            } else {
                merge_max(&mut volume, &part, c.colour());
            }
        }
        Ok(volume)
    }
}

/// Fuzzy union of `src` (which carries its own colours) into `dst`: where `src` is
/// strictly denser, its density and colour win. Bricks in sorted order: deterministic.
fn merge_max_coloured(dst: &mut SparseVolume, src: &SparseVolume) {
    let grid_box = dst.grid.index_box();
    for b in src.density.sorted_bricks() {
        for ijk in brick_index_box(b).intersection(&grid_box).iter() {
            let v = src.density.get(ijk);
            if v > dst.density.get(ijk) {
                dst.density.set(ijk, v);
                if let (Some(c), Some(s)) = (dst.colour.as_mut(), src.colour.as_ref()) {
                    c.set(ijk, s.get(ijk));
                }
            }
        }
    }
    dst.density.prune();
    if let Some(c) = dst.colour.as_mut() {
        c.prune();
    }
}

/// The lazy union: the analytic leaves through one `AnalyticField`, the other operands
/// through their own fields (one call each per sample).
struct UnionField<'a> {
    analytic: Option<AnalyticField>,
    others: Vec<(Box<dyn Field + 'a>, Rgb)>,
    bounds: Aabb,
    step: DVec3,
}

impl UnionField<'_> {
    /// The densest operand's value and colour (the first on ties).
    fn best(&self, p: DVec3, with_colour: bool) -> (f64, Vec3) {
        let mut best = (0.0, Vec3::ONE);
        if let Some(a) = &self.analytic {
            let v = a.value(p);
            if v > best.0 {
                best = (
                    v,
                    if with_colour {
                        a.colour(p).unwrap_or(Vec3::ONE)
                    } else {
                        Vec3::ONE
                    },
                );
            }
        }
        for (f, c) in &self.others {
            let v = f.value(p);
            if v > best.0 {
                let colour = if with_colour {
                    f.colour(p).unwrap_or(Vec3::from(*c))
                } else {
                    Vec3::ONE
                };
                best = (v, colour);
            }
        }
        best
    }
}

impl std::fmt::Debug for UnionField<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UnionField").field("bounds", &self.bounds).finish()
    }
}

impl Field for UnionField<'_> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.best(world_pos, false).0
    }
    /// The grid's spacing, as for the baked volume.
    fn gradient_step(&self) -> DVec3 {
        self.step
    }
    /// Max preserves conservative bounds.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let mut range = (0.0f64, 0.0f64);
        let operands = self.analytic.iter().map(|a| a as &dyn Field);
        for f in operands.chain(self.others.iter().map(|(f, _)| f.as_ref())) {
            let (lo, hi) = f.value_range(world_box);
            range = (range.0.max(lo), range.1.max(hi));
        }
        range
    }
    fn has_colour(&self) -> bool {
        true
    }
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        Some(self.best(world_pos, true).1)
    }
}
