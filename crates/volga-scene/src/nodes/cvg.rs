//! Operator node: a CVG operator (survey §17.5, eqs. 17 and 18, blend, complement) over
//! any nodes, evaluated through `volga_cvg`: lazily as a `CvgField` (interval bounds per
//! box for empty-space skipping) or baked over only the region the operator reaches (an
//! intersection bakes the overlap, a difference its first operand's box).
//!
//! Attributes follow `volga_cvg::Op::attributes`: union/intersection take the operand
//! whose density wins, differences keep the first operand's, algebraic operators and
//! blend mix colours weighted by density.

use glam::Vec3;
use serde::{Deserialize, Serialize};
use volga_core::{Aabb, Field, Grid};
use volga_cvg::{Cvg, CvgField, Leaf, LeafColour, Op};

use super::procedural::{Counted, Counters, NodeCounters};
use super::{Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::NodeSpec;
use crate::SceneError;

/// `Cvg(op: Intersection, operands: [A, B])`; `Complement` takes one operand, the
/// others two (`Union`, `Intersection`, `Difference` of eq. 17; `Product`,
/// `ProbabilisticSum`, `AlgebraicDifference` of eq. 18; `Blend(w)` with `w` in \[0, 1\]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CvgSpec {
    /// A label for the report; default the node's field path (`root.Cvg`).
    #[serde(default)]
    pub name: Option<String>,
    /// The operator.
    pub op: CvgOpSpec,
    /// The operand nodes, A then B: one for `Complement`, two for every other operator.
    pub operands: Vec<NodeSpec>,
}

/// A CVG operator on the operands' densities `dA`, `dB` (each in \[0, 1\]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum CvgOpSpec {
    /// Fuzzy union `max(dA, dB)` (eq. 17); colour of the denser operand (A on ties).
    Union,
    /// Fuzzy intersection `min(dA, dB)` (eq. 17); colour of the thinner operand (A on
    /// ties).
    Intersection,
    /// Fuzzy difference `min(dA, 1 − dB)` (eq. 17): B carves A; A's colour.
    Difference,
    /// Complement `1 − d` of its one operand, whose colour it keeps; 1 far from the
    /// operand, so it fills the grid.
    Complement,
    /// Algebraic intersection `dA·dB` (eq. 18); colours weighted by density.
    Product,
    /// Algebraic union `dA + dB − dA·dB` (eq. 18); colours weighted by density.
    ProbabilisticSum,
    /// Algebraic difference `dA − dA·dB` (eq. 18): B carves A; A's colour.
    AlgebraicDifference,
    /// Blend `w·dA + (1 − w)·dB` with the weight `w` in \[0, 1\]; colours weighted by
    /// `w·dA` and `(1 − w)·dB`.
    Blend(f64),
}

/// Operator node: a CVG operator over one or two nodes (`NodeSpec::Cvg`).
#[derive(Debug)]
pub struct CvgNode {
    name: String,
    /// `None`: the complement.
    op: Option<Op>,
    children: Vec<Box<dyn Node>>,
    counters: Counters,
}

impl CvgNode {
    /// Checks a `Cvg` spec at field path `f` (`root.Cvg`) and its operands; `leaves` counts
    /// the leaf nodes met so far, for their default names.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field refused: `{f}.op.Blend` for a weight
    /// outside \[0, 1\], `{f}.operands` for the wrong number of operands, or an operand's
    /// own field.
    pub fn validate(cx: &Ctx, f: &str, spec: &CvgSpec, leaves: &mut usize) -> Result<Self, SceneError> {
        let (op, arity) = match spec.op {
            CvgOpSpec::Union => (Some(Op::Union), 2),
            CvgOpSpec::Intersection => (Some(Op::Intersection), 2),
            CvgOpSpec::Difference => (Some(Op::Difference), 2),
            CvgOpSpec::Complement => (None, 1),
            CvgOpSpec::Product => (Some(Op::Product), 2),
            CvgOpSpec::ProbabilisticSum => (Some(Op::ProbabilisticSum), 2),
            CvgOpSpec::AlgebraicDifference => (Some(Op::AlgebraicDifference), 2),
            CvgOpSpec::Blend(w) => {
                if !(0.0..=1.0).contains(&w) {
                    return Err(cx.err(
                        format!("{f}.op.Blend"),
                        format!("the weight must lie in [0, 1], got {w}"),
                    ));
                }
                (Some(Op::Blend(w)), 2)
            }
        };
        if spec.operands.len() != arity {
            return Err(cx.err(
                format!("{f}.operands"),
                format!("{:?} takes {arity} operand(s), got {}", spec.op, spec.operands.len()),
            ));
        }
        let children = spec
            .operands
            .iter()
            .enumerate()
            .map(|(i, o)| super::union::node(cx, &format!("{f}.operands[{i}]"), o, leaves))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(CvgNode {
            name: spec.name.clone().unwrap_or_else(|| f.to_string()),
            op,
            children,
            counters: Counters::default(),
        })
    }

    fn tree<'a>(&'a self, grid: &Grid) -> Result<Cvg<'a>, SceneError> {
        let leaf = |c: &'a dyn Node| -> Result<Cvg<'a>, SceneError> {
            let field = c.lazy_field(grid)?;
            let colour = if field.has_colour() {
                LeafColour::FromField
            } else {
                LeafColour::Constant(Vec3::from(c.colour()))
            };
            Ok(Cvg::Leaf(Leaf::new(field).with_colour(colour)))
        };
        Ok(match self.op {
            None => Cvg::not(leaf(self.children[0].as_ref())?),
            Some(op) => Cvg::op(op, leaf(self.children[0].as_ref())?, leaf(self.children[1].as_ref())?),
        })
    }
}

impl Node for CvgNode {
    fn kind(&self) -> &'static str {
        "cvg"
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
    /// The operator's reach (`Cvg::support`) from the operands' boxes.
    fn bounds(&self) -> Aabb {
        let b: Vec<Aabb> = self.children.iter().map(|c| c.bounds()).collect();
        match self.op {
            None => Aabb::new(glam::DVec3::splat(f64::NEG_INFINITY), glam::DVec3::splat(f64::INFINITY)),
            Some(Op::Intersection | Op::Product) => b[0].intersection(&b[1]),
            Some(Op::Difference | Op::AlgebraicDifference) => b[0],
            Some(_) => b[0].union(&b[1]),
        }
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        let reach = self.bounds().intersection(&grid.world_bounds());
        let operands = self.children.iter().fold(Estimate::default(), |e, c| Estimate {
            bricks: 0,
            extra_bytes: e.extra_bytes.saturating_add(c.estimate(grid).extra_bytes),
        });
        Estimate {
            bricks: super::bricks_within(grid, &reach),
            extra_bytes: operands.extra_bytes,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let mut field = CvgField::new(self.tree(grid)?, &grid.world_bounds());
        field.set_gradient_step(grid.transform.spacing());
        Ok(Box::new(Counted {
            field,
            samples: &self.counters.samples,
        }))
    }
    fn counters(&self) -> Vec<NodeCounters> {
        vec![NodeCounters {
            node: self.name.clone(),
            kind: self.kind().into(),
            samples: self.counters.samples.get(),
            noise_evaluations: 0,
        }]
    }
}
