//! Triangle meshes: narrow-band distances, anti-aliased solids and shells, and signed
//! distance fields (survey §17.4), with a clear answer for meshes that are not closed.
//!
//! ## Distance
//! Exact point–triangle distances (Ericson's closest point): triangles are binned into
//! 8³ bricks with their band, and each voxel keeps its nearest triangle (the first in a
//! fixed order among equals, so the result is independent of thread count). Work is
//! proportional to the surface: about (triangle area + band) voxels per triangle.
//! Per-triangle data is stored in Morton order of the centroids, so the triangles of
//! one brick are neighbours in memory too. Each triangle is evaluated only in the
//! regions where it can be nearest (its face's prism, and the wedges and cones of the
//! edges and vertices it owns; see the `regions` module), about two evaluations per band
//! voxel.
//!
//! ## Sign: inside means generalized winding number ≥ ½, proven per voxel
//! The documented answer for every mesh, closed or not, is the generalized winding
//! number `w(p)` (Jacobson et al. 2013): inside iff `w(p) ≥ ½`, with `w` on the surface
//! itself its principal value (the mean of the two sides). For a closed, consistently
//! oriented mesh that is the usual inside; for an open scan like the Stanford bunny it
//! fills the holes the way the surface suggests; overlapping, self-intersecting,
//! flipped and flat parts get their exact `w` too. Every sign is **proven**, not
//! estimated (the `sign` module): a band voxel takes its nearest triangle's certified
//! interval when the interval clears ½, else the caps' winding number, else the mesh's
//! certified winding number refined until its error bound clears ½ (exactly summed at
//! worst). Voxels beyond the band take their sign by flood fill from band voxels inside
//! their brick (a 6-step is shorter than the band, so it crosses no sheet), trusted only
//! as far as the gradient bound allows on open meshes; bricks the band does not reach are
//! classified by certified queries per face-connected component (no boundary: `w` is
//! constant between sheets) or per octree box, refined down to single voxels where the
//! level set `w = ½` passes far from the surface (open meshes).

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::{Aabb, Brick, Grid, IndexBox, Progress, SparseVolume, BRICK_DIM, BRICK_VOXELS};
use volga_mesh::{closest_point_on_triangle, Bvh, Feature, TriMesh};

use crate::mask::BrickMask;
use crate::regions::{EdgeUse, FeatureRegions};
use crate::sign::{MeshTopology, SignOracle, SignStats};
use crate::tri_distance::{BandColumns, Nearest, TriDistance};
use crate::{OrientedBoxFilter, SurfaceMode};

/// A mesh prepared for distance voxelization: BVH, pseudo-normals, boundary flags and
/// per-triangle winding numbers.
#[derive(Debug, Clone)]
pub struct MeshVoxelizer {
    triangles: Vec<[DVec3; 3]>,
    bvh: Bvh,
    /// Unit face normal (zero for degenerate triangles).
    face_normal: Vec<DVec3>,
    /// Per triangle and edge k (corner k → k+1): pseudo-normal, and whether the edge is
    /// a boundary or non-manifold edge.
    edge_normal: Vec<[DVec3; 3]>,
    edge_ambiguous: Vec<[bool; 3]>,
    /// Per triangle and corner: the welded vertex's angle-weighted pseudo-normal and
    /// whether the vertex touches a boundary or non-manifold edge.
    vertex_normal: Vec<[DVec3; 3]>,
    vertex_ambiguous: Vec<[bool; 3]>,
    boundary_edges: usize,
    distance: Vec<TriDistance>,
    /// Face, edge and vertex regions that bound where each triangle can be nearest.
    regions: FeatureRegions,
    /// Certified signs: per-triangle principal values, caps, gradient bounds.
    sign: SignOracle,
}

/// [`MeshVoxelizer`]'s parts that do not need the BVH.
struct WithoutBvh {
    triangles: Vec<[DVec3; 3]>,
    face_normal: Vec<DVec3>,
    edge_normal: Vec<[DVec3; 3]>,
    vertex_normal: Vec<[DVec3; 3]>,
    boundary_edges: usize,
    distance: Vec<TriDistance>,
    regions: FeatureRegions,
    /// Voxelizer (Morton) order → mesh order.
    order: Vec<u32>,
    corners: Vec<[u32; 3]>,
    welded_pos: Vec<DVec3>,
    uses: Vec<EdgeUse>,
}

/// Welded positions, indexed by welded vertex.
fn welded_positions(mesh: &TriMesh, welded: &[u32], count: usize) -> Vec<DVec3> {
    let mut out = vec![DVec3::ZERO; count];
    for (i, &w) in welded.iter().enumerate() {
        out[w as usize] = mesh.positions[i];
    }
    out
}

/// Triangle order along a Morton (Z-order) curve of their centroids: neighbours in
/// this order are neighbours in space (ties by index, so the order is unique).
fn morton_order(mesh: &TriMesh) -> Vec<u32> {
    let bounds = mesh.bounds();
    let size = bounds.size().max(DVec3::splat(f64::MIN_POSITIVE));
    let mut keyed: Vec<(u64, u32)> = (0..mesh.triangles.len())
        .into_par_iter()
        .map(|i| {
            let [a, b, c] = mesh.triangle(i);
            let q =
                (((a + b + c) / 3.0 - bounds.min) / size * 2_097_151.0).clamp(DVec3::ZERO, DVec3::splat(2_097_151.0));
            (crate::pairs::morton3(q.x as u64, q.y as u64, q.z as u64), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

impl MeshVoxelizer {
    pub fn new(mesh: &TriMesh) -> Self {
        // The BVH (for winding numbers) is built from the mesh as given, alongside
        // everything else, which needs it only for meshes without simple boundary loops.
        let (bvh, rest) = rayon::join(|| Bvh::build(mesh), || Self::without_bvh(mesh));
        let sign = SignOracle::build(&MeshTopology {
            triangles: &rest.triangles,
            corners: &rest.corners,
            welded_pos: &rest.welded_pos,
            uses: &rest.uses,
            bvh: &bvh,
            to_bvh: &rest.order,
        });
        let edge_ambiguous = sign.edge_ok.iter().map(|ok| ok.map(|ok| !ok)).collect();
        let vertex_ambiguous = sign.vertex_ok.iter().map(|ok| ok.map(|ok| !ok)).collect();
        MeshVoxelizer {
            triangles: rest.triangles,
            bvh,
            face_normal: rest.face_normal,
            edge_normal: rest.edge_normal,
            edge_ambiguous,
            vertex_normal: rest.vertex_normal,
            vertex_ambiguous,
            boundary_edges: rest.boundary_edges,
            distance: rest.distance,
            regions: rest.regions,
            sign,
        }
    }

    /// Everything but the BVH, on the triangles in Morton order: the triangles a brick
    /// gathers then sit close together in memory (in mesh order they are scattered over
    /// the whole arrays, and cache misses dominated the band loop).
    fn without_bvh(mesh: &TriMesh) -> WithoutBvh {
        let order = morton_order(mesh);
        let mesh = &TriMesh {
            positions: mesh.positions.clone(),
            triangles: order.iter().map(|&i| mesh.triangles[i as usize]).collect(),
        };
        let triangles: Vec<[DVec3; 3]> = (0..mesh.triangles.len()).map(|i| mesh.triangle(i)).collect();

        // Weld exactly equal positions (loaders split vertices at texture seams).
        let mut weld: FxHashMap<[u64; 3], u32> = FxHashMap::default();
        let welded: Vec<u32> = mesh
            .positions
            .iter()
            .map(|p| {
                let key = p.to_array().map(|c| (c + 0.0).to_bits());
                let next = weld.len() as u32;
                *weld.entry(key).or_insert(next)
            })
            .collect();
        let corner = |t: usize, k: usize| welded[mesh.triangles[t][k] as usize];
        let welded_pos = welded_positions(mesh, &welded, weld.len());

        let face_normal: Vec<DVec3> = triangles
            .par_iter()
            .map(|[a, b, c]| (*b - *a).cross(*c - *a).normalize_or_zero())
            .collect();

        // Edges: every use (welded endpoints, triangle, corner), sorted so that the uses
        // of one edge are adjacent, lowest triangle first.
        let mut uses: Vec<EdgeUse> = Vec::with_capacity(3 * triangles.len());
        for t in 0..triangles.len() {
            for k in 0..3 {
                let (i, j) = (corner(t, k), corner(t, (k + 1) % 3));
                if i != j {
                    uses.push(EdgeUse {
                        key: (i.min(j) as u64) << 32 | i.max(j) as u64,
                        triangle: t as u32,
                        corner: k as u8,
                    });
                }
            }
        }
        uses.par_sort_unstable_by_key(|u| (u.key, u.triangle, u.corner));

        // Per triangle edge: how many faces use it, and the sum of their normals.
        let n_welded = weld.len();
        let mut edge_normal = vec![[DVec3::ZERO; 3]; triangles.len()];
        let mut boundary_edges = 0;
        for group in uses.chunk_by(|a, b| a.key == b.key) {
            let sum: DVec3 = group.iter().map(|u| face_normal[u.triangle as usize]).sum();
            for u in group {
                edge_normal[u.triangle as usize][u.corner as usize] = sum;
            }
            boundary_edges += (group.len() == 1) as usize;
        }

        // Vertices: angle-weighted normals (which features may use them: `sign`).
        let mut vnormal = vec![DVec3::ZERO; n_welded];
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (p, q, r) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
                let angle = (q - p).angle_between(r - p);
                if angle.is_finite() {
                    vnormal[corner(t, k) as usize] += face_normal[t] * angle;
                }
            }
        }
        let vertex_normal: Vec<[DVec3; 3]> = (0..triangles.len())
            .map(|t| [0, 1, 2].map(|k| vnormal[corner(t, k) as usize]))
            .collect();
        let regions = FeatureRegions::build(&triangles, &uses, &welded_pos, &vnormal);
        let distance = triangles.par_iter().map(|t| TriDistance::new(*t)).collect();
        let corners = (0..triangles.len()).map(|t| [0, 1, 2].map(|k| corner(t, k))).collect();
        WithoutBvh {
            triangles,
            face_normal,
            edge_normal,
            vertex_normal,
            boundary_edges,
            distance,
            regions,
            order,
            corners,
            welded_pos,
            uses,
        }
    }

    /// Upper bound on the bricks [`MeshVoxelizer::voxelize`] stores for a band of
    /// `band_world` on `grid`, plus the grid's brick count when the inside is filled
    /// (uniform bricks), computed from the triangles without allocating.
    pub fn estimate_bricks(mesh: &TriMesh, grid: &Grid, band_world: f64) -> (u64, u64) {
        let h = grid.min_spacing();
        let band = band_world / h;
        let per_triangle: u64 = (0..mesh.triangles.len())
            .map(|i| {
                let tri = mesh.triangle(i);
                let lo = tri[0].min(tri[1]).min(tri[2]);
                let hi = tri[0].max(tri[1]).max(tri[2]);
                let span = ((hi - lo) / h + 2.0 * band) / BRICK_DIM as f64 + 2.0;
                // Saturating: a triangle far larger than the grid must not overflow.
                let [x, y, z] = span.to_array().map(|s| s.floor() as u64);
                x.saturating_mul(y).saturating_mul(z)
            })
            .fold(0u64, u64::saturating_add);
        let grid_bricks = volga_core::brick_extent(grid.dims()).as_u64vec3().element_product();
        (per_triangle.min(grid_bricks), grid_bricks)
    }

    /// Edges used by exactly one triangle (after welding): 0 for a closed mesh.
    pub fn boundary_edge_count(&self) -> usize {
        self.boundary_edges
    }

    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// How each sign was proven in the last call is returned by
    /// [`MeshVoxelizer::voxelize_with_stats`]; this is what was learned while building:
    /// unclean triangles and the boundary cycle.
    pub fn sign_stats(&self) -> SignStats {
        self.sign.stats
    }

    /// The sign of a band voxel at `p` whose nearest triangle is `t`, `d2` away (squared),
    /// with its proven margin `|w − ½|` (a lower bound) and how it was proven. `slack` is
    /// the half-width of `t`'s certified interval of `w` near `t` (see `sign`).
    fn decide(&self, p: DVec3, t: usize, d2: f64, slack: f64, stats: &mut SignStats) -> (bool, f64) {
        let sign = &self.sign;
        let (c, feature) = closest_point_on_triangle(p, self.triangles[t]);
        let (normal, ok) = match feature {
            Feature::Face => (self.face_normal[t], true),
            Feature::Edge(k) => (self.edge_normal[t][k], !self.edge_ambiguous[t][k]),
            Feature::Vertex(k) => (self.vertex_normal[t][k], !self.vertex_ambiguous[t][k]),
        };
        let along = (p - c).dot(normal);
        // The side is trusted well above the rounding of `p − c` and of the normal.
        let tolerance = 1e-12 * (p.abs().max_element() + (p - c).length()) * normal.length();
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
            if !sign.closed && !sign.cap_within(p, d2.sqrt()) {
                // No cap between `p` and its nearest point: `w(p) = I − w_C(p)` with the
                // region's integer `I` on this side.
                let threshold = (sign.front[t] + behind as i64) as f64 - 0.5;
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
    fn integer_at(&self, p: DVec3) -> (Option<f64>, u32) {
        let Some(cap) = self.sign.cap.as_ref() else {
            return (None, 0);
        };
        let c0 = cap.winding_number_bounded(p, None, |_, e| e < 0.05);
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
    /// precision near ½ is bought on the caps' small tree. Where `I` cannot be proven an
    /// integer (a point on a cap), the mesh's tree is refined directly.
    fn certified(
        &self,
        p: DVec3,
        known: Option<f64>,
        mut stop: impl FnMut(f64, f64) -> bool,
    ) -> volga_mesh::WindingBound {
        let mut terms = 0;
        if let Some(cap) = &self.sign.cap {
            let i = known.or_else(|| {
                let (i, t) = self.integer_at(p);
                terms = t;
                i
            });
            if let Some(i) = i {
                let c = cap.winding_number_bounded(p, None, |w, e| stop(i - w, e));
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
    fn exact_side(&self, p: DVec3, known: Option<f64>, stats: &mut SignStats) -> (bool, f64) {
        let b = self.certified(p, known, |w, e| (w - 0.5).abs() > e);
        stats.exact_voxels += 1;
        stats.exact_triangles += b.exact_triangles as u64;
        stats.query_terms += b.terms as u64;
        (b.value >= 0.5, b.margin(0.5))
    }

    /// The certified winding number at `p`, refined until its margin from ½ is proven
    /// to exceed `needed`, or proven not to.
    fn margin_query(&self, p: DVec3, known: Option<f64>, needed: f64) -> volga_mesh::WindingBound {
        self.certified(p, known, |w, e| {
            let gap = (w - 0.5).abs();
            gap - e > needed || gap + e <= needed
        })
    }

    /// `I` for a region free of the mesh whose box (centre, radius) no cap reaches.
    fn region_integer(&self, centre: DVec3, radius: f64) -> Option<f64> {
        (self.sign.cap.is_some() && !self.sign.cap_within(centre, radius))
            .then(|| self.integer_at(centre).0)
            .flatten()
    }

    /// The inside voxels of one brick beyond the band (`unknown`). Each 6-connected
    /// component takes the sign of the band voxels next to it: a 6-step from a voxel
    /// beyond the band is shorter than the band, so it crosses no sheet. Without a
    /// boundary (`w` constant between sheets) that is exact; otherwise `w` drifts by at
    /// most the gradient bound times the path, and the component keeps the sign only
    /// while the seeds' proven margin covers the drift. Components touching no band
    /// voxel take a certified query at their first voxel on the same terms; the rest
    /// ask every voxel.
    #[allow(clippy::too_many_arguments)]
    fn flood_signs(
        &self,
        brick: IVec3,
        inside_band: BrickMask,
        outside_band: BrickMask,
        margin: &[f64; BRICK_VOXELS],
        unknown: BrickMask,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> BrickMask {
        let (touches_inside, touches_outside) = (inside_band.dilate6(), outside_band.dilate6());
        let centre = |o: usize| {
            let ijk = brick * BRICK_DIM + IVec3::new(o as i32 % 8, o as i32 / 8 % 8, o as i32 / 64);
            grid.transform.voxel_center(ijk)
        };
        // `w` drifts by at most this much per 6-step inside the brick.
        let step_drift = if self.sign.closed {
            0.0
        } else {
            let lo = grid.transform.index_to_world((brick * BRICK_DIM).as_dvec3() - 0.5);
            let hi = grid
                .transform
                .index_to_world(((brick + 1) * BRICK_DIM).as_dvec3() - 0.5);
            self.sign.boundary.gradient_bound(&Aabb::new(lo.min(hi), lo.max(hi))) * grid.max_spacing()
        };
        // Steps from `start` to cover `component` (6-connected, so it ends).
        let depth = |start: BrickMask, component: BrickMask| {
            let (mut covered, mut steps) = (start, 1u32);
            while covered != component {
                covered = covered.dilate6().and(&component);
                steps += 1;
            }
            steps as f64
        };
        let seed_margin = |seeds: BrickMask| {
            let mut min = f64::INFINITY;
            let mut left = seeds;
            while let Some(o) = left.first() {
                left.remove(o);
                min = min.min(margin[o]);
            }
            min
        };
        let mut inside = inside_band;
        let mut rest = unknown;
        while let Some(first) = rest.first() {
            let mut component = BrickMask::EMPTY;
            component.insert(first);
            component = component.flood(&rest);
            rest = rest.and_not(&component);
            let (by_inside, by_outside) = (component.and(&touches_inside), component.and(&touches_outside));
            let decided = match (!by_inside.is_empty(), !by_outside.is_empty()) {
                (true, false) => {
                    let m = seed_margin(inside_band.and(&component.dilate6()));
                    (step_drift == 0.0 || m > step_drift * depth(by_inside, component)).then_some(true)
                }
                (false, true) => {
                    let m = seed_margin(outside_band.and(&component.dilate6()));
                    (step_drift == 0.0 || m > step_drift * depth(by_outside, component)).then_some(false)
                }
                (false, false) => {
                    let mut start = BrickMask::EMPTY;
                    start.insert(first);
                    let needed = if step_drift == 0.0 {
                        0.0
                    } else {
                        step_drift * (depth(start, component) - 1.0)
                    };
                    let w = self.margin_query(centre(first), None, needed);
                    stats.query_terms += w.terms as u64;
                    stats.region_queries += 1;
                    (w.margin(0.5) > needed || (needed == 0.0 && w.side(0.5).is_some())).then_some(w.value >= 0.5)
                }
                (true, true) => None,
            };
            match decided {
                Some(true) => inside = inside.or(&component),
                Some(false) => {}
                None if self.sign.cap.is_some() => {
                    // `I = w_M + w_C` is one integer on each connected set of these
                    // voxels farther than a step from every cap (a step between two of
                    // them crosses neither the mesh nor a cap): one integer query per
                    // set, then boxes and voxels ask only the caps' small tree. Voxels
                    // within a step of a cap ask the whole mesh.
                    let step = grid.max_spacing();
                    let mut far = BrickMask::EMPTY;
                    let mut left = component;
                    while let Some(o) = left.first() {
                        left.remove(o);
                        if !self.sign.cap_within(centre(o), step) {
                            far.insert(o);
                        }
                    }
                    let mut near = component.and_not(&far);
                    while let Some(first) = far.first() {
                        let mut set = BrickMask::EMPTY;
                        set.insert(first);
                        set = set.flood(&far);
                        far = far.and_not(&set);
                        let (known, terms) = self.integer_at(centre(first));
                        stats.query_terms += terms as u64;
                        stats.region_queries += 1;
                        inside = inside.or(&self.prove_in_brick(brick, set, 0, 8, known, grid, stats));
                    }
                    while let Some(o) = near.first() {
                        near.remove(o);
                        if self.exact_side(centre(o), None, stats).0 {
                            inside.insert(o);
                        }
                    }
                }
                None => {
                    // Octants of the brick wholly in the component are free of sheets:
                    // prove them box by box, down to single voxels.
                    inside = inside.or(&self.prove_in_brick(brick, component, 0, 8, None, grid, stats));
                }
            }
        }
        inside
    }

    /// The inside voxels of `allowed` (voxels beyond the band of one brick) within the
    /// cube of side `size` at brick-local corner `lo` (packed `x + 8y + 64z`). A cube
    /// wholly in `allowed` holds no sheet, so it takes the sign of its centre when the
    /// certified margin there exceeds the gradient bound times its radius; otherwise it
    /// splits, and single voxels ask the certified winding number.
    #[allow(clippy::too_many_arguments)]
    fn prove_in_brick(
        &self,
        brick: IVec3,
        allowed: BrickMask,
        lo: usize,
        size: usize,
        known: Option<f64>,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> BrickMask {
        let corner = IVec3::new((lo % 8) as i32, (lo / 8 % 8) as i32, (lo / 64) as i32);
        let cube = IndexBox::new(corner, corner + size as i32);
        let region = BrickMask::of_region(IVec3::ZERO, &cube);
        let here = region.and(&allowed);
        if here.is_empty() {
            return BrickMask::EMPTY;
        }
        let t = &grid.transform;
        let base = brick * BRICK_DIM;
        if size == 1 {
            let (inside, _) = self.exact_side(t.voxel_center(base + corner), known, stats);
            return if inside { here } else { BrickMask::EMPTY };
        }
        if here == region {
            let (a, b) = (
                t.voxel_center(base + corner),
                t.voxel_center(base + corner + size as i32 - 1),
            );
            let (p_lo, p_hi) = (a.min(b), a.max(b));
            let radius = 0.5 * (p_hi - p_lo).length();
            let drift = self.sign.boundary.gradient_bound(&Aabb::new(p_lo, p_hi)) * radius;
            let w = self.margin_query(0.5 * (p_lo + p_hi), known, drift);
            stats.query_terms += w.terms as u64;
            stats.region_queries += 1;
            if w.margin(0.5) > drift {
                return if w.value >= 0.5 { here } else { BrickMask::EMPTY };
            }
        }
        let half = size / 2;
        let mut inside = BrickMask::EMPTY;
        for k in 0..8 {
            let o = (k & 1) * half + ((k >> 1) & 1) * half * 8 + (k >> 2) * half * 64;
            inside = inside.or(&self.prove_in_brick(brick, allowed, lo + o, half, known, grid, stats));
        }
        inside
    }

    /// Boundary-free meshes: `w` is constant between sheets and 0 outside the mesh's
    /// bounds, so face-connected bricks that no band reaches share their sign. Label
    /// them by flood fill and prove the sign once per component.
    fn inside_bricks_by_components(
        &self,
        candidates: &[IVec3],
        band: &rustc_hash::FxHashSet<IVec3>,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> Vec<IVec3> {
        let set: rustc_hash::FxHashSet<IVec3> = candidates.iter().copied().collect();
        let mut label: FxHashMap<IVec3, bool> = FxHashMap::default();
        let mut inside = Vec::new();
        for &start in candidates {
            if label.contains_key(&start) {
                continue;
            }
            let centre = grid.transform.index_to_world((start * BRICK_DIM).as_dvec3() + 3.5);
            let is_inside = self.exact_side(centre, None, stats).0;
            stats.region_queries += 1;
            let mut stack = vec![start];
            label.insert(start, is_inside);
            while let Some(b) = stack.pop() {
                if is_inside {
                    inside.push(b);
                }
                for o in [IVec3::X, IVec3::NEG_X, IVec3::Y, IVec3::NEG_Y, IVec3::Z, IVec3::NEG_Z] {
                    let nb = b + o;
                    if set.contains(&nb) && !band.contains(&nb) && !label.contains_key(&nb) {
                        label.insert(nb, is_inside);
                        stack.push(nb);
                    }
                }
            }
        }
        inside.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        inside
    }

    /// Meshes with a boundary: `w` varies smoothly away from the surface (through the
    /// holes, and outside the mesh's bounds where stacked sheets can reach ½), so the
    /// whole grid beyond the band is classified by an octree of voxel boxes: a box no band
    /// reaches takes the sign of its centre when the certified margin there exceeds the
    /// gradient bound times the box's radius; otherwise it splits, down to single voxels.
    /// Returns the wholly inside bricks and the partly inside ones as masks.
    fn inside_by_octree(
        &self,
        touched: &rustc_hash::FxHashSet<IVec3>,
        grid: &Grid,
        stats: &mut SignStats,
    ) -> (Vec<IVec3>, Vec<(IVec3, BrickMask)>) {
        let extent = volga_core::brick_extent(grid.dims());
        // Prefix sums of touched bricks: "does this box hold band" in O(1).
        let (ex, ey, ez) = (extent.x as usize + 1, extent.y as usize + 1, extent.z as usize + 1);
        let mut prefix = vec![0u32; ex * ey * ez];
        let at = |x: usize, y: usize, z: usize| (z * ey + y) * ex + x;
        for z in 1..ez {
            for y in 1..ey {
                for x in 1..ex {
                    let own = touched.contains(&IVec3::new(x as i32 - 1, y as i32 - 1, z as i32 - 1)) as u32;
                    prefix[at(x, y, z)] =
                        own + prefix[at(x - 1, y, z)] + prefix[at(x, y - 1, z)] + prefix[at(x, y, z - 1)]
                            - prefix[at(x - 1, y - 1, z)]
                            - prefix[at(x - 1, y, z - 1)]
                            - prefix[at(x, y - 1, z - 1)]
                            + prefix[at(x - 1, y - 1, z - 1)];
                }
            }
        }
        let band_in = |lo: IVec3, hi: IVec3| {
            let (l, h) = (lo.as_uvec3(), hi.as_uvec3());
            let (l, h) = (
                (l.x as usize, l.y as usize, l.z as usize),
                (h.x as usize, h.y as usize, h.z as usize),
            );
            prefix[at(h.0, h.1, h.2)]
                + prefix[at(l.0, l.1, h.2)]
                + prefix[at(l.0, h.1, l.2)]
                + prefix[at(h.0, l.1, l.2)]
                - prefix[at(l.0, h.1, h.2)]
                - prefix[at(h.0, l.1, h.2)]
                - prefix[at(h.0, h.1, l.2)]
                - prefix[at(l.0, l.1, l.2)]
                > 0
        };
        let grid_box = grid.index_box();
        let mut size = BRICK_DIM;
        while size < grid.dims().max_element() as i32 {
            size *= 2;
        }
        let results = [self.classify_box(
            None,
            IndexBox::new(IVec3::ZERO, IVec3::splat(size)),
            &grid_box,
            &band_in,
            grid,
        )];
        let mut full = Vec::new();
        let mut partial: FxHashMap<IVec3, BrickMask> = FxHashMap::default();
        for (boxes, local) in results {
            stats.add(&local);
            for b in boxes {
                let bricks = IndexBox::new(
                    b.min.div_euclid(IVec3::splat(BRICK_DIM)),
                    (b.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)),
                );
                for brick in bricks.iter() {
                    let own = IndexBox::new(brick * BRICK_DIM, (brick + 1) * BRICK_DIM).intersection(&grid_box);
                    if own.intersection(&b) == own {
                        full.push(brick);
                    } else {
                        let mask = partial.entry(brick).or_default();
                        *mask = mask.or(&BrickMask::of_region(brick, &b));
                    }
                }
            }
        }
        full.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        let mut partial: Vec<(IVec3, BrickMask)> = partial.into_iter().collect();
        partial.sort_unstable_by_key(|(b, _)| (b.z, b.y, b.x));
        (full, partial)
    }

    /// One octree box (voxel index space, a power-of-two cube, clipped to the grid):
    /// its inside voxels as boxes, and the queries it took.
    fn classify_box(
        &self,
        known: Option<f64>,
        cube: IndexBox,
        grid_box: &IndexBox,
        band_in: &(dyn Fn(IVec3, IVec3) -> bool + Sync),
        grid: &Grid,
    ) -> (Vec<IndexBox>, SignStats) {
        let mut stats = SignStats::default();
        let region = cube.intersection(grid_box);
        if region.is_empty() {
            return (Vec::new(), stats);
        }
        let size = (cube.max - cube.min).x;
        if size >= BRICK_DIM {
            let lo = region.min.div_euclid(IVec3::splat(BRICK_DIM));
            let hi = (region.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM));
            if band_in(lo, hi) {
                if size > BRICK_DIM {
                    return self.split(None, cube, grid_box, band_in, grid);
                }
                return (Vec::new(), stats); // a band brick: its voxels are the band's
            }
        }
        // No band in the box: no sheet either, so straight paths inside it cross none.
        let t = &grid.transform;
        let (a, b) = (t.voxel_center(region.min), t.voxel_center(region.max - IVec3::ONE));
        let (lo, hi) = (a.min(b), a.max(b));
        let centre = 0.5 * (lo + hi);
        let radius = 0.5 * (hi - lo).length();
        let drift = self.sign.boundary.gradient_bound(&Aabb::new(lo, hi)) * radius;
        if size == 1 {
            let (inside, _) = self.exact_side(centre, known, &mut stats);
            return (if inside { vec![region] } else { Vec::new() }, stats);
        }
        let w = self.margin_query(centre, known, drift);
        stats.query_terms += w.terms as u64;
        stats.region_queries += 1;
        if w.margin(0.5) > drift {
            (if w.value >= 0.5 { vec![region] } else { Vec::new() }, stats)
        } else {
            // Free of the mesh; if no cap reaches it, `I` is one integer over it.
            let known = known.or_else(|| self.region_integer(centre, radius));
            let (boxes, more) = self.split(known, cube, grid_box, band_in, grid);
            stats.add(&more);
            (boxes, stats)
        }
    }

    /// The eight octants of `cube`, in parallel while they are large.
    fn split(
        &self,
        known: Option<f64>,
        cube: IndexBox,
        grid_box: &IndexBox,
        band_in: &(dyn Fn(IVec3, IVec3) -> bool + Sync),
        grid: &Grid,
    ) -> (Vec<IndexBox>, SignStats) {
        let half = (cube.max - cube.min).x / 2;
        let octant = |k: i32| {
            let lo = cube.min + IVec3::new(k & 1, (k >> 1) & 1, k >> 2) * half;
            self.classify_box(known, IndexBox::new(lo, lo + half), grid_box, band_in, grid)
        };
        let parts: Vec<(Vec<IndexBox>, SignStats)> = if half >= 4 * BRICK_DIM {
            (0..8).into_par_iter().map(octant).collect()
        } else {
            (0..8).map(octant).collect()
        };
        let mut stats = SignStats::default();
        let mut boxes = Vec::new();
        for (b, s) in parts {
            boxes.extend(b);
            stats.add(&s);
        }
        (boxes, stats)
    }

    /// Voxelizes the mesh in `mode`. Every mode is served: `Binary(sep)` is the binary
    /// surface of the triangles ([`crate::voxelize_triangles`], the same voxels as
    /// [`crate::voxelize_mesh_surface`] on the mesh), the others come from the exact
    /// narrow band. The result's [`SparseVolume::density_kind`] is
    /// [`SurfaceMode::channel_kind`].
    pub fn voxelize(&self, grid: &Grid, mode: SurfaceMode, progress: &dyn Progress) -> SparseVolume {
        self.voxelize_with_stats(grid, mode, progress).0
    }

    /// [`MeshVoxelizer::voxelize`], with how every sign was proven ([`SignStats`]:
    /// fast, cap and exact voxels, region queries; plus the mesh's unclean triangles and
    /// boundary cycle).
    pub fn voxelize_with_stats(
        &self,
        grid: &Grid,
        mode: SurfaceMode,
        progress: &dyn Progress,
    ) -> (SparseVolume, SignStats) {
        let spacing = grid.transform.spacing();
        let filter = OrientedBoxFilter::for_spacing(spacing);
        let (band, signed) = match mode {
            SurfaceMode::Solid => (filter.half_width(), true),
            SurfaceMode::Shell { thickness } => (0.5 * thickness + filter.half_width(), false),
            SurfaceMode::Distance {
                half_width_voxels,
                signed,
            } => (half_width_voxels * grid.max_spacing(), signed),
            // Binary inside: the distance band of one voxel decides the sign near the surface.
            SurfaceMode::Inside => (grid.max_spacing(), true),
            // A union of per-triangle voxel sets: the triangles' (Morton) order does not
            // change it.
            SurfaceMode::Binary(separability) => {
                return (
                    crate::voxelize_triangles(grid, &self.triangles, separability, progress),
                    SignStats::default(),
                );
            }
        };
        // Signs flow from the band to the voxels beyond it by 6-steps, which must be
        // shorter than the band: a narrower distance band still searches one voxel (its
        // values are clamped to the band, so the output is the same).
        let value_band = band;
        let band = if signed { band.max(grid.max_spacing()) } else { band };
        let background = mode.background(grid);
        let inside_value = match mode {
            SurfaceMode::Solid | SurfaceMode::Inside => 1.0,
            SurfaceMode::Distance { .. } => -value_band as f32,
            _ => background,
        };
        let value = |d_unsigned: f64, inside: bool| -> f32 {
            match mode {
                SurfaceMode::Solid => filter.density(if inside { -d_unsigned } else { d_unsigned }) as f32,
                SurfaceMode::Shell { thickness } => filter.density(d_unsigned - 0.5 * thickness) as f32,
                SurfaceMode::Distance { .. } => {
                    let d = if signed && inside { -d_unsigned } else { d_unsigned };
                    d.clamp(-value_band, value_band) as f32
                }
                SurfaceMode::Inside | SurfaceMode::Binary(_) => inside as u8 as f32,
            }
        };

        let t = &grid.transform;
        let grid_box = grid.index_box();
        // Voxel range each triangle's band can reach.
        let ranges: Vec<IndexBox> = self
            .triangles
            .par_iter()
            .map(|tri| {
                let lo = t.world_to_index(tri[0].min(tri[1]).min(tri[2]) - band).ceil();
                let hi = t.world_to_index(tri[0].max(tri[1]).max(tri[2]) + band).floor() + 1.0;
                let clip = |v: DVec3| v.clamp(DVec3::splat(-1.0), grid.dims().as_dvec3() + 1.0).as_ivec3();
                IndexBox::new(clip(lo), clip(hi)).intersection(&grid_box)
            })
            .collect();
        let bins = crate::pairs::bin_by_brick(&ranges, volga_core::brick_extent(grid.dims()));

        progress.start("voxelize", bins.bricks.len() as u64);
        let band2 = band * band;
        // The band in index units on the finest axis (a superset on anisotropic grids).
        let band_index = band / grid.min_spacing();
        let prepared = self.regions.prepare(t, &grid_box, band);
        // Half-width of each triangle's certified interval of `w` within the band: the
        // error of `w̄` at its centroid plus the gradient bound times the farthest path
        // (centroid → nearest point → voxel). Zero without a boundary.
        let slack: Vec<f64> = if signed && !self.sign.closed {
            // One gradient bound per triangle, over its box grown by the band (runs of
            // triangles sharing one bound were cheaper to set up but sent twice as many
            // bunny voxels to the caps at N = 256).
            (0..self.triangles.len())
                .into_par_iter()
                .map(|i| {
                    let tri = &self.triangles[i];
                    let b = volga_core::Aabb::new(tri[0].min(tri[1]).min(tri[2]), tri[0].max(tri[1]).max(tri[2]));
                    let g = self.sign.boundary.gradient_bound(&b.expanded(DVec3::splat(band)));
                    self.sign.w_bar_error[i] + g * (self.sign.radius[i] + band)
                })
                .collect()
        } else {
            vec![0.0; self.triangles.len()]
        };
        let band_bricks: Vec<(IVec3, Brick<f32>, SignStats)> = (0..bins.bricks.len())
            .into_par_iter()
            .map(|k| {
                let brick = bins.bricks[k];
                let region = IndexBox::new(brick * BRICK_DIM, (brick + 1) * BRICK_DIM).intersection(&grid_box);
                // Start at the band: farther candidates are never needed.
                let mut best = Nearest {
                    d2: [band2 * (1.0 + 1e-9); BRICK_VOXELS],
                    id: [u32::MAX; BRICK_VOXELS],
                };
                // Triangles in index order: among equally near ones the first stays, so
                // the result is independent of threads.
                for &i in bins.items(k) {
                    let dist = &self.distance[i as usize];
                    let mut update = |start, axis, count| dist.column_min(t, start, axis, count, &mut best, i);
                    if self.regions.is_fallback(i as usize) {
                        let tri_index = self.triangles[i as usize].map(|p| t.world_to_index(p));
                        BandColumns::new(tri_index, band_index).for_each(&region, update);
                    } else {
                        prepared.for_each_run(i as usize, &region, &mut update);
                    }
                }
                let (best_d2, best_tri) = (&best.d2, &best.id);
                // Band voxels: exact distance and sign. Voxels beyond the band: their sign
                // flows from band voxels through 6-neighbours (a 6-step is shorter than the
                // band, so it cannot cross the surface); a pocket no band voxel reaches asks
                // the winding number once.
                let in_band = |o: usize| best_tri[o] != u32::MAX && best_d2[o] <= band2;
                let mut data = [background; BRICK_VOXELS];
                let mut stats = SignStats::default();
                let mut margin = [0.0f64; BRICK_VOXELS];
                let (mut inside_band, mut outside_band) = (BrickMask::EMPTY, BrickMask::EMPTY);
                for z in region.min.z..region.max.z {
                    for y in region.min.y..region.max.y {
                        let row = IVec3::new(region.min.x, y, z);
                        let first = Brick::<f32>::local_offset(row);
                        for (o, x) in (first..).zip(region.min.x..region.max.x) {
                            if in_band(o) {
                                let p = t.voxel_center(IVec3::new(x, y, z));
                                let tri = best_tri[o] as usize;
                                let inside = signed && {
                                    let (inside, m) = self.decide(p, tri, best_d2[o], slack[tri], &mut stats);
                                    margin[o] = m;
                                    inside
                                };
                                if inside {
                                    inside_band.insert(o);
                                } else {
                                    outside_band.insert(o);
                                }
                                data[o] = value(best_d2[o].sqrt(), inside);
                            }
                        }
                    }
                }
                if signed {
                    let region_mask = BrickMask::of_region(brick, &region);
                    let unknown = region_mask.and_not(&inside_band.or(&outside_band));
                    let inside = self.flood_signs(brick, inside_band, outside_band, &margin, unknown, grid, &mut stats);
                    let mut fill = inside.and(&unknown);
                    while let Some(o) = fill.first() {
                        data[o] = inside_value;
                        fill.remove(o);
                    }
                }
                progress.inc(1);
                (brick, Brick::from_voxels(&data), stats)
            })
            .collect();
        progress.finish();

        let mut stats = self.sign.stats;
        let mut volume = SparseVolume::new(*grid, background, false).with_density_kind(mode.channel_kind());
        let touched: rustc_hash::FxHashSet<IVec3> = band_bricks.iter().map(|(b, _, _)| *b).collect();
        for (b, brick, brick_stats) in band_bricks {
            stats.add(&brick_stats);
            if brick != Brick::Uniform(background) {
                volume.density.insert_brick(b, brick);
            }
        }
        if signed && inside_value != background {
            // Bricks no triangle band reaches.
            let (inside, partial) = if self.sign.closed {
                // Constant between sheets and 0 outside the bounds: only bricks in the
                // mesh's bounds can be inside, one query per component.
                let bounds = self.bvh.bounds();
                let lo = t
                    .world_to_index(bounds.min)
                    .floor()
                    .as_ivec3()
                    .div_euclid(IVec3::splat(BRICK_DIM));
                let hi = t
                    .world_to_index(bounds.max)
                    .ceil()
                    .as_ivec3()
                    .div_euclid(IVec3::splat(BRICK_DIM))
                    + 1;
                let ext = volume.brick_extent();
                let candidates: Vec<IVec3> = IndexBox::new(lo.max(IVec3::ZERO), hi.min(ext))
                    .iter()
                    .filter(|b| !touched.contains(b))
                    .collect();
                (
                    self.inside_bricks_by_components(&candidates, &touched, grid, &mut stats),
                    Vec::new(),
                )
            } else {
                self.inside_by_octree(&touched, grid, &mut stats)
            };
            for b in inside {
                let region = IndexBox::new(b * BRICK_DIM, (b + 1) * BRICK_DIM);
                let brick = if region.intersection(&grid_box) == region {
                    Brick::Uniform(inside_value)
                } else {
                    volga_core::gather_brick(b, |ijk| {
                        if grid_box.contains(ijk) {
                            inside_value
                        } else {
                            background
                        }
                    })
                };
                volume.density.insert_brick(b, brick);
            }
            for (b, mask) in partial {
                let brick = volga_core::gather_brick(b, |ijk| {
                    let o = Brick::<f32>::local_offset(ijk);
                    if grid_box.contains(ijk) && mask.contains(o) {
                        inside_value
                    } else {
                        background
                    }
                });
                volume.density.insert_brick(b, brick);
            }
        }
        (volume, stats)
    }
}
