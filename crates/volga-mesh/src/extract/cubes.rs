//! Marching cubes with topology-correct cases: the face ambiguities resolved by the
//! asymptotic decider ([`super::table`]) and the interior ambiguities by the trilinear
//! interpolant's cross-sections (the survey's §3; the tunnel test of Chernyaev's
//! marching cubes 33 and Lopes & Brodlie, here derived rather than tabulated).
//!
//! **Interior test.** Two loops of a cube bound one piece of surface, a tube, exactly when
//! the trilinear interpolant joins through the cube's interior both the regions of the
//! cube's boundary on their inside and those on their outside. Two diagonal corners of a
//! cross-section perpendicular to an axis, at height `t`, are joined when the section is
//! ambiguous and its bilinear saddle lies on their side: with the section's corner values
//! `A(t)…D(t)` linear in `t`, the saddle's sign is that of the quadratic `P₁P₂ − N₁N₂`,
//! whose extremes over each interval of constant sign pattern are checked exactly (at the
//! interval's ends and at its vertex). Every such join found on the three axes is merged
//! into the components the cube's surface already has; two loops whose inside and outside
//! components both meet become one tube, zipped between them. Anything less clear-cut
//! (three or more loops joined) keeps one disc per loop, which is still closed and manifold.
//!
//! **No edge drawn twice.** Two cubes share only the crossings of their common face, so a
//! mesh edge between two crossings of one face could be drawn by both cubes. Fans are
//! rooted, and tubes zipped, so that every edge inside a cube joins crossings of different
//! faces (or a centre vertex of its own): with the shared segments, every edge of the mesh
//! then lies in exactly two triangles.

use glam::{DVec3, IVec3};
use volga_core::Field;

use super::table::{self, Case, CENTRE, EDGE_LO, SHARE_FACE};
use super::{corner, edge_fraction, on_block_face, place, BlockMesh, BlockSamples, Extraction, Lattice, PRIVATE};

/// Vertex key codes of a cube's loop centres (`linear(cell)·8 + code`); lattice edges use
/// `1 << axis`.
pub(super) const CENTRE_CODES: [u64; 4] = [0, 3, 5, 6];

/// The sign of the asymptotic decider on every ambiguous face of a cube with inside mask
/// `mask` and inward-signed corner values `vals` (inside `≥ 0`): bit `f` set when face `f`'s
/// inside corners are joined across it (saddle `≥ 0`, i.e. `P₁P₂ ≥ N₁N₂`).
#[inline]
pub(super) fn decisions(mask: u8, vals: &[f64; 8]) -> u8 {
    let amb = AMBIGUOUS[mask as usize];
    if amb == 0 {
        return 0;
    }
    let mut dec = 0;
    for f in 0..6 {
        if amb >> f & 1 == 0 {
            continue;
        }
        let c = table::FACE_CORNERS[f];
        let (p, n) = if vals[c[0]] >= 0.0 {
            (vals[c[0]] * vals[c[2]], vals[c[1]] * vals[c[3]])
        } else {
            (vals[c[1]] * vals[c[3]], vals[c[0]] * vals[c[2]])
        };
        if p >= n {
            dec |= 1 << f;
        }
    }
    dec
}

/// [`table::ambiguous_faces`] for every mask.
static AMBIGUOUS: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut m = 0;
    while m < 256 {
        let mut f = 0;
        while f < 6 {
            let c = table::FACE_CORNERS[f];
            let s = [m >> c[0] & 1, m >> c[1] & 1, m >> c[2] & 1, m >> c[3] & 1];
            if s[0] == s[2] && s[1] == s[3] && s[0] != s[1] {
                t[m] |= 1 << f;
            }
            f += 1;
        }
        m += 1;
    }
    t
};

fn find(root: &mut [u8; 8], c: usize) -> usize {
    let mut c = c;
    while root[c] as usize != c {
        c = root[c] as usize;
    }
    c
}

fn union(root: &mut [u8; 8], a: usize, b: usize) {
    let (ra, rb) = (find(root, a), find(root, b));
    if ra != rb {
        root[ra.max(rb)] = ra.min(rb) as u8;
    }
}

/// The two loops of `case` that the interior joins into one tube, if exactly one such pair
/// exists (see the module documentation).
pub(super) fn tunnel(case: &Case, vals: &[f64; 8]) -> Option<(usize, usize)> {
    if case.loops() < 2 {
        return None;
    }
    let mut root = case.surface_root;
    for axis in 0..3 {
        // The section's corners, in cyclic order, are the four edges along `axis`.
        let es = [axis * 4, axis * 4 + 1, axis * 4 + 3, axis * 4 + 2];
        let lo = es.map(|e| vals[EDGE_LO[e]]);
        let hi = es.map(|e| vals[table::edge_hi(e)]);
        let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], hi[3] - lo[3]];
        let mut ts = [0.0f64; 6];
        let mut nt = 1;
        for i in 0..4 {
            if (lo[i] >= 0.0) != (hi[i] >= 0.0) {
                ts[nt] = lo[i] / (lo[i] - hi[i]);
                nt += 1;
            }
        }
        ts[nt] = 1.0;
        nt += 1;
        ts[..nt].sort_by(f64::total_cmp);
        let v = |i: usize, t: f64| lo[i] + t * d[i];
        for w in ts[..nt].windows(2) {
            let (t0, t1) = (w[0], w[1]);
            if t1 <= t0 {
                continue;
            }
            let tm = 0.5 * (t0 + t1);
            let sg = [0, 1, 2, 3].map(|i| v(i, tm) >= 0.0);
            if !(sg[0] == sg[2] && sg[1] == sg[3] && sg[0] != sg[1]) {
                continue;
            }
            let (p, q) = if sg[0] { ((0, 2), (1, 3)) } else { ((1, 3), (0, 2)) };
            // g(t) = v_p0·v_p1 − v_q0·v_q1 = a2 t² + a1 t + a0.
            let a2 = d[p.0] * d[p.1] - d[q.0] * d[q.1];
            let a1 = lo[p.0] * d[p.1] + lo[p.1] * d[p.0] - lo[q.0] * d[q.1] - lo[q.1] * d[q.0];
            let a0 = lo[p.0] * lo[p.1] - lo[q.0] * lo[q.1];
            let g = |t: f64| (a2 * t + a1) * t + a0;
            let (mut gmax, mut gmin) = (g(t0).max(g(t1)), g(t0).min(g(t1)));
            if a2 != 0.0 {
                let tv = -a1 / (2.0 * a2);
                if tv > t0 && tv < t1 {
                    gmax = gmax.max(g(tv));
                    gmin = gmin.min(g(tv));
                }
            }
            let end = |i: usize, want_inside: bool| {
                let e = es[i];
                if (lo[i] >= 0.0) == want_inside {
                    EDGE_LO[e]
                } else {
                    table::edge_hi(e)
                }
            };
            if gmax > 0.0 {
                union(&mut root, end(p.0, true), end(p.1, true));
            }
            if gmin < 0.0 {
                union(&mut root, end(q.0, false), end(q.1, false));
            }
        }
    }
    let keys: Vec<(usize, usize)> = case
        .sides
        .iter()
        .map(|&(i, o)| (find(&mut root, i as usize), find(&mut root, o as usize)))
        .collect();
    let mut pair = None;
    for a in 0..keys.len() {
        for b in a + 1..keys.len() {
            if keys[a] == keys[b] {
                if pair.is_some() {
                    return None;
                }
                pair = Some((a, b));
            }
        }
    }
    pair
}

/// First id of a tube's middle ring in [`zip`] and [`tube`].
const MIDDLE: u8 = 16;

/// The tube between loops `a` and `b` (edge ids, each counter-clockwise seen from outside):
/// one zip if one avoids joining crossings of a face, otherwise two zips through a middle
/// ring of new vertices (`MIDDLE + i`, halfway from `a`'s vertices to the nearest of `b`'s,
/// returned as the second item).
fn tube(a: &[u8], b: &[u8], pos: &dyn Fn(u8) -> DVec3) -> Option<(Vec<[u8; 3]>, Vec<DVec3>)> {
    if let Some(t) = zip(a, b, pos) {
        return Some((t, Vec::new()));
    }
    let ring: Vec<DVec3> = a
        .iter()
        .map(|&e| {
            let p = pos(e);
            let q = b
                .iter()
                .map(|&f| pos(f))
                .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)));
            0.5 * (p + q.unwrap_or(p))
        })
        .collect();
    let both = |id: u8| {
        if id >= MIDDLE {
            ring[(id - MIDDLE) as usize]
        } else {
            pos(id)
        }
    };
    let m: Vec<u8> = (0..a.len() as u8).map(|i| MIDDLE + i).collect();
    let m_rev: Vec<u8> = m.iter().rev().copied().collect();
    // The ring is used once in each direction: as `b` of the first zip, as `a` of the second.
    let mut tris = zip(a, &m_rev, &both)?;
    tris.extend(zip(&m, b, &both)?);
    Some((tris, ring))
}

/// Triangles of the tube between loops `a` and `b` (edge ids, each loop counter-clockwise
/// seen from outside): the zip of least total rung length whose rungs never join two
/// crossings of one face, or `None` if no zip avoids that.
pub(super) fn zip(a: &[u8], b: &[u8], pos: &dyn Fn(u8) -> DVec3) -> Option<Vec<[u8; 3]>> {
    let c: Vec<u8> = b.iter().rev().copied().collect();
    let (k1, k2) = (a.len(), c.len());
    debug_assert!(k1 >= 3 && k2 >= 3);
    let rung = |s1: usize, s2: usize, i: usize, m: usize| (a[(s1 + i) % k1], c[(s2 + m) % k2]);
    // Crossings (ids below 12) of one face must not be joined; a middle ring's vertices
    // (`MIDDLE + i`) belong to this cube alone.
    let allowed = |r: (u8, u8)| r.0 >= MIDDLE || r.1 >= MIDDLE || !SHARE_FACE[r.0 as usize][r.1 as usize];
    let mut best: Option<(f64, Vec<[u8; 3]>)> = None;
    let w = k2 + 1;
    let mut cost = vec![f64::INFINITY; (k1 + 1) * w];
    let mut from = vec![0u8; (k1 + 1) * w];
    for s1 in 0..k1 {
        for s2 in 0..k2 {
            if !allowed(rung(s1, s2, 0, 0)) {
                continue;
            }
            cost.fill(f64::INFINITY);
            for i in 0..=k1 {
                for m in 0..=k2 {
                    let r = rung(s1, s2, i, m);
                    // The path starts by advancing on `c` and ends by advancing on `a`
                    // (every zip has such a rung to start from), so it never comes back
                    // to a rung of the start row or column: no rung is drawn twice.
                    if !allowed(r) || (i > 0 && m == 0) || (i == k1 && m < k2) || (i == 0 && m == k2) {
                        continue;
                    }
                    let len = pos(r.0).distance(pos(r.1));
                    if i == 0 && m == 0 {
                        cost[0] = len;
                        continue;
                    }
                    let (ci, cm) = (
                        if i > 0 { cost[(i - 1) * w + m] } else { f64::INFINITY },
                        if m > 0 { cost[i * w + m - 1] } else { f64::INFINITY },
                    );
                    let (c, f) = if ci <= cm { (ci, 1) } else { (cm, 2) };
                    cost[i * w + m] = c + len;
                    from[i * w + m] = f;
                }
            }
            let total = cost[k1 * w + k2];
            if !total.is_finite() || best.as_ref().is_some_and(|(b, _)| *b <= total) {
                continue;
            }
            let (mut i, mut m) = (k1, k2);
            let mut tris = Vec::with_capacity(k1 + k2);
            while i > 0 || m > 0 {
                if from[i * w + m] == 1 {
                    // (i−1, m) → (i, m): triangle a_{i−1} a_i c_m.
                    tris.push([rung(s1, s2, i - 1, m).0, rung(s1, s2, i, m).0, rung(s1, s2, i, m).1]);
                    i -= 1;
                } else {
                    // (i, m−1) → (i, m): triangle c_m c_{m−1} a_i.
                    tris.push([rung(s1, s2, i, m).1, rung(s1, s2, i, m - 1).1, rung(s1, s2, i, m).0]);
                    m -= 1;
                }
            }
            tris.reverse();
            best = Some((total, tris));
        }
    }
    best.map(|(_, t)| t)
}

/// Marching cubes over one block's samples (lattice points `b.lo ..= b.lo + b.n − 1`).
pub(super) fn mesh_block<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    b: &BlockSamples,
    job: &Extraction,
    inward: f64,
) -> BlockMesh {
    let cases = table::cases();
    let n = b.n;
    let s = &b.values;
    let at = |p: IVec3| (p.x + n.x * (p.y + n.y * p.z)) as usize;
    let mut out = BlockMesh::default();
    let mut local = vec![u32::MAX; s.len() * 3];
    let offsets: [usize; 8] = std::array::from_fn(|c| at(corner(c)));
    let mut ids = [0u32; CUBE_IDS];
    // Per row of points along x: 1 all outside, 2 all inside, 3 both; a row of cubes
    // between four rows all outside or all inside is skipped whole.
    let sides: Vec<u8> = s
        .chunks_exact(n.x as usize)
        .map(|r| r.iter().fold(0u8, |m, &v| m | if v >= 0.0 { 2 } else { 1 }))
        .collect();
    for z in 0..n.z - 1 {
        for y in 0..n.y - 1 {
            let r = (y + n.y * z) as usize;
            let (r_y, r_z) = (r + 1, r + n.y as usize);
            let rows = sides[r] | sides[r_y] | sides[r_z] | sides[r_z + 1];
            if rows != 3 {
                continue;
            }
            let row = at(IVec3::new(0, y, z));
            for x in 0..n.x - 1 {
                let i0 = row + x as usize;
                let vals: [f64; 8] = std::array::from_fn(|c| s[i0 + offsets[c]]);
                let mask = (0..8).fold(0u8, |m, c| m | ((vals[c] >= 0.0) as u8) << c);
                if mask == 0 || mask == 0xff {
                    continue;
                }
                let case = &cases[mask as usize * 64 + decisions(mask, &vals) as usize];
                let base = IVec3::new(x, y, z);
                for &e in &case.edges {
                    let e = e as usize;
                    let axis = table::edge_axis(e);
                    let lo_c = EDGE_LO[e];
                    let slot = (i0 + offsets[lo_c]) * 3 + axis;
                    if local[slot] == u32::MAX {
                        local[slot] = out.positions.len() as u32;
                        let pa = b.lo + base + corner(lo_c);
                        let hi_c = table::edge_hi(e);
                        let pb = b.lo + base + corner(hi_c);
                        // Only an edge on the block's faces can be another block's too.
                        out.keys.push(if on_block_face(n, pa - b.lo, pb - b.lo) {
                            lattice.linear(pa) * 8 + (1u64 << axis)
                        } else {
                            PRIVATE
                        });
                        let p = place(field, lattice, pa, pb, vals[lo_c], vals[hi_c], job, inward);
                        out.positions.push(p);
                        if let Some(g) = b.gradient(pa - b.lo, edge_fraction(lattice, pa, pb, p)) {
                            out.gradients.push((local[slot], g));
                        }
                    }
                    ids[e] = local[slot];
                }
                let cell_key = lattice.linear(b.lo + base) * 8;
                emit_cube(case, &vals, &mut ids, &mut out, |l| cell_key + CENTRE_CODES[l]);
            }
        }
    }
    out
}

/// Slots of a cube's vertex ids: the 12 edge crossings, the loops' centres
/// ([`CENTRE`]` + l`) and a tube's middle ring (`MIDDLE + i`).
pub(super) const CUBE_IDS: usize = MIDDLE as usize + 12;

/// The triangles of one cube of case `case` (corner values `vals`, inward-signed), with
/// the crossings of `case.edges` already in `ids` (indices into `out.positions`): decides
/// the interior (a tube or one disc per loop), adds the loops' centre vertices (keyed
/// `centre_key(l)`) and a tube's middle ring (never merged), and appends the triangles.
#[inline]
pub(super) fn emit_cube(
    case: &Case,
    vals: &[f64; 8],
    ids: &mut [u32; CUBE_IDS],
    out: &mut BlockMesh,
    centre_key: impl Fn(usize) -> u64,
) {
    let tube = tunnel(case, vals).and_then(|(la, lb)| {
        let pos = |e: u8| out.positions[ids[e as usize] as usize];
        tube(case.loop_edges(la), case.loop_edges(lb), &pos).map(|(t, ring)| (la, lb, t, ring))
    });
    if let Some((_, _, _, ring)) = &tube {
        for (i, p) in ring.iter().enumerate() {
            ids[(MIDDLE as usize) + i] = out.positions.len() as u32;
            out.keys.push(PRIVATE);
            out.positions.push(*p);
        }
    }
    for l in 0..case.loops() {
        if case.centred[l] && !tube.as_ref().is_some_and(|t| t.0 == l || t.1 == l) {
            let edges = case.loop_edges(l);
            let centre = edges
                .iter()
                .map(|&e| out.positions[ids[e as usize] as usize])
                .sum::<DVec3>()
                / edges.len() as f64;
            ids[CENTRE as usize + l] = out.positions.len() as u32;
            out.keys.push(centre_key(l));
            out.positions.push(centre);
        }
    }
    match &tube {
        None => out
            .triangles
            .extend(case.triangles.iter().map(|t| t.map(|c| ids[c as usize]))),
        Some((la, lb, tris, _)) => {
            // Fans of the other loops, then the tube.
            let mut k = 0;
            for l in 0..case.loops() {
                let count = fan_len(case, l);
                if l != *la && l != *lb {
                    out.triangles
                        .extend(case.triangles[k..k + count].iter().map(|t| t.map(|c| ids[c as usize])));
                }
                k += count;
            }
            out.triangles.extend(tris.iter().map(|t| t.map(|c| ids[c as usize])));
            out.tubes += 1;
        }
    }
}

/// Triangles in loop `l`'s fan.
#[inline]
fn fan_len(case: &Case, l: usize) -> usize {
    let k = case.loop_edges(l).len();
    if case.centred[l] {
        k
    } else {
        k - 2
    }
}
