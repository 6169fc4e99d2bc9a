use glam::{DAffine3, DVec3};
use volga_core::Aabb;

use crate::InvalidMesh;

/// A triangle soup with shared vertices, in **world space** (`f64`).
///
/// Triangles are counter-clockwise seen from outside (right-hand rule: the normal
/// `(b − a) × (c − a)` points out), which is what makes the winding number 1 inside a
/// closed mesh. Loaders keep the vertices as the file lists them; topology queries
/// ([`TriMesh::edge_stats`]) weld exactly-equal positions first, because OBJ and glTF
/// split vertices at texture seams and a seam is not a hole.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions in world coordinates, which `triangles` index. Must be finite
    /// ([`TriMesh::validate`]); positions no triangle uses are allowed and ignored by the
    /// queries.
    pub positions: Vec<DVec3>,
    /// Each triangle as three 0-based indices into `positions`, counter-clockwise seen
    /// from outside; every index must be `< positions.len()`. Degenerate triangles
    /// (repeated indices, collinear corners) are allowed.
    pub triangles: Vec<[u32; 3]>,
}

/// Edge counts of a mesh after welding exactly-equal positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeStats {
    /// Distinct positions.
    pub welded_vertices: usize,
    /// Distinct undirected edges between two different welded positions.
    pub edges: usize,
    /// Edges used by exactly one triangle: the rim of a hole.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Boundary edges counted by vertex index, without welding: what a tool that
    /// trusts the file's connectivity reports. The excess over `boundary_edges` is
    /// seams where the file repeats a position (the Utah teapot's patch seams).
    pub unwelded_boundary_edges: usize,
}

impl TriMesh {
    /// A mesh whose indices are in range and whose positions are finite.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self, InvalidMesh> {
        let mesh = TriMesh { positions, triangles };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks what [`TriMesh::new`] checks; loaders guarantee it.
    pub fn validate(&self) -> Result<(), InvalidMesh> {
        if u32::try_from(self.positions.len()).is_err() {
            return Err(InvalidMesh::TooManyVertices(self.positions.len()));
        }
        if let Some((vertex, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(InvalidMesh::NonFiniteVertex {
                vertex,
                position: p.to_array(),
            });
        }
        for (triangle, t) in self.triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= self.positions.len()) {
                return Err(InvalidMesh::IndexOutOfRange {
                    triangle,
                    index,
                    vertex_count: self.positions.len(),
                });
            }
        }
        Ok(())
    }

    /// The closed box `aabb` as 12 outward-facing triangles on its 8 corners.
    pub fn from_aabb(aabb: &Aabb) -> TriMesh {
        let (lo, hi) = (aabb.min, aabb.max);
        // Corner k has x from bit 0, y from bit 1, z from bit 2.
        let positions = (0..8)
            .map(|k| {
                DVec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect();
        let triangles = vec![
            [0, 2, 3], // z = lo, normal −z
            [0, 3, 1],
            [4, 5, 7], // z = hi, normal +z
            [4, 7, 6],
            [0, 1, 5], // y = lo, normal −y
            [0, 5, 4],
            [2, 6, 7], // y = hi, normal +y
            [2, 7, 3],
            [0, 4, 6], // x = lo, normal −x
            [0, 6, 2],
            [1, 3, 7], // x = hi, normal +x
            [1, 7, 5],
        ];
        TriMesh { positions, triangles }
    }

    /// Number of triangles (`triangles.len()`), degenerate ones included.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The three corners of triangle `i`. Panics if `i` or its indices are out of range.
    #[inline]
    pub fn triangle(&self, i: usize) -> [DVec3; 3] {
        self.triangles[i].map(|v| self.positions[v as usize])
    }

    /// Box of the vertices that triangles use ([`Aabb::EMPTY`] without triangles).
    pub fn bounds(&self) -> Aabb {
        self.triangles.iter().flatten().fold(Aabb::EMPTY, |b, &v| {
            b.union(&Aabb::new(self.positions[v as usize], self.positions[v as usize]))
        })
    }

    /// Triangles whose area is exactly zero in floating point (repeated or collinear
    /// corners): `(b − a) × (c − a) == 0`.
    pub fn degenerate_triangle_count(&self) -> usize {
        (0..self.triangles.len())
            .filter(|&i| {
                let [a, b, c] = self.triangle(i);
                (b - a).cross(c - a) == DVec3::ZERO
            })
            .count()
    }

    /// Edge incidences after welding exactly-equal positions (`-0.0 == 0.0`).
    ///
    /// An edge is counted once per triangle side that spans it, whatever the side's
    /// direction; sides whose two ends weld to the same position are skipped.
    pub fn edge_stats(&self) -> EdgeStats {
        let (weld, welded_vertices) = self.weld_exact();
        let welded = edge_incidences(&self.triangles, |v| weld[v as usize]);
        let unwelded = edge_incidences(&self.triangles, |v| v);
        EdgeStats {
            welded_vertices,
            edges: welded.edges,
            boundary_edges: welded.boundary_edges,
            non_manifold_edges: welded.non_manifold_edges,
            unwelded_boundary_edges: unwelded.boundary_edges,
        }
    }

    /// Points every `spacing` (or closer) along the edges whose two triangles meet at more
    /// than `min_degrees` (edges by vertex index, in index order; edges in one triangle or in
    /// more than two are skipped): where a mesher's chamfer is measured.
    pub fn sharp_edge_points(&self, min_degrees: f64, spacing: f64) -> Vec<DVec3> {
        let mut edges: Vec<((u32, u32), usize)> = Vec::with_capacity(self.triangles.len() * 3);
        for (t, tri) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                edges.push(((a.min(b), a.max(b)), t));
            }
        }
        edges.sort_unstable();
        let normal = |t: usize| {
            let [p, q, r] = self.triangle(t);
            (q - p).cross(r - p).normalize_or_zero()
        };
        let cos = min_degrees.to_radians().cos();
        let mut out = Vec::new();
        for run in edges.chunk_by(|x, y| x.0 == y.0) {
            if let [(edge, t0), (_, t1)] = run {
                if normal(*t0).dot(normal(*t1)) < cos {
                    let (pa, pb) = (self.positions[edge.0 as usize], self.positions[edge.1 as usize]);
                    let steps = (pa.distance(pb) / spacing).ceil().max(1.0) as usize;
                    out.extend((0..=steps).map(|i| pa.lerp(pb, i as f64 / steps as f64)));
                }
            }
        }
        out
    }

    /// Edges used by exactly one triangle (see [`TriMesh::edge_stats`]).
    pub fn boundary_edge_count(&self) -> usize {
        self.edge_stats().boundary_edges
    }

    /// Edges used by three or more triangles (see [`TriMesh::edge_stats`]).
    pub fn non_manifold_edge_count(&self) -> usize {
        self.edge_stats().non_manifold_edges
    }

    /// No boundary edges: every edge is shared by at least two triangles, so the
    /// surface encloses a volume and the winding number is an integer off the surface
    /// (for consistently oriented triangles). Non-manifold edges are allowed and
    /// reported separately by [`TriMesh::non_manifold_edge_count`].
    pub fn is_closed(&self) -> bool {
        self.boundary_edge_count() == 0
    }

    /// The mesh mapped by `transform`. A mirroring transform (negative determinant)
    /// also reverses each triangle's corner order, so outward normals stay outward and
    /// inside stays inside.
    pub fn transformed(&self, transform: &DAffine3) -> TriMesh {
        let positions = self.positions.iter().map(|&p| transform.transform_point3(p)).collect();
        let mirrored = transform.matrix3.determinant() < 0.0;
        let triangles = self
            .triangles
            .iter()
            .map(|&[a, b, c]| if mirrored { [a, c, b] } else { [a, b, c] })
            .collect();
        TriMesh { positions, triangles }
    }

    /// The mesh with every position moved by `offset` (world units); triangles unchanged.
    pub fn translated(&self, offset: DVec3) -> TriMesh {
        TriMesh {
            positions: self.positions.iter().map(|&p| p + offset).collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// Maps each vertex to the id of its position class and returns the class count.
    fn weld_exact(&self) -> (Vec<u32>, usize) {
        // Sort vertex ids by position bits, then number the runs of equal positions.
        let key = |p: DVec3| (p + DVec3::ZERO).to_array().map(f64::to_bits); // + 0.0 folds −0.0 into 0.0
        let mut order: Vec<u32> = (0..self.positions.len() as u32).collect();
        order.sort_unstable_by_key(|&v| (key(self.positions[v as usize]), v));
        let mut weld = vec![0u32; self.positions.len()];
        let mut classes = 0usize;
        let mut previous = None;
        for &v in &order {
            let k = key(self.positions[v as usize]);
            if previous != Some(k) {
                classes += 1;
                previous = Some(k);
            }
            weld[v as usize] = classes as u32 - 1;
        }
        (weld, classes)
    }
}

struct Incidences {
    edges: usize,
    boundary_edges: usize,
    non_manifold_edges: usize,
}

/// Counts undirected edges by how many triangle sides span them, with vertices
/// identified by `id`; sides whose ends share an id are skipped.
fn edge_incidences(triangles: &[[u32; 3]], id: impl Fn(u32) -> u32) -> Incidences {
    let mut keys: Vec<u64> = Vec::with_capacity(triangles.len() * 3);
    for t in triangles {
        let w = t.map(&id);
        for k in 0..3 {
            let (a, b) = (w[k], w[(k + 1) % 3]);
            if a != b {
                keys.push(((a.min(b) as u64) << 32) | a.max(b) as u64);
            }
        }
    }
    keys.sort_unstable();
    let mut counts = Incidences {
        edges: 0,
        boundary_edges: 0,
        non_manifold_edges: 0,
    };
    for run in keys.chunk_by(|x, y| x == y) {
        counts.edges += 1;
        match run.len() {
            1 => counts.boundary_edges += 1,
            2 => {}
            _ => counts.non_manifold_edges += 1,
        }
    }
    counts
}

#[cfg(test)]
mod tests {
    #[test]
    fn sharp_edge_points_of_a_box_lie_on_its_twelve_edges() {
        let b = volga_core::Aabb::new(glam::DVec3::new(-1.0, -0.5, 0.0), glam::DVec3::new(1.0, 0.5, 2.0));
        let mesh = super::TriMesh::from_aabb(&b);
        let points = mesh.sharp_edge_points(30.0, 0.1);
        // 12 edges of lengths 2, 1 and 2 (four each): 20, 10 and 20 steps, +1 end each.
        assert_eq!(points.len(), 4 * (21 + 11 + 21));
        for p in &points {
            let on = (0..3).filter(|&k| p[k] == b.min[k] || p[k] == b.max[k]).count();
            assert!(on >= 2, "{p} is not on an edge");
        }
        assert!(mesh.sharp_edge_points(95.0, 0.1).is_empty());
    }

    use super::*;

    fn unit_box() -> TriMesh {
        TriMesh::from_aabb(&Aabb::new(DVec3::ZERO, DVec3::ONE))
    }

    #[test]
    fn box_is_closed_and_outward() {
        let m = unit_box();
        let stats = m.edge_stats();
        assert_eq!(
            stats,
            EdgeStats {
                welded_vertices: 8,
                edges: 18,
                boundary_edges: 0,
                non_manifold_edges: 0,
                unwelded_boundary_edges: 0,
            }
        );
        let centre = DVec3::splat(0.5);
        for i in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(i);
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0 - centre) > 0.0, "triangle {i} faces inwards");
        }
    }

    #[test]
    fn seams_weld_and_holes_count() {
        let mut m = unit_box();
        // Split vertex 0 as a texture seam would: a copy used by half its triangles.
        m.positions.push(m.positions[0]);
        m.triangles[0][0] = 8;
        m.triangles[4][0] = 8;
        assert!(m.is_closed());
        // By index, the copy's four edges and their four partners are open.
        assert_eq!(m.edge_stats().unwelded_boundary_edges, 8);
        m.triangles.pop();
        assert_eq!(m.boundary_edge_count(), 3);
        assert!(!m.is_closed());
    }

    #[test]
    fn mirroring_keeps_orientation() {
        let m = unit_box().transformed(&DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0)));
        let centre = DVec3::new(-0.5, 0.5, 0.5);
        for i in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(i);
            assert!((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0.0);
        }
    }

    #[test]
    fn validation_and_degenerates() {
        assert!(TriMesh::new(vec![DVec3::ZERO], vec![[0, 0, 1]]).is_err());
        assert!(TriMesh::new(vec![DVec3::NAN], vec![]).is_err());
        let m = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], vec![[0, 1, 2], [0, 0, 1]]).unwrap();
        assert_eq!(m.degenerate_triangle_count(), 2);
        assert_eq!(m.bounds(), Aabb::new(DVec3::ZERO, DVec3::X * 2.0));
    }
}
