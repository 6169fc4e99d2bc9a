//! What the extraction tests share: the independent manifold check (counted from the
//! triangles alone, never from the extractor's own bookkeeping) and exact distance fields.

use std::collections::HashMap;

use glam::DVec3;
use volga_core::{Aabb, Field, FieldKind};
use volga_mesh::TriMesh;

/// Every undirected edge in exactly two triangles, once in each direction; no triangle
/// repeats a vertex; every vertex used and its link one cycle.
pub fn check_closed_manifold(mesh: &TriMesh, what: &str) {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "{what}: triangle {t:?} repeats a vertex"
        );
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "{what}: directed edge {a}->{b} used {n} times");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "{what}: edge {a}-{b} not in exactly two faces"
        );
    }
    let mut next: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            next.entry(t[k]).or_default().push((t[(k + 1) % 3], t[(k + 2) % 3]));
        }
    }
    assert_eq!(next.len(), mesh.positions.len(), "{what}: unused vertices");
    for (v, fan) in &next {
        let map: HashMap<u32, u32> = fan.iter().copied().collect();
        assert_eq!(map.len(), fan.len(), "{what}: vertex {v} fan repeats");
        let start = fan[0].0;
        let (mut cur, mut steps) = (start, 0);
        loop {
            cur = map[&cur];
            steps += 1;
            if cur == start {
                break;
            }
            assert!(steps <= fan.len(), "{what}: vertex {v}: link is not a cycle");
        }
        assert_eq!(steps, fan.len(), "{what}: vertex {v}: link is more than one disc");
    }
}

/// An exact signed distance given as a closure (1-Lipschitz, so ranges are centre ±
/// half-diagonal).
pub struct Sdf<F>(pub F, pub Aabb);

impl<F: Fn(DVec3) -> f64 + Sync> Field for Sdf<F> {
    fn kind(&self) -> FieldKind {
        FieldKind::SignedDistance
    }
    fn bounds(&self) -> Aabb {
        self.1
    }
    fn value(&self, p: DVec3) -> f64 {
        (self.0)(p)
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(1e-6)
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        let d = self.value(b.center());
        let h = b.size().length() * 0.5;
        (d - h, d + h)
    }
}
