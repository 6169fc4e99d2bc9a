//! Winding numbers over the tree: the fast far-field sum (Barill et al. 2018) and the
//! same with a certified error bound, refined best first.

use std::f64::consts::PI;

use glam::DVec3;

use super::{Bvh, Node, FAR_FIELD_BETA, STACK_SIZE};
use crate::solid_angle;
use crate::winding::SolidAngleSum;

impl Bvh {
    /// Fast generalized winding number at `p` (Barill, Dickson, Schmidt, Levin &
    /// Jacobson, "Fast Winding Numbers for Soups and Clouds", SIGGRAPH 2018).
    ///
    /// Each node stores its dipole moment `N = Σ aᵢnᵢ` (area-weighted normals) and first
    /// moment `M = Σ (xᵢ − c) (aᵢnᵢ)ᵀ` about its area-weighted centroid `c`. When `p` is
    /// farther than [`FAR_FIELD_BETA`]` × r` from `c` (`r` bounds the node's extent from
    /// `c`), the node contributes the first two terms of the Taylor expansion of its
    /// solid angle about `c`: with `d = c − p`,
    /// `(N·d/|d|³ + tr(M)/|d|³ − 3 dᵀMd/|d|⁵) / 4π`. The first is the dipole term
    /// `(Σ aᵢnᵢ)·(c − p)/(4π|c − p|³)`; the second, which Barill et al. also keep, costs
    /// a 3×3 product and cuts the error about threefold. Otherwise the node's children
    /// are visited, and leaves near `p` sum exact solid angles ([`solid_angle`]), so the
    /// answer is exact where `p` is close to the surface.
    ///
    /// **Error.** The dropped terms of a far node are of relative order `(r/|d|)²`
    /// (≤ 1/β²) of its unsigned contribution `A/(4π|d|²)`. Measured against the exact
    /// sum at 1000 random points of the bounding box padded by 10%, with β = 2 (the
    /// `winding_accuracy` example): on spot the absolute error has median 1.6e-3, mean
    /// 3.0e-3, max 2.7e-2; on the Stanford bunny median 2.1e-3, mean 3.7e-3, max 3.6e-2
    /// (the dipole term alone: means about 9e-3, maxima about 5e-2). That is far below
    /// the ½ that decides inside: no sample was classified differently from the exact
    /// sum. Cost per query: about 2 µs against 120 µs (spot) and 1.5 ms (bunny) exact.
    pub fn winding_number(&self, p: DVec3) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let far_squared = FAR_FIELD_BETA * FAR_FIELD_BETA;
        let mut total = 0.0;
        let mut exact = SolidAngleSum::default();
        let mut stack = [0u32; STACK_SIZE];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            let to_center = node.center - p;
            let distance_squared = to_center.length_squared();
            if distance_squared > far_squared * node.radius * node.radius {
                total += far_field(node, to_center, distance_squared);
            } else if node.is_leaf() {
                let first = node.first_or_right as usize;
                for triangle in &self.triangles[first..first + node.count as usize] {
                    exact.add(p, *triangle);
                }
            } else {
                stack[top] = index + node.first_or_right;
                stack[top + 1] = index + 1;
                top += 2;
            }
        }
        (total + exact.settle()) / (4.0 * PI)
    }

    /// The winding number at `p` with a **certified error bound**, refined until `done`
    /// accepts it.
    ///
    /// The first pass is [`Bvh::winding_number`]'s traversal; every node it takes in the far
    /// field also gets a bound on what the expansion drops. The expansion is the exact
    /// first-order Taylor expansion of the kernel `n·(x − p)/|x − p|³` about the node's
    /// centre (its dipole and first moment are exact for flat triangles), so the remainder
    /// at a surface point `x = c + s` is `½ D²g(ξ)[s, s]`, a third derivative of `1/|y|`.
    /// Those are at most `3!/|y|⁴` in any unit directions (the Legendre bound `|P₃| ≤ 1`,
    /// and a symmetric 3-tensor's norm is reached on its diagonal), so a node at distance
    /// `d` with radius `r` and second moment `S₂ = ∫|x − c|² dA` is off by at most
    /// `3 S₂ / (d − r)⁴ / 4π`; and never more than its unsigned solid angle
    /// `A / (d − r)²` plus the estimate itself. The smaller of the two is used.
    ///
    /// While `done(value, error)` is false, the far node with the largest bound is opened
    /// (its children enter the far field or are summed exactly), best first, until every
    /// triangle is summed exactly: then `error` is only the rounding allowance, 1e-13 per
    /// term. The order is a function of `p` alone, so the result is deterministic.
    ///
    /// `skip` leaves out one triangle (mesh index): evaluated at a point of that
    /// triangle, the sum of the others is the principal value on the surface minus the
    /// triangle's own zero.
    pub fn winding_number_bounded(
        &self,
        p: DVec3,
        skip: Option<u32>,
        mut done: impl FnMut(f64, f64) -> bool,
    ) -> WindingBound {
        let mut acc = Accumulator::default();
        if self.nodes.is_empty() {
            return acc.finish();
        }
        // The far nodes' buffer is reused by the thread's next query (queries run by
        // the million; allocating one each contended for the allocator's lock).
        acc.far = FAR_BUFFER.with(|b| std::mem::take(&mut *b.borrow_mut()));
        self.visit(0, p, skip, &mut acc);
        while !done(acc.sum.settle() / (4.0 * PI), acc.error() / (4.0 * PI)) {
            if acc.heap.is_none() {
                // First refinement: order the first pass's far nodes (O(n) heapify).
                acc.heap = Some(std::collections::BinaryHeap::from(std::mem::take(&mut acc.far)));
            }
            let Some(FarNode { bound, index, approx }) = acc.heap.as_mut().and_then(|h| h.pop()) else {
                break;
            };
            acc.sum.total -= approx;
            acc.far_error -= bound;
            acc.refinements += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                self.sum_leaf(node, p, skip, &mut acc);
            } else {
                self.visit(index + 1, p, skip, &mut acc);
                self.visit(index + node.first_or_right, p, skip, &mut acc);
            }
        }
        let bound = acc.finish();
        let mut buffer = match acc.heap.take() {
            Some(heap) => heap.into_vec(),
            None => std::mem::take(&mut acc.far),
        };
        buffer.clear();
        FAR_BUFFER.with(|b| *b.borrow_mut() = buffer);
        bound
    }

    /// Adds the subtree at `start` to `acc`: far nodes as expansions with their bounds,
    /// near leaves exactly.
    fn visit(&self, start: u32, p: DVec3, skip: Option<u32>, acc: &mut Accumulator) {
        let far_squared = FAR_FIELD_BETA * FAR_FIELD_BETA;
        let mut stack = [0u32; STACK_SIZE];
        stack[0] = start;
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            let to_center = node.center - p;
            let distance_squared = to_center.length_squared();
            if distance_squared > far_squared * node.radius * node.radius {
                let approx = far_field(node, to_center, distance_squared);
                let bound = far_bound(node, distance_squared, approx);
                acc.sum.total += approx;
                acc.far_error += bound;
                acc.terms += 1;
                let far = FarNode { bound, index, approx };
                match &mut acc.heap {
                    Some(heap) => heap.push(far),
                    None => acc.far.push(far),
                }
            } else if node.is_leaf() {
                self.sum_leaf(node, p, skip, acc);
            } else {
                stack[top] = index + node.first_or_right;
                stack[top + 1] = index + 1;
                top += 2;
            }
        }
    }

    fn sum_leaf(&self, node: &Node, p: DVec3, skip: Option<u32>, acc: &mut Accumulator) {
        let first = node.first_or_right as usize;
        for k in first..first + node.count as usize {
            if Some(self.triangle_ids[k]) != skip {
                acc.sum.add(p, self.triangles[k]);
                acc.exact_triangles += 1;
                acc.terms += 1;
            }
        }
    }

    /// The exact winding number by summing every triangle's solid angle (`O(n)`): the
    /// reference for [`Bvh::winding_number`].
    pub fn winding_number_exact(&self, p: DVec3) -> f64 {
        self.triangles.iter().map(|&t| solid_angle(p, t)).sum::<f64>() / (4.0 * PI)
    }
}

/// A winding number and a certified bound on its error: the exact sum of solid angles
/// over the triangles' `f64` corners lies in `value ± error`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindingBound {
    /// The winding number estimate: the solid-angle sum over `4π` (1 inside and 0 outside
    /// a closed, outward-oriented mesh; fractional near the holes of an open one).
    pub value: f64,
    /// Certified half-width of the interval `value ± error` holding the exact sum. Never
    /// 0: it includes a rounding allowance of `1e-13 / 4π` per term summed or removed.
    pub error: f64,
    /// Triangles whose solid angle was summed one by one.
    pub exact_triangles: u32,
    /// Far-field nodes opened after the first pass.
    pub refinements: u32,
    /// Terms summed (far-field expansions and exact solid angles): the query's work.
    pub terms: u32,
}

impl WindingBound {
    /// `Some(value ≥ threshold)` when the bound proves it, `None` otherwise.
    pub fn side(&self, threshold: f64) -> Option<bool> {
        if self.value - self.error >= threshold {
            Some(true)
        } else if self.value + self.error < threshold {
            Some(false)
        } else {
            None
        }
    }

    /// Proven distance from `threshold` (0 when the bound straddles it).
    pub fn margin(&self, threshold: f64) -> f64 {
        ((self.value - threshold).abs() - self.error).max(0.0)
    }
}

thread_local! {
    /// [`Bvh::winding_number_bounded`]'s far-node buffer, kept between queries.
    static FAR_BUFFER: std::cell::RefCell<Vec<FarNode>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A far node's expansion and its error bound, ordered by the bound (then index).
#[derive(Debug, Clone, Copy)]
struct FarNode {
    bound: f64,
    index: u32,
    approx: f64,
}

impl PartialEq for FarNode {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl Eq for FarNode {}
impl PartialOrd for FarNode {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for FarNode {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.bound.total_cmp(&other.bound).then(other.index.cmp(&self.index))
    }
}

/// Running state of [`Bvh::winding_number_bounded`], in steradians.
#[derive(Default)]
struct Accumulator {
    /// Far-field estimates and exact solid angles.
    sum: SolidAngleSum,
    far_error: f64,
    /// Far nodes of the first pass; a heap (largest bound first) once refining.
    far: Vec<FarNode>,
    heap: Option<std::collections::BinaryHeap<FarNode>>,
    terms: u32,
    exact_triangles: u32,
    refinements: u32,
}

impl Accumulator {
    /// The far-field bounds plus a rounding allowance of 1e-13 per term added or removed.
    fn error(&self) -> f64 {
        self.far_error.max(0.0) + 1e-13 * (self.terms + 2 * self.refinements + 1) as f64
    }

    fn finish(&mut self) -> WindingBound {
        WindingBound {
            value: self.sum.settle() / (4.0 * PI),
            error: self.error() / (4.0 * PI),
            exact_triangles: self.exact_triangles,
            refinements: self.refinements,
            terms: self.terms,
        }
    }
}

/// A far node's solid angle seen from `p`, where `r = center − p`: the Taylor
/// expansion of `∫ n·(x − p)/|x − p|³ dA` about the centre to first order,
/// `N·r/|r|³ + tr(J M)` with `J = I/|r|³ − 3 r rᵀ/|r|⁵` the kernel's Jacobian and `M`
/// the first moment (Barill et al. 2018, §3, the first two terms of the expansion).
#[inline]
pub(crate) fn far_field(node: &Node, r: DVec3, r_squared: f64) -> f64 {
    let r_cubed = r_squared * r_squared.sqrt();
    let dipole = node.area_normal.dot(r) / r_cubed;
    let m = &node.first_moment;
    let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    dipole + trace / r_cubed - 3.0 * r.dot(*m * r) / (r_cubed * r_squared)
}

/// The certified bound on what [`far_field`]'s `approx` drops for a node `distance²`
/// away (see [`Bvh::winding_number_bounded`]), in steradians.
#[inline]
pub(crate) fn far_bound(node: &Node, distance_squared: f64, approx: f64) -> f64 {
    let gap = distance_squared.sqrt() - node.radius;
    let gap2 = gap * gap;
    let unsigned = node.area / gap2;
    (3.0 * node.second_moment / (gap2 * gap2)).min(unsigned + approx.abs()) + 1e-12 * (unsigned + approx.abs())
}
