//! N-connected components of black and of white voxels by union-find over runs.

use glam::IVec3;
use rayon::prelude::*;
use serde::{Serialize, Serializer};
use volga_core::IndexBox;

use crate::runs::{Colour, RowRuns};
use crate::{Connectivity, VoxelSet};

/// One N-connected component (survey 17.2: a maximal N-connected set of voxels of
/// one colour).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Component {
    /// Label: components are numbered 0, 1, … in the (z, y, x) order of their first
    /// voxel, so labels do not depend on thread count or on how the set was built.
    pub label: u32,
    /// The component's first voxel in (z, y, x) order: a voxel to point a user at.
    #[serde(serialize_with = "ivec3")]
    pub first_voxel: IVec3,
    /// Number of voxels in the component.
    pub voxel_count: u64,
    /// Smallest voxel coordinate on each axis (inclusive).
    #[serde(serialize_with = "ivec3")]
    pub bbox_min: IVec3,
    /// Largest voxel coordinate on each axis (inclusive).
    #[serde(serialize_with = "ivec3")]
    pub bbox_max: IVec3,
    /// Whether a voxel of the component lies on the grid's boundary layer. For white
    /// components of a padded set this means "outside"; otherwise the component is
    /// enclosed (a cavity, the inside of a closed surface).
    pub touches_border: bool,
}

impl Component {
    /// The half-open index box of the component's voxels.
    pub fn bounding_box(&self) -> IndexBox {
        IndexBox::new(self.bbox_min, self.bbox_max + IVec3::ONE)
    }
}

pub(crate) fn ivec3<S: Serializer>(v: &IVec3, serializer: S) -> Result<S::Ok, S::Error> {
    v.to_array().serialize(serializer)
}

/// The N-components of one colour of a [`VoxelSet`], with a label for every voxel
/// of that colour ([`Components::label_at`]).
///
/// Built from [`black_components`] or [`white_components`]. Memory and time are linear
/// in the number of runs (≤ rows + black voxels), not in the grid volume.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Components {
    connectivity: Connectivity,
    runs: RowRuns,
    run_labels: Vec<u32>,
    components: Vec<Component>,
}

/// The N-connected components of the black voxels.
pub fn black_components(set: &VoxelSet, connectivity: Connectivity) -> Components {
    Components::compute(set, Colour::Black, connectivity)
}

/// The N-connected components of the white voxels of `Σ` (the grid minus the set).
/// Voxels outside the grid are not part of `Σ` and connect nothing; pad the set
/// ([`VoxelSet::padded`]) to count the outside as one white region.
pub fn white_components(set: &VoxelSet, connectivity: Connectivity) -> Components {
    Components::compute(set, Colour::White, connectivity)
}

impl Components {
    fn compute(set: &VoxelSet, colour: Colour, connectivity: Connectivity) -> Self {
        let runs = RowRuns::new(set, colour);
        let roots = union_runs(&runs, connectivity);
        let run_labels = labels_from_roots(&roots);
        let components = summarize(&runs, &run_labels);
        Components {
            connectivity,
            runs,
            run_labels,
            components,
        }
    }

    /// The adjacency the components were labelled with.
    pub fn connectivity(&self) -> Connectivity {
        self.connectivity
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// No components (no voxel of this colour in the grid).
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// Components in label order.
    pub fn components(&self) -> &[Component] {
        &self.components
    }

    /// Label of the component holding voxel `ijk`; `None` if `ijk` is outside the grid
    /// or of the other colour.
    pub fn label_at(&self, ijk: IVec3) -> Option<u32> {
        let dims = self.runs.dims.as_ivec3();
        if ijk.cmplt(IVec3::ZERO).any() || ijk.cmpge(dims).any() {
            return None;
        }
        self.runs.find(ijk).map(|run| self.run_labels[run])
    }

    /// Components that do not touch the grid border (enclosed regions).
    pub fn interior(&self) -> impl Iterator<Item = &Component> {
        self.components.iter().filter(|c| !c.touches_border)
    }
}

/// Union-find over runs; returns for every run the smallest run index of its
/// component.
///
/// Three phases, so that the result never depends on scheduling:
/// 1. each z-slab unions its own rows in parallel (disjoint index ranges);
/// 2. each pair of slabs `(z, z + 1)` lists, in parallel, the pairs of slab roots its
///    touching runs connect (sorted, deduplicated);
/// 3. those pairs are united sequentially in z order.
///
/// Unions always link the larger root under the smaller, so a root is the smallest
/// index of its tree and `parent[i] ≤ i` throughout; a forward pass then flattens.
fn union_runs(runs: &RowRuns, connectivity: Connectivity) -> Vec<u32> {
    let dims = runs.dims;
    let (ny, nz) = (dims.y as usize, dims.z as usize);
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    let in_slab: Vec<_> = crate::connectivity::row_steps(connectivity)
        .iter()
        .filter(|s| s.1 == 0)
        .collect();
    let across: Vec<_> = crate::connectivity::row_steps(connectivity)
        .iter()
        .filter(|s| s.1 == 1)
        .collect();

    let mut slabs = Vec::with_capacity(nz);
    let mut rest = parent.as_mut_slice();
    for z in 0..nz {
        let range = runs.slab(z);
        let (head, tail) = rest.split_at_mut(range.len());
        slabs.push((z, range.start, head));
        rest = tail;
    }
    slabs.into_par_iter().for_each(|(z, base, slice)| {
        let mut forest = Forest { parent: slice, base };
        for &&(dy, _, reach) in &in_slab {
            for y in 0..ny.saturating_sub(dy as usize) {
                let (ra, rb) = (y + ny * z, y + dy as usize + ny * z);
                runs.for_touching(ra, rb, reach, |a, b| forest.union(a as u32, b as u32));
            }
        }
        forest.flatten();
    });

    let pairs: Vec<Vec<(u32, u32)>> = (0..nz.saturating_sub(1))
        .into_par_iter()
        .map(|z| {
            let mut pairs = Vec::new();
            for &&(dy, _, reach) in &across {
                for y in 0..ny as i32 {
                    let y2 = y + dy;
                    if y2 < 0 || y2 >= ny as i32 {
                        continue;
                    }
                    let (ra, rb) = (y as usize + ny * z, y2 as usize + ny * (z + 1));
                    runs.for_touching(ra, rb, reach, |a, b| {
                        if parent[a] != parent[b] {
                            pairs.push((parent[a], parent[b]));
                        }
                    });
                }
            }
            pairs.sort_unstable();
            pairs.dedup();
            pairs
        })
        .collect();

    let mut forest = Forest {
        parent: &mut parent,
        base: 0,
    };
    for (a, b) in pairs.into_iter().flatten() {
        forest.union(a, b);
    }
    forest.flatten();
    parent
}

/// A union-find forest over the global indices `base..base + parent.len()`.
struct Forest<'a> {
    parent: &'a mut [u32],
    base: usize,
}

impl Forest<'_> {
    fn find(&mut self, mut x: u32) -> u32 {
        loop {
            let p = self.parent[x as usize - self.base];
            if p == x {
                return x;
            }
            let grandparent = self.parent[p as usize - self.base];
            self.parent[x as usize - self.base] = grandparent;
            x = grandparent;
        }
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra < rb {
            self.parent[rb as usize - self.base] = ra;
        } else if rb < ra {
            self.parent[ra as usize - self.base] = rb;
        }
    }

    /// Points every index at its root; relies on `parent[i] ≤ i`.
    fn flatten(&mut self) {
        for i in 0..self.parent.len() {
            let p = self.parent[i] as usize - self.base;
            self.parent[i] = self.parent[p];
        }
    }
}

/// Labels 0, 1, … in order of each component's smallest run (= first voxel).
fn labels_from_roots(roots: &[u32]) -> Vec<u32> {
    let mut labels = Vec::with_capacity(roots.len());
    let mut next = 0u32;
    for (i, &root) in roots.iter().enumerate() {
        if root as usize == i {
            labels.push(next);
            next += 1;
        } else {
            labels.push(labels[root as usize]);
        }
    }
    labels
}

fn summarize(runs: &RowRuns, labels: &[u32]) -> Vec<Component> {
    let dims = runs.dims;
    let ny = dims.y as usize;
    let mut components: Vec<Component> = Vec::new();
    for r in 0..runs.offsets.len() - 1 {
        let (y, z) = ((r % ny) as i32, (r / ny) as i32);
        let row_on_border = y == 0 || y as u32 == dims.y - 1 || z == 0 || z as u32 == dims.z - 1;
        for i in runs.row(r) {
            let (start, end) = (runs.starts[i], runs.ends[i]);
            let lo = IVec3::new(start as i32, y, z);
            let hi = IVec3::new(end as i32 - 1, y, z);
            let on_border = row_on_border || start == 0 || end == dims.x;
            let label = labels[i];
            if label as usize == components.len() {
                components.push(Component {
                    label,
                    first_voxel: lo,
                    voxel_count: 0,
                    bbox_min: lo,
                    bbox_max: hi,
                    touches_border: false,
                });
            }
            let c = &mut components[label as usize];
            c.voxel_count += (end - start) as u64;
            c.bbox_min = c.bbox_min.min(lo);
            c.bbox_max = c.bbox_max.max(hi);
            c.touches_border |= on_border;
        }
    }
    components
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::UVec3;

    #[test]
    fn two_blobs_and_their_white_surroundings() {
        // Two black voxels touching at a vertex: one 26-component, two 6-components.
        let set = VoxelSet::from_voxels(UVec3::splat(4), [IVec3::new(1, 1, 1), IVec3::new(2, 2, 2)]).unwrap();
        let c26 = black_components(&set, Connectivity::TwentySix);
        assert_eq!(c26.len(), 1);
        assert_eq!(c26.components()[0].voxel_count, 2);
        assert_eq!(
            c26.components()[0].bounding_box(),
            IndexBox::new(IVec3::ONE, IVec3::splat(3))
        );
        assert!(!c26.components()[0].touches_border);
        let c6 = black_components(&set, Connectivity::Six);
        assert_eq!(c6.len(), 2);
        assert_eq!(c6.label_at(IVec3::new(2, 2, 2)), Some(1));
        assert_eq!(c6.label_at(IVec3::new(0, 2, 2)), None);
        let white = white_components(&set, Connectivity::Six);
        assert_eq!(white.len(), 1);
        assert_eq!(white.components()[0].voxel_count, 62);
        assert!(white.components()[0].touches_border);
        assert_eq!(white.label_at(IVec3::new(1, 1, 1)), None);
        assert_eq!(white.label_at(IVec3::new(4, 0, 0)), None);
    }
}
