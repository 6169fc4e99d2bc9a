//! voxblt (survey §17.5): copy or combine a cuboid block of one volume into another,
//! voxel by voxel, with any CVG operator — the volume counterpart of a bitblt.

use glam::IVec3;
use volga_core::{IndexBox, SparseVolume};

use crate::op::{Attributes, Op};

/// What a block transfer does with the destination's voxels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BlockOp {
    /// Replace them by the source's (density and colour).
    Copy,
    /// `dst ← op(dst, src)`, attributes by the operator's rule (dst is operand `A`).
    Combine(Op),
}

/// Transfers the voxels of `src` inside `src_box` to `dst`, voxel `ijk` landing on
/// `ijk + offset`; voxels landing outside `dst`'s grid are dropped. Colour moves only
/// when both volumes carry it. Returns the number of destination voxels written.
pub fn voxblt(dst: &mut SparseVolume, src: &SparseVolume, src_box: &IndexBox, offset: IVec3, op: BlockOp) -> u64 {
    let src_box = src_box.intersection(&src.grid.index_box());
    let dst_box = dst.grid.index_box();
    let mut written = 0;
    for ijk in src_box.iter() {
        let target = ijk + offset;
        if !dst_box.contains(target) {
            continue;
        }
        let s = src.density.get(ijk) as f64;
        let sc = src.colour.as_ref().map(|c| c.get(ijk));
        let (d, colour) = match op {
            BlockOp::Copy => (s, sc),
            BlockOp::Combine(op) => {
                let a = dst.density.get(target) as f64;
                let colour = match (dst.colour.as_ref(), sc) {
                    (Some(dc), Some(sc)) => {
                        let attr = |c: [f32; 3]| Attributes {
                            colour: c.into(),
                            material: 0,
                        };
                        Some(op.attributes(a, attr(dc.get(target)), s, attr(sc)).colour.to_array())
                    }
                    _ => None,
                };
                (op.apply(a, s), colour)
            }
        };
        dst.density.set(target, d as f32);
        if let (Some(dc), Some(c)) = (dst.colour.as_mut(), colour) {
            dc.set(target, c);
        }
        written += 1;
    }
    dst.density.prune();
    if let Some(c) = dst.colour.as_mut() {
        c.prune();
    }
    written
}
