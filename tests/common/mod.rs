//! Helpers shared by the integration tests: brute-force discrete topology on small
//! dense grids, independent of the library's own validators.
#![allow(dead_code)]

use glam::IVec3;
use volga::voxelize::Separability;
use volga::DenseVolume;

pub fn black(v: &DenseVolume, ijk: IVec3) -> bool {
    v.density.get(ijk) > 0.5
}

/// The N-neighbourhood offsets (half of them: one of each ±o pair).
pub fn half_steps(sep: Separability) -> Vec<IVec3> {
    let mut out = Vec::new();
    for z in -1..=1 {
        for y in -1..=1 {
            for x in -1..=1 {
                let o = IVec3::new(x, y, z);
                let nonzero = (x != 0) as i32 + (y != 0) as i32 + (z != 0) as i32;
                let ok = match sep {
                    Separability::Six => nonzero == 1,
                    Separability::Eighteen => nonzero == 1 || nonzero == 2,
                    Separability::TwentySix => nonzero >= 1,
                };
                // Keep the lexicographically positive half.
                if ok && (z, y, x) > (0, 0, 0) {
                    out.push(o);
                }
            }
        }
    }
    out
}

/// Number of white voxels reached by an N-flood fill from the white voxels on the grid
/// border.
pub fn flood_from_border(v: &DenseVolume, sep: Separability) -> Vec<bool> {
    let shape = v.density.shape();
    let dims = shape.dims().as_ivec3();
    let mut seen = vec![false; shape.len()];
    let mut stack = Vec::new();
    for ijk in v.grid.index_box().iter() {
        let border = ijk.cmpeq(IVec3::ZERO).any() || ijk.cmpeq(dims - 1).any();
        if border && !black(v, ijk) {
            seen[shape.linearize(ijk)] = true;
            stack.push(ijk);
        }
    }
    let steps: Vec<IVec3> = half_steps(sep).into_iter().flat_map(|o| [o, -o]).collect();
    while let Some(p) = stack.pop() {
        for &o in &steps {
            let q = p + o;
            if v.grid.contains(q) && !black(v, q) && !seen[shape.linearize(q)] {
                seen[shape.linearize(q)] = true;
                stack.push(q);
            }
        }
    }
    seen
}
