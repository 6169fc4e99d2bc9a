//! Strokes: a tool, an operation, and how they change the octree.
//!
//! Every operation is volume-sampled: the tool is seen through the oriented box filter of
//! the sculpt's grid (survey §17.4), `t = clamp(½ − d/W, 0, 1)` for the tool's signed
//! distance `d` at a voxel centre, `W = 2√3` voxels, so a tool edge is a linear ramp and
//! edits stay alias-free at any zoom. Per voxel (density `ρ`, colour `c`, all in f64, the
//! result rounded to f32):
//!
//! | op | new voxel |
//! |---|---|
//! | carve (and saw) | `ρ' = min(ρ, 1 − t)` — the fuzzy difference of survey eq. 17 |
//! | add | `ρ' = max(ρ, t)` — the fuzzy union |
//! | spray | `ρ' = min(1, ρ + s·t_f)`, `t_f` the filter widened by the falloff: additive, so a carve followed by a full-strength spray with the same tool restores solid material exactly |
//! | paint | `c' = c + (p − c)·s·t`, density unchanged |
//! | smooth | `ρ' = ρ + (ρ̄ − ρ)·s·t`, `ρ̄` the mean of the 27 neighbours before the stroke |
//!
//! `t = 0` leaves every voxel as it was (bit for bit), which is what bounds an edit to the
//! tool's box: the recursion visits only nodes meeting that box, and a node is left alone
//! (not even subdivided) when the tool's distance range over it proves the operation is
//! the identity there — a stroke far outside the object creates no nodes.

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Aabb, IndexBox};
use volga_shapes::OrientedBoxFilter;

use crate::octree::{child_offset, node_size, Brick, Node, SculptGrid, Voxel, BRICK, BRICK_VOXELS};
use crate::tool::Tool;
use crate::SculptError;

/// What a stroke does with its tool.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Operation {
    /// Subtract the tool volume (carving; with a swept tool, sawing).
    Carve,
    /// Fuzzy union with the tool volume.
    Add,
    /// Additive spray: `strength` in (0, 1] per stroke, `falloff_world ≥ 0` widens the
    /// tool's soft edge (world units) beyond the filter's band.
    ///
    /// `ρ' = min(1, ρ + strength·t_f)` with `t_f = clamp(½ − d/W_f, 0, 1)`,
    /// `W_f = 2·(√3·h + falloff_world)`: the filter's half-width grown by the falloff.
    Spray {
        /// Density added where the tool is fully present, in (0, 1].
        strength: f64,
        /// World distance by which the ramp's half-width exceeds the filter's `√3·h`, ≥ 0.
        falloff_world: f64,
    },
    /// Colour within the tool, `strength` in (0, 1]; shape unchanged.
    Paint {
        /// The paint's linear RGB colour, each channel in \[0, 1\].
        colour: [f32; 3],
        /// Fraction of the way to `colour` where the tool is fully present, in (0, 1].
        strength: f64,
    },
    /// Blend towards the 27-neighbour mean, `strength` in (0, 1].
    Smooth {
        /// Fraction of the way to the mean where the tool is fully present, in (0, 1].
        strength: f64,
    },
}

impl Operation {
    fn validate(&self) -> Result<(), SculptError> {
        let unit = |s: f64| s.is_finite() && s > 0.0 && s <= 1.0;
        let ok = match *self {
            Operation::Carve | Operation::Add => true,
            Operation::Spray {
                strength,
                falloff_world,
            } => unit(strength) && (0.0..=crate::MAX_WORLD).contains(&falloff_world),
            Operation::Paint { colour, strength } => {
                unit(strength) && colour.iter().all(|c| c.is_finite() && (0.0..=1.0).contains(c))
            }
            Operation::Smooth { strength } => unit(strength),
        };
        if ok {
            Ok(())
        } else {
            Err(SculptError::Operation(format!(
                "{self:?}: strengths must be in (0, 1], colours in [0, 1], falloff in [0, 1e100] world units"
            )))
        }
    }

    /// Whether the result depends on neighbouring voxels.
    fn reads_neighbours(&self) -> bool {
        matches!(self, Operation::Smooth { .. })
    }
}

/// A tool and what to do with it: one edit.
#[derive(Debug, Clone)]
pub struct Stroke {
    /// Where the stroke acts.
    pub tool: Tool,
    /// What it does there.
    pub operation: Operation,
}

impl Stroke {
    /// A stroke; refuses an operation whose parameters are out of range (strengths in
    /// (0, 1], colours in \[0, 1\], a finite falloff ≥ 0).
    pub fn new(tool: Tool, operation: Operation) -> Result<Stroke, SculptError> {
        operation.validate()?;
        Ok(Stroke { tool, operation })
    }

    /// The per-voxel rule of this stroke on `grid`: voxel `ijk` holding `old`, whose 27
    /// neighbours (background 0 outside the grid) average `neighbour_mean` before the
    /// stroke, becomes the returned voxel. The octree applies exactly this rule; it is
    /// public so dense references (tests, benchmarks) can apply the same edit.
    pub fn voxel_after(&self, grid: &SculptGrid, ijk: IVec3, old: Voxel, neighbour_mean: f64) -> Voxel {
        let p = Prepared::new(self, *grid);
        p.apply(old, p.tool_density(&self.tool, ijk), neighbour_mean)
    }
}

/// A stroke prepared for one grid: its filter and the voxels it may touch.
pub(crate) struct Prepared<'a> {
    stroke: &'a Stroke,
    grid: SculptGrid,
    filter: OrientedBoxFilter,
    /// Voxels outside this box have `t = 0`.
    pub edit_box: IndexBox,
    /// Whether the edit is large enough to split across threads (small edits run on the
    /// calling thread: waiting for a stolen job costs more than it saves).
    parallel: bool,
}

impl<'a> Prepared<'a> {
    pub fn new(stroke: &'a Stroke, grid: SculptGrid) -> Prepared<'a> {
        let base = grid.spacing() * 3f64.sqrt();
        let half_width = match stroke.operation {
            Operation::Spray { falloff_world, .. } => base + falloff_world,
            _ => base,
        };
        // Finite: the grid's spacing and the falloff are each at most MAX_WORLD.
        let filter = OrientedBoxFilter::with_half_width(half_width).expect("spacing and falloff are validated");
        let reach = stroke.tool.bounds().expanded(DVec3::splat(half_width));
        let edit_box = grid.voxels_touching(&reach);
        Prepared {
            stroke,
            grid,
            filter,
            edit_box,
            parallel: edit_box.volume() >= PARALLEL_VOXELS,
        }
    }

    /// The tool's filtered density at a voxel centre.
    #[inline]
    pub fn tool_density(&self, tool: &Tool, ijk: IVec3) -> f64 {
        self.filter.density(tool.distance(self.grid.voxel_center(ijk)))
    }

    /// The voxel after the stroke, given its tool density `t` and (for smoothing) the mean
    /// of its 27 neighbours before the stroke. The one per-voxel rule: the octree and the
    /// dense references of the tests both call it.
    #[inline]
    pub fn apply(&self, old: Voxel, t: f64, neighbour_mean: f64) -> Voxel {
        let rho = old.density as f64;
        let density = match self.stroke.operation {
            Operation::Carve => rho.min(1.0 - t),
            Operation::Add => rho.max(t),
            Operation::Spray { strength, .. } => (rho + strength * t).min(1.0),
            Operation::Paint { .. } => rho,
            Operation::Smooth { strength } => rho + (neighbour_mean - rho) * (strength * t),
        };
        let colour = match self.stroke.operation {
            Operation::Paint { colour, strength } => {
                let w = strength * t;
                std::array::from_fn(|i| (old.colour[i] as f64 + (colour[i] as f64 - old.colour[i] as f64) * w) as f32)
            }
            _ => old.colour,
        };
        Voxel {
            density: density as f32,
            colour,
        }
    }

    /// Whether the stroke leaves a uniform region of `v` unchanged for every tool density
    /// in `[t_lo, t_hi]` (pointwise operations; smoothing is decided by the caller).
    fn identity_on(&self, v: Voxel, t_hi: f64) -> bool {
        if t_hi <= 0.0 {
            return true;
        }
        let rho = v.density as f64;
        match self.stroke.operation {
            Operation::Carve => rho <= 1.0 - t_hi,
            Operation::Add => rho >= t_hi,
            Operation::Spray { .. } => rho >= 1.0,
            Operation::Paint { colour, .. } => v.colour.map(f32::to_bits) == colour.map(f32::to_bits),
            Operation::Smooth { .. } => false,
        }
    }

    /// Tool density range over the voxel centres of a node.
    fn density_range(&self, tool: &Tool, node: &IndexBox) -> (f64, f64) {
        let (d_lo, d_hi) = tool.distance_range(&self.grid.centres_box(node));
        (self.filter.density(d_hi), self.filter.density(d_lo))
    }
}

/// The smallest box holding both (either may be empty).
pub(crate) fn union(a: Option<IndexBox>, b: Option<IndexBox>) -> Option<IndexBox> {
    match (a, b) {
        (Some(a), Some(b)) => Some(IndexBox::new(a.min.min(b.min), a.max.max(b.max))),
        (x, None) | (None, x) => x,
    }
}

/// Nodes at or above this level edit their children in parallel (large edits only).
const PARALLEL_LEVEL: u32 = 3;
/// Edits whose box holds at least this many voxels (128³) use several threads.
const PARALLEL_VOXELS: u64 = 1 << 21;

/// Applies `p` to `node` (at `origin`, `level`); `old_root` is the whole tree before the
/// stroke (read by smoothing). Returns the new node if anything changed, and the voxels
/// that changed.
pub(crate) fn edit(
    p: &Prepared,
    old_root: &Node,
    node: &Node,
    origin: IVec3,
    level: u32,
) -> (Option<Node>, Option<IndexBox>) {
    let mine = IndexBox::new(origin, origin + node_size(level));
    if mine.intersection(&p.edit_box).is_empty() {
        return (None, None);
    }
    let tool = &p.stroke.tool;
    match node {
        Node::Uniform(v) => {
            let (t_lo, t_hi) = p.density_range(tool, &mine);
            let unchanged = if p.stroke.operation.reads_neighbours() {
                t_hi <= 0.0 || neighbourhood_is(p, old_root, &mine, v.density)
            } else {
                p.identity_on(*v, t_hi)
            };
            if unchanged {
                return (None, None);
            }
            if t_lo == t_hi && !p.stroke.operation.reads_neighbours() {
                let new = p.apply(*v, t_lo, 0.0);
                return if new == *v {
                    (None, None)
                } else {
                    (Some(Node::Uniform(new)), Some(mine))
                };
            }
            if level == 0 {
                return edit_brick(p, old_root, &[*v; BRICK_VOXELS], origin);
            }
            let children: [Node; 8] = std::array::from_fn(|_| Node::Uniform(*v));
            edit_children(p, old_root, &children, origin, level)
        }
        Node::Brick(b) => {
            // A brick the tool cannot change (too far, or already below the carve) is
            // left alone without visiting its voxels.
            let (_, t_hi) = p.density_range(tool, &mine);
            let untouched = t_hi <= 0.0
                || match p.stroke.operation {
                    Operation::Carve => b.max as f64 <= 1.0 - t_hi,
                    Operation::Add => b.min as f64 >= t_hi,
                    Operation::Spray { .. } => b.min >= 1.0,
                    _ => false,
                };
            if untouched {
                return (None, None);
            }
            edit_brick(p, old_root, &b.voxels(), origin)
        }
        Node::Branch(children) => edit_children(p, old_root, children, origin, level),
    }
}

fn edit_children(
    p: &Prepared,
    old_root: &Node,
    children: &[Node; 8],
    origin: IVec3,
    level: u32,
) -> (Option<Node>, Option<IndexBox>) {
    let one = |k: usize| edit(p, old_root, &children[k], origin + child_offset(k, level), level - 1);
    let results: Vec<(Option<Node>, Option<IndexBox>)> = if p.parallel && level >= PARALLEL_LEVEL {
        (0..8).into_par_iter().map(one).collect()
    } else {
        (0..8).map(one).collect()
    };
    if results.iter().all(|(n, _)| n.is_none()) {
        return (None, None);
    }
    let mut changed = None;
    let mut new_children = children.clone();
    for (k, (n, c)) in results.into_iter().enumerate() {
        if let Some(n) = n {
            new_children[k] = n;
        }
        changed = union(changed, c);
    }
    (Some(Node::branch(new_children)), changed)
}

/// Whether every voxel within one voxel of `node` (the smoothing stencil; outside the grid
/// the background 0) has density `value` before the stroke.
fn neighbourhood_is(p: &Prepared, old_root: &Node, node: &IndexBox, value: f32) -> bool {
    let grown = IndexBox::new(node.min - 1, node.max + 1);
    let grid = p.grid.index_box();
    if grown.intersection(&grid) != grown && value != 0.0 {
        return false;
    }
    matches!(old_root.density_range(&grown, IVec3::ZERO, p.grid.levels()), Some((lo, hi)) if lo == value && hi == value)
}

fn edit_brick(
    p: &Prepared,
    old_root: &Node,
    voxels: &[Voxel; BRICK_VOXELS],
    origin: IVec3,
) -> (Option<Node>, Option<IndexBox>) {
    let mine = IndexBox::new(origin, origin + BRICK);
    let work = mine.intersection(&p.edit_box);
    let margin = p.filter.half_width();
    let Some(tool) = p.stroke.tool.localized(&p.grid.centres_box(&mine), margin) else {
        return (None, None);
    };
    let smooth = p.stroke.operation.reads_neighbours();
    let neighbours = smooth.then(|| gather_neighbourhood(p, old_root, origin));
    // Deep inside the tool the density is the same at every centre: no distances needed.
    let (t_lo, t_hi) = p.density_range(&tool, &mine);
    let constant = (t_lo == t_hi).then_some(t_lo);
    let mut out = *voxels;
    let mut changed: Option<IndexBox> = None;
    for ijk in work.iter() {
        let local = ijk - origin;
        let k = Brick::offset(local);
        let t = constant.unwrap_or_else(|| p.tool_density(&tool, ijk));
        if t <= 0.0 {
            continue;
        }
        let mean = neighbours.as_ref().map_or(0.0, |n| n.mean27(local));
        let new = p.apply(voxels[k], t, mean);
        if new != voxels[k] {
            out[k] = new;
            changed = union(changed, Some(IndexBox::new(ijk, ijk + 1)));
        }
    }
    if changed.is_none() {
        return (None, None);
    }
    (Some(Brick::from_voxels(&out)), changed)
}

/// Densities of a brick and its one-voxel rim (10³), from the tree before the stroke.
struct Neighbourhood([f32; 1000]);

impl Neighbourhood {
    /// Mean of the 27 densities around the brick voxel `local` (f64 sum in a fixed order).
    fn mean27(&self, local: IVec3) -> f64 {
        let mut sum = 0.0f64;
        for dz in 0..3 {
            for dy in 0..3 {
                for dx in 0..3 {
                    let q = local + IVec3::new(dx, dy, dz);
                    sum += self.0[(q.x + 10 * (q.y + 10 * q.z)) as usize] as f64;
                }
            }
        }
        sum / 27.0
    }
}

fn gather_neighbourhood(p: &Prepared, old_root: &Node, origin: IVec3) -> Neighbourhood {
    let grid = p.grid.index_box();
    let mut n = [0.0f32; 1000];
    for z in 0..10 {
        for y in 0..10 {
            for x in 0..10 {
                let ijk = origin + IVec3::new(x - 1, y - 1, z - 1);
                if grid.contains(ijk) {
                    n[(x + 10 * (y + 10 * z)) as usize] = old_root.voxel(ijk, IVec3::ZERO, p.grid.levels()).density;
                }
            }
        }
    }
    Neighbourhood(n)
}

/// What an edit changed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EditReport {
    /// Voxels whose density or colour changed (`None`: nothing changed).
    pub changed_voxels: Option<IndexBox>,
    /// World box outside which the sculpt's [`Field`](volga_core::Field) values (trilinear
    /// density and colour) are unchanged: the changed voxels grown by their one-voxel
    /// reconstruction support. Hand it to a localized re-render.
    pub changed_world: Option<Aabb>,
}

impl EditReport {
    pub(crate) fn from_voxels(grid: &SculptGrid, changed: Option<IndexBox>) -> EditReport {
        EditReport {
            changed_voxels: changed,
            changed_world: changed.map(|b| grid.centres_box(&b).expanded(DVec3::splat(grid.spacing()))),
        }
    }
}
