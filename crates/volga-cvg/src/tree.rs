//! A CVG tree: operators over leaves, itself a `volga_core::Field` sampled lazily, with
//! conservative interval bounds per box and the region outside which it equals its
//! background (what baking visits).

use glam::{DVec3, Vec3};
use volga_core::{Aabb, Field, FieldKind};

use crate::op::{complement, Attributes, Op};

/// How a leaf gets its colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LeafColour {
    /// The field's own colour if it has one, else white.
    FromField,
    /// One colour everywhere.
    Constant(Vec3),
    /// A scalar field of colour: `outer` at density 0 to `inner` at density 1, linear in
    /// the leaf's density (figure 41's "colour from a simple scalar field").
    Ramp {
        /// The colour at density 0.
        outer: Vec3,
        /// The colour at density 1.
        inner: Vec3,
    },
}

/// A spatial object: a density field (clamped to \[0, 1\]) with attributes.
pub struct Leaf<'a> {
    field: Box<dyn Field + 'a>,
    colour: LeafColour,
    material: u16,
}

impl<'a> Leaf<'a> {
    /// A leaf of `field`'s density, its colour from the field ([`LeafColour::FromField`]),
    /// material 0.
    pub fn new(field: Box<dyn Field + 'a>) -> Self {
        Leaf {
            field,
            colour: LeafColour::FromField,
            material: 0,
        }
    }

    /// The same leaf coloured by `colour`.
    pub fn with_colour(mut self, colour: LeafColour) -> Self {
        self.colour = colour;
        self
    }

    /// The same leaf with material id `material`.
    pub fn with_material(mut self, material: u16) -> Self {
        self.material = material;
        self
    }

    fn density(&self, p: DVec3) -> f64 {
        if !self.field.bounds().contains(p) {
            return clamp01(self.field.background());
        }
        clamp01(self.field.value(p))
    }

    fn attributes(&self, p: DVec3, d: f64) -> Attributes {
        let colour = match self.colour {
            LeafColour::FromField => self.field.colour(p).unwrap_or(Vec3::ONE),
            LeafColour::Constant(c) => c,
            LeafColour::Ramp { outer, inner } => outer.lerp(inner, d as f32),
        };
        Attributes {
            colour,
            material: self.material,
        }
    }
}

fn clamp01(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// A node of a CVG tree.
pub enum Cvg<'a> {
    /// A spatial object.
    Leaf(Leaf<'a>),
    /// The complement `1 − d` of a subtree.
    Complement(Box<Cvg<'a>>),
    /// A binary operator over two subtrees.
    Binary {
        /// The operator.
        op: Op,
        /// Its operand `A`.
        a: Box<Cvg<'a>>,
        /// Its operand `B`.
        b: Box<Cvg<'a>>,
    },
}

impl std::fmt::Debug for Cvg<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Cvg::Leaf(l) => write!(f, "Leaf({:?})", l.field.bounds()),
            Cvg::Complement(a) => write!(f, "Complement({a:?})"),
            Cvg::Binary { op, a, b } => write!(f, "{}({a:?}, {b:?})", op.name()),
        }
    }
}

impl<'a> Cvg<'a> {
    /// A leaf of `field` ([`Leaf::new`]).
    pub fn leaf(field: impl Field + 'a) -> Self {
        Cvg::Leaf(Leaf::new(Box::new(field)))
    }

    /// `op(a, b)`.
    pub fn op(op: Op, a: Cvg<'a>, b: Cvg<'a>) -> Self {
        Cvg::Binary {
            op,
            a: Box::new(a),
            b: Box::new(b),
        }
    }

    /// The complement of `a`.
    #[allow(clippy::should_implement_trait)]
    pub fn not(a: Cvg<'a>) -> Self {
        Cvg::Complement(Box::new(a))
    }

    /// The density far from everything.
    pub fn background(&self) -> f64 {
        match self {
            Cvg::Leaf(l) => clamp01(l.field.background()),
            Cvg::Complement(a) => complement(a.background()),
            Cvg::Binary { op, a, b } => op.apply(a.background(), b.background()),
        }
    }

    /// A box outside which the density equals [`Cvg::background`]: a leaf's bounds; a
    /// complement's operand's; for a binary operator, the operand boxes the operator
    /// can reach. Where `A` is at its background the result is `op(bgA, dB)`; if that is
    /// the same for every `dB` (the interval form says so), only `A`'s box can differ
    /// from the background (e.g. `min(0, ·)`: an intersection reaches only the overlap,
    /// a difference only `A`'s box). Likewise for `B`; otherwise the union of both.
    pub fn support(&self) -> Aabb {
        match self {
            Cvg::Leaf(l) => l.field.bounds(),
            Cvg::Complement(a) => a.support(),
            Cvg::Binary { op, a, b } => {
                let (bga, bgb) = (a.background(), b.background());
                let fixed_by_a = {
                    let r = op.range((bga, bga), (0.0, 1.0));
                    r.0 == r.1
                };
                let fixed_by_b = {
                    let r = op.range((0.0, 1.0), (bgb, bgb));
                    r.0 == r.1
                };
                match (fixed_by_a, fixed_by_b) {
                    (true, true) => a.support().intersection(&b.support()),
                    (true, false) => a.support(),
                    (false, true) => b.support(),
                    (false, false) => a.support().union(&b.support()),
                }
            }
        }
    }

    /// The density at a point.
    pub fn density(&self, p: DVec3) -> f64 {
        match self {
            Cvg::Leaf(l) => l.density(p),
            Cvg::Complement(a) => complement(a.density(p)),
            Cvg::Binary { op, a, b } => op.apply(a.density(p), b.density(p)),
        }
    }

    /// The density and attributes at a point.
    pub fn sample(&self, p: DVec3) -> (f64, Attributes) {
        match self {
            Cvg::Leaf(l) => {
                let d = l.density(p);
                (d, l.attributes(p, d))
            }
            Cvg::Complement(a) => {
                let (d, attr) = a.sample(p);
                (complement(d), attr)
            }
            Cvg::Binary { op, a, b } => {
                let (da, aa) = a.sample(p);
                let (db, ab) = b.sample(p);
                (op.apply(da, db), op.attributes(da, aa, db, ab))
            }
        }
    }

    /// Conservative bounds of the density over a box.
    pub fn range(&self, world_box: &Aabb) -> (f64, f64) {
        match self {
            Cvg::Leaf(l) => {
                let bounds = l.field.bounds();
                let bg = clamp01(l.field.background());
                let inner = world_box.intersection(&bounds);
                if inner.is_empty() {
                    return (bg, bg);
                }
                let (lo, hi) = l.field.value_range(world_box);
                let (mut lo, mut hi) = (clamp01(lo), if hi.is_nan() { 1.0 } else { hi.clamp(0.0, 1.0) });
                // Part of the box lies outside the leaf's bounds, where it is background.
                if world_box.min.cmplt(bounds.min).any() || world_box.max.cmpgt(bounds.max).any() {
                    lo = lo.min(bg);
                    hi = hi.max(bg);
                }
                (lo, hi)
            }
            Cvg::Complement(a) => {
                let (lo, hi) = a.range(world_box);
                (complement(hi), complement(lo))
            }
            Cvg::Binary { op, a, b } => op.range(a.range(world_box), b.range(world_box)),
        }
    }

    fn has_colour(&self) -> bool {
        match self {
            Cvg::Leaf(l) => l.colour != LeafColour::FromField || l.field.has_colour(),
            Cvg::Complement(a) => a.has_colour(),
            Cvg::Binary { a, b, .. } => a.has_colour() || b.has_colour(),
        }
    }

    fn gradient_step(&self) -> DVec3 {
        match self {
            Cvg::Leaf(l) => l.field.gradient_step(),
            Cvg::Complement(a) => a.gradient_step(),
            Cvg::Binary { a, b, .. } => a.gradient_step().min(b.gradient_step()),
        }
    }

    /// Leaves under this node.
    pub fn leaf_count(&self) -> usize {
        match self {
            Cvg::Leaf(_) => 1,
            Cvg::Complement(a) => a.leaf_count(),
            Cvg::Binary { a, b, .. } => a.leaf_count() + b.leaf_count(),
        }
    }
}

/// A CVG tree as a field: density, the attribute colour, and [`Cvg::range`] as its
/// `value_range` so the raycaster skips boxes whose bounds say nothing is visible.
pub struct CvgField<'a> {
    tree: Cvg<'a>,
    bounds: Aabb,
    background: f64,
    step: DVec3,
}

impl<'a> CvgField<'a> {
    /// The tree restricted to `clip` (a scene's grid box): outside `support ∩ clip` the
    /// value is the tree's background.
    pub fn new(tree: Cvg<'a>, clip: &Aabb) -> Self {
        CvgField {
            bounds: tree.support().intersection(clip),
            background: tree.background(),
            step: tree.gradient_step(),
            tree,
        }
    }

    /// The tree it samples.
    pub fn tree(&self) -> &Cvg<'a> {
        &self.tree
    }

    /// Sets the central-difference step (a scene's voxel spacing); by default the
    /// smallest of the leaves'.
    pub fn set_gradient_step(&mut self, step: DVec3) {
        self.step = step;
    }
}

impl std::fmt::Debug for CvgField<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CvgField")
            .field("tree", &self.tree)
            .field("bounds", &self.bounds)
            .finish()
    }
}

impl Field for CvgField<'_> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn kind(&self) -> FieldKind {
        FieldKind::Density
    }
    fn background(&self) -> f64 {
        self.background
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.tree.density(world_pos)
    }
    fn gradient_step(&self) -> DVec3 {
        self.step
    }
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        self.tree.range(world_box)
    }
    fn has_colour(&self) -> bool {
        self.tree.has_colour()
    }
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        Some(self.tree.sample(world_pos).1.colour)
    }
}
