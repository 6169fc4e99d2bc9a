//! Extraction on an adaptive tree's own cells, without resampling to its finest level: the
//! tree's **dual grid** (Schaefer & Warren 2004, "Dual marching cubes: primal contouring of
//! dual grids"). Every vertex of the tree that lies inside its root gives one dual cell,
//! the eight leaves around it (leaf `b` is the one on the `+` side of axis `a` when bit `a`
//! of `b` is set), with its corners at the leaves' centres. Around a vertex where leaves of
//! different sizes meet, several corners are one leaf: the cell is a degenerate hexahedron.
//!
//! Vertices are keyed by their leaf pair (a dual edge) and placed on the segment between
//! the two leaves' centres, refined on the field. Two methods:
//!
//! - [`ExtractMethod::Cubes`] (the default): each dual cell by the lattice's marching-cubes
//!   cases (`cubes.rs`). Leaves around a tree vertex are boxes, so a repeated leaf fills
//!   corners adjacent along axes: a face with a repeated leaf is a triangle, a segment or a
//!   point, never ambiguous, and both cells sharing it see the same leaves in the same
//!   places, so they draw the same segments. Two crossings on edges with the same leaf pair
//!   are one vertex and adjacent on their loop (the face between those edges collapsed to
//!   the dual edge), so a triangle repeating a vertex has no area and is dropped, leaving
//!   the loop's disc one vertex shorter.
//! - [`ExtractMethod::Tetrahedra`]: each dual cell cut into the six Kuhn tetrahedra around
//!   its `0 → 7` diagonal; every shared face is cut from its lowest corner to its highest
//!   on both sides, and a tetrahedron with a repeated leaf has no volume and is skipped.
//!   About three times the triangles.
//!
//! Both are closed and manifold with no crack where leaf sizes change (checked by the tests
//! over ADFs of analytic shapes and of the unclean corpus, by an edge–face count from the
//! triangles alone). [`ExtractMethod::Dual`] is not offered on tree cells.
//!
//! The surface is closed wherever it lies inside the hull of the leaf centres: vertices on
//! the root's boundary have no dual cell, so a surface less than half a boundary leaf from
//! the root's faces is cut open there.

use rustc_hash::FxHashMap as HashMap;

use glam::DVec3;
use rayon::prelude::*;
use volga_core::{Aabb, Field};

use super::cubes::{decisions, emit_cube, CUBE_IDS};
use super::table::{self, EDGE_LO};
use super::tetra::{emit_tetrahedron, TETRAHEDRA};
use super::{finish, BlockMesh, ExtractError, ExtractMethod, Extraction, Surface, VertexPlacement, PRIVATE};

/// One leaf of an adaptive tree as its dual grid sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeLeaf {
    /// The leaf's centre (world space): a corner of the dual cells around it.
    pub world_centre: DVec3,
    /// The field there (the leaf's own reconstruction at its centre).
    pub value: f64,
}

/// A bound on the working bytes per leaf of a tree's dual grid and its extraction, before
/// the surface itself (a 32-byte [`TreeLeaf`], at most 8 dual cells of 32 bytes, and the
/// caller's per-leaf bookkeeping while it builds them, up to 128 bytes), for callers with
/// a memory limit.
pub const TREE_BYTES_PER_LEAF: u64 = 8 * 32 + 32 + 8 * 16;

/// The level and the vertex placement of an [`extract_tree_cells`] call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellExtraction {
    /// The iso value (0 for signed distances).
    pub iso: f64,
    /// How a vertex is placed between two leaf centres.
    pub placement: VertexPlacement,
    /// Largest distance (world units) a simplified vertex may lie from the plane of any
    /// triangle it replaced ([`simplify`](super::simplify)); 0 keeps every triangle.
    pub adaptivity: f64,
    /// [`ExtractMethod::Cubes`] or [`ExtractMethod::Tetrahedra`] (module documentation).
    pub method: ExtractMethod,
}

impl CellExtraction {
    /// Level `iso`, marching cubes, vertices refined onto the surface (tolerance `1e-9`, at
    /// most 32 steps), no simplification.
    pub fn new(iso: f64) -> CellExtraction {
        CellExtraction {
            iso,
            placement: VertexPlacement::Refined {
                tolerance: 1e-9,
                max_iterations: 32,
            },
            adaptivity: 0.0,
            method: ExtractMethod::Cubes,
        }
    }
}

/// Dual cells meshed per parallel task.
const CHUNK: usize = 2048;

/// The iso-surface of `field` on a tree's dual grid: `leaves` with their centres and
/// values, `dual_cells` the eight leaf indices around each tree vertex (module
/// documentation). Vertices are refined on `field`, which must be the field whose values
/// `leaves` hold (a leaf's centre value is where a refinement starts). Triangles are
/// counter-clockwise seen from outside and merged in `dual_cells` order, so the mesh is
/// identical for any thread count; it stops with [`ExtractError::TooManyTriangles`] past
/// `max_triangles`. `Surface::blocks_sampled` counts the dual cells the surface crosses,
/// `blocks_skipped` the others.
pub fn extract_tree_cells<F: Field + ?Sized>(
    field: &F,
    leaves: &[TreeLeaf],
    dual_cells: &[[u32; 8]],
    job: &CellExtraction,
    max_triangles: u64,
) -> Result<Surface, ExtractError> {
    if !job.iso.is_finite() {
        return Err(ExtractError::Iso(job.iso));
    }
    if !(job.adaptivity.is_finite() && job.adaptivity >= 0.0) {
        return Err(ExtractError::Adaptivity(job.adaptivity));
    }
    if job.method == ExtractMethod::Dual {
        return Err(ExtractError::MethodOnTree(job.method));
    }
    for (cell, ids) in dual_cells.iter().enumerate() {
        if let Some(&leaf) = ids.iter().find(|&&i| i as usize >= leaves.len()) {
            return Err(ExtractError::LeafIndex {
                cell,
                leaf,
                leaves: leaves.len(),
            });
        }
    }
    let inward = field.kind().inward_sign();
    let triangles = std::sync::atomic::AtomicU64::new(0);
    let over = std::sync::atomic::AtomicBool::new(false);
    let crossed = std::sync::atomic::AtomicU64::new(0);
    let outs: Vec<BlockMesh> = dual_cells
        .par_chunks(CHUNK)
        .filter_map(|chunk| {
            if over.load(std::sync::atomic::Ordering::Relaxed) {
                return None;
            }
            let (out, n) = mesh_chunk(field, leaves, chunk, job, inward);
            crossed.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
            let total = triangles.fetch_add(out.triangles.len() as u64, std::sync::atomic::Ordering::Relaxed)
                + out.triangles.len() as u64;
            if total > max_triangles {
                over.store(true, std::sync::atomic::Ordering::Relaxed);
                return None;
            }
            (!out.triangles.is_empty()).then_some(out)
        })
        .collect();
    if over.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(ExtractError::TooManyTriangles { max: max_triangles });
    }
    // `finish` takes a lattice job: the simplification bound is `adaptivity · cell`.
    let lattice_job = Extraction {
        region: Aabb::EMPTY,
        cell: 1.0,
        iso: job.iso,
        placement: job.placement,
        method: job.method,
        adaptivity: job.adaptivity,
    };
    let chunks = outs.len() as u64;
    let mut surface = finish(field, &lattice_job, outs, chunks);
    let crossed = crossed.into_inner();
    surface.blocks_sampled = crossed;
    surface.blocks_skipped = dual_cells.len() as u64 - crossed;
    Ok(surface)
}

/// Marching cubes or tetrahedra over one chunk of dual cells; also the number the surface
/// crosses.
fn mesh_chunk<F: Field + ?Sized>(
    field: &F,
    leaves: &[TreeLeaf],
    chunk: &[[u32; 8]],
    job: &CellExtraction,
    inward: f64,
) -> (BlockMesh, u64) {
    let mut out = BlockMesh::default();
    let mut local: HashMap<u64, u32> = HashMap::default();
    let mut crossed = 0;
    let cases = table::cases();
    for ids in chunk {
        let vals: [f64; 8] = ids.map(|i| inward * (leaves[i as usize].value - job.iso));
        let inside_mask = (0..8).fold(0u8, |m, c| m | ((vals[c] >= 0.0) as u8) << c);
        if inside_mask == 0 || inside_mask == 0xff {
            continue;
        }
        crossed += 1;
        let mut vertex = |a: usize, b: usize| -> u32 {
            // Keyed and placed from the lower leaf index to the higher one, so every dual
            // cell sharing the pair computes the same vertex.
            let (la, lb) = (ids[a].min(ids[b]), ids[a].max(ids[b]));
            let key = (la as u64) << 32 | lb as u64;
            *local.entry(key).or_insert_with(|| {
                let (pa, pb) = (&leaves[la as usize], &leaves[lb as usize]);
                let (sa, sb) = (inward * (pa.value - job.iso), inward * (pb.value - job.iso));
                let position = super::place_on_segment(
                    field,
                    pa.world_centre,
                    pb.world_centre,
                    sa,
                    sb,
                    job.placement,
                    job.iso,
                    inward,
                    1e-9,
                );
                out.keys.push(key);
                out.positions.push(position);
                out.positions.len() as u32 - 1
            })
        };
        if job.method == ExtractMethod::Tetrahedra {
            for tet in TETRAHEDRA {
                let t = tet.map(|c| ids[c]);
                if t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3] {
                    continue;
                }
                emit_tetrahedron(tet, &vals, &mut vertex, &mut out.triangles);
            }
            continue;
        }
        let case = &cases[inside_mask as usize * 64 + decisions(inside_mask, &vals) as usize];
        let mut slots = [0u32; CUBE_IDS];
        for &e in &case.edges {
            slots[e as usize] = vertex(EDGE_LO[e as usize], table::edge_hi(e as usize));
        }
        let (first, first_vertex) = (out.triangles.len(), out.positions.len());
        emit_cube(case, &vals, &mut slots, &mut out, |_| PRIVATE);
        // A loop's centre (or a tube's ring) is an average of its crossings, which across a
        // large cell can be far from a curved surface: Newton steps along the gradient.
        for p in &mut out.positions[first_vertex..] {
            *p = onto_surface(field, *p, job.iso);
        }
        // Crossings of two edges with one leaf pair are one vertex: drop what has no area.
        let mut k = first;
        for i in first..out.triangles.len() {
            let t = out.triangles[i];
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                out.triangles[k] = t;
                k += 1;
            }
        }
        out.triangles.truncate(k);
    }
    (out, crossed)
}

/// `p` moved onto the level `iso` by Newton steps along the field's gradient (at most 8,
/// each kept only if it brings the value closer to `iso`).
fn onto_surface<F: Field + ?Sized>(field: &F, mut p: DVec3, iso: f64) -> DVec3 {
    let mut v = field.value(p) - iso;
    for _ in 0..8 {
        if !v.is_finite() || v == 0.0 {
            break;
        }
        let g = field.gradient(p);
        let g2 = g.length_squared();
        if !(g2.is_finite() && g2 > 0.0) {
            break;
        }
        let q = p - g * (v / g2);
        let w = field.value(q) - iso;
        if w.is_nan() || w.abs() >= v.abs() {
            break;
        }
        (p, v) = (q, w);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use volga_core::FieldKind;

    /// `|p| − 1`.
    struct Ball;
    impl Field for Ball {
        fn kind(&self) -> FieldKind {
            FieldKind::SignedDistance
        }
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0))
        }
        fn value(&self, p: DVec3) -> f64 {
            p.length() - 1.0
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::splat(1e-6)
        }
        fn value_range(&self, _: &Aabb) -> (f64, f64) {
            (f64::NEG_INFINITY, f64::INFINITY)
        }
    }

    /// A uniform tree: leaves of size 0.25 over [−1.5, 1.5]³, dual cells its lattice cubes.
    fn uniform() -> (Vec<TreeLeaf>, Vec<[u32; 8]>) {
        let n = 12;
        let at = |x: i32, y: i32, z: i32| (x + n * (y + n * z)) as u32;
        let mut leaves = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let c = DVec3::new(x as f64, y as f64, z as f64) * 0.25 - 1.375;
                    leaves.push(TreeLeaf {
                        world_centre: c,
                        value: Ball.value(c),
                    });
                }
            }
        }
        let mut cells = Vec::new();
        for z in 0..n - 1 {
            for y in 0..n - 1 {
                for x in 0..n - 1 {
                    cells.push(std::array::from_fn(|b| {
                        at(x + (b & 1) as i32, y + (b >> 1 & 1) as i32, z + (b >> 2 & 1) as i32)
                    }));
                }
            }
        }
        (leaves, cells)
    }

    #[test]
    fn a_uniform_tree_meshes_like_its_lattice_and_bad_input_is_refused() {
        let (leaves, cells) = uniform();
        for method in [ExtractMethod::Cubes, ExtractMethod::Tetrahedra] {
            let job = CellExtraction {
                method,
                ..CellExtraction::new(0.0)
            };
            let s = extract_tree_cells(&Ball, &leaves, &cells, &job, u64::MAX).unwrap();
            let stats = s.mesh.edge_stats();
            assert_eq!((stats.boundary_edges, stats.non_manifold_edges), (0, 0), "{method:?}");
            assert!(s.mesh.positions.iter().all(|p| (p.length() - 1.0).abs() < 1e-6));
            let lattice =
                Extraction::new(Aabb::new(DVec3::splat(-1.375), DVec3::splat(1.375)), 0.25, 0.0).with_method(method);
            let l = super::super::extract_surface_with(&Ball, &lattice).unwrap();
            assert_eq!(s.mesh.triangles.len(), l.mesh.triangles.len(), "{method:?}");
        }
        let job = CellExtraction::new(0.0);
        let mut bad = cells.clone();
        bad[5][3] = leaves.len() as u32;
        assert!(matches!(
            extract_tree_cells(&Ball, &leaves, &bad, &job, u64::MAX),
            Err(ExtractError::LeafIndex { cell: 5, .. })
        ));
        let dual = CellExtraction {
            method: ExtractMethod::Dual,
            ..job
        };
        assert!(matches!(
            extract_tree_cells(&Ball, &leaves, &cells, &dual, u64::MAX),
            Err(ExtractError::MethodOnTree(ExtractMethod::Dual))
        ));
        let nan = CellExtraction { iso: f64::NAN, ..job };
        assert!(matches!(
            extract_tree_cells(&Ball, &leaves, &cells, &nan, u64::MAX),
            Err(ExtractError::Iso(_))
        ));
        assert!(matches!(
            extract_tree_cells(&Ball, &leaves, &cells, &job, 10),
            Err(ExtractError::TooManyTriangles { max: 10 })
        ));
    }
}
