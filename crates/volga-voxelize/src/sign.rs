//! Certified inside/outside for any triangle mesh: the sign of `w(p) − ½`, where `w` is
//! the generalized winding number, proven for every voxel (see `docs/VOXELIZE.md`).
//!
//! ## The identity behind the fast path
//! Take the mesh `M` as a 2-chain: its boundary `∂M` (each edge with the net number of
//! times the triangles run along it, forwards minus backwards) is a 1-cycle, whether the
//! mesh is closed, open, non-manifold, self-intersecting or inconsistently oriented. Its
//! loops are closed here by cones `C` (one apex per loop, lifted off the loop's plane), so
//! `M + C` is closed and its winding number `I = w_M + w_C` is an **integer** off the
//! surface, changing only across a sheet of `M + C`. Two consequences:
//!
//! * On a triangle `t` that no other triangle of `M + C` crosses ("clean"), `I` takes one
//!   integer `I⁺` just in front of it and `I⁺ + 1` just behind, and the same across
//!   every clean, consistently oriented manifold edge: one certified query per connected
//!   region of clean triangles gives `I⁺` exactly. Then `w̄_M = I⁺ + ½ − w_C` on `t`.
//! * `∇w_M = −∇w_C` off the surface is the Biot–Savart field of the boundary cycle, so
//!   `|∇w| ≤ Σ_e |m_e| ∫_e dl/|x − p|² / 4π` ([`SegmentTree::gradient_bound`]); for a
//!   closed mesh it is 0 and `w` is constant between sheets.
//!
//! A band voxel `p` whose nearest point `q` lies on clean triangle `t` (with a clean,
//! manifold star when `q` is on an edge or corner) has `w(p) = w̄_M(q) ± ½ + ∫_q^p ∇w`,
//! with the side from the pseudo-normal (Bærentzen & Aanæs 2005). Every term is known
//! with a certified bound; when the interval straddles ½, the voxel asks `w_C(p)` (when
//! no cap is within `|p − q|`) or, last, the mesh's certified winding number
//! ([`volga_mesh::Bvh::winding_number_bounded`]), refined until it proves its side.

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::Aabb;
use volga_mesh::{triangles_may_intersect, Bvh, TriMesh};

use crate::regions::EdgeUse;

/// How each voxel's sign was proven; the counts go to reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct SignStats {
    /// Band voxels decided by their nearest triangle's certified interval.
    pub fast_voxels: u64,
    /// Band voxels decided by the caps' winding number `w_C(p)` alone.
    pub cap_voxels: u64,
    /// Voxels that asked the whole mesh's certified winding number: in the band, and
    /// beyond it (where a flood fill or an octree box could not prove its sign).
    pub exact_voxels: u64,
    pub exact_band_voxels: u64,
    /// Of those, solid angles summed one by one (the cost of the fallback).
    pub exact_triangles: u64,
    /// Terms (expansions and exact solid angles) summed by all certified queries.
    pub query_terms: u64,
    /// Certified winding queries for regions of voxels or bricks beyond the band.
    pub region_queries: u64,
    /// Triangles another triangle (or a cap) crosses or touches off their shared
    /// edges and corners: their band voxels take the slow path.
    pub unclean_triangles: u64,
    /// Edges of the boundary cycle (net multiplicity ≠ 0) and cap triangles closing it.
    pub boundary_cycle_edges: u64,
}

impl SignStats {
    pub fn add(&mut self, other: &SignStats) {
        self.fast_voxels += other.fast_voxels;
        self.cap_voxels += other.cap_voxels;
        self.exact_voxels += other.exact_voxels;
        self.exact_band_voxels += other.exact_band_voxels;
        self.exact_triangles += other.exact_triangles;
        self.region_queries += other.region_queries;
        self.query_terms += other.query_terms;
    }
}

/// A weighted segment hierarchy over the boundary cycle, for gradient bounds.
#[derive(Debug, Clone, Default)]
pub(crate) struct SegmentTree {
    nodes: Vec<SegmentNode>,
    /// (start, end, |multiplicity|), in tree order.
    segments: Vec<(DVec3, DVec3, f64)>,
}

#[derive(Debug, Clone, Copy)]
struct SegmentNode {
    bounds: Aabb,
    /// Σ |m_e| |e| below this node.
    weighted_length: f64,
    first: u32,
    count: u32,
    /// Internal nodes: index of the right child (the left one follows the node).
    right: u32,
}

fn box_gap(a: &Aabb, b: &Aabb) -> f64 {
    (a.min - b.max).max(b.min - a.max).max(DVec3::ZERO).length()
}

impl SegmentTree {
    pub(crate) fn build(mut segments: Vec<(DVec3, DVec3, f64)>) -> SegmentTree {
        let mut nodes = Vec::new();
        if !segments.is_empty() {
            let n = segments.len();
            Self::build_node(&mut segments, 0, n, &mut nodes);
        }
        SegmentTree { nodes, segments }
    }

    fn build_node(segments: &mut [(DVec3, DVec3, f64)], first: usize, end: usize, nodes: &mut Vec<SegmentNode>) {
        let slice = &mut segments[first..end];
        let bounds = slice
            .iter()
            .fold(Aabb::EMPTY, |b, (s, e, _)| b.union(&Aabb::new(s.min(*e), s.max(*e))));
        let weighted_length = slice.iter().map(|(s, e, w)| w * (*e - *s).length()).sum();
        let index = nodes.len();
        nodes.push(SegmentNode {
            bounds,
            weighted_length,
            first: first as u32,
            count: (end - first) as u32,
            right: 0,
        });
        if end - first <= 4 {
            return;
        }
        let size = bounds.size();
        let axis = if size.x >= size.y && size.x >= size.z {
            0
        } else if size.y >= size.z {
            1
        } else {
            2
        };
        let mid = slice.len() / 2;
        slice.select_nth_unstable_by(mid, |a, b| (a.0 + a.1)[axis].total_cmp(&(b.0 + b.1)[axis]));
        Self::build_node(segments, first, first + mid, nodes);
        let right = nodes.len();
        Self::build_node(segments, first + mid, end, nodes);
        nodes[index].right = right as u32;
        nodes[index].count = 0;
    }

    /// An upper bound on `|∇w|` over the box: `Σ_e |m_e| min(|e|/D², π/D) / 4π` with `D`
    /// the gap between the box and the segment's box; infinite when a segment touches it.
    pub(crate) fn gradient_bound(&self, query: &Aabb) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut total = 0.0;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i];
            let gap = box_gap(&node.bounds, query);
            if gap > 0.0 && gap >= node.bounds.size().length() {
                total += node.weighted_length / (gap * gap);
            } else if node.count > 0 {
                let first = node.first as usize;
                for &(s, e, w) in &self.segments[first..first + node.count as usize] {
                    let d = box_gap(&Aabb::new(s.min(e), s.max(e)), query);
                    if d == 0.0 {
                        return f64::INFINITY;
                    }
                    total += w * ((e - s).length() / (d * d)).min(PI / d);
                }
            } else {
                stack.push(node.right as usize);
                stack.push(i + 1);
            }
        }
        total / (4.0 * PI)
    }
}

/// Union–find with path halving.
struct Sets(Vec<u32>);

impl Sets {
    fn new(n: usize) -> Sets {
        Sets((0..n as u32).collect())
    }
    fn find(&mut self, mut i: u32) -> u32 {
        while self.0[i as usize] != i {
            let up = self.0[self.0[i as usize] as usize];
            self.0[i as usize] = up;
            i = up;
        }
        i
    }
    fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        // The smaller index is the root, so roots are the first member (deterministic).
        if a < b {
            self.0[b as usize] = a;
        } else if b < a {
            self.0[a as usize] = b;
        }
    }
}

/// What the voxelizer needs to decide signs: per triangle the certified principal value
/// and which features may use the pseudo-normal.
#[derive(Debug, Clone)]
pub(crate) struct SignOracle {
    /// The boundary cycle is empty: `w` is constant between sheets.
    pub(crate) closed: bool,
    pub(crate) boundary: SegmentTree,
    /// Cones closing the boundary cycle (`None` when it is empty).
    pub(crate) cap: Option<Bvh>,
    /// Per triangle: trusted (clean, in a certified region); `I⁺` of its region; `w̄_M`
    /// at its centroid with the error of that value; the farthest corner from the
    /// centroid.
    pub(crate) trusted: Vec<bool>,
    pub(crate) front: Vec<i64>,
    pub(crate) w_bar: Vec<f64>,
    pub(crate) w_bar_error: Vec<f64>,
    pub(crate) radius: Vec<f64>,
    /// Per triangle and corner `k`: edge `k → k+1` may use its pseudo-normal; the
    /// vertex at corner `k` may use its pseudo-normal.
    pub(crate) edge_ok: Vec<[bool; 3]>,
    pub(crate) vertex_ok: Vec<[bool; 3]>,
    pub(crate) stats: SignStats,
}

/// Inputs of [`SignOracle::build`], triangles in the voxelizer's (Morton) order.
pub(crate) struct MeshTopology<'a> {
    pub(crate) triangles: &'a [[DVec3; 3]],
    /// Welded vertex ids of each triangle's corners.
    pub(crate) corners: &'a [[u32; 3]],
    pub(crate) welded_pos: &'a [DVec3],
    /// Edge uses sorted by (key, triangle, corner).
    pub(crate) uses: &'a [EdgeUse],
    /// The BVH over the mesh in its original order, and voxelizer index → BVH index.
    pub(crate) bvh: &'a Bvh,
    pub(crate) to_bvh: &'a [u32],
}

/// Relative tolerance of the adjacency tests: pairs closer than this to touching or to
/// coplanar count as crossing (which only sends their voxels down the slow path).
const TOUCH: f64 = 1e-9;

/// Whether two triangles that share the welded corners in `ids_*` meet anywhere but
/// their shared edge or corner, decided conservatively.
fn adjacent_pair_crosses(t: [DVec3; 3], t_ids: [u32; 3], s: [DVec3; 3], s_ids: [u32; 3]) -> bool {
    let repeats = |ids: [u32; 3]| ids[0] == ids[1] || ids[1] == ids[2] || ids[2] == ids[0];
    if repeats(t_ids) || repeats(s_ids) {
        return true; // a degenerate triangle is never clean, nor what touches it
    }
    let mut shared = [(0usize, 0usize); 9];
    let mut count = 0;
    for (i, ti) in t_ids.iter().enumerate() {
        for (j, sj) in s_ids.iter().enumerate() {
            if ti == sj {
                shared[count] = (i, j);
                count += 1;
            }
        }
    }
    let scale = t
        .iter()
        .chain(&s)
        .map(|v| (*v - t[0]).length())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    match count {
        0 => triangles_may_intersect(t, s, TOUCH * scale),
        1 => {
            let (i, j) = shared[0];
            let v = t[i];
            let (a1, a2) = (t[(i + 1) % 3] - v, t[(i + 2) % 3] - v);
            let (b1, b2) = (s[(j + 1) % 3] - v, s[(j + 2) % 3] - v);
            let (nt, ns) = (a1.cross(a2), b1.cross(b2));
            // `r` in the closed cone spanned by `a` and `b` about `n` (with slack).
            let in_cone = |r: DVec3, a: DVec3, b: DVec3, n: DVec3| {
                let slack = TOUCH * a.length() * r.length() * n.length();
                a.cross(r).dot(n) >= -slack && r.cross(b).dot(n) >= -slack
            };
            let d = nt.cross(ns);
            if d.length() <= TOUCH * nt.length() * ns.length() {
                // (Nearly) coplanar: the wedges overlap iff an edge of one lies in the other.
                let ns = if ns.dot(nt) < 0.0 { -ns } else { ns };
                let (b1, b2) = if b1.cross(b2).dot(nt) < 0.0 { (b2, b1) } else { (b1, b2) };
                in_cone(b1, a1, a2, nt) || in_cone(b2, a1, a2, nt) || in_cone(a1, b1, b2, ns) || in_cone(a2, b1, b2, ns)
            } else {
                in_cone(d, a1, a2, nt) && in_cone(d, b1, b2, ns) || in_cone(-d, a1, a2, nt) && in_cone(-d, b1, b2, ns)
            }
        }
        2 => {
            // The planes meet only along the shared edge unless `s` folds back onto `t`.
            let (i0, j0) = shared[0];
            let (i1, _) = shared[1];
            let (a, b) = (t[i0], t[i1]);
            let ot = t[3 - i0 - i1];
            let os = s[(0..3).find(|&k| k != j0 && k != shared[1].1).unwrap_or(0)];
            let nt = (b - a).cross(ot - a);
            let m = nt.cross(b - a);
            let same_side = m.dot(os - a) * m.dot(ot - a).signum() >= -TOUCH * m.length() * (os - a).length();
            let off_plane = nt.dot(os - a).abs();
            same_side && off_plane <= 1e-6 * nt.length() * (os - a).length()
        }
        _ => true,
    }
}

impl SignOracle {
    pub(crate) fn build(mesh: &MeshTopology) -> SignOracle {
        let n = mesh.triangles.len();
        // 1. Net multiplicity of every edge; the boundary cycle.
        let mut consistent = vec![[false; 3]; n];
        let mut directed: Vec<(u32, u32)> = Vec::new();
        let mut segments = Vec::new();
        let corner_of = |t: u32, v: u32| mesh.corners[t as usize].iter().position(|&c| c == v).unwrap_or(0) as u32;
        let mut fans = Sets::new(3 * n);
        let mut edge_bad_vertex = vec![false; mesh.welded_pos.len()];
        for group in mesh.uses.chunk_by(|a, b| a.key == b.key) {
            let (lo, hi) = ((group[0].key >> 32) as u32, (group[0].key & 0xffff_ffff) as u32);
            let m: i64 = group
                .iter()
                .map(|u| {
                    let from = mesh.corners[u.triangle as usize][u.corner as usize];
                    if from == lo {
                        1
                    } else {
                        -1
                    }
                })
                .sum();
            if group.len() == 2 && m == 0 {
                for u in group {
                    consistent[u.triangle as usize][u.corner as usize] = true;
                }
                let (t1, t2) = (group[0].triangle, group[1].triangle);
                for v in [lo, hi] {
                    fans.union(3 * t1 + corner_of(t1, v), 3 * t2 + corner_of(t2, v));
                }
            } else {
                edge_bad_vertex[lo as usize] = true;
                edge_bad_vertex[hi as usize] = true;
            }
            if m != 0 {
                let (from, to) = if m > 0 { (lo, hi) } else { (hi, lo) };
                for _ in 0..m.unsigned_abs() {
                    directed.push((from, to));
                }
                segments.push((
                    mesh.welded_pos[from as usize],
                    mesh.welded_pos[to as usize],
                    m.unsigned_abs() as f64,
                ));
            }
        }
        let closed = directed.is_empty();
        let boundary = SegmentTree::build(segments);

        // 2. Close the cycle: walk it into closed loops (every vertex has as many
        // boundary edges in as out), and cone each loop from an apex lifted off it.
        let caps = close_cycle(&directed, mesh);
        let apex_base = mesh.welded_pos.len() as u32;
        let cap = (!caps.is_empty()).then(|| {
            Bvh::build(&TriMesh {
                positions: caps.iter().flat_map(|(t, _)| *t).collect(),
                triangles: (0..caps.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
            })
        });

        // 3. Clean triangles: none of M + C crosses them off shared features.
        let degenerate = |t: &[DVec3; 3]| {
            let e = (t[1] - t[0]).length().max((t[2] - t[0]).length());
            (t[1] - t[0]).cross(t[2] - t[0]).length() <= 1e-12 * e * e
        };
        let mut from_bvh = vec![0u32; n];
        for (i, &b) in mesh.to_bvh.iter().enumerate() {
            from_bvh[b as usize] = i as u32;
        }
        let boxes: Vec<Aabb> = mesh
            .triangles
            .iter()
            .map(|t| {
                let scale = (t[1] - t[0]).length().max((t[2] - t[0]).length());
                Aabb::new(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
                    .expanded(DVec3::splat(2.0 * TOUCH * scale))
            })
            .collect();
        let pairs = candidate_pairs(&boxes, mesh.bvh, &from_bvh);
        let mut crossings: Vec<u32> = pairs
            .par_iter()
            .filter(|&&(t, s)| {
                let (t, s) = (t as usize, s as usize);
                adjacent_pair_crosses(mesh.triangles[t], mesh.corners[t], mesh.triangles[s], mesh.corners[s])
            })
            .flat_map_iter(|&(t, s)| [t, s])
            .collect();
        crossings.par_extend(
            (0..n as u32)
                .into_par_iter()
                .filter(|&t| degenerate(&mesh.triangles[t as usize])),
        );
        if let Some(cap) = &cap {
            crossings.par_extend((0..n).into_par_iter().filter_map(|t| {
                let mut near = Vec::new();
                cap.boxes_overlapping(&boxes[t], &mut near);
                near.into_iter()
                    .any(|c| {
                        let (s, ids) = caps[c as usize];
                        let ids = ids.map(|i| if i == u32::MAX { apex_base + c } else { i });
                        adjacent_pair_crosses(mesh.triangles[t], mesh.corners[t], s, ids)
                    })
                    .then_some(t as u32)
            }));
        }
        let mut clean = vec![true; n];
        for t in crossings {
            clean[t as usize] = false;
        }

        // 4. Features: an edge may use its pseudo-normal when it is consistent and both
        // triangles are clean; a corner when its star is one clean, consistent fan.
        let mut edge_ok = vec![[false; 3]; n];
        for group in mesh.uses.chunk_by(|a, b| a.key == b.key) {
            let (u, v) = (group[0], group[group.len() - 1]);
            if group.len() == 2
                && consistent[u.triangle as usize][u.corner as usize]
                && clean[u.triangle as usize]
                && clean[v.triangle as usize]
            {
                edge_ok[u.triangle as usize][u.corner as usize] = true;
                edge_ok[v.triangle as usize][v.corner as usize] = true;
            }
        }
        let mut fan_root = vec![u32::MAX; mesh.welded_pos.len()];
        let mut vertex_bad = edge_bad_vertex;
        for (t, &is_clean) in clean.iter().enumerate() {
            for k in 0..3 {
                let v = mesh.corners[t][k] as usize;
                let root = fans.find((3 * t + k) as u32);
                if !is_clean || (fan_root[v] != u32::MAX && fan_root[v] != root) {
                    vertex_bad[v] = true;
                }
                fan_root[v] = root;
            }
        }
        let vertex_ok: Vec<[bool; 3]> = (0..n)
            .map(|t| [0, 1, 2].map(|k| !vertex_bad[mesh.corners[t][k] as usize]))
            .collect();

        // 5. Regions of clean triangles joined by consistent edges; `I⁺` once per region.
        let mut regions = Sets::new(n);
        for group in mesh.uses.chunk_by(|a, b| a.key == b.key) {
            if group.len() == 2
                && consistent[group[0].triangle as usize][group[0].corner as usize]
                && clean[group[0].triangle as usize]
                && clean[group[1].triangle as usize]
            {
                regions.union(group[0].triangle, group[1].triangle);
            }
        }
        let root: Vec<u32> = (0..n as u32).map(|t| regions.find(t)).collect();
        let representatives: Vec<u32> = (0..n as u32)
            .filter(|&t| root[t as usize] == t && clean[t as usize])
            .collect();
        let centroid = |t: usize| {
            let [a, b, c] = mesh.triangles[t];
            (a + b + c) / 3.0
        };
        let cap_winding = |p: DVec3, tolerance: f64| {
            cap.as_ref()
                .map(|c| c.winding_number_bounded(p, None, |_, e| e <= tolerance))
        };
        let mut region_queries = 0u64;
        let front_of_region: FxHashMap<u32, Option<i64>> = representatives
            .par_iter()
            .map(|&t| {
                let c = centroid(t as usize);
                let (wc, ec) = cap_winding(c, 1e-6).map_or((0.0, 0.0), |b| (b.value, b.error));
                let w = mesh
                    .bvh
                    .winding_number_bounded(c, Some(mesh.to_bvh[t as usize]), |w, e| {
                        let x = w + wc - 0.5;
                        (x - x.round()).abs() + e + ec < 0.45
                    });
                let x = w.value + wc - 0.5;
                let certain = (x - x.round()).abs() + w.error + ec < 0.45;
                (t, certain.then_some(x.round() as i64))
            })
            .collect();
        region_queries += representatives.len() as u64;

        // 6. Per triangle: w̄ at the centroid = I⁺ + ½ − w_C(centroid). Runs of 32
        // triangles in (Morton) order share one query at the centre of their bounding
        // sphere when no cap reaches the sphere: `w_C` is smooth there, off by at most the
        // gradient bound times the distance; triangles the shared value does not pin
        // within 0.02 ask their own.
        let (clean_ref, root_ref, front_ref) = (&clean, &root, &front_of_region);
        let per_triangle: Vec<(bool, i64, f64, f64, f64)> = (0..n)
            .into_par_iter()
            .chunks(32)
            .flat_map_iter(|run| {
                let run_box = run
                    .iter()
                    .fold(Aabb::EMPTY, |b, &t| b.union(&Aabb::new(centroid(t), centroid(t))));
                let (centre, reach) = (run_box.center(), 0.5 * run_box.size().length());
                let shared = cap.as_ref().and_then(|c| {
                    c.closest_within(centre, reach).is_none().then(|| {
                        let b = c.winding_number_bounded(centre, None, |_, e| e <= 0.005);
                        (b.value, b.error, boundary.gradient_bound(&run_box))
                    })
                });
                run.into_iter().map(move |t| {
                    let tri = mesh.triangles[t];
                    let c = centroid(t);
                    let radius = tri.iter().map(|v| (*v - c).length()).fold(0.0, f64::max);
                    let front = if clean_ref[t] {
                        front_ref.get(&root_ref[t]).copied().flatten()
                    } else {
                        None
                    };
                    match front {
                        Some(i) => {
                            let near = shared.and_then(|(w, e, g)| {
                                let e = e + g * (c - centre).length();
                                (e <= 0.02).then_some((w, e))
                            });
                            let (wc, ec) = near
                                .or_else(|| cap_winding(c, 0.02).map(|b| (b.value, b.error)))
                                .unwrap_or((0.0, 0.0));
                            (true, i, i as f64 + 0.5 - wc, ec, radius)
                        }
                        None => (false, 0, 0.0, 0.0, radius),
                    }
                })
            })
            .collect();

        let stats = SignStats {
            region_queries,
            unclean_triangles: clean.iter().filter(|c| !**c).count() as u64,
            boundary_cycle_edges: directed.len() as u64,
            ..SignStats::default()
        };
        SignOracle {
            closed,
            boundary,
            cap,
            trusted: per_triangle.iter().map(|p| p.0).collect(),
            front: per_triangle.iter().map(|p| p.1).collect(),
            w_bar: per_triangle.iter().map(|p| p.2).collect(),
            w_bar_error: per_triangle.iter().map(|p| p.3).collect(),
            radius: per_triangle.iter().map(|p| p.4).collect(),
            edge_ok,
            vertex_ok,
            stats,
        }
    }

    /// `w_C(p)` certified against `threshold` (0 with no caps).
    pub(crate) fn cap_winding(&self, p: DVec3, threshold: f64) -> volga_mesh::WindingBound {
        match &self.cap {
            Some(cap) => cap.winding_number_bounded(p, None, |w, e| (w - threshold).abs() > e),
            None => volga_mesh::WindingBound {
                value: 0.0,
                error: 0.0,
                exact_triangles: 0,
                refinements: 0,
                terms: 0,
            },
        }
    }

    /// Whether a cap triangle lies within `distance` of `p`.
    pub(crate) fn cap_within(&self, p: DVec3, distance: f64) -> bool {
        self.cap
            .as_ref()
            .is_some_and(|c| c.closest_within(p, distance).is_some())
    }
}

/// Pairs `(t, s)`, `t < s`, of triangles whose boxes overlap: a uniform hash grid of
/// cells about twice the median box size, each pair tested once, in the lowest cell both
/// boxes reach. Boxes spanning more than 64 cells (rare, large triangles) query the BVH
/// instead.
fn candidate_pairs(boxes: &[Aabb], bvh: &Bvh, from_bvh: &[u32]) -> Vec<(u32, u32)> {
    if boxes.is_empty() {
        return Vec::new();
    }
    let mut sizes: Vec<f64> = boxes.iter().map(|b| b.size().max_element()).collect();
    let mid = sizes.len() / 2;
    sizes.select_nth_unstable_by(mid, f64::total_cmp);
    let all = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let cell = (2.0 * sizes[mid])
        .max(all.size().max_element() / 1e6)
        .max(f64::MIN_POSITIVE);
    let origin = all.min;
    let range = |b: &Aabb| {
        let lo = ((b.min - origin) / cell).floor().as_ivec3();
        let hi = ((b.max - origin) / cell).floor().as_ivec3();
        (lo, hi)
    };
    let key = |c: glam::IVec3| (c.x as u64) | (c.y as u64) << 21 | (c.z as u64) << 42;
    let mut entries: Vec<(u64, u32)> = Vec::with_capacity(boxes.len() * 2);
    let mut large = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        let (lo, hi) = range(b);
        let span = (hi - lo + 1).as_i64vec3();
        if span.x * span.y * span.z > 64 || hi.max_element() >= 1 << 21 {
            large.push(i as u32);
            continue;
        }
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    entries.push((key(glam::IVec3::new(x, y, z)), i as u32));
                }
            }
        }
    }
    entries.par_sort_unstable();
    let groups: Vec<&[(u64, u32)]> = entries.chunk_by(|a, b| a.0 == b.0).collect();
    let mut pairs: Vec<(u32, u32)> = groups
        .par_iter()
        .flat_map_iter(|group| {
            let mut out = Vec::new();
            let here = group[0].0;
            for (k, &(_, a)) in group.iter().enumerate() {
                for &(_, b) in &group[k + 1..] {
                    let (ba, bb) = (&boxes[a as usize], &boxes[b as usize]);
                    if ba.min.cmpgt(bb.max).any() || bb.min.cmpgt(ba.max).any() {
                        continue;
                    }
                    // Test the pair only in the lowest cell both boxes reach.
                    let first = range(ba).0.max(range(bb).0);
                    if key(first) == here {
                        out.push((a.min(b), a.max(b)));
                    }
                }
            }
            out
        })
        .collect();
    let large_set: rustc_hash::FxHashSet<u32> = large.iter().copied().collect();
    for &t in &large {
        let mut near = Vec::new();
        bvh.boxes_overlapping(&boxes[t as usize], &mut near);
        for b in near {
            let s = from_bvh[b as usize];
            // Pairs of two large boxes once; large with small from the large side.
            if s != t && (!large_set.contains(&s) || t < s) {
                pairs.push((t.min(s), t.max(s)));
            }
        }
    }
    pairs
}

/// Cap triangles `[apex, to, from]` for every directed boundary edge `from → to`, one
/// apex per closed loop, with their welded ids (`u32::MAX` for the apex).
fn close_cycle(directed: &[(u32, u32)], mesh: &MeshTopology) -> Vec<([DVec3; 3], [u32; 3])> {
    if directed.is_empty() {
        return Vec::new();
    }
    let mut out: FxHashMap<u32, Vec<u32>> = FxHashMap::default();
    for &(from, to) in directed {
        out.entry(from).or_default().push(to);
    }
    for targets in out.values_mut() {
        // Popped from the end: the smallest target first.
        targets.sort_unstable_by(|a, b| b.cmp(a));
    }
    let mut starts: Vec<u32> = out.keys().copied().collect();
    starts.sort_unstable();
    let mesh_centre = mesh.welded_pos.iter().sum::<DVec3>() / mesh.welded_pos.len().max(1) as f64;
    let mut caps = Vec::new();
    for start in starts {
        while out.get(&start).is_some_and(|t| !t.is_empty()) {
            // A closed walk from `start`: in = out at every vertex, so it can only stop
            // back at `start`.
            let mut walk = vec![start];
            let mut v = start;
            while let Some(next) = out.get_mut(&v).and_then(|t| t.pop()) {
                walk.push(next);
                v = next;
                if v == start {
                    break;
                }
            }
            let points: Vec<DVec3> = walk.iter().map(|&i| mesh.welded_pos[i as usize]).collect();
            let loop_len = points.len() - 1;
            let centre = points[..loop_len].iter().sum::<DVec3>() / loop_len.max(1) as f64;
            let area: DVec3 = (0..loop_len)
                .map(|k| (points[k] - centre).cross(points[k + 1] - centre))
                .sum::<DVec3>();
            let radius = points.iter().map(|p| (*p - centre).length()).fold(0.0, f64::max);
            let mut lift = area.normalize_or_zero();
            if lift == DVec3::ZERO {
                lift = DVec3::Z;
            }
            if lift.dot(mesh_centre - centre) > 0.0 {
                lift = -lift;
            }
            let apex = centre + lift * 0.5 * radius;
            for k in 0..loop_len {
                caps.push(([apex, points[k + 1], points[k]], [u32::MAX, walk[k + 1], walk[k]]));
            }
        }
    }
    caps
}
