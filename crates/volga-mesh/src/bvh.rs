//! Bounding volume hierarchy over a mesh's triangles: exact closest point, box
//! queries, and the fast (Barnes–Hut) winding number (`bvh/winding.rs`).

use glam::{DMat3, DVec3};
use volga_core::Aabb;

use crate::{closest_point_on_triangle, triangle_box_overlap, Feature, TriMesh};

mod winding;

pub use winding::WindingBound;
pub(crate) use winding::{far_bound, far_field};

/// Most triangles in a leaf.
const LEAF_SIZE: usize = 4;
/// Subtrees with at least this many triangles build their halves with `rayon::join`.
const PARALLEL_MIN_TRIANGLES: usize = 8192;
/// Traversal stack size; median splits keep the depth ≤ ⌈log₂ n⌉ ≤ 32 for `u32` counts.
const STACK_SIZE: usize = 64;

/// The far-field criterion of [`Bvh::winding_number`]: a node is approximated when
/// `p` is farther than `FAR_FIELD_BETA × radius` from its centre (Barill et al. 2018
/// recommend 2; 3 roughly halves the error at about four times the cost).
pub const FAR_FIELD_BETA: f64 = 2.0;

/// The nearest point of a mesh to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// Euclidean distance (world units) from the query to `point`.
    pub distance: f64,
    /// Index of the triangle in the mesh the BVH was built from.
    pub triangle: u32,
    /// The nearest point itself, on that triangle (world coordinates).
    pub point: DVec3,
    /// Where on that triangle `point` lies (its corner numbering).
    pub feature: Feature,
}

/// A BVH over a [`TriMesh`], in **world space**. It keeps its own copy of the triangle
/// corners (in tree order, for locality), so it does not borrow the mesh.
///
/// Built by median splits of triangle centroids along the longest axis of their box,
/// ties broken by triangle index, with large subtrees built in parallel. Every split is
/// a function of the input alone and each half writes only its own slice, so the tree
/// is bit-identical for any number of threads.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// Preorder: a node's left child follows it; its right child is `right_offset` on.
    nodes: Vec<Node>,
    /// Triangle corners in tree order.
    triangles: Vec<[DVec3; 3]>,
    /// Tree order → mesh triangle index.
    triangle_ids: Vec<u32>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Node {
    bounds: Aabb,
    /// `Σ ½ (b − a) × (c − a)`: the area-weighted normal sum (dipole moment).
    area_normal: DVec3,
    /// `Σ (xᵢ − center) (aᵢnᵢ)ᵀ` over triangle centroids `xᵢ`: the first moment, for
    /// the second term of the far-field expansion.
    first_moment: DMat3,
    /// Sum of triangle areas.
    area: f64,
    /// `Σ ∫ |x − center|² dA` over the node's triangles: bounds the far field's error.
    second_moment: f64,
    /// Area-weighted centroid (box centre if the area is zero): the expansion point.
    pub(crate) center: DVec3,
    /// An upper bound on the distance from `center` to any corner in the node.
    pub(crate) radius: f64,
    /// Leaf: index of the first triangle in tree order; internal: offset to the right child.
    first_or_right: u32,
    /// Leaf: number of triangles (≥ 1); internal: 0.
    count: u32,
}

impl Node {
    fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

impl Bvh {
    /// Builds the hierarchy. Panics if a triangle index is out of range (a mesh from the
    /// loaders or [`TriMesh::new`] never has one).
    pub fn build(mesh: &TriMesh) -> Bvh {
        let corners: Vec<[DVec3; 3]> = (0..mesh.triangles.len()).map(|i| mesh.triangle(i)).collect();
        let centroids: Vec<DVec3> = corners.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let mut order: Vec<u32> = (0..corners.len() as u32).collect();
        let input = BuildInput {
            corners: &corners,
            centroids: &centroids,
        };
        let nodes = if order.is_empty() {
            Vec::new()
        } else {
            input.build_parallel(&mut order, 0)
        };
        Bvh {
            nodes,
            triangles: order.iter().map(|&i| corners[i as usize]).collect(),
            triangle_ids: order,
        }
    }

    /// The root node: the whole mesh's far-field expansion (`None` when empty).
    pub(crate) fn root(&self) -> Option<&Node> {
        self.nodes.first()
    }

    /// Mesh triangle indices in tree order: the triangles of a leaf, and of any subtree,
    /// are consecutive, so runs of this order are spatially compact.
    pub fn tree_order(&self) -> &[u32] {
        &self.triangle_ids
    }

    /// Number of triangles indexed.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Box of all triangles ([`Aabb::EMPTY`] for an empty mesh).
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    /// The exact nearest point of the mesh (`None` only for an empty mesh or NaN `p`).
    pub fn closest(&self, p: DVec3) -> Option<Closest> {
        self.closest_within(p, f64::INFINITY)
    }

    /// The exact nearest point if it is at most `max_distance` away.
    ///
    /// Branch and bound: nodes are visited nearer box first and skipped once their box
    /// is farther than the best distance so far. Among triangles at exactly the same
    /// distance the first in tree order wins (deterministic).
    pub fn closest_within(&self, p: DVec3, max_distance: f64) -> Option<Closest> {
        if self.nodes.is_empty() || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        // Until a triangle is found the bound has slack for the rounding of the square;
        // acceptance itself compares the distance (`sqrt` of the square) with `max_distance`.
        let mut bound_squared = max_distance * max_distance * (1.0 + 1e-12);
        let mut best: Option<(usize, DVec3, Feature, f64)> = None;
        let mut stack = [(0u32, 0.0f64); STACK_SIZE];
        stack[0] = (0, box_distance_squared(&self.nodes[0].bounds, p));
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (index, box_distance) = stack[top];
            if box_distance > bound_squared {
                continue;
            }
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                let first = node.first_or_right as usize;
                for k in first..first + node.count as usize {
                    let (point, feature) = closest_point_on_triangle(p, self.triangles[k]);
                    let d2 = (p - point).length_squared();
                    let better = match best {
                        Some(_) => d2 < bound_squared,
                        None => d2.sqrt() <= max_distance,
                    };
                    if better {
                        bound_squared = d2;
                        best = Some((k, point, feature, d2));
                    }
                }
                continue;
            }
            let left = index + 1;
            let right = index + node.first_or_right;
            let dl = box_distance_squared(&self.nodes[left as usize].bounds, p);
            let dr = box_distance_squared(&self.nodes[right as usize].bounds, p);
            // Push the farther child first so the nearer one is searched first.
            let (near, far) = if dr < dl {
                ((right, dr), (left, dl))
            } else {
                ((left, dl), (right, dr))
            };
            for child in [far, near] {
                if child.1 <= bound_squared {
                    stack[top] = child;
                    top += 1;
                }
            }
        }
        best.map(|(k, point, feature, d2)| Closest {
            distance: d2.sqrt(),
            triangle: self.triangle_ids[k],
            point,
            feature,
        })
    }

    /// A triangle (mesh index) near `p`, found in `O(depth)`: from the root down to the
    /// child whose box is nearer (the first on ties), then the leaf's nearest triangle.
    /// Not always the nearest of the mesh ([`Bvh::closest`] backtracks for that, which
    /// from a point deep inside a closed surface visits most of the tree), but a cheap
    /// start for walks that count what lies between it and `p`. `None` for an empty tree.
    pub fn near_triangle(&self, p: DVec3) -> Option<u32> {
        let mut index = 0u32;
        let node = loop {
            let node = self.nodes.get(index as usize)?;
            if node.is_leaf() {
                break node;
            }
            let (left, right) = (index + 1, index + node.first_or_right);
            let dl = box_distance_squared(&self.nodes[left as usize].bounds, p);
            let dr = box_distance_squared(&self.nodes[right as usize].bounds, p);
            index = if dr < dl { right } else { left };
        };
        let first = node.first_or_right as usize;
        (first..first + node.count as usize)
            .map(|k| {
                let (point, _) = closest_point_on_triangle(p, self.triangles[k]);
                ((p - point).length_squared(), k)
            })
            .fold(None, |best: Option<(f64, usize)>, (d2, k)| match best {
                Some((b, _)) if b <= d2 => best,
                _ => Some((d2, k)),
            })
            .map(|(_, k)| self.triangle_ids[k])
    }

    /// Replaces the contents of `out` with the indices (ascending) of the triangles
    /// that touch the closed box, by the exact test [`triangle_box_overlap`].
    pub fn triangles_overlapping(&self, query: &Aabb, out: &mut Vec<u32>) {
        out.clear();
        if query.is_empty() {
            return;
        }
        self.for_each_box_overlapping(query, |k| {
            if triangle_box_overlap(self.triangles[k], query) {
                out.push(self.triangle_ids[k]);
            }
        });
        out.sort_unstable();
    }

    /// Calls `f` with the tree-order index of every triangle in a leaf whose box meets the
    /// closed box.
    fn for_each_box_overlapping(&self, query: &Aabb, mut f: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; STACK_SIZE];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.nodes[index as usize];
            if node.bounds.min.cmpgt(query.max).any() || node.bounds.max.cmplt(query.min).any() {
                continue;
            }
            if node.is_leaf() {
                let first = node.first_or_right as usize;
                (first..first + node.count as usize).for_each(&mut f);
            } else {
                stack[top] = index + node.first_or_right;
                stack[top + 1] = index + 1;
                top += 2;
            }
        }
    }

    /// Appends to `out` the indices of the triangles whose bounding boxes meet the
    /// closed box (a superset of [`Bvh::triangles_overlapping`], in tree order).
    pub fn boxes_overlapping(&self, query: &Aabb, out: &mut Vec<u32>) {
        if query.is_empty() {
            return;
        }
        self.for_each_box_overlapping(query, |k| {
            let [a, b, c] = self.triangles[k];
            if !(a.min(b).min(c).cmpgt(query.max).any() || a.max(b).max(c).cmplt(query.min).any()) {
                out.push(self.triangle_ids[k]);
            }
        });
    }

    /// Calls `f(index, corners)` for every triangle (mesh index) whose bounding box meets
    /// the closed box, in tree order: the candidates of a segment or box test.
    pub fn for_each_triangle_near(&self, query: &Aabb, mut f: impl FnMut(u32, [DVec3; 3])) {
        if query.is_empty() {
            return;
        }
        self.for_each_box_overlapping(query, |k| {
            let [a, b, c] = self.triangles[k];
            if !(a.min(b).min(c).cmpgt(query.max).any() || a.max(b).max(c).cmplt(query.min).any()) {
                f(self.triangle_ids[k], self.triangles[k]);
            }
        });
    }
}

/// `u vᵀ`.
#[inline]
fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

/// Squared distance from `p` to the closed box (0 inside).
#[inline]
fn box_distance_squared(b: &Aabb, p: DVec3) -> f64 {
    (b.min - p).max(p - b.max).max(DVec3::ZERO).length_squared()
}

struct BuildInput<'a> {
    corners: &'a [[DVec3; 3]],
    centroids: &'a [DVec3],
}

impl BuildInput<'_> {
    /// Nodes of the subtree over `order` (which starts at tree position `first`), in
    /// preorder; the two halves of large subtrees are built on separate threads and
    /// concatenated, which leaves the relative child offsets valid.
    fn build_parallel(&self, order: &mut [u32], first: usize) -> Vec<Node> {
        if order.len() < PARALLEL_MIN_TRIANGLES {
            let mut nodes = Vec::with_capacity(2 * order.len() / LEAF_SIZE + 1);
            self.build_sequential(order, first, &mut nodes);
            return nodes;
        }
        let mid = self.split(order);
        let (lo, hi) = order.split_at_mut(mid);
        let (left, right) = rayon::join(
            || self.build_parallel(lo, first),
            || self.build_parallel(hi, first + mid),
        );
        let mut nodes = Vec::with_capacity(1 + left.len() + right.len());
        nodes.push(parent(&left[0], &right[0], 1 + left.len()));
        nodes.extend(left);
        nodes.extend(right);
        nodes
    }

    fn build_sequential(&self, order: &mut [u32], first: usize, nodes: &mut Vec<Node>) {
        if order.len() <= LEAF_SIZE {
            nodes.push(self.leaf(order, first));
            return;
        }
        let mid = self.split(order);
        let (lo, hi) = order.split_at_mut(mid);
        let index = nodes.len();
        nodes.push(self.leaf(&[], 0)); // placeholder, replaced below
        self.build_sequential(lo, first, nodes);
        let right = nodes.len();
        self.build_sequential(hi, first + mid, nodes);
        nodes[index] = parent(&nodes[index + 1], &nodes[right], right - index);
    }

    /// Partitions `order` at its median centroid along the longest axis of the centroid
    /// box (ties by triangle index, a total order, so the halves are unique).
    fn split(&self, order: &mut [u32]) -> usize {
        let centroid_box = order.iter().fold(Aabb::EMPTY, |b, &i| {
            let c = self.centroids[i as usize];
            b.union(&Aabb::new(c, c))
        });
        let size = centroid_box.size();
        let axis = if size.x >= size.y && size.x >= size.z {
            0
        } else if size.y >= size.z {
            1
        } else {
            2
        };
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&i, &j| {
            let (ci, cj) = (self.centroids[i as usize][axis], self.centroids[j as usize][axis]);
            ci.total_cmp(&cj).then(i.cmp(&j))
        });
        mid
    }

    fn leaf(&self, order: &[u32], first: usize) -> Node {
        let mut bounds = Aabb::EMPTY;
        let (mut area_normal, mut area, mut weighted_centroid) = (DVec3::ZERO, 0.0, DVec3::ZERO);
        for &i in order {
            let [a, b, c] = self.corners[i as usize];
            bounds = bounds.union(&Aabb::new(a.min(b).min(c), a.max(b).max(c)));
            let n = 0.5 * (b - a).cross(c - a);
            let triangle_area = n.length();
            area_normal += n;
            area += triangle_area;
            weighted_centroid += triangle_area * self.centroids[i as usize];
        }
        let center = if area > 0.0 {
            weighted_centroid / area
        } else {
            bounds.center()
        };
        let first_moment = order.iter().fold(DMat3::ZERO, |m, &i| {
            let [a, b, c] = self.corners[i as usize];
            m + outer(self.centroids[i as usize] - center, 0.5 * (b - a).cross(c - a))
        });
        let radius = order
            .iter()
            .flat_map(|&i| self.corners[i as usize])
            .map(|v| (v - center).length())
            .fold(0.0, f64::max);
        // ∫_t |x − c|² dA = A (|x̄ − c|² + (|a − x̄|² + |b − x̄|² + |c − x̄|²) / 12).
        let second_moment = order
            .iter()
            .map(|&i| {
                let [a, b, c] = self.corners[i as usize];
                let x = self.centroids[i as usize];
                let triangle_area = 0.5 * (b - a).cross(c - a).length();
                let spread = (a - x).length_squared() + (b - x).length_squared() + (c - x).length_squared();
                triangle_area * ((x - center).length_squared() + spread / 12.0)
            })
            .sum();
        Node {
            bounds,
            area_normal,
            first_moment,
            area,
            second_moment,
            center,
            radius,
            first_or_right: first as u32,
            count: order.len() as u32,
        }
    }
}

/// An internal node over two children, `right_offset` nodes before the right one.
fn parent(left: &Node, right: &Node, right_offset: usize) -> Node {
    let bounds = left.bounds.union(&right.bounds);
    let area = left.area + right.area;
    let center = if area > 0.0 {
        (left.center * left.area + right.center * right.area) / area
    } else {
        bounds.center()
    };
    // Two upper bounds on the extent from `center`: through the children's spheres,
    // and the farthest corner of the box; keep the smaller.
    let through_children =
        ((left.center - center).length() + left.radius).max((right.center - center).length() + right.radius);
    let box_corner = (bounds.max - center).abs().max((bounds.min - center).abs()).length();
    Node {
        bounds,
        area_normal: left.area_normal + right.area_normal,
        // Moments move to the new centre: Σ(x − c)Nᵀ = Σ(x − c_child)Nᵀ + (c_child − c)N_childᵀ.
        first_moment: left.first_moment
            + outer(left.center - center, left.area_normal)
            + right.first_moment
            + outer(right.center - center, right.area_normal),
        area,
        // Parallel axes: each child's centre is its area-weighted centroid.
        second_moment: left.second_moment
            + left.area * (left.center - center).length_squared()
            + right.second_moment
            + right.area * (right.center - center).length_squared(),
        center,
        radius: through_children.min(box_corner),
        first_or_right: right_offset as u32,
        count: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_mesh() {
        let bvh = Bvh::build(&TriMesh::default());
        assert_eq!(bvh.closest(DVec3::ZERO), None);
        assert_eq!(bvh.winding_number(DVec3::ZERO), 0.0);
        let mut out = vec![7];
        bvh.triangles_overlapping(&Aabb::new(DVec3::ZERO, DVec3::ONE), &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn cube_queries() {
        let cube = TriMesh::from_aabb(&Aabb::new(DVec3::ZERO, DVec3::ONE));
        let bvh = Bvh::build(&cube);
        let c = bvh.closest(DVec3::new(0.5, 0.5, 3.0)).unwrap();
        assert_eq!(c.distance, 2.0);
        assert_eq!(c.point, DVec3::new(0.5, 0.5, 1.0));
        assert!(bvh.closest_within(DVec3::new(0.5, 0.5, 3.0), 1.9).is_none());
        assert!(bvh.closest_within(DVec3::new(0.5, 0.5, 3.0), 2.0).is_some());
        let c = bvh.closest(DVec3::splat(2.0)).unwrap();
        assert_eq!((c.point, c.distance), (DVec3::ONE, 3f64.sqrt()));
        assert!(matches!(c.feature, Feature::Vertex(_)));
        assert!((bvh.winding_number(DVec3::splat(0.5)) - 1.0).abs() < 1e-12);
        assert!(bvh.winding_number(DVec3::splat(5.0)).abs() < 1e-3);
        let mut out = Vec::new();
        bvh.triangles_overlapping(&Aabb::new(DVec3::splat(0.25), DVec3::splat(0.75)), &mut out);
        assert!(out.is_empty());
        bvh.triangles_overlapping(
            &Aabb::new(DVec3::new(0.25, 0.25, 0.9), DVec3::new(0.75, 0.75, 1.0)),
            &mut out,
        );
        assert_eq!(out, vec![2, 3]); // the z = 1 face, touched from inside
    }

    /// The one-descent triangle is a real triangle of the mesh, never nearer than the
    /// nearest, and the nearest itself when the tree is a single leaf.
    #[test]
    fn near_triangle_is_a_triangle_no_nearer_than_the_nearest() {
        for (name, mesh) in crate::unclean::corpus() {
            let bvh = Bvh::build(&mesh);
            let b = mesh.bounds();
            for k in 0..200 {
                let f = k as f64 / 200.0;
                let p = b.min - 0.3 * b.size() + DVec3::new(f, (f * 7.3).fract(), (f * 13.7).fract()) * 1.6 * b.size();
                let near = bvh.near_triangle(p).expect("a non-empty mesh");
                let (q, _) = closest_point_on_triangle(p, mesh.triangle(near as usize));
                let nearest = bvh.closest(p).expect("a non-empty mesh");
                assert!((p - q).length() >= nearest.distance, "{name}: {p}");
            }
        }
        let tri = TriMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            triangles: vec![[0, 1, 2], [0, 1, 3], [0, 2, 3]],
        };
        let bvh = Bvh::build(&tri);
        for p in [
            DVec3::new(0.2, 0.2, -1.0),
            DVec3::new(0.2, -1.0, 0.2),
            DVec3::new(-1.0, 0.2, 0.2),
        ] {
            assert_eq!(bvh.near_triangle(p), Some(bvh.closest(p).unwrap().triangle), "{p}");
        }
    }
}
