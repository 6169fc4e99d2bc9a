//! Marching tetrahedra: each lattice cube split into the six Kuhn (Freudenthal) tetrahedra
//! around its main diagonal, the same split in every cube (Doi & Koide 1991), so
//! neighbouring cubes agree on their shared faces and no configuration is ambiguous.

use glam::{DVec3, IVec3};
use volga_core::Field;

use super::{corner, edge_fraction, on_block_face, place, BlockMesh, BlockSamples, Extraction, Lattice, PRIVATE};

/// The six Kuhn tetrahedra of a cube (corner `c` at `(c & 1, c >> 1 & 1, c >> 2 & 1)`):
/// chains `0 → e_a → e_a + e_b → 7` over the permutations of the axes.
pub(super) const TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// Marching tetrahedra over one block's samples.
pub(super) fn mesh_block<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    b_samples: &BlockSamples,
    job: &Extraction,
    inward: f64,
) -> BlockMesh {
    let (lo, n, s) = (b_samples.lo, b_samples.n, &b_samples.values);
    let at = |p: IVec3| (p.x + n.x * (p.y + n.y * p.z)) as usize;
    let mut out = BlockMesh::default();
    // Local vertex of (lattice point, direction bits 1..7), u32::MAX if none yet.
    let mut local = vec![u32::MAX; s.len() * 8];
    for z in 0..n.z - 1 {
        for y in 0..n.y - 1 {
            for x in 0..n.x - 1 {
                let base = IVec3::new(x, y, z);
                let vals: [f64; 8] = std::array::from_fn(|c| s[at(base + corner(c))]);
                let inside_mask = (0..8).fold(0u8, |m, c| m | ((vals[c] >= 0.0) as u8) << c);
                if inside_mask == 0 || inside_mask == 0xff {
                    continue;
                }
                for tet in TETRAHEDRA {
                    let mut edge_vertex = |a: usize, b: usize| -> u32 {
                        // Edge from the lower corner to the upper one (chains are ordered).
                        let (a, b) = if a < b { (a, b) } else { (b, a) };
                        let pa = base + corner(a);
                        let slot = at(pa) * 8 + (a ^ b);
                        if local[slot] == u32::MAX {
                            local[slot] = out.positions.len() as u32;
                            let pb = base + corner(b);
                            // Only an edge on the block's faces can be another block's too.
                            out.keys.push(if on_block_face(n, pa, pb) {
                                lattice.linear(lo + pa) * 8 + (a ^ b) as u64
                            } else {
                                PRIVATE
                            });
                            let p = place(field, lattice, lo + pa, lo + pb, vals[a], vals[b], job, inward);
                            out.positions.push(p);
                            if let Some(g) = b_samples.gradient(pa, edge_fraction(lattice, lo + pa, lo + pb, p)) {
                                out.gradients.push((local[slot], g));
                            }
                        }
                        local[slot]
                    };
                    emit_tetrahedron(tet, &vals, &mut edge_vertex, &mut out.triangles);
                }
            }
        }
    }
    out
}

/// Triangles of one tetrahedron, oriented counter-clockwise seen from outside.
pub(super) fn emit_tetrahedron(
    tet: [usize; 4],
    vals: &[f64; 8],
    edge_vertex: &mut impl FnMut(usize, usize) -> u32,
    triangles: &mut Vec<[u32; 3]>,
) {
    let (mut inside, mut outside) = ([0usize; 4], [0usize; 4]);
    let (mut n_in, mut n_out) = (0, 0);
    for c in tet {
        if vals[c] >= 0.0 {
            inside[n_in] = c;
            n_in += 1;
        } else {
            outside[n_out] = c;
            n_out += 1;
        }
    }
    if n_in == 0 || n_out == 0 {
        return;
    }
    let (inside, outside) = (&inside[..n_in], &outside[..n_out]);
    // From inside to outside: the direction every triangle's normal must take (from the
    // corners' small integer positions, so its dot with a normal is never near zero).
    let centroid = |cs: &[usize]| cs.iter().map(|&c| corner(c).as_dvec3()).sum::<DVec3>() / cs.len() as f64;
    let out_dir = centroid(outside) - centroid(inside);
    let mut push = |edges: [(usize, usize); 3]| {
        let mid = edges.map(|(a, b)| (corner(a) + corner(b)).as_dvec3());
        let normal = (mid[1] - mid[0]).cross(mid[2] - mid[0]);
        let mut tri = edges.map(|(a, b)| edge_vertex(a, b));
        if normal.dot(out_dir) < 0.0 {
            tri.swap(1, 2);
        }
        triangles.push(tri);
    };
    match (inside.len(), outside.len()) {
        (1, 3) => {
            let a = inside[0];
            push([(a, outside[0]), (a, outside[1]), (a, outside[2])]);
        }
        (3, 1) => {
            let o = outside[0];
            push([(inside[0], o), (inside[1], o), (inside[2], o)]);
        }
        (2, 2) => {
            let ([a, b], [c, d]) = ([inside[0], inside[1]], [outside[0], outside[1]]);
            // The quad ac–ad–bd–bc, split along ac–bd (inside this tetrahedron only).
            push([(a, c), (a, d), (b, d)]);
            push([(a, c), (b, d), (b, c)]);
        }
        _ => {}
    }
}
