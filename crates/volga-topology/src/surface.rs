//! Checks against a reference triangle mesh: N-tunnels through it, cover, minimal cover.
//!
//! Everything works in **index space** (voxel `ijk` is the closed cell
//! `[ijk − ½, ijk + ½]`, its centre the integer point); a [`SurfaceMesh`] carries the
//! triangles converted to index space and the transform that reports positions back in
//! world units. Work follows the surface: every triangle visits only the voxels near it
//! (its bounding box halved down to blocks of at most 8³ voxels, keeping the blocks its
//! exact triangle–box overlap test accepts, then a slab around its plane in each), never
//! the whole grid.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use serde::{Serialize, Serializer};
use volga_core::{Aabb, IndexBox, Transform};
use volga_mesh::{segment_crosses_triangle, triangle_box_overlap};

use crate::components::ivec3;
use crate::{Connectivity, VoxelSet};

/// A reference surface for the mesh checks: triangles in the index space of a voxel
/// set's grid, and the grid's transform (used only to report world positions).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceMesh {
    triangles: Vec<[DVec3; 3]>,
    transform: Transform,
}

impl SurfaceMesh {
    /// World-space triangles mapped to the index space of `transform`
    /// (`Transform::world_to_index`, the same arithmetic as volga's voxelizers).
    pub fn from_world(triangles: impl IntoIterator<Item = [DVec3; 3]>, transform: &Transform) -> Self {
        SurfaceMesh {
            triangles: triangles
                .into_iter()
                .map(|t| t.map(|p| transform.world_to_index(p)))
                .collect(),
            transform: *transform,
        }
    }

    /// Triangles already in index space; `transform` maps index to world for reports.
    pub fn from_index(triangles: Vec<[DVec3; 3]>, transform: Transform) -> Self {
        SurfaceMesh { triangles, transform }
    }

    /// The triangles in index space, in the order given (reports cite these indices).
    pub fn triangles(&self) -> &[[DVec3; 3]] {
        &self.triangles
    }

    /// Index space to world space, for reporting world positions.
    pub fn transform(&self) -> &Transform {
        &self.transform
    }

    /// The triangles with their indices, in parallel.
    fn indexed(&self) -> impl IndexedParallelIterator<Item = (u32, &[DVec3; 3])> + '_ {
        self.triangles.par_iter().enumerate().map(|(i, t)| (i as u32, t))
    }
}

/// An N-tunnel through the mesh: two N-adjacent white voxels whose connecting segment
/// meets a triangle (closed segment, closed triangle: touching counts).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeshTunnel {
    /// The first voxel in (z, y, x) order.
    #[serde(serialize_with = "ivec3")]
    pub a: IVec3,
    /// Its N-neighbour, after `a` in (z, y, x) order.
    #[serde(serialize_with = "ivec3")]
    pub b: IVec3,
    /// The lowest-numbered triangle the segment meets.
    pub triangle: u32,
    /// Where the segment meets that triangle's plane, in index space (the segment's
    /// midpoint when it lies in the plane or the triangle has no area).
    #[serde(serialize_with = "dvec3")]
    pub point: DVec3,
    /// The same point in world space.
    #[serde(serialize_with = "dvec3")]
    pub world: DVec3,
}

/// A triangle with a point in no black closed cell, located by one white voxel where
/// that happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct UncoveredTriangle {
    /// The triangle's index in the mesh.
    pub triangle: u32,
    /// A white voxel whose cell holds uncovered points of the triangle (the first in
    /// (z, y, x) order); for a triangle leaving the grid, the cell of a vertex outside
    /// it (`in_grid` false).
    #[serde(serialize_with = "ivec3")]
    pub voxel: IVec3,
    /// Whether `voxel` lies in the grid.
    pub in_grid: bool,
}

/// The mesh sections of a [`TopologyReport`](crate::TopologyReport): tunnels, cover,
/// minimal cover. Lists hold the first [`AnalyzeOptions::listed`](crate::AnalyzeOptions)
/// entries in (z, y, x) or triangle order; counts are always total.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeshReport {
    /// Triangles of the mesh.
    pub triangles: u64,
    /// Triangles with a non-finite coordinate, ignored by every check.
    pub skipped_triangles: u64,
    /// Distinct N-adjacent white voxel pairs whose segment meets the mesh.
    pub tunnel_count: u64,
    /// The first tunnels, in (z, y, x) order.
    pub tunnels: Vec<MeshTunnel>,
    /// No N-tunnels: the black set is N-separating with respect to this mesh.
    pub separating: bool,
    /// Every point of every triangle lies in a black voxel's closed cell.
    pub covers: bool,
    /// Triangles with a point in no black closed cell.
    pub uncovered_triangle_count: u64,
    /// The first uncovered triangles, in triangle order.
    pub uncovered: Vec<UncoveredTriangle>,
    /// Black voxels whose closed cell no triangle touches.
    pub untouched_voxel_count: u64,
    /// The first untouched black voxels, in (z, y, x) order.
    #[serde(serialize_with = "ivec3_list")]
    pub untouched_voxels: Vec<IVec3>,
    /// Black voxels that can be removed one at a time with the surface still covered
    /// (the untouched ones included): those whose open cell no triangle meets (see
    /// [`cover`]). Meaningful when `covers`.
    pub redundant_voxel_count: u64,
    /// The first redundant black voxels, in (z, y, x) order.
    #[serde(serialize_with = "ivec3_list")]
    pub redundant_voxels: Vec<IVec3>,
    /// Covers, and removing any single black voxel uncovers a surface point; `None`
    /// when the black set does not cover the surface.
    pub minimal_cover: Option<bool>,
}

fn dvec3<S: Serializer>(v: &DVec3, serializer: S) -> Result<S::Ok, S::Error> {
    v.to_array().serialize(serializer)
}

fn ivec3_list<S: Serializer>(v: &[IVec3], serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_seq(v.iter().map(|v| v.to_array()))
}

/// Every check against `mesh`, lists cut to `listed` entries.
pub fn check_mesh(set: &VoxelSet, connectivity: Connectivity, mesh: &SurfaceMesh, listed: usize) -> MeshReport {
    let tunnel_records = tunnel_records(set, connectivity, mesh);
    let tunnel_count = tunnel_records.len() as u64;
    let tunnels = tunnel_records
        .iter()
        .take(listed)
        .map(|r| r.locate(set, connectivity, mesh))
        .collect();
    let cover = cover(set, mesh);
    let covers = cover.covers();
    let untouched: Vec<IVec3> = cover.untouched().collect();
    let redundant: Vec<IVec3> = cover.redundant().collect();
    MeshReport {
        triangles: mesh.triangles.len() as u64,
        skipped_triangles: cover.skipped,
        tunnel_count,
        tunnels,
        separating: tunnel_count == 0,
        covers,
        uncovered_triangle_count: cover.uncovered.len() as u64,
        uncovered: cover.uncovered.iter().take(listed).copied().collect(),
        untouched_voxel_count: untouched.len() as u64,
        untouched_voxels: untouched.into_iter().take(listed).collect(),
        redundant_voxel_count: redundant.len() as u64,
        minimal_cover: covers.then_some(redundant.is_empty()),
        redundant_voxels: redundant.into_iter().take(listed).collect(),
    }
}

/// All N-tunnels through `mesh`, sorted by `(a, b)` in (z, y, x) order, each pair once.
///
/// A tunnel is a pair of N-adjacent white voxels of the grid whose connecting segment
/// (closed, between the voxel centres) meets a triangle (closed), decided by
/// [`volga_mesh::segment_crosses_triangle`] (touching counts). Only pairs near a
/// triangle are tested: the segment lies in the box `[a − 1, a + 1]`, so a triangle can
/// only meet segments from the voxels `a` whose box it overlaps. None means the set is
/// N-separating with respect to the mesh. Non-finite triangles are skipped.
pub fn mesh_tunnels(set: &VoxelSet, connectivity: Connectivity, mesh: &SurfaceMesh) -> Vec<MeshTunnel> {
    tunnel_records(set, connectivity, mesh)
        .iter()
        .map(|r| r.locate(set, connectivity, mesh))
        .collect()
}

/// A tunnel as found: voxel `a`, forward offset number `k`, lowest triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct TunnelRecord {
    key: u64,
    k: u8,
    triangle: u32,
}

impl TunnelRecord {
    fn locate(&self, set: &VoxelSet, connectivity: Connectivity, mesh: &SurfaceMesh) -> MeshTunnel {
        let a = set.shape().delinearize(self.key as usize);
        let d = forward_offsets(connectivity)[self.k as usize];
        let tri = mesh.triangles[self.triangle as usize];
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let (pa, pb) = (a.as_dvec3(), (a + d).as_dvec3());
        let (sa, sb) = (n.dot(pa - tri[0]), n.dot(pb - tri[0]));
        let t = if sa != sb {
            (sa / (sa - sb)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let point = pa + (pb - pa) * t;
        MeshTunnel {
            a,
            b: a + d,
            triangle: self.triangle,
            point,
            world: mesh.transform.index_to_world(point),
        }
    }
}

/// The N-offsets after the origin in (z, y, x) order: each adjacent pair once, `a`
/// before `b`.
fn forward_offsets(connectivity: Connectivity) -> &'static [IVec3] {
    connectivity.half_offsets()
}

fn tunnel_records(set: &VoxelSet, connectivity: Connectivity, mesh: &SurfaceMesh) -> Vec<TunnelRecord> {
    let forward = forward_offsets(connectivity);
    let grid = IndexBox::new(IVec3::ZERO, set.dims().as_ivec3());
    let dims = set.dims();
    let shape = set.shape();
    let key = |v: IVec3| shape.linearize(v) as u64;
    let mut records: Vec<TunnelRecord> = mesh
        .indexed()
        .filter(|(_, t)| is_finite(t))
        .fold(Vec::new, |mut out, (index, &tri)| {
            let n = normal(&tri);
            // A plane-side filter before the exact test: pairs strictly on one side of
            // the triangle's plane (by far more than rounding) cannot meet it.
            let eps = rounding_margin(&tri, n, dims);
            let steps: Vec<f64> = forward.iter().map(|d| n.dot(d.as_dvec3())).collect();
            let reach = steps.iter().fold(0.0f64, |m, s| m.max(s.abs())) + eps;
            for_each_span(&tri, n, reach, 1.0, grid, &mut |y, z, x0, x1| {
                let (_, row) = set.row_with_start(y, z);
                let mut i = row.partition_point(|&x| (x as i32) < x0);
                for x in x0..=x1 {
                    if row.get(i) == Some(&(x as u32)) {
                        i += 1;
                        continue; // black
                    }
                    let a = IVec3::new(x, y, z);
                    let sa = n.dot(a.as_dvec3() - tri[0]);
                    for (k, (&d, &step)) in forward.iter().zip(&steps).enumerate() {
                        let sb = sa + step;
                        if (sa > eps && sb > eps) || (sa < -eps && sb < -eps) {
                            continue;
                        }
                        let b = a + d;
                        if !set.in_grid(b) || set.contains(b) {
                            continue;
                        }
                        if segment_crosses_triangle(a.as_dvec3(), b.as_dvec3(), tri) {
                            out.push(TunnelRecord {
                                key: key(a),
                                k: k as u8,
                                triangle: index,
                            });
                        }
                    }
                }
            });
            out
        })
        .flatten_iter()
        .collect();
    records.par_sort_unstable();
    records.dedup_by(|later, first| (later.key, later.k) == (first.key, first.k));
    records
}

fn is_finite(t: &[DVec3; 3]) -> bool {
    t.iter().all(|p| p.is_finite())
}

/// The triangle's unnormalized normal (zero for a degenerate triangle).
fn normal(t: &[DVec3; 3]) -> DVec3 {
    (t[1] - t[0]).cross(t[2] - t[0])
}

/// A bound, far above rounding, on the error of `n · (p − t[0])` for grid points `p`.
fn rounding_margin(t: &[DVec3; 3], n: DVec3, dims: glam::UVec3) -> f64 {
    let scale = 1.0
        + t.iter()
            .fold(dims.max_element() as f64, |m, p| m.max(p.abs().max_element()));
    1e-9 * n.length() * scale
}

/// Points of `clip` near a triangle, as row spans: calls `f(y, z, x0, x1)` (`x0 ≤ x1`,
/// inclusive) on pieces of rows that hold every point `a` of `clip` with
/// `|n · (a − t[0])| ≤ w` (a slab around the triangle's plane, with one point of slack
/// at each end of a span) whose box `[a − r, a + r]` overlaps the triangle.
///
/// The triangle's bounding box grown by `r` is halved recursively, keeping only halves
/// whose grown box overlaps the triangle ([`triangle_box_overlap`]), down to blocks of
/// at most 8 points a side, which are scanned row by row over the slab: the cost
/// follows the surface (plus block margins), not the bounding box. A degenerate
/// triangle (`n = 0`) gets whole block rows.
fn for_each_span(tri: &[DVec3; 3], n: DVec3, w: f64, r: f64, clip: IndexBox, f: &mut impl FnMut(i32, i32, i32, i32)) {
    let lo = tri[0].min(tri[1]).min(tri[2]) - r;
    let hi = tri[0].max(tri[1]).max(tri[2]) + r;
    let lo = to_ivec(lo.ceil()).max(clip.min);
    let hi = to_ivec(hi.floor()).min(clip.max - IVec3::ONE);
    if lo.cmpgt(hi).any() {
        return;
    }
    blocks(tri, n, w, r, lo, hi, f);
}

fn to_i(v: f64) -> i32 {
    let lim = (1i64 << 30) as f64;
    v.clamp(-lim, lim) as i32
}

fn to_ivec(v: DVec3) -> IVec3 {
    IVec3::new(to_i(v.x), to_i(v.y), to_i(v.z))
}

/// One level of [`for_each_span`]; `lo..=hi` is non-empty.
fn blocks(tri: &[DVec3; 3], n: DVec3, w: f64, r: f64, lo: IVec3, hi: IVec3, f: &mut impl FnMut(i32, i32, i32, i32)) {
    if !triangle_box_overlap(*tri, &Aabb::new(lo.as_dvec3() - r, hi.as_dvec3() + r)) {
        return;
    }
    let size = hi - lo + IVec3::ONE;
    if size.max_element() > 8 {
        let k = if size.x >= size.y && size.x >= size.z {
            0
        } else if size.y >= size.z {
            1
        } else {
            2
        };
        let mid = lo[k] + size[k] / 2;
        let mut upper_lo = lo;
        upper_lo[k] = mid;
        let mut lower_hi = hi;
        lower_hi[k] = mid - 1;
        blocks(tri, n, w, r, lo, lower_hi, f);
        blocks(tri, n, w, r, upper_lo, hi, f);
        return;
    }
    let v0 = tri[0];
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            let c = n.y * (y as f64 - v0.y) + n.z * (z as f64 - v0.z);
            let (x0, x1) = if n.x == 0.0 {
                if c.abs() > w {
                    continue;
                }
                (lo.x, hi.x)
            } else {
                let p = (-w - c) / n.x + v0.x;
                let q = (w - c) / n.x + v0.x;
                (
                    lo.x.max(to_i(p.min(q).ceil()) - 1),
                    hi.x.min(to_i(p.max(q).floor()) + 1),
                )
            };
            if x0 <= x1 {
                f(y, z, x0, x1);
            }
        }
    }
}

pub use volga_mesh::triangle_meets_open_box;

/// If the triangle has area and lies in a cell-face plane `x_k = m + ½`: `(k, m)`.
fn face_plane(tri: &[DVec3; 3]) -> Option<(usize, i32)> {
    if (tri[1] - tri[0]).cross(tri[2] - tri[0]) == DVec3::ZERO {
        return None;
    }
    (0..3).find_map(|k| {
        let c = tri[0][k];
        let s = c - 0.5;
        (tri[1][k] == c && tri[2][k] == c && s == s.floor() && s.abs() < (1u64 << 30) as f64).then_some((k, s as i32))
    })
}

/// Result of the cover test.
pub struct Cover<'a> {
    set: &'a VoxelSet,
    /// Per black voxel (in storage order): some triangle overlaps its closed cell.
    touched: Vec<AtomicU64>,
    /// Per black voxel: some surface point lies in its cell and in no other black cell.
    necessary: Vec<AtomicU64>,
    /// Uncovered triangles in index order.
    pub uncovered: Vec<UncoveredTriangle>,
    /// Triangles skipped for a non-finite coordinate.
    pub skipped: u64,
}

impl Cover<'_> {
    /// Every point of the surface lies in a black closed cell.
    pub fn covers(&self) -> bool {
        self.uncovered.is_empty()
    }

    /// Black voxels whose closed cell no triangle overlaps, in (z, y, x) order.
    pub fn untouched(&self) -> impl Iterator<Item = IVec3> + '_ {
        self.set
            .iter()
            .enumerate()
            .filter(|(i, _)| !get(&self.touched, *i))
            .map(|(_, v)| v)
    }

    /// Black voxels that can be removed alone with every surface point still in a
    /// black closed cell, in (z, y, x) order. Meaningful when the set covers.
    pub fn redundant(&self) -> impl Iterator<Item = IVec3> + '_ {
        self.set
            .iter()
            .enumerate()
            .filter(|(i, _)| !get(&self.necessary, *i))
            .map(|(_, v)| v)
    }
}

fn bitset(len: u64) -> Vec<AtomicU64> {
    (0..len.div_ceil(64)).map(|_| AtomicU64::new(0)).collect()
}

fn set_bit(bits: &[AtomicU64], i: usize) {
    bits[i / 64].fetch_or(1 << (i % 64), Ordering::Relaxed);
}

fn get(bits: &[AtomicU64], i: usize) -> bool {
    bits[i / 64].load(Ordering::Relaxed) & (1 << (i % 64)) != 0
}

/// The cover test: does every point of the mesh lie in a black voxel's closed cell,
/// which black voxels does the mesh not touch, and which can be removed one at a time.
///
/// **What is decided, per triangle `T`** (cells tile space, so `T` lies in the union of
/// the closed cells it overlaps):
/// * A point of `T` inside the open cell of a white voxel lies in no black closed cell:
///   uncovered. Conversely the uncovered part of `T` is relatively open in `T`, so if it
///   is not empty it has positive area; unless `T` lies in a cell-face plane
///   (`x_k = m + ½`), a piece of positive area cannot fit in the cell faces and reaches
///   an open cell, which is then white. So for such `T`: **uncovered ⇔ `T` meets the
///   open cell of a white voxel** (or leaves the grid: voxels outside it are not
///   black).
/// * If `T` lies in a cell-face plane, the same argument one dimension down: uncovered
///   ⇔ `T` meets the open face between two white voxels (the open box of the two
///   cells).
/// * A black voxel `v` is **necessary** (removing it uncovers a point) ⇔ some `T` meets
///   the open cell of `v` (for `T` in a face plane: the open face between `v` and a
///   white voxel). The same argument: after removing `v` the uncovered part of `T`
///   lies in `v`'s cell and, if not empty, has positive area there.
/// * The cover is **minimal** ⇔ it covers and every black voxel is necessary.
///
/// Overlap with closed cells is [`triangle_box_overlap`], with open cells
/// [`triangle_meets_open_box`]; both in `f64`, exact for contact on cell faces
/// (coordinate comparisons). The one case decided only approximately: a zero-area
/// triangle (a segment or point) lying in a cell-face plane, where only the open-cell
/// test is applied. Non-finite triangles are skipped.
pub fn cover<'a>(set: &'a VoxelSet, mesh: &SurfaceMesh) -> Cover<'a> {
    let grid = IndexBox::new(IVec3::ZERO, set.dims().as_ivec3());
    let closed_grid = Aabb::new(DVec3::splat(-0.5), set.dims().as_dvec3() - 0.5);
    let touched = bitset(set.len());
    let necessary = bitset(set.len());
    let key = |v: IVec3| (v.z, v.y, v.x);
    let results: Vec<Option<Option<UncoveredTriangle>>> = mesh
        .indexed()
        .map(|(index, tri)| {
            if !is_finite(tri) {
                return None;
            }
            let mut first: Option<UncoveredTriangle> = None;
            let mut uncovered = |voxel: IVec3, in_grid: bool| {
                let replace = match &first {
                    None => true,
                    Some(f) => f.in_grid && in_grid && key(voxel) < key(f.voxel),
                };
                if replace {
                    first = Some(UncoveredTriangle {
                        triangle: index,
                        voxel,
                        in_grid,
                    });
                }
            };
            if let Some(outside) = tri.iter().find(|p| !closed_grid.contains(**p)) {
                uncovered(to_ivec((*outside + 0.5).floor()), false);
            }
            let face = face_plane(tri);
            let n = normal(tri);
            // A closed cell meets the plane only if |n·(c − t0)| ≤ ½‖n‖₁.
            let reach = 0.5 * n.abs().element_sum() + rounding_margin(tri, n, set.dims());
            for_each_span(tri, n, reach, 0.5, grid, &mut |y, z, x0, x1| {
                let (start, row) = set.row_with_start(y, z);
                let mut i = row.partition_point(|&x| (x as i32) < x0);
                for x in x0..=x1 {
                    let black = if row.get(i) == Some(&(x as u32)) {
                        i += 1;
                        Some(start + i - 1)
                    } else {
                        None
                    };
                    let c = IVec3::new(x, y, z);
                    let centre = c.as_dvec3();
                    match face {
                        None => {
                            if triangle_meets_open_box(*tri, centre - 0.5, centre + 0.5) {
                                match black {
                                    Some(i) => {
                                        set_bit(&touched, i);
                                        set_bit(&necessary, i);
                                    }
                                    None => uncovered(c, true),
                                }
                            } else if let Some(i) = black {
                                if triangle_box_overlap(*tri, &Aabb::new(centre - 0.5, centre + 0.5)) {
                                    set_bit(&touched, i);
                                }
                            }
                        }
                        Some((k, m)) => {
                            if !triangle_box_overlap(*tri, &Aabb::new(centre - 0.5, centre + 0.5)) {
                                continue;
                            }
                            if let Some(i) = black {
                                set_bit(&touched, i);
                            }
                            let mut step = IVec3::ZERO;
                            step[k] = 1;
                            // The voxel across the plane from `c`, and the lower of the two.
                            let other = if c[k] == m { c + step } else { c - step };
                            let lower = if c[k] == m { c } else { other };
                            let open =
                                triangle_meets_open_box(*tri, lower.as_dvec3() - 0.5, (lower + step).as_dvec3() + 0.5);
                            if !open || set.contains(other) {
                                continue;
                            }
                            match black {
                                Some(i) => set_bit(&necessary, i),
                                None => uncovered(c, true),
                            }
                        }
                    }
                }
            });
            Some(first)
        })
        .collect();
    let skipped = results.iter().filter(|r| r.is_none()).count() as u64;
    Cover {
        set,
        touched,
        necessary,
        uncovered: results.into_iter().flatten().flatten().collect(),
        skipped,
    }
}
