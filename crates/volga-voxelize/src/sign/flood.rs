//! Flood proofs inside one band brick: voxels beyond the band take the sign of the band
//! voxels their 6-connected component touches, as far as the gradient bound allows;
//! the rest are proven box by box within the brick, down to single voxels.

use glam::IVec3;
use volga_core::{Aabb, Grid, IndexBox, BRICK_DIM, BRICK_VOXELS};

use super::SignStats;
use crate::mask::BrickMask;
use crate::mesh::MeshVoxelizer;

impl MeshVoxelizer {
    /// The inside voxels of one brick beyond the band (`unknown`). Each 6-connected
    /// component takes the sign of the band voxels next to it: a 6-step from a voxel
    /// beyond the band is shorter than the band, so it crosses no sheet. Without a
    /// boundary (`w` constant between sheets) that is exact; otherwise `w` drifts by at
    /// most the gradient bound times the path, and the component keeps the sign only
    /// while the seeds' proven margin covers the drift. Components touching no band
    /// voxel take a certified query at their first voxel on the same terms; the rest
    /// ask every voxel.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn flood_signs(
        &self,
        brick: IVec3,
        inside_band: BrickMask,
        outside_band: BrickMask,
        margin: &[f64; BRICK_VOXELS],
        unknown: BrickMask,
        reference: Option<usize>,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> BrickMask {
        let (touches_inside, touches_outside) = (inside_band.dilate6(), outside_band.dilate6());
        let centre = |o: usize| {
            let ijk = brick * BRICK_DIM + IVec3::new(o as i32 % 8, o as i32 / 8 % 8, o as i32 / 64);
            grid.transform.voxel_center(ijk)
        };
        // `w` drifts by at most this much per 6-step inside the brick.
        let step_drift = if self.sign.closed {
            0.0
        } else {
            let lo = grid.transform.index_to_world((brick * BRICK_DIM).as_dvec3() - 0.5);
            let hi = grid
                .transform
                .index_to_world(((brick + 1) * BRICK_DIM).as_dvec3() - 0.5);
            self.sign.boundary.gradient_bound(&Aabb::new(lo.min(hi), lo.max(hi))) * grid.max_spacing()
        };
        // Steps from `start` to cover `component` (6-connected, so it ends).
        let depth = |start: BrickMask, component: BrickMask| {
            let (mut covered, mut steps) = (start, 1u32);
            while covered != component {
                covered = covered.dilate6().and(&component);
                steps += 1;
            }
            steps as f64
        };
        let seed_margin = |seeds: BrickMask| {
            let mut min = f64::INFINITY;
            let mut left = seeds;
            while let Some(o) = left.first() {
                left.remove(o);
                min = min.min(margin[o]);
            }
            min
        };
        let mut inside = inside_band;
        let mut rest = unknown;
        // The cap triangles near the brick, gathered once for all its components.
        let mut near_caps: Option<Vec<[glam::DVec3; 3]>> = None;
        // `w` drifts by at most this much per 6-step inside each octant (x + 2y + 4z).
        let mut octant_drifts: Option<[f64; 8]> = None;
        while let Some(first) = rest.first() {
            let mut component = BrickMask::EMPTY;
            component.insert(first);
            component = component.flood(&rest);
            rest = rest.and_not(&component);
            let (by_inside, by_outside) = (component.and(&touches_inside), component.and(&touches_outside));
            let decided = match (!by_inside.is_empty(), !by_outside.is_empty()) {
                (true, false) => {
                    let m = seed_margin(inside_band.and(&component.dilate6()));
                    (step_drift == 0.0 || m > step_drift * depth(by_inside, component)).then_some(true)
                }
                (false, true) => {
                    let m = seed_margin(outside_band.and(&component.dilate6()));
                    (step_drift == 0.0 || m > step_drift * depth(by_outside, component)).then_some(false)
                }
                (false, false) => {
                    let mut start = BrickMask::EMPTY;
                    start.insert(first);
                    let needed = if step_drift == 0.0 {
                        0.0
                    } else {
                        step_drift * (depth(start, component) - 1.0)
                    };
                    let known = reference.and_then(|t| self.integer_from(t, centre(first)));
                    let w = self.margin_query(centre(first), known.map(|i| i as f64), needed);
                    stats.query_terms += w.terms as u64;
                    stats.region_queries += 1;
                    (w.margin(0.5) > needed || (needed == 0.0 && w.side(0.5).is_some())).then_some(w.value >= 0.5)
                }
                (true, true) => None,
            };
            let component = match decided {
                Some(true) => {
                    inside = inside.or(&component);
                    continue;
                }
                Some(false) => continue,
                None => {
                    // Voxel by voxel: the margin of the best seed, less the drift of the
                    // steps from it, with the gradient bound of each octant of the brick
                    // (the brick's own bound is infinite when the boundary enters it).
                    let drifts = *octant_drifts.get_or_insert_with(|| {
                        std::array::from_fn(|k| {
                            let corner =
                                brick * BRICK_DIM + 4 * IVec3::new(k as i32 & 1, k as i32 >> 1 & 1, k as i32 >> 2);
                            let lo = grid.transform.index_to_world(corner.as_dvec3() - 0.5);
                            let hi = grid.transform.index_to_world((corner + 4).as_dvec3() - 0.5);
                            self.sign.boundary.gradient_bound(&Aabb::new(lo.min(hi), lo.max(hi))) * grid.max_spacing()
                        })
                    });
                    let by_in = proven_by_seeds(inside_band, component, margin, &drifts);
                    let by_out = proven_by_seeds(outside_band, component, margin, &drifts);
                    inside = inside.or(&by_in.and_not(&by_out));
                    let rest = component.and_not(&by_in.or(&by_out).and_not(&by_in.and(&by_out)));
                    if rest.is_empty() {
                        continue;
                    }
                    rest
                }
            };
            if self.sign.cap.is_some() {
                // `I = w_M + w_C` is an integer off the mesh and the caps, carried
                // from voxel to voxel by the proven cap crossings of each step (a
                // step from a voxel beyond the band crosses no sheet of the mesh),
                // from one voxel whose `I` is carried from a trusted triangle (or,
                // failing that, queried). Voxels farther than a step from every cap
                // are proven box by box with their `I`, the rest one by one, both
                // asking only the caps.
                let integers = self.carry_integers(component, reference, &centre, stats);
                let step = grid.max_spacing();
                // The cap triangles that can lie within `step` of a voxel of the
                // brick: `cap_within` over them is the caps' tree's answer (the same
                // distances, compared the same way), without a tree query per voxel.
                let near_caps = near_caps.get_or_insert_with(|| self.caps_near_brick(&centre, step));
                let mut far: Vec<(i64, BrickMask)> = Vec::new();
                let mut left = component;
                while let Some(o) = left.first() {
                    left.remove(o);
                    let known = integers[o];
                    match known {
                        Some(i) if !cap_within_among(near_caps, centre(o), step) => {
                            match far.iter_mut().find(|(j, _)| *j == i) {
                                Some((_, set)) => set.insert(o),
                                None => {
                                    let mut set = BrickMask::EMPTY;
                                    set.insert(o);
                                    far.push((i, set));
                                }
                            }
                        }
                        _ => {
                            if self.exact_side(centre(o), known.map(|i| i as f64), stats).0 {
                                inside.insert(o);
                            }
                        }
                    }
                }
                for (i, set) in far {
                    inside = inside.or(&self.prove_in_brick(brick, set, 0, 8, Some(i as f64), grid, stats));
                }
            } else {
                // Octants of the brick wholly in the component are free of sheets: prove
                // them box by box, down to single voxels.
                inside = inside.or(&self.prove_in_brick(brick, component, 0, 8, None, grid, stats));
            }
        }
        inside
    }

    /// The cap triangles whose boxes meet the box of the brick's voxel centres grown by
    /// `distance` (and a relative 1e-9): every cap triangle within `distance` of a voxel
    /// centre of the brick.
    fn caps_near_brick(&self, centre: &dyn Fn(usize) -> glam::DVec3, distance: f64) -> Vec<[glam::DVec3; 3]> {
        let mut near = Vec::new();
        if let Some(cap) = &self.sign.cap {
            let (a, b) = (centre(0), centre(BRICK_VOXELS - 1));
            let grow = distance * (1.0 + 1e-9) + 1e-9 * a.abs().max(b.abs()).max_element();
            let query = Aabb::new(a.min(b), a.max(b)).expanded(glam::DVec3::splat(grow));
            cap.for_each_triangle_near(&query, |_, t| near.push(t));
        }
        near
    }

    /// `I` at each voxel of `component` (voxels beyond the band of one brick, with
    /// caps): carried along 6-steps by proven cap crossings from a voxel whose `I` is
    /// carried from trusted triangle `reference` or, failing that, proven by a query;
    /// `None` where no proof went through.
    fn carry_integers(
        &self,
        component: BrickMask,
        reference: Option<usize>,
        centre: &dyn Fn(usize) -> glam::DVec3,
        stats: &mut SignStats,
    ) -> [Option<i64>; BRICK_VOXELS] {
        let mut integers = [None; BRICK_VOXELS];
        let mut unassigned = component;
        let mut failed = BrickMask::EMPTY;
        let mut scratch = Vec::new();
        {
            while let Some(seed) = unassigned.and_not(&failed).first() {
                let p = centre(seed);
                let known = reference
                    .and_then(|t| self.integer_from(t, p))
                    .or_else(|| self.integer_near(p))
                    .or_else(|| {
                        let (i, terms) = self.integer_at(p);
                        stats.query_terms += terms as u64;
                        stats.region_queries += 1;
                        i.map(|i| i as i64)
                    });
                let Some(i) = known else {
                    failed.insert(seed);
                    continue;
                };
                integers[seed] = Some(i);
                unassigned.remove(seed);
                // Breadth first from the seed, each voxel from its first assigned
                // neighbour (in a fixed order).
                let mut frontier = BrickMask::EMPTY;
                frontier.insert(seed);
                loop {
                    let mut next = BrickMask::EMPTY;
                    let mut candidates = frontier.dilate6().and(&unassigned);
                    while let Some(o) = candidates.first() {
                        candidates.remove(o);
                        for n in neighbours6(o) {
                            if !frontier.contains(n) {
                                continue;
                            }
                            let from = integers[n].expect("frontier voxels are assigned");
                            if let Some(c) = self.sign.cap_crossings(centre(n), centre(o), &mut scratch) {
                                integers[o] = Some(from + c);
                                next.insert(o);
                                break;
                            }
                        }
                    }
                    if next.is_empty() {
                        break;
                    }
                    unassigned = unassigned.and_not(&next);
                    frontier = next;
                }
            }
        }
        integers
    }

    /// The inside voxels of `allowed` (voxels beyond the band of one brick) within the
    /// cube of side `size` at brick-local corner `lo` (packed `x + 8y + 64z`). A cube
    /// wholly in `allowed` holds no sheet, so it takes the sign of its centre when the
    /// certified margin there exceeds the gradient bound times its radius; otherwise it
    /// splits, and single voxels ask the certified winding number.
    #[allow(clippy::too_many_arguments)]
    fn prove_in_brick(
        &self,
        brick: IVec3,
        allowed: BrickMask,
        lo: usize,
        size: usize,
        known: Option<f64>,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> BrickMask {
        let corner = IVec3::new((lo % 8) as i32, (lo / 8 % 8) as i32, (lo / 64) as i32);
        let cube = IndexBox::new(corner, corner + size as i32);
        let region = BrickMask::of_region(IVec3::ZERO, &cube);
        let here = region.and(&allowed);
        if here.is_empty() {
            return BrickMask::EMPTY;
        }
        let t = &grid.transform;
        let base = brick * BRICK_DIM;
        if size == 1 {
            let (inside, _) = self.exact_side(t.voxel_center(base + corner), known, stats);
            return if inside { here } else { BrickMask::EMPTY };
        }
        if here == region {
            let (a, b) = (
                t.voxel_center(base + corner),
                t.voxel_center(base + corner + size as i32 - 1),
            );
            let (p_lo, p_hi) = (a.min(b), a.max(b));
            let radius = 0.5 * (p_hi - p_lo).length();
            let drift = self.sign.boundary.gradient_bound(&Aabb::new(p_lo, p_hi)) * radius;
            let w = self.margin_query(0.5 * (p_lo + p_hi), known, drift);
            stats.query_terms += w.terms as u64;
            stats.region_queries += 1;
            if w.margin(0.5) > drift {
                return if w.value >= 0.5 { here } else { BrickMask::EMPTY };
            }
        }
        let half = size / 2;
        let mut inside = BrickMask::EMPTY;
        for k in 0..8 {
            let o = (k & 1) * half + ((k >> 1) & 1) * half * 8 + (k >> 2) * half * 64;
            inside = inside.or(&self.prove_in_brick(brick, allowed, lo + o, half, known, grid, stats));
        }
        inside
    }
}

/// Whether one of `triangles` lies within `distance` of `p`: the test of
/// [`Bvh::closest_within`](volga_mesh::Bvh::closest_within) (the nearest point's
/// distance, `sqrt` of its square, at most `distance`) over a list that holds every
/// triangle of the tree within `distance` of `p`. A triangle whose box is farther than
/// `distance` (grown by a relative 1e-9, far beyond the rounding of either distance) is
/// passed over without its nearest point: the box holds the triangle, so the nearest
/// point could not be within `distance` either.
fn cap_within_among(triangles: &[[glam::DVec3; 3]], p: glam::DVec3, distance: f64) -> bool {
    let reach = (distance * (1.0 + 1e-9)).powi(2);
    triangles.iter().any(|&t| {
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        let gap = (lo - p).max(p - hi).max(glam::DVec3::ZERO);
        if gap.length_squared() > reach {
            return false;
        }
        let (q, _) = volga_mesh::closest_point_on_triangle(p, t);
        (p - q).length_squared().sqrt() <= distance
    })
}

/// The six-neighbours of brick offset `o` (packed `x + 8y + 64z`) inside the brick.
fn neighbours6(o: usize) -> impl Iterator<Item = usize> {
    let (x, y, z) = (o % 8, o / 8 % 8, o / 64);
    [
        (x > 0).then(|| o - 1),
        (x < 7).then(|| o + 1),
        (y > 0).then(|| o - 8),
        (y < 7).then(|| o + 8),
        (z > 0).then(|| o - 64),
        (z < 7).then(|| o + 64),
    ]
    .into_iter()
    .flatten()
}

/// The voxels of `component` (beyond the band, so no 6-step into or inside it crosses a
/// sheet of the mesh) that `seeds` (band voxels of one side with proven margins
/// `margin[o] ≤ |w − ½|`) prove on their side: along a path of 6-steps from a seed of
/// margin `m` through voxels of the component, `w` changes by at most the sum of the
/// steps' drifts, so a voxel with `m − Σ drift > 0` is on the seed's side. A step runs
/// half in each voxel's cell, so its drift is the mean of the two cells' octant drifts
/// (`drifts[x/4 + 2(y/4) + 4(z/4)]`: the octant's gradient bound times the longest
/// spacing). The best seed and path per voxel, by relaxation from the seeds (only strict
/// gains of positive drifts spread, so it ends); proven where the best exceeds 1e-12,
/// far above the rounding of the subtractions.
fn proven_by_seeds(
    seeds: BrickMask,
    component: BrickMask,
    margin: &[f64; BRICK_VOXELS],
    drifts: &[f64; 8],
) -> BrickMask {
    const PROVEN: f64 = 1e-12;
    let octant = |o: usize| (o % 8 / 4) + 2 * (o / 8 % 8 / 4) + 4 * (o / 64 / 4);
    let step = |a: usize, b: usize| 0.5 * (drifts[octant(a)] + drifts[octant(b)]);
    let least = drifts.iter().copied().fold(f64::INFINITY, f64::min);
    if least.is_nan() || least <= 0.0 {
        return BrickMask::EMPTY; // no drift bound to count on (a closed mesh never asks)
    }
    let mut best = [f64::NEG_INFINITY; BRICK_VOXELS];
    let mut frontier = BrickMask::EMPTY;
    let mut left = seeds.and(&component.dilate6());
    while let Some(o) = left.first() {
        left.remove(o);
        if margin[o] - least > PROVEN {
            best[o] = margin[o];
            frontier.insert(o);
        }
    }
    let mut proven = BrickMask::EMPTY;
    while !frontier.is_empty() {
        let mut next = BrickMask::EMPTY;
        let mut reached = frontier.dilate6().and(&component);
        while let Some(o) = reached.first() {
            reached.remove(o);
            let from = neighbours6(o)
                .filter(|&n| frontier.contains(n))
                .map(|n| best[n] - step(n, o))
                .fold(f64::NEG_INFINITY, f64::max);
            if from > best[o] && from > PROVEN {
                best[o] = from;
                proven.insert(o);
                if from - least > PROVEN {
                    next.insert(o);
                }
            }
        }
        frontier = next;
    }
    proven
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, IVec3, UVec3};
    use volga_core::{Grid, Transform, BRICK_DIM, BRICK_VOXELS};

    use super::{cap_within_among, neighbours6, proven_by_seeds};
    use crate::mask::BrickMask;
    use crate::mesh::MeshVoxelizer;
    use proptest::prelude::*;

    /// Every voxel's best `m − Σ drift` over all paths from a seed through the component,
    /// by plain Bellman–Ford over the whole brick (every voxel relaxed every round).
    fn best_by_brute_force(seeds: &[usize], component: &BrickMask, margin: &[f64], drifts: &[f64; 8]) -> Vec<f64> {
        let octant = |o: usize| (o % 8 / 4) + 2 * (o / 8 % 8 / 4) + 4 * (o / 64 / 4);
        let mut best = vec![f64::NEG_INFINITY; BRICK_VOXELS];
        for &s in seeds {
            best[s] = margin[s];
        }
        loop {
            let mut changed = false;
            for o in 0..BRICK_VOXELS {
                if !component.contains(o) {
                    continue;
                }
                for n in neighbours6(o) {
                    let v = best[n] - 0.5 * (drifts[octant(n)] + drifts[octant(o)]);
                    if v > best[o] {
                        best[o] = v;
                        changed = true;
                    }
                }
            }
            if !changed {
                return best;
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// The relaxation from the seeds proves exactly the voxels whose best path
        /// keeps a positive margin (beyond 1e-12), and only voxels of the component.
        #[test]
        fn seeds_prove_what_their_best_paths_keep(
            bits in prop::collection::vec(any::<u64>(), 8),
            seed_bits in prop::collection::vec(any::<u64>(), 8),
            margins in prop::collection::vec(0.0f64..0.5, BRICK_VOXELS),
            drifts in prop::collection::vec(0.005f64..0.2, 8),
        ) {
            let mut component = BrickMask::EMPTY;
            let mut seeds = BrickMask::EMPTY;
            let mut seed_list = Vec::new();
            for o in 0..BRICK_VOXELS {
                let (c, s) = (bits[o / 64] >> (o % 64) & 1 == 1, seed_bits[o / 64] >> (o % 64) & 3 == 3);
                if s {
                    seeds.insert(o);
                    seed_list.push(o);
                } else if c {
                    component.insert(o);
                }
            }
            let drifts: [f64; 8] = std::array::from_fn(|k| drifts[k]);
            let proven = proven_by_seeds(seeds, component, &margins[..].try_into().unwrap(), &drifts);
            let best = best_by_brute_force(&seed_list, &component, &margins, &drifts);
            for (o, &b) in best.iter().enumerate() {
                let expected = component.contains(o) && b > 1e-12;
                prop_assert_eq!(proven.contains(o), expected, "voxel {} best {}", o, b);
            }
        }
    }

    /// The brick's gathered list answers `cap_within` as the caps' tree does, for every
    /// voxel of every brick around the open corpus meshes, at two grids and two steps.
    #[test]
    fn gathered_caps_answer_as_the_cap_tree() {
        let (mut checked, mut within) = (0, 0);
        for (name, mesh) in volga_mesh::unclean::corpus() {
            let voxelizer = MeshVoxelizer::new(&mesh);
            if voxelizer.sign.cap.is_none() {
                continue;
            }
            let bounds = mesh.bounds();
            for spacing in [0.04, 0.11] {
                let origin = bounds.min - DVec3::splat(0.3);
                let dims = ((bounds.size() + 0.6) / spacing).ceil().as_uvec3() + UVec3::ONE;
                let grid = Grid::new(Transform::new(origin, DVec3::splat(spacing)).unwrap(), dims).unwrap();
                let bricks = (dims.as_ivec3() + BRICK_DIM - 1) / BRICK_DIM;
                for brick in volga_core::IndexBox::new(IVec3::ZERO, bricks).iter() {
                    let centre = |o: usize| {
                        let ijk = brick * BRICK_DIM + IVec3::new(o as i32 % 8, o as i32 / 8 % 8, o as i32 / 64);
                        grid.transform.voxel_center(ijk)
                    };
                    for step in [spacing, 3.0 * spacing] {
                        let near = voxelizer.caps_near_brick(&centre, step);
                        for o in 0..BRICK_VOXELS {
                            let tree = voxelizer.sign.cap_within(centre(o), step);
                            assert_eq!(
                                cap_within_among(&near, centre(o), step),
                                tree,
                                "{name}: {brick} {o} {step}"
                            );
                            checked += 1;
                            within += tree as usize;
                        }
                    }
                }
            }
        }
        eprintln!("{within} of {checked} voxels have a cap within the step");
        assert!(within > 1000 && checked > 2 * within, "{within} of {checked}");
    }
}
