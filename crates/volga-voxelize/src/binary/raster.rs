//! The binary voxelizer's driver: triangles moved to index space, bucketed in coarse
//! spatial order, rasterized in chunks into brick masks and merged by brick, or binned
//! by brick on grids too large for packed brick keys.

use glam::{DVec3, IVec3};
use std::sync::Arc;

use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::{Brick, ChannelKind, Grid, IndexBox, Progress, Shape3, SparseVolume, BRICK_DIM, BRICK_VOXELS};

use super::box26::Prepared26;
use super::separating::PreparedTriangle;
use super::{clamp_i, lower, upper, voxel_range, Separability};
use crate::mask::BrickMask;

/// Where the binary voxelizer puts black voxels. `is_set` lets a triangle skip a voxel
/// an earlier triangle made black (the union does not change); a sink that cannot
/// answer cheaply says `false`.
pub(super) trait VoxelSink {
    fn is_set(&self, ijk: IVec3) -> bool;
    fn set(&mut self, ijk: IVec3);
}

/// Binary surface voxelization of world-space triangles on `grid` with the given
/// separability. Black voxels get density 1; the result is the union over triangles.
///
/// Triangles are bucketed by a coarse cell of the grid; chunks of spatially consecutive
/// triangles, each triangle prepared once, collect their black voxels as bit masks per
/// brick, which are then merged by brick (sorted in storage order). A union does not
/// depend on the order in which it is formed, so the result is identical for any
/// thread count. Non-finite triangles are skipped (callers validate input; the mesh
/// loader refuses them).
pub fn voxelize_triangles(
    grid: &Grid,
    triangles: &[[DVec3; 3]],
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    voxelize_indexed(
        grid,
        triangles.len(),
        |i| triangles[i].map(|p| t.world_to_index(p)),
        separability,
        progress,
    )
}

/// [`voxelize_triangles`] for the triangles of a mesh, without gathering them first
/// (its vertices are moved to index space once, not once per corner).
pub fn voxelize_mesh_surface(
    grid: &Grid,
    mesh: &volga_mesh::TriMesh,
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    let index_positions: Vec<DVec3> = mesh.positions.par_iter().map(|&p| t.world_to_index(p)).collect();
    voxelize_indexed(
        grid,
        mesh.triangles.len(),
        |i| mesh.triangles[i].map(|v| index_positions[v as usize]),
        separability,
        progress,
    )
}

/// [`voxelize_triangles`] on the bricks of `clip` only (whole bricks of the grid, clipped
/// to it): the triangles whose voxel range meets `clip`, rasterized as in the whole run;
/// bricks outside `clip` are dropped. Each voxel is black iff some triangle covers it,
/// a test of that voxel and triangle alone, so `clip`'s bricks are those of the whole
/// run bit for bit.
pub fn voxelize_triangles_in(
    grid: &Grid,
    triangles: &[[DVec3; 3]],
    separability: Separability,
    clip: &IndexBox,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    clipped(
        grid,
        triangles.len(),
        |i| triangles[i].map(|p| t.world_to_index(p)),
        separability,
        clip,
        progress,
    )
}

/// [`voxelize_mesh_surface`] on the bricks of `clip` only (see
/// [`voxelize_triangles_in`]).
pub fn voxelize_mesh_surface_in(
    grid: &Grid,
    mesh: &volga_mesh::TriMesh,
    separability: Separability,
    clip: &IndexBox,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    let index_positions: Vec<DVec3> = mesh.positions.par_iter().map(|&p| t.world_to_index(p)).collect();
    clipped(
        grid,
        mesh.triangles.len(),
        |i| mesh.triangles[i].map(|v| index_positions[v as usize]),
        separability,
        clip,
        progress,
    )
}

/// The triangles whose voxel range meets `clip`, voxelized; bricks outside `clip` dropped.
fn clipped(
    grid: &Grid,
    count: usize,
    index_triangle: impl Fn(usize) -> [DVec3; 3] + Sync,
    separability: Separability,
    clip: &IndexBox,
    progress: &dyn Progress,
) -> SparseVolume {
    let kept: Vec<u32> = (0..count)
        .into_par_iter()
        .filter(|&i| {
            let [a, b, c] = index_triangle(i);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                return false;
            }
            let (lo, hi) = voxel_range(a, b, c);
            !IndexBox::new(lo, hi + IVec3::ONE).intersection(clip).is_empty()
        })
        .map(|i| i as u32)
        .collect();
    let mut volume = voxelize_indexed(
        grid,
        kept.len(),
        |k| index_triangle(kept[k] as usize),
        separability,
        progress,
    );
    let bricks = IndexBox::new(
        clip.min.div_euclid(IVec3::splat(BRICK_DIM)),
        (clip.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)),
    );
    for b in volume.density.sorted_bricks() {
        if !bricks.contains(b) {
            volume.density.remove_brick(b);
        }
    }
    volume
}

/// The union over `count` triangles, given in index space by `index_triangle`.
/// Triangles with a non-finite coordinate are skipped.
fn voxelize_indexed(
    grid: &Grid,
    count: usize,
    index_triangle: impl Fn(usize) -> [DVec3; 3] + Sync,
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    let grid_box = grid.index_box();
    let finite = |i: usize| {
        let tri = index_triangle(i);
        tri.iter().all(|p| p.is_finite()).then_some(tri)
    };
    if grid_box.max.cmpgt(IVec3::splat(1 << (21 + BRICK_LOG2))).any() {
        let index_triangles: Vec<[DVec3; 3]> = (0..count).into_par_iter().filter_map(finite).collect();
        return voxelize_triangles_by_bricks(grid, &index_triangles, separability, progress);
    }
    // Triangles in coarse spatial order: bucketed (a counting sort) by the cell of
    // their first vertex, cells of 2^s bricks a side in storage order, at most
    // `MAX_CELLS` of them. Non-finite triangles are dropped here. On the bunny at
    // N = 128 this cuts the brick masks the chunks hand over from 13,829 to 2,514 (mesh
    // order scatters a chunk over ~200 bricks) and lets more voxels be found black
    // already; it costs two passes over the triangles.
    const MAX_CELLS: i64 = 1 << 16;
    let cells = (grid_box.max + IVec3::splat(BRICK_DIM - 1)) >> BRICK_LOG2;
    let shift = (0..21)
        .find(|&s: &i32| {
            let c = ((cells + IVec3::splat((1 << s) - 1)) >> s).max(IVec3::ONE).as_i64vec3();
            c.x * c.y * c.z <= MAX_CELLS
        })
        .unwrap_or(21);
    let cells = ((cells + IVec3::splat((1 << shift) - 1)) >> shift).max(IVec3::ONE);
    let Ok(cell_shape) = Shape3::new(cells.as_uvec3()) else {
        // Not reached (at most `MAX_CELLS` cells of ≥ 1 per axis); the per-brick path
        // handles any grid.
        let index_triangles: Vec<[DVec3; 3]> = (0..count).into_par_iter().filter_map(finite).collect();
        return voxelize_triangles_by_bricks(grid, &index_triangles, separability, progress);
    };
    let cell_of: Vec<u32> = (0..count)
        .into_par_iter()
        .map(|i| match finite(i) {
            Some([a, ..]) => {
                let c = (clamp_i(a).clamp(grid_box.min, grid_box.max - IVec3::ONE) >> (BRICK_LOG2 + shift))
                    .clamp(IVec3::ZERO, cells - IVec3::ONE);
                cell_shape.linearize(c) as u32
            }
            None => u32::MAX,
        })
        .collect();
    let mut start = vec![0u32; cell_shape.len() + 1];
    for &c in cell_of.iter().filter(|&&c| c != u32::MAX) {
        start[c as usize + 1] += 1;
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let mut order = vec![0u32; start[start.len() - 1] as usize];
    for (i, &c) in cell_of.iter().enumerate().filter(|(_, &c)| c != u32::MAX) {
        order[start[c as usize] as usize] = i as u32;
        start[c as usize] += 1;
    }
    drop(cell_of);

    // Chunks of spatially consecutive triangles collect their voxels as 512-bit brick
    // masks (a voxel is hit by ~5 small triangles; setting a bit costs nothing),
    // merged by brick at the end ([`rasterize_chunk`]).
    const CHUNK: usize = 1024;
    progress.start("voxelize", order.len().div_ceil(CHUNK) as u64);
    let chunks: Vec<Vec<(u64, BrickMask)>> = order
        .par_chunks(CHUNK)
        .map(|chunk| {
            let tris: Vec<[DVec3; 3]> = chunk.iter().map(|&i| index_triangle(i as usize)).collect();
            let masks = rasterize_chunk(&tris, separability, &grid_box);
            progress.inc(1);
            masks
        })
        .collect();
    let mut masks: Vec<(u64, BrickMask)> = chunks.concat();
    masks.par_sort_unstable_by_key(|(k, _)| *k);
    progress.finish();

    let runs: Vec<&[(u64, BrickMask)]> = masks.chunk_by(|a, b| a.0 == b.0).collect();
    let bricks: Vec<(IVec3, Brick<f32>)> = runs
        .par_iter()
        .map(|run| {
            let mask = run.iter().fold(BrickMask::EMPTY, |m, (_, r)| m.or(r));
            (brick_of_key(run[0].0), binary_brick(&mask))
        })
        .collect();
    let mut volume = SparseVolume::new(*grid, 0.0, false).with_density_kind(ChannelKind::Binary);
    for (b, brick) in bricks {
        volume.density.insert_brick(b, brick);
    }
    volume
}

/// The brick with 1 on `mask`'s voxels and 0 elsewhere, as [`Brick::from_voxels`] makes
/// it (uniform when all are equal), written in place: no 2 KiB staging copy, and the
/// uniform test reads eight words instead of 512 values.
fn binary_brick(mask: &BrickMask) -> Brick<f32> {
    if mask.0.iter().all(|&w| w == u64::MAX) {
        return Brick::Uniform(1.0);
    }
    if mask.is_empty() {
        return Brick::Uniform(0.0);
    }
    let mut data = Arc::new([0.0f32; BRICK_VOXELS]);
    let voxels = Arc::get_mut(&mut data).expect("a new Arc has no other owner");
    for (z, &word) in mask.0.iter().enumerate() {
        let mut left = word;
        while left != 0 {
            voxels[64 * z + left.trailing_zeros() as usize] = 1.0;
            left &= left - 1;
        }
    }
    Brick::Dense(data)
}

/// The voxels of `tris` (in coarse spatial order) within `grid_box`, as brick masks
/// keyed by [`brick_key`]. The masks live in a dense array over the box of bricks the
/// triangles reach when it holds at most `DENSE_BRICKS`; a wider run of triangles is
/// halved (its halves, being spatially consecutive, span smaller boxes) down to
/// `MIN_SPLIT` triangles, below which a hash map holds the masks. At N = 512, 28 of the
/// bunny's 68 runs of 1,024 triangles span more than 4,096 bricks.
fn rasterize_chunk(tris: &[[DVec3; 3]], separability: Separability, grid_box: &IndexBox) -> Vec<(u64, BrickMask)> {
    const DENSE_BRICKS: i64 = 4096; // 256 KiB of masks
    const MIN_SPLIT: usize = 128;
    // The bricks: the union of the triangles' voxel ranges (the range of their bounding
    // box, rounding being monotonic), clipped to the grid.
    let Some(&[first, ..]) = tris.first() else {
        return Vec::new();
    };
    let (lo, hi) = tris
        .iter()
        .flatten()
        .fold((first, first), |(lo, hi), &p| (lower(lo, p), upper(hi, p)));
    let (lo, hi) = voxel_range(lo, hi, hi);
    let lo = lo.max(grid_box.min) >> BRICK_LOG2;
    let hi = hi.min(grid_box.max - IVec3::ONE) >> BRICK_LOG2;
    let size = (hi - lo + IVec3::ONE).max(IVec3::ZERO);
    let wide = size.as_i64vec3().element_product() > DENSE_BRICKS;
    if wide && tris.len() >= 2 * MIN_SPLIT {
        let (left, right) = tris.split_at(tris.len() / 2);
        let mut masks = rasterize_chunk(left, separability, grid_box);
        masks.extend(rasterize_chunk(right, separability, grid_box));
        return masks;
    }
    // A dense array of masks over the box of bricks when it is small (an empty box has
    // no layout and takes the map, which stays empty).
    let dense = (!wide).then(|| Shape3::new(size.as_uvec3()).ok()).flatten();
    if let Some(shape) = dense {
        let mut sink = DenseMasks {
            lo,
            shape,
            masks: vec![BrickMask::EMPTY; shape.len()],
        };
        rasterize(tris, separability, grid_box, &mut sink);
        sink.masks
            .into_iter()
            .enumerate()
            .filter(|(_, m)| !m.is_empty())
            .map(|(i, m)| (brick_key(lo + shape.delinearize(i)), m))
            .collect()
    } else {
        let mut sink = MapMasks {
            masks: FxHashMap::default(),
            last_key: u64::MAX,
            last: BrickMask::EMPTY,
        };
        rasterize(tris, separability, grid_box, &mut sink);
        sink.flush();
        sink.masks.into_iter().collect()
    }
}

/// Sets every voxel of `region` that one of `index_triangles` covers.
#[inline]
fn rasterize(index_triangles: &[[DVec3; 3]], separability: Separability, region: &IndexBox, sink: &mut impl VoxelSink) {
    for &tri in index_triangles {
        let fast = (separability == Separability::TwentySix)
            .then(|| Prepared26::new(tri))
            .flatten();
        match fast {
            Some(p) => p.rasterize(region, sink),
            None => PreparedTriangle::new(tri, separability).for_each_voxel(region, |ijk| sink.set(ijk)),
        }
    }
}

/// A chunk's voxels as brick masks in a dense array over its box of bricks.
struct DenseMasks {
    lo: IVec3,
    /// Layout of the box of bricks from `lo`.
    shape: Shape3,
    masks: Vec<BrickMask>,
}

impl DenseMasks {
    #[inline]
    fn slot(&self, ijk: IVec3) -> (usize, usize) {
        let b = (ijk >> BRICK_LOG2) - self.lo;
        (self.shape.linearize(b), Brick::<f32>::local_offset(ijk))
    }
}

impl VoxelSink for DenseMasks {
    #[inline]
    fn is_set(&self, ijk: IVec3) -> bool {
        let (i, o) = self.slot(ijk);
        self.masks[i].contains(o)
    }

    #[inline]
    fn set(&mut self, ijk: IVec3) {
        let (i, o) = self.slot(ijk);
        self.masks[i].insert(o);
    }
}

/// A chunk's voxels as brick masks in a hash map, for chunks spread over many bricks.
/// Consecutive voxels mostly share a brick: they are gathered before touching the map.
struct MapMasks {
    masks: FxHashMap<u64, BrickMask>,
    last_key: u64,
    last: BrickMask,
}

impl MapMasks {
    fn flush(&mut self) {
        if self.last_key != u64::MAX {
            let entry = self.masks.entry(self.last_key).or_default();
            *entry = entry.or(&self.last);
        }
    }
}

impl VoxelSink for MapMasks {
    #[inline]
    fn is_set(&self, ijk: IVec3) -> bool {
        brick_key(ijk >> BRICK_LOG2) == self.last_key && self.last.contains(Brick::<f32>::local_offset(ijk))
    }

    #[inline]
    fn set(&mut self, ijk: IVec3) {
        let key = brick_key(ijk >> BRICK_LOG2);
        if key != self.last_key {
            self.flush();
            self.last_key = key;
            self.last = BrickMask::EMPTY;
        }
        self.last.insert(Brick::<f32>::local_offset(ijk));
    }
}

/// Packs a brick of a grid (non-negative, below 2²¹ per axis) as z, y, x: sorting keys
/// sorts bricks in storage order.
#[inline]
fn brick_key(b: IVec3) -> u64 {
    let b = b.as_uvec3();
    ((b.z as u64) << 42) | ((b.y as u64) << 21) | b.x as u64
}

#[inline]
fn brick_of_key(key: u64) -> IVec3 {
    let mask = (1u64 << 21) - 1;
    IVec3::new((key & mask) as i32, ((key >> 21) & mask) as i32, (key >> 42) as i32)
}

const BRICK_LOG2: i32 = volga_core::BRICK_LOG2;

/// The same union for grids too large for packed keys: triangles binned into bricks
/// (prepared again in every brick they touch), bricks processed in parallel and stored
/// in sorted order.
fn voxelize_triangles_by_bricks(
    grid: &Grid,
    index_triangles: &[[DVec3; 3]],
    separability: Separability,
    progress: &dyn Progress,
) -> SparseVolume {
    // (brick, triangle) pairs for every brick a triangle's voxel range touches.
    let grid_box = grid.index_box();
    let mut pairs: Vec<(IVec3, u32)> = index_triangles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, [a, b, c])| {
            let (lo, hi) = voxel_range(*a, *b, *c);
            let (lo, hi) = (lo.max(grid_box.min), hi.min(grid_box.max - IVec3::ONE));
            let bricks = if lo.cmpgt(hi).any() {
                IndexBox::new(IVec3::ZERO, IVec3::ZERO)
            } else {
                IndexBox::new(
                    lo.div_euclid(IVec3::splat(BRICK_DIM)),
                    hi.div_euclid(IVec3::splat(BRICK_DIM)) + 1,
                )
            };
            bricks.iter().map(move |b| (b, i as u32)).collect::<Vec<_>>()
        })
        .collect();
    crate::pairs::sort_brick_pairs(&mut pairs);
    let groups: Vec<&[(IVec3, u32)]> = pairs.chunk_by(|a, b| a.0 == b.0).collect();

    progress.start("voxelize", groups.len() as u64);
    let bricks: Vec<(IVec3, Brick<f32>)> = groups
        .par_iter()
        .filter_map(|group| {
            let brick = group[0].0;
            let region = IndexBox::new(brick * BRICK_DIM, (brick + 1) * BRICK_DIM).intersection(&grid_box);
            let mut data = [0.0f32; BRICK_VOXELS];
            let mut any = false;
            for &(_, i) in group.iter() {
                PreparedTriangle::new(index_triangles[i as usize], separability).for_each_voxel(&region, |ijk| {
                    data[Brick::<f32>::local_offset(ijk)] = 1.0;
                    any = true;
                });
            }
            progress.inc(1);
            any.then(|| (brick, Brick::from_voxels(&data)))
        })
        .collect();
    progress.finish();

    let mut volume = SparseVolume::new(*grid, 0.0, false).with_density_kind(ChannelKind::Binary);
    for (b, brick) in bricks {
        volume.density.insert_brick(b, brick);
    }
    volume
}
