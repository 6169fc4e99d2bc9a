//! Dual contouring on the marching-cubes loops: one vertex per loop of every cube (Nielson's
//! dual marching cubes, 2004), placed at the minimizer of the quadratic error of the
//! planes through the loop's edge crossings with the field's gradients as normals (Ju,
//! Losasso, Schaefer & Warren's dual contouring, 2002), so planes that meet at an edge or
//! a corner put the vertex on it. Each lattice edge that crosses the iso-value becomes one
//! quad over the loops of its four cubes that contain that crossing.
//!
//! **Manifold.** The quads are the dual of the marching-cubes surface of
//! [`super::table`] (face ambiguities by the asymptotic decider): every crossing lies in
//! one loop of each of its four cubes, every face segment in two loops, so the dual is
//! closed and manifold, with one exception the literature names (Schaefer, Ju & Warren,
//! *Manifold dual contouring*, 2007): where both segments of an ambiguous face belong to
//! one loop on each side, the two loops would be joined by two dual edges. There the
//! second segment (the one cutting off the face's later corner) gets a vertex of its own
//! at its midpoint, which splits the second dual edge in two; the quads on that segment's
//! crossings become pentagons fanned from it.
//!
//! **Placement.** `x = c + (AᵀA)⁺ Aᵀ(b − Ac)` with `c` the crossings' mean and `⁺` the
//! pseudo-inverse truncated at a tenth of the largest eigenvalue (so a flat loop's vertex
//! stays at its centroid, an edge's slides to the edge, a corner's goes to the corner),
//! then clamped to the cube grown by half a cell on each side (a corner or edge just past
//! the cube's face is still reached; a far-off minimizer of a nearly singular system is not).

use glam::{DVec3, IVec3};
use rustc_hash::FxHashMap as HashMap;
use volga_core::{Aabb, Field};

use super::cubes::{decisions, CENTRE_CODES};
use super::table::{self, Case, EDGE_LO, FACE_CORNERS, FACE_EDGES};
use super::{place, BlockMesh, BlockSamples, Extraction, Lattice, BLOCK};

struct Ctx<'a, F: ?Sized> {
    field: &'a F,
    lattice: &'a Lattice,
    b: &'a BlockSamples,
    job: &'a Extraction,
    inward: f64,
}

impl<F: Field + ?Sized> Ctx<'_, F> {
    #[inline]
    fn at(&self, p_local: IVec3) -> usize {
        let n = self.b.n;
        (p_local.x + n.x * (p_local.y + n.y * p_local.z)) as usize
    }
    /// Inward-signed corner values of the cube with global min corner `q`.
    fn vals(&self, q: IVec3) -> [f64; 8] {
        let l = q - self.b.lo;
        std::array::from_fn(|c| {
            let k = table::corner_bits(c);
            self.b.values[self.at(l + IVec3::new(k[0], k[1], k[2]))]
        })
    }
    /// The crossing on local edge `e` of the cube with global min corner `q`.
    fn crossing(&self, q: IVec3, e: usize, vals: &[f64; 8]) -> DVec3 {
        let (lo_c, hi_c) = (EDGE_LO[e], table::edge_hi(e));
        let (a, b) = (table::corner_bits(lo_c), table::corner_bits(hi_c));
        let pa = q + IVec3::new(a[0], a[1], a[2]);
        let pb = q + IVec3::new(b[0], b[1], b[2]);
        place(
            self.field,
            self.lattice,
            pa,
            pb,
            vals[lo_c],
            vals[hi_c],
            self.job,
            self.inward,
        )
    }
}

/// Dual contouring over one block (its cubes and lattice edges whose lower corner lies in
/// `owned_lo .. owned_lo + BLOCK`; `b` holds the samples from one point below).
pub(super) fn mesh_block<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    b: &BlockSamples,
    owned_lo: IVec3,
    job: &Extraction,
    inward: f64,
) -> BlockMesh {
    let cases = table::cases();
    let ctx = Ctx {
        field,
        lattice,
        b,
        job,
        inward,
    };
    let owned_hi = (owned_lo + BLOCK).min(lattice.points); // exclusive, in points
    let mut out = BlockMesh::default();
    let mut index: HashMap<u64, u32> = HashMap::default();
    let mut vertex = |out: &mut BlockMesh, key: u64, pos: DVec3| -> u32 {
        *index.entry(key).or_insert_with(|| {
            out.keys.push(key);
            out.positions.push(pos);
            (out.positions.len() - 1) as u32
        })
    };

    // Case of every cube of the samples (u16::MAX: no surface), computed once.
    let n = b.n;
    let cube_at = |q_local: IVec3| (q_local.x + n.x * (q_local.y + n.y * q_local.z)) as usize;
    let mut case_of = vec![u16::MAX; b.values.len()];
    for z in 0..n.z - 1 {
        for y in 0..n.y - 1 {
            for x in 0..n.x - 1 {
                let q = IVec3::new(x, y, z) + b.lo;
                let vals = ctx.vals(q);
                let mask = (0..8).fold(0u8, |m, c| m | ((vals[c] >= 0.0) as u8) << c);
                if mask != 0 && mask != 0xff {
                    case_of[cube_at(q - b.lo)] = (mask as usize * 64 + decisions(mask, &vals) as usize) as u16;
                }
            }
        }
    }

    // Vertices of the owned cubes: one per loop, at its QEF minimizer. The crossings of
    // all owned cubes first (each lattice edge once), their gradients in one batch.
    let mut slot = vec![u32::MAX; b.values.len() * 3];
    let mut points = Vec::new();
    let mut loops: Vec<(IVec3, usize)> = Vec::new();
    let owned_cells = |f: &mut dyn FnMut(IVec3)| {
        for z in owned_lo.z..owned_hi.z.min(lattice.points.z - 1) {
            for y in owned_lo.y..owned_hi.y.min(lattice.points.y - 1) {
                for x in owned_lo.x..owned_hi.x.min(lattice.points.x - 1) {
                    f(IVec3::new(x, y, z));
                }
            }
        }
    };
    owned_cells(&mut |q: IVec3| {
        let id = case_of[cube_at(q - b.lo)];
        if id == u16::MAX {
            return;
        }
        let case = &cases[id as usize];
        let vals = ctx.vals(q);
        for &e in &case.edges {
            let e = e as usize;
            let k = table::corner_bits(EDGE_LO[e]);
            let s = ctx.at(q - b.lo + IVec3::new(k[0], k[1], k[2])) * 3 + table::edge_axis(e);
            if slot[s] == u32::MAX {
                slot[s] = points.len() as u32;
                points.push(ctx.crossing(q, e, &vals));
            }
        }
        loops.push((q, id as usize));
    });
    let mut grads = vec![DVec3::ZERO; points.len()];
    field.gradients_at(&points, &mut grads);
    // Output vertex of each cube's loop (cubes of the samples, four loops at most).
    let mut cell_vertex = vec![u32::MAX; b.values.len() * 4];
    let mut loop_points = Vec::new();
    let mut loop_grads = Vec::new();
    for &(q, id) in &loops {
        let case = &cases[id];
        let cell = Aabb::new(lattice.world(q), lattice.world(q + 1));
        for (l, code) in CENTRE_CODES.iter().enumerate().take(case.loops()) {
            loop_points.clear();
            loop_grads.clear();
            for &e in case.loop_edges(l) {
                let e = e as usize;
                let k = table::corner_bits(EDGE_LO[e]);
                let s = slot[ctx.at(q - b.lo + IVec3::new(k[0], k[1], k[2])) * 3 + table::edge_axis(e)] as usize;
                loop_points.push(points[s]);
                loop_grads.push(grads[s]);
            }
            let x = qef_vertex(&loop_points, &loop_grads, &cell);
            cell_vertex[cube_at(q - b.lo) * 4 + l] = vertex(&mut out, lattice.linear(q) * 8 + code, x);
        }
    }

    // One quad (or pentagon) per owned lattice edge that crosses.
    let mut ring = Vec::with_capacity(8);
    for z in owned_lo.z..owned_hi.z {
        for y in owned_lo.y..owned_hi.y {
            for x in owned_lo.x..owned_hi.x {
                let p = IVec3::new(x, y, z);
                let sp = b.values[ctx.at(p - b.lo)];
                for axis in 0..3 {
                    let ea = IVec3::AXES[axis];
                    if p[axis] + 1 >= lattice.points[axis] {
                        continue;
                    }
                    let sq = b.values[ctx.at(p + ea - b.lo)];
                    if (sp >= 0.0) == (sq >= 0.0) {
                        continue;
                    }
                    let (bx, cx) = ((axis + 1) % 3, (axis + 2) % 3);
                    let (eb, ec) = (IVec3::AXES[bx], IVec3::AXES[cx]);
                    let deltas = [(0, 0), (1, 0), (1, 1), (0, 1)];
                    let cells = deltas.map(|(db, dc)| p - eb * db - ec * dc);
                    if cells
                        .iter()
                        .any(|c| c.cmplt(IVec3::ZERO).any() || c.cmpge(lattice.points - 1).any())
                    {
                        continue; // the surface leaves the lattice here
                    }
                    let case_ids = cells.map(|c| case_of[cube_at(c - b.lo)] as usize);
                    ring.clear();
                    for i in 0..4 {
                        let (db, dc) = deltas[i];
                        let e = axis * 4 + db as usize + 2 * dc as usize;
                        let case = &cases[case_ids[i]];
                        let l = case.edge_loop[e] as usize;
                        debug_assert!(l < 4, "crossing without a loop");
                        let at = cube_at(cells[i] - b.lo) * 4 + l;
                        if cell_vertex[at] == u32::MAX {
                            // Another block's cube: its owner places the vertex.
                            let key = lattice.linear(cells[i]) * 8 + CENTRE_CODES[l];
                            cell_vertex[at] = vertex(&mut out, key, DVec3::NAN);
                        }
                        ring.push(cell_vertex[at]);
                        let j = (i + 1) % 4;
                        if let Some((key, pos)) =
                            split(&ctx, cases, p, axis, (cells[i], case_ids[i]), (cells[j], case_ids[j]))
                        {
                            ring.push(vertex(&mut out, key, pos));
                        }
                    }
                    if sp < 0.0 {
                        ring.reverse();
                    }
                    emit(&mut out, &ring);
                }
            }
        }
    }
    out
}

/// Triangles of one dual polygon (counter-clockwise seen from outside): a quad split along
/// a fixed diagonal (its two cubes share only this lattice edge, so the diagonal is drawn
/// once), or, when it carries split vertices, a fan from the first of them (a split vertex
/// lies in exactly two polygons, where it is the root, so its diagonals are drawn once).
fn emit(out: &mut BlockMesh, ring: &[u32]) {
    let k = ring.len();
    let r = (0..k).find(|&i| is_split(out.keys[ring[i] as usize])).unwrap_or(0);
    for d in 1..k - 1 {
        out.triangles.push([ring[r], ring[(r + d) % k], ring[(r + d + 1) % k]]);
    }
}

/// Whether a vertex key is a face split vertex (codes `1 << axis`).
#[inline]
fn is_split(key: u64) -> bool {
    matches!(key & 7, 1 | 2 | 4)
}

/// The split vertex on the face between two ring cubes `(q, case)` for the crossing on
/// lattice edge `(p, axis)`, if that face is doubly linked and the crossing lies on its
/// second segment.
fn split<F: Field + ?Sized>(
    ctx: &Ctx<'_, F>,
    cases: &[Case],
    p: IVec3,
    axis: usize,
    a: (IVec3, usize),
    b: (IVec3, usize),
) -> Option<(u64, DVec3)> {
    let diff = b.0 - a.0;
    let f_ax = (0..3).find(|&k| diff[k] != 0)?;
    let (lower, upper) = if diff[f_ax] > 0 { (a, b) } else { (b, a) };
    let (fl, fu) = (f_ax * 2 + 1, f_ax * 2);
    let (cl, cu) = (&cases[lower.1], &cases[upper.1]);
    if cl.doubled_faces >> fl & 1 == 0 || cu.doubled_faces >> fu & 1 == 0 {
        return None;
    }
    // The upper cube's face on side 0: its cut-off corners are those on the cut side.
    let mask = (upper.1 / 64) as u8;
    let dec = (upper.1 % 64) as u8;
    let joined_inside = dec >> fu & 1 == 1;
    let corners = FACE_CORNERS[fu];
    let i2 = (0..4).rev().find(|&i| (mask >> corners[i] & 1 == 1) != joined_inside)?;
    let seg = [FACE_EDGES[fu][(i2 + 3) % 4], FACE_EDGES[fu][i2]];
    // Our crossing as a local edge of the upper cube.
    let d = p - upper.0;
    let (bx, cx) = ((axis + 1) % 3, (axis + 2) % 3);
    let e = axis * 4 + d[bx] as usize + 2 * d[cx] as usize;
    if !seg.contains(&e) {
        return None;
    }
    let vals = ctx.vals(upper.0);
    let mid = 0.5 * (ctx.crossing(upper.0, seg[0], &vals) + ctx.crossing(upper.0, seg[1], &vals));
    Some((ctx.lattice.linear(upper.0) * 8 + (1u64 << f_ax), mid))
}

/// The point minimizing the squared distances to the planes through `points` with normals
/// `grads`, solved about their mean `c` with the pseudo-inverse of `AᵀA` (eigenvalues
/// below a tenth of the largest dropped: Lindstrom's and Ju et al.'s truncation, so
/// directions the planes do not fix stay at `c`), clamped to `cell` grown by [`CLAMP_MARGIN`].
fn qef_vertex(points: &[DVec3], grads: &[DVec3], cell: &Aabb) -> DVec3 {
    let c = points.iter().sum::<DVec3>() / points.len() as f64;
    let mut ata = [[0.0f64; 3]; 3];
    let mut atb = DVec3::ZERO;
    for (p, g) in points.iter().zip(grads) {
        let n = g.normalize_or_zero();
        if n == DVec3::ZERO {
            continue;
        }
        for (i, row) in ata.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v += n[i] * n[j];
            }
        }
        atb += n * n.dot(*p - c);
    }
    let (values, vectors) = symmetric_eigen(ata);
    let top = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut x = c;
    for k in 0..3 {
        if top > 0.0 && values[k] > TRUNCATION * top {
            x += vectors[k] * (vectors[k].dot(atb) / values[k]);
        }
    }
    if !x.is_finite() {
        return c;
    }
    let margin = CLAMP_MARGIN * (cell.max - cell.min);
    x.clamp(cell.min - margin, cell.max + margin)
}

/// How far (in cells) a vertex may leave its cube toward a feature in a neighbouring one.
const CLAMP_MARGIN: f64 = 0.5;

/// Eigenvalues below this fraction of the largest are treated as zero.
const TRUNCATION: f64 = 0.1;

/// Eigenvalues and unit eigenvectors of a symmetric 3×3 matrix (cyclic Jacobi rotations).
fn symmetric_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [DVec3; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..12 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if off <= 1e-30 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let (cs, sn) = (1.0 / (t * t + 1.0).sqrt(), 0.0);
            let sn = sn + t * cs;
            // A ← Jᵀ A J on rows/columns p, q.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = cs * akp - sn * akq;
                row[q] = sn * akp + cs * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = cs * row_p[k] - sn * row_q[k];
                a[q][k] = sn * row_p[k] + cs * row_q[k];
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = cs * vp - sn * vq;
                row[q] = sn * vp + cs * vq;
            }
        }
    }
    let vectors = [0, 1, 2].map(|k| DVec3::new(v[0][k], v[1][k], v[2][k]));
    ([a[0][0], a[1][1], a[2][2]], vectors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_decomposition_reconstructs_the_matrix() {
        let m = [[2.0, 0.5, -0.3], [0.5, 1.0, 0.2], [-0.3, 0.2, 0.1]];
        let (vals, vecs) = symmetric_eigen(m);
        for i in 0..3 {
            for j in 0..3 {
                let r: f64 = (0..3).map(|k| vals[k] * vecs[k][i] * vecs[k][j]).sum();
                assert!((r - m[i][j]).abs() < 1e-12, "{i}{j}: {r} vs {}", m[i][j]);
            }
        }
    }

    #[test]
    fn planes_meeting_at_a_corner_put_the_vertex_on_it() {
        let corner = DVec3::new(0.3, 0.7, 0.4);
        let pts = [
            corner + DVec3::new(0.0, -0.2, 0.1),
            corner + DVec3::new(-0.25, 0.0, 0.2),
            corner + DVec3::new(0.1, -0.3, 0.0),
            corner + DVec3::new(0.0, 0.1, -0.3),
        ];
        let grads = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::X];
        let x = qef_vertex(&pts, &grads, &Aabb::new(DVec3::ZERO, DVec3::ONE));
        assert!(x.distance(corner) < 1e-12, "{x}");
        // Two planes: the vertex lies on their line, at the mean's position along it.
        let x = qef_vertex(&pts[..2], &grads[..2], &Aabb::new(DVec3::ZERO, DVec3::ONE));
        assert!((x.x - corner.x).abs() < 1e-12 && (x.y - corner.y).abs() < 1e-12, "{x}");
    }
}
