//! Point queries on any mesh, every sign proven: exact distance, certified winding number
//! and certified inside test, one point or a batch (in parallel, the same bits for any
//! thread count).

use glam::DVec3;
use rayon::prelude::*;

use crate::{Bvh, CappedWinding, TriMesh};

/// Points per parallel job of the batch queries.
const CHUNK: usize = 1024;

/// A mesh prepared for point queries: its BVH (exact nearest triangle, winding-number
/// moments) and its boundary cycle closed by caps ([`CappedWinding`], the certified inside
/// test that costs a few cap triangles near holes instead of the whole mesh).
#[derive(Debug, Clone)]
pub struct MeshQueries {
    capped: CappedWinding,
}

impl MeshQueries {
    /// Prepares `mesh` for queries: the cones capping its boundary ([`cap_triangles`]) and
    /// the BVHs of the mesh, the caps and both together ([`CappedWinding::new`]). Copies
    /// what it needs, so `mesh` is not borrowed. Panics if a triangle index is out of range
    /// (a mesh from the loaders or [`TriMesh::new`] never has one).
    ///
    /// [`cap_triangles`]: crate::cap_triangles
    pub fn new(mesh: &TriMesh) -> MeshQueries {
        MeshQueries {
            capped: CappedWinding::new(mesh),
        }
    }

    /// The mesh's BVH.
    pub fn bvh(&self) -> &Bvh {
        self.capped.mesh_bvh()
    }

    /// Signed distance from `world_pos` to the mesh, negative inside (world units): the exact
    /// distance to the nearest triangle, negated where the generalized winding number is
    /// ≥ ½ (proven, [`CappedWinding::inside`]). On the surface the distance is 0. An empty
    /// mesh gives `+∞`.
    pub fn signed_distance(&self, world_pos: DVec3) -> f64 {
        let Some(closest) = self.bvh().closest(world_pos) else {
            return f64::INFINITY;
        };
        if self.capped.inside(world_pos).0 {
            -closest.distance
        } else {
            closest.distance
        }
    }

    /// The generalized winding number at `world_pos`, within `tolerance` of the exact sum
    /// of the triangles' solid angles (certified: the far-field expansions are refined until
    /// their error bound is below it; a tolerance of 0 sums every triangle).
    pub fn winding_number(&self, world_pos: DVec3, tolerance: f64) -> f64 {
        self.bvh()
            .winding_number_bounded(world_pos, None, |_, error| error <= tolerance)
            .value
    }

    /// Whether the winding number at `world_pos` is ≥ ½, proven.
    pub fn inside(&self, world_pos: DVec3) -> bool {
        self.capped.inside(world_pos).0
    }

    /// [`MeshQueries::signed_distance`] of every point, in parallel.
    pub fn signed_distances(&self, world_pos: &[DVec3]) -> Vec<f64> {
        batch(world_pos, |p| self.signed_distance(p))
    }

    /// [`MeshQueries::winding_number`] of every point, in parallel.
    pub fn winding_numbers(&self, world_pos: &[DVec3], tolerance: f64) -> Vec<f64> {
        batch(world_pos, |p| self.winding_number(p, tolerance))
    }

    /// The fast winding number ([`Bvh::winding_number`]: two-term far-field expansion beyond
    /// twice a node's radius, exact solid angles nearer; Barill et al. 2018) of every point,
    /// in parallel. Not certified: errors are typically below 1e-2 (measured in that
    /// method's doc), far below the ½ that decides inside; [`MeshQueries::insides`] proves it.
    pub fn fast_winding_numbers(&self, world_pos: &[DVec3]) -> Vec<f64> {
        batch(world_pos, |p| self.bvh().winding_number(p))
    }

    /// [`MeshQueries::inside`] of every point, in parallel.
    pub fn insides(&self, world_pos: &[DVec3]) -> Vec<bool> {
        batch(world_pos, |p| self.inside(p))
    }
}

/// `f` of every point, in parallel. Points are visited in Morton order of their position
/// (nearby queries share the BVH nodes they read, about 1.5× faster on scattered points)
/// and the answers put back in the input order; each answer depends on its point alone,
/// so the result is the same for any thread count.
fn batch<T: Send + Sync + Default + Clone>(points: &[DVec3], f: impl Fn(DVec3) -> T + Sync) -> Vec<T> {
    let order = morton_order(points);
    let mut sorted = vec![T::default(); points.len()];
    sorted
        .par_chunks_mut(CHUNK)
        .zip(order.par_chunks(CHUNK))
        .for_each(|(o, idx)| {
            for (o, &i) in o.iter_mut().zip(idx) {
                *o = f(points[i]);
            }
        });
    let mut out = vec![T::default(); points.len()];
    for (&i, v) in order.iter().zip(sorted) {
        out[i] = v;
    }
    out
}

/// The indices of `points` sorted by the Morton code of their position in the points'
/// bounding box (10 bits per axis; ties by index).
fn morton_order(points: &[DVec3]) -> Vec<usize> {
    let (lo, hi) = points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let scale = 1023.0 / (hi - lo).max(DVec3::splat(f64::MIN_POSITIVE));
    let spread = |v: u64| {
        let mut x = v & 0x3ff;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    let mut keyed: Vec<(u64, usize)> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let q = ((*p - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(1023.0));
            let key = spread(q.x as u64) << 2 | spread(q.y as u64) << 1 | spread(q.z as u64);
            (key, i)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::unclean;
    use volga_core::Aabb;

    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn cube_distances_and_signs_are_exact() {
        let cube = TriMesh::from_aabb(&Aabb::new(DVec3::splat(-1.0), DVec3::ONE));
        let q = MeshQueries::new(&cube);
        let exact = |p: DVec3| {
            let d = p.abs() - DVec3::ONE;
            d.max(DVec3::ZERO).length() + d.max_element().min(0.0)
        };
        let mut seed = 7;
        let points: Vec<DVec3> = (0..500)
            .map(|_| DVec3::new(rng(&mut seed), rng(&mut seed), rng(&mut seed)) * 4.0 - 2.0)
            .collect();
        let d = q.signed_distances(&points);
        for (p, d) in points.iter().zip(&d) {
            assert!((d - exact(*p)).abs() < 1e-12, "{p}: {d} against {}", exact(*p));
        }
        assert!((q.winding_number(DVec3::ZERO, 0.0) - 1.0).abs() < 1e-12);
        assert!(q.winding_number(DVec3::splat(3.0), 1e-9).abs() < 1e-9);
    }

    #[test]
    fn signs_match_the_brute_force_winding_number_on_unclean_meshes() {
        let mut seed = 11;
        for (name, mesh) in unclean::corpus() {
            let q = MeshQueries::new(&mesh);
            let b = mesh.bounds();
            let points: Vec<DVec3> = (0..200)
                .map(|_| b.min + (b.max - b.min) * DVec3::new(rng(&mut seed), rng(&mut seed), rng(&mut seed)))
                .collect();
            let inside = q.insides(&points);
            let d = q.signed_distances(&points);
            for (k, p) in points.iter().enumerate() {
                let w = crate::winding_number(&mesh, *p);
                if (w - 0.5).abs() > 1e-9 {
                    assert_eq!(inside[k], w >= 0.5, "{name} at {p}: w = {w}");
                    assert_eq!(d[k] < 0.0, w >= 0.5, "{name} at {p}: d = {}, w = {w}", d[k]);
                }
                let wn = q.winding_number(*p, 1e-10);
                assert!((wn - w).abs() <= 1e-9, "{name} at {p}: {wn} against {w}");
            }
        }
    }

    #[test]
    fn morton_order_is_a_permutation() {
        let mut seed = 5;
        let points: Vec<DVec3> = (0..5000)
            .map(|_| DVec3::new(rng(&mut seed), rng(&mut seed), rng(&mut seed)) * 1e6)
            .chain([DVec3::ZERO; 3])
            .collect();
        let mut order = morton_order(&points);
        order.sort_unstable();
        assert_eq!(order, (0..points.len()).collect::<Vec<_>>());
        assert!(morton_order(&[]).is_empty());
        assert_eq!(morton_order(&[DVec3::ONE]), vec![0]);
    }

    #[test]
    fn batches_are_the_same_for_any_thread_count() {
        let mesh = unclean::uv_sphere(DVec3::splat(0.1), 1.0, 12, 24);
        let q = MeshQueries::new(&mesh);
        let mut seed = 3;
        let points: Vec<DVec3> = (0..3000)
            .map(|_| DVec3::new(rng(&mut seed), rng(&mut seed), rng(&mut seed)) * 3.0 - 1.5)
            .collect();
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
        let a = one.install(|| q.signed_distances(&points));
        let b = three.install(|| q.signed_distances(&points));
        assert_eq!(
            a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
}
