//! Signed distance to a mesh: exact magnitude, sign from the winding number.

use glam::DVec3;

use crate::Bvh;

/// Signed distance from `p` to the mesh, negative inside (world units).
///
/// The magnitude is the exact distance to the nearest triangle ([`Bvh::closest`]); the
/// sign is **inside iff the fast winding number is ≥ ½** ([`Bvh::winding_number`]).
/// This is volga's documented answer for every mesh: for a closed, outward-oriented
/// mesh it is the usual inside test, and for an open one (the Stanford bunny's holes,
/// the teapot's separate parts) it fills a hole as the surface around it suggests
/// instead of depending on which ray a parity test happened to shoot. Feature-based
/// signs (angle-weighted pseudonormals) are not used because they are only defined
/// for closed manifolds. An empty mesh gives `+∞`.
pub fn signed_distance(bvh: &Bvh, p: DVec3) -> f64 {
    signed_distance_within(bvh, p, f64::INFINITY).unwrap_or(f64::INFINITY)
}

/// [`signed_distance`] for a narrow band: `None` when the surface is farther than
/// `max_distance`, in which case the winding number is not evaluated at all.
pub fn signed_distance_within(bvh: &Bvh, p: DVec3, max_distance: f64) -> Option<f64> {
    let closest = bvh.closest_within(p, max_distance)?;
    let inside = bvh.winding_number(p) >= 0.5;
    Some(if inside { -closest.distance } else { closest.distance })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TriMesh;
    use volga_core::Aabb;

    #[test]
    fn cube_matches_the_box_distance() {
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::ONE);
        let bvh = Bvh::build(&TriMesh::from_aabb(&b));
        let exact = |p: DVec3| {
            let q = p.abs() - DVec3::ONE;
            q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
        };
        for p in [
            DVec3::ZERO,
            DVec3::new(0.5, -0.2, 0.9),
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(2.0, -2.0, 0.5),
        ] {
            assert!((signed_distance(&bvh, p) - exact(p)).abs() < 1e-12, "{p}");
        }
        assert_eq!(signed_distance_within(&bvh, DVec3::new(3.0, 0.0, 0.0), 1.0), None);
        assert_eq!(
            signed_distance(&Bvh::build(&TriMesh::default()), DVec3::ZERO),
            f64::INFINITY
        );
    }
}
