//! The dynamic-resolution octree (Bærentzen 1998, survey §17.9).
//!
//! The sculpt is a cubic grid of `8·2^levels` voxels per axis. A node at level `L` covers
//! `8·2^L` voxels per axis and is one of:
//! * `Uniform` — every voxel in it has the same density and colour: a homogeneous region
//!   of any size is **one** node (all inside, all outside, or constant colour);
//! * `Brick` — level 0 only: 8³ voxels stored densely (the finest resolution; a pointer per
//!   voxel would cost more than the voxel);
//! * `Branch` — eight children, x fastest (child `k` has its x half from bit 0, y from bit 1,
//!   z from bit 2).
//!
//! Leaves therefore sit at any level. Nodes are immutable and shared (`Arc`): an edit builds
//! new nodes only along the paths it changes and points at the old ones elsewhere, so an
//! undo step keeps exactly the changed subtrees, and the tree is canonical — every node
//! whose voxels are all equal *is* a `Uniform` node (edits and builders collapse), so two
//! trees holding the same voxels have the same structure.

use std::sync::Arc;

use glam::{DVec3, IVec3};
use volga_core::IndexBox;

/// Voxels per brick edge (level 0 nodes).
pub const BRICK: i32 = 8;
pub(crate) const BRICK_VOXELS: usize = 512;

/// One voxel's payload: density in \[0, 1\] (volume-sampled, ½ on the surface) and linear RGB.
#[derive(Debug, Clone, Copy)]
pub struct Voxel {
    /// Density in \[0, 1\]: 0 empty, 1 solid, ½ on the surface.
    pub density: f32,
    /// Linear RGB colour.
    pub colour: [f32; 3],
}

impl PartialEq for Voxel {
    /// Bitwise: what "homogeneous" and "restored exactly" mean.
    fn eq(&self, o: &Voxel) -> bool {
        self.density.to_bits() == o.density.to_bits() && self.colour.map(f32::to_bits) == o.colour.map(f32::to_bits)
    }
}

/// The colours of a brick: one for all voxels, or one each.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum BrickColour {
    Uniform([f32; 3]),
    PerVoxel(Box<[[f32; 3]; BRICK_VOXELS]>),
}

/// 8³ voxels, x fastest, with the density range kept for `value_range`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Brick {
    pub density: [f32; BRICK_VOXELS],
    pub colour: BrickColour,
    pub min: f32,
    pub max: f32,
}

impl Brick {
    #[inline]
    pub fn offset(local: IVec3) -> usize {
        (local.x + BRICK * (local.y + BRICK * local.z)) as usize
    }

    #[inline]
    pub fn voxel(&self, offset: usize) -> Voxel {
        Voxel {
            density: self.density[offset],
            colour: match &self.colour {
                BrickColour::Uniform(c) => *c,
                BrickColour::PerVoxel(c) => c[offset],
            },
        }
    }

    /// The node holding these voxels: `Uniform` if all are equal, else a brick (colours
    /// stored per voxel only when they differ).
    pub fn from_voxels(voxels: &[Voxel; BRICK_VOXELS]) -> Node {
        let first = voxels[0];
        if voxels.iter().all(|v| *v == first) {
            return Node::Uniform(first);
        }
        let mut density = [0.0f32; BRICK_VOXELS];
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        for (d, v) in density.iter_mut().zip(voxels) {
            *d = v.density;
            min = min.min(v.density);
            max = max.max(v.density);
        }
        let colour = if voxels
            .iter()
            .all(|v| v.colour.map(f32::to_bits) == first.colour.map(f32::to_bits))
        {
            BrickColour::Uniform(first.colour)
        } else {
            BrickColour::PerVoxel(Box::new(std::array::from_fn(|i| voxels[i].colour)))
        };
        Node::Brick(Arc::new(Brick {
            density,
            colour,
            min,
            max,
        }))
    }

    pub fn voxels(&self) -> [Voxel; BRICK_VOXELS] {
        std::array::from_fn(|i| self.voxel(i))
    }
}

/// A node of the octree (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) enum Node {
    Uniform(Voxel),
    Brick(Arc<Brick>),
    Branch(Arc<[Node; 8]>),
}

impl PartialEq for Node {
    /// Structural and bitwise equality (shared pointers compare equal without descending).
    fn eq(&self, other: &Node) -> bool {
        match (self, other) {
            (Node::Uniform(a), Node::Uniform(b)) => a == b,
            (Node::Brick(a), Node::Brick(b)) => {
                Arc::ptr_eq(a, b)
                    || (a.density.map(f32::to_bits) == b.density.map(f32::to_bits)
                        && match (&a.colour, &b.colour) {
                            (BrickColour::Uniform(x), BrickColour::Uniform(y)) => {
                                x.map(f32::to_bits) == y.map(f32::to_bits)
                            }
                            (BrickColour::PerVoxel(x), BrickColour::PerVoxel(y)) => x
                                .iter()
                                .zip(y.iter())
                                .all(|(p, q)| p.map(f32::to_bits) == q.map(f32::to_bits)),
                            _ => false,
                        })
            }
            (Node::Branch(a), Node::Branch(b)) => Arc::ptr_eq(a, b) || a.iter().zip(b.iter()).all(|(x, y)| x == y),
            _ => false,
        }
    }
}

/// Edge length in voxels of a node at `level`.
#[inline]
pub(crate) fn node_size(level: u32) -> i32 {
    BRICK << level
}

/// Offset of child `k` of a node at `level` (whose children are at `level − 1`).
#[inline]
pub(crate) fn child_offset(k: usize, level: u32) -> IVec3 {
    let half = node_size(level) / 2;
    IVec3::new((k & 1) as i32, (k >> 1 & 1) as i32, (k >> 2 & 1) as i32) * half
}

/// Which child of a node at (`origin`, `level`) holds `ijk` (inside the node).
#[inline]
pub(crate) fn child_of(ijk: IVec3, origin: IVec3, level: u32) -> usize {
    let half = node_size(level) / 2;
    let r = ijk - origin;
    (r.x >= half) as usize | ((r.y >= half) as usize) << 1 | ((r.z >= half) as usize) << 2
}

impl Node {
    /// Collapse eight children into one `Uniform` node if they all are the same uniform voxel.
    pub fn branch(children: [Node; 8]) -> Node {
        if let Node::Uniform(first) = children[0] {
            if children.iter().all(|c| matches!(c, Node::Uniform(v) if *v == first)) {
                return Node::Uniform(first);
            }
        }
        Node::Branch(Arc::new(children))
    }

    /// The voxel at `ijk` (inside this node at `origin`, `level`).
    pub fn voxel(&self, ijk: IVec3, origin: IVec3, level: u32) -> Voxel {
        let (mut node, mut origin, mut level) = (self, origin, level);
        loop {
            match node {
                Node::Uniform(v) => return *v,
                Node::Brick(b) => return b.voxel(Brick::offset(ijk - origin)),
                Node::Branch(children) => {
                    let k = child_of(ijk, origin, level);
                    origin += child_offset(k, level);
                    node = &children[k];
                    level -= 1;
                }
            }
        }
    }

    /// `(min, max)` density over the voxels of `query` inside this node (conservative for
    /// bricks: their whole range). `None` if `query` misses the node.
    pub fn density_range(&self, query: &IndexBox, origin: IVec3, level: u32) -> Option<(f32, f32)> {
        let mine = IndexBox::new(origin, origin + node_size(level));
        if mine.intersection(query).is_empty() {
            return None;
        }
        match self {
            Node::Uniform(v) => Some((v.density, v.density)),
            Node::Brick(b) => Some((b.min, b.max)),
            Node::Branch(children) => {
                let mut out: Option<(f32, f32)> = None;
                for (k, c) in children.iter().enumerate() {
                    if let Some((lo, hi)) = c.density_range(query, origin + child_offset(k, level), level - 1) {
                        out = Some(out.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
                    }
                }
                out
            }
        }
    }

    /// Visits every node (pre-order).
    pub fn visit(&self, f: &mut impl FnMut(&Node)) {
        f(self);
        if let Node::Branch(children) = self {
            for c in children.iter() {
                c.visit(f);
            }
        }
    }
}

/// Counts of an octree's nodes and its memory.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    /// Homogeneous leaves (any level).
    pub uniform: u64,
    /// Dense 8³ bricks (level 0).
    pub bricks: u64,
    /// Bricks whose colours are stored per voxel.
    pub coloured_bricks: u64,
    /// Interior nodes.
    pub branches: u64,
    /// Heap bytes of the tree (node arrays, bricks, per-voxel colours, `Arc` counts).
    pub bytes: u64,
}

impl NodeStats {
    /// All nodes: uniform leaves, bricks and branches.
    pub fn nodes(&self) -> u64 {
        self.uniform + self.bricks + self.branches
    }
}

pub(crate) fn stats(root: &Node) -> NodeStats {
    let mut s = NodeStats {
        bytes: std::mem::size_of::<Node>() as u64,
        ..NodeStats::default()
    };
    let arc_counts = 2 * std::mem::size_of::<usize>() as u64;
    root.visit(&mut |n| match n {
        Node::Uniform(_) => s.uniform += 1,
        Node::Brick(b) => {
            s.bricks += 1;
            s.bytes += std::mem::size_of::<Brick>() as u64 + arc_counts;
            if matches!(b.colour, BrickColour::PerVoxel(_)) {
                s.coloured_bricks += 1;
                s.bytes += (BRICK_VOXELS * 12) as u64;
            }
        }
        Node::Branch(_) => {
            s.branches += 1;
            s.bytes += std::mem::size_of::<[Node; 8]>() as u64 + arc_counts;
        }
    });
    s
}

/// World placement of a sculpt: voxel `ijk`'s centre is `origin + ijk·spacing`; the grid
/// has `8·2^levels` voxels per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SculptGrid {
    origin: DVec3,
    spacing: f64,
    levels: u32,
}

/// The deepest tree: 8·2^17 = 1 048 576 voxels per axis.
pub const MAX_LEVELS: u32 = 17;

/// The largest world coordinate or length a sculpt works with (origin, the grid's extent,
/// a spray's falloff): sums and squares of such values stay finite in `f64`, so no edit
/// overflows to infinity. The same as [`volga_core::MAX_WORLD`].
pub const MAX_WORLD: f64 = volga_core::MAX_WORLD;

impl SculptGrid {
    /// Refuses a non-finite origin, a spacing that is not finite and positive, more than
    /// [`MAX_LEVELS`] levels, a grid reaching beyond [`MAX_WORLD`] (an origin
    /// coordinate, or the extent `spacing · 8·2^levels`, above 1e100 in magnitude), or a
    /// spacing below [`volga_core::MIN_SPACING`] (1e-100).
    pub fn new(origin: DVec3, spacing: f64, levels: u32) -> Result<SculptGrid, crate::SculptError> {
        let within = |x: f64| x.is_finite() && x.abs() <= MAX_WORLD;
        if !(origin.to_array().iter().all(|&c| within(c))
            && spacing >= volga_core::MIN_SPACING
            && within(spacing * node_size(levels.min(MAX_LEVELS)) as f64))
            || levels > MAX_LEVELS
        {
            return Err(crate::SculptError::Grid {
                origin: origin.to_array(),
                spacing,
                levels,
            });
        }
        Ok(SculptGrid {
            origin,
            spacing,
            levels,
        })
    }

    /// The smallest grid of this spacing whose voxel centres cover `world_box` (plus the
    /// filter's band), centred on it.
    pub fn covering(world_box: &volga_core::Aabb, spacing: f64) -> Result<SculptGrid, crate::SculptError> {
        let need = (world_box.size().max_element() / spacing).ceil() + 8.0;
        let mut levels = 0;
        while (node_size(levels) as f64) < need && levels < MAX_LEVELS {
            levels += 1;
        }
        let n = node_size(levels) as f64;
        let origin = world_box.center() - DVec3::splat((n - 1.0) * 0.5 * spacing);
        SculptGrid::new(origin, spacing, levels)
    }

    /// World position of voxel `(0, 0, 0)`'s centre.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }
    /// Distance between neighbouring voxel centres (world units).
    pub fn spacing(&self) -> f64 {
        self.spacing
    }
    /// Levels of the octree: the grid has `8·2^levels` voxels per axis.
    pub fn levels(&self) -> u32 {
        self.levels
    }
    /// Voxels per axis: `8·2^levels`.
    pub fn dims(&self) -> i32 {
        node_size(self.levels)
    }
    /// The voxels of the grid.
    pub fn index_box(&self) -> IndexBox {
        IndexBox::new(IVec3::ZERO, IVec3::splat(self.dims()))
    }
    /// World position of voxel `ijk`'s centre: `origin + ijk·spacing`.
    #[inline]
    pub fn voxel_center(&self, ijk: IVec3) -> DVec3 {
        self.origin + ijk.as_dvec3() * self.spacing
    }
    /// Continuous index coordinates of a world position (voxel centres at integers).
    #[inline]
    pub fn world_to_index(&self, world_pos: DVec3) -> DVec3 {
        (world_pos - self.origin) / self.spacing
    }
    /// Voxels whose centres may lie in `world_box` (rounded outwards), clipped to the grid.
    pub fn voxels_touching(&self, world_box: &volga_core::Aabb) -> IndexBox {
        if world_box.is_empty() {
            return IndexBox::new(IVec3::ZERO, IVec3::ZERO);
        }
        let lo = self.world_to_index(world_box.min).floor().max(DVec3::splat(-1.0));
        let hi = self
            .world_to_index(world_box.max)
            .ceil()
            .min(DVec3::splat(self.dims() as f64 + 1.0));
        if !(lo.is_finite() && hi.is_finite()) {
            return IndexBox::new(IVec3::ZERO, IVec3::ZERO);
        }
        IndexBox::new(lo.as_ivec3(), hi.as_ivec3() + 1).intersection(&self.index_box())
    }
    /// World box of a voxel box's centres.
    pub fn centres_box(&self, b: &IndexBox) -> volga_core::Aabb {
        volga_core::Aabb::new(self.voxel_center(b.min), self.voxel_center(b.max - 1))
    }
}
