//! Iso-surface extraction from any [`Field`]: the one mesher that sculpts, ADFs and scene
//! outputs share.
//!
//! **Methods** ([`ExtractMethod`], per call; `docs/EXTRACT.md` has the figures), all on the
//! lattice `region.min + ijk·cell` and all **closed and manifold by index** wherever the
//! surface lies inside `region` (every edge in exactly two triangles, once in each
//! direction; every vertex's link one disc):
//!
//! - [`ExtractMethod::Cubes`] (the default): marching cubes whose case table is derived
//!   from the asymptotic decider on faces (`table.rs`) and whose interiors are decided by
//!   the trilinear interpolant's cross-sections (`cubes.rs`: tubes where it joins two
//!   loops), the survey's §3;
//! - [`ExtractMethod::Dual`]: one vertex per marching-cubes loop at its QEF minimizer, one
//!   quad per crossing lattice edge (`dual.rs`), which keeps sharp edges and corners;
//! - [`ExtractMethod::Tetrahedra`]: the six Kuhn (Freudenthal) tetrahedra around each
//!   cube's main diagonal, the same split in every cube (Doi & Koide 1991): no ambiguous
//!   configuration at all, about three times the triangles.
//!
//! [`Extraction::adaptivity`] then merges vertices within a stated bound ([`simplify`]), and
//! [`IsoIndex`] keeps a lattice's samples for re-extraction at other iso-values.
//!
//! **Sides.** A lattice point is *inside* when `inward·(value − iso) ≥ 0`
//! ([`FieldKind::inward_sign`](volga_core::FieldKind::inward_sign)): a half-open rule, so a value exactly at `iso` counts as
//! inside and a vertex never needs a tie-break. Triangles are counter-clockwise seen from
//! outside (volga-mesh's convention); the orientation is decided from the lattice corners'
//! integer positions, never from interpolated vertices, so it is exact.
//!
//! **Vertex placement.** [`VertexPlacement::Linear`] interpolates the two lattice values
//! (what marching-cubes tools do: error `O(cell²·curvature)`); [`VertexPlacement::Refined`]
//! then runs regula falsi (Illinois) on the field along the edge until the value is within
//! `tolerance` of `iso` or the bracket is shorter than `1e-9·cell`. Normals are the field's
//! gradient turned outward by its kind ([`FieldKind::outward`](volga_core::FieldKind::outward)), unit length (zero where the
//! gradient vanishes).
//!
//! **Speed.** The lattice is cut into blocks of 16³ cubes; a block whose conservative
//! [`Field::value_range`] lies on one side of `iso` is skipped without sampling (an
//! octree-backed field answers that per node), the others are sampled (straight from the
//! voxels when the lattice is a volume's voxel centres) and meshed in parallel, and
//! vertices are merged by key (lattice edge, cube loop, face) in block order, so the mesh
//! is identical for any thread count.

use rustc_hash::FxHashMap as HashMap;

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Aabb, Field};

use crate::TriMesh;

mod cells;
mod cubes;
mod dual;
mod samples;
pub mod simplify;
mod span;
mod table;
mod tetra;

pub use cells::{extract_tree_cells, CellExtraction, TreeLeaf, TREE_BYTES_PER_LEAF};
pub use span::IsoIndex;

use samples::{edge_fraction, BlockSamples};

/// Cubes per block edge.
const BLOCK: i32 = 16;
/// At most this many lattice points per axis (edge keys must fit in 64 bits).
pub const MAX_LATTICE_POINTS_PER_AXIS: u64 = 1 << 20;

/// Why an extraction was refused (before any sampling).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExtractError {
    /// `region` has a NaN or infinite corner, or `min > max` on some axis. A flat box
    /// (`min == max` on an axis) is accepted: it gets one cell across.
    #[error("extraction region must be finite and non-empty, got {min:?} .. {max:?}")]
    Region {
        /// `region.min` as given.
        min: [f64; 3],
        /// `region.max` as given.
        max: [f64; 3],
    },
    /// `cell` is zero, negative, NaN or infinite; holds the value given.
    #[error("extraction cell size must be finite and positive, got {0}")]
    Cell(f64),
    /// `iso` is NaN or infinite; holds the value given.
    #[error("iso value must be finite, got {0}")]
    Iso(f64),
    /// The lattice would have more than [`MAX_LATTICE_POINTS_PER_AXIS`] points along some
    /// axis: use a larger `cell` or a smaller `region`.
    #[error("extraction lattice of {points:?} points is too large (at most {max} per axis)")]
    TooLarge {
        /// Lattice points asked for along x, y and z: `⌈size / cell⌉ + 1` per axis.
        points: [u64; 3],
        /// The limit, [`MAX_LATTICE_POINTS_PER_AXIS`].
        max: u64,
    },
    /// The lattice has more than [`MAX_BLOCKS`] blocks of 16³ cubes: more than an
    /// extraction visits in reasonable time. Use a larger `cell` or a smaller `region`.
    #[error("extraction lattice of {points:?} points has {blocks} blocks of 16³ cubes, more than the {max} an extraction visits: use a larger cell or a smaller region")]
    TooManyBlocks {
        /// Lattice points along x, y and z.
        points: [u64; 3],
        /// Blocks the lattice has.
        blocks: u64,
        /// The limit, [`MAX_BLOCKS`].
        max: u64,
    },
    /// The adaptivity is negative, NaN or infinite; holds the value given.
    #[error("adaptivity must be finite and at least 0 (cells), got {0}")]
    Adaptivity(f64),
    /// [`extract_tree_cells`] offers marching cubes and tetrahedra, not this method.
    #[error("the {} method does not run on a tree's own cells: use cubes or tetrahedra", .0.name())]
    MethodOnTree(ExtractMethod),
    /// A dual cell given to [`extract_tree_cells`] names a leaf that is not in its list.
    #[error("dual cell {cell} names leaf {leaf}, but there are {leaves} leaves")]
    LeafIndex {
        /// The dual cell's position in its list.
        cell: usize,
        /// The leaf index it names.
        leaf: u32,
        /// Leaves given.
        leaves: usize,
    },
    /// An [`IsoIndex`] would keep more than `max_bytes` of samples: narrow the iso range,
    /// use a larger cell or raise the memory limit.
    #[error("the iso-value index would keep more than {} of samples: narrow the iso range, use a larger cell or raise the memory limit", volga_core::memory::Bytes(*max_bytes as u128))]
    IndexTooLarge {
        /// The most bytes allowed.
        max_bytes: u64,
    },
    /// The surface has more triangles than the caller allowed
    /// ([`extract_surface_bounded`]); the extraction stopped there.
    #[error("the surface has more than {max} triangles, the most this extraction may hold (about {} of memory at {BYTES_PER_TRIANGLE} bytes per triangle): use a larger cell or raise the memory limit", volga_core::memory::Bytes(*max as u128 * BYTES_PER_TRIANGLE as u128))]
    TooManyTriangles {
        /// The most triangles allowed.
        max: u64,
    },
}

/// Most blocks of 16³ lattice cubes an extraction visits (2^30: each is at least one
/// `value_range` query).
pub const MAX_BLOCKS: u64 = 1 << 30;

/// Peak bytes an extraction holds per output triangle (the triangle, its share of vertex
/// positions, normals and edge keys, and the per-block copies before merging): what
/// [`extract_surface_bounded`]'s `max_triangles` is computed from by callers with a
/// memory limit.
pub const BYTES_PER_TRIANGLE: u64 = 160;

/// Where a vertex is placed on its lattice edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VertexPlacement {
    /// Linear interpolation of the two lattice values (marching-cubes placement).
    Linear,
    /// Linear, then regula falsi on the field until `|value − iso| ≤ tolerance` (in the
    /// field's units) or the bracket is below `1e-9·cell`, at most `max_iterations` steps.
    Refined {
        /// Stop once `|value − iso| ≤ tolerance` (field units); a negative or NaN tolerance
        /// leaves only the bracket width and `max_iterations` to stop it.
        tolerance: f64,
        /// Most field evaluations per vertex; 0 keeps the linear placement.
        max_iterations: u32,
    },
}

/// How the surface is drawn through the lattice cubes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum ExtractMethod {
    /// Marching tetrahedra: six Kuhn tetrahedra per cube, no ambiguous case at all; about
    /// three times the triangles of marching cubes.
    Tetrahedra,
    /// Marching cubes with topology-correct cases: faces by the asymptotic decider,
    /// interiors by the trilinear interpolant's cross-sections (tubes where it has one).
    #[default]
    Cubes,
    /// Dual contouring on the marching-cubes loops: one vertex per loop at the minimizer
    /// of its crossings' tangent planes (sharp edges and corners kept), one quad per
    /// crossing lattice edge.
    Dual,
}

impl ExtractMethod {
    /// Every method, in the order tables list them.
    pub const ALL: [ExtractMethod; 3] = [ExtractMethod::Tetrahedra, ExtractMethod::Cubes, ExtractMethod::Dual];

    /// The method's name as the CLI, scene files and reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            ExtractMethod::Tetrahedra => "tetrahedra",
            ExtractMethod::Cubes => "cubes",
            ExtractMethod::Dual => "dual",
        }
    }

    /// The method named `name` (as [`name`](Self::name) spells it).
    pub fn from_name(name: &str) -> Option<ExtractMethod> {
        ExtractMethod::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// What to extract: the lattice and the level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extraction {
    /// World box sampled; a closed surface must lie strictly inside it to come out closed.
    pub region: Aabb,
    /// Lattice spacing (world units).
    pub cell: f64,
    /// The iso value (0.5 for volga's filtered densities, 0 for signed distances).
    pub iso: f64,
    /// How a vertex is placed on a lattice edge that crosses `iso`.
    pub placement: VertexPlacement,
    /// How the surface is drawn through the cubes.
    pub method: ExtractMethod,
    /// Largest distance (in lattice cells) a simplified vertex may lie from the plane of
    /// any triangle it replaced; 0 keeps every triangle. See [`simplify`].
    pub adaptivity: f64,
}

impl Extraction {
    /// The lattice of spacing `cell` over `region` at `iso`, marching cubes, vertices
    /// refined onto the surface (tolerance `1e-9`, at most 32 steps), no simplification.
    pub fn new(region: Aabb, cell: f64, iso: f64) -> Extraction {
        Extraction {
            region,
            cell,
            iso,
            placement: VertexPlacement::Refined {
                tolerance: 1e-9,
                max_iterations: 32,
            },
            method: ExtractMethod::Cubes,
            adaptivity: 0.0,
        }
    }

    /// This extraction with another method.
    pub fn with_method(mut self, method: ExtractMethod) -> Extraction {
        self.method = method;
        self
    }

    /// This extraction with another adaptivity (cells).
    pub fn with_adaptivity(mut self, adaptivity: f64) -> Extraction {
        self.adaptivity = adaptivity;
        self
    }

    /// This extraction with another vertex placement.
    pub fn with_placement(mut self, placement: VertexPlacement) -> Extraction {
        self.placement = placement;
        self
    }
}

/// An extracted surface: the mesh and one unit outward normal per vertex.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Surface {
    /// The triangles, in world coordinates, counter-clockwise seen from outside; empty if
    /// the surface does not cross the lattice. Vertices are shared by lattice edge, not by
    /// position: where the field equals `iso` exactly at a lattice point, the vertices of
    /// several edges coincide there and zero-area triangles can occur.
    pub mesh: TriMesh,
    /// One per entry of `mesh.positions`: the field's gradient there, turned outward and
    /// normalized; zero where the gradient vanishes.
    pub normals: Vec<DVec3>,
    /// Blocks of up to 16³ lattice cubes that were sampled and meshed.
    pub blocks_sampled: u64,
    /// Blocks skipped without sampling because [`Field::value_range`] put them wholly on
    /// one side of `iso`.
    pub blocks_skipped: u64,
    /// Cubes ([`ExtractMethod::Cubes`]) whose interior joined two loops into a tube.
    pub tubes: u64,
    /// Edge collapses made by the simplification (`adaptivity > 0`).
    pub collapses: u64,
}

/// The iso-surface of `field` at `iso` on the lattice of spacing `cell` over `region`,
/// with vertices refined onto the surface (tolerance `1e-9` of the field's units, at most
/// 32 regula falsi steps). See the module documentation.
pub fn extract_surface<F: Field + ?Sized>(
    field: &F,
    region: Aabb,
    cell: f64,
    iso: f64,
) -> Result<Surface, ExtractError> {
    extract_surface_with(field, &Extraction::new(region, cell, iso))
}

/// The lattice of an extraction: points `region.min + ijk·cell`, `0 ≤ ijk < points`.
#[derive(Clone, Copy)]
pub(crate) struct Lattice {
    origin: DVec3,
    cell: f64,
    points: IVec3,
}

impl Lattice {
    #[inline]
    fn world(&self, ijk: IVec3) -> DVec3 {
        self.origin + ijk.as_dvec3() * self.cell
    }
    #[inline]
    fn linear(&self, ijk: IVec3) -> u64 {
        let p = self.points.as_u64vec3();
        ijk.x as u64 + p.x * (ijk.y as u64 + p.y * ijk.z as u64)
    }
}

/// The lattice of `job` and its blocks per axis, after checking every parameter.
fn checked_lattice(job: &Extraction) -> Result<(Lattice, IVec3), ExtractError> {
    let region = job.region;
    if !(region.min.is_finite() && region.max.is_finite()) || region.is_empty() {
        return Err(ExtractError::Region {
            min: region.min.to_array(),
            max: region.max.to_array(),
        });
    }
    if !(job.cell.is_finite() && job.cell > 0.0) {
        return Err(ExtractError::Cell(job.cell));
    }
    if !job.iso.is_finite() {
        return Err(ExtractError::Iso(job.iso));
    }
    if !(job.adaptivity.is_finite() && job.adaptivity >= 0.0) {
        return Err(ExtractError::Adaptivity(job.adaptivity));
    }
    let cubes = (region.size() / job.cell).ceil().max(DVec3::ONE);
    let points = [cubes.x + 1.0, cubes.y + 1.0, cubes.z + 1.0];
    if points.iter().any(|&p| p > MAX_LATTICE_POINTS_PER_AXIS as f64) {
        return Err(ExtractError::TooLarge {
            points: points.map(|p| p as u64),
            max: MAX_LATTICE_POINTS_PER_AXIS,
        });
    }
    let lattice = Lattice {
        origin: region.min,
        cell: job.cell,
        points: IVec3::new(points[0] as i32, points[1] as i32, points[2] as i32),
    };
    let blocks = (lattice.points - 1 + BLOCK - 1) / BLOCK;
    let block_count = blocks.as_u64vec3().element_product();
    if block_count > MAX_BLOCKS {
        return Err(ExtractError::TooManyBlocks {
            points: points.map(|p| p as u64),
            blocks: block_count,
            max: MAX_BLOCKS,
        });
    }
    Ok((lattice, blocks))
}

/// [`extract_surface`] with every choice explicit.
pub fn extract_surface_with<F: Field + ?Sized>(field: &F, job: &Extraction) -> Result<Surface, ExtractError> {
    extract_surface_bounded(field, job, u64::MAX)
}

/// [`extract_surface_with`] stopping with [`ExtractError::TooManyTriangles`] once the
/// surface passes `max_triangles` (callers with a memory limit pass
/// `limit / BYTES_PER_TRIANGLE`), so a surface larger than memory is refused while it is
/// being found rather than discovered by the allocator.
pub fn extract_surface_bounded<F: Field + ?Sized>(
    field: &F,
    job: &Extraction,
    max_triangles: u64,
) -> Result<Surface, ExtractError> {
    let (lattice, blocks) = checked_lattice(job)?;
    let inward = field.kind().inward_sign();
    let block_count = blocks.as_u64vec3().element_product();
    // Blocks are numbered x fastest and met in that order; only those the surface crosses
    // are kept, and the triangle count is watched as they are meshed.
    let (bx, by) = (blocks.x as u64, blocks.y as u64);
    let triangles = std::sync::atomic::AtomicU64::new(0);
    let over = std::sync::atomic::AtomicBool::new(false);
    let outs: Vec<BlockMesh> = (0..block_count)
        .into_par_iter()
        .filter_map(|k| {
            if over.load(std::sync::atomic::Ordering::Relaxed) {
                return None;
            }
            let b = IVec3::new((k % bx) as i32, (k / bx % by) as i32, (k / (bx * by)) as i32);
            let out = mesh_block(field, &lattice, b, job, inward)?;
            let total = triangles.fetch_add(out.triangles.len() as u64, std::sync::atomic::Ordering::Relaxed)
                + out.triangles.len() as u64;
            if total > max_triangles {
                over.store(true, std::sync::atomic::Ordering::Relaxed);
                return None;
            }
            Some(out)
        })
        .collect();
    if over.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(ExtractError::TooManyTriangles { max: max_triangles });
    }

    Ok(finish(field, job, outs, block_count))
}

/// Merges block meshes (in block order: deterministic for any thread count), simplifies
/// them if asked, and adds the normals.
fn finish<F: Field + ?Sized>(field: &F, job: &Extraction, outs: Vec<BlockMesh>, block_count: u64) -> Surface {
    let mut surface = Surface {
        blocks_skipped: block_count - outs.len() as u64,
        blocks_sampled: outs.len() as u64,
        ..Surface::default()
    };
    let mut index: HashMap<u64, u32> = HashMap::default();
    let mut remap = Vec::new();
    // Gradients known from the blocks' voxels (NaN: ask the field), unless the
    // simplification moves the vertices.
    let keep_known = job.adaptivity == 0.0;
    let mut known: Vec<DVec3> = Vec::new();
    index.reserve(
        outs.iter()
            .map(|o| o.keys.iter().filter(|&&k| k != PRIVATE).count())
            .sum(),
    );
    surface
        .mesh
        .positions
        .reserve(outs.iter().map(|o| o.positions.len()).sum());
    surface
        .mesh
        .triangles
        .reserve(outs.iter().map(|o| o.triangles.len()).sum());
    for out in outs {
        remap.clear();
        surface.tubes += out.tubes;
        for (key, pos) in out.keys.iter().zip(&out.positions) {
            let next = surface.mesh.positions.len() as u32;
            if *key == PRIVATE {
                surface.mesh.positions.push(*pos);
                remap.push(next);
                continue;
            }
            let id = *index.entry(*key).or_insert_with(|| {
                surface.mesh.positions.push(*pos);
                next
            });
            // A dual block refers to other blocks' cube vertices before their owner places
            // them (position NaN until then).
            if surface.mesh.positions[id as usize].is_nan() {
                surface.mesh.positions[id as usize] = *pos;
            }
            remap.push(id);
        }
        surface
            .mesh
            .triangles
            .extend(out.triangles.iter().map(|t| t.map(|v| remap[v as usize])));
        if keep_known && !out.gradients.is_empty() {
            known.resize(surface.mesh.positions.len(), DVec3::NAN);
            for (v, g) in &out.gradients {
                // A shared vertex keeps its first block's position, and gradient.
                let slot = &mut known[remap[*v as usize] as usize];
                if slot.is_nan() {
                    *slot = *g;
                }
            }
        }
    }
    debug_assert!(surface.mesh.positions.iter().all(|p| p.is_finite()));
    if job.adaptivity > 0.0 {
        let stats = simplify::simplify(&mut surface.mesh, job.adaptivity * job.cell);
        surface.collapses = stats.collapses;
    }
    // (Empty when the simplification ran: every vertex then asks the field.)
    known.resize(surface.mesh.positions.len(), DVec3::NAN);
    let positions = &surface.mesh.positions;
    surface.normals = positions
        .par_chunks(1024)
        .zip(known.par_chunks(1024))
        .flat_map_iter(|(chunk, known)| {
            let ask: Vec<DVec3> = chunk
                .iter()
                .zip(known)
                .filter(|(_, g)| g.is_nan())
                .map(|(p, _)| *p)
                .collect();
            let mut asked = vec![DVec3::ZERO; ask.len()];
            field.gradients_at(&ask, &mut asked);
            let mut asked = asked.into_iter();
            known
                .iter()
                .map(|g| {
                    let g = if g.is_nan() {
                        asked.next().unwrap_or(DVec3::ZERO)
                    } else {
                        *g
                    };
                    field.kind().outward(g).normalize_or_zero()
                })
                .collect::<Vec<_>>()
        })
        .collect();
    surface
}

/// One block's triangles over its own vertex list; `keys[v]` names vertex `v` (a lattice
/// edge, a cube's loop, a face split: see the methods' modules).
#[derive(Default)]
struct BlockMesh {
    keys: Vec<u64>,
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Cubes whose two loops were joined into a tube.
    tubes: u64,
    /// Field gradients already known from the block's voxels: (vertex, gradient).
    gradients: Vec<(u32, DVec3)>,
}

/// The key of a vertex that belongs to one cube alone (never merged).
const PRIVATE: u64 = u64::MAX;

/// Whether the lattice edge between a block's points `la` and `lb` (block coordinates, the
/// block spanning `0 ..= n − 1`) lies in one of the block's faces: only such an edge's
/// vertex can be met by a neighbouring block, so only it is keyed for merging.
#[inline]
fn on_block_face(n: IVec3, la: IVec3, lb: IVec3) -> bool {
    (0..3).any(|k| la[k] == lb[k] && (la[k] == 0 || la[k] == n[k] - 1))
}

/// Corner `c` of a cube as an offset: `(c & 1, c >> 1 & 1, c >> 2 & 1)`.
#[inline]
fn corner(c: usize) -> IVec3 {
    IVec3::new((c & 1) as i32, (c >> 1 & 1) as i32, (c >> 2 & 1) as i32)
}

/// Whether the block's lattice points `lo ..= hi` may hold both sides of `iso` (from the
/// field's conservative value range).
fn block_may_cross<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    lo: IVec3,
    hi: IVec3,
    iso: f64,
    inward: f64,
) -> bool {
    let (vlo, vhi) = field.value_range(&Aabb::new(lattice.world(lo), lattice.world(hi)));
    let (slo, shi) = if inward > 0.0 {
        (vlo - iso, vhi - iso)
    } else {
        (iso - vhi, iso - vlo)
    };
    // All inside or all outside: no edge changes side.
    !(slo >= 0.0 || shi < 0.0)
}

/// The lattice points a block samples: its own (`lo ..= hi`), and for the dual method one
/// more below (the cubes around its lattice edges).
fn block_points(lattice: &Lattice, block: IVec3, method: ExtractMethod) -> (IVec3, IVec3, IVec3) {
    let lo = block * BLOCK;
    let hi = (lo + BLOCK).min(lattice.points - 1);
    let sample_lo = match method {
        ExtractMethod::Dual => (lo - 1).max(IVec3::ZERO),
        _ => lo,
    };
    (lo, hi, sample_lo)
}

fn mesh_block<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    block: IVec3,
    job: &Extraction,
    inward: f64,
) -> Option<BlockMesh> {
    let (lo, hi, sample_lo) = block_points(lattice, block, job.method);
    if !block_may_cross(field, lattice, lo, hi, job.iso, inward) {
        return None;
    }
    let samples = BlockSamples::sample(field, lattice, sample_lo, hi).signed(inward, job.iso);
    Some(mesh_samples(field, lattice, &samples, lo, job, inward))
}

/// One block's mesh from its inward-signed samples.
fn mesh_samples<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    samples: &BlockSamples,
    lo: IVec3,
    job: &Extraction,
    inward: f64,
) -> BlockMesh {
    match job.method {
        ExtractMethod::Tetrahedra => tetra::mesh_block(field, lattice, samples, job, inward),
        ExtractMethod::Cubes => cubes::mesh_block(field, lattice, samples, job, inward),
        ExtractMethod::Dual => dual::mesh_block(field, lattice, samples, lo, job, inward),
    }
}

/// The vertex on the lattice edge `pa → pb` (values `sa`, `sb` on opposite sides, in the
/// inward-signed space where inside is `≥ 0`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn place<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    pa: IVec3,
    pb: IVec3,
    sa: f64,
    sb: f64,
    job: &Extraction,
    inward: f64,
) -> DVec3 {
    let (wa, wb) = (lattice.world(pa), lattice.world(pb));
    let min_width = 1e-9 / (wb - wa).length().max(f64::MIN_POSITIVE) * lattice.cell;
    place_on_segment(field, wa, wb, sa, sb, job.placement, job.iso, inward, min_width)
}

/// The vertex on the segment `wa → wb` (world space; values `sa`, `sb` on opposite sides
/// in the inward-signed space), refined by `placement` until the bracket is narrower than
/// `min_width` (a fraction of the segment).
#[allow(clippy::too_many_arguments)]
pub(crate) fn place_on_segment<F: Field + ?Sized>(
    field: &F,
    wa: DVec3,
    wb: DVec3,
    sa: f64,
    sb: f64,
    placement: VertexPlacement,
    iso: f64,
    inward: f64,
    min_width: f64,
) -> DVec3 {
    let at = |t: f64| wa + (wb - wa) * t;
    let t = (sa / (sa - sb)).clamp(0.0, 1.0);
    let VertexPlacement::Refined {
        tolerance,
        max_iterations,
    } = placement
    else {
        return at(t);
    };
    // Regula falsi with the Illinois modification on s(t), bracket [t0, t1].
    let (mut t0, mut t1, mut s0, mut s1) = (0.0, 1.0, sa, sb);
    let mut t = t;
    let mut side = 0i8;
    for _ in 0..max_iterations {
        let s = inward * (field.value(at(t)) - iso);
        if !s.is_finite() || s.abs() <= tolerance {
            break;
        }
        if (s >= 0.0) == (s0 >= 0.0) {
            t0 = t;
            s0 = s;
            if side == -1 {
                s1 *= 0.5;
            }
            side = -1;
        } else {
            t1 = t;
            s1 = s;
            if side == 1 {
                s0 *= 0.5;
            }
            side = 1;
        }
        if t1 - t0 <= min_width {
            break;
        }
        let next = t0 + (t1 - t0) * s0 / (s0 - s1);
        t = if next.is_finite() && next > t0 && next < t1 {
            next
        } else {
            0.5 * (t0 + t1)
        };
    }
    at(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `|p − c| − r`, exact range.
    struct Ball {
        c: DVec3,
        r: f64,
    }
    impl Field for Ball {
        fn kind(&self) -> volga_core::FieldKind {
            volga_core::FieldKind::SignedDistance
        }
        fn bounds(&self) -> Aabb {
            Aabb::new(self.c - self.r - 1.0, self.c + self.r + 1.0)
        }
        fn value(&self, p: DVec3) -> f64 {
            (p - self.c).length() - self.r
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::splat(1e-4)
        }
        fn value_range(&self, b: &Aabb) -> (f64, f64) {
            let d = self.value(b.center());
            let h = b.size().length() * 0.5;
            (d - h, d + h)
        }
    }

    #[test]
    fn a_ball_is_closed_and_outward_and_blocks_are_skipped() {
        let ball = Ball {
            c: DVec3::new(0.1, 0.2, 0.3),
            r: 10.0,
        };
        let region = Aabb::new(DVec3::splat(-40.0), DVec3::splat(40.0));
        let s = extract_surface(&ball, region, 0.7, 0.0).unwrap();
        assert_eq!(s.mesh.edge_stats().boundary_edges, 0);
        assert_eq!(s.mesh.edge_stats().non_manifold_edges, 0);
        assert!(s.blocks_skipped > 0 && s.blocks_sampled > 0);
        for (tri, _) in s.mesh.triangles.iter().zip(0..) {
            let [a, b, c] = tri.map(|v| s.mesh.positions[v as usize]);
            let n = (b - a).cross(c - a);
            if n.length() > 1e-9 {
                assert!(n.dot((a + b + c) / 3.0 - ball.c) > 0.0, "inward triangle");
            }
        }
    }

    #[test]
    fn refused_inputs() {
        let ball = Ball { c: DVec3::ZERO, r: 1.0 };
        let r = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0));
        assert!(matches!(
            extract_surface(&ball, r, 0.0, 0.0),
            Err(ExtractError::Cell(_))
        ));
        assert!(matches!(
            extract_surface(&ball, r, f64::NAN, 0.0),
            Err(ExtractError::Cell(_))
        ));
        assert!(matches!(
            extract_surface(&ball, Aabb::EMPTY, 0.1, 0.0),
            Err(ExtractError::Region { .. })
        ));
        assert!(matches!(
            extract_surface(&ball, r, 1e-9, 0.0),
            Err(ExtractError::TooLarge { .. })
        ));
        assert!(matches!(
            extract_surface(&ball, r, 0.1, f64::NAN),
            Err(ExtractError::Iso(_))
        ));
    }
}
