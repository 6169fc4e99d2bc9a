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

use std::time::Instant;

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use volga_core::{Brick, Grid, IndexBox, Progress, SparseVolume, BRICK_DIM, BRICK_VOXELS};
use volga_mesh::{Bvh, FaceFrame, TriMesh};

use crate::blocks::Blocks;
use crate::mask::BrickMask;
use crate::profile::{BrickClock, Lap, VoxelizeProfile};
use crate::regions::{EdgeUse, FeatureRegions};
use crate::sign::{MeshTopology, SignOracle, SignStats, Slack};
use crate::tri_distance::{Nearest, TriDistance};
use crate::{OrientedBoxFilter, SurfaceMode};

/// A mesh prepared for distance voxelization: BVH, pseudo-normals, boundary flags and
/// per-triangle winding numbers.
#[derive(Debug, Clone)]
pub struct MeshVoxelizer {
    pub(crate) triangles: Vec<[DVec3; 3]>,
    /// Each triangle's face test for `closest_point_with_frame`, prepared once (`None`:
    /// degenerate).
    pub(crate) face_frames: Vec<Option<FaceFrame>>,
    pub(crate) bvh: Bvh,
    /// Unit face normal (zero for degenerate triangles).
    pub(crate) face_normal: Vec<DVec3>,
    /// Per triangle and edge k (corner k → k+1): pseudo-normal, and whether the edge is
    /// a boundary or non-manifold edge.
    pub(crate) edge_normal: Vec<[DVec3; 3]>,
    pub(crate) edge_ambiguous: Vec<[bool; 3]>,
    /// Per triangle and corner: the welded vertex's angle-weighted pseudo-normal and
    /// whether the vertex touches a boundary or non-manifold edge.
    pub(crate) vertex_normal: Vec<[DVec3; 3]>,
    pub(crate) vertex_ambiguous: Vec<[bool; 3]>,
    boundary_edges: usize,
    pub(crate) distance: Vec<TriDistance>,
    /// Face, edge and vertex regions that bound where each triangle can be nearest.
    pub(crate) regions: FeatureRegions,
    /// Certified signs: per-triangle principal values, caps, gradient bounds.
    pub(crate) sign: SignOracle,
    /// Where [`MeshVoxelizer::new`]'s time went.
    prepare_profile: VoxelizeProfile,
    /// Voxelizer (Morton) order → mesh order (the BVH's triangle ids), and back.
    pub(crate) to_mesh: Vec<u32>,
    pub(crate) from_mesh: Vec<u32>,
}

/// [`MeshVoxelizer::new`]'s tables: the triangles in Morton order, welded, with their
/// normals and edge uses. Built alongside the BVH; the feature regions and the sign
/// oracle are then built from them side by side.
struct Tables {
    triangles: Vec<[DVec3; 3]>,
    face_normal: Vec<DVec3>,
    edge_normal: Vec<[DVec3; 3]>,
    vertex_normal: Vec<[DVec3; 3]>,
    /// Angle-weighted normal per welded vertex.
    welded_normal: Vec<DVec3>,
    boundary_edges: usize,
    /// Voxelizer (Morton) order → mesh order.
    order: Vec<u32>,
    corners: Vec<[u32; 3]>,
    welded_pos: Vec<DVec3>,
    uses: Vec<EdgeUse>,
}

/// The per-triangle distance machinery built from [`Tables`] (no BVH, no signs).
struct Features {
    face_frames: Vec<Option<FaceFrame>>,
    distance: Vec<TriDistance>,
    regions: FeatureRegions,
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
    /// Prepares `mesh` (world space): triangles in Morton order, normals and
    /// pseudo-normals of the welded mesh, feature regions, the BVH and the sign oracle.
    pub fn new(mesh: &TriMesh) -> Self {
        // The BVH (for winding numbers) is built from the mesh as given, alongside the
        // tables; then the feature regions (mostly one core's work) alongside the sign
        // oracle (which needs the BVH, not the regions).
        let start = Instant::now();
        let ((bvh, bvh_s), (rest, rest_s)) = rayon::join(
            || (Bvh::build(mesh), start.elapsed().as_secs_f64()),
            || (Self::tables(mesh), start.elapsed().as_secs_f64()),
        );
        let second = Instant::now();
        let ((features, features_s), (sign, sign_s)) = rayon::join(
            || (Self::features(&rest), second.elapsed().as_secs_f64()),
            || {
                let sign = SignOracle::build(&MeshTopology {
                    triangles: &rest.triangles,
                    corners: &rest.corners,
                    welded_pos: &rest.welded_pos,
                    uses: &rest.uses,
                    bvh: &bvh,
                    to_bvh: &rest.order,
                });
                (sign, second.elapsed().as_secs_f64())
            },
        );
        // The second step's wall time is shared out in proportion to its two sides' times.
        let (first_wall, second_wall) = ((second - start).as_secs_f64(), second.elapsed().as_secs_f64());
        let features_share = features_s / (features_s + sign_s).max(f64::MIN_POSITIVE);
        let mut prepare_profile = VoxelizeProfile::default();
        prepare_profile.push(
            "tables_and_bvh",
            first_wall + second_wall * features_share,
            bvh_s + rest_s + features_s,
        );
        prepare_profile.push("sign_oracle", second_wall * (1.0 - features_share), sign_s);
        let edge_ambiguous = sign.edge_ok.iter().map(|ok| ok.map(|ok| !ok)).collect();
        let vertex_ambiguous = sign.vertex_ok.iter().map(|ok| ok.map(|ok| !ok)).collect();
        MeshVoxelizer {
            triangles: rest.triangles,
            face_frames: features.face_frames,
            bvh,
            face_normal: rest.face_normal,
            edge_normal: rest.edge_normal,
            edge_ambiguous,
            vertex_normal: rest.vertex_normal,
            vertex_ambiguous,
            boundary_edges: rest.boundary_edges,
            distance: features.distance,
            regions: features.regions,
            sign,
            prepare_profile,
            from_mesh: {
                let mut from = vec![0u32; rest.order.len()];
                for (i, &m) in rest.order.iter().enumerate() {
                    from[m as usize] = i as u32;
                }
                from
            },
            to_mesh: rest.order,
        }
    }

    /// Where [`MeshVoxelizer::new`]'s time went: `tables_and_bvh` (Morton order, welding
    /// and normals alongside the BVH, then the feature regions and distance tables),
    /// and `sign_oracle` (boundary cycle, caps, clean triangles, `I⁺` and `w̄` per
    /// triangle). The oracle runs alongside the feature regions: that step's wall time is
    /// shared out between the two stages in proportion to their sides' times, so the
    /// stages' wall times add up to the call's; a stage's CPU time sums its sides' times.
    pub fn prepare_profile(&self) -> &VoxelizeProfile {
        &self.prepare_profile
    }

    /// The tables, on the triangles in Morton order: the triangles a brick gathers then
    /// sit close together in memory (in mesh order they are scattered over the whole
    /// arrays, and cache misses dominated the band loop).
    fn tables(mesh: &TriMesh) -> Tables {
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
        // of one edge are adjacent, lowest triangle first: a counting sort by the lower
        // endpoint, then each vertex's few uses by the upper one (stable, so uses of one
        // edge keep their (triangle, corner) order). The same order as sorting by
        // (key, triangle, corner), at a fraction of the cost.
        let n_welded = weld.len();
        let edge_of = |t: usize, k: usize| {
            let (i, j) = (corner(t, k), corner(t, (k + 1) % 3));
            (i != j).then(|| (i.min(j) as u64) << 32 | i.max(j) as u64)
        };
        let mut start = vec![0u32; n_welded + 1];
        for t in 0..triangles.len() {
            for k in 0..3 {
                if let Some(key) = edge_of(t, k) {
                    start[(key >> 32) as usize + 1] += 1;
                }
            }
        }
        for v in 0..n_welded {
            start[v + 1] += start[v];
        }
        let mut next = start.clone();
        let mut uses = vec![
            EdgeUse {
                key: 0,
                triangle: 0,
                corner: 0,
            };
            start[n_welded] as usize
        ];
        for t in 0..triangles.len() {
            for k in 0..3 {
                if let Some(key) = edge_of(t, k) {
                    let slot = &mut next[(key >> 32) as usize];
                    uses[*slot as usize] = EdgeUse {
                        key,
                        triangle: t as u32,
                        corner: k as u8,
                    };
                    *slot += 1;
                }
            }
        }
        for v in 0..n_welded {
            uses[start[v] as usize..start[v + 1] as usize].sort_by_key(|u| u.key);
        }
        debug_assert!(uses.is_sorted());

        // Per triangle edge: how many faces use it, and the sum of their normals.
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
        let corners = (0..triangles.len()).map(|t| [0, 1, 2].map(|k| corner(t, k))).collect();
        Tables {
            triangles,
            face_normal,
            edge_normal,
            vertex_normal,
            welded_normal: vnormal,
            boundary_edges,
            order,
            corners,
            welded_pos,
            uses,
        }
    }

    /// Feature regions, distance tables and face frames of the tables' triangles.
    fn features(tables: &Tables) -> Features {
        let triangles = &tables.triangles;
        let ((regions, distance), face_frames) = rayon::join(
            || {
                rayon::join(
                    || FeatureRegions::build(triangles, &tables.uses, &tables.welded_pos, &tables.welded_normal),
                    || triangles.par_iter().map(|t| TriDistance::new(*t)).collect(),
                )
            },
            || triangles.par_iter().map(|t| FaceFrame::new(*t)).collect(),
        );
        Features {
            face_frames,
            distance,
            regions,
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

    /// The BVH over the mesh's triangles in their original order (winding numbers,
    /// closest points).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// How each sign was proven in the last call is returned by
    /// [`MeshVoxelizer::voxelize_with_stats`]; this is what was learned while building:
    /// unclean triangles and the boundary cycle.
    pub fn sign_stats(&self) -> SignStats {
        self.sign.stats
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
        self.voxelize_clipped(grid, mode, &grid.index_box(), progress)
    }

    /// The voxels of `region` (index space, `0 ≤ min < max ≤ dims`) of
    /// [`MeshVoxelizer::voxelize_with_stats`] on `grid`, **bit for bit**, as a volume on
    /// [`Grid::window`]`(region)`, computed without the rest of the grid: only the bricks
    /// of `grid` that meet `region` are voxelized, each exactly as in the whole run (the
    /// same triangles in the same order, the same band, the same sign proofs; a sign is a
    /// proven fact about the winding number, so the bricks far from the surface get the
    /// same signs whichever queries prove them). The [`SignStats`] count this region's
    /// work only. This is what chunked and out-of-core grids are built from.
    ///
    /// Errors with [`volga_core::CoreError::BadRegion`] for a region that is empty or
    /// not inside the grid.
    pub fn voxelize_region(
        &self,
        grid: &Grid,
        mode: SurfaceMode,
        region: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<(SparseVolume, SignStats), volga_core::CoreError> {
        grid.window(region)?;
        let clip = brick_cover(region).intersection(&grid.index_box());
        let (volume, stats) = self.voxelize_clipped(grid, mode, &clip, progress);
        Ok((volume.window(region)?, stats))
    }

    /// [`MeshVoxelizer::voxelize_with_stats`] on the bricks of `grid` that meet `clip`
    /// (voxel indices) only, each bit for bit the whole run's brick, on `grid`'s lattice
    /// (no other brick stored); [`MeshVoxelizer::voxelize_region`] moves a region onto a
    /// grid of its own.
    pub fn voxelize_in(
        &self,
        grid: &Grid,
        mode: SurfaceMode,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> (SparseVolume, SignStats) {
        let clip = brick_cover(clip).intersection(&grid.index_box());
        if clip.is_empty() {
            let background = mode.background(grid);
            let volume = SparseVolume::new(*grid, background, false).with_density_kind(mode.channel_kind());
            return (volume, SignStats::default());
        }
        self.voxelize_clipped(grid, mode, &clip, progress)
    }

    /// [`MeshVoxelizer::voxelize_with_stats`] on the bricks of `grid` inside `clip` (a
    /// union of whole bricks clipped to the grid); no brick outside it is stored.
    pub(crate) fn voxelize_clipped(
        &self,
        grid: &Grid,
        mode: SurfaceMode,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> (SparseVolume, SignStats) {
        self.voxelize_profiled(grid, mode, clip, progress, None)
    }

    /// [`MeshVoxelizer::voxelize_clipped`], appending where the time went to `profile`
    /// when given (stages `bins`, `slack`, `distances`, `band_signs`, `flood_signs`,
    /// `brick_output`, `far_field`; or `binary_surface`; see [`VoxelizeProfile`]).
    pub(crate) fn voxelize_profiled(
        &self,
        grid: &Grid,
        mode: SurfaceMode,
        clip: &IndexBox,
        progress: &dyn Progress,
        mut profile: Option<&mut VoxelizeProfile>,
    ) -> (SparseVolume, SignStats) {
        let timing = profile.is_some();
        let mut stage = Instant::now();
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
                let surface = if *clip == grid.index_box() {
                    crate::voxelize_triangles(grid, &self.triangles, separability, progress)
                } else {
                    crate::binary::voxelize_triangles_in(grid, &self.triangles, separability, clip, progress)
                };
                if let Some(profile) = profile {
                    profile.serial("binary_surface", stage);
                }
                return (surface, SignStats::default());
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
                let clip_to = |v: DVec3| v.clamp(DVec3::splat(-1.0), grid.dims().as_dvec3() + 1.0).as_ivec3();
                IndexBox::new(clip_to(lo), clip_to(hi)).intersection(clip)
            })
            .collect();

        // The triangles binned by block of bricks (`crate::blocks`), and the feature
        // regions for this grid (laid out as the distance pass reaches them).
        let blocks = Blocks::new(&ranges, grid, &self.sign.trusted);
        let prepared = self.regions.prepare(t, &grid_box, band);
        progress.start("voxelize", blocks.brick_count());
        let band2 = band * band;
        if let Some(profile) = profile.as_deref_mut() {
            stage = profile.serial("bins", stage);
        }
        // Each triangle's certified interval of `w` within the band: the error of `w̄` at
        // its centroid plus a gradient bound times the path (centroid → nearest point →
        // voxel), taken per voxel ([`MeshVoxelizer::decide`]). Zero without a boundary.
        let slack: Vec<Slack> = if signed && !self.sign.closed {
            // One gradient bound per triangle, over its box grown by the band (runs of
            // triangles sharing one bound were cheaper to set up but sent twice as many
            // bunny voxels to the caps at N = 256).
            (0..self.triangles.len())
                .into_par_iter()
                .map(|i| {
                    // Unused by a triangle whose band misses the bricks computed.
                    if ranges[i].is_empty() {
                        return Slack::default();
                    }
                    self.slack(i, band)
                })
                .collect()
        } else {
            vec![Slack::default(); self.triangles.len()]
        };
        if let Some(profile) = profile.as_deref_mut() {
            stage = profile.serial("slack", stage);
        }
        // One brick's band signs, flood and output from its nearest triangles.
        let finish =
            |brick: IVec3, first_trusted: Option<usize>, best: &Nearest, lap: &mut Lap, clock: &mut BrickClock| {
                let region = IndexBox::new(brick * BRICK_DIM, (brick + 1) * BRICK_DIM).intersection(&grid_box);
                let (best_d2, best_tri) = (&best.d2, &best.id);
                // Band voxels: exact distance and sign. Voxels beyond the band: their sign
                // flows from band voxels through 6-neighbours (a 6-step is shorter than the
                // band, so it cannot cross the surface); a pocket no band voxel reaches asks
                // the winding number once.
                let in_band = |o: usize| best_tri[o] != u32::MAX && best_d2[o] <= band2;
                // A trusted triangle whose band reaches the brick: `I` is carried from it to
                // voxels whose nearest triangle cannot carry it.
                let bin_reference = first_trusted.filter(|_| signed);
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
                                    let (inside, m) =
                                        self.decide(p, tri, best_d2[o], slack[tri], bin_reference, &mut stats);
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
                clock.band_signs = lap.lap();
                if signed {
                    let region_mask = BrickMask::of_region(brick, &region);
                    let unknown = region_mask.and_not(&inside_band.or(&outside_band));
                    // A trusted triangle near the brick, to carry `I` from.
                    let reference = if self.sign.closed {
                        None
                    } else {
                        let mut band_voxels = inside_band.or(&outside_band);
                        let mut found = None;
                        while let Some(o) = band_voxels.first() {
                            band_voxels.remove(o);
                            if self.sign.trusted[best_tri[o] as usize] {
                                found = Some(best_tri[o] as usize);
                                break;
                            }
                        }
                        found.or(first_trusted)
                    };
                    let inside = self.flood_signs(
                        brick,
                        inside_band,
                        outside_band,
                        &margin,
                        unknown,
                        reference,
                        grid,
                        &mut stats,
                    );
                    let mut fill = inside.and(&unknown);
                    while let Some(o) = fill.first() {
                        data[o] = inside_value;
                        fill.remove(o);
                    }
                }
                clock.flood_signs = lap.lap();
                progress.inc(1);
                let brick_data = Brick::from_voxels(&data);
                clock.output = lap.lap();
                (brick, brick_data, stats)
            };
        let band_bricks: Vec<(IVec3, Brick<f32>, SignStats, BrickClock)> = (0..blocks.len())
            .into_par_iter()
            .flat_map_iter(|kb| {
                let mut lap = Lap::new(timing);
                let nearest = self.block_nearest(&blocks, kb, &prepared, grid, band);
                let distances = lap.lap();
                // The bricks' signs in parallel again: a block's sign work can be most of
                // a small mesh's (the teapot's self-crossings), too coarse to share out.
                let out: Vec<(IVec3, Brick<f32>, SignStats, BrickClock)> = blocks
                    .bricks(kb)
                    .par_iter()
                    .zip(nearest.par_iter())
                    .enumerate()
                    .map(|(j, (&(brick, first_trusted), best))| {
                        let mut lap = Lap::new(timing);
                        let mut clock = BrickClock {
                            distances: if j == 0 { distances } else { 0.0 },
                            ..BrickClock::default()
                        };
                        let (brick, data, stats) = finish(brick, first_trusted, best, &mut lap, &mut clock);
                        (brick, data, stats, clock)
                    })
                    .collect();
                out
            })
            .collect();
        progress.finish();

        let mut stats = self.sign.stats;
        let mut volume = SparseVolume::new(*grid, background, false).with_density_kind(mode.channel_kind());
        let touched: rustc_hash::FxHashSet<IVec3> = band_bricks.iter().map(|(b, _, _, _)| *b).collect();
        let mut clock = BrickClock::default();
        for (b, brick, brick_stats, brick_clock) in band_bricks {
            stats.add(&brick_stats);
            clock.add(&brick_clock);
            if brick != Brick::Uniform(background) {
                volume.density.insert_brick(b, brick);
            }
        }
        if let Some(profile) = profile.as_deref_mut() {
            let now = Instant::now();
            clock.stages((now - stage).as_secs_f64(), profile);
            stage = now;
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
                let clip_bricks = brick_range(clip);
                let candidates: Vec<IVec3> = IndexBox::new(lo.max(IVec3::ZERO), hi.min(ext))
                    .intersection(&clip_bricks)
                    .iter()
                    .filter(|b| !touched.contains(b))
                    .collect();
                (
                    self.inside_bricks_by_components(&candidates, &touched, grid, &mut stats),
                    Vec::new(),
                )
            } else {
                self.inside_by_octree(&touched, grid, clip, &mut stats)
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
        if let Some(profile) = profile {
            profile.serial("far_field", stage);
        }
        (volume, stats)
    }
}

/// The bricks (brick coordinates) holding the voxels of `voxels`.
fn brick_range(voxels: &IndexBox) -> IndexBox {
    IndexBox::new(
        voxels.min.div_euclid(IVec3::splat(BRICK_DIM)),
        (voxels.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)),
    )
}

/// The voxels of the whole bricks that hold the voxels of `region`.
fn brick_cover(region: &IndexBox) -> IndexBox {
    let bricks = brick_range(region);
    IndexBox::new(bricks.min * BRICK_DIM, bricks.max * BRICK_DIM)
}
