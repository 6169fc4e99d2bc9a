//! Feature regions for exact narrow-band distances (the characteristic/scan-conversion
//! idea of Mauch, "A fast algorithm for computing the closest point and distance
//! transform", 2000): each point of a mesh lies in the relative interior of exactly one
//! feature (a face, an edge or a vertex), and a voxel's nearest mesh point can only be
//! on a feature whose region contains the voxel:
//!
//! * **face** `T` (unit normal `n`): the prism over `T` — the voxel projects into `T` and
//!   `|n·(p − a)| ≤ band`. If the projection fell outside `T`, a point of `T`'s
//!   boundary would be nearer than any interior point.
//! * **edge** `ab` (interior): `(p − a)·(b − a) ≥ 0`, `(p − b)·(a − b) ≥ 0` (else an end
//!   point is nearer), and for every non-degenerate face `F` on the edge,
//!   `m_F·(p − a) ≥ 0` with `m_F` the outward normal of the edge in `F`'s plane (else
//!   stepping from the edge into `F` gets nearer: the derivative of the squared
//!   distance along `−m_F` is `2 m_F·(p − a) < 0`).
//! * **vertex** `v`: `(p − v)·(w − v) ≤ 0` for every edge `vw` (else stepping along the
//!   edge gets nearer).
//!
//! These are necessary conditions, so each region is a superset of the feature's
//! Voronoi region, and the regions of all features cover the band. Evaluating every
//! triangle only on its face region and on the regions of the edges and vertices it
//! owns (the lowest-index triangle using them) therefore still finds the exact
//! minimum; each band voxel is evaluated about twice instead of once per triangle
//! within the band (≈ 20 at 256 voxels on the bunny). On a smooth surface the edge and
//! vertex regions are thin wedges and cones.
//!
//! Regions are convex (intersections of half-spaces) and are scan-converted column by
//! column: along a column every half-space is an interval. Each half-space is widened
//! by a slack of about 10⁻⁶ voxel (plus the rounding of far-off coordinates), so a
//! voxel on a region's boundary is never lost to rounding; extra voxels only cost an
//! evaluation. Triangles too thin for a trustworthy normal (|ab × ac| < 10⁻⁶ of the
//! squared longest edge) take the conservative path instead: every voxel within the
//! band of their bounding box.
//!
//! Geometry is f64 (world units, relative to the mesh's centre for precision far from
//! the origin).

use glam::{DVec3, IVec3};
use volga_core::{IndexBox, Transform};

use crate::tri_distance::{ceil_i32, emit_run, floor_i32};

/// One use of a mesh edge: welded endpoints packed as `min << 32 | max`, and the
/// triangle and corner `k` (edge from corner `k` to `k + 1`) that use it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct EdgeUse {
    pub(crate) key: u64,
    pub(crate) triangle: u32,
    pub(crate) corner: u8,
}

/// A half-space `m·(p − centre) ≤ offset + band_coeff·band` (unit `m`, world units).
#[derive(Debug, Clone, Copy)]
struct Plane {
    m: DVec3,
    offset: f64,
    band_coeff: f64,
}

/// One feature's region, owned by one triangle.
#[derive(Debug, Clone, Copy)]
struct Region {
    /// Column axis: the direction in which the region is thinnest, roughly.
    axis: u8,
    /// The feature's box (relative to the centre) and how far the band widens it per
    /// axis below and above (|n| for faces, at most 1 for edges, 1 for vertices): the
    /// region lies in `[lo − pad_lo·band, hi + pad_hi·band]`.
    lo: DVec3,
    hi: DVec3,
    pad_lo: DVec3,
    pad_hi: DVec3,
    first_plane: u32,
    planes: u32,
}

/// Regions and their half-spaces, as one of the three kinds of features builds them.
#[derive(Debug, Clone, Default)]
struct Part {
    /// Owning triangle of each region.
    owners: Vec<u32>,
    regions: Vec<Region>,
    planes: Vec<Plane>,
}

impl Part {
    fn with_capacity(regions: usize, planes: usize) -> Part {
        Part {
            owners: Vec::with_capacity(regions),
            regions: Vec::with_capacity(regions),
            planes: Vec::with_capacity(planes),
        }
    }

    fn push(&mut self, owner: u32, region: Region) {
        self.owners.push(owner);
        self.regions.push(region);
    }
}

/// Regions are addressed as `part << PART_SHIFT | index` (faces, edges, vertices).
const PART_SHIFT: u32 = 30;

/// Feature regions of a mesh, grouped by owning triangle.
#[derive(Debug, Clone, Default)]
pub(crate) struct FeatureRegions {
    centre: DVec3,
    /// Size of the mesh's box plus the centre's magnitude: the scale of rounding errors.
    scale: f64,
    /// Face, edge and vertex regions, each part with its own half-spaces (kept apart:
    /// concatenating ~40 MB of half-spaces cost more than building them).
    parts: [Part; 3],
    /// Region addresses grouped by owning triangle: those of triangle `t` are
    /// `order[by_triangle[t]..by_triangle[t + 1]]`.
    order: Vec<u32>,
    by_triangle: Vec<u32>,
    /// Triangles handled conservatively (degenerate or too thin).
    fallback: Vec<bool>,
}

/// How far the wedge of an edge between two faces reaches from the edge's box, per
/// axis, below and above, per unit of band. In the plane across the edge (unit
/// direction `e`) the wedge's directions form the sector `{x : m₁·x ≥ 0, m₂·x ≥ 0}`
/// (`mᵢ` the faces' outward side normals), bounded by the rays `r₁ = ±n₁` and
/// `r₂ = ±n₂`; the sector within radius 1 reaches `max(0, r₁ₖ, r₂ₖ)` along axis `k`,
/// or the length of the axis's projection where that projection lies inside the
/// sector. Faces that continue each other in one plane leave the whole normal line
/// (both sides); faces folded onto each other (a half-plane) and sectors wider than
/// 120° keep the full box. Every bound is widened by 10⁻⁶.
fn wedge_pads(sides: [(DVec3, DVec3); 2], e: DVec3) -> (DVec3, DVec3) {
    const MARGIN: f64 = 1e-6;
    let full = (DVec3::ONE, DVec3::ONE);
    let [(n1, m1), (n2, m2)] = sides;
    if e == DVec3::ZERO || m1 == DVec3::ZERO || m2 == DVec3::ZERO {
        return full;
    }
    if m2.dot(n1).abs() < 1e-9 || m1.dot(n2).abs() < 1e-9 {
        if m1.dot(m2) > 0.0 {
            // Folded onto itself (m₂ = m₁): the wedge is a half-plane.
            return full;
        }
        // Coplanar continuation: m₂ = −m₁ and the wedge is the normal line.
        let reach = n1.abs().max(n2.abs()) + MARGIN;
        return (reach, reach);
    }
    let r1 = if m2.dot(n1) > 0.0 { n1 } else { -n1 };
    let r2 = if m1.dot(n2) > 0.0 { n2 } else { -n2 };
    if r1.dot(r2) < -0.5 {
        return full;
    }
    let orientation = r1.cross(r2);
    let inside = |d: DVec3| r1.cross(d).dot(orientation) >= 0.0 && d.cross(r2).dot(orientation) >= 0.0;
    let mut lo = DVec3::ZERO.min(r1).min(r2);
    let mut hi = DVec3::ZERO.max(r1).max(r2);
    for k in 0..3 {
        let mut axis = DVec3::ZERO;
        axis[k] = 1.0;
        // The axis projected across the edge.
        let d = axis - e * e[k];
        let len = d.length();
        if len > 0.0 {
            if inside(d) {
                hi[k] = hi[k].max(len);
            }
            if inside(-d) {
                lo[k] = lo[k].min(-len);
            }
        }
    }
    (-lo + MARGIN, hi + MARGIN)
}

fn dominant_axis(v: DVec3) -> u8 {
    crate::binary::dominant_axis(v) as u8
}

impl FeatureRegions {
    /// `triangles` with welded corner ids `corner(t, k)`, welded positions and
    /// vertex normals (any vector roughly along the surface normal; zero if unknown).
    pub(crate) fn build(
        triangles: &[[DVec3; 3]],
        uses: &[EdgeUse],
        welded_pos: &[DVec3],
        vertex_normal: &[DVec3],
    ) -> FeatureRegions {
        let n = triangles.len();
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in triangles {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let centre = if n == 0 { DVec3::ZERO } else { (lo + hi) * 0.5 };
        let scale = if n == 0 {
            0.0
        } else {
            (hi - lo).max_element() + centre.abs().max_element()
        };
        let normal_of = |[a, b, c]: &[DVec3; 3]| {
            let cross = (*b - *a).cross(*c - *a);
            let longest = (*b - *a)
                .length_squared()
                .max((*c - *a).length_squared())
                .max((*c - *b).length_squared());
            let ok = cross.length() > 1e-6 * longest && cross.is_finite();
            ok.then(|| cross.normalize())
        };
        let normals: Vec<Option<DVec3>> = triangles.iter().map(normal_of).collect();
        let fallback: Vec<bool> = normals.iter().map(|n| n.is_none()).collect();

        let push_plane = |planes: &mut Vec<Plane>, m: DVec3, through: DVec3, band_coeff: f64| {
            let m = m.normalize_or_zero();
            planes.push(Plane {
                m,
                offset: m.dot(through - centre),
                band_coeff,
            });
        };

        // Faces: three side planes (they reject columns outside the footprint early),
        // then the slab.
        let faces = || {
            let mut part = Part::with_capacity(n, 5 * n);
            for (t, tri) in triangles.iter().enumerate() {
                let Some(nrm) = normals[t] else { continue };
                let first_plane = part.planes.len() as u32;
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    push_plane(&mut part.planes, (b - a).cross(nrm), a, 0.0);
                }
                push_plane(&mut part.planes, nrm, tri[0], 1.0);
                push_plane(&mut part.planes, -nrm, tri[0], 1.0);
                part.push(
                    t as u32,
                    Region {
                        axis: dominant_axis(nrm),
                        lo: tri[0].min(tri[1]).min(tri[2]) - centre,
                        hi: tri[0].max(tri[1]).max(tri[2]) - centre,
                        pad_lo: nrm.abs(),
                        pad_hi: nrm.abs(),
                        first_plane,
                        planes: 5,
                    },
                );
            }
            part
        };

        // Edges, grouped by welded endpoints; the owner is the lowest triangle index.
        let edges = || {
            // One side plane per use and two end planes per edge (a `Vec` that outgrows
            // its capacity copies ~16 MB of planes for the bunny).
            let edge_count = uses.chunk_by(|x, y| x.key == y.key).count();
            let mut part = Part::with_capacity(edge_count, uses.len() + 2 * edge_count);
            for group in uses.chunk_by(|x, y| x.key == y.key) {
                let (i, j, owner) = ((group[0].key >> 32) as u32, group[0].key as u32, group[0].triangle);
                if fallback[owner as usize] {
                    continue; // the owner's conservative band covers the edge
                }
                let (a, b) = (welded_pos[i as usize], welded_pos[j as usize]);
                let first_plane = part.planes.len() as u32;
                let mut normal_sum = DVec3::ZERO;
                // (unit normal, unit outward side normal) of the first two faces.
                let mut sides: [(DVec3, DVec3); 2] = [(DVec3::ZERO, DVec3::ZERO); 2];
                let mut faces = 0;
                for u in group {
                    let Some(nrm) = normals[u.triangle as usize] else {
                        continue;
                    };
                    let tri = &triangles[u.triangle as usize];
                    let (p, q) = (tri[u.corner as usize], tri[(u.corner as usize + 1) % 3]);
                    let outward = (q - p).cross(nrm);
                    // Outside (or on) the face's side plane through the edge.
                    push_plane(&mut part.planes, -outward, p, 0.0);
                    if faces < 2 {
                        sides[faces] = (nrm, outward.normalize_or_zero());
                    }
                    faces += 1;
                    normal_sum += nrm;
                }
                let (pad_lo, pad_hi) = if faces == 2 {
                    wedge_pads(sides, (b - a).normalize_or_zero())
                } else {
                    (DVec3::ONE, DVec3::ONE)
                };
                push_plane(&mut part.planes, a - b, a, 0.0);
                push_plane(&mut part.planes, b - a, b, 0.0);
                let axis = if normal_sum.length_squared() > 1e-12 {
                    dominant_axis(normal_sum)
                } else {
                    // Columns across the edge: along its smallest component.
                    let e = (b - a).abs();
                    if e.x <= e.y && e.x <= e.z {
                        0
                    } else if e.y <= e.z {
                        1
                    } else {
                        2
                    }
                };
                part.push(
                    owner,
                    Region {
                        axis,
                        lo: a.min(b) - centre,
                        hi: a.max(b) - centre,
                        pad_lo,
                        pad_hi,
                        first_plane,
                        planes: part.planes.len() as u32 - first_plane,
                    },
                );
            }
            part
        };

        // Vertices: the owner is the lowest triangle index with an edge at the vertex.
        let vertices = || {
            // Each vertex's neighbours, ascending, by a counting sort: the edges come in
            // key order, so a vertex first meets the lower neighbours it is the upper end
            // for (ascending), then the upper ones (ascending).
            let n_vertices = welded_pos.len();
            let mut start = vec![0u32; n_vertices + 1];
            let mut vertex_owner = vec![u32::MAX; n_vertices];
            let edge_ends = |group: &[EdgeUse]| ((group[0].key >> 32) as usize, group[0].key as u32 as usize);
            for group in uses.chunk_by(|x, y| x.key == y.key) {
                let (i, j) = edge_ends(group);
                start[i + 1] += 1;
                start[j + 1] += 1;
                let owner = group[0].triangle;
                vertex_owner[i] = vertex_owner[i].min(owner);
                vertex_owner[j] = vertex_owner[j].min(owner);
            }
            for v in 0..n_vertices {
                start[v + 1] += start[v];
            }
            let mut next = start.clone();
            let mut neighbours = vec![0u32; start[n_vertices] as usize];
            for group in uses.chunk_by(|x, y| x.key == y.key) {
                let (i, j) = edge_ends(group);
                neighbours[next[i] as usize] = j as u32;
                next[i] += 1;
                neighbours[next[j] as usize] = i as u32;
                next[j] += 1;
            }
            let mut part = Part::with_capacity(n_vertices, neighbours.len());
            for v in 0..n_vertices {
                let group = &neighbours[start[v] as usize..start[v + 1] as usize];
                let owner = vertex_owner[v];
                if group.is_empty() || owner == u32::MAX || fallback[owner as usize] {
                    continue;
                }
                let p = welded_pos[v];
                let first_plane = part.planes.len() as u32;
                for &w in group {
                    push_plane(&mut part.planes, welded_pos[w as usize] - p, p, 0.0);
                }
                part.push(
                    owner,
                    Region {
                        axis: dominant_axis(vertex_normal.get(v).copied().unwrap_or(DVec3::ZERO)),
                        lo: p - centre,
                        hi: p - centre,
                        pad_lo: DVec3::ONE,
                        pad_hi: DVec3::ONE,
                        first_plane,
                        planes: group.len() as u32,
                    },
                );
            }
            part
        };

        let (faces, (edges, vertices)) = rayon::join(faces, || rayon::join(edges, vertices));
        let parts = [faces, edges, vertices];
        // Region addresses grouped by owner, keeping face, edges, vertices in order (a
        // counting sort; the regions themselves stay where they are).
        let mut by_triangle = vec![0u32; n + 1];
        for part in &parts {
            for &owner in &part.owners {
                by_triangle[owner as usize + 1] += 1;
            }
        }
        for t in 0..n {
            by_triangle[t + 1] += by_triangle[t];
        }
        let mut slot = by_triangle.clone();
        let mut order = vec![0u32; by_triangle[n] as usize];
        for (k, part) in parts.iter().enumerate() {
            for (index, &owner) in part.owners.iter().enumerate() {
                order[slot[owner as usize] as usize] = (k as u32) << PART_SHIFT | index as u32;
                slot[owner as usize] += 1;
            }
        }
        FeatureRegions {
            centre,
            scale,
            parts,
            order,
            by_triangle,
            fallback,
        }
    }

    /// Whether triangle `t` needs the conservative path (its whole band).
    #[inline]
    pub(crate) fn is_fallback(&self, t: usize) -> bool {
        self.fallback[t]
    }

    /// The regions laid out for one grid and band: index boxes, and each half-space as
    /// a linear function of the column's lateral indices plus its bound along the
    /// column, so that a column costs two multiply-adds per half-space. Prepared
    /// region by region as [`PreparedRegions::for_each_run`] visits them (a region is
    /// visited about twice at N = 256; preparing all ~1 M half-spaces up front cost
    /// 27 ms of one core and 31 MB for the bunny).
    pub(crate) fn prepare(&self, transform: &Transform, grid_box: &IndexBox, band: f64) -> PreparedRegions<'_> {
        let (origin, spacing) = (transform.origin(), transform.spacing());
        PreparedRegions {
            regions: self,
            spacing,
            inv_spacing: 1.0 / spacing,
            // Voxel centres relative to the mesh centre: `base + ijk·spacing`.
            base: origin - self.centre,
            band,
            slack: 1e-6 * spacing.min_element() + 1e-13 * self.scale,
            grid_box: *grid_box,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct PreparedPlane {
    g0: f64,
    gu: f64,
    gw: f64,
    /// `−1/slope`: negative for an upper bound `i_d ≤ g·neg_inv`, positive for a lower
    /// bound `i_d ≥ g·neg_inv`, zero for a column-wide test `g ≤ 0`.
    neg_inv: f64,
}

/// [`FeatureRegions`] for one grid and band ([`FeatureRegions::prepare`]).
pub(crate) struct PreparedRegions<'a> {
    regions: &'a FeatureRegions,
    spacing: DVec3,
    inv_spacing: DVec3,
    base: DVec3,
    band: f64,
    slack: f64,
    grid_box: IndexBox,
}

/// Half-spaces of one region held on the stack; more go to the heap.
const INLINE_PLANES: usize = 16;

impl PreparedRegions<'_> {
    /// Calls `f(first_ijk, axis, count)` for runs of voxels of `region_box` (index
    /// space) that lie in the regions triangle `t` owns, within the band of their
    /// features' boxes. Runs of different regions may overlap.
    pub(crate) fn for_each_run(&self, t: usize, region_box: &IndexBox, mut f: impl FnMut(IVec3, usize, i32)) {
        let fr = self.regions;
        let range = fr.by_triangle[t] as usize..fr.by_triangle[t + 1] as usize;
        let (base, band, slack) = (self.base, self.band, self.slack);
        let clip = |v: DVec3| v.clamp(DVec3::splat(-4.0e8), DVec3::splat(4.0e8));
        let mut heap: Vec<PreparedPlane> = Vec::new();
        for &address in &fr.order[range] {
            let part = &fr.parts[(address >> PART_SHIFT) as usize];
            let r = &part.regions[(address & ((1 << PART_SHIFT) - 1)) as usize];
            // The region's index box (inclusive) within the grid. Rounding `· inv_spacing`
            // differs from `/ spacing` by far less than the slack the box already has.
            let lo_f = clip((r.lo - (r.pad_lo * band + slack) - base) * self.inv_spacing);
            let hi_f = clip((r.hi + (r.pad_hi * band + slack) - base) * self.inv_spacing);
            let lo = IVec3::new(ceil_i32(lo_f.x), ceil_i32(lo_f.y), ceil_i32(lo_f.z))
                .max(self.grid_box.min)
                .max(region_box.min);
            let hi = IVec3::new(floor_i32(hi_f.x), floor_i32(hi_f.y), floor_i32(hi_f.z))
                .min(self.grid_box.max - IVec3::ONE)
                .min(region_box.max - IVec3::ONE);
            if lo.cmpgt(hi).any() {
                continue;
            }
            let d = r.axis as usize;
            let (u, w) = ((d + 1) % 3, (d + 2) % 3);
            // Each half-space `m·(base + ijk·spacing) ≤ offset + band_coeff·band + slack`
            // as `g0 + i_u·gu + i_w·gw + i_d·slope ≤ 0`.
            let spacing = self.spacing;
            let prepare = |plane: &Plane| {
                let slope = plane.m[d] * spacing[d];
                PreparedPlane {
                    g0: plane.m.dot(base) - plane.offset - plane.band_coeff * band - slack,
                    gu: plane.m[u] * spacing[u],
                    gw: plane.m[w] * spacing[w],
                    neg_inv: if slope != 0.0 { -1.0 / slope } else { 0.0 },
                }
            };
            let source = &part.planes[r.first_plane as usize..(r.first_plane + r.planes) as usize];
            let mut inline = [PreparedPlane {
                g0: 0.0,
                gu: 0.0,
                gw: 0.0,
                neg_inv: 0.0,
            }; INLINE_PLANES];
            let planes: &[PreparedPlane] = if source.len() <= INLINE_PLANES {
                for (slot, plane) in inline.iter_mut().zip(source) {
                    *slot = prepare(plane);
                }
                &inline[..source.len()]
            } else {
                heap.clear();
                heap.extend(source.iter().map(prepare));
                &heap
            };
            let (s_min, s_max) = (lo[d] as f64, hi[d] as f64);
            for cu in lo[u]..=hi[u] {
                for cw in lo[w]..=hi[w] {
                    let (mut s_lo, mut s_hi) = (s_min, s_max);
                    for plane in planes {
                        let g = plane.g0 + cu as f64 * plane.gu + cw as f64 * plane.gw;
                        if plane.neg_inv < 0.0 {
                            s_hi = s_hi.min(g * plane.neg_inv);
                        } else if plane.neg_inv > 0.0 {
                            s_lo = s_lo.max(g * plane.neg_inv);
                        } else if g > 0.0 {
                            s_hi = f64::NEG_INFINITY;
                        }
                        if s_lo > s_hi {
                            break;
                        }
                    }
                    if s_lo <= s_hi {
                        // s_lo, s_hi lie in the region's (clipped, i32) box.
                        emit_run(s_lo, s_hi, [d, u, w], cu, cw, &mut f);
                    }
                }
            }
        }
    }
}
