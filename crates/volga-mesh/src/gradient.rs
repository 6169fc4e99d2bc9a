//! Gradient bounds of the winding number off the surface: the gradient of a surface's
//! winding number depends only on its boundary (it is the Biot–Savart field of the
//! boundary cycle), bounded over a box by a weighted segment hierarchy.

use std::f64::consts::PI;

use glam::DVec3;
use volga_core::Aabb;

/// A weighted segment hierarchy over a boundary cycle, for bounds on the gradient of
/// the winding number of any surface it bounds, at points off that surface: `∇w` is
/// the Biot–Savart field of the cycle, so `|∇w(x)| ≤ Σ_e |m_e| ∫_e dl/|x − y|² / 4π`.
#[derive(Debug, Clone, Default)]
pub struct SegmentTree {
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
    /// The hierarchy over `segments`: `(start, end, |multiplicity|)`.
    pub fn build(mut segments: Vec<(DVec3, DVec3, f64)>) -> SegmentTree {
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
    pub fn gradient_bound(&self, query: &Aabb) -> f64 {
        self.kernel_bound(
            query,
            false,
            |length, gap| length / (gap * gap),
            |length, d| (length / (d * d)).min(PI / d),
        )
    }

    /// An upper bound on the norm of the Hessian of `w` over the box:
    /// `Σ_e |m_e| min(2|e|/D³, 4/D²) / 4π` with `D` as in
    /// [`SegmentTree::gradient_bound`]. The derivative of the Biot–Savart kernel
    /// `(x − y)/|x − y|³` is `(I − 3 r̂ r̂ᵀ)/|r|³`, of norm `2/|r|³`, and its integral along
    /// a whole line at distance `D` is `4/D²`. Infinite when a segment touches the box.
    pub fn hessian_bound(&self, query: &Aabb) -> f64 {
        self.kernel_bound(
            query,
            true,
            |length, gap| 2.0 * length / (gap * gap * gap),
            |length, d| (2.0 * length / (d * d * d)).min(4.0 / (d * d)),
        )
    }

    /// `Σ_e |m_e| segment(|e|, D_e) / 4π` over the segments, a node whose box is farther
    /// from the query than its own diagonal taken at once as `node(Σ |m_e| |e|, gap)`
    /// (both decreasing in the distance, so each term bounds its segments'); infinite when
    /// a segment's box touches the query. With `by_centre`, a segment's distance `D_e` is
    /// also bounded below by its distance from the query's centre less the query's
    /// half-diagonal (tighter for a small query near a long oblique segment).
    fn kernel_bound(
        &self,
        query: &Aabb,
        by_centre: bool,
        node_term: impl Fn(f64, f64) -> f64,
        segment_term: impl Fn(f64, f64) -> f64,
    ) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut total = 0.0;
        // Depth-first, on the stack: each level pops one node and pushes at most two, and
        // median splits keep the depth below 32 (`u32` segment counts), so 64 slots hold it.
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let i = stack[top] as usize;
            let node = &self.nodes[i];
            let gap = box_gap(&node.bounds, query);
            if gap > 0.0 && gap >= node.bounds.size().length() {
                total += node_term(node.weighted_length, gap);
            } else if node.count > 0 {
                let first = node.first as usize;
                for &(s, e, w) in &self.segments[first..first + node.count as usize] {
                    let mut d = box_gap(&Aabb::new(s.min(e), s.max(e)), query);
                    if by_centre {
                        let centre = query.center();
                        let to_segment = crate::closest_point_on_segment(centre, s, e).0 - centre;
                        // Slack for the rounding of both lengths.
                        let d_centre = to_segment.length() * (1.0 - 1e-9) - 0.5 * query.size().length() * (1.0 + 1e-9);
                        d = d.max(d_centre);
                    }
                    if d == 0.0 {
                        return f64::INFINITY;
                    }
                    total += w * segment_term((e - s).length(), d);
                }
            } else {
                stack[top] = node.right;
                stack[top + 1] = i as u32 + 1;
                top += 2;
            }
        }
        total / (4.0 * PI)
    }
}
