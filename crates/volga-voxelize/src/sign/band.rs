//! Winding-number proofs for single points: the sign of a band voxel from its nearest
//! triangle's certified interval, the caps' winding number or, last, the mesh's
//! certified winding number; and the certified queries (`w = I − w_C`) that the flood
//! and region proofs share.

use glam::DVec3;
use volga_mesh::{closest_point_with_frame, Feature};

use super::crossings::CROSSING_SCRATCH;
use super::SignStats;
use crate::mesh::MeshVoxelizer;

/// How far `w` can stray from a triangle's `w̄` (its certified value at the centroid)
/// at a band voxel whose nearest point on the triangle is `c`: `w̄`'s own error plus a
/// bound on `|∇w|` over the triangle's box grown by the band, times the length of the
/// path centroid → `c` → voxel (along the triangle, then off it: no sheet of the mesh is
/// crossed, and the whole path lies in that box).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Slack {
    pub(crate) error: f64,
    /// Infinite when the boundary reaches the box.
    pub(crate) gradient: f64,
    pub(crate) centroid: DVec3,
}

impl Slack {
    /// The half-width of the interval at voxel centre `p` (world space) whose nearest
    /// point on the triangle is `c`.
    #[inline]
    pub(crate) fn at(&self, p: DVec3, c: DVec3) -> f64 {
        if self.gradient == 0.0 {
            return self.error;
        }
        if !self.gradient.is_finite() {
            // Also where the path has length 0 (a voxel centre at the centroid).
            return f64::INFINITY;
        }
        // The lengths' rounding is far below the allowance.
        let path = ((c - self.centroid).length() + (p - c).length()) * (1.0 + 1e-9);
        self.error + self.gradient * path
    }
}

impl MeshVoxelizer {
    /// Triangle `t`'s [`Slack`] within `band` (world units) of it: the gradient bound
    /// of `w` over the triangle's box grown by the band.
    pub(crate) fn slack(&self, t: usize, band: f64) -> Slack {
        let tri = &self.triangles[t];
        let b = volga_core::Aabb::new(tri[0].min(tri[1]).min(tri[2]), tri[0].max(tri[1]).max(tri[2]));
        Slack {
            error: self.sign.w_bar_error[t],
            gradient: self.sign.boundary.gradient_bound(&b.expanded(DVec3::splat(band))),
            centroid: (tri[0] + tri[1] + tri[2]) / 3.0,
        }
    }

    /// The sign of a band voxel at `p` whose nearest triangle is `t`, `d2` away (squared),
    /// with its proven margin `|w − ½|` (a lower bound) and how it was proven. `slack`
    /// bounds how far `w` strays from `t`'s `w̄` within the band ([`Slack`]);
    /// `reference` a trusted triangle near the voxel to carry `I` from when `t` cannot.
    pub(crate) fn decide(
        &self,
        p: DVec3,
        t: usize,
        d2: f64,
        slack: Slack,
        reference: Option<usize>,
        stats: &mut SignStats,
    ) -> (bool, f64) {
        let sign = &self.sign;
        let (c, feature) = closest_point_with_frame(p, self.triangles[t], self.face_frames[t].as_ref());
        let slack = slack.at(p, c);
        let (normal, ok) = match feature {
            Feature::Face => (self.face_normal[t], true),
            Feature::Edge(k) => (self.edge_normal[t][k], !self.edge_ambiguous[t][k]),
            Feature::Vertex(k) => (self.vertex_normal[t][k], !self.vertex_ambiguous[t][k]),
        };
        let along = (p - c).dot(normal);
        // The side is trusted well above the rounding of `p − c` and of the normal.
        let tolerance = 1e-12 * (p.abs().max_element() + (p - c).length()) * normal.length();
        let mut integer = None;
        if ok && sign.trusted[t] && along.abs() > tolerance && normal.length() > 1e-6 {
            let behind = along < 0.0;
            let mid = sign.w_bar[t] + if behind { 0.5 } else { -0.5 };
            if mid - slack >= 0.5 {
                stats.fast_voxels += 1;
                return (true, mid - slack - 0.5);
            }
            if mid + slack < 0.5 {
                stats.fast_voxels += 1;
                return (false, 0.5 - mid - slack);
            }
            // `I` just off `c` on this side is the region's integer; no sheet of the
            // mesh lies between `c` and `p` (`c` is the nearest point), so `I(p)` is that
            // plus the caps crossed on the way, counted exactly: `w(p) = I − w_C(p)`.
            if !sign.closed {
                integer = CROSSING_SCRATCH
                    .with_borrow_mut(|scratch| sign.cap_crossings(c, p, scratch))
                    .map(|crossed| sign.front[t] + behind as i64 + crossed);
            }
        }
        if integer.is_none() {
            // Nearest to a boundary feature (or too close to call the side there): carry
            // `I` from the triangle's centroid instead, crossings of the mesh included; from
            // a trusted triangle near the brick when this one is not trusted (another
            // triangle crosses it).
            integer = self
                .integer_from(t, p)
                .or_else(|| reference.filter(|&r| r != t).and_then(|r| self.integer_from(r, p)));
        }
        if let Some(i) = integer {
            let threshold = i as f64 - 0.5;
            let b = sign.cap_winding(p, threshold);
            stats.query_terms += b.terms as u64;
            if b.value + b.error <= threshold {
                stats.cap_voxels += 1;
                return (true, threshold - b.value - b.error);
            }
            if b.value - b.error > threshold {
                stats.cap_voxels += 1;
                return (false, b.value - b.error - threshold);
            }
        }
        stats.exact_band_voxels += 1;
        if d2.sqrt() <= 1e-12 * p.abs().max_element() + f64::MIN_POSITIVE {
            // On the surface up to rounding, where a solid angle can take its principal
            // value: so can a cap's at the mesh's boundary, and `w_M + w_C` is no longer
            // an integer plus the caps. Ask the mesh's own tree.
            let b = self.bvh.winding_number_bounded(p, None, |w, e| (w - 0.5).abs() > e);
            stats.exact_voxels += 1;
            stats.exact_triangles += b.exact_triangles as u64;
            stats.query_terms += b.terms as u64;
            return (b.value >= 0.5, b.margin(0.5));
        }
        self.exact_side(p, None, stats)
    }

    /// `I = w_M + w_C` at `p` (an integer off the mesh and its caps), when a bound
    /// below ½ proves it; `None` without caps or on a sheet.
    pub(super) fn integer_at(&self, p: DVec3) -> (Option<f64>, u32) {
        let Some(cap) = self.sign.cap.as_ref() else {
            return (None, 0);
        };
        let c0 = self.sign.cap_bounded(cap, p, |_, e| e < 0.05);
        let m = self.bvh.winding_number_bounded(p, None, |w, e| {
            let x = w + c0.value;
            let off = (x - x.round()).abs();
            off + e + c0.error < 0.45 || off - e - c0.error > 0.05
        });
        let x = m.value + c0.value;
        (
            ((x - x.round()).abs() + m.error + c0.error < 0.45).then(|| x.round()),
            m.terms + c0.terms,
        )
    }

    /// The whole mesh's certified winding number at `p`, refined until `stop` accepts.
    ///
    /// With a boundary, `w = I − w_C` where `I = w_M + w_C` is an integer off the
    /// surface and the caps: `I` needs only an error below ½ (a few refinements of the
    /// mesh's tree; or it is `known`, constant over a region free of both), and the
    /// precision near ½ is bought on the caps alone (cone by cone). Where `I` cannot be
    /// proven an integer (a point on a cap), the mesh's tree is refined directly.
    fn certified(
        &self,
        p: DVec3,
        known: Option<f64>,
        mut stop: impl FnMut(f64, f64) -> bool,
    ) -> volga_mesh::WindingBound {
        let mut terms = 0;
        if let Some(cap) = &self.sign.cap {
            // `I` carried from a triangle near `p` (a tree descent and the crossings on
            // the way) before the mesh's tree is asked for it.
            let i = known.or_else(|| self.integer_near(p).map(|i| i as f64)).or_else(|| {
                let (i, t) = self.integer_at(p);
                terms = t;
                i
            });
            if let Some(i) = i {
                let c = self.sign.cap_bounded(cap, p, |w, e| stop(i - w, e));
                return volga_mesh::WindingBound {
                    value: i - c.value,
                    error: c.error,
                    exact_triangles: c.exact_triangles,
                    refinements: c.refinements,
                    terms: c.terms + terms,
                };
            }
        }
        let mut b = self.bvh.winding_number_bounded(p, None, stop);
        b.terms += terms;
        b
    }

    /// The certified winding number at `p`, refined until it proves its side of ½ (a
    /// tie within rounding counts as inside, `w ≥ ½`).
    pub(super) fn exact_side(&self, p: DVec3, known: Option<f64>, stats: &mut SignStats) -> (bool, f64) {
        let b = self.certified(p, known, |w, e| (w - 0.5).abs() > e);
        stats.exact_voxels += 1;
        stats.exact_triangles += b.exact_triangles as u64;
        stats.query_terms += b.terms as u64;
        (b.value >= 0.5, b.margin(0.5))
    }

    /// The certified winding number at `p`, refined until its margin from ½ is proven
    /// to exceed `needed`, or proven not to.
    pub(super) fn margin_query(&self, p: DVec3, known: Option<f64>, needed: f64) -> volga_mesh::WindingBound {
        self.certified(p, known, |w, e| {
            let gap = (w - 0.5).abs();
            gap - e > needed || gap + e <= needed
        })
    }

    /// `I` for a region free of the mesh whose box (centre, radius) no cap reaches.
    pub(super) fn region_integer(&self, centre: DVec3, radius: f64) -> Option<f64> {
        (self.sign.cap.is_some() && !self.sign.cap_within(centre, radius))
            .then(|| {
                self.integer_near(centre)
                    .map(|i| i as f64)
                    .or_else(|| self.integer_at(centre).0)
            })
            .flatten()
    }
}

#[cfg(test)]
mod tests {
    use volga_mesh::{closest_point_on_triangle, Feature, TriMesh};

    use crate::mesh::MeshVoxelizer;

    /// A mesh vendored in tests/data.
    fn shared(name: &str) -> TriMesh {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data")
            .join(name);
        volga_mesh::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    /// The band's certified interval about a trusted triangle's `w̄` holds at points
    /// whose nearest point on the whole mesh lies inside that triangle's face: the
    /// brute-force winding number there is within `w̄ ∓ ½ ± slack`, the slack taken per
    /// point (the path centroid → nearest point → point). On open meshes (teapot, bunny
    /// and every mesh of the unclean corpus with a boundary), at points off random
    /// triangles up to the band away, near the holes and far from them.
    #[test]
    fn the_band_interval_holds_at_every_point_it_is_used_for() {
        let mut meshes = vec![
            ("teapot", shared("teapot.obj")),
            ("bunny", shared("stanford-bunny.obj")),
        ];
        meshes.extend(volga_mesh::unclean::corpus());
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rand = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut open_meshes = 0;
        for (name, mesh) in &meshes {
            let v = MeshVoxelizer::new(mesh);
            if v.sign.closed {
                continue;
            }
            open_meshes += 1;
            let size = mesh.bounds().size().max_element();
            let (mut checked, mut tight) = (0, 0);
            for k in 0..3000 {
                // Bands of 1/16 to 1/256 of the mesh.
                let band = size / [16.0, 64.0, 256.0][k % 3];
                let t = (rand() * v.triangles.len() as f64) as usize % v.triangles.len();
                if !v.sign.trusted[t] {
                    continue;
                }
                let tri = v.triangles[t];
                let (r1, r2) = (rand(), rand());
                let (r1, r2) = if r1 + r2 > 1.0 { (1.0 - r1, 1.0 - r2) } else { (r1, r2) };
                let on = tri[0] + (tri[1] - tri[0]) * r1 + (tri[2] - tri[0]) * r2;
                let p = on + v.face_normal[t] * band * (2.0 * rand() - 1.0);
                let Some(nearest) = v.bvh.closest(p) else { continue };
                let (c, feature) = closest_point_on_triangle(p, tri);
                let d = (p - c).length();
                // Only where `decide` takes the interval: `t` nearest, its face.
                if feature != Feature::Face
                    || v.from_mesh[nearest.triangle as usize] as usize != t && nearest.distance < d
                    || d > band
                    || d < 1e-9 * size
                {
                    continue;
                }
                let behind = (p - c).dot(v.face_normal[t]) < 0.0;
                let mid = v.sign.w_bar[t] + if behind { 0.5 } else { -0.5 };
                let slack = v.slack(t, band);
                let half_width = slack.at(p, c);
                let w = v.bvh.winding_number_exact(p);
                assert!(
                    (w - mid).abs() <= half_width,
                    "{name}: w = {w} outside {mid} ± {half_width} at {p} (triangle {t}, band {band})"
                );
                checked += 1;
                tight += (half_width < 0.5) as u32;
            }
            assert!(checked > 500, "{name}: {checked} points checked");
            // Away from the holes the interval is narrow enough to decide signs (a lone
            // triangle or quad is all rim).
            if matches!(*name, "teapot" | "bunny") {
                assert!(
                    tight > checked / 2,
                    "{name}: the interval decided {tight} of {checked} points"
                );
            }
        }
        assert!(open_meshes >= 4, "{open_meshes} open meshes");
    }
}
