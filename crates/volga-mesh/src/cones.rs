//! The caps' certified winding number summed cone by cone.
//!
//! Caps close a mesh's boundary cycle with cones: one apex per loop, one sliver
//! triangle per boundary edge ([`crate::cap_triangles`]). A BVH over slivers is a poor
//! one: every sliver runs from the rim to the apex, so near a cap every node is near
//! and a certified query refines to the leaves through many far-field terms and heap
//! operations. Here each cone (cut into patches of at most [`ConeCaps::PATCH_EDGES`] edges along
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

/// Cap triangles grouped into cones (see the module doc), for certified winding
/// numbers of the caps alone: [`ConeCaps::winding_number_bounded`] answers as
/// [`Bvh::winding_number_bounded`] does over the same triangles (the same exact sum
/// within the same certified error), at a fraction of the cost near the caps.
#[derive(Debug, Clone)]
pub struct ConeCaps {
    patches: Vec<Patch>,
    /// Each patch's rim as polylines, coordinates apart (so the per-vertex work of a
    /// query runs over plain arrays): points `k` and `k + 1` of a patch form the
    /// triangle `(rim[k], rim[k + 1], apex)` where `linked[k]`.
    rim_x: Vec<f64>,
    rim_y: Vec<f64>,
    rim_z: Vec<f64>,
    linked: Vec<bool>,
    triangles: usize,
}

#[derive(Debug, Clone)]
struct Patch {
    apex: DVec3,
    rim_start: u32,
    rim_end: u32,
    edges: u32,
    /// The far-field expansion of the patch's triangles (the root of their BVH).
    expansion: Node,
}

/// Per query, a patch's rim vertices `r` (with `v = r − p`, `c = apex − p`) and the
/// terms of its triangles, in arrays of [`RIM_POINTS`].
struct Scratch {
    /// `v`, `v × c`, `|v|`, `v · c`.
    v: [Vec<f64>; 3],
    cross: [Vec<f64>; 3],
    length: Vec<f64>,
    along: Vec<f64>,
    /// Per triangle `(k, k + 1)`: [`crate::solid_angle`]'s numerator and denominator.
    numerator: Vec<f64>,
    denominator: Vec<f64>,
    /// `numerator / denominator`.
    tangent: Vec<f64>,
}

/// Most polyline points of a patch: every edge's two ends.
const RIM_POINTS: usize = 2 * ConeCaps::PATCH_EDGES;

impl Scratch {
    fn new() -> Scratch {
        let buffer = || vec![0.0; RIM_POINTS];
        Scratch {
            v: [buffer(), buffer(), buffer()],
            cross: [buffer(), buffer(), buffer()],
            length: buffer(),
            along: buffer(),
            numerator: buffer(),
            denominator: buffer(),
            tangent: buffer(),
        }
    }
}

/// A far patch of the first pass: its bound, its expansion's value, its index.
type Far = (f64, f64, u32);

thread_local! {
    /// The thread's buffers, kept between queries (taken out for a query's duration, so
    /// a query asked from inside `done` finds none and makes its own).
    static SCRATCH: RefCell<Option<(Scratch, Vec<Far>)>> = const { RefCell::new(None) };
}

impl ConeCaps {
    /// Most boundary edges in one patch.
    pub const PATCH_EDGES: usize = 128;
    /// Most patches: beyond, a flat scan per query loses to a tree (and
    /// [`ConeCaps::build`] returns `None`).
    pub const MAX_PATCHES: usize = 64;

    /// Groups `triangles` by their apex (the corner position shared by the most
    /// triangles: of the three corners, the one with the fewest distinct positions) and
    /// each cone's edges into chains along its loop, cut into patches of at most
    /// [`ConeCaps::PATCH_EDGES`] edges. `None` for no triangles or more than [`ConeCaps::MAX_PATCHES`]
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
            rim_x: Vec::new(),
            rim_y: Vec::new(),
            rim_z: Vec::new(),
            linked: Vec::new(),
            triangles: triangles.len(),
        };
        for (apex, edges) in &cones {
            let chained = chain(edges, key);
            for run in chained.chunks(Self::PATCH_EDGES) {
                if caps.patches.len() == Self::MAX_PATCHES {
                    return None;
                }
                caps.push_patch(*apex, run, key);
            }
        }
        Some(caps)
    }

    fn push_patch(&mut self, apex: DVec3, run: &[[DVec3; 2]], key: impl Fn(DVec3) -> [u64; 3]) {
        let rim_start = self.rim_x.len();
        let mut positions = Vec::with_capacity(3 * run.len());
        let mut last: Option<[u64; 3]> = None;
        let push = |caps: &mut ConeCaps, r: DVec3| {
            caps.rim_x.push(r.x);
            caps.rim_y.push(r.y);
            caps.rim_z.push(r.z);
            caps.linked.push(false);
        };
        for edge in run {
            // Continue the polyline where the edge starts at its last point; else start
            // a new one (unlinked from the last).
            if last != Some(key(edge[0])) {
                push(self, edge[0]);
            }
            *self.linked.last_mut().expect("a point was pushed") = true;
            push(self, edge[1]);
            last = Some(key(edge[1]));
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
            rim_end: self.rim_x.len() as u32,
            edges: run.len() as u32,
            expansion,
        });
    }

    /// Cap triangles indexed.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Patches (cones, or runs of [`ConeCaps::PATCH_EDGES`] edges of one).
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
        let (mut scratch, mut far) = SCRATCH
            .with_borrow_mut(Option::take)
            .unwrap_or_else(|| (Scratch::new(), Vec::new()));
        far.clear();
        let bound = {
            let (scratch, far) = (&mut scratch, &mut far);
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
                    let n = self.sum_patch(patch, p, &mut sum, scratch);
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
                let n = self.sum_patch(&self.patches[k as usize], p, &mut sum, scratch);
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
        };
        SCRATCH.with_borrow_mut(|kept| *kept = Some((scratch, far)));
        bound
    }

    /// Adds the exact solid angles of `patch`'s triangles at `p`; returns how many.
    fn sum_patch(&self, patch: &Patch, p: DVec3, sum: &mut SolidAngleSum, scratch: &mut Scratch) -> u32 {
        let c = patch.apex - p;
        let lc = c.length();
        let range = patch.rim_start as usize..patch.rim_end as usize;
        let n = range.len();
        let (rx, ry, rz) = (
            &self.rim_x[range.clone()],
            &self.rim_y[range.clone()],
            &self.rim_z[range.clone()],
        );
        let Scratch {
            v: [vx, vy, vz],
            cross: [wx, wy, wz],
            length,
            along,
            numerator,
            denominator,
            tangent,
        } = scratch;
        let (vx, vy, vz) = (&mut vx[..n], &mut vy[..n], &mut vz[..n]);
        let (wx, wy, wz) = (&mut wx[..n], &mut wy[..n], &mut wz[..n]);
        let (length, along) = (&mut length[..n], &mut along[..n]);
        // Per rim vertex, `glam`'s operations written out (the same roundings as
        // `solid_angle`'s vectors), over plain arrays.
        for k in 0..n {
            let (x, y, z) = (rx[k] - p.x, ry[k] - p.y, rz[k] - p.z);
            vx[k] = x;
            vy[k] = y;
            vz[k] = z;
            wx[k] = y * c.z - c.y * z;
            wy[k] = z * c.x - c.z * x;
            wz[k] = x * c.y - c.x * y;
            length[k] = ((x * x) + (y * y) + (z * z)).sqrt();
            along[k] = (x * c.x) + (y * c.y) + (z * c.z);
        }
        // Per pair of consecutive points, the triangle `(a, b, c)`'s terms in
        // `solid_angle`'s order of operations: `a · (b × c)` and
        // `|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|`.
        let pairs = n.saturating_sub(1);
        let (numerator, denominator, tangent) = (
            &mut numerator[..pairs],
            &mut denominator[..pairs],
            &mut tangent[..pairs],
        );
        for k in 0..pairs {
            numerator[k] = (vx[k] * wx[k + 1]) + (vy[k] * wy[k + 1]) + (vz[k] * wz[k + 1]);
            let ab = (vx[k] * vx[k + 1]) + (vy[k] * vy[k + 1]) + (vz[k] * vz[k + 1]);
            denominator[k] =
                length[k] * length[k + 1] * lc + ab * lc + along[k] * length[k + 1] + along[k + 1] * length[k];
            tangent[k] = numerator[k] / denominator[k];
        }
        let linked = &self.linked[patch.rim_start as usize..patch.rim_start as usize + pairs];
        for k in 0..pairs {
            if linked[k] {
                sum.add_half_angle_with(numerator[k], denominator[k], tangent[k]);
            }
        }
        patch.edges
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
