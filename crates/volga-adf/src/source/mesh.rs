//! The triangle-mesh source: exact distances to the nearest triangle and signs proven by
//! the capped winding number, with the build's shortcuts (candidate lists, sorted scans,
//! whole-cell sign proofs).

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use volga_core::Aabb;
use volga_mesh::{Bvh, CappedWinding, FaceFrame, TriMesh};
use volga_shapes::DistanceSource;

use super::{AdfSource, CellCandidates, Sample, SurfaceMeasures};

/// A triangle mesh: exact unsigned distance to the nearest triangle (`Bvh::closest`) with
/// the sign of the generalized winding number, **proven** per point: inside means
/// `w(p) ≥ ½`, decided by `volga_mesh::CappedWinding` (the integer winding number of the
/// mesh closed by cones over its boundary cycle, minus the cones' own, each certified).
/// Open, self-intersecting and overlapping meshes (the Stanford bunny with its holes)
/// therefore get the same inside as the voxelizer's.
///
/// Counts its queries (`queries`, `winding_terms`) for reports.
#[derive(Debug)]
pub struct MeshSource {
    bvh: Bvh,
    /// Mesh triangle ids in the BVH's tree order: the order of the three arrays below,
    /// whose runs of [`CLUSTER`] are the clusters candidate lists hold.
    order: Vec<u32>,
    /// Triangle corners in tree order, for the exact distances of a cell's candidate scans.
    triangles: Vec<[DVec3; 3]>,
    /// Each triangle's face test in tree order, prepared once for the scans (`None`:
    /// degenerate).
    frames: Vec<Option<FaceFrame>>,
    /// Each cluster's triangles' boxes and planes, coordinate by coordinate: what a scan's
    /// lower bounds read ([`MeshSource::sample_among`]).
    blocks: Vec<ScanBlock>,
    /// Each cluster's box (the union of its triangles' boxes): what a candidate list
    /// holds, sorts by and narrows ([`MeshSource::candidates`]).
    clusters: Vec<ClusterBox>,
    /// Absolute slack (world units) subtracted from the plane and edge lower bounds: covers the
    /// rounding of the bound and of `closest_point_on_triangle` with a wide margin.
    plane_slack: f64,
    /// Cells whose side is at most this list single triangles ([`SPLIT_BELOW`] times the
    /// median cluster's largest extent).
    split_below: f64,
    winding: CappedWinding,
    bounds: Aabb,
    measures: SurfaceMeasures,
    queries: AtomicU64,
    winding_terms: AtomicU64,
    integer_queries: AtomicU64,
}

impl MeshSource {
    /// Builds the BVH. Errors if the mesh has no triangles.
    pub fn new(mesh: &TriMesh) -> Result<Self, crate::AdfError> {
        if mesh.triangle_count() == 0 {
            return Err(crate::AdfError::EmptySource("the mesh has no triangles".into()));
        }
        if mesh.triangle_count() >= SINGLE as usize {
            return Err(crate::AdfError::TooManyTriangles(mesh.triangle_count()));
        }
        let bounds = mesh.bounds();
        if !(bounds.min.is_finite() && bounds.max.is_finite()) {
            return Err(crate::AdfError::EmptySource("the mesh has non-finite vertices".into()));
        }
        let bvh = Bvh::build(mesh);
        let order = bvh.tree_order().to_vec();
        let triangles: Vec<[DVec3; 3]> = order.iter().map(|&i| mesh.triangle(i as usize)).collect();
        let mut blocks = Vec::with_capacity(triangles.len().div_ceil(CLUSTER));
        let mut clusters = Vec::with_capacity(blocks.capacity());
        for run in triangles.chunks(CLUSTER) {
            let mut block = ScanBlock::EMPTY;
            let mut cluster = ClusterBox {
                lo: DVec3::INFINITY,
                hi: DVec3::NEG_INFINITY,
            };
            for (k, &t @ [a, b, c]) in run.iter().enumerate() {
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                let normal = scan_normal(t);
                for axis in 0..3 {
                    block.lo[axis][k] = lo[axis];
                    block.hi[axis][k] = hi[axis];
                    block.normal[axis][k] = normal[axis];
                }
                block.offset[k] = normal.dot(a);
                for (e, [from, to, other]) in [[a, b, c], [b, c, a], [c, a, b]].into_iter().enumerate() {
                    let outward = edge_normal(from, to, other, normal);
                    for axis in 0..3 {
                        block.edge_normal[e][axis][k] = outward[axis];
                    }
                    block.edge_offset[e][k] = outward.dot(from);
                }
                cluster.lo = cluster.lo.min(lo);
                cluster.hi = cluster.hi.max(hi);
            }
            blocks.push(block);
            clusters.push(cluster);
        }
        let mut extents: Vec<f64> = clusters
            .iter()
            .map(|c: &ClusterBox| (c.hi - c.lo).max_element())
            .collect();
        extents.sort_unstable_by(f64::total_cmp);
        let split_below = SPLIT_BELOW * extents[extents.len() / 2];
        let frames = triangles.iter().map(|&t| FaceFrame::new(t)).collect();
        let extent = bounds.min.abs().max(bounds.max.abs()).max_element();
        let plane_slack = 1e-9 * bounds.size().length() + 1e-12 * extent;
        Ok(MeshSource {
            bvh,
            order,
            triangles,
            frames,
            blocks,
            clusters,
            plane_slack,
            split_below,
            winding: CappedWinding::new(mesh),
            bounds,
            measures: SurfaceMeasures::of_mesh(mesh),
            queries: AtomicU64::new(0),
            winding_terms: AtomicU64::new(0),
            integer_queries: AtomicU64::new(0),
        })
    }

    /// The mesh's BVH (exact nearest points, winding numbers).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Distance queries answered so far.
    pub fn queries(&self) -> u64 {
        self.queries.load(Ordering::Relaxed)
    }

    /// Queries that computed the integer winding number `I` themselves (the others took it
    /// from a neighbour's sheet-free ball).
    pub fn integer_queries(&self) -> u64 {
        self.integer_queries.load(Ordering::Relaxed)
    }

    /// Winding-number terms summed so far (the cost of proving signs).
    pub fn winding_terms(&self) -> u64 {
        self.winding_terms.load(Ordering::Relaxed)
    }

    /// The proven side of `p`: `w(p) ≥ ½`.
    pub fn inside(&self, p: DVec3) -> bool {
        let (inside, cost) = self.winding.inside(p);
        self.winding_terms.fetch_add(cost.terms, Ordering::Relaxed);
        inside
    }
}

/// Triangles per cluster: candidate lists hold runs of this many triangles of the BVH's
/// tree order (spatially compact), so lists are this many times shorter to narrow and
/// sort, and a scan reads each cluster's triangles side by side.
const CLUSTER: usize = 8;
/// The flag of a list entry that is one triangle (its position in tree order below the
/// flag), not a cluster: cells no larger than a typical cluster list triangles apart.
const SINGLE: u32 = 1 << 31;
/// Cells up to this many times the median cluster's largest extent list triangles apart.
const SPLIT_BELOW: f64 = 0.5;

/// The neighbour's distance bounds this one (1-Lipschitz): a tighter search.
#[inline]
fn near_bound(p: DVec3, near: Option<(DVec3, &Sample)>) -> f64 {
    near.map_or(f64::INFINITY, |(q, s)| {
        (s.value.abs() + (p - q).length()) * (1.0 + 1e-9)
    })
}

impl MeshSource {
    /// The sample from its unsigned distance: the sign from the winding number
    /// `w = I − w_C` (`volga_mesh::CappedWinding`), the integer `I` carried over from
    /// `near` by counting the sheets crossed in between (among `candidates` when given:
    /// they hold every mesh and cap triangle meeting the segment) or computed when that count is
    /// not certain; `w_C` (the caps alone) is always computed, certified against `I − ½`.
    fn signed(
        &self,
        p: DVec3,
        unsigned: f64,
        near: Option<(DVec3, &Sample)>,
        candidates: Option<&CellCandidates>,
    ) -> Sample {
        if unsigned == 0.0 {
            return Sample {
                value: 0.0,
                region: None,
            };
        }
        let known = near.and_then(|(q, s)| {
            s.region.and_then(|i| match candidates {
                Some(c) => self.winding.integer_along_listed(
                    q,
                    i,
                    p,
                    self.triangles_meeting(c.meeting_cell(), q.min(p), q.max(p)),
                    c.sheets.iter().copied(),
                ),
                None => self.winding.integer_along(q, i, p),
            })
        });
        if known.is_none() {
            self.integer_queries.fetch_add(1, Ordering::Relaxed);
        }
        // Inside ⇔ w_C ≤ I − ½: decided by the cell's bounds on w_C when they clear it.
        let threshold = known.map(|i| i as f64 - 0.5);
        let by_bounds = match (candidates.and_then(|c| c.sign_bounds), threshold) {
            (Some((_, hi)), Some(t)) if hi < t => Some(true),
            (Some((lo, _)), Some(t)) if lo > t => Some(false),
            _ => None,
        };
        // Else by the cell's model of `w` (no triangle meets the cell).
        // (When `I` is known: a sample's region is then kept for its neighbours.)
        let by_bounds = by_bounds.or_else(|| {
            known?;
            candidates?.sign_model.as_ref()?.side_at(p)
        });
        let (inside, integer) = match by_bounds {
            Some(inside) => (inside, known),
            None => {
                let (inside, integer, cost) = self.winding.inside_with(p, known);
                self.winding_terms.fetch_add(cost.terms, Ordering::Relaxed);
                (inside, integer)
            }
        };
        Sample {
            value: if inside { -unsigned } else { unsigned },
            region: integer,
        }
    }
}

/// The largest `f32` not above `x` (for `x ≥ 0`, finite or not).
#[inline]
fn f32_at_most(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x {
        // y > x ≥ 0: the next positive f32 below (f32::MAX below +∞).
        f32::from_bits(y.to_bits() - 1)
    } else {
        y
    }
}

/// The boxes and planes of a cluster's triangles, coordinate by coordinate (slot `k`:
/// the cluster's `k`-th triangle), so a scan computes the lower bounds of all of them
/// in one pass (`MeshSource::lower_bounds_squared`).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct ScanBlock {
    lo: [[f64; CLUSTER]; 3],
    hi: [[f64; CLUSTER]; 3],
    /// [`scan_normal`]: unit, or zero for a triangle too thin for a plane bound.
    normal: [[f64; CLUSTER]; 3],
    /// `normal · a` for the triangle's first corner `a`: the plane is `normal · x = offset`.
    offset: [f64; CLUSTER],
    /// Per edge `(a, b)`, `(b, c)`, `(c, a)`: [`edge_normal`], the unit normal of the edge
    /// in the triangle's plane pointing away from the triangle (zero without a plane).
    edge_normal: [[[f64; CLUSTER]; 3]; 3],
    /// `edge_normal · from` for the edge's first corner.
    edge_offset: [[f64; CLUSTER]; 3],
}

impl ScanBlock {
    /// Slots past a short cluster's last triangle are bounded with the others but their
    /// bounds are never used (the scan stops at the cluster's length).
    const EMPTY: ScanBlock = ScanBlock {
        lo: [[0.0; CLUSTER]; 3],
        hi: [[0.0; CLUSTER]; 3],
        normal: [[0.0; CLUSTER]; 3],
        offset: [0.0; CLUSTER],
        edge_normal: [[[0.0; CLUSTER]; 3]; 3],
        edge_offset: [[0.0; CLUSTER]; 3],
    };
}

/// A cluster's box: the union of its triangles' boxes.
#[derive(Clone, Copy, Debug)]
struct ClusterBox {
    lo: DVec3,
    hi: DVec3,
}

/// The unit normal of a triangle whose double area is at least 1e-3 of its longest edge
/// squared, else zero (no plane bound: the nearest point of a thin triangle may lie off
/// the plane computed from its corners by more than rounding).
fn scan_normal([a, b, c]: [DVec3; 3]) -> DVec3 {
    let n = (b - a).cross(c - a);
    let longest = (b - a)
        .length_squared()
        .max((c - b).length_squared())
        .max((a - c).length_squared());
    let area2 = n.length();
    if area2.is_finite() && area2 >= 1e-3 * longest && area2 > 0.0 {
        n / area2
    } else {
        DVec3::ZERO
    }
}

/// The unit vector in the plane of unit normal `normal` (zero: none) perpendicular to the
/// edge `from → to` and pointing away from the triangle's third corner `other`; zero when
/// there is no plane or the edge has no direction.
fn edge_normal(from: DVec3, to: DVec3, other: DVec3, normal: DVec3) -> DVec3 {
    let m = (to - from).cross(normal);
    let length = m.length();
    if normal == DVec3::ZERO || !(length > 0.0 && length.is_finite()) {
        return DVec3::ZERO;
    }
    let m = m / length;
    if m.dot(other - from) > 0.0 {
        -m
    } else {
        m
    }
}

impl MeshSource {
    /// For each triangle of a cluster (its block), a lower bound of the squared distance
    /// `closest_point_on_triangle` computes from `p` to it, below it by more than
    /// rounding: the squared gap to the triangle's box (what the scan always pruned by),
    /// or the squared distance `h²` to its plane less `plane_slack` when that is larger;
    /// and `h`. Written slot by slot without branches, so the compiler computes several
    /// slots at once. A candidate whose bound exceeds the best squared distance so far
    /// cannot lower it, so skipping it leaves the minimum unchanged.
    #[inline]
    fn lower_bounds_squared(&self, block: &ScanBlock, p: DVec3) -> ([f64; CLUSTER], [f64; CLUSTER]) {
        let mut bounds = [0.0; CLUSTER];
        let mut heights = [0.0; CLUSTER];
        for k in 0..CLUSTER {
            (bounds[k], heights[k]) = self.lower_bound_squared(block, k, p);
        }
        (bounds, heights)
    }

    /// Lowers `best` to the squared distance from `p` to triangle `t` (tree order) when
    /// that is not above it; whether it did.
    #[inline]
    fn lower_to_triangle(&self, p: DVec3, t: usize, best: &mut f64) -> bool {
        let (q, _) = volga_mesh::closest_point_with_frame(p, self.triangles[t], self.frames[t].as_ref());
        let d2 = (p - q).length_squared();
        let lowered = d2 <= *best;
        if lowered {
            *best = d2;
        }
        lowered
    }

    /// [`MeshSource::lower_bounds_squared`] of slot `k` alone.
    #[inline]
    fn lower_bound_squared(&self, block: &ScanBlock, k: usize, p: DVec3) -> (f64, f64) {
        let gap = |axis: usize, q: f64| at_least(at_least(block.lo[axis][k] - q, q - block.hi[axis][k]), 0.0);
        let (gx, gy, gz) = (gap(0, p.x), gap(1, p.y), gap(2, p.z));
        let gap = (gx * gx) + (gy * gy) + (gz * gz);
        let height = at_least(
            (dot_at(&block.normal, k, p) - block.offset[k]).abs() - self.plane_slack,
            0.0,
        );
        (at_least(gap, height * height * (1.0 - 1e-9)), height)
    }

    /// Triangle `k` of a block's bound [`MeshSource::lower_bounds_squared`] raised, where
    /// larger, to `h² + e²` with `e` the largest distance of `p` outside one of its edges'
    /// lines in its plane less `plane_slack` (`height`: `h`): every point of the triangle
    /// lies inside all three edge lines, so its distance from `p`'s foot on the plane is
    /// at least `e`.
    #[inline]
    fn edge_bound_squared(&self, block: &ScanBlock, k: usize, p: DVec3, bound: f64, height: f64) -> f64 {
        let outside = (0..3)
            .map(|e| dot_at(&block.edge_normal[e], k, p) - block.edge_offset[e][k])
            .fold(0.0, at_least);
        let aside = at_least(outside - self.plane_slack, 0.0);
        at_least(bound, ((height * height) + (aside * aside)) * (1.0 - 1e-9))
    }
}

/// The larger of two numbers (no NaN here: a branch the compiler turns into `max`).
#[inline]
fn at_least(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// `n[k] · p` for a vector of a block stored coordinate by coordinate.
#[inline]
fn dot_at(n: &[[f64; CLUSTER]; 3], k: usize, p: DVec3) -> f64 {
    (n[0][k] * p.x) + (n[1][k] * p.y) + (n[2][k] * p.z)
}

impl MeshSource {
    /// The positions in tree order of cluster `c`'s triangles.
    #[inline]
    fn cluster_range(&self, c: u32) -> std::ops::Range<usize> {
        let start = c as usize * CLUSTER;
        start..(start + CLUSTER).min(self.triangles.len())
    }

    /// The positions in tree order of a list entry's triangles: a cluster's, or one
    /// triangle's (an id with [`SINGLE`]).
    #[inline]
    fn entry_range(&self, entry: u32) -> std::ops::Range<usize> {
        if entry & SINGLE != 0 {
            let t = (entry & !SINGLE) as usize;
            t..t + 1
        } else {
            self.cluster_range(entry)
        }
    }

    /// A list entry's box: its cluster's, or its triangle's.
    #[inline]
    fn entry_box(&self, entry: u32) -> (DVec3, DVec3) {
        if entry & SINGLE != 0 {
            let t = (entry & !SINGLE) as usize;
            let (block, k) = (&self.blocks[t / CLUSTER], t % CLUSTER);
            (
                DVec3::new(block.lo[0][k], block.lo[1][k], block.lo[2][k]),
                DVec3::new(block.hi[0][k], block.hi[1][k], block.hi[2][k]),
            )
        } else {
            let c = &self.clusters[entry as usize];
            (c.lo, c.hi)
        }
    }

    /// The mesh ids of the triangles of `entries` (ids of a [`CellCandidates`] list of
    /// this source: clusters, or single triangles), entry by entry: what a list, or a
    /// prefix of it such as [`CellCandidates::meeting_cell`], stands for.
    pub fn triangles_of<'a>(&'a self, entries: &'a [u32]) -> impl Iterator<Item = u32> + 'a {
        entries
            .iter()
            .flat_map(move |&e| self.order[self.entry_range(e)].iter().copied())
    }
}

impl MeshSource {
    /// The mesh ids of the triangles of list `entries` whose boxes meet the box `lo..hi`
    /// (closed), read in tree order: every triangle of theirs that can meet a segment
    /// inside it.
    fn triangles_meeting<'a>(&'a self, entries: &'a [u32], lo: DVec3, hi: DVec3) -> impl Iterator<Item = u32> + 'a {
        let meets = move |a: DVec3, b: DVec3| !(a.cmpgt(hi).any() || b.cmplt(lo).any());
        entries
            .iter()
            .filter(move |&&e| {
                let (a, b) = self.entry_box(e);
                meets(a, b)
            })
            .flat_map(move |&e| {
                self.entry_range(e).filter(move |&t| {
                    let (a, b) = self.entry_box(t as u32 | SINGLE);
                    meets(a, b)
                })
            })
            .map(move |t| self.order[t])
    }
}

impl DistanceSource for MeshSource {
    fn distance(&self, p: DVec3) -> f64 {
        self.sample(p, None).value
    }

    /// The 1-Lipschitz bound around the box's centre; for a mesh with holes, whose sign
    /// may jump away from the surface, only the unsigned distance is 1-Lipschitz, so the
    /// range is `±(|d| + r)`.
    fn range(&self, world_box: &Aabb) -> (f64, f64) {
        let d = self.distance(world_box.center());
        let r = world_box.size().length() * 0.5;
        if self.may_jump() {
            (-(d.abs() + r), d.abs() + r)
        } else {
            (d - r, d + r)
        }
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

impl AdfSource for MeshSource {
    /// The unsigned distance to the nearest triangle, and the sign from the winding number
    /// `w = I − w_C` (`volga_mesh::CappedWinding`): the integer `I` is carried over from
    /// `near` by counting the sheets of the mesh and its caps the segment between them
    /// crosses (`CappedWinding::integer_along`), or computed when that count is not
    /// certain; `w_C` (the caps alone) is always computed, certified against `I − ½`.
    fn sample(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Sample {
        self.queries.fetch_add(1, Ordering::Relaxed);
        let bound = near_bound(p, near);
        let unsigned = self
            .bvh
            .closest_within(p, bound)
            .or_else(|| self.bvh.closest(p))
            .map_or(f64::INFINITY, |c| c.distance);
        self.signed(p, unsigned, near, None)
    }

    /// The clusters of triangles (8 consecutive ones of the BVH's tree order)
    /// whose boxes are within `reach` (Euclidean) of the cell: their triangles hold the
    /// nearest point of every point of the cell (its distance is at most `reach`). All
    /// clusters are filtered at the top of the tree (no parent), else the parent's list;
    /// a cell no larger than half the median cluster lists the triangles of its clusters
    /// apart (entries flagged by the top bit), each kept when its own box is within `reach`.
    /// Sorted by the boxes' gap to the cell (`lower`).
    fn candidates(&self, cell: &Aabb, reach: f64, parent: Option<&CellCandidates>) -> Option<CellCandidates> {
        // Slack for the rounding of `reach` and of the box distances.
        let reach = reach * (1.0 + 1e-9) + 1e-12 * cell.size().max_element();
        let reach_squared = reach * reach;
        let gap_squared = |entry: u32| {
            let (lo, hi) = self.entry_box(entry);
            (lo - cell.max).max(cell.min - hi).max(DVec3::ZERO).length_squared()
        };
        // A candidate's sort key: its gap rounded down to f32 (still a lower bound), whose
        // bits order as the values do (gaps are ≥ 0), above its id (ties by id: the order
        // is a function of the cell alone).
        let mut keys: Vec<u64> = Vec::new();
        let mut keep = |entry: u32| {
            let g = gap_squared(entry);
            if g <= reach_squared {
                keys.push((u64::from(f32_at_most(g).to_bits()) << 32) | u64::from(entry));
            }
        };
        // A cell no larger than a typical cluster lists its clusters' triangles apart.
        let split = cell.size().max_element() <= self.split_below;
        let mut narrow = |entry: u32| {
            if split && entry & SINGLE == 0 {
                if gap_squared(entry) <= reach_squared {
                    for t in self.cluster_range(entry) {
                        keep(t as u32 | SINGLE);
                    }
                }
            } else {
                keep(entry);
            }
        };
        match parent {
            Some(list) => {
                // The parent's gaps are lower bounds of this cell's (it lies inside the
                // parent): a sorted list ends with the first one beyond the reach.
                let end = if list.lower.len() == list.ids.len() {
                    list.lower.partition_point(|&g| g <= reach_squared)
                } else {
                    list.ids.len()
                };
                list.ids[..end].iter().for_each(|&e| narrow(e));
            }
            None => (0..self.clusters.len() as u32).for_each(narrow),
        }
        // Nearest boxes first.
        keys.sort_unstable();
        let lower = keys
            .iter()
            .map(|&k| f64::from(f32::from_bits((k >> 32) as u32)))
            .collect();
        let ids = keys.iter().map(|&k| k as u32).collect();
        let mut sheets = Vec::new();
        self.winding.caps_overlapping(cell, &mut sheets);
        let sign_bounds = match parent.and_then(|p| p.sign_bounds) {
            // The parent's ball holds this cell's (a child's centre is half the
            // parent's radius from the parent's, its radius half of it), so its
            // bounds hold here; they decide every threshold `I − ½` its own would
            // decide when they hold no half-integer.
            Some((lo, hi)) if (lo + 0.5).ceil() > hi + 0.5 => Some((lo, hi)),
            _ => self
                .winding
                .caps_range_over_ball(cell.center(), 0.5 * cell.size().length() * (1.0 + 1e-9)),
        };
        Some(CellCandidates {
            ids,
            lower,
            sheets,
            sign_bounds,
            sign_model: None,
        })
    }

    /// The nearest of the cell's candidates, and the sheets crossed from `near` counted
    /// among them (the BVH only when rounding left the scan empty). The same distance as
    /// [`MeshSource::sample`]: the minimum over a set that holds the nearest triangle.
    ///
    /// The scan visits the list's entries (clusters, or single triangles) by their boxes'
    /// gap to the cell and stops at the first gap above the best squared distance so far
    /// (every later triangle is farther from any point of the cell); a cluster is skipped
    /// when its box is farther from `p` than the best, and a triangle when its lower bound
    /// is: its box, or for a well-shaped triangle its plane and edge lines
    /// (`MeshSource::lower_bounds_squared` and `edge_bound_squared`, private). Only
    /// triangles that cannot lower the minimum are skipped, so the value is the plain
    /// scan's, bit for bit.
    fn sample_among(&self, p: DVec3, near: Option<(DVec3, &Sample)>, candidates: &CellCandidates) -> Sample {
        self.queries.fetch_add(1, Ordering::Relaxed);
        let bound = near_bound(p, near);
        let mut best = if bound.is_finite() {
            bound * bound * (1.0 + 1e-12)
        } else {
            f64::INFINITY
        };
        let mut found = false;
        // Ascending cell-box gaps: every later candidate is at least this far from `p`.
        let sorted = candidates.lower.len() == candidates.ids.len();
        for (k, &id) in candidates.ids.iter().enumerate() {
            if sorted && candidates.lower[k] > best {
                break;
            }
            if id & SINGLE != 0 {
                let t = (id & !SINGLE) as usize;
                let (block, k) = (&self.blocks[t / CLUSTER], t % CLUSTER);
                let (bound, height) = self.lower_bound_squared(block, k, p);
                if !(bound > best || self.edge_bound_squared(block, k, p, bound, height) > best) {
                    found |= self.lower_to_triangle(p, t, &mut best);
                }
                continue;
            }
            // The cluster's box holds its triangles' boxes: its gap is at most theirs.
            let c = &self.clusters[id as usize];
            if (c.lo - p).max(p - c.hi).max(DVec3::ZERO).length_squared() > best {
                continue;
            }
            let block = &self.blocks[id as usize];
            let (bounds, heights) = self.lower_bounds_squared(block, p);
            for (k, t) in self.cluster_range(id).enumerate() {
                if !(bounds[k] > best || self.edge_bound_squared(block, k, p, bounds[k], heights[k]) > best) {
                    found |= self.lower_to_triangle(p, t, &mut best);
                }
            }
        }
        if !found {
            // Only through rounding of the neighbour's bound: ask the BVH.
            return self.sample(p, near);
        }
        self.signed(p, best.sqrt(), near, Some(candidates))
    }

    /// `CappedWinding::winding_model` over the cell when its bounds of `w_C` are missing
    /// (the cell is near a cap) and no triangle meets it (every listed box has a positive
    /// gap, the rest are beyond the reach), with `I` at the centre carried from `corner`
    /// across the cell's cap triangles.
    fn sign_model(
        &self,
        cell: &Aabb,
        corner: (DVec3, &Sample),
        candidates: &CellCandidates,
    ) -> Option<volga_mesh::WindingModel> {
        let meets_none = candidates.meeting_cell().is_empty();
        if candidates.sign_bounds.is_some() || !meets_none || !self.may_jump() {
            return None;
        }
        let (q, s) = corner;
        let centre = cell.center();
        let integer = s.region.and_then(|i| {
            self.winding
                .integer_along_listed(q, i, centre, std::iter::empty(), candidates.sheets.iter().copied())
        });
        let (model, terms) = self.winding.winding_model(cell, integer);
        self.winding_terms.fetch_add(terms, Ordering::Relaxed);
        model
    }

    /// Only with holes (caps closing a boundary).
    fn may_jump(&self) -> bool {
        self.winding.cap_triangle_count() > 0
    }

    /// Measured once from the triangles ([`SurfaceMeasures::of_mesh`]).
    fn surface_measures(&self) -> Option<SurfaceMeasures> {
        Some(self.measures)
    }

    /// `½ − w(p)`, with `w_C` summed to 1e-6.
    fn sign_field(&self, p: DVec3) -> Option<f64> {
        Some(0.5 - self.winding.winding_value(p, 1e-6))
    }

    /// `I − w_C` with the sample's certified `I`.
    fn sign_field_at(&self, p: DVec3, sample: &Sample) -> Option<f64> {
        Some(match sample.region {
            Some(i) => 0.5 - self.winding.winding_value_with(p, i, 1e-6),
            None => 0.5 - self.winding.winding_value(p, 1e-6),
        })
    }

    /// `CappedWinding::inside_over_ball` over the cell's circumscribed ball: its centre is
    /// farther than the ball's radius from the mesh (the corner is farther than the
    /// cell's diagonal), so `I` is the corner's unless a cap meets the ball (then `None`).
    fn side_of_empty_cell(&self, cell: &Aabb, corner: (DVec3, &Sample)) -> Option<bool> {
        let radius = 0.5 * cell.size().length();
        if corner.1.value.is_nan() || corner.1.value.abs() <= 2.0 * radius {
            return None;
        }
        self.winding
            .inside_over_ball(cell.center(), radius * (1.0 + 1e-9), corner.1.region?)
    }

    /// The parent's certified bounds of `w_C` (over a ball holding the cell and meeting
    /// no cap) decide the side when they clear the corner's `I − ½`: no mesh sheet meets
    /// the cell (the corner is farther than its diagonal) and no cap does, so `I` is the
    /// corner's everywhere in it. Otherwise [`AdfSource::side_of_empty_cell`].
    fn side_of_empty_cell_in(
        &self,
        cell: &Aabb,
        corner: (DVec3, &Sample),
        parent: Option<&CellCandidates>,
    ) -> Option<bool> {
        if let Some(side) = parent.and_then(|p| p.sign_model.as_ref()?.side_in(cell)) {
            return Some(side);
        }
        if let (Some((lo, hi)), Some(integer)) = (parent.and_then(|p| p.sign_bounds), corner.1.region) {
            let threshold = integer as f64 - 0.5;
            if corner.1.value.abs() > cell.size().length() {
                if hi < threshold {
                    return Some(true);
                }
                if lo > threshold {
                    return Some(false);
                }
            }
        }
        self.side_of_empty_cell(cell, corner)
    }

    /// No mesh triangle meets the cell, so `I` changes only across the caps between
    /// `near` and `p` (counted); `w_C` decides.
    fn inside_in_empty_cell(&self, p: DVec3, near: (DVec3, &Sample)) -> Option<bool> {
        let (q, s) = near;
        let integer = self.winding.integer_along_among(q, s.region?, p, std::iter::empty())?;
        let (inside, _, cost) = self.winding.inside_with(p, Some(integer));
        self.winding_terms.fetch_add(cost.terms, Ordering::Relaxed);
        Some(inside)
    }
}
