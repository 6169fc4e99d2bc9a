//! Region proofs for bricks no band reaches: per face-connected component of bricks
//! (meshes without a boundary, where `w` is constant between sheets), or by an octree
//! of voxel boxes refined down to single voxels (meshes with a boundary).

use glam::IVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::{Aabb, Grid, IndexBox, BRICK_DIM};

use super::crossings::CROSSING_SCRATCH;
use super::SignStats;
use crate::mask::BrickMask;
use crate::mesh::MeshVoxelizer;

impl MeshVoxelizer {
    /// Boundary-free meshes: `w` is constant between sheets and 0 outside the mesh's
    /// bounds, so face-connected bricks that no band reaches share their sign. Label
    /// them by flood fill and prove the sign once per component.
    pub(crate) fn inside_bricks_by_components(
        &self,
        candidates: &[IVec3],
        band: &rustc_hash::FxHashSet<IVec3>,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> Vec<IVec3> {
        let set: rustc_hash::FxHashSet<IVec3> = candidates.iter().copied().collect();
        let mut label: FxHashMap<IVec3, bool> = FxHashMap::default();
        let mut inside = Vec::new();
        for &start in candidates {
            if label.contains_key(&start) {
                continue;
            }
            let centre = grid.transform.index_to_world((start * BRICK_DIM).as_dvec3() + 3.5);
            let is_inside = self.exact_side(centre, None, stats).0;
            stats.region_queries += 1;
            let mut stack = vec![start];
            label.insert(start, is_inside);
            while let Some(b) = stack.pop() {
                if is_inside {
                    inside.push(b);
                }
                for o in [IVec3::X, IVec3::NEG_X, IVec3::Y, IVec3::NEG_Y, IVec3::Z, IVec3::NEG_Z] {
                    let nb = b + o;
                    if set.contains(&nb) && !band.contains(&nb) && !label.contains_key(&nb) {
                        label.insert(nb, is_inside);
                        stack.push(nb);
                    }
                }
            }
        }
        inside.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        inside
    }

    /// Meshes with a boundary: `w` varies smoothly away from the surface (through the
    /// holes, and outside the mesh's bounds where stacked sheets can reach ½), so the
    /// whole grid beyond the band is classified by an octree of voxel boxes: a box no band
    /// reaches takes the sign of its centre when the certified margin there exceeds the
    /// gradient bound times the box's radius; otherwise it splits, down to single voxels.
    /// Returns the wholly inside bricks and the partly inside ones as masks.
    pub(crate) fn inside_by_octree(
        &self,
        touched: &rustc_hash::FxHashSet<IVec3>,
        grid: &Grid,
        clip: &IndexBox,
        stats: &mut SignStats,
    ) -> (Vec<IVec3>, Vec<(IVec3, BrickMask)>) {
        // Only the voxels of `clip` (whole bricks, or the grid): a box's sign is proven,
        // so clipping changes which queries prove it, never the answer.
        let grid_box = grid.index_box().intersection(clip);
        // The bricks of `clip`: `base + [0, extent)`.
        let base = grid_box.min.div_euclid(IVec3::splat(BRICK_DIM));
        let extent = (grid_box.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)) - base;
        // Prefix sums of touched bricks: "does this box hold band" in O(1).
        let (ex, ey, ez) = (extent.x as usize + 1, extent.y as usize + 1, extent.z as usize + 1);
        let mut prefix = vec![0u32; ex * ey * ez];
        let at = |x: usize, y: usize, z: usize| (z * ey + y) * ex + x;
        for z in 1..ez {
            for y in 1..ey {
                for x in 1..ex {
                    let own = touched.contains(&(base + IVec3::new(x as i32 - 1, y as i32 - 1, z as i32 - 1))) as u32;
                    prefix[at(x, y, z)] =
                        own + prefix[at(x - 1, y, z)] + prefix[at(x, y - 1, z)] + prefix[at(x, y, z - 1)]
                            - prefix[at(x - 1, y - 1, z)]
                            - prefix[at(x - 1, y, z - 1)]
                            - prefix[at(x, y - 1, z - 1)]
                            + prefix[at(x - 1, y - 1, z - 1)];
                }
            }
        }
        let band_in = |lo: IVec3, hi: IVec3| {
            let (l, h) = ((lo - base).as_uvec3(), (hi - base).as_uvec3());
            let (l, h) = (
                (l.x as usize, l.y as usize, l.z as usize),
                (h.x as usize, h.y as usize, h.z as usize),
            );
            prefix[at(h.0, h.1, h.2)]
                + prefix[at(l.0, l.1, h.2)]
                + prefix[at(l.0, h.1, l.2)]
                + prefix[at(h.0, l.1, l.2)]
                - prefix[at(l.0, h.1, h.2)]
                - prefix[at(h.0, l.1, h.2)]
                - prefix[at(h.0, h.1, l.2)]
                - prefix[at(l.0, l.1, l.2)]
                > 0
        };
        let mut size = BRICK_DIM;
        while size < grid.dims().max_element() as i32 {
            size *= 2;
        }
        let results = [self.classify_box(
            None,
            None,
            IndexBox::new(IVec3::ZERO, IVec3::splat(size)),
            &grid_box,
            &band_in,
            grid,
        )];
        let mut full = Vec::new();
        let mut partial: FxHashMap<IVec3, BrickMask> = FxHashMap::default();
        for (boxes, local) in results {
            stats.add(&local);
            for b in boxes {
                let bricks = IndexBox::new(
                    b.min.div_euclid(IVec3::splat(BRICK_DIM)),
                    (b.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)),
                );
                for brick in bricks.iter() {
                    let own = IndexBox::new(brick * BRICK_DIM, (brick + 1) * BRICK_DIM).intersection(&grid_box);
                    if own.intersection(&b) == own {
                        full.push(brick);
                    } else {
                        let mask = partial.entry(brick).or_default();
                        *mask = mask.or(&BrickMask::of_region(brick, &b));
                    }
                }
            }
        }
        full.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        let mut partial: Vec<(IVec3, BrickMask)> = partial.into_iter().collect();
        partial.sort_unstable_by_key(|(b, _)| (b.z, b.y, b.x));
        (full, partial)
    }

    /// One octree box (voxel index space, a power-of-two cube, clipped to the grid):
    /// its inside voxels as boxes, and the queries it took. `known` is `I` over the whole
    /// box; `parent` a point of the enclosing box free of the mesh with its proven `I`,
    /// to carry `I` to this box's centre by the caps crossed on the way.
    fn classify_box(
        &self,
        known: Option<f64>,
        parent: Option<(glam::DVec3, f64)>,
        cube: IndexBox,
        grid_box: &IndexBox,
        band_in: &(dyn Fn(IVec3, IVec3) -> bool + Sync),
        grid: &Grid,
    ) -> (Vec<IndexBox>, SignStats) {
        let mut stats = SignStats::default();
        let region = cube.intersection(grid_box);
        if region.is_empty() {
            return (Vec::new(), stats);
        }
        let size = (cube.max - cube.min).x;
        if size >= BRICK_DIM {
            let lo = region.min.div_euclid(IVec3::splat(BRICK_DIM));
            let hi = (region.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM));
            if band_in(lo, hi) {
                if size > BRICK_DIM {
                    return self.split(None, None, cube, grid_box, band_in, grid);
                }
                return (Vec::new(), stats); // a band brick: its voxels are the band's
            }
        }
        // No band in the box: no sheet either, so straight paths inside it cross none.
        let t = &grid.transform;
        let (a, b) = (t.voxel_center(region.min), t.voxel_center(region.max - IVec3::ONE));
        let (lo, hi) = (a.min(b), a.max(b));
        let centre = 0.5 * (lo + hi);
        // `I` at the centre, carried from the enclosing box's centre (both lie in its
        // hull of voxel centres, which no sheet of the mesh meets: the segment crosses
        // only caps) or from a triangle near it, spares the mesh's tree.
        let carried = known.or_else(|| {
            parent.and_then(|(from, i)| {
                CROSSING_SCRATCH
                    .with_borrow_mut(|scratch| self.sign.cap_crossings(from, centre, scratch))
                    .map(|c| i + c as f64)
            })
        });
        // A single voxel is decided exactly; a larger box by one query when `w` keeps
        // clear of ½ by more than it can drift over the box.
        if size == 1 {
            let (inside, _) = self.exact_side(centre, carried, &mut stats);
            return (if inside { vec![region] } else { Vec::new() }, stats);
        }
        let radius = 0.5 * (hi - lo).length();
        let drift = self.sign.boundary.gradient_bound(&Aabb::new(lo, hi)) * radius;
        let at_centre = carried.or_else(|| self.integer_near(centre).map(|i| i as f64));
        let w = self.margin_query(centre, at_centre, drift);
        stats.query_terms += w.terms as u64;
        stats.region_queries += 1;
        if w.margin(0.5) > drift {
            (if w.value >= 0.5 { vec![region] } else { Vec::new() }, stats)
        } else {
            // Free of the mesh; if no cap reaches it, `I` is one integer over it.
            let known = known.or_else(|| self.region_integer(centre, radius));
            let parent = at_centre.map(|i| (centre, i));
            let (boxes, more) = self.split(known, parent, cube, grid_box, band_in, grid);
            stats.add(&more);
            (boxes, stats)
        }
    }

    /// The eight octants of `cube`, in parallel while they are large.
    fn split(
        &self,
        known: Option<f64>,
        parent: Option<(glam::DVec3, f64)>,
        cube: IndexBox,
        grid_box: &IndexBox,
        band_in: &(dyn Fn(IVec3, IVec3) -> bool + Sync),
        grid: &Grid,
    ) -> (Vec<IndexBox>, SignStats) {
        let half = (cube.max - cube.min).x / 2;
        let octant = |k: i32| {
            let lo = cube.min + IVec3::new(k & 1, (k >> 1) & 1, k >> 2) * half;
            self.classify_box(known, parent, IndexBox::new(lo, lo + half), grid_box, band_in, grid)
        };
        let parts: Vec<(Vec<IndexBox>, SignStats)> = if half >= 4 * BRICK_DIM {
            (0..8).into_par_iter().map(octant).collect()
        } else {
            (0..8).map(octant).collect()
        };
        let mut stats = SignStats::default();
        let mut boxes = Vec::new();
        for (b, s) in parts {
            boxes.extend(b);
            stats.add(&s);
        }
        (boxes, stats)
    }
}
