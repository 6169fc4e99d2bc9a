//! A fast certified inside test for any mesh: the winding number split into an integer
//! part and a small cap part.
//!
//! Take the mesh `M` as a 2-chain. Its boundary `∂M` (each welded edge with the net
//! number of times triangles run along it, forwards minus backwards) is a 1-cycle for any
//! mesh: closed, open, non-manifold, self-intersecting or inconsistently oriented. Close
//! it with cones `C` (one apex per connected component of the cycle, near the component's
//! vertex centroid): `M + C` is a closed chain, so `I = w_M + w_C` is an **integer** off
//! `M ∪ C`. Hence `w_M(p) ≥ ½ ⇔ w_C(p) ≤ I(p) − ½`:
//!
//! * `I(p)` needs the closed chain's winding number only to within ½ (a first-pass fast
//!   winding number almost always suffices; certified by `Bvh::winding_number_bounded`);
//! * `w_C(p)` sums the cap triangles only — a few per hole — refined until its certified
//!   interval clears `I − ½`.
//!
//! The expensive case of a direct query, a point near the surface spanning a hole where
//! `w_M ≈ ½` (every triangle of the mesh summed exactly), costs only the caps here. A
//! closed mesh has no caps and `w_M = I`. A point on a cap triangle (where `I` jumps)
//! falls back to the direct certified query of `M`.

use rustc_hash::FxHashMap;

use glam::DVec3;

use crate::{Bvh, ConeCaps, SegmentTree, TriMesh, WindingBound};
use volga_core::Aabb;

/// The inside test `w(p) ≥ ½` of a mesh, proven per query (see the module doc).
#[derive(Debug, Clone)]
pub struct CappedWinding {
    /// `M + C`.
    closed: Bvh,
    /// `M + C` as triangles (mesh ids of `closed`), for segment crossings.
    closed_triangles: Vec<[DVec3; 3]>,
    /// `C` alone (`None` for a closed mesh).
    caps: Option<Bvh>,
    /// `C` summed cone by cone, for every query of `w_C` (`None` for a closed mesh or
    /// caps of too many cones: `caps` answers then).
    cones: Option<ConeCaps>,
    /// `M` alone, for the rare fallback on cap triangles.
    mesh: Bvh,
    cap_triangles: usize,
    /// Total area of the cap triangles: bounds the gradient of `w_C` away from them.
    cap_area: f64,
    /// The caps' boundary cycle (the mesh's, reversed): a second, usually much tighter,
    /// bound on the gradient of `w_C` away from the caps.
    cap_boundary: SegmentTree,
    /// The mesh's boundary cycle `∂M`, oriented, each edge with its net multiplicity: the
    /// gradient of `w_M` (its Biot–Savart field, [`CappedWinding::winding_model`]).
    rim: Vec<(DVec3, DVec3, f64)>,
    /// Size of the mesh (its box's diagonal plus its distance from the origin): the scale
    /// of "on a cap" tests.
    scale: f64,
}

/// What one inside query cost.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InsideCost {
    /// Winding-number terms summed (expansions and exact solid angles).
    pub terms: u64,
    /// Whether the direct query of the whole mesh was needed.
    pub fallback: bool,
}

/// A certified first-order model of the winding number `w` over a box no triangle of
/// the mesh meets ([`CappedWinding::winding_model`]): at `x` in the box,
/// `|w(x) − value − gradient·(x − c)| ≤ error + slope_error |x − c| + curvature |x − c|²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindingModel {
    /// The box it holds in.
    bounds: Aabb,
    /// The box's centre `c`.
    centre: DVec3,
    /// `w(c)`, within `error`.
    value: f64,
    error: f64,
    /// `∇w(c)`, within `slope_error` (the length of the difference).
    gradient: DVec3,
    slope_error: f64,
    /// Half a bound on the Hessian's norm over the box.
    curvature: f64,
}

impl WindingModel {
    /// Whether `w ≥ ½` (inside) at `x`, proven: `None` when the model cannot tell, or
    /// `x` is outside its box.
    pub fn side_at(&self, x: DVec3) -> Option<bool> {
        self.side_near(x, 0.0)
    }

    /// Whether `w ≥ ½` at every point of `cell`, proven: `None` when the model cannot
    /// tell, or `cell` is not inside its box.
    pub fn side_in(&self, cell: &Aabb) -> Option<bool> {
        let inside = self.bounds.min.cmple(cell.min).all() && cell.max.cmple(self.bounds.max).all();
        if !inside {
            return None;
        }
        self.side_near(cell.center(), 0.5 * cell.size().length())
    }

    /// The side at every point of the model's box within `radius` of `x` (whose box is
    /// checked: `x` must lie in it).
    fn side_near(&self, x: DVec3, radius: f64) -> Option<bool> {
        if !self.bounds.contains(x) {
            return None;
        }
        let offset = x - self.centre;
        let linear = self.value + self.gradient.dot(offset);
        let reach = offset.length() + radius;
        // The model's terms, then slack for this evaluation's rounding (`w` and its
        // linear part are of order 1 here: 1e-12 of them is far above it).
        let spread =
            (self.gradient.length() * radius + self.error + self.slope_error * reach + self.curvature * reach * reach)
                * (1.0 + 1e-9)
                + 1e-12 * (1.0 + linear.abs());
        if linear - spread > 0.5 {
            Some(true)
        } else if linear + spread < 0.5 {
            Some(false)
        } else {
            None
        }
    }
}

impl CappedWinding {
    /// Builds the boundary cycle, its cones and the two BVHs.
    pub fn new(mesh: &TriMesh) -> CappedWinding {
        let caps = cap_triangles(mesh);
        let cap_count = caps.len();
        let mut positions = mesh.positions.clone();
        let mut triangles = mesh.triangles.clone();
        let mut cap_positions = Vec::with_capacity(cap_count * 3);
        let mut cap_tris = Vec::with_capacity(cap_count);
        for t in &caps {
            let base = positions.len() as u32;
            positions.extend_from_slice(t);
            triangles.push([base, base + 1, base + 2]);
            let cb = cap_positions.len() as u32;
            cap_positions.extend_from_slice(t);
            cap_tris.push([cb, cb + 1, cb + 2]);
        }
        let closed = TriMesh { positions, triangles };
        let cap_mesh = TriMesh {
            positions: cap_positions,
            triangles: cap_tris,
        };
        CappedWinding {
            closed: Bvh::build(&closed),
            closed_triangles: (0..closed.triangle_count()).map(|i| closed.triangle(i)).collect(),
            caps: (cap_count > 0).then(|| Bvh::build(&cap_mesh)),
            cones: ConeCaps::build(&caps),
            mesh: Bvh::build(mesh),
            cap_triangles: cap_count,
            cap_area: caps
                .iter()
                .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
                .sum(),
            cap_boundary: boundary_of(&caps),
            // ∂M = −∂C: the caps' boundary reversed.
            rim: boundary_edges(&caps)
                .into_iter()
                .map(|(a, b, m)| (a, b, -(m as f64)))
                .collect(),
            scale: {
                let b = mesh.bounds();
                b.size().length() + b.min.abs().max(b.max.abs()).max_element()
            },
        }
    }

    /// The BVH of the mesh itself (without caps).
    pub fn mesh_bvh(&self) -> &Bvh {
        &self.mesh
    }

    /// Cap triangles closing the boundary cycle (0 for a closed mesh).
    pub fn cap_triangle_count(&self) -> usize {
        self.cap_triangles
    }

    /// Whether `w(p) ≥ ½`, proven, and what it cost. (On the mesh itself the answer is the
    /// principal value's; callers that need a sign there usually have distance 0.)
    pub fn inside(&self, p: DVec3) -> (bool, InsideCost) {
        let (inside, _, cost) = self.inside_with(p, None);
        (inside, cost)
    }

    /// [`CappedWinding::inside`] given the integer part `I` when the caller knows it (from
    /// a point whose ball free of mesh and caps contains `p`, see
    /// [`CappedWinding::cap_distance`]); also returns `I` (`None` on a sheet of `M + C`,
    /// where `I` is undefined and the mesh was asked directly).
    pub fn inside_with(&self, p: DVec3, known: Option<i64>) -> (bool, Option<i64>, InsideCost) {
        let mut cost = InsideCost::default();
        let integer = match known {
            Some(i) => i,
            None => match self.integer_part(p, &mut cost) {
                Some(i) => i,
                None => {
                    let direct = self.mesh.winding_number_bounded(p, None, |v, e| (v - 0.5).abs() > e);
                    cost.terms += direct.terms as u64;
                    cost.fallback = true;
                    return (direct.side(0.5).unwrap_or(direct.value >= 0.5), None, cost);
                }
            },
        };
        let Some(caps) = &self.caps else {
            return (integer >= 1, Some(integer), cost);
        };
        let threshold = integer as f64 - 0.5;
        let cap = self.cap_bounded(caps, p, |v, e| (v - threshold).abs() > e);
        cost.terms += cap.terms as u64;
        // w_M = I − w_C ≥ ½  ⇔  w_C ≤ I − ½ (undecided only at the rounding allowance:
        // then the summed value decides).
        let inside = match cap.side(threshold) {
            Some(above) => !above,
            None => cap.value <= threshold,
        };
        (inside, Some(integer), cost)
    }

    /// `I(to)` from `I(from)`: `I` changes by ±1 across each sheet of `M + C` the segment
    /// crosses (+1 entering a triangle's back, the side its normal points away from).
    /// Each crossing is decided by the signs of floating-point triple products that are
    /// accepted only when they exceed a bound on their rounding error (1e-12 of the
    /// product of the magnitudes, far above the `f64` error of a triple product), so the
    /// count is exact; a segment through an edge, a corner or within a sheet's rounding
    /// band gets `None` (the caller asks the winding number instead). Zero-area
    /// triangles are skipped: `I` does not jump across them.
    pub fn integer_along(&self, from: DVec3, from_integer: i64, to: DVec3) -> Option<i64> {
        if from == to {
            return Some(from_integer);
        }
        let query = volga_core::Aabb::new(from.min(to), from.max(to));
        let mut ids = Vec::new();
        self.closed.boxes_overlapping(&query, &mut ids);
        self.count_crossings(from, from_integer, to, ids)
    }

    /// [`CappedWinding::integer_along`] with the mesh triangles to test given by the
    /// caller: `mesh_triangles` (ids in the mesh) must include every triangle of the mesh
    /// that meets the segment (e.g. every triangle near a box containing it); the cap
    /// triangles are found here. The answer is the same certified `I` (it may be `None`
    /// where `integer_along` is not, or the reverse, only when an endpoint lies within
    /// rounding of the plane of a triangle that one of them tests and the other does not).
    pub fn integer_along_among(
        &self,
        from: DVec3,
        from_integer: i64,
        to: DVec3,
        mesh_triangles: impl IntoIterator<Item = u32>,
    ) -> Option<i64> {
        let mut caps = Vec::new();
        self.caps_overlapping(&volga_core::Aabb::new(from.min(to), from.max(to)), &mut caps);
        self.integer_along_listed(from, from_integer, to, mesh_triangles, caps)
    }

    /// Appends to `out` the indices of the cap triangles whose boxes meet the closed box
    /// `query` (what [`CappedWinding::integer_along_listed`] takes for a segment inside it).
    pub fn caps_overlapping(&self, query: &volga_core::Aabb, out: &mut Vec<u32>) {
        if let Some(c) = &self.caps {
            c.boxes_overlapping(query, out);
        }
    }

    /// [`CappedWinding::integer_along_among`] with the cap triangles given too:
    /// `cap_triangles` (indices among the caps, as [`CappedWinding::caps_overlapping`]
    /// gives them) must include every cap triangle whose box meets the segment's (e.g.
    /// those meeting a box containing it). Both lists are filtered by the segment's box
    /// here, so the triangles tested, and the answer, are `integer_along_among`'s.
    pub fn integer_along_listed(
        &self,
        from: DVec3,
        from_integer: i64,
        to: DVec3,
        mesh_triangles: impl IntoIterator<Item = u32>,
        cap_triangles: impl IntoIterator<Item = u32>,
    ) -> Option<i64> {
        if from == to {
            return Some(from_integer);
        }
        let query = volga_core::Aabb::new(from.min(to), from.max(to));
        let mesh_count = (self.closed_triangles.len() - self.cap_triangles) as u32;
        let boxes = |id: &u32| {
            let [a, b, c] = self.closed_triangles[*id as usize];
            !(a.min(b).min(c).cmpgt(query.max).any() || a.max(b).max(c).cmplt(query.min).any())
        };
        let ids = mesh_triangles
            .into_iter()
            .filter(|id| *id < mesh_count && boxes(id))
            .chain(cap_triangles.into_iter().map(|c| c + mesh_count).filter(boxes));
        self.count_crossings(from, from_integer, to, ids)
    }

    /// `I(to)` from `I(from)` counting the crossings of the listed triangles of `M + C`.
    fn count_crossings(
        &self,
        from: DVec3,
        from_integer: i64,
        to: DVec3,
        ids: impl IntoIterator<Item = u32>,
    ) -> Option<i64> {
        let mut integer = from_integer;
        for id in ids {
            integer += signed_crossing(from, to, self.closed_triangles[id as usize])?;
        }
        Some(integer)
    }

    /// The integer winding number `I` of `M + C` at `p`, certified; `None` on a sheet.
    ///
    /// Off the sheets the true sum is an integer, so an estimate within `½ − |v − round v|`
    /// of it proves `round v`. On a sheet the sum is not an integer (a principal value),
    /// so points on (or within rounding of) a cap triangle are refused here; points on the
    /// mesh itself have distance 0 and never need a sign.
    fn integer_part(&self, p: DVec3, cost: &mut InsideCost) -> Option<i64> {
        if self.cap_distance(p) <= 1e-12 * self.scale {
            return None;
        }
        let closed = self
            .closed
            .winding_number_bounded(p, None, |v, e| e < 0.5 - (v - v.round()).abs());
        cost.terms += closed.terms as u64;
        (closed.error < 0.5 - (closed.value - closed.value.round()).abs()).then(|| closed.value.round() as i64)
    }

    /// Distance from `p` to the nearest cap triangle (`∞` for a closed mesh). A ball around
    /// `p` of radius `min(distance to the mesh, cap distance)` meets no sheet of `M + C`, so
    /// `I` is constant in it.
    pub fn cap_distance(&self, p: DVec3) -> f64 {
        self.caps
            .as_ref()
            .and_then(|c| c.closest(p))
            .map_or(f64::INFINITY, |c| c.distance)
    }

    /// The winding number `w(p) = I − w_C(p)` with `w_C` summed to within `tolerance`
    /// (cone by cone when the caps have few cones, else through their tree; the mesh's
    /// own certified sum on a sheet of `M + C`).
    pub fn winding_value(&self, p: DVec3, tolerance: f64) -> f64 {
        let mut cost = InsideCost::default();
        match self.integer_part(p, &mut cost) {
            Some(i) => {
                let cap = self
                    .caps
                    .as_ref()
                    .map_or(0.0, |c| self.cap_bounded(c, p, |_, e| e <= tolerance).value);
                i as f64 - cap
            }
            None => self.mesh.winding_number_bounded(p, None, |_, e| e <= tolerance).value,
        }
    }
}

impl CappedWinding {
    /// Whether every point of the ball `|x − centre| ≤ radius` is inside, proven with one
    /// query, for a ball that no sheet of the mesh meets and whose integer part `I` is
    /// `integer` (the caller knows both, e.g. from a point of the ball farther from the
    /// mesh than its diameter). `None` when the ball meets a cap or the proof fails.
    ///
    /// With no sheet of `M + C` in the ball, `I` is constant and `w_M = I − w_C`; the
    /// gradient of the caps' winding number is at most `A_C / (π ρ³)` at distance `ρ`
    /// from caps of area `A_C` (the solid-angle kernel's gradient is at most `4/ρ³`, over
    /// `4π`), so `w_C` varies by at most `radius · A_C / (π r³)` over the ball, `r` its
    /// distance from the caps (or by the radius times the caps' boundary's Biot–Savart
    /// bound, when less). If `w_C(centre)`, certified, clears `I − ½` by more than
    /// that, the side is the same everywhere in the ball.
    pub fn inside_over_ball(&self, centre: DVec3, radius: f64, integer: i64) -> Option<bool> {
        let Some(caps) = &self.caps else {
            return Some(integer >= 1);
        };
        let r = self.cap_distance(centre) - radius;
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        let variation = self.cap_variation(centre, radius, r);
        let threshold = integer as f64 - 0.5;
        let cap = self.cap_bounded(caps, centre, |v, e| (v - threshold).abs() > e + variation);
        ((cap.value - threshold).abs() > cap.error + variation).then_some(cap.value < threshold)
    }

    /// `w_C(p)` certified, refined until `done` accepts it: cone by cone when the caps
    /// have few cones, else through their tree.
    fn cap_bounded(&self, caps: &Bvh, p: DVec3, done: impl FnMut(f64, f64) -> bool) -> WindingBound {
        match &self.cones {
            Some(cones) => cones.winding_number_bounded(p, done),
            None => caps.winding_number_bounded(p, None, done),
        }
    }

    /// How much `w_C` can vary over the ball `|x − centre| ≤ radius`, `r > 0` away from
    /// the caps: the radius times a bound on `|∇w_C|` over the ball, the lesser of
    /// `A_C / (π r³)` (see [`CappedWinding::inside_over_ball`]) and the Biot–Savart bound
    /// of the caps' boundary cycle over the ball's box (`w_C` is harmonic off the caps,
    /// its gradient the field of their boundary: [`SegmentTree::gradient_bound`]). The
    /// second is asked only when the first is not already small.
    fn cap_variation(&self, centre: DVec3, radius: f64, r: f64) -> f64 {
        let by_area = radius * self.cap_area / (std::f64::consts::PI * r * r * r) * (1.0 + 1e-9);
        if by_area <= 1e-3 {
            return by_area;
        }
        let ball_box = Aabb::new(centre - DVec3::splat(radius), centre + DVec3::splat(radius));
        let by_boundary = radius * self.cap_boundary.gradient_bound(&ball_box) * (1.0 + 1e-9);
        by_area.min(by_boundary)
    }

    /// Certified bounds of the caps' winding number `w_C` over the ball
    /// `|x − centre| ≤ radius`, when the ball meets no cap (see
    /// [`CappedWinding::inside_over_ball`] for the gradient bound); `None` for a closed
    /// mesh (no caps: `w_C = 0`, nothing to bound) or a ball near a cap.
    pub fn caps_range_over_ball(&self, centre: DVec3, radius: f64) -> Option<(f64, f64)> {
        let caps = self.caps.as_ref()?;
        let r = self.cap_distance(centre) - radius;
        if r.is_nan() || r <= 0.0 {
            return None;
        }
        let variation = self.cap_variation(centre, radius, r);
        if variation > 0.25 {
            return None;
        }
        let cap = self.cap_bounded(caps, centre, |_, e| e <= 0.01);
        let spread = cap.error + variation;
        Some((cap.value - spread, cap.value + spread))
    }

    /// A certified first-order model of the mesh's winding number `w = w_M` over `cell`,
    /// a box that **no triangle of the mesh meets** (the caller's to know, e.g. from the
    /// triangles' boxes): `w` is then smooth in it, even across the caps (only `I` and
    /// `w_C` jump there, together), its gradient the Biot–Savart field of the boundary
    /// cycle `∂M` and its Hessian bounded by [`SegmentTree::hessian_bound`]. So with `c`
    /// the box's centre, `w(x) = w(c) + ∇w(c)·(x − c) + R` with `|R| ≤ ½ H |x − c|²`
    /// along the segment, which stays in the box. `w(c)` is `I − w_C` certified to 1e-6,
    /// `∇w(c)` summed exactly over `∂M`'s edges with a bound on its rounding.
    ///
    /// `None` for a closed mesh (no boundary: `w = I` is constant off the mesh, asked
    /// directly), caps of too many cones (the sum over `∂M` would cost more than the
    /// queries it saves), a centre on a cap sheet (`I` undefined), or a box a boundary
    /// edge's box touches. `integer`: the integer part `I` at the box's centre when the
    /// caller knows it (certified, e.g. carried from a corner by
    /// [`CappedWinding::integer_along_listed`]), else it is computed. Also returns the
    /// winding-number terms it summed.
    pub fn winding_model(&self, cell: &Aabb, integer: Option<i64>) -> (Option<WindingModel>, u64) {
        let (Some(caps), Some(_)) = (&self.caps, &self.cones) else {
            return (None, 0);
        };
        let curvature = 0.5 * self.cap_boundary.hessian_bound(cell) * (1.0 + 1e-9);
        if !curvature.is_finite() {
            return (None, 0);
        }
        let centre = cell.center();
        let mut cost = InsideCost::default();
        let Some(integer) = integer.or_else(|| self.integer_part(centre, &mut cost)) else {
            return (None, cost.terms);
        };
        let cap = self.cap_bounded(caps, centre, |_, e| e <= 1e-6);
        let terms = cost.terms + cap.terms as u64;
        let Some((gradient, slope_error)) = self.rim_gradient(centre) else {
            return (None, terms);
        };
        let model = WindingModel {
            bounds: *cell,
            centre,
            value: integer as f64 - cap.value,
            error: cap.error,
            gradient,
            slope_error,
            curvature,
        };
        (Some(model), terms + self.rim.len() as u64)
    }

    /// `∇w_M(x)` for `x` off the boundary cycle: `Σ m_e K_e(x) / 4π` over `∂M`'s edges
    /// `a → b`, with the segment's Biot–Savart integral in its stable closed form
    /// `K = (r₁ × r₂)(|r₁| + |r₂|) / (|r₁||r₂|(|r₁||r₂| + r₁·r₂))`, `r₁ = a − x`,
    /// `r₂ = b − x`; and a bound on the sum's rounding. Each term is at most
    /// `S = |m|(|r₁| + |r₂|)/den` (`den = |r₁||r₂| + r₁·r₂`) and off by at most about
    /// `14 ε S (1 + |r₁||r₂|/den)` (the cross product's components and `den` lose up to
    /// a few `ε |r₁||r₂|` to cancellation), the sum by `n ε Σ S` more; the bound allows
    /// `1e-13 + 1e-15 n` of `Σ S (1 + |r₁||r₂|/den)`, 45× the first and 4.5× the second.
    /// `None` when `x` is within `den ≤ 1e-6 |r₁||r₂|` of an edge (the analysis needs
    /// `den`'s relative error small).
    fn rim_gradient(&self, x: DVec3) -> Option<(DVec3, f64)> {
        let mut gradient = DVec3::ZERO;
        let mut scale = 0.0;
        for &(a, b, m) in &self.rim {
            let (r1, r2) = (a - x, b - x);
            let (l1, l2) = (r1.length(), r2.length());
            let product = l1 * l2;
            let den = product + r1.dot(r2);
            // (NaN refused too.)
            if den.partial_cmp(&(1e-6 * product)) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            gradient += r1.cross(r2) * (m * (l1 + l2) / (product * den));
            scale += m.abs() * (l1 + l2) / den * (1.0 + product / den);
        }
        let allowance = 1e-13 + 1e-15 * self.rim.len() as f64;
        let error = allowance * scale / (4.0 * std::f64::consts::PI);
        (gradient.is_finite() && error.is_finite()).then(|| (gradient / (4.0 * std::f64::consts::PI), error))
    }

    /// [`CappedWinding::winding_value`] given the integer part `I` at `p` (certified by the
    /// caller, e.g. from [`CappedWinding::inside_with`]): `I − w_C(p)` with `w_C` summed to
    /// within `tolerance`. The same value as `winding_value` off the sheets of `M + C`.
    pub fn winding_value_with(&self, p: DVec3, integer: i64, tolerance: f64) -> f64 {
        let cap = self
            .caps
            .as_ref()
            .map_or(0.0, |c| self.cap_bounded(c, p, |_, e| e <= tolerance).value);
        integer as f64 - cap
    }
}

/// How `I` changes along the segment `from → to` at one triangle `[a, b, c]`: `Some(1)`
/// when the segment crosses its interior entering its back (the side its normal
/// `(b − a) × (c − a)` points away from), `Some(−1)` entering its front, `Some(0)` when it
/// misses it or the triangle has zero area (`I` does not jump across it); `None` when
/// rounding cannot tell (an endpoint within rounding of the plane, or the segment
/// through an edge or a corner).
///
/// Each sign is a floating-point triple product accepted only when it exceeds a bound on
/// its rounding error (1e-12 of the product of the magnitudes, far above the `f64` error
/// of a triple product), so a `Some` is exact.
pub fn signed_crossing(from: DVec3, to: DVec3, [a, b, c]: [DVec3; 3]) -> Option<i64> {
    let normal = (b - a).cross(c - a);
    if normal == DVec3::ZERO {
        return Some(0);
    }
    // Plane sides of the endpoints: positive in front (along the normal).
    let side = |d: DVec3| -> Option<f64> {
        let v = -(a - d).dot((b - d).cross(c - d));
        let bound = 1e-12 * (a - d).length() * (b - d).length() * (c - d).length();
        (v.abs() > bound).then_some(v)
    };
    let (s_from, s_to) = (side(from)?, side(to)?);
    if (s_from > 0.0) == (s_to > 0.0) {
        return Some(0);
    }
    // Which side of each edge the line from → to passes.
    let segment = to - from;
    let edge = |u: DVec3, v: DVec3| -> Option<f64> {
        let w = (u - from).cross(v - from).dot(segment);
        let bound = 1e-12 * (u - from).length() * (v - from).length() * segment.length();
        (w.abs() > bound).then_some(w)
    };
    let known = [edge(a, b), edge(b, c), edge(c, a)];
    let positive = known.iter().filter(|e| matches!(e, Some(v) if *v > 0.0)).count();
    let negative = known.iter().filter(|e| matches!(e, Some(v) if *v < 0.0)).count();
    if positive > 0 && negative > 0 {
        return Some(0); // the line passes outside the triangle
    }
    if positive + negative < 3 {
        return None; // through an edge or a corner, within rounding
    }
    Some(if s_from > 0.0 { 1 } else { -1 })
}

/// The cones closing the mesh's boundary cycle: for each boundary edge `a → b` of net
/// multiplicity `m ≠ 0`, `|m|` copies of `(b, a, apex)` (or `(a, b, apex)` for `m < 0`),
/// with one apex per connected component of the cycle near its vertices' centroid (lifted
/// by 7 % of the component's radius). Vertices are welded by exact position, so split
/// seams are not boundaries.
pub fn cap_triangles(mesh: &TriMesh) -> Vec<[DVec3; 3]> {
    let mut ids: FxHashMap<[u64; 3], u32> = FxHashMap::default();
    let mut welded = Vec::with_capacity(mesh.positions.len());
    let mut points: Vec<DVec3> = Vec::new();
    for p in &mesh.positions {
        let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        let next = points.len() as u32;
        let id = *ids.entry(key).or_insert(next);
        if id == next {
            points.push(*p);
        }
        welded.push(id);
    }
    // Net multiplicity of each undirected edge, positive along (min → max).
    let mut net: FxHashMap<(u32, u32), i64> = FxHashMap::default();
    for t in &mesh.triangles {
        let v = [welded[t[0] as usize], welded[t[1] as usize], welded[t[2] as usize]];
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            if a == b {
                continue;
            }
            if a < b {
                *net.entry((a, b)).or_insert(0) += 1;
            } else {
                *net.entry((b, a)).or_insert(0) -= 1;
            }
        }
    }
    let mut edges: Vec<(u32, u32, i64)> = net
        .into_iter()
        .filter(|&(_, m)| m != 0)
        .map(|((a, b), m)| (a, b, m))
        .collect();
    edges.sort_unstable();
    if edges.is_empty() {
        return Vec::new();
    }
    // Components of the cycle (union-find over its vertices).
    let mut parent: FxHashMap<u32, u32> = FxHashMap::default();
    fn find(parent: &mut FxHashMap<u32, u32>, mut x: u32) -> u32 {
        while let Some(&p) = parent.get(&x) {
            if p == x {
                break;
            }
            let gp = *parent.get(&p).unwrap_or(&p);
            parent.insert(x, gp);
            x = gp;
        }
        x
    }
    for &(a, b, _) in &edges {
        parent.entry(a).or_insert(a);
        parent.entry(b).or_insert(b);
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            parent.insert(hi, lo);
        }
    }
    let mut sums: FxHashMap<u32, (DVec3, f64)> = FxHashMap::default();
    let mut vertices: Vec<u32> = parent.keys().copied().collect();
    vertices.sort_unstable();
    for v in vertices {
        let r = find(&mut parent, v);
        let e = sums.entry(r).or_insert((DVec3::ZERO, 0.0));
        e.0 += points[v as usize];
        e.1 += 1.0;
    }
    // Each component's apex: its vertex centroid, lifted off by a small odd offset (7 % of
    // the component's radius along a fixed direction with no simple ratios), so cap planes
    // rarely pass through lattice points a caller samples (points on a cap need the slow
    // path, see `integer_part`).
    let mut radius: FxHashMap<u32, f64> = FxHashMap::default();
    for &(a, b, _) in &edges {
        let r = find(&mut parent, a);
        let (sum, n) = sums[&r];
        let c = sum / n;
        let e = radius.entry(r).or_insert(0.0);
        *e = e
            .max((points[a as usize] - c).length())
            .max((points[b as usize] - c).length());
    }
    let lift = DVec3::new(0.321_7, 0.268_3, 0.412_9).normalize();
    let mut caps = Vec::new();
    for &(a, b, m) in &edges {
        let r = find(&mut parent, a);
        let (sum, n) = sums[&r];
        let apex = sum / n + lift * (0.07 * radius[&r]);
        let (pa, pb) = (points[a as usize], points[b as usize]);
        let tri = if m > 0 { [pb, pa, apex] } else { [pa, pb, apex] };
        for _ in 0..m.unsigned_abs() {
            caps.push(tri);
        }
    }
    caps
}

/// The boundary cycle of `triangles`: each edge whose net multiplicity (the triangles
/// running along it forwards minus backwards, endpoints equal bit for bit) is not zero,
/// from its lower endpoint (by the bits of its coordinates) to its higher, with that
/// multiplicity, in that order of endpoints.
fn boundary_edges(triangles: &[[DVec3; 3]]) -> Vec<(DVec3, DVec3, i64)> {
    let key = |p: DVec3| p.to_array().map(|c| (c + 0.0).to_bits());
    // Per edge (endpoints' bits, lower first): the endpoints and the net multiplicity.
    type Key = ([u64; 3], [u64; 3]);
    let mut net: FxHashMap<Key, (DVec3, DVec3, i64)> = FxHashMap::default();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (ka, kb) = (key(a), key(b));
            if ka == kb {
                continue;
            }
            let (lo, hi, sign) = if ka < kb { (a, b, 1) } else { (b, a, -1) };
            net.entry((key(lo), key(hi))).or_insert((lo, hi, 0)).2 += sign;
        }
    }
    let mut edges: Vec<(DVec3, DVec3, i64)> = net.into_values().filter(|&(_, _, m)| m != 0).collect();
    // A fixed order (the map's is arbitrary): the tree, and its sums, are then one.
    edges.sort_unstable_by(|x, y| key(x.0).cmp(&key(y.0)).then_with(|| key(x.1).cmp(&key(y.1))));
    edges
}

/// The boundary cycle of `triangles` ([`boundary_edges`], multiplicities as weights) as a
/// [`SegmentTree`]. For the caps, the cones' inner edges cancel and the mesh's boundary
/// cycle, reversed, is left.
fn boundary_of(triangles: &[[DVec3; 3]]) -> SegmentTree {
    SegmentTree::build(
        boundary_edges(triangles)
            .into_iter()
            .map(|(a, b, m)| (a, b, m.unsigned_abs() as f64))
            .collect(),
    )
}
