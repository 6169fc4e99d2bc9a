use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Brick, Grid, IndexBox, Progress, Rgb, SparseVolume, BRICK_DIM, BRICK_VOXELS};

use crate::{OrientedBoxFilter, Shape, SignedDistance};

/// A shape with the colour it carries into the volume's colour channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solid {
    /// The shape (world space).
    pub shape: Shape,
    /// Its RGB colour.
    pub colour: Rgb,
}

impl Solid {
    /// `shape` with `colour`.
    pub fn new(shape: Shape, colour: Rgb) -> Self {
        Solid { shape, colour }
    }
}

/// Brick coordinates whose voxels may receive density from `solid` on `grid`
/// (its bounds grown by the filter half-width), clipped to the grid.
fn band_bricks(grid: &Grid, solid: &Solid, filter: &OrientedBoxFilter) -> IndexBox {
    let world_box = solid.shape.bounds().expanded(DVec3::splat(filter.half_width()));
    let t = &grid.transform;
    let lo = t.world_to_index(world_box.min).ceil();
    let hi = t.world_to_index(world_box.max).floor() + DVec3::ONE;
    let clip = |v: DVec3| v.clamp(DVec3::splat(-1.0), grid.dims().as_dvec3() + 1.0).as_ivec3();
    let voxels = IndexBox::new(clip(lo), clip(hi)).intersection(&grid.index_box());
    if voxels.is_empty() {
        return IndexBox::new(IVec3::ZERO, IVec3::ZERO);
    }
    IndexBox::new(
        voxels.min.div_euclid(IVec3::splat(BRICK_DIM)),
        (voxels.max - IVec3::ONE).div_euclid(IVec3::splat(BRICK_DIM)) + IVec3::ONE,
    )
}

/// Upper bound on the bricks [`voxelize_solids`] allocates, computed without
/// allocating: the sum over solids of the bricks their filter band can touch, capped by
/// the grid's brick count.
pub fn estimate_solid_bricks(grid: &Grid, solids: &[Solid]) -> u64 {
    let filter = OrientedBoxFilter::for_spacing(grid.transform.spacing());
    let total = volga_core::SparseVolume::new(*grid, 0.0, false)
        .brick_extent()
        .as_u64vec3()
        .element_product();
    let sum: u64 = solids
        .iter()
        .map(|s| band_bricks(grid, s, &filter).volume())
        .fold(0u64, |a, b| a.saturating_add(b));
    sum.min(total)
}

/// How a solid relates to every voxel centre of one brick (1-Lipschitz bound on the
/// exact signed distance around the brick's centre).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cover {
    /// Every voxel gets density 1 from this solid.
    Full,
    /// Every voxel gets density 0.
    None,
    Partial,
}

fn classify(shape: &Shape, center: DVec3, radius: f64, half_width: f64) -> Cover {
    if !shape.is_exact() {
        return Cover::Partial;
    }
    let d = shape.signed_distance(center);
    if d + radius <= -half_width {
        Cover::Full
    } else if d - radius >= half_width {
        Cover::None
    } else {
        Cover::Partial
    }
}

/// Volume-samples `solids` on `grid` with the oriented box filter and merges them with
/// the fuzzy union (max). With `with_colour`, each voxel takes the colour of the first
/// solid (in slice order) that attains its density.
///
/// Work is per brick of the solids' bands; bricks are processed in parallel and stored
/// in a fixed order, so the result does not depend on the thread count.
pub fn voxelize_solids(grid: &Grid, solids: &[Solid], with_colour: bool, progress: &dyn Progress) -> SparseVolume {
    voxelize_solids_in(grid, solids, with_colour, &grid.index_box(), progress)
}

/// [`voxelize_solids`] on the bricks of `grid` that meet `clip` (voxel indices) only, each
/// the whole run's brick bit for bit (a brick's voxels depend on nothing outside it).
pub fn voxelize_solids_in(
    grid: &Grid,
    solids: &[Solid],
    with_colour: bool,
    clip: &IndexBox,
    progress: &dyn Progress,
) -> SparseVolume {
    let filter = OrientedBoxFilter::for_spacing(grid.transform.spacing());
    let wanted = volga_core::bricks_meeting(clip);
    let mut bricks: Vec<IVec3> = solids
        .iter()
        .flat_map(|s| {
            band_bricks(grid, s, &filter)
                .intersection(&wanted)
                .iter()
                .collect::<Vec<_>>()
        })
        .collect();
    bricks.sort_unstable_by_key(|b| (b.z, b.y, b.x));
    bricks.dedup();

    progress.start("voxelize", bricks.len() as u64);
    let results: Vec<_> = bricks
        .par_chunks(64)
        .flat_map_iter(|chunk| {
            let out: Vec<_> = chunk
                .iter()
                .filter_map(|&b| sample_brick(grid, solids, &filter, b, with_colour).map(|r| (b, r)))
                .collect();
            progress.inc(chunk.len() as u64);
            out
        })
        .collect();
    progress.finish();

    let mut volume = SparseVolume::new(*grid, 0.0, with_colour);
    for (b, (density, colour)) in results {
        volume.density.insert_brick(b, density);
        if let (Some(c), Some(dst)) = (colour, volume.colour.as_mut()) {
            dst.insert_brick(b, c);
        }
    }
    volume
}

/// Fuzzy union (max, survey eq. 17) of `src`'s density into `dst` (same grid), giving
/// `colour` to the voxels where `src` is strictly denser. Bricks in sorted order:
/// deterministic.
pub fn merge_max(dst: &mut SparseVolume, src: &SparseVolume, colour: Rgb) {
    let grid_box = dst.grid.index_box();
    for b in src.density.sorted_bricks() {
        for ijk in volga_core::brick_index_box(b).intersection(&grid_box).iter() {
            let v = src.density.get(ijk);
            if v > dst.density.get(ijk) {
                dst.density.set(ijk, v);
                if let Some(c) = dst.colour.as_mut() {
                    c.set(ijk, colour);
                }
            }
        }
    }
    dst.density.prune();
    if let Some(c) = dst.colour.as_mut() {
        c.prune();
    }
}

type BrickPair = (Brick<f32>, Option<Brick<Rgb>>);

fn sample_brick(
    grid: &Grid,
    solids: &[Solid],
    filter: &OrientedBoxFilter,
    brick: IVec3,
    with_colour: bool,
) -> Option<BrickPair> {
    let t = &grid.transform;
    let base = brick * BRICK_DIM;
    let half = (BRICK_DIM - 1) as f64 * 0.5;
    let center = t.index_to_world(base.as_dvec3() + half);
    let radius = (t.spacing() * half).length();
    let in_grid = grid.index_box();
    let whole_brick_in_grid = in_grid.contains(base) && in_grid.contains(base + IVec3::splat(BRICK_DIM - 1));

    let mut relevant: Vec<(usize, Cover)> = Vec::with_capacity(solids.len());
    for (i, s) in solids.iter().enumerate() {
        match classify(&s.shape, center, radius, filter.half_width()) {
            Cover::None => {}
            c => relevant.push((i, c)),
        }
    }
    if relevant.is_empty() {
        return None;
    }
    let first_full = relevant.iter().position(|(_, c)| *c == Cover::Full);
    if whole_brick_in_grid {
        if let Some(k) = first_full {
            // Every voxel has density 1; colour is the first solid reaching 1, which is
            // the first full solid unless an earlier partial one also reaches 1 somewhere.
            if !with_colour {
                return Some((Brick::Uniform(1.0), None));
            }
            if k == 0 {
                return Some((Brick::Uniform(1.0), Some(Brick::Uniform(solids[relevant[0].0].colour))));
            }
        }
    }

    let mut density = [0.0f32; BRICK_VOXELS];
    let mut colour = with_colour.then_some([[0.0f32; 3]; BRICK_VOXELS]);
    for (n, ijk) in volga_core::IndexBox::new(base, base + IVec3::splat(BRICK_DIM))
        .iter()
        .enumerate()
    {
        if !in_grid.contains(ijk) {
            continue;
        }
        let p = t.voxel_center(ijk);
        let mut best = 0.0f64;
        let mut best_solid = usize::MAX;
        for &(i, cover) in &relevant {
            let d = match cover {
                Cover::Full => 1.0,
                _ => filter.density(solids[i].shape.signed_distance(p)),
            };
            if d > best {
                best = d;
                best_solid = i;
            }
        }
        density[n] = best as f32;
        if let Some(c) = colour.as_mut() {
            if best_solid != usize::MAX {
                c[n] = solids[best_solid].colour;
            }
        }
    }
    let density = Brick::from_voxels(&density);
    if density == Brick::Uniform(0.0) {
        return None;
    }
    Some((density, colour.map(|c| Brick::from_voxels(&c))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::{AxisBox, Sphere};
    use glam::UVec3;
    use volga_core::{NoProgress, Transform};

    fn grid(n: u32) -> Grid {
        Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(n)).unwrap()
    }

    /// Brute force: the profile of the max over solids at every voxel of the grid.
    fn brute(grid: &Grid, solids: &[Solid]) -> Vec<f32> {
        let f = OrientedBoxFilter::for_spacing(grid.transform.spacing());
        grid.index_box()
            .iter()
            .map(|ijk| {
                let p = grid.transform.voxel_center(ijk);
                solids
                    .iter()
                    .map(|s| f.density(s.shape.signed_distance(p)))
                    .fold(0.0, f64::max) as f32
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_including_brick_fast_paths() {
        let g = grid(41);
        let solids = [
            Solid::new(
                Shape::Sphere(Sphere::new(DVec3::splat(20.0), 15.0).unwrap()),
                [1.0, 0.0, 0.0],
            ),
            Solid::new(
                Shape::AxisBox(AxisBox::new(DVec3::new(3.0, 3.0, 3.0), DVec3::new(12.5, 30.0, 9.0)).unwrap()),
                [0.0, 1.0, 0.0],
            ),
        ];
        let v = voxelize_solids(&g, &solids, true, &NoProgress);
        let d = v.to_dense().unwrap();
        assert_eq!(d.density.as_slice(), brute(&g, &solids).as_slice());
        // Interior of the sphere is stored as uniform bricks, not voxel by voxel.
        assert!(v.density.dense_brick_count() < v.density.brick_count());
        // Colour: red inside the sphere only, green inside the box only.
        let c = d.colour.unwrap();
        assert_eq!(c.get(IVec3::splat(20)), [1.0, 0.0, 0.0]);
        assert_eq!(c.get(IVec3::new(5, 28, 5)), [0.0, 1.0, 0.0]);
    }

    #[test]
    fn estimate_bounds_allocation() {
        let g = grid(64);
        let solids = [Solid::new(
            Shape::Sphere(Sphere::new(DVec3::splat(32.0), 20.0).unwrap()),
            [1.0; 3],
        )];
        let v = voxelize_solids(&g, &solids, false, &NoProgress);
        assert!(estimate_solid_bricks(&g, &solids) >= v.density.brick_count() as u64);
    }

    #[test]
    fn solid_outside_grid_gives_empty_volume() {
        let g = grid(16);
        let solids = [Solid::new(
            Shape::Sphere(Sphere::new(DVec3::splat(100.0), 5.0).unwrap()),
            [1.0; 3],
        )];
        let v = voxelize_solids(&g, &solids, false, &NoProgress);
        assert_eq!(v.density.brick_count(), 0);
        assert_eq!(estimate_solid_bricks(&g, &solids), 0);
    }
}
