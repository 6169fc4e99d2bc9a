//! The cube case table shared by marching cubes ([`super::cubes`]) and dual marching cubes
//! ([`super::dual`]): for each of the 256 sign patterns of a cube's corners and each choice
//! on its ambiguous faces, the closed loops the iso-surface draws on the cube's faces.
//!
//! The table is not typed in: it is derived once from the rule that defines it. On each
//! face, the surface crosses the face's edges whose end points differ in sign; two
//! crossings make one segment, four (an *ambiguous* face: the signs alternate around it)
//! make two, and which corners the two segments cut off is the face's **asymptotic
//! decider** (Nielson & Hamann 1991, the survey's §3 [239]): the bilinear interpolant's
//! saddle value `(P₁P₂ − N₁N₂)/(P₁ + P₂ − N₁ − N₂)` decides whether the two inside corners
//! (values `P₁, P₂ ≥ 0`) are joined across the face (saddle `≥ 0`, i.e. `P₁P₂ ≥ N₁N₂`) or
//! the two outside ones are. Both cubes of a face evaluate that test on the same four
//! values, so they draw the same segments and the surface has no holes. Segments are
//! directed with the inside on their right seen from outside the cube; every crossing then
//! has one incoming and one outgoing segment, and following them gives the loops, each
//! oriented counter-clockwise seen from outside the surface.

use std::sync::OnceLock;

/// Corner `c` of a cube: `(c & 1, c >> 1 & 1, c >> 2 & 1)`.
#[inline]
pub(crate) const fn corner_bits(c: usize) -> [i32; 3] {
    [(c & 1) as i32, (c >> 1 & 1) as i32, (c >> 2 & 1) as i32]
}

/// Edge `e = axis·4 + k` runs along `axis` from corner `EDGE_LO[e]` to `EDGE_LO[e] | 1 << axis`;
/// `k = bit_b + 2·bit_c` for the other two axes `b = axis + 1`, `c = axis + 2` (mod 3).
pub(crate) const EDGE_LO: [usize; 12] = {
    let mut t = [0usize; 12];
    let mut e = 0;
    while e < 12 {
        let (a, k) = (e / 4, e % 4);
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        t[e] = ((k & 1) << b) | ((k >> 1) << c);
        e += 1;
    }
    t
};

/// The axis of edge `e`.
#[inline]
pub(crate) const fn edge_axis(e: usize) -> usize {
    e / 4
}

/// The upper corner of edge `e`.
#[inline]
pub(crate) const fn edge_hi(e: usize) -> usize {
    EDGE_LO[e] | 1 << edge_axis(e)
}

/// The edge between two corners that differ in one bit.
const fn edge_between(c0: usize, c1: usize) -> usize {
    let (lo, hi) = if c0 < c1 { (c0, c1) } else { (c1, c0) };
    let diff = lo ^ hi;
    let a = if diff == 1 {
        0
    } else if diff == 2 {
        1
    } else {
        2
    };
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    a * 4 + ((lo >> b) & 1) + 2 * ((lo >> c) & 1)
}

/// Face `f = axis·2 + side`: its corners in cyclic order `(b, c) = (0,0), (1,0), (1,1), (0,1)`
/// for the other two axes `b = axis + 1`, `c = axis + 2` (mod 3).
pub(crate) const FACE_CORNERS: [[usize; 4]; 6] = {
    let mut t = [[0usize; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let (a, s) = (f / 2, f % 2);
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let cyc = [(0, 0), (1, 0), (1, 1), (0, 1)];
        let mut i = 0;
        while i < 4 {
            t[f][i] = (s << a) | (cyc[i].0 << b) | (cyc[i].1 << c);
            i += 1;
        }
        f += 1;
    }
    t
};

/// `FACE_EDGES[f][i]`: the edge from `FACE_CORNERS[f][i]` to `FACE_CORNERS[f][i + 1]`.
pub(crate) const FACE_EDGES: [[usize; 4]; 6] = {
    let mut t = [[0usize; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            t[f][i] = edge_between(FACE_CORNERS[f][i], FACE_CORNERS[f][(i + 1) % 4]);
            i += 1;
        }
        f += 1;
    }
    t
};

/// Whether two edges lie on a common face (and are different).
pub(crate) const SHARE_FACE: [[bool; 12]; 12] = {
    let mut t = [[false; 12]; 12];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            let mut j = 0;
            while j < 4 {
                if i != j {
                    t[FACE_EDGES[f][i]][FACE_EDGES[f][j]] = true;
                }
                j += 1;
            }
            i += 1;
        }
        f += 1;
    }
    t
};

/// A triangle corner in a case's triangulation: an edge crossing (`0..12`) or the centre
/// vertex of loop `l` (`CENTRE + l`).
pub(crate) const CENTRE: u8 = 12;

/// One cube configuration: its loops and the disc triangulation of each.
#[derive(Debug, Clone, Default)]
pub(crate) struct Case {
    /// The loops' edges, oriented counter-clockwise seen from outside the surface,
    /// concatenated; loop `l` is `edges[starts[l]..starts[l + 1]]`.
    pub edges: Vec<u8>,
    /// Loop boundaries in `edges` (`loops + 1` entries).
    pub starts: Vec<u8>,
    /// One triangle fan per loop, over [`CENTRE`]-coded corners: rooted at a loop vertex
    /// whose diagonals join no two crossings of one face, or at the loop's centre vertex
    /// when no vertex can be the root (so no edge of the mesh is drawn twice across a face).
    pub triangles: Vec<[u8; 3]>,
    /// Per loop: whether its fan uses the centre vertex.
    pub centred: Vec<bool>,
    /// The loop each crossed edge belongs to (`u8::MAX` where the edge has no crossing).
    pub edge_loop: [u8; 12],
    /// Per loop: a corner on its inside and one on its outside.
    pub sides: Vec<(u8, u8)>,
    /// Connected components of the cube's surface minus the loops, as a root corner per
    /// corner (the start of the interior-tunnel test).
    pub surface_root: [u8; 8],
    /// Faces on which both segments belong to one loop (bit `f`).
    pub doubled_faces: u8,
}

impl Case {
    /// Number of loops.
    #[inline]
    pub fn loops(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// The edges of loop `l`.
    #[inline]
    pub fn loop_edges(&self, l: usize) -> &[u8] {
        &self.edges[self.starts[l] as usize..self.starts[l + 1] as usize]
    }
}

/// Bit `f` set when face `f` of a cube with inside mask `mask` is ambiguous (its four
/// corners alternate in sign).
pub(crate) fn ambiguous_faces(mask: u8) -> u8 {
    let mut out = 0;
    for (f, corners) in FACE_CORNERS.iter().enumerate() {
        let s = corners.map(|c| mask >> c & 1);
        if s[0] == s[2] && s[1] == s[3] && s[0] != s[1] {
            out |= 1 << f;
        }
    }
    out
}

/// The case table, indexed by `mask as usize * 64 + decisions` (bit `f` of `decisions`:
/// the inside corners of ambiguous face `f` are joined across it; ignored on faces that
/// are not ambiguous).
pub(crate) fn cases() -> &'static [Case] {
    static TABLE: OnceLock<Vec<Case>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut table: Vec<Case> = Vec::with_capacity(256 * 64);
        for mask in 0..256usize {
            let amb = ambiguous_faces(mask as u8);
            for dec in 0..64u8 {
                if dec & !amb != 0 {
                    // Same as with those bits cleared: share the computation.
                    let base: Case = table[mask * 64 + (dec & amb) as usize].clone();
                    table.push(base);
                } else {
                    table.push(build_case(mask as u8, dec));
                }
            }
        }
        table
    })
}

fn inside(mask: u8, c: usize) -> bool {
    mask >> c & 1 == 1
}

/// Doubled coordinates of edge `e`'s midpoint.
fn edge_mid2(e: usize) -> [i32; 3] {
    let lo = corner_bits(EDGE_LO[e]);
    let hi = corner_bits(edge_hi(e));
    [lo[0] + hi[0], lo[1] + hi[1], lo[2] + hi[2]]
}

fn cross(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [i32; 3], b: [i32; 3]) -> i32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The segment between crossings on edges `e0`, `e1` of face `f`, directed so that the
/// inside lies on its right seen from outside the cube; `probe` is a corner of the face not
/// on the segment's line and `probe_inside` its side.
fn directed(f: usize, e0: usize, e1: usize, probe: usize, probe_inside: bool) -> (usize, usize) {
    let (a, s) = (f / 2, f % 2);
    let mut n = [0i32; 3];
    n[a] = if s == 1 { 1 } else { -1 };
    let (m0, m1) = (edge_mid2(e0), edge_mid2(e1));
    let left = cross(n, sub(m1, m0));
    let c = corner_bits(probe);
    let side = dot(left, sub([2 * c[0], 2 * c[1], 2 * c[2]], m0));
    debug_assert!(side != 0);
    // Left of e0 → e1 must be outside.
    if (side > 0) == probe_inside {
        (e1, e0)
    } else {
        (e0, e1)
    }
}

fn find(root: &mut [u8; 8], c: usize) -> usize {
    let mut c = c;
    while root[c] as usize != c {
        root[c] = root[root[c] as usize];
        c = root[c] as usize;
    }
    c
}

fn union(root: &mut [u8; 8], a: usize, b: usize) {
    let (ra, rb) = (find(root, a), find(root, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        root[hi] = lo as u8;
    }
}

fn build_case(mask: u8, dec: u8) -> Case {
    let mut case = Case {
        edge_loop: [u8::MAX; 12],
        surface_root: std::array::from_fn(|c| c as u8),
        ..Case::default()
    };
    if mask == 0 || mask == 0xff {
        return case;
    }
    let mut next = [usize::MAX; 12];
    // Which segments each face draws (for doubled faces): (face, from, to).
    let mut face_segments: Vec<(usize, usize, usize)> = Vec::new();
    let mut root: [u8; 8] = std::array::from_fn(|c| c as u8);
    for f in 0..6 {
        let corners = FACE_CORNERS[f];
        let edges = FACE_EDGES[f];
        let crossed: Vec<usize> = (0..4)
            .filter(|&i| inside(mask, corners[i]) != inside(mask, corners[(i + 1) % 4]))
            .collect();
        // Surface connectivity: corners joined along uncrossed face edges.
        for i in 0..4 {
            let (c0, c1) = (corners[i], corners[(i + 1) % 4]);
            if inside(mask, c0) == inside(mask, c1) {
                union(&mut root, c0, c1);
            }
        }
        match crossed.len() {
            0 => {}
            2 => {
                let (i, j) = (crossed[0], crossed[1]);
                let probe = corners[0];
                let (from, to) = directed(f, edges[i], edges[j], probe, inside(mask, probe));
                next[from] = to;
                face_segments.push((f, from, to));
            }
            4 => {
                let joined_inside = dec >> f & 1 == 1;
                // The corners cut off: the outside ones when the inside pair is joined.
                let cut_inside = !joined_inside;
                let pair: Vec<usize> = (0..4).filter(|&i| inside(mask, corners[i]) == cut_inside).collect();
                let other: Vec<usize> = (0..4).filter(|&i| inside(mask, corners[i]) != cut_inside).collect();
                union(&mut root, corners[other[0]], corners[other[1]]);
                for &i in &pair {
                    // Corner i is cut off by the segment between its two edges.
                    let (ea, eb) = (edges[(i + 3) % 4], edges[i]);
                    let (from, to) = directed(f, ea, eb, corners[i], cut_inside);
                    next[from] = to;
                    face_segments.push((f, from, to));
                }
            }
            _ => unreachable!("a face has 0, 2 or 4 crossings"),
        }
    }
    case.surface_root = std::array::from_fn(|c| find(&mut root, c) as u8);
    // Follow the segments into loops, starting each at its lowest edge.
    let mut seen = [false; 12];
    case.starts.push(0);
    for start in 0..12 {
        if next[start] == usize::MAX || seen[start] {
            continue;
        }
        let l = case.loops() as u8;
        let mut e = start;
        loop {
            seen[e] = true;
            case.edge_loop[e] = l;
            case.edges.push(e as u8);
            e = next[e];
            assert!(e != usize::MAX, "open loop in case {mask:#010b}/{dec:#08b}");
            if e == start {
                break;
            }
        }
        case.starts.push(case.edges.len() as u8);
        let e0 = start;
        let (lo, hi) = (EDGE_LO[e0], edge_hi(e0));
        let (ins, out) = if inside(mask, lo) { (lo, hi) } else { (hi, lo) };
        case.sides.push((ins as u8, out as u8));
    }
    for &(f, from, _) in &face_segments {
        let same = face_segments
            .iter()
            .filter(|s| s.0 == f)
            .all(|s| case.edge_loop[s.1] == case.edge_loop[from]);
        if face_segments.iter().filter(|s| s.0 == f).count() == 2 && same {
            case.doubled_faces |= 1 << f;
        }
    }
    // Fans: rooted where no diagonal joins two crossings of one face.
    for l in 0..case.loops() {
        let lp: Vec<u8> = case.loop_edges(l).to_vec();
        let k = lp.len();
        let root = (0..k).find(|&r| (2..k - 1).all(|d| !SHARE_FACE[lp[r] as usize][lp[(r + d) % k] as usize]));
        match root {
            Some(r) => {
                for d in 1..k - 1 {
                    case.triangles.push([lp[r], lp[(r + d) % k], lp[(r + d + 1) % k]]);
                }
                case.centred.push(false);
            }
            None => {
                for i in 0..k {
                    case.triangles.push([CENTRE + l as u8, lp[i], lp[(i + 1) % k]]);
                }
                case.centred.push(true);
            }
        }
    }
    case
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_has_one_to_four_closed_loops() {
        let t = cases();
        assert_eq!(t.len(), 256 * 64);
        for mask in 1..255usize {
            let c = &t[mask * 64];
            assert!(c.loops() >= 1 && c.loops() <= 4, "mask {mask}: {} loops", c.loops());
            let crossed = (0..12)
                .filter(|&e| (mask >> EDGE_LO[e] & 1) != (mask >> edge_hi(e) & 1))
                .count();
            assert_eq!(c.edges.len(), crossed);
            // The single-corner case is one triangle.
            if mask.count_ones() == 1 {
                assert_eq!(c.triangles.len(), 1);
            }
        }
        // Triangles per case average about two (marching cubes' usual figure).
        let tris: usize = (0..256).map(|m| t[m * 64].triangles.len()).sum();
        assert!(tris > 256 && tris < 256 * 4, "{tris}");
    }

    #[test]
    fn face_tables_are_consistent() {
        for f in 0..6 {
            for i in 0..4 {
                let e = FACE_EDGES[f][i];
                let (c0, c1) = (FACE_CORNERS[f][i], FACE_CORNERS[f][(i + 1) % 4]);
                assert!(EDGE_LO[e] == c0.min(c1) && edge_hi(e) == c0.max(c1));
            }
        }
    }
}
