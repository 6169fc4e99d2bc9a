//! A read-only copy of a voxel source prepared for ray sampling: padded tiles in one flat
//! array behind a flat tile table, so a trilinear sample (and a trilinear gradient's
//! 4×4×4 stencil) is one table read and loads from one tile — no hash look-up, no brick
//! seams, no per-corner bounds checks.

use std::collections::HashMap;

use glam::IVec3;
use rayon::prelude::*;

use crate::{Grid, IndexBox, Rgb, VoxelReader, VoxelSource};

/// Voxels along each edge of an atlas tile (a power of two).
const TILE_LOG2: i32 = 4;
const TILE: i32 = 1 << TILE_LOG2;
/// Padded tile edge: the tile's voxels plus an apron of one voxel before and two after,
/// so every voxel of the stencil `base − 1 ..= base + 2` of a base voxel inside the tile
/// is stored in the tile.
const PADDED: i32 = TILE + 3;
const PADDED_VOXELS: usize = (PADDED * PADDED * PADDED) as usize;
const STRIDE_Y: usize = PADDED as usize;
const STRIDE_Z: usize = (PADDED * PADDED) as usize;

/// Largest atlas [`BrickAtlas::build`] makes (bytes); beyond it, it declines.
pub const MAX_ATLAS_BYTES: u64 = 1 << 30;

/// A voxel source copied into padded tiles of 16³ voxels (19³ stored: an apron of one
/// voxel before and two after on each axis, read from the source, background outside
/// the grid), addressed through a flat table of tile slots. Tiles whose padded block is
/// one value share one stored tile per value, so uniform regions (the background
/// included) cost a table entry.
///
/// Every density it returns is the source's own `f32` (the same bits), so a
/// [`Sampled`](crate::Sampled) over an atlas reconstructs exactly what it does over the
/// source; colour and value ranges are read from the source. It is what
/// [`Field::prepare`](crate::Field::prepare) builds for sampled volumes: read-only, made
/// once per render.
pub struct BrickAtlas<S> {
    source: S,
    /// Tiles per axis: `ceil(dims / 16)`.
    tiles: IVec3,
    /// Voxels covered by whole tiles per axis (`tiles · 16`): a base voxel in
    /// `[0, extent)` is served from its tile.
    extent: IVec3,
    /// Tile (x fastest) → first voxel of its padded block in `voxels`.
    table: Vec<u32>,
    voxels: Vec<f32>,
}

impl<S: VoxelSource> BrickAtlas<S> {
    /// Bytes the atlas of `source` would take (table and stored tiles), counting which
    /// tiles are uniform from the source's [`VoxelSource::density_range`]; nothing is
    /// allocated.
    pub fn estimate_bytes(source: &S) -> u64 {
        let (tiles, uniform) = tile_classes(source);
        let n = tiles.element_product() as u64;
        let stored = uniform.iter().filter(|u| u.is_none()).count() as u64;
        let distinct: std::collections::HashSet<u32> = uniform.iter().flatten().map(|v| v.to_bits()).collect();
        n * 4 + (stored + distinct.len() as u64) * PADDED_VOXELS as u64 * 4
    }

    /// Copies `source` into an atlas, or `None` if it would take more than
    /// [`MAX_ATLAS_BYTES`] (checked before allocating) or more slots than `u32` counts.
    /// Tiles are filled in parallel; the result does not depend on the thread count.
    pub fn build(source: S) -> Option<Self> {
        let (tiles, uniform) = tile_classes(&source);
        // Slots in tile order: one per non-uniform tile, one per distinct uniform value.
        let mut slot_of_value: HashMap<u32, u32> = HashMap::new();
        let mut fills: Vec<Option<f32>> = Vec::new(); // per slot: Some(v) uniform, None copy
        let mut owner: Vec<usize> = Vec::new(); // per slot: the tile it copies
        let mut table = Vec::with_capacity(uniform.len());
        for (tile, u) in uniform.iter().enumerate() {
            let slot = match u {
                Some(v) => *slot_of_value.entry(v.to_bits()).or_insert_with(|| {
                    fills.push(Some(*v));
                    owner.push(tile);
                    (fills.len() - 1) as u32
                }),
                None => {
                    fills.push(None);
                    owner.push(tile);
                    (fills.len() - 1) as u32
                }
            };
            table.push(slot);
        }
        let bytes = fills.len() as u64 * PADDED_VOXELS as u64 * 4 + table.len() as u64 * 4;
        let slots_fit = (fills.len() as u64) * (PADDED_VOXELS as u64) < u32::MAX as u64;
        if bytes > MAX_ATLAS_BYTES || !slots_fit {
            return None;
        }
        let table: Vec<u32> = table.into_iter().map(|s| s * PADDED_VOXELS as u32).collect();
        let mut voxels = vec![0.0f32; fills.len() * PADDED_VOXELS];
        voxels
            .par_chunks_mut(PADDED_VOXELS)
            .zip(fills.par_iter().zip(owner.par_iter()))
            .for_each(|(block, (fill, &tile))| match fill {
                Some(v) => block.fill(*v),
                None => {
                    let first = delinearize(tile, tiles) * TILE - IVec3::ONE;
                    let mut reader = source.reader();
                    for (o, out) in block.iter_mut().enumerate() {
                        let local = IVec3::new(
                            (o % STRIDE_Y) as i32,
                            ((o / STRIDE_Y) % STRIDE_Y) as i32,
                            (o / STRIDE_Z) as i32,
                        );
                        *out = reader.density(first + local);
                    }
                }
            });
        Some(BrickAtlas {
            source,
            tiles,
            extent: tiles * TILE,
            table,
            voxels,
        })
    }

    /// The source the atlas was copied from.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// Bytes held (table and stored tiles).
    pub fn memory_bytes(&self) -> u64 {
        (self.table.len() * 4 + self.voxels.len() * 4) as u64
    }

    /// Offset in `voxels` of voxel `base` when `base` is in `[0, extent)` on every axis
    /// (its tile holds `base − 1 ..= base + 2`), else `None`.
    #[inline(always)]
    fn offset(&self, base: IVec3) -> Option<usize> {
        if !(base.cmpge(IVec3::ZERO).all() && base.cmplt(self.extent).all()) {
            return None;
        }
        let t = base >> TILE_LOG2;
        let tile = t.x as usize + self.tiles.x as usize * (t.y as usize + self.tiles.y as usize * t.z as usize);
        let local = (base & IVec3::splat(TILE - 1)) + IVec3::ONE;
        Some(self.table[tile] as usize + local.x as usize + STRIDE_Y * local.y as usize + STRIDE_Z * local.z as usize)
    }

    #[inline(always)]
    fn cube_at(&self, o: usize) -> [f32; 8] {
        let v = &self.voxels[o..o + STRIDE_Z + STRIDE_Y + 2];
        [
            v[0],
            v[1],
            v[STRIDE_Y],
            v[STRIDE_Y + 1],
            v[STRIDE_Z],
            v[STRIDE_Z + 1],
            v[STRIDE_Z + STRIDE_Y],
            v[STRIDE_Z + STRIDE_Y + 1],
        ]
    }
}

/// Tiles per axis and, per tile (x fastest), its value if its padded block is uniform.
fn tile_classes<S: VoxelSource>(source: &S) -> (IVec3, Vec<Option<f32>>) {
    let grid = source.grid();
    let dims = grid.dims().as_ivec3();
    let tiles = (dims + IVec3::splat(TILE - 1)) >> TILE_LOG2;
    let n = tiles.as_uvec3().as_u64vec3().element_product() as usize;
    let bg = source.background();
    let uniform = (0..n)
        .into_par_iter()
        .map(|tile| {
            let first = delinearize(tile, tiles) * TILE - IVec3::ONE;
            let padded = IndexBox::new(first, first + IVec3::splat(PADDED));
            let inside = padded.intersection(&grid.index_box());
            let (mut lo, mut hi) = if inside.is_empty() {
                (bg, bg)
            } else {
                source.density_range(&inside)
            };
            if inside != padded {
                lo = lo.min(bg);
                hi = hi.max(bg);
            }
            // Bit-equal ends only (so -0.0 and 0.0, or NaNs, get their own copies).
            (lo.to_bits() == hi.to_bits()).then_some(lo)
        })
        .collect();
    (tiles, uniform)
}

/// Tile `tile`'s coordinates among `tiles` (x fastest; at least one tile per axis).
#[inline]
fn delinearize(tile: usize, tiles: IVec3) -> IVec3 {
    crate::Shape3::new_unchecked(tiles.as_uvec3()).delinearize(tile)
}

impl<S: VoxelSource> VoxelSource for BrickAtlas<S> {
    fn grid(&self) -> &Grid {
        self.source.grid()
    }
    fn background(&self) -> f32 {
        self.source.background()
    }
    #[inline]
    fn density(&self, ijk: IVec3) -> f32 {
        match self.offset(ijk) {
            Some(o) => self.voxels[o],
            None => self.source.density(ijk),
        }
    }
    #[inline]
    fn density_cube(&self, base: IVec3) -> [f32; 8] {
        match self.offset(base) {
            Some(o) => self.cube_at(o),
            None => self.source.density_cube(base),
        }
    }
    fn density_range(&self, index_box: &IndexBox) -> (f32, f32) {
        self.source.density_range(index_box)
    }
    fn has_colour(&self) -> bool {
        self.source.has_colour()
    }
    fn colour(&self, ijk: IVec3) -> Rgb {
        self.source.colour(ijk)
    }
    type Reader<'a>
        = AtlasReader<'a, S>
    where
        Self: 'a;
    fn reader(&self) -> AtlasReader<'_, S> {
        AtlasReader(self)
    }
}

/// Reads a [`BrickAtlas`] (nothing to cache: a read is a table look-up).
pub struct AtlasReader<'a, S>(&'a BrickAtlas<S>);

impl<S: VoxelSource> VoxelReader for AtlasReader<'_, S> {
    #[inline]
    fn density(&mut self, ijk: IVec3) -> f32 {
        self.0.density(ijk)
    }
    #[inline]
    fn density_cube(&mut self, base: IVec3) -> [f32; 8] {
        self.0.density_cube(base)
    }
    #[inline]
    fn density_block(&mut self, base: IVec3, out: &mut [f32; 64]) -> bool {
        let Some(o) = self.0.offset(base) else {
            return false;
        };
        let first = o - 1 - STRIDE_Y - STRIDE_Z;
        let v = &self.0.voxels[first..first + 3 * STRIDE_Z + 3 * STRIDE_Y + 4];
        for (row, chunk) in out.chunks_exact_mut(4).enumerate() {
            let start = (row / 4) * STRIDE_Z + (row % 4) * STRIDE_Y;
            chunk.copy_from_slice(&v[start..start + 4]);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, UVec3};

    use super::*;
    use crate::{DenseVolume, SparseVolume, Transform};

    fn volume(dims: UVec3) -> SparseVolume {
        let grid = Grid::new(Transform::new(DVec3::splat(-3.0), DVec3::splat(0.5)).unwrap(), dims).unwrap();
        let mut dense = DenseVolume::new(grid, 0.25, false).unwrap();
        for ijk in grid.index_box().iter() {
            // Noise-like values plus a uniform slab (z < 8) to exercise shared tiles.
            let h = ijk.x.wrapping_mul(73_856_093) ^ ijk.y.wrapping_mul(19_349_663) ^ ijk.z.wrapping_mul(83_492_791);
            let v = if ijk.z < 8 { 0.75 } else { (h & 1023) as f32 / 1023.0 };
            dense.density.set(ijk, v);
        }
        SparseVolume::from_dense(&dense)
    }

    #[test]
    fn reads_equal_the_source_everywhere() {
        for dims in [UVec3::new(37, 20, 33), UVec3::ONE, UVec3::new(16, 16, 16)] {
            let v = volume(dims);
            let atlas = BrickAtlas::build(&v).expect("small atlas");
            let mut reader = atlas.reader();
            let lo = IVec3::splat(-3);
            let hi = dims.as_ivec3() + IVec3::splat(3);
            for ijk in IndexBox::new(lo, hi).iter() {
                assert_eq!(atlas.density(ijk).to_bits(), v.density(ijk).to_bits(), "{ijk}");
                let cube = atlas.density_cube(ijk);
                assert_eq!(cube.map(f32::to_bits), v.density_cube(ijk).map(f32::to_bits), "{ijk}");
                let mut block = [0.0f32; 64];
                if reader.density_block(ijk, &mut block) {
                    for (c, b) in block.iter().enumerate() {
                        let o = IVec3::new((c % 4) as i32, ((c / 4) % 4) as i32, (c / 16) as i32) - IVec3::ONE;
                        assert_eq!(b.to_bits(), v.density(ijk + o).to_bits(), "{ijk} + {o}");
                    }
                } else {
                    assert!(ijk.cmplt(IVec3::ZERO).any() || ijk.cmpge(atlas.extent).any());
                }
            }
            assert!(atlas.memory_bytes() <= BrickAtlas::estimate_bytes(&&v));
        }
    }

    #[test]
    fn uniform_tiles_share_storage() {
        let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(64)).unwrap();
        let v = SparseVolume::new(grid, 0.0, false);
        let atlas = BrickAtlas::build(&v).unwrap();
        assert_eq!(atlas.voxels.len(), PADDED_VOXELS);
        assert_eq!(atlas.table.len(), 64);
    }
}
