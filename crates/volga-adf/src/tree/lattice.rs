//! Sampling the source on a cell's 3×3×3 lattice (its 8 corners and 19 test points)
//! during a build: lattice indices, the per-subtree sample cache, and the children's
//! corners taken from their parent's lattice.

use std::sync::atomic::Ordering;

use glam::DVec3;

use super::build::Builder;
use super::corner_position;
use crate::source::{AdfSource, CellCandidates, Sample};
use crate::AdfError;

/// Samples already taken in one sequentially built subtree, by lattice point (integer
/// coordinates in half-finest-cell units from the root's minimum): a point shared by
/// sibling or cousin cells is evaluated once. Values are functions of the point alone, so
/// the cache changes the work, never the tree.
pub(crate) struct SampleCache {
    ///
    /// A test point is on the lattice of cells of its own depth only (at an odd multiple
    /// of their half size in one or two coordinates: every deeper cell has it as a corner,
    /// from its parent's lattice, and no shallower cell's lattice holds it), so it is
    /// looked up only by the other cells of that depth around it: one across a face
    /// centre, three around an edge midpoint. Each entry counts the lookups left and is
    /// dropped at the last; the entries whose other cells never take a lattice (they
    /// are pruned, or leaves of a shallower depth) are dropped when the subtree holding
    /// all of them is done ([`SampleCache::finish`]). So the map holds the build's
    /// frontier, not every sample, and stays small enough to be quick.
    pub(super) samples: rustc_hash::FxHashMap<LatticeKey, (Sample, u8)>,
    /// Sides proven at the test points of cells no surface meets
    /// ([`AdfSource::inside_in_empty_cell`]; `true`: inside), with the lookups left, kept
    /// and dropped like `samples`: neighbouring empty cells near a jump share them.
    sides: rustc_hash::FxHashMap<LatticeKey, (bool, u8)>,
    /// Sign-field values at jump leaves' corners ([`AdfSource::sign_field_at`]).
    pub(super) sign_fields: rustc_hash::FxHashMap<LatticeKey, Option<f64>>,
    /// Depth of the subtree's root: a point whose cells' common ancestor is shallower is
    /// shared with cells of other subtrees only, which have caches of their own.
    root_depth: u8,
    /// The build's maximum depth (the lattice's unit is half its cells).
    max_depth: u8,
    /// By depth `a`: the keys stored whose cells' common ancestor is the cell of depth `a`
    /// being built (one at a time, depth first).
    by_ancestor: Vec<Vec<LatticeKey>>,
}

/// A lattice point's integer coordinates ([`Builder::lattice_key`]) as two words, `x` and
/// `y` in one (the cache's maps are on the build's hot path).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct LatticeKey {
    xy: u64,
    z: u32,
}

impl LatticeKey {
    #[inline]
    pub(crate) fn new([x, y, z]: [u32; 3]) -> Self {
        LatticeKey {
            xy: u64::from(x) | (u64::from(y) << 32),
            z,
        }
    }

    #[inline]
    pub(crate) fn coordinates(self) -> [u32; 3] {
        [self.xy as u32, (self.xy >> 32) as u32, self.z]
    }

    /// The key `(i, j, k)` lattice units further along the axes (no coordinate passes
    /// `u32::MAX`: they are at most `2^(max_depth + 1)`).
    #[inline]
    pub(crate) fn offset(self, [i, j, k]: [u32; 3]) -> Self {
        LatticeKey {
            xy: self.xy + u64::from(i) + (u64::from(j) << 32),
            z: self.z + k,
        }
    }
}

impl SampleCache {
    /// An empty cache for the subtree rooted at depth `root_depth` of a build to
    /// `max_depth`.
    pub(crate) fn new(root_depth: u8, max_depth: u8) -> Self {
        SampleCache {
            samples: Default::default(),
            sides: Default::default(),
            sign_fields: Default::default(),
            root_depth,
            max_depth,
            by_ancestor: vec![Vec::new(); max_depth as usize + 1],
        }
    }

    /// The depth of the smallest cell of this subtree that holds every cell of this subtree
    /// having test point `key` on its boundary; `boundary` marks the axes across which
    /// the point lies on those cells' faces. `None` when no other cell of this subtree has
    /// it (the others lie in other subtrees, or outside the root).
    ///
    /// A lattice coordinate with `z` trailing zero bits lies on a mid-plane of the cells of
    /// depth `max_depth − z` (the lattice's unit is half the finest cell), which divides
    /// them and nothing shallower; the coordinates 0 and `2^(max_depth + 1)` are the root's
    /// faces. Across an axis whose plane divides a cell shallower than this subtree's
    /// root, the cells on the other side lie in other subtrees; across the others, the
    /// cells around the point lie in the smallest cell that the shallowest of those
    /// planes divides.
    fn ancestor_depth(&self, key: LatticeKey, boundary: [bool; 3]) -> Option<u8> {
        let mut depth = None;
        for (k, on) in key.coordinates().into_iter().zip(boundary) {
            if !on {
                continue;
            }
            let zeros = k.trailing_zeros();
            if zeros > u32::from(self.max_depth) {
                continue; // a face of the root
            }
            let a = self.max_depth - zeros as u8;
            if a >= self.root_depth {
                depth = Some(depth.map_or(a, |d: u8| d.min(a)));
            }
        }
        depth
    }

    /// Keeps sample `s` at test point `key` for the `left` other cells around it, unless
    /// none of them is in this subtree.
    fn keep(&mut self, key: LatticeKey, boundary: [bool; 3], s: Sample, left: u8) {
        if let Some(a) = self.ancestor_depth(key, boundary) {
            self.samples.insert(key, (s, left));
            self.by_ancestor[a as usize].push(key);
        }
    }

    /// The side at test point `key` of a cell no surface meets, if a neighbour of the
    /// same depth proved it (one of the lookups its entry waits for) or sampled the point.
    /// A sample's entry is only read: the cell may still take its lattice (when a side
    /// disagrees) and look the sample up then.
    pub(crate) fn side(&mut self, key: LatticeKey) -> Option<bool> {
        if let Some((inside, left)) = self.sides.get_mut(&key) {
            let inside = *inside;
            *left -= 1;
            if *left == 0 {
                self.sides.remove(&key);
            }
            return Some(inside);
        }
        self.samples.get(&key).map(|(s, _)| s.value < 0.0)
    }

    /// Keeps the side proven at test point `key` (lattice position `ijk` in its cell) for
    /// the other cells around it, as [`SampleCache::keep`] does samples.
    pub(crate) fn keep_side(&mut self, key: LatticeKey, [i, j, k]: [usize; 3], inside: bool) {
        let boundary = [i != 1, j != 1, k != 1];
        let left = match boundary.iter().filter(|&&b| b).count() {
            1 => 1,
            2 => 3,
            _ => return, // the centre, which no other cell has
        };
        if let Some(a) = self.ancestor_depth(key, boundary) {
            self.sides.insert(key, (inside, left));
            self.by_ancestor[a as usize].push(key);
        }
    }

    /// The cell of depth `depth` being built is done: every cell around the test points
    /// kept for it has been built, so they are dropped.
    pub(crate) fn finish(&mut self, depth: u8) {
        if let Some(keys) = self.by_ancestor.get_mut(depth as usize) {
            for key in keys.drain(..) {
                if self.samples.remove(&key).is_none() {
                    self.sides.remove(&key);
                }
            }
        }
    }
}

/// The 27 points of a cell's 3×3×3 lattice, index `i + 3j + 9k`, in half-cell units.
#[inline]
pub(super) fn lattice_index(i: usize, j: usize, k: usize) -> usize {
    i + 3 * j + 9 * k
}

/// By lattice index: the cell's 8 corners from the nearest to the farthest, in corner
/// order among equally near ones (distances in half-cell units, exact).
const CORNERS_BY_DISTANCE: [[u8; 8]; 27] = {
    let mut table = [[0u8; 8]; 27];
    let mut l: usize = 0;
    while l < 27 {
        let ijk = [l % 3, (l / 3) % 3, l / 9];
        let mut distance = [0usize; 8];
        let mut b = 0;
        while b < 8 {
            let mut axis = 0;
            while axis < 3 {
                let d = ijk[axis].abs_diff(((b >> axis) & 1) * 2);
                distance[b] += d * d;
                axis += 1;
            }
            b += 1;
        }
        // Insertion by (distance, corner): a stable order.
        let mut n = 0;
        let mut d = 0;
        while d <= 12 {
            let mut b = 0;
            while b < 8 {
                if distance[b] == d {
                    table[l][n] = b as u8;
                    n += 1;
                }
                b += 1;
            }
            d += 1;
        }
        l += 1;
    }
    table
};

#[inline]
fn corner_lattice(b: usize) -> usize {
    lattice_index((b & 1) * 2, ((b >> 1) & 1) * 2, ((b >> 2) & 1) * 2)
}

impl<S: AdfSource + ?Sized> Builder<'_, S> {
    pub fn eval(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Result<Sample, AdfError> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let s = self.source.sample(p, near);
        if s.value.is_finite() {
            Ok(s)
        } else {
            Err(AdfError::NonFinite(p.to_array()))
        }
    }

    pub(super) fn eval_among(
        &self,
        p: DVec3,
        near: Option<(DVec3, &Sample)>,
        candidates: &CellCandidates,
    ) -> Result<Sample, AdfError> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let s = self.source.sample_among(p, near, candidates);
        if s.value.is_finite() {
            Ok(s)
        } else {
            Err(AdfError::NonFinite(p.to_array()))
        }
    }

    /// The 27 samples of a cell's 3×3×3 lattice: its corners and its 19 test points (each
    /// given the nearest corner that knows its region), from `cache` when a neighbour
    /// took them already, among the cell's `candidates` when the source narrows.
    pub(super) fn lattice(
        &self,
        min: DVec3,
        size: f64,
        samples: &[Sample; 8],
        candidates: Option<&CellCandidates>,
        mut cache: Option<&mut SampleCache>,
    ) -> Result<[Sample; 27], AdfError> {
        let mut lattice = [None; 27];
        for b in 0..8 {
            lattice[corner_lattice(b)] = Some(samples[b]);
        }
        let half = size * 0.5;
        let keys = self.cell_keys(min, size);
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    let l = lattice_index(i, j, k);
                    if lattice[l].is_some() {
                        continue;
                    }
                    let p = min + DVec3::new(i as f64, j as f64, k as f64) * half;
                    // The centre is strictly inside the cell and at an odd multiple of
                    // its children's half size: no other cell's lattice holds it (its
                    // descendants get it as a corner from this lattice), so it is neither
                    // looked up nor kept.
                    let centre = l == lattice_index(1, 1, 1);
                    let mut cache_here = if centre { None } else { cache.as_deref_mut() };
                    let key = keys(i, j, k);
                    debug_assert_eq!(key, self.lattice_key(p));
                    if let Some(c) = cache_here.as_deref_mut() {
                        if let std::collections::hash_map::Entry::Occupied(mut e) = c.samples.entry(key) {
                            let (s, left) = e.get_mut();
                            lattice[l] = Some(*s);
                            *left -= 1;
                            if *left == 0 {
                                e.remove();
                            }
                            continue;
                        }
                    }
                    // The nearest corner that knows its region (the shortest carry; the
                    // first in corner order among equally near ones).
                    let near = CORNERS_BY_DISTANCE[l]
                        .iter()
                        .map(|&b| b as usize)
                        .find(|&b| samples[b].region.is_some())
                        .map(|b| (corner_position(min, size, b), &samples[b]));
                    let s = match candidates {
                        Some(c) => self.eval_among(p, near, c)?,
                        None => self.eval(p, near)?,
                    };
                    if let Some(c) = cache_here {
                        // Other cells of this depth sharing the point: 1 across a face
                        // centre (one coordinate on the cell's boundary), 3 around an
                        // edge midpoint (two).
                        let boundary = [i != 1, j != 1, k != 1];
                        let on_boundary = boundary.iter().filter(|&&b| b).count();
                        c.keep(key, boundary, s, if on_boundary == 1 { 1 } else { 3 });
                    }
                    lattice[l] = Some(s);
                }
            }
        }
        Ok(lattice.map(|s| s.expect("every lattice point is sampled")))
    }

    /// Integer lattice coordinates of a lattice point (exact: points and origin are on
    /// the lattice of the finest cells).
    #[inline]
    pub(super) fn lattice_key(&self, p: DVec3) -> LatticeKey {
        let k = ((p - self.lattice_origin) / self.lattice_unit).round();
        LatticeKey::new([k.x as u32, k.y as u32, k.z as u32])
    }

    /// The keys of a cell's 3×3×3 lattice by position `(i, j, k)` (in half cells): its
    /// minimum's key plus integer steps, a half cell being a power of two of units (no
    /// division or rounding per point).
    #[inline]
    pub(super) fn cell_keys(&self, min: DVec3, size: f64) -> impl Fn(usize, usize, usize) -> LatticeKey {
        let base = self.lattice_key(min);
        let step = (size * 0.5 / self.lattice_unit).round() as u32;
        move |i, j, k| base.offset([i as u32 * step, j as u32 * step, k as u32 * step])
    }
}

/// The corner values and minimum of child octant `o` (bits x, y, z) from the parent's
/// 3×3×3 lattice.
#[inline]
pub(crate) fn child_of<T: Copy>(min: DVec3, half: f64, o: usize, lattice: &[T; 27]) -> (DVec3, [T; 8]) {
    let (ox, oy, oz) = (o & 1, (o >> 1) & 1, (o >> 2) & 1);
    let child_min = min + DVec3::new(ox as f64, oy as f64, oz as f64) * half;
    let values =
        std::array::from_fn(|b| lattice[lattice_index(ox + (b & 1), oy + ((b >> 1) & 1), oz + ((b >> 2) & 1))]);
    (child_min, values)
}

#[cfg(test)]
mod tests {
    use super::SampleCache;

    /// The smallest common ancestor's depth of the cells of depth `depth` (integer indices)
    /// that lie inside the subtree root `root` (its index at `root_depth`), by brute
    /// force; `None` unless there are two.
    fn brute_ancestor(cells: &[[u32; 3]], depth: u8, root: [u32; 3], root_depth: u8) -> Option<u8> {
        let inside: Vec<[u32; 3]> = cells
            .iter()
            .copied()
            .filter(|c| c.map(|x| x >> (depth - root_depth)) == root)
            .collect();
        if inside.len() < 2 {
            return None;
        }
        (root_depth..depth).rev().find(|&e| {
            inside
                .iter()
                .all(|c| c.map(|x| x >> (depth - e)) == inside[0].map(|x| x >> (depth - e)))
        })
    }

    /// The corner order by distance is the one a search by world distance finds (the first
    /// of equally near corners), at every lattice point of a cell far from the origin.
    #[test]
    fn corners_by_distance_are_the_nearest_first() {
        use glam::DVec3;
        let (min, size) = (DVec3::new(1e6, -3.5e5, 2.0), 0.125);
        for l in 0..27 {
            let p = min + DVec3::new((l % 3) as f64, ((l / 3) % 3) as f64, (l / 9) as f64) * size * 0.5;
            let mut order: Vec<usize> = (0..8).collect();
            order.sort_by(|&a, &b| {
                let da = (p - super::corner_position(min, size, a)).length_squared();
                let db = (p - super::corner_position(min, size, b)).length_squared();
                da.total_cmp(&db).then(a.cmp(&b))
            });
            let table: Vec<usize> = super::CORNERS_BY_DISTANCE[l].iter().map(|&b| b as usize).collect();
            assert_eq!(table, order, "lattice point {l}");
        }
    }

    /// A side kept at a face centre serves the one other cell across the face and is then
    /// gone; at an edge midpoint it serves three; the centre is not kept; a sampled point
    /// answers with its sample's sign and keeps its entry; and a cell's end drops what is
    /// left.
    #[test]
    fn sides_are_shared_with_the_cells_around_their_point_and_then_dropped() {
        use super::LatticeKey;
        use crate::source::Sample;
        // Root depth 1, maximum depth 3: lattice unit 1, cells of depth 2 have side 4.
        let mut cache = SampleCache::new(1, 3);
        // A face centre at x = 4 (the mid-plane of a depth-1 cell, 2 trailing zeros).
        let face = LatticeKey::new([4, 2, 2]);
        cache.keep_side(face, [2, 1, 1], true);
        assert_eq!(cache.side(face), Some(true));
        assert_eq!(cache.side(face), None, "one lookup across a face");
        // An edge midpoint on the planes x = 4 and y = 4.
        let edge = LatticeKey::new([4, 4, 2]);
        cache.keep_side(edge, [2, 2, 1], false);
        for _ in 0..3 {
            assert_eq!(cache.side(edge), Some(false));
        }
        assert_eq!(cache.side(edge), None, "three lookups around an edge");
        // The centre of a cell is no other cell's test point.
        let centre = LatticeKey::new([2, 2, 2]);
        cache.keep_side(centre, [1, 1, 1], true);
        assert_eq!(cache.side(centre), None);
        // A sampled point answers with its sample's sign.
        let sampled = LatticeKey::new([4, 6, 2]);
        let s = Sample {
            value: -0.25,
            region: Some(1),
        };
        cache.keep(sampled, [true, false, false], s, 1);
        assert_eq!(cache.side(sampled), Some(true));
        assert_eq!(cache.side(sampled), Some(true), "a sample is only read");
        // Entries nobody looked up are dropped when their depth-1 cell is done.
        cache.keep_side(face, [2, 1, 1], false);
        cache.finish(1);
        assert_eq!(cache.side(face), None);
        assert!(cache.sides.is_empty() && cache.samples.is_empty());
    }

    /// Every test point of every cell of a small build, in every subtree: the depth at
    /// which the cache drops it is that of the smallest cell holding the other cells of
    /// its subtree around it, and it is not kept when there are none (brute force over
    /// the cells around the point).
    #[test]
    fn test_points_are_dropped_exactly_when_their_subtree_cells_are_done() {
        let max_depth = 5u8;
        let mut checked = 0;
        for root_depth in 0..=3u8 {
            let cache = SampleCache::new(root_depth, max_depth);
            for depth in root_depth..=max_depth {
                let unit = 1u32 << (max_depth + 1 - depth); // a depth-`depth` cell, in lattice units
                let n = 1u32 << depth;
                // Cells of a few subtrees (all of them for shallow roots).
                for cell in (0..n * n * n).step_by(7) {
                    let c = [cell % n, (cell / n) % n, cell / (n * n)];
                    let root = c.map(|x| x >> (depth - root_depth));
                    for l in 0..27u32 {
                        let ijk = [l % 3, (l / 3) % 3, l / 9];
                        let boundary = ijk.map(|x| x != 1);
                        let on = boundary.iter().filter(|&&b| b).count();
                        if on == 0 || on == 3 {
                            continue; // the centre and the corners are not cached
                        }
                        let key = [0, 1, 2].map(|a| c[a] * unit + ijk[a] * unit / 2);
                        // The cells of this depth around the point.
                        let mut cells = vec![[0u32; 3]];
                        for a in 0..3 {
                            let options: Vec<u32> = if boundary[a] {
                                let b = key[a] / unit;
                                [b.wrapping_sub(1), b].into_iter().filter(|&x| x < n).collect()
                            } else {
                                vec![key[a] / unit]
                            };
                            cells = cells
                                .iter()
                                .flat_map(|cell| {
                                    options.iter().map(move |&x| {
                                        let mut next = *cell;
                                        next[a] = x;
                                        next
                                    })
                                })
                                .collect();
                        }
                        assert!(cells.contains(&c));
                        assert_eq!(
                            cache.ancestor_depth(super::LatticeKey::new(key), boundary),
                            brute_ancestor(&cells, depth, root, root_depth),
                            "root depth {root_depth}, depth {depth}, cell {c:?}, lattice point {ijk:?}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }
}
