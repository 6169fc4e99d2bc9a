//! Moving the integer `I = w_M + w_C` along a segment: it changes by ±1 exactly where
//! the segment crosses a sheet of the mesh or of a cap, so the signed count of those
//! crossings, each **proven** ([`volga_mesh::signed_crossing`], the test the ADF's
//! `CappedWinding` counts sheets with), carries a known `I` from one point to another
//! without a winding-number query.

use glam::DVec3;
use volga_core::Aabb;
use volga_mesh::signed_crossing;

use super::oracle::SignOracle;
use crate::mesh::MeshVoxelizer;

/// The side of `p` of the plane of `[a, b, c]`: `Some(true)` behind (away from the normal
/// `(b − a) × (c − a)`), `Some(false)` in front, `None` within the rounding bound of the
/// triple product (as in [`signed_crossing`]).
fn behind(p: DVec3, [a, b, c]: [DVec3; 3]) -> Option<bool> {
    let v = -(a - p).dot((b - p).cross(c - p));
    let bound = 1e-12 * (a - p).length() * (b - p).length() * (c - p).length();
    (v.abs() > bound).then_some(v < 0.0)
}

impl SignOracle {
    /// The proven change of `I` from `a` to `b` (the segment must not cross the mesh):
    /// the signed crossings of the caps, `None` when one is too close to call.
    pub(crate) fn cap_crossings(&self, a: DVec3, b: DVec3, scratch: &mut Vec<u32>) -> Option<i64> {
        let Some(cap) = &self.cap else {
            return Some(0);
        };
        scratch.clear();
        cap.boxes_overlapping(&Aabb::new(a.min(b), a.max(b)), scratch);
        let mut total = 0;
        for &c in scratch.iter() {
            total += signed_crossing(a, b, self.cap_triangles[c as usize])?;
        }
        Some(total)
    }
}

impl MeshVoxelizer {
    /// `I(p)` proven from trusted triangle `t` (voxelizer index): just off its centroid
    /// on `p`'s side `I` is the region's `I⁺` (plus one behind); from there to `p` it
    /// changes by the signed crossings of every other triangle of the mesh and of the
    /// caps, each proven. `None` when `p` is too close to `t`'s plane or a crossing is
    /// too close to call. Without caps (a closed mesh) `I` is the winding number itself.
    pub(crate) fn integer_from(&self, t: usize, p: DVec3) -> Option<i64> {
        let sign = &self.sign;
        if !sign.trusted[t] {
            return None;
        }
        let tri = self.triangles[t];
        let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
        let mut total = sign.front[t] + behind(p, tri)? as i64;
        let segment = Aabb::new(centroid.min(p), centroid.max(p));
        let own = self.to_mesh[t];
        let mut ambiguous = false;
        self.bvh.for_each_triangle_near(&segment, |id, corners| {
            if id != own && !ambiguous {
                match signed_crossing(centroid, p, corners) {
                    Some(n) => total += n,
                    None => ambiguous = true,
                }
            }
        });
        if ambiguous {
            return None;
        }
        CROSSING_SCRATCH
            .with_borrow_mut(|scratch| sign.cap_crossings(centroid, p, scratch))
            .map(|c| total + c)
    }

    /// `I(p)` carried from a triangle near `p` ([`MeshVoxelizer::integer_from`]) for a
    /// point off the mesh and the caps: first the one a single descent of the tree finds
    /// (cheap; the crossings of anything between it and `p` are counted), then the
    /// nearest one; `None` when neither proves it.
    pub(crate) fn integer_near(&self, p: DVec3) -> Option<i64> {
        if self.sign.closed {
            return None;
        }
        let near = self.bvh.near_triangle(p)?;
        self.integer_from(self.from_mesh[near as usize] as usize, p)
            .or_else(|| {
                let nearest = self.bvh.closest(p)?.triangle;
                (nearest != near)
                    .then(|| self.integer_from(self.from_mesh[nearest as usize] as usize, p))
                    .flatten()
            })
    }
}

thread_local! {
    /// Candidate caps of one crossing count, reused.
    pub(crate) static CROSSING_SCRATCH: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: [DVec3; 3] = [DVec3::ZERO, DVec3::X, DVec3::Y]; // normal +z

    #[test]
    fn crossings_by_direction() {
        let (front, back) = (DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.2, 0.2, -1.0));
        assert_eq!(signed_crossing(front, back, T), Some(1));
        assert_eq!(signed_crossing(back, front, T), Some(-1));
        assert_eq!((behind(front, T), behind(back, T)), (Some(false), Some(true)));
        // Beside the triangle, on one side, parallel to it.
        assert_eq!(
            signed_crossing(DVec3::new(2.0, 2.0, 1.0), DVec3::new(2.0, 2.0, -1.0), T),
            Some(0)
        );
        assert_eq!(signed_crossing(front, front + DVec3::X, T), Some(0));
        // Through an edge, a corner, or ending on the triangle: not decided.
        assert_eq!(
            signed_crossing(DVec3::new(0.5, 0.0, 1.0), DVec3::new(0.5, 0.0, -1.0), T),
            None
        );
        assert_eq!(
            signed_crossing(DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, -1.0), T),
            None
        );
        assert_eq!(signed_crossing(front, DVec3::new(0.2, 0.2, 0.0), T), None);
        assert_eq!(behind(DVec3::new(0.7, 0.7, 0.0), T), None);
        // A zero-area triangle: `I` does not jump across it.
        let flat = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert_eq!(
            signed_crossing(DVec3::new(0.5, 0.0, 1.0), DVec3::new(0.5, 0.0, -1.0), flat),
            Some(0)
        );
    }

    /// Against the winding number of a closed tetrahedron: the jump of `w` along random
    /// segments equals the signed crossings summed over its faces.
    #[test]
    fn crossings_match_winding_jumps() {
        let v = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let faces = [
            [v[0], v[2], v[1]],
            [v[0], v[1], v[3]],
            [v[0], v[3], v[2]],
            [v[1], v[2], v[3]],
        ];
        let w =
            |x: DVec3| faces.iter().map(|&f| volga_mesh::solid_angle(x, f)).sum::<f64>() / (4.0 * std::f64::consts::PI);
        let mut state = 12345u64;
        let mut rand = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 0.5
        };
        let mut decided = 0;
        for _ in 0..2000 {
            let (a, b) = (DVec3::new(rand(), rand(), rand()), DVec3::new(rand(), rand(), rand()));
            let sum: Option<i64> = faces.iter().map(|&f| signed_crossing(a, b, f)).sum();
            if let Some(n) = sum {
                decided += 1;
                assert_eq!((w(b) - w(a)).round() as i64, n, "{a} → {b}");
            }
        }
        assert!(decided > 1900);
    }
}
