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
                stack[top] = node.right;
                stack[top + 1] = i as u32 + 1;
                top += 2;
            }
        }
        total / (4.0 * PI)
    }
}
