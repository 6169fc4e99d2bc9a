//! [`VoxelSet`]: the black voxels of a binary voxel space, stored by rows.

use glam::{IVec3, UVec3};
use rayon::prelude::*;
use volga_core::{Brick, DenseVolume, IndexBox, Shape3, SparseVolume, BRICK_DIM};

use crate::TopologyError;

/// Largest number of rows or voxels a set holds, so that run and label indices fit
/// in `u32` (a set has at most `rows + voxels` runs of either colour).
const MAX_ENTRIES: u64 = i32::MAX as u64;
/// Largest extent on one axis, as for [`volga_core::Grid`]: `ijk ± 1` never overflows.
const MAX_DIM: u32 = i32::MAX as u32 / 2;
/// Bytes a row index may take when the available memory cannot be read.
const FALLBACK_MEMORY_LIMIT: u64 = 1 << 40;

/// The black voxels `S` of a binary voxel space `Σ` (survey 17.2) in **index space**.
///
/// `Σ` is the grid `0 ≤ ijk < dims`: voxels outside it are not part of the space
/// (neither black nor white). [`VoxelSet::padded`] adds white layers around the grid
/// for callers who want the outside counted as one white region.
///
/// Storage is compressed sparse rows: for every row `(y, z)` (row index
/// `y + dims.y · z`) the sorted x of its black voxels. Memory is 8 bytes per row plus
/// 4 per black voxel, so a 1024³ shell costs its voxels and 8 MiB of row index, not
/// 1024³ bits. Rows and voxels are each limited to 2³¹ − 1 (checked at construction).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VoxelSet {
    shape: Shape3,
    /// `row_offsets[r]..row_offsets[r + 1]` indexes `xs` for row `r`.
    row_offsets: Vec<u64>,
    /// x of the black voxels, strictly increasing within a row.
    xs: Vec<u32>,
}

impl VoxelSet {
    /// The empty set (all voxels white) over a grid of `dims` voxels.
    pub fn empty(dims: UVec3) -> Result<Self, TopologyError> {
        let shape = check_dims(dims)?;
        let rows = shape.row_count();
        Ok(VoxelSet {
            shape,
            row_offsets: vec![0; rows + 1],
            xs: Vec::new(),
        })
    }

    /// The set of the given voxels (duplicates allowed, any order); a voxel outside
    /// the grid is an error naming it.
    pub fn from_voxels(dims: UVec3, voxels: impl IntoIterator<Item = IVec3>) -> Result<Self, TopologyError> {
        let shape = check_dims(dims)?;
        let in_grid = IndexBox::new(IVec3::ZERO, dims.as_ivec3());
        let mut keys = Vec::new();
        for ijk in voxels {
            if !in_grid.contains(ijk) {
                return Err(TopologyError::OutsideGrid {
                    ijk: ijk.to_array(),
                    dims: dims.to_array(),
                });
            }
            keys.push(shape.linearize(ijk) as u64);
        }
        keys.par_sort_unstable();
        keys.dedup();
        Self::from_sorted_keys(shape, &keys)
    }

    /// Voxels of `volume`'s grid whose density is `≥ threshold` (NaN is white).
    pub fn from_dense(volume: &DenseVolume, threshold: f32) -> Result<Self, TopologyError> {
        let dims = volume.grid.dims();
        let shape = check_dims(dims)?;
        let density = volume.density.as_slice();
        let (nx, ny) = (dims.x as usize, dims.y as usize);
        let slabs: Vec<(Vec<u64>, Vec<u32>)> = density
            .par_chunks(shape.plane_len())
            .map(|slab| {
                let mut counts = Vec::with_capacity(ny);
                let mut xs = Vec::new();
                for row in slab.chunks(nx) {
                    let before = xs.len();
                    xs.extend((0..nx as u32).filter(|&x| row[x as usize] >= threshold));
                    counts.push((xs.len() - before) as u64);
                }
                (counts, xs)
            })
            .collect();
        Self::from_slabs(shape, slabs)
    }

    /// Voxels of `volume`'s grid whose density is `≥ threshold` (NaN is white), read
    /// brick by brick: the cost follows the stored bricks, unless the background
    /// itself is black, in which case every voxel of the grid is visited.
    pub fn from_sparse(volume: &SparseVolume, threshold: f32) -> Result<Self, TopologyError> {
        let dims = volume.grid.dims();
        let shape = check_dims(dims)?;
        let grid_box = volume.grid.index_box();
        let extent = volume.brick_extent();
        let background_black = volume.density.background() >= threshold;
        let bricks: Vec<IVec3> = if background_black {
            IndexBox::new(IVec3::ZERO, extent).iter().collect()
        } else {
            let in_extent = IndexBox::new(IVec3::ZERO, extent);
            volume
                .density
                .sorted_bricks()
                .into_iter()
                .filter(|&b| in_extent.contains(b))
                .collect()
        };
        let mut keys: Vec<u64> = bricks
            .par_iter()
            .flat_map_iter(|&b| {
                let min = b * BRICK_DIM;
                let region = IndexBox::new(min, min + IVec3::splat(BRICK_DIM)).intersection(&grid_box);
                let brick = volume.density.brick(b);
                let mut keys = Vec::new();
                for ijk in region.iter() {
                    let value = match brick {
                        None => volume.density.background(),
                        Some(brick) => brick.get_local(Brick::<f32>::local_offset(ijk)),
                    };
                    if value >= threshold {
                        keys.push(shape.linearize(ijk) as u64);
                    }
                }
                keys
            })
            .collect();
        keys.par_sort_unstable();
        Self::from_sorted_keys(shape, &keys)
    }

    /// Builds the rows from strictly increasing linear keys `x + X·(y + Y·z)`.
    fn from_sorted_keys(shape: Shape3, keys: &[u64]) -> Result<Self, TopologyError> {
        check_len(shape.dims(), keys.len() as u64)?;
        let rows = shape.row_count();
        let mut row_offsets = vec![0u64; rows + 1];
        for &k in keys {
            row_offsets[shape.split_row(k as usize).1 + 1] += 1;
        }
        for r in 0..rows {
            row_offsets[r + 1] += row_offsets[r];
        }
        let xs = keys.par_iter().map(|&k| shape.split_row(k as usize).0 as u32).collect();
        Ok(VoxelSet { shape, row_offsets, xs })
    }

    /// Concatenates per-z slabs of (per-row counts, xs).
    fn from_slabs(shape: Shape3, slabs: Vec<(Vec<u64>, Vec<u32>)>) -> Result<Self, TopologyError> {
        let len: u64 = slabs.iter().map(|(_, xs)| xs.len() as u64).sum();
        check_len(shape.dims(), len)?;
        let rows = shape.row_count();
        let mut row_offsets = Vec::with_capacity(rows + 1);
        row_offsets.push(0u64);
        let mut xs = Vec::with_capacity(len as usize);
        let mut total = 0;
        for (counts, slab_xs) in slabs {
            for c in counts {
                total += c;
                row_offsets.push(total);
            }
            xs.extend_from_slice(&slab_xs);
        }
        Ok(VoxelSet { shape, row_offsets, xs })
    }

    /// Grid extent in voxels.
    pub fn dims(&self) -> UVec3 {
        self.shape.dims()
    }

    /// The dense layout of the grid (linear keys `x + X·(y + Y·z)`, rows `y + Y·z`).
    pub fn shape(&self) -> Shape3 {
        self.shape
    }

    /// Number of black voxels.
    pub fn len(&self) -> u64 {
        self.xs.len() as u64
    }

    /// No black voxel.
    pub fn is_empty(&self) -> bool {
        self.xs.is_empty()
    }

    /// Number of rows, `dims.y · dims.z`.
    pub fn row_count(&self) -> usize {
        self.row_offsets.len() - 1
    }

    /// Sorted x of the black voxels of row `(y, z)` (empty outside the grid).
    pub fn row(&self, y: i32, z: i32) -> &[u32] {
        if y < 0 || z < 0 || y as u32 >= self.shape.dims().y || z as u32 >= self.shape.dims().z {
            return &[];
        }
        self.row_at(self.shape.row(IVec3::new(0, y, z)))
    }

    /// Sorted x of the black voxels of row index `r = y + dims.y · z`.
    pub(crate) fn row_at(&self, r: usize) -> &[u32] {
        &self.xs[self.row_offsets[r] as usize..self.row_offsets[r + 1] as usize]
    }

    /// Whether `ijk` is a voxel of the space `Σ` (inside the grid).
    #[inline]
    pub fn in_grid(&self, ijk: IVec3) -> bool {
        ijk.cmpge(IVec3::ZERO).all() && ijk.as_uvec3().cmplt(self.shape.dims()).all()
    }

    /// Whether `ijk` is black (false outside the grid).
    #[inline]
    pub fn contains(&self, ijk: IVec3) -> bool {
        self.in_grid(ijk) && self.row(ijk.y, ijk.z).binary_search(&(ijk.x as u32)).is_ok()
    }

    /// Row `(y, z)` as [`VoxelSet::row`] and the position of its first voxel in
    /// [`VoxelSet::iter`] order (0 and empty outside the grid).
    pub(crate) fn row_with_start(&self, y: i32, z: i32) -> (usize, &[u32]) {
        if y < 0 || z < 0 || y as u32 >= self.shape.dims().y || z as u32 >= self.shape.dims().z {
            return (0, &[]);
        }
        let r = self.shape.row(IVec3::new(0, y, z));
        (self.row_offsets[r] as usize, self.row_at(r))
    }

    /// The black voxels in (z, y, x) lexicographic order.
    pub fn iter(&self) -> impl Iterator<Item = IVec3> + '_ {
        let ny = self.shape.dims().y as usize;
        (0..self.row_count()).flat_map(move |r| {
            let (y, z) = ((r % ny) as i32, (r / ny) as i32);
            self.row_at(r).iter().map(move |&x| IVec3::new(x as i32, y, z))
        })
    }

    /// Smallest box holding every black voxel, `None` for the empty set.
    pub fn bounding_box(&self) -> Option<IndexBox> {
        let ny = self.shape.dims().y as usize;
        let mut bbox: Option<IndexBox> = None;
        for r in 0..self.row_count() {
            let row = self.row_at(r);
            if let (Some(&first), Some(&last)) = (row.first(), row.last()) {
                let (y, z) = ((r % ny) as i32, (r / ny) as i32);
                let lo = IVec3::new(first as i32, y, z);
                let hi = IVec3::new(last as i32, y, z) + IVec3::ONE;
                bbox = Some(match bbox {
                    None => IndexBox::new(lo, hi),
                    Some(b) => IndexBox::new(b.min.min(lo), b.max.max(hi)),
                });
            }
        }
        bbox
    }

    /// The same voxels in a grid grown by `layers` white voxels on every side (voxel
    /// `ijk` moves to `ijk + layers`). With one layer, every white voxel outside the
    /// object is connected through the new border, so "touches the border" means
    /// "outside".
    pub fn padded(&self, layers: u32) -> Result<Self, TopologyError> {
        let grown = self.shape.dims().as_u64vec3() + glam::U64Vec3::splat(2 * layers as u64);
        if grown.max_element() > MAX_DIM as u64 {
            return Err(TopologyError::TooLarge {
                dims: grown.min(glam::U64Vec3::splat(u32::MAX as u64)).as_uvec3().to_array(),
                bytes: (grown.y as u128 * grown.z as u128 + 1) * 8,
            });
        }
        let dims = grown.as_uvec3();
        let shape = check_dims(dims)?;
        let mut row_offsets = Vec::with_capacity(shape.row_count() + 1);
        row_offsets.push(0u64);
        let mut xs = Vec::with_capacity(self.xs.len());
        let shift = layers as i32;
        for z in 0..dims.z as i32 {
            for y in 0..dims.y as i32 {
                xs.extend(self.row(y - shift, z - shift).iter().map(|&x| x + layers));
                row_offsets.push(xs.len() as u64);
            }
        }
        Ok(VoxelSet { shape, row_offsets, xs })
    }

    /// Makes `ijk` white; returns whether it was black. Costs O(rows + voxels): for
    /// edits of a few voxels (tests, tools probing one voxel at a time).
    pub fn remove(&mut self, ijk: IVec3) -> bool {
        if !self.in_grid(ijk) {
            return false;
        }
        let r = self.row_index(ijk);
        let base = self.row_offsets[r] as usize;
        match self.row_at(r).binary_search(&(ijk.x as u32)) {
            Ok(i) => {
                self.xs.remove(base + i);
                self.row_offsets[r + 1..].iter_mut().for_each(|o| *o -= 1);
                true
            }
            Err(_) => false,
        }
    }

    /// Makes `ijk` black; returns whether it was white (false outside the grid or at
    /// the voxel limit). Costs O(rows + voxels), like [`VoxelSet::remove`].
    pub fn insert(&mut self, ijk: IVec3) -> bool {
        if !self.in_grid(ijk) || self.len() >= MAX_ENTRIES {
            return false;
        }
        let r = self.row_index(ijk);
        let base = self.row_offsets[r] as usize;
        match self.row_at(r).binary_search(&(ijk.x as u32)) {
            Ok(_) => false,
            Err(i) => {
                self.xs.insert(base + i, ijk.x as u32);
                self.row_offsets[r + 1..].iter_mut().for_each(|o| *o += 1);
                true
            }
        }
    }

    fn row_index(&self, ijk: IVec3) -> usize {
        self.shape.row(ijk)
    }
}

/// Validates `dims` and returns its layout, refusing a row index that cannot be
/// allocated (before allocating it) or a grid whose linear keys do not fit in `usize`.
fn check_dims(dims: UVec3) -> Result<Shape3, TopologyError> {
    if dims.cmpeq(UVec3::ZERO).any() {
        return Err(TopologyError::EmptyGrid(dims.to_array()));
    }
    let rows = dims.y as u64 * dims.z as u64;
    let bytes = (rows as u128 + 1) * 8;
    let limit = volga_core::memory::available_bytes().unwrap_or(FALLBACK_MEMORY_LIMIT);
    if dims.max_element() > MAX_DIM || rows > MAX_ENTRIES || bytes > limit as u128 {
        return Err(TopologyError::TooLarge {
            dims: dims.to_array(),
            bytes,
        });
    }
    Shape3::new(dims).map_err(|_| TopologyError::TooLarge {
        dims: dims.to_array(),
        bytes,
    })
}

fn check_len(dims: UVec3, len: u64) -> Result<(), TopologyError> {
    if len > MAX_ENTRIES {
        return Err(TopologyError::TooLarge {
            dims: dims.to_array(),
            bytes: len as u128 * 4,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use volga_core::{Grid, Transform};

    fn grid(dims: UVec3) -> Grid {
        Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), dims).unwrap()
    }

    #[test]
    fn from_voxels_sorts_dedups_and_rejects_outside() {
        let dims = UVec3::new(4, 3, 2);
        let v = [
            IVec3::new(3, 2, 1),
            IVec3::new(0, 0, 0),
            IVec3::new(3, 2, 1),
            IVec3::new(1, 0, 1),
        ];
        let s = VoxelSet::from_voxels(dims, v).unwrap();
        assert_eq!(s.len(), 3);
        assert_eq!(
            s.iter().collect::<Vec<_>>(),
            vec![IVec3::new(0, 0, 0), IVec3::new(1, 0, 1), IVec3::new(3, 2, 1)]
        );
        assert!(s.contains(IVec3::new(1, 0, 1)));
        assert!(!s.contains(IVec3::new(1, 0, 0)));
        assert!(!s.contains(IVec3::new(-1, 0, 0)));
        assert_eq!(s.bounding_box(), Some(IndexBox::new(IVec3::ZERO, IVec3::new(4, 3, 2))));
        let err = VoxelSet::from_voxels(dims, [IVec3::new(4, 0, 0)]).unwrap_err();
        assert_eq!(
            err,
            TopologyError::OutsideGrid {
                ijk: [4, 0, 0],
                dims: [4, 3, 2]
            }
        );
        assert!(matches!(
            VoxelSet::empty(UVec3::new(0, 1, 1)),
            Err(TopologyError::EmptyGrid(_))
        ));
    }

    #[test]
    fn huge_grids_are_refused_before_allocating() {
        let err = VoxelSet::empty(UVec3::splat(1 << 29)).unwrap_err();
        assert!(matches!(err, TopologyError::TooLarge { .. }), "{err}");
        assert!(err.to_string().contains("536870912"), "{err}");
    }

    #[test]
    fn dense_and_sparse_thresholds_agree() {
        let g = grid(UVec3::new(11, 9, 10));
        let mut dense = DenseVolume::new(g, 0.0, false).unwrap();
        let mut expected = Vec::new();
        for ijk in g.index_box().iter() {
            let v = ((ijk.x * 7 + ijk.y * 3 + ijk.z * 5) % 11) as f32 / 10.0;
            dense.density.set(ijk, v);
            if v >= 0.5 {
                expected.push(ijk);
            }
        }
        let a = VoxelSet::from_dense(&dense, 0.5).unwrap();
        let b = VoxelSet::from_sparse(&SparseVolume::from_dense(&dense), 0.5).unwrap();
        let c = VoxelSet::from_voxels(g.dims(), expected).unwrap();
        assert_eq!(a, c);
        assert_eq!(b, c);

        // A black background makes absent bricks black, clipped to the grid.
        let sparse = SparseVolume::new(grid(UVec3::new(3, 2, 9)), 1.0, false);
        assert_eq!(VoxelSet::from_sparse(&sparse, 0.5).unwrap().len(), 3 * 2 * 9);
    }

    #[test]
    fn padding_shifts_and_edits_keep_rows_consistent() {
        let mut s = VoxelSet::from_voxels(UVec3::new(2, 2, 2), [IVec3::ZERO, IVec3::ONE]).unwrap();
        let p = s.padded(1).unwrap();
        assert_eq!(p.dims(), UVec3::splat(4));
        assert_eq!(p.iter().collect::<Vec<_>>(), vec![IVec3::ONE, IVec3::splat(2)]);
        assert!(s.insert(IVec3::new(1, 0, 0)));
        assert!(!s.insert(IVec3::new(1, 0, 0)));
        assert!(!s.insert(IVec3::new(2, 0, 0)));
        assert!(s.remove(IVec3::ZERO));
        assert!(!s.remove(IVec3::ZERO));
        assert_eq!(
            s,
            VoxelSet::from_voxels(UVec3::new(2, 2, 2), [IVec3::new(1, 0, 0), IVec3::ONE]).unwrap()
        );
    }
}
