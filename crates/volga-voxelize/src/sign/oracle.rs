//! The sign oracle, built once per mesh: the boundary cycle closed by cones, clean
//! triangles and features, the integer `I⁺` of each region of clean triangles and the
//! certified principal value `w̄_M` of each triangle.

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::Aabb;
use volga_mesh::{Bvh, ConeCaps, TriMesh};

use super::clean::{adjacent_pair_crosses, candidate_pairs, TOUCH};
use super::SignStats;
use crate::regions::EdgeUse;
use volga_mesh::SegmentTree;

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
    /// The same cones summed cone by cone, for every certified `w_C` (`None` when there
    /// are too many: the tree answers then).
    pub(crate) cones: Option<ConeCaps>,
    /// The cap triangles, indexed as in `cap`.
    pub(crate) cap_triangles: Vec<[DVec3; 3]>,
    /// Per triangle: trusted (clean, in a certified region); `I⁺` of its region; `w̄_M`
    /// at its centroid with the error of that value.
    pub(crate) trusted: Vec<bool>,
    pub(crate) front: Vec<i64>,
    pub(crate) w_bar: Vec<f64>,
    pub(crate) w_bar_error: Vec<f64>,
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
        let cap_triangles: Vec<[DVec3; 3]> = caps.iter().map(|(t, _)| *t).collect();
        let cones = ConeCaps::build(&cap_triangles);
        let cap_winding = |p: DVec3, tolerance: f64| {
            cap.as_ref()
                .map(|c| cap_query(c, cones.as_ref(), p, |_, e| e <= tolerance))
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
        // within 0.1 ask their own (to 0.02). The error only widens the triangle's band
        // interval (`Slack`), whose margin far from the holes is near ½: on the bunny at
        // N = 256, 0.1 instead of 0.02 sends 3 of 933 k band voxels to the caps and
        // spares 29 k of 44 k own queries.
        let (clean_ref, root_ref, front_ref) = (&clean, &root, &front_of_region);
        let per_triangle: Vec<(bool, i64, f64, f64)> = (0..n)
            .into_par_iter()
            .chunks(32)
            .flat_map_iter(|run| {
                let run_box = run
                    .iter()
                    .fold(Aabb::EMPTY, |b, &t| b.union(&Aabb::new(centroid(t), centroid(t))));
                let (centre, reach) = (run_box.center(), 0.5 * run_box.size().length());
                let shared = cap.as_ref().and_then(|c| {
                    c.closest_within(centre, reach).is_none().then(|| {
                        let b = cap_query(c, cones.as_ref(), centre, |_, e| e <= 0.005);
                        (b.value, b.error, boundary.gradient_bound(&run_box))
                    })
                });
                run.into_iter().map(move |t| {
                    let c = centroid(t);
                    let front = if clean_ref[t] {
                        front_ref.get(&root_ref[t]).copied().flatten()
                    } else {
                        None
                    };
                    match front {
                        Some(i) => {
                            let near = shared.and_then(|(w, e, g)| {
                                let e = e + g * (c - centre).length();
                                (e <= 0.1).then_some((w, e))
                            });
                            let (wc, ec) = near
                                .or_else(|| cap_winding(c, 0.02).map(|b| (b.value, b.error)))
                                .unwrap_or((0.0, 0.0));
                            (true, i, i as f64 + 0.5 - wc, ec)
                        }
                        None => (false, 0, 0.0, 0.0),
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
            cones,
            cap_triangles,
            trusted: per_triangle.iter().map(|p| p.0).collect(),
            front: per_triangle.iter().map(|p| p.1).collect(),
            w_bar: per_triangle.iter().map(|p| p.2).collect(),
            w_bar_error: per_triangle.iter().map(|p| p.3).collect(),
            edge_ok,
            vertex_ok,
            stats,
        }
    }

    /// `w_C(p)` certified against `threshold` (0 with no caps).
    pub(crate) fn cap_winding(&self, p: DVec3, threshold: f64) -> volga_mesh::WindingBound {
        match &self.cap {
            Some(cap) => self.cap_bounded(cap, p, |w, e| (w - threshold).abs() > e),
            None => volga_mesh::WindingBound {
                value: 0.0,
                error: 0.0,
                exact_triangles: 0,
                refinements: 0,
                terms: 0,
            },
        }
    }

    /// `w_C(p)` refined until `done` accepts it: cone by cone when the caps have few
    /// cones, else through their tree (`cap`).
    pub(crate) fn cap_bounded(
        &self,
        cap: &Bvh,
        p: DVec3,
        done: impl FnMut(f64, f64) -> bool,
    ) -> volga_mesh::WindingBound {
        cap_query(cap, self.cones.as_ref(), p, done)
    }

    /// Whether a cap triangle lies within `distance` of `p`.
    pub(crate) fn cap_within(&self, p: DVec3, distance: f64) -> bool {
        self.cap
            .as_ref()
            .is_some_and(|c| c.closest_within(p, distance).is_some())
    }
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

/// The caps' certified winding number at `p`, refined until `done` accepts it: cone by
/// cone when `cones` is given, else through the caps' tree.
fn cap_query(
    cap: &Bvh,
    cones: Option<&ConeCaps>,
    p: DVec3,
    done: impl FnMut(f64, f64) -> bool,
) -> volga_mesh::WindingBound {
    match cones {
        Some(cones) => cones.winding_number_bounded(p, done),
        None => cap.winding_number_bounded(p, None, done),
    }
}
