//! What an ADF is built from: anything that can answer "signed distance at this world
//! point" — a triangle mesh (exact distance, certified winding-number sign), a shape of the
//! geometry layer, a CSG tree of sources, a sampled signed-distance volume, or another ADF.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use volga_core::{Aabb, Field, FieldKind};
use volga_mesh::{Bvh, CappedWinding, TriMesh};
use volga_shapes::SignedDistance;

/// A signed distance in world units, negative inside, queried at world points.
///
/// `distance` must be a function of the point alone (deterministic builds). Sources whose
/// values are exact Euclidean distances (`is_exact`) let the builder prune cells by the
/// 1-Lipschitz bound (a cell whose corners are all farther than its diagonal contains no
/// surface); approximate sources (CSG trees, first-order distances) are pruned the same way,
/// which is the usual ADF convention (Frisken et al. 2000), but the guarantee is then theirs.
pub trait DistanceSource: Sync {
    /// Signed distance at `world_pos` (world units, negative inside).
    fn distance(&self, world_pos: DVec3) -> f64;

    /// The distance with what the source learnt on the way ([`Sample`]), given a nearby
    /// point it sampled before (`near`), which it may use to skip work (a mesh carries
    /// the integer part of its winding number over by counting the sheets in between).
    /// The value must equal [`DistanceSource::distance`] exactly.
    fn sample(&self, world_pos: DVec3, _near: Option<(DVec3, &Sample)>) -> Sample {
        Sample {
            value: self.distance(world_pos),
            region: None,
        }
    }

    /// A smooth function with the sign of the distance, for sources whose signed distance
    /// jumps from `+d` to `−d` away from any surface (an open mesh, across the surface
    /// that spans a hole, where the winding number passes ½): there the ADF stores this
    /// function at its cell corners to place the jump. `None`: the distance has no jumps.
    fn sign_field(&self, _world_pos: DVec3) -> Option<f64> {
        None
    }

    /// Whether the sign may change away from any surface (an open mesh's inside across a
    /// hole). Then a cell far from the surface is pruned only if its test points confirm
    /// its corners' sign.
    fn may_jump(&self) -> bool {
        false
    }
    /// World box containing the surface (the zero set); the ADF's root cube encloses it.
    fn bounds(&self) -> Aabb;
    /// Whether `distance` is the exact Euclidean signed distance.
    fn is_exact(&self) -> bool {
        true
    }
}

/// A distance and what the source learnt computing it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The signed distance.
    pub value: f64,
    /// An integer the source can carry to nearby points itself (a mesh: the winding
    /// number `I` of the mesh closed by caps, carried by counting sheets crossed).
    pub region: Option<i64>,
}

impl<S: DistanceSource + ?Sized> DistanceSource for &S {
    fn distance(&self, p: DVec3) -> f64 {
        (**self).distance(p)
    }
    fn sample(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Sample {
        (**self).sample(p, near)
    }
    fn sign_field(&self, p: DVec3) -> Option<f64> {
        (**self).sign_field(p)
    }
    fn may_jump(&self) -> bool {
        (**self).may_jump()
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn is_exact(&self) -> bool {
        (**self).is_exact()
    }
}

impl<S: DistanceSource + ?Sized> DistanceSource for Box<S> {
    fn distance(&self, p: DVec3) -> f64 {
        (**self).distance(p)
    }
    fn sample(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Sample {
        (**self).sample(p, near)
    }
    fn sign_field(&self, p: DVec3) -> Option<f64> {
        (**self).sign_field(p)
    }
    fn may_jump(&self) -> bool {
        (**self).may_jump()
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn is_exact(&self) -> bool {
        (**self).is_exact()
    }
}

/// A shape of the geometry layer (`volga-shapes`) as a distance source.
#[derive(Debug, Clone)]
pub struct ShapeSource<S>(pub S);

impl<S: SignedDistance + Sync> DistanceSource for ShapeSource<S> {
    fn distance(&self, p: DVec3) -> f64 {
        self.0.signed_distance(p)
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn is_exact(&self) -> bool {
        self.0.is_exact()
    }
}

/// A triangle mesh: exact unsigned distance to the nearest triangle (`Bvh::closest`) with
/// the sign of the generalized winding number, **proven** per point: inside means
/// `w(p) ≥ ½`, decided by `volga_mesh::CappedWinding` (the integer winding number of the
/// mesh closed by cones over its boundary cycle, minus the cones' own, each certified).
/// Open, self-intersecting and overlapping meshes (the Stanford bunny with its holes)
/// therefore get the same inside as the voxelizer's.
///
/// Counts its queries (`queries`, `winding_terms`) for reports.
#[derive(Debug)]
pub struct MeshSource {
    bvh: Bvh,
    winding: CappedWinding,
    bounds: Aabb,
    queries: AtomicU64,
    winding_terms: AtomicU64,
    integer_queries: AtomicU64,
}

impl MeshSource {
    /// Builds the BVH. Errors if the mesh has no triangles.
    pub fn new(mesh: &TriMesh) -> Result<Self, crate::AdfError> {
        if mesh.triangle_count() == 0 {
            return Err(crate::AdfError::EmptySource("the mesh has no triangles".into()));
        }
        let bounds = mesh.bounds();
        if !(bounds.min.is_finite() && bounds.max.is_finite()) {
            return Err(crate::AdfError::EmptySource("the mesh has non-finite vertices".into()));
        }
        Ok(MeshSource {
            bvh: Bvh::build(mesh),
            winding: CappedWinding::new(mesh),
            bounds,
            queries: AtomicU64::new(0),
            winding_terms: AtomicU64::new(0),
            integer_queries: AtomicU64::new(0),
        })
    }

    /// The mesh's BVH (exact nearest points, winding numbers).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Distance queries answered so far.
    pub fn queries(&self) -> u64 {
        self.queries.load(Ordering::Relaxed)
    }

    /// Queries that computed the integer winding number `I` themselves (the others took it
    /// from a neighbour's sheet-free ball).
    pub fn integer_queries(&self) -> u64 {
        self.integer_queries.load(Ordering::Relaxed)
    }

    /// Winding-number terms summed so far (the cost of proving signs).
    pub fn winding_terms(&self) -> u64 {
        self.winding_terms.load(Ordering::Relaxed)
    }

    /// The proven side of `p`: `w(p) ≥ ½`.
    pub fn inside(&self, p: DVec3) -> bool {
        let (inside, cost) = self.winding.inside(p);
        self.winding_terms.fetch_add(cost.terms, Ordering::Relaxed);
        inside
    }
}

impl DistanceSource for MeshSource {
    fn distance(&self, p: DVec3) -> f64 {
        self.sample(p, None).value
    }

    /// The unsigned distance to the nearest triangle, and the sign from the winding number
    /// `w = I − w_C` (`volga_mesh::CappedWinding`): the integer `I` is carried over from
    /// `near` by counting the sheets of the mesh and its caps the segment between them
    /// crosses (`CappedWinding::integer_along`), or computed when that count is not
    /// certain; `w_C` (the caps alone) is always computed, certified against `I − ½`.
    fn sample(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Sample {
        self.queries.fetch_add(1, Ordering::Relaxed);
        // The neighbour's distance bounds this one (1-Lipschitz): a tighter search.
        let bound = near.map_or(f64::INFINITY, |(q, s)| {
            (s.value.abs() + (p - q).length()) * (1.0 + 1e-9)
        });
        let unsigned = self
            .bvh
            .closest_within(p, bound)
            .or_else(|| self.bvh.closest(p))
            .map_or(f64::INFINITY, |c| c.distance);
        if unsigned == 0.0 {
            return Sample {
                value: 0.0,
                region: None,
            };
        }
        // `I` carried over from the neighbour by counting the sheets between them.
        let known = near.and_then(|(q, s)| s.region.and_then(|i| self.winding.integer_along(q, i, p)));
        if known.is_none() {
            self.integer_queries.fetch_add(1, Ordering::Relaxed);
        }
        let (inside, integer, cost) = self.winding.inside_with(p, known);
        self.winding_terms.fetch_add(cost.terms, Ordering::Relaxed);
        Sample {
            value: if inside { -unsigned } else { unsigned },
            region: integer,
        }
    }

    /// Only with holes (caps closing a boundary).
    fn may_jump(&self) -> bool {
        self.winding.cap_triangle_count() > 0
    }

    /// `½ − w(p)`, with `w_C` summed to 1e-6.
    fn sign_field(&self, p: DVec3) -> Option<f64> {
        Some(0.5 - self.winding.winding_value(p, 1e-6))
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// A sampled (or any) field of signed-distance kind as a source: its reconstruction is the
/// distance. Refused for densities and occupancies, whose values are not distances.
#[derive(Debug, Clone)]
pub struct FieldSource<F>(F);

impl<F: Field> FieldSource<F> {
    pub fn new(field: F) -> Result<Self, crate::AdfError> {
        if field.kind() != FieldKind::SignedDistance {
            return Err(crate::AdfError::NotADistance(field.kind()));
        }
        Ok(FieldSource(field))
    }
}

impl<F: Field> DistanceSource for FieldSource<F> {
    fn distance(&self, p: DVec3) -> f64 {
        self.0.value(p)
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn is_exact(&self) -> bool {
        false
    }
}

/// A CSG operator on signed distances: union `min`, intersection `max`, difference
/// `max(a, −b)`. The result is exact outside a union and inside an intersection and a
/// conservative (never larger in magnitude) bound elsewhere, the standard CSG of distance
/// fields; the zero set is exactly the CSG surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CsgOp {
    Union,
    Intersection,
    Difference,
}

impl CsgOp {
    #[inline]
    pub fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            CsgOp::Union => a.min(b),
            CsgOp::Intersection => a.max(b),
            CsgOp::Difference => a.max(-b),
        }
    }

    /// The range of `apply(a, b)` for `a ∈ [a0, a1]`, `b ∈ [b0, b1]` (exact: the
    /// operators are monotone in each argument).
    #[inline]
    pub fn apply_range(self, (a0, a1): (f64, f64), (b0, b1): (f64, f64)) -> (f64, f64) {
        match self {
            CsgOp::Union => (a0.min(b0), a1.min(b1)),
            CsgOp::Intersection => (a0.max(b0), a1.max(b1)),
            CsgOp::Difference => (a0.max(-b1), a1.max(-b0)),
        }
    }
}

/// Two sources combined by a [`CsgOp`]: a CSG tree node (nest them for trees).
#[derive(Debug, Clone)]
pub struct Csg<A, B> {
    pub op: CsgOp,
    pub a: A,
    pub b: B,
}

impl<A: DistanceSource, B: DistanceSource> DistanceSource for Csg<A, B> {
    fn distance(&self, p: DVec3) -> f64 {
        self.op.apply(self.a.distance(p), self.b.distance(p))
    }
    /// The operands' sign fields are not combined (a jump of either operand survives only
    /// where it decides the result); `None`.
    fn sign_field(&self, _p: DVec3) -> Option<f64> {
        None
    }
    fn bounds(&self) -> Aabb {
        let (a, b) = (self.a.bounds(), self.b.bounds());
        match self.op {
            CsgOp::Union => a.union(&b),
            CsgOp::Intersection => {
                let i = a.intersection(&b);
                if i.is_empty() {
                    a
                } else {
                    i
                }
            }
            CsgOp::Difference => a,
        }
    }
    fn is_exact(&self) -> bool {
        false
    }
}
