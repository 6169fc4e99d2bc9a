//! Certified inside/outside for any triangle mesh: the sign of `w(p) − ½`, where `w` is
//! the generalized winding number, proven for every voxel (see `docs/VOXELIZE.md`).
//!
//! ## The identity behind the fast path
//! Take the mesh `M` as a 2-chain: its boundary `∂M` (each edge with the net number of
//! times the triangles run along it, forwards minus backwards) is a 1-cycle, whether the
//! mesh is closed, open, non-manifold, self-intersecting or inconsistently oriented. Its
//! loops are closed here by cones `C` (one apex per loop, lifted off the loop's plane), so
//! `M + C` is closed and its winding number `I = w_M + w_C` is an **integer** off the
//! surface, changing only across a sheet of `M + C`. Two consequences:
//!
//! * On a triangle `t` that no other triangle of `M + C` crosses ("clean"), `I` takes one
//!   integer `I⁺` just in front of it and `I⁺ + 1` just behind, and the same across
//!   every clean, consistently oriented manifold edge: one certified query per connected
//!   region of clean triangles gives `I⁺` exactly. Then `w̄_M = I⁺ + ½ − w_C` on `t`.
//! * `∇w_M = −∇w_C` off the surface is the Biot–Savart field of the boundary cycle, so
//!   `|∇w| ≤ Σ_e |m_e| ∫_e dl/|x − p|² / 4π` ([`volga_mesh::SegmentTree::gradient_bound`]); for a
//!   closed mesh it is 0 and `w` is constant between sheets.
//!
//! A band voxel `p` whose nearest point `q` lies on clean triangle `t` (with a clean,
//! manifold star when `q` is on an edge or corner) has `w(p) = w̄_M(q) ± ½ + ∫_q^p ∇w`,
//! with the side from the pseudo-normal (Bærentzen & Aanæs 2005). Every term is known
//! with a certified bound; when the interval straddles ½, the voxel's integer `I` is
//! carried from `q` (or from `t`'s centroid) by the proven signed crossings of the caps
//! and the mesh on the way (`I` jumps by exactly ±1 at each), and the voxel asks only
//! `w_C(p)`; last, the mesh's certified winding number
//! ([`volga_mesh::Bvh::winding_number_bounded`]), refined until it proves its side. The
//! same carried integers spare the whole mesh's query beyond the band.
//!
//! ## Where the proofs live
//! * [`oracle`]: what is learned once per mesh ([`SignOracle`]): the boundary cycle and
//!   its caps, clean triangles, `I⁺` per region and `w̄_M` per triangle.
//! * `clean`: which triangles another triangle (or a cap) crosses.
//! * `band`: the sign of a band voxel (nearest triangle's interval, caps, certified
//!   winding number), and the certified queries the other proofs share.
//! * `crossings`: a known integer `I` carried from point to point by the proven signed
//!   crossings ([`volga_mesh::signed_crossing`]) of the caps and the mesh.
//! * `flood`: voxels beyond the band inside a band brick (flood fill from band voxels,
//!   boxes within the brick).
//! * `far`: bricks no band reaches (components of bricks, or an octree of boxes).

mod band;
mod clean;
mod crossings;
mod far;
mod flood;
mod oracle;

pub(crate) use band::Slack;
pub(crate) use oracle::{MeshTopology, SignOracle};

/// How each voxel's sign was proven; the counts go to reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct SignStats {
    /// Band voxels decided by their nearest triangle's certified interval.
    pub fast_voxels: u64,
    /// Band voxels decided by a carried integer `I` and the caps' winding number `w_C(p)`
    /// alone (`w = I` itself on a mesh without caps).
    pub cap_voxels: u64,
    /// Voxels that asked the whole mesh's certified winding number: in the band, and
    /// beyond it (where a flood fill or an octree box could not prove its sign).
    pub exact_voxels: u64,
    /// Of those, the band voxels (the rest lie beyond the band).
    pub exact_band_voxels: u64,
    /// Of those, solid angles summed one by one (the cost of the fallback).
    pub exact_triangles: u64,
    /// Terms (expansions and exact solid angles) summed by all certified queries.
    pub query_terms: u64,
    /// Certified winding queries for regions of voxels or bricks beyond the band.
    pub region_queries: u64,
    /// Triangles another triangle (or a cap) crosses or touches off their shared
    /// edges and corners: their band voxels take the slow path.
    pub unclean_triangles: u64,
    /// Edges of the boundary cycle (net multiplicity ≠ 0) and cap triangles closing it.
    pub boundary_cycle_edges: u64,
}

impl SignStats {
    /// Adds the per-voxel counts of `other` (the per-mesh ones, unclean triangles and
    /// boundary cycle edges, are not summed).
    pub fn add(&mut self, other: &SignStats) {
        self.fast_voxels += other.fast_voxels;
        self.cap_voxels += other.cap_voxels;
        self.exact_voxels += other.exact_voxels;
        self.exact_band_voxels += other.exact_band_voxels;
        self.exact_triangles += other.exact_triangles;
        self.region_queries += other.region_queries;
        self.query_terms += other.query_terms;
    }
}
