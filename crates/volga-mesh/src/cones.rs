//! The caps' certified winding number summed cone by cone.
//!
//! Caps close a mesh's boundary cycle with cones: one apex per loop, one sliver
//! triangle per boundary edge ([`crate::cap_triangles`]). A BVH over slivers is a poor
//! one: every sliver runs from the rim to the apex, so near a cap every node is near
//! and a certified query refines to the leaves through many far-field terms and heap
//! operations. Here each cone (cut into patches of at most [`PATCH_EDGES`] edges along
//! its loop) is one far-field term when the point is far from it and otherwise one
//! exact sum whose per-vertex work (the vector to the rim vertex, its length, its cross
//! and dot products with the apex's) is done once for the two edges that share it.

use std::cell::RefCell;
use std::f64::consts::PI;

use glam::DVec3;
use rustc_hash::FxHashMap;

use crate::bvh::{far_bound, far_field, Node};
use crate::winding::SolidAngleSum;
use crate::{Bvh, TriMesh, WindingBound, FAR_FIELD_BETA};

/// Most boundary edges in one patch.
pub const PATCH_EDGES: usize = 128;
/// Most patches: beyond, a flat scan per query loses to a tree.
pub const MAX_PATCHES: usize = 64;

/// Cap triangles grouped into cones (see the module doc), for certified winding
/// numbers of the caps alone: [`ConeCaps::winding_number_bounded`] answers as
/// [`Bvh::winding_number_bounded`] does over the same triangles (the same exact sum
/// within the same certified error), at a fraction of the cost near the caps.
#[derive(Debug, Clone)]
pub struct ConeCaps {
    patches: Vec<Patch>,
    /// Rim vertices, each patch's in one run.
    rim: Vec<DVec3>,
    /// Each patch's edges as indices into its run of `rim`: the triangle
    /// `(rim[a], rim[b], apex)`.
    edges: Vec<[u16; 2]>,
    triangles: usize,
}

#[derive(Debug, Clone)]
struct Patch {
    apex: DVec3,
    rim_start: u32,
    rim_end: u32,
    edges_start: u32,
    edges_end: u32,
    /// The far-field expansion of the patch's triangles (the root of their BVH).
    expansion: Node,
}

/// Per query and rim vertex `r`, with `v = r − p` and `c = apex − p`.
#[derive(Debug, Clone, Copy, Default)]
struct RimPoint {
    v: DVec3,
    /// `v × c`.
    cross: DVec3,
    /// `|v|`.
    length: f64,
    /// `v · c`.
    along: f64,
}

/// A far patch of the first pass: its bound, its expansion's value, its index.
type Far = (f64, f64, u32);

thread_local! {
    static SCRATCH: RefCell<(Vec<RimPoint>, Vec<Far>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl ConeCaps {
    /// Groups `triangles` by their apex (the corner position shared by the most
    /// triangles: of the three corners, the one with the fewest distinct positions) and
    /// each cone's edges into chains along its loop, cut into patches of at most
    /// [`PATCH_EDGES`] edges. `None` for no triangles or more than [`MAX_PATCHES`]
    /// patches (a tree is then the better index).
    pub fn build(triangles: &[[DVec3; 3]]) -> Option<ConeCaps> {
        if triangles.is_empty() {
            return None;
        }
        let key = |p: DVec3| p.to_array().map(|c| (c + 0.0).to_bits());
        let apex_corner = (0..3)
            .min_by_key(|&k| {
                let mut distinct: Vec<[u64; 3]> = triangles.iter().map(|t| key(t[k])).collect();
                distinct.sort_unstable();
                distinct.dedup();
                distinct.len()
            })
            .expect("three corners");
        // Cones in order of first appearance; each edge (a, b) of triangle (a, b, apex)
        // after a cyclic turn (which keeps the orientation).
        let mut cone_of: FxHashMap<[u64; 3], usize> = FxHashMap::default();
        let mut cones: Vec<(DVec3, Vec<[DVec3; 2]>)> = Vec::new();
        for t in triangles {
            let apex = t[apex_corner];
            let edge = [t[(apex_corner + 1) % 3], t[(apex_corner + 2) % 3]];
            let next = cones.len();
            let k = *cone_of.entry(key(apex)).or_insert(next);
            if k == next {
                cones.push((apex, Vec::new()));
            }
            cones[k].1.push(edge);
        }
        let mut caps = ConeCaps {
            patches: Vec::new(),
            rim: Vec::new(),
            edges: Vec::new(),
            triangles: triangles.len(),
        };
        for (apex, edges) in &cones {
            let chained = chain(edges, key);
            for run in chained.chunks(PATCH_EDGES) {
                if caps.patches.len() == MAX_PATCHES {
                    return None;
                }
                caps.push_patch(*apex, run, key);
            }
        }
        Some(caps)
    }

    fn push_patch(&mut self, apex: DVec3, run: &[[DVec3; 2]], key: impl Fn(DVec3) -> [u64; 3]) {
        let rim_start = self.rim.len();
        let edges_start = self.edges.len();
        let mut local: FxHashMap<[u64; 3], u16> = FxHashMap::default();
        let mut positions = Vec::with_capacity(3 * run.len());
        for edge in run {
            let ends = edge.map(|r| {
                let next = (self.rim.len() - rim_start) as u16;
                let i = *local.entry(key(r)).or_insert(next);
                if i == next {
                    self.rim.push(r);
                }
                i
            });
            self.edges.push(ends);
            positions.extend_from_slice(&[edge[0], edge[1], apex]);
        }
        let mesh = TriMesh {
            triangles: (0..run.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
            positions,
        };
        let mut expansion = *Bvh::build(&mesh).root().expect("a patch has triangles");
        // The tree's root bounds its radius through its children's; the patch's own
        // farthest corner (as a leaf measures it) is tighter.
        expansion.radius = mesh
            .positions
            .iter()
            .map(|&v| (v - expansion.center).length())
            .fold(0.0, f64::max);
        self.patches.push(Patch {
            apex,
            rim_start: rim_start as u32,
            rim_end: self.rim.len() as u32,
            edges_start: edges_start as u32,
            edges_end: self.edges.len() as u32,
            expansion,
        });
    }

    /// Cap triangles indexed.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Patches (cones, or runs of [`PATCH_EDGES`] edges of one).
    pub fn patch_count(&self) -> usize {
        self.patches.len()
    }

    /// The caps' winding number at `p` with a certified error bound, refined until
    /// `done(value, error)` accepts it: the contract of [`Bvh::winding_number_bounded`].
    ///
    /// The first pass takes each patch farther than [`FAR_FIELD_BETA`] times its radius
    /// as one far-field term (the expansion and bound of the tree's nodes) and sums the
    /// others exactly; while `done` refuses, the far patch with the largest bound (ties
    /// to the first) is summed exactly instead. Every exact term is
    /// [`crate::solid_angle`]'s, bit for bit; the sum carries the same rounding
    /// allowance, 1e-13 per term.
    pub fn winding_number_bounded(&self, p: DVec3, mut done: impl FnMut(f64, f64) -> bool) -> WindingBound {
        SCRATCH.with_borrow_mut(|(rim, far)| {
            far.clear();
            let mut sum = SolidAngleSum::default();
            let (mut far_error, mut terms, mut exact, mut refinements) = (0.0f64, 0u32, 0u32, 0u32);
            let far_squared = FAR_FIELD_BETA * FAR_FIELD_BETA;
            for (k, patch) in self.patches.iter().enumerate() {
                let node = &patch.expansion;
                let to_center = node.center - p;
                let distance_squared = to_center.length_squared();
                if distance_squared > far_squared * node.radius * node.radius {
                    let approx = far_field(node, to_center, distance_squared);
                    let bound = far_bound(node, distance_squared, approx);
                    sum.total += approx;
                    far_error += bound;
                    terms += 1;
                    far.push((bound, approx, k as u32));
                } else {
                    let n = self.sum_patch(patch, p, &mut sum, rim);
                    exact += n;
                    terms += n;
                }
            }
            let error = |far_error: f64, terms: u32, refinements: u32| {
                far_error.max(0.0) + 1e-13 * (terms + 2 * refinements + 1) as f64
            };
            while !done(
                sum.settle() / (4.0 * PI),
                error(far_error, terms, refinements) / (4.0 * PI),
            ) {
                // The largest bound, ties to the first patch.
                let Some(at) = (0..far.len()).reduce(|best, i| {
                    let (a, b) = (far[best], far[i]);
                    if b.0.total_cmp(&a.0).then(a.2.cmp(&b.2)).is_gt() {
                        i
                    } else {
                        best
                    }
                }) else {
                    break;
                };
                let (bound, approx, k) = far.swap_remove(at);
                sum.total -= approx;
                far_error -= bound;
                refinements += 1;
                let n = self.sum_patch(&self.patches[k as usize], p, &mut sum, rim);
                exact += n;
                terms += n;
            }
            WindingBound {
                value: sum.settle() / (4.0 * PI),
                error: error(far_error, terms, refinements) / (4.0 * PI),
                exact_triangles: exact,
                refinements,
                terms,
            }
        })
    }

    /// Adds the exact solid angles of `patch`'s triangles at `p`; returns how many.
    fn sum_patch(&self, patch: &Patch, p: DVec3, sum: &mut SolidAngleSum, rim: &mut Vec<RimPoint>) -> u32 {
        let c = patch.apex - p;
        let lc = c.length();
        let edges = &self.edges[patch.edges_start as usize..patch.edges_end as usize];
        rim.clear();
        rim.extend(
            self.rim[patch.rim_start as usize..patch.rim_end as usize]
                .iter()
                .map(|&r| {
                    let v = r - p;
                    RimPoint {
                        v,
                        cross: v.cross(c),
                        length: v.length(),
                        along: v.dot(c),
                    }
                }),
        );
        // `solid_angle`'s terms for the triangle (a, b, c), in its order of operations.
        let term = |[i, j]: [u16; 2]| {
            let (a, b) = (&rim[i as usize], &rim[j as usize]);
            let numerator = a.v.dot(b.cross);
            let denominator = a.length * b.length * lc + a.v.dot(b.v) * lc + a.along * b.length + b.along * a.length;
            (numerator, denominator)
        };
        for &edge in edges {
            let (numerator, denominator) = term(edge);
            sum.add_half_angle(numerator, denominator);
        }
        edges.len() as u32
    }
}

/// `edges` reordered into chains: each edge followed, where one is left, by an edge
/// starting where it ends (the first such in input order), so runs follow the loop.
fn chain(edges: &[[DVec3; 2]], key: impl Fn(DVec3) -> [u64; 3]) -> Vec<[DVec3; 2]> {
    let mut starting: FxHashMap<[u64; 3], Vec<usize>> = FxHashMap::default();
    for (i, e) in edges.iter().enumerate().rev() {
        starting.entry(key(e[0])).or_default().push(i);
    }
    let mut used = vec![false; edges.len()];
    let mut out = Vec::with_capacity(edges.len());
    for first in 0..edges.len() {
        let mut at = first;
        while !used[at] {
            used[at] = true;
            out.push(edges[at]);
            let Some(list) = starting.get_mut(&key(edges[at][1])) else {
                break;
            };
            while list.last().is_some_and(|&i| used[i]) {
                list.pop();
            }
            match list.last() {
                Some(&i) => at = i,
                None => break,
            }
        }
    }
    out
}
