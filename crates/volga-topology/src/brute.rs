//! Brute-force discrete topology by definition, on small grids: the references the
//! run-based algorithms (this crate's tests) and the voxelizers' separability claims
//! (the root integration tests) are checked against. One copy for both.
//!
//! Compiled only with the `testing` feature; hidden from the docs. Quadratic or worse:
//! for grids of a few thousand voxels.

use std::collections::{BTreeSet, VecDeque};

use glam::{IVec3, UVec3};
use volga_core::{Adjacency, Shape3};

use crate::VoxelSet;

/// Every voxel of the grid in (z, y, x) order.
pub fn grid_voxels(dims: UVec3) -> impl Iterator<Item = IVec3> {
    let d = dims.as_ivec3();
    (0..d.z).flat_map(move |z| (0..d.y).flat_map(move |y| (0..d.x).map(move |x| IVec3::new(x, y, z))))
}

pub fn in_grid(dims: UVec3, v: IVec3) -> bool {
    v.cmpge(IVec3::ZERO).all() && v.cmplt(dims.as_ivec3()).all()
}

/// Components of the voxels where `member` holds, by BFS in (z, y, x) seed order:
/// (first voxel, sorted voxels, touches border) per component, in label order.
pub fn bfs_components(
    dims: UVec3,
    member: impl Fn(IVec3) -> bool,
    adjacency: Adjacency,
) -> Vec<(IVec3, Vec<IVec3>, bool)> {
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    let key = |v: IVec3| (v.z, v.y, v.x);
    for seed in grid_voxels(dims) {
        if !member(seed) || seen.contains(&key(seed)) {
            continue;
        }
        let mut voxels = vec![];
        let mut queue = VecDeque::from([seed]);
        seen.insert(key(seed));
        while let Some(v) = queue.pop_front() {
            voxels.push(v);
            for &d in adjacency.offsets() {
                let q = v + d;
                if in_grid(dims, q) && member(q) && seen.insert(key(q)) {
                    queue.push_back(q);
                }
            }
        }
        voxels.sort_by_key(|&v| key(v));
        let d = dims.as_ivec3();
        let border = voxels
            .iter()
            .any(|v| v.cmpeq(IVec3::ZERO).any() || v.cmpeq(d - IVec3::ONE).any());
        out.push((seed, voxels, border));
    }
    out
}

/// White components of `set` by BFS (see [`bfs_components`]).
pub fn white_bfs(set: &VoxelSet, adjacency: Adjacency) -> Vec<(IVec3, Vec<IVec3>, bool)> {
    bfs_components(set.dims(), |v| !set.contains(v), adjacency)
}

/// Which voxels of the `shape` grid an N-flood through white voxels (where `black` is
/// false) reaches from the white voxels on the grid border, indexed by
/// [`Shape3::linearize`]. A closed N-separating surface leaves its inside unreached.
pub fn flood_from_border(shape: Shape3, black: impl Fn(IVec3) -> bool, adjacency: Adjacency) -> Vec<bool> {
    let dims = shape.dims();
    let mut seen = vec![false; shape.len()];
    let mut stack = Vec::new();
    for ijk in grid_voxels(dims) {
        let border = ijk.cmpeq(IVec3::ZERO).any() || ijk.cmpeq(dims.as_ivec3() - 1).any();
        if border && !black(ijk) {
            seen[shape.linearize(ijk)] = true;
            stack.push(ijk);
        }
    }
    while let Some(p) = stack.pop() {
        for &o in adjacency.offsets() {
            let q = p + o;
            if in_grid(dims, q) && !black(q) && !seen[shape.linearize(q)] {
                seen[shape.linearize(q)] = true;
                stack.push(q);
            }
        }
    }
    seen
}

/// Brute simplicity by definition: remove `v` and check that no new white component
/// holds voxels of two old ones. `false` if `v` is not black.
pub fn brute_simple(set: &VoxelSet, v: IVec3, adjacency: Adjacency) -> bool {
    let before = white_bfs(set, adjacency);
    let label_of = |q: IVec3| before.iter().position(|c| c.1.contains(&q));
    let mut after = set.clone();
    if !after.remove(v) {
        return false;
    }
    white_bfs(&after, adjacency).iter().all(|(_, voxels, _)| {
        let labels: BTreeSet<usize> = voxels.iter().filter_map(|&q| label_of(q)).collect();
        labels.len() <= 1
    })
}

/// χ by listing the distinct vertices, edges, faces and cubes of the closed cubes.
pub fn brute_euler(set: &VoxelSet) -> i64 {
    let mut vertices = BTreeSet::new();
    let mut edges = BTreeSet::new();
    let mut faces = BTreeSet::new();
    let key = |v: IVec3| (v.x, v.y, v.z);
    for v in set.iter() {
        for c in 0..8 {
            let corner = v + IVec3::new(c & 1, (c >> 1) & 1, (c >> 2) & 1);
            vertices.insert(key(corner));
        }
        for axis in 0..3 {
            let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
            for a in 0..2 {
                for b in 0..2 {
                    let mut start = v;
                    start[u] += a;
                    start[w] += b;
                    edges.insert((axis, key(start)));
                }
                // Face normal to `axis` at offset a.
                let mut start = v;
                start[axis] += a;
                faces.insert((axis, key(start)));
            }
        }
    }
    vertices.len() as i64 - edges.len() as i64 + faces.len() as i64 - set.len() as i64
}
