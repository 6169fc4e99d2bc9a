//! What an ADF is built from: anything that can answer "signed distance at this world
//! point" — a triangle mesh (exact distance, certified winding-number sign), a shape of the
//! geometry layer, a CSG tree of sources, a sampled signed-distance volume, or another ADF.

use glam::DVec3;
use volga_core::{Aabb, Field, FieldKind};
use volga_mesh::TriMesh;
use volga_shapes::{DistanceSource, ShapeSource, SignedDistance};

mod mesh;

pub use mesh::MeshSource;

/// What the ADF build asks of a source beyond its signed distance ([`DistanceSource`]):
/// ways to do less work for the same values. Every method has a default that does the
/// work plainly, so a source that is only a distance implements it empty
/// (`impl AdfSource for MySource {}`).
///
/// The builder prunes a cell whose corners are all of one sign and farther from the
/// surface than its diagonal (the 1-Lipschitz bound: no surface passes through it). For
/// exact sources ([`DistanceSource::is_exact`]) that is proven; approximate sources (CSG
/// trees, first-order distances) are pruned the same way, which is the usual ADF
/// convention (Frisken et al. 2000), but the guarantee is then theirs.
pub trait AdfSource: DistanceSource {
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

    /// Narrowing for one cell of the build: the ids of the primitives (a mesh: its
    /// triangles) that can hold the nearest surface point of any point of `cell`, given
    /// `reach`, an upper bound of `|distance|` over the cell, and the parent cell's list
    /// (`None` at the top). The builder passes the list to [`AdfSource::sample_among`]
    /// for the cell's test points and narrows it again for the children. `None`: the source
    /// does not narrow (the default).
    fn candidates(&self, _cell: &Aabb, _reach: f64, _parent: Option<&CellCandidates>) -> Option<CellCandidates> {
        None
    }

    /// A model of the sign over `cell` for its `candidates`
    /// ([`CellCandidates::sign_model`]), given a corner and its sample; the builder asks
    /// after [`AdfSource::candidates`]. `None` (the default): no model.
    fn sign_model(
        &self,
        _cell: &Aabb,
        _corner: (DVec3, &Sample),
        _candidates: &CellCandidates,
    ) -> Option<volga_mesh::WindingModel> {
        None
    }

    /// [`AdfSource::sample`] at a point of a cell whose [`AdfSource::candidates`]
    /// are `candidates`, with `near` in the same cell. Must return exactly what `sample`
    /// returns (the default calls it).
    fn sample_among(&self, world_pos: DVec3, near: Option<(DVec3, &Sample)>, _candidates: &CellCandidates) -> Sample {
        self.sample(world_pos, near)
    }

    /// A smooth function with the sign of the distance, for sources whose signed distance
    /// jumps from `+d` to `−d` away from any surface (an open mesh, across the surface
    /// that spans a hole, where the winding number passes ½): there the ADF stores this
    /// function at its cell corners to place the jump. `None`: the distance has no jumps.
    fn sign_field(&self, _world_pos: DVec3) -> Option<f64> {
        None
    }

    /// [`AdfSource::sign_field`] at a point whose sample is known (the source may
    /// reuse what it learnt); must return the same value (the default calls `sign_field`).
    fn sign_field_at(&self, world_pos: DVec3, _sample: &Sample) -> Option<f64> {
        self.sign_field(world_pos)
    }

    /// Whether `world_pos` is inside (distance < 0), for a point of a cell that no surface
    /// meets, given a sample `near` in the same cell: the sign alone, cheaper than
    /// [`AdfSource::sample`] for sources whose sign can jump ([`AdfSource::may_jump`]).
    /// Must agree with the sign of `sample`'s value; `None`: not known cheaply (the
    /// default), the builder samples the point.
    fn inside_in_empty_cell(&self, _world_pos: DVec3, _near: (DVec3, &Sample)) -> Option<bool> {
        None
    }

    /// Whether every point of `cell`, a cell no surface meets, is inside, proven at once
    /// from a corner's sample (`corner`); `None`: not proven (the default), the builder
    /// asks [`AdfSource::inside_in_empty_cell`] at each test point.
    fn side_of_empty_cell(&self, _cell: &Aabb, _corner: (DVec3, &Sample)) -> Option<bool> {
        None
    }

    /// [`AdfSource::side_of_empty_cell`] given the parent cell's candidates
    /// (`parent`, `None` at the top), whose certified bounds may prove the side without a
    /// query. Must return `None` or the same side (the default calls
    /// `side_of_empty_cell`).
    fn side_of_empty_cell_in(
        &self,
        cell: &Aabb,
        corner: (DVec3, &Sample),
        _parent: Option<&CellCandidates>,
    ) -> Option<bool> {
        self.side_of_empty_cell(cell, corner)
    }

    /// Whether the sign may change away from any surface (an open mesh's inside across a
    /// hole). Then a cell far from the surface is pruned only if its test points confirm
    /// its corners' sign.
    fn may_jump(&self) -> bool {
        false
    }

    /// The surface's area and total absolute mean curvature, for the build's a-priori
    /// estimate ([`crate::Adf::estimate`]). `None` (the default): unknown; the estimate
    /// then takes the source's bounding box as a convex stand-in (exact bounds for any
    /// convex shape inside it, an underestimate for a non-convex one).
    fn surface_measures(&self) -> Option<SurfaceMeasures> {
        None
    }
}

/// What the build's estimate needs to know of a surface ([`AdfSource::surface_measures`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMeasures {
    /// Area (world units²).
    pub area: f64,
    /// Total absolute mean curvature `∫|H| dA` (world units): for a triangle mesh
    /// `½ Σ Lₑ θₑ` over its edges (length × angle between the two faces' normals, π at a
    /// boundary edge, where the distance wraps around the edge); `4πr` for a sphere;
    /// `2π ×` the mean width for any convex body (`π(a + b + c)` for an `a × b × c` box).
    pub curvature: f64,
}

impl SurfaceMeasures {
    /// The measures of an `a × b × c` box: upper bounds for every convex body inside it
    /// (area and mean width are monotone under inclusion of convex bodies).
    pub fn of_box(size: DVec3) -> Self {
        SurfaceMeasures {
            area: 2.0 * (size.x * size.y + size.y * size.z + size.z * size.x),
            curvature: std::f64::consts::PI * (size.x + size.y + size.z),
        }
    }

    /// The measures of a triangle mesh (positions welded where exactly equal, so seams
    /// split for texture coordinates do not count as boundaries). Degenerate triangles
    /// count for nothing; an edge shared by more than two triangles counts π per extra
    /// triangle.
    pub fn of_mesh(mesh: &TriMesh) -> Self {
        let mut ids: rustc_hash::FxHashMap<[u64; 3], u32> = Default::default();
        let mut canonical = Vec::with_capacity(mesh.positions.len());
        for p in &mesh.positions {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            let next = ids.len() as u32;
            canonical.push(*ids.entry(key).or_insert(next));
        }
        let mut area = 0.0;
        // Per edge: its length and the unit normals of the triangles on it.
        let mut edges: rustc_hash::FxHashMap<(u32, u32), (f64, Vec<DVec3>)> = Default::default();
        for (t, corners) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = mesh.triangle(t);
            let n = (b - a).cross(c - a);
            let len = n.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            area += 0.5 * len;
            let unit = n / len;
            for (i, j) in [(0, 1), (1, 2), (2, 0)] {
                let (u, v) = (canonical[corners[i] as usize], canonical[corners[j] as usize]);
                let key = (u.min(v), u.max(v));
                let length = mesh.positions[corners[i] as usize].distance(mesh.positions[corners[j] as usize]);
                edges.entry(key).or_insert_with(|| (length, Vec::new())).1.push(unit);
            }
        }
        let mut curvature = 0.0;
        for (length, normals) in edges.values() {
            let angle = match normals.as_slice() {
                [_] => std::f64::consts::PI,
                [n1, n2] => n1.dot(*n2).clamp(-1.0, 1.0).acos(),
                [n1, n2, rest @ ..] => n1.dot(*n2).clamp(-1.0, 1.0).acos() + std::f64::consts::PI * rest.len() as f64,
                [] => 0.0,
            };
            curvature += 0.5 * length * angle;
        }
        SurfaceMeasures { area, curvature }
    }
}

/// What a source narrowed for one cell of the build ([`AdfSource::candidates`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CellCandidates {
    /// Ids of the primitives, or of groups of them, that can hold the nearest surface
    /// point of any point of the cell (a mesh: clusters of triangles,
    /// `MeshSource::triangles_of` gives their triangles).
    pub ids: Vec<u32>,
    /// When as long as `ids`: a lower bound, for every point of the cell, of the squared
    /// distance to each primitive, ascending (`ids` in that order), so a scan for the
    /// nearest one stops at the first bound above its best (a mesh: the squared gap
    /// between the cell and the cluster's box, rounded down to `f32`). Empty: `ids` in no
    /// particular order.
    pub lower: Vec<f64>,
    /// Certified bounds over the cell of a quantity the source decides signs with (a mesh
    /// with holes: the caps' winding number `w_C`), when it could bound it.
    pub sign_bounds: Option<(f64, f64)>,
    /// Ids of further sheets a segment inside the cell may cross, found once for the
    /// cell (a mesh with holes: the cap triangles whose boxes meet the cell).
    pub sheets: Vec<u32>,
    /// A certified first-order model over the cell of the winding number the sign is
    /// the side of ½ of, when no surface meets the cell and `sign_bounds` could not be
    /// had (a mesh with holes: `CappedWinding::winding_model`), so most points of a
    /// cell the surface spanning a hole passes through get their side without a query.
    pub sign_model: Option<volga_mesh::WindingModel>,
}

impl CellCandidates {
    /// The ids whose bound is 0 when the list is sorted (`lower`), else all: with a
    /// mesh, the clusters whose boxes meet the cell. Their triangles include every
    /// triangle whose box meets the cell, which is all a segment inside the cell can
    /// cross, so a count of crossings filtered by the segment's box sees the same ones.
    pub fn meeting_cell(&self) -> &[u32] {
        if self.lower.len() == self.ids.len() {
            &self.ids[..self.lower.partition_point(|&g| g <= 0.0)]
        } else {
            &self.ids
        }
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

/// Forwards every [`AdfSource`] method through a pointer, so `&S` and `Box<S>` can
/// never silently fall back to a default a new method adds (one list, both impls; their
/// [`DistanceSource`] methods are forwarded by `volga-shapes` the same way).
macro_rules! forward_adf_source {
    ($($ptr:ty),*) => {$(
        impl<S: AdfSource + ?Sized> AdfSource for $ptr {
            fn sample(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Sample {
                (**self).sample(p, near)
            }
            fn candidates(&self, cell: &Aabb, reach: f64, parent: Option<&CellCandidates>) -> Option<CellCandidates> {
                (**self).candidates(cell, reach, parent)
            }
            fn sign_model(
                &self,
                cell: &Aabb,
                corner: (DVec3, &Sample),
                candidates: &CellCandidates,
            ) -> Option<volga_mesh::WindingModel> {
                (**self).sign_model(cell, corner, candidates)
            }
            fn sample_among(&self, p: DVec3, near: Option<(DVec3, &Sample)>, candidates: &CellCandidates) -> Sample {
                (**self).sample_among(p, near, candidates)
            }
            fn sign_field(&self, p: DVec3) -> Option<f64> {
                (**self).sign_field(p)
            }
            fn may_jump(&self) -> bool {
                (**self).may_jump()
            }
            fn side_of_empty_cell(&self, cell: &Aabb, corner: (DVec3, &Sample)) -> Option<bool> {
                (**self).side_of_empty_cell(cell, corner)
            }
            fn sign_field_at(&self, p: DVec3, sample: &Sample) -> Option<f64> {
                (**self).sign_field_at(p, sample)
            }
            fn side_of_empty_cell_in(
                &self,
                cell: &Aabb,
                corner: (DVec3, &Sample),
                parent: Option<&CellCandidates>,
            ) -> Option<bool> {
                (**self).side_of_empty_cell_in(cell, corner, parent)
            }
            fn inside_in_empty_cell(&self, p: DVec3, near: (DVec3, &Sample)) -> Option<bool> {
                (**self).inside_in_empty_cell(p, near)
            }
            fn surface_measures(&self) -> Option<SurfaceMeasures> {
                (**self).surface_measures()
            }
        }
    )*};
}

forward_adf_source!(&S, Box<S>);

/// A shape of the geometry layer: the build's defaults (an exact distance, no narrowing).
impl<S: SignedDistance + Sync> AdfSource for ShapeSource<S> {}

/// A sampled (or any) field of signed-distance kind as a source: its reconstruction is the
/// distance. Refused for densities and occupancies, whose values are not distances.
#[derive(Debug, Clone)]
pub struct FieldSource<F>(F);

impl<F: Field> FieldSource<F> {
    /// `field` as a source; refused ([`crate::AdfError::NotADistance`]) unless its kind
    /// is [`FieldKind::SignedDistance`].
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

/// The build's defaults (a sampled field has no shortcuts).
impl<F: Field> AdfSource for FieldSource<F> {}

/// A CSG operator on signed distances: union `min`, intersection `max`, difference
/// `max(a, −b)`. The result is exact outside a union and inside an intersection and a
/// conservative (never larger in magnitude) bound elsewhere, the standard CSG of distance
/// fields; the zero set is exactly the CSG surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CsgOp {
    /// `min(a, b)`: inside either.
    Union,
    /// `max(a, b)`: inside both.
    Intersection,
    /// `max(a, −b)`: inside `a` and outside `b`.
    Difference,
}

impl CsgOp {
    /// The combined signed distance of `a` and `b`.
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
    /// The operator.
    pub op: CsgOp,
    /// The first operand (the one a difference keeps).
    pub a: A,
    /// The second operand (the one a difference removes).
    pub b: B,
}

impl<A: DistanceSource, B: DistanceSource> DistanceSource for Csg<A, B> {
    fn distance(&self, p: DVec3) -> f64 {
        self.op.apply(self.a.distance(p), self.b.distance(p))
    }
    /// The operator applied to the operands' ranges ([`CsgOp::apply_range`]: the
    /// operators are monotone in each operand, so this contains every value).
    fn range(&self, world_box: &Aabb) -> (f64, f64) {
        self.op.apply_range(self.a.range(world_box), self.b.range(world_box))
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

impl<A: DistanceSource, B: DistanceSource> AdfSource for Csg<A, B> {
    /// The operands' sign fields are not combined (a jump of either operand survives only
    /// where it decides the result); `None`.
    fn sign_field(&self, _p: DVec3) -> Option<f64> {
        None
    }
}
