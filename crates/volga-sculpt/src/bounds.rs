//! Upper bounds on what a stroke or an export holds, computed before the work so callers
//! with a memory limit can refuse it with the size needed.

use glam::IVec3;

use crate::edit::{Prepared, Stroke};
use crate::octree::{node_size, Brick, Node, BRICK_VOXELS};
use crate::Sculpt;

/// Bytes one brick of the octree may take: its densities, per-voxel colours, the branch
/// arrays above it and `Arc` counts (a generous round figure over `size_of`).
pub const BRICK_BYTES_BOUND: u64 = (std::mem::size_of::<Brick>() + BRICK_VOXELS * 12 + 1024) as u64;

/// Bricks of 8³ voxels along x, y and z that the voxel box `b` touches; `None` when empty.
fn bricks_of(b: &volga_core::IndexBox) -> Option<(u128, u128, u128)> {
    if b.is_empty() {
        return None;
    }
    let lo = b.min.div_euclid(IVec3::splat(8));
    let hi = (b.max - 1).div_euclid(IVec3::splat(8)) + 1;
    let n = (hi - lo).as_u64vec3();
    Some((n.x as u128, n.y as u128, n.z as u128))
}

/// Bytes one sparse-volume brick takes beyond its payload (hash-map entry, tag, box).
const VOLUME_BRICK_OVERHEAD: u64 = 64;

impl Sculpt {
    /// An upper bound on the bricks `stroke` may add to the octree (each at most
    /// [`BRICK_BYTES_BOUND`] bytes): a stroke leaves uniform nodes inside and outside its
    /// tool, and only bricks near the tool's surface become dense; counted as every brick
    /// of its reach (clipped to the grid) or, when fewer, a shell four bricks deep on each
    /// face of the reach.
    pub fn stroke_brick_bound(&self, stroke: &Stroke) -> u128 {
        let Some((x, y, z)) = bricks_of(&Prepared::new(stroke, self.grid).edit_box) else {
            return 0;
        };
        (x * y * z).min(8 * (x * y + y * z + z * x))
    }

    /// The exact number of bricks [`to_sparse_volume`](Sculpt::to_sparse_volume) stores
    /// (uniform and dense) and an upper bound on their bytes, counted on the tree without
    /// building the volume. A uniform solid node of level `L` becomes `(2^L)³` uniform
    /// bricks.
    pub fn sparse_volume_bytes(&self, with_colour: bool) -> (u128, u128) {
        fn walk(n: &Node, level: u32, colour: bool, out: &mut (u128, u128)) {
            match n {
                Node::Uniform(v) => {
                    if v.density != 0.0 {
                        let k = (node_size(level) / 8) as u128;
                        let bricks = k * k * k;
                        out.0 += bricks;
                        out.1 += bricks * VOLUME_BRICK_OVERHEAD as u128 * if colour { 2 } else { 1 };
                    }
                }
                Node::Brick(_) => {
                    out.0 += 1;
                    out.1 += (BRICK_VOXELS as u128 * 4 + VOLUME_BRICK_OVERHEAD as u128)
                        + if colour {
                            BRICK_VOXELS as u128 * 12 + VOLUME_BRICK_OVERHEAD as u128
                        } else {
                            0
                        };
                }
                Node::Branch(children) => {
                    for c in children.iter() {
                        walk(c, level - 1, colour, out);
                    }
                }
            }
        }
        let mut out = (0, 0);
        walk(&self.root, self.grid.levels(), with_colour, &mut out);
        out
    }
}

impl crate::SculptGrid {
    /// An upper bound on the bytes of sampling an object whose material lies in
    /// `world_box` onto this grid ([`Sculpt::from_field`]): the bricks of the box
    /// (clipped to the grid) that its surface may cross, every brick of the box's shell
    /// two bricks deep on each face (or the whole box, if smaller), at
    /// [`BRICK_BYTES_BOUND`] each. An object whose surface folds more than twice through
    /// the box's shell (sponges, many parts) can exceed it; the bound is exact for boxes
    /// and generous for convex objects.
    pub fn sample_bytes_bound(&self, world_box: &volga_core::Aabb) -> u128 {
        let Some((x, y, z)) = bricks_of(&self.voxels_touching(world_box)) else {
            return 0;
        };
        (x * y * z).min(4 * (x * y + y * z + z * x)) * BRICK_BYTES_BOUND as u128
    }
}
