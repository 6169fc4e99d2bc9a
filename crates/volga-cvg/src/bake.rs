//! Baking any field into a sparse volume over only the bricks it can reach: the bricks
//! touching `field.bounds()` (a CVG tree's support, so an intersection bakes only the
//! overlap), each classified by the field's conservative `value_range` first, so a brick
//! whose range is one value is stored as that value without sampling a voxel.

use glam::IVec3;
use rayon::prelude::*;
use volga_core::{brick_index_box, Brick, Field, Grid, IndexBox, Rgb, SparseVolume, BRICK_DIM, BRICK_VOXELS};

/// What baking did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BakeStats {
    /// Bricks within the field's bounds (the only ones looked at).
    pub bricks_visited: u64,
    /// Of those, bricks settled by the value range alone (no voxel sampled).
    pub bricks_uniform: u64,
    /// Voxels sampled.
    pub samples: u64,
}

/// The field at every voxel centre of `grid` it can reach (density as `f32`, and colour
/// when `colour`); the volume's background is the field's. Deterministic: bricks are
/// computed independently and inserted in sorted order.
pub fn bake(field: &dyn Field, grid: &Grid, colour: bool) -> (SparseVolume, BakeStats) {
    bake_in(field, grid, colour, &grid.index_box())
}

/// [`bake`] on the bricks of `grid` that meet `clip` (voxel indices) only, each computed
/// exactly as in the whole bake (so they are the whole bake's bricks, bit for bit); no
/// other brick is stored or sampled. Chunked and out-of-core bakes are made of these.
pub fn bake_in(field: &dyn Field, grid: &Grid, colour: bool, clip: &IndexBox) -> (SparseVolume, BakeStats) {
    let background = field.background() as f32;
    let mut volume = SparseVolume::new(*grid, background, colour);
    let region = field.bounds().intersection(&grid.world_bounds());
    let mut stats = BakeStats::default();
    if region.is_empty() {
        return (volume, stats);
    }
    let voxels = grid.index_box_touching(&region).intersection(&grid.index_box());
    if voxels.is_empty() {
        return (volume, stats);
    }
    // The bricks that meet both the field's voxels and `clip`; `voxels` itself stays the
    // whole bake's (each brick's sampling depends on it).
    let wanted = voxels.intersection(clip);
    if wanted.is_empty() {
        return (volume, stats);
    }
    let (lo, hi): (IVec3, IVec3) = (wanted.min >> 3, (wanted.max - 1) >> 3);
    let mut bricks = Vec::new();
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                bricks.push(IVec3::new(x, y, z));
            }
        }
    }
    let results: Vec<_> = bricks
        .par_iter()
        .map(|&b| bake_brick(field, grid, b, &voxels, background, colour))
        .collect();
    for (b, (density, tint, samples, uniform)) in bricks.iter().zip(results) {
        stats.bricks_visited += 1;
        stats.bricks_uniform += uniform as u64;
        stats.samples += samples;
        if !matches!(density, Brick::Uniform(v) if v == background) {
            volume.density.insert_brick(*b, density);
        }
        // Colour is kept wherever something is visible, background density included
        // (a complement's background is 1).
        if let (Some(c), Some(t)) = (volume.colour.as_mut(), tint) {
            if !matches!(t, Brick::Uniform(rgb) if rgb == [0.0; 3]) {
                c.insert_brick(*b, t);
            }
        }
    }
    (volume, stats)
}

type BakedBrick = (Brick<f32>, Option<Brick<Rgb>>, u64, bool);

fn bake_brick(
    field: &dyn Field,
    grid: &Grid,
    b: IVec3,
    voxels: &IndexBox,
    background: f32,
    colour: bool,
) -> BakedBrick {
    let inside = brick_index_box(b).intersection(voxels);
    let t = &grid.transform;
    let centres = volga_core::Aabb::new(t.voxel_center(inside.min), t.voxel_center(inside.max - 1));
    let (lo, hi) = field.value_range(&centres);
    let full = inside.volume() == BRICK_VOXELS as u64;
    if lo == hi && (full || lo as f32 == background) {
        let v = lo as f32;
        let tint = (colour && v != 0.0).then(|| sample_colours(field, grid, b, &inside, None));
        return (Brick::Uniform(v), tint, 0, true);
    }
    let base = b * BRICK_DIM;
    let mut data = [background; BRICK_VOXELS];
    let mut samples = 0;
    for ijk in inside.iter() {
        let o = ijk - base;
        data[(o.x + BRICK_DIM * (o.y + BRICK_DIM * o.z)) as usize] = field.value(t.voxel_center(ijk)) as f32;
        samples += 1;
    }
    let density = Brick::from_voxels(&data);
    let tint = colour.then(|| sample_colours(field, grid, b, &inside, Some(&data)));
    (density, tint, samples, false)
}

/// Colours of the voxels of brick `b` inside `inside` whose density (`density`, or
/// non-zero everywhere when `None`) is not 0: colour is looked up only where something
/// is visible (a texture's noise runs nowhere else).
fn sample_colours(
    field: &dyn Field,
    grid: &Grid,
    b: IVec3,
    inside: &IndexBox,
    density: Option<&[f32; BRICK_VOXELS]>,
) -> Brick<Rgb> {
    let base = b * BRICK_DIM;
    let mut data = [[0.0f32; 3]; BRICK_VOXELS];
    for ijk in inside.iter() {
        let o = ijk - base;
        let i = (o.x + BRICK_DIM * (o.y + BRICK_DIM * o.z)) as usize;
        if density.is_some_and(|d| d[i] == 0.0) {
            continue;
        }
        let c = field
            .colour(grid.transform.voxel_center(ijk))
            .unwrap_or(glam::Vec3::ONE);
        data[i] = c.to_array();
    }
    Brick::from_voxels(&data)
}
