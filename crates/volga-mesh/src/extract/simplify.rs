//! Adaptivity: fewer, larger triangles where the surface is flat, within a stated bound.
//!
//! Edge collapses ordered by the quadric error metric (Garland & Heckbert 1997), each vertex
//! carrying the sum `Q` of the squared-distance quadrics of the planes of the original
//! triangles it has absorbed. A collapse to the point `x` is made only when
//!
//! - `√Q(x) ≤ ε`: since `Q(x)` is a sum of squared distances, **every** original plane the
//!   merged vertex stands for is within `ε` of it (the stated bound; the Hausdorff distance
//!   to the true surface is measured by `volga bench extract`),
//! - the link condition holds (the two end points share exactly the two neighbours of their
//!   edge), so the mesh stays manifold and keeps its genus,
//! - no remaining triangle turns by more than 78° or becomes degenerate, and
//! - neither end point lies on a boundary edge (a surface leaving the lattice keeps its rim),
//!   and the merged vertex has at most 12 neighbours (no fans of slivers).
//!
//! `x` is the quadric's minimizer when it is well conditioned (that keeps sharp edges and
//! corners), otherwise the best of the two end points and their midpoint. Collapses happen
//! in order of cost, ties broken by vertex ids, so the result does not depend on threads.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::TriMesh;

/// What a simplification did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimplifyStats {
    /// Edges collapsed.
    pub collapses: u64,
    /// Triangles before.
    pub triangles_before: u64,
    /// Triangles after.
    pub triangles_after: u64,
}

/// Most neighbours a merged vertex may have.
const MAX_VALENCE: usize = 12;

/// A queued collapse: (cost bits, lower vertex, upper vertex, their stamps when queued).
type Candidate = (u64, u32, u32, u32, u32);

/// A symmetric 4×4 quadric `[A b; bᵀ c]` of summed squared plane distances.
#[derive(Clone, Copy, Default)]
struct Quadric {
    a: [f64; 6], // xx xy xz yy yz zz
    b: [f64; 3],
    c: f64,
}

impl Quadric {
    fn plane(n: DVec3, p: DVec3) -> Quadric {
        let d = -n.dot(p);
        Quadric {
            a: [n.x * n.x, n.x * n.y, n.x * n.z, n.y * n.y, n.y * n.z, n.z * n.z],
            b: [n.x * d, n.y * d, n.z * d],
            c: d * d,
        }
    }
    fn add(&self, o: &Quadric) -> Quadric {
        Quadric {
            a: std::array::from_fn(|i| self.a[i] + o.a[i]),
            b: std::array::from_fn(|i| self.b[i] + o.b[i]),
            c: self.c + o.c,
        }
    }
    fn eval(&self, p: DVec3) -> f64 {
        let a = &self.a;
        let v = a[0] * p.x * p.x
            + 2.0 * a[1] * p.x * p.y
            + 2.0 * a[2] * p.x * p.z
            + a[3] * p.y * p.y
            + 2.0 * a[4] * p.y * p.z
            + a[5] * p.z * p.z
            + 2.0 * (self.b[0] * p.x + self.b[1] * p.y + self.b[2] * p.z)
            + self.c;
        v.max(0.0)
    }
    fn minimizer(&self) -> Option<DVec3> {
        let a = &self.a;
        let m = DMat3::from_cols(
            DVec3::new(a[0], a[1], a[2]),
            DVec3::new(a[1], a[3], a[4]),
            DVec3::new(a[2], a[4], a[5]),
        );
        let det = m.determinant();
        let scale = (a[0] + a[3] + a[5]).powi(3);
        if det.abs() <= 1e-9 * scale || det.is_nan() {
            return None;
        }
        let x = m.inverse() * -DVec3::from_array(self.b);
        x.is_finite().then_some(x)
    }
}

/// Collapses edges of `mesh` while every merged vertex stays within `epsilon` (world units)
/// of the plane of each original triangle it replaces (see the module documentation).
/// Unused vertices are removed; triangles keep their orientation.
pub fn simplify(mesh: &mut TriMesh, epsilon: f64) -> SimplifyStats {
    let mut stats = SimplifyStats {
        triangles_before: mesh.triangles.len() as u64,
        ..SimplifyStats::default()
    };
    if epsilon.is_nan() || epsilon <= 0.0 || mesh.triangles.is_empty() {
        stats.triangles_after = stats.triangles_before;
        return stats;
    }
    let eps2 = epsilon * epsilon;
    let nv = mesh.positions.len();
    let mut pos = mesh.positions.clone();
    let mut q = vec![Quadric::default(); nv];
    for tri in &mesh.triangles {
        let [a, b, c] = tri.map(|v| pos[v as usize]);
        let n = (b - a).cross(c - a);
        let plane = if n.length_squared() > 0.0 {
            Quadric::plane(n.normalize(), a)
        } else {
            Quadric::default()
        };
        for &v in tri {
            q[v as usize] = q[v as usize].add(&plane);
        }
    }
    // Two rounds over a fixed grid of bins (the second shifted by half a bin, so the
    // first's seams lie inside bins): each bin's triangles are simplified on their own, in
    // parallel, with the vertices on triangles that leave the bin locked. A last round
    // over the whole (much smaller) mesh takes what the seams held back. The bins depend
    // only on the mesh, so the result does not depend on the thread count; the quadrics
    // carry over, so the bound holds for the whole.
    let (lo, hi) = pos.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), p| {
        (a.min(*p), b.max(*p))
    });
    let bin = ((hi - lo).max_element() / BINS_PER_AXIS).max(f64::MIN_POSITIVE);
    let mut tris = mesh.triangles.clone();
    for (shift, whole) in [(0.0, false), (0.5, false), (0.0, true)] {
        let key = |p: DVec3| {
            if whole {
                return (0, 0, 0);
            }
            let k = ((p - lo) / bin + shift).floor();
            (k.z as i64, k.y as i64, k.x as i64)
        };
        let mut parts: std::collections::BTreeMap<(i64, i64, i64), Vec<[u32; 3]>> = Default::default();
        let mut seams = Vec::new();
        for t in &tris {
            let [a, b, c] = t.map(|v| key(pos[v as usize]));
            if a == b && b == c {
                parts.entry(a).or_default().push(*t);
            } else {
                seams.push(*t);
            }
        }
        let parts: Vec<Vec<[u32; 3]>> = parts.into_values().collect();
        let results: Vec<Part> = parts
            .into_par_iter()
            .map(|p| simplify_part(&pos, &q, p, eps2))
            .collect();
        tris.clear();
        for r in results {
            stats.collapses += r.collapses;
            for (v, p, qq) in r.moved {
                pos[v as usize] = p;
                q[v as usize] = qq;
            }
            tris.extend(r.triangles);
        }
        tris.extend(seams);
    }
    // Compact.
    let mut new_id = vec![u32::MAX; nv];
    let mut positions = Vec::new();
    let mut triangles = Vec::with_capacity(tris.len());
    for tri in &tris {
        triangles.push(tri.map(|v| {
            let vi = v as usize;
            if new_id[vi] == u32::MAX {
                new_id[vi] = positions.len() as u32;
                positions.push(pos[vi]);
            }
            new_id[vi]
        }));
    }
    mesh.positions = positions;
    mesh.triangles = triangles;
    stats.triangles_after = mesh.triangles.len() as u64;
    stats
}

/// Bins along the longest side of the mesh's box.
const BINS_PER_AXIS: f64 = 8.0;

/// One bin's result: its triangles (global vertex ids), the survivors' new positions and
/// quadrics, and the collapses made.
struct Part {
    triangles: Vec<[u32; 3]>,
    moved: Vec<(u32, DVec3, Quadric)>,
    collapses: u64,
}

/// Simplifies one bin's triangles (global vertex ids into `global_pos` and `global_q`).
fn simplify_part(global_pos: &[DVec3], global_q: &[Quadric], part: Vec<[u32; 3]>, eps2: f64) -> Part {
    // Local numbering, in order of the global ids.
    let mut ids: Vec<u32> = part.iter().flatten().copied().collect();
    ids.sort_unstable();
    ids.dedup();
    let local = |g: u32| ids.binary_search(&g).expect("vertex of the part") as u32;
    let mut tris: Vec<[u32; 3]> = part.iter().map(|t| t.map(local)).collect();
    let nv = ids.len();
    let mut pos: Vec<DVec3> = ids.iter().map(|&g| global_pos[g as usize]).collect();
    let mut q: Vec<Quadric> = ids.iter().map(|&g| global_q[g as usize]).collect();
    let mut alive = vec![true; tris.len()];
    let mut vt: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            vt[v as usize].push(t as u32);
        }
    }
    let mut collapses = 0u64;
    // Boundary (and non-manifold) vertices are locked.
    let mut locked = vec![false; nv];
    {
        let mut edges: Vec<(u32, u32)> = tris
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
            .collect();
        edges.sort_unstable();
        let mut i = 0;
        while i < edges.len() {
            let mut j = i;
            while j < edges.len() && edges[j] == edges[i] {
                j += 1;
            }
            if j - i != 2 {
                locked[edges[i].0 as usize] = true;
                locked[edges[i].1 as usize] = true;
            }
            i = j;
        }
    }
    let mut stamp = vec![0u32; nv];
    let mut removed = vec![false; nv];
    let mut heap: BinaryHeap<Reverse<Candidate>> = BinaryHeap::new();

    let target = |q: &Quadric, pa: DVec3, pb: DVec3| -> (DVec3, f64) {
        let mut best = (pa, q.eval(pa));
        for p in [pb, 0.5 * (pa + pb)] {
            let e = q.eval(p);
            if e < best.1 {
                best = (p, e);
            }
        }
        if let Some(x) = q.minimizer() {
            // Keep the optimum near the edge (an ill-posed quadric can put it far away).
            let len = pa.distance(pb);
            if x.distance(0.5 * (pa + pb)) <= len {
                let e = q.eval(x);
                if e < best.1 {
                    best = (x, e);
                }
            }
        }
        best
    };
    let push = |heap: &mut BinaryHeap<_>, q: &[Quadric], pos: &[DVec3], stamp: &[u32], u: u32, v: u32| {
        let (a, b) = (u.min(v), u.max(v));
        let qq = q[a as usize].add(&q[b as usize]);
        let (_, e) = target(&qq, pos[a as usize], pos[b as usize]);
        if e <= eps2 {
            heap.push(Reverse((e.to_bits(), a, b, stamp[a as usize], stamp[b as usize])));
        }
    };
    for tri in &tris {
        for k in 0..3 {
            let (u, v) = (tri[k], tri[(k + 1) % 3]);
            if u < v && !locked[u as usize] && !locked[v as usize] {
                push(&mut heap, &q, &pos, &stamp, u, v);
            }
        }
    }

    let mut nbr_u = Vec::new();
    let mut nbr_v = Vec::new();
    while let Some(Reverse((_, u, v, su, sv))) = heap.pop() {
        let (ui, vi) = (u as usize, v as usize);
        if removed[ui] || removed[vi] || stamp[ui] != su || stamp[vi] != sv {
            continue;
        }
        // The edge must still exist: the triangles on it.
        let shared: Vec<u32> = vt[ui]
            .iter()
            .copied()
            .filter(|&t| alive[t as usize] && tris[t as usize].contains(&v))
            .collect();
        if shared.len() != 2 {
            continue;
        }
        // Link condition.
        neighbours(&vt, &alive, &tris, ui, &mut nbr_u);
        neighbours(&vt, &alive, &tris, vi, &mut nbr_v);
        let common = nbr_u.iter().filter(|x| nbr_v.binary_search(x).is_ok()).count();
        // The merged vertex has `|N(u)| + |N(v)| − 4` neighbours: capped, so no vertex
        // grows a fan of slivers (and each collapse stays cheap).
        if common != 2 || nbr_u.len() + nbr_v.len() - 4 > MAX_VALENCE {
            continue;
        }
        let qq = q[ui].add(&q[vi]);
        let (x, e) = target(&qq, pos[ui], pos[vi]);
        if e > eps2 {
            continue;
        }
        // No remaining triangle may flip or degenerate.
        let mut ok = true;
        for w in [ui, vi] {
            for &t in &vt[w] {
                let tri = tris[t as usize];
                if !alive[t as usize] || (tri.contains(&u) && tri.contains(&v)) {
                    continue;
                }
                let old = tri.map(|k| pos[k as usize]);
                let new = tri.map(|k| if k == u || k == v { x } else { pos[k as usize] });
                let n0 = (old[1] - old[0]).cross(old[2] - old[0]);
                let n1 = (new[1] - new[0]).cross(new[2] - new[0]);
                let (l0, l1) = (n0.length(), n1.length());
                if l0 == 0.0 {
                    continue;
                }
                if l1 <= 1e-12 * l0 || n0.dot(n1) < 0.2 * l0 * l1 {
                    ok = false;
                    break;
                }
            }
            if !ok {
                break;
            }
        }
        if !ok {
            continue;
        }
        // Collapse v into u at x.
        for &t in &shared {
            alive[t as usize] = false;
        }
        let moved: Vec<u32> = vt[vi].iter().copied().filter(|&t| alive[t as usize]).collect();
        for &t in &moved {
            for k in tris[t as usize].iter_mut() {
                if *k == v {
                    *k = u;
                }
            }
        }
        let mut list: Vec<u32> = vt[ui].iter().copied().filter(|&t| alive[t as usize]).collect();
        list.extend(moved);
        vt[ui] = list;
        vt[vi].clear();
        removed[vi] = true;
        pos[ui] = x;
        q[ui] = qq;
        stamp[ui] += 1;
        collapses += 1;
        // Only edges at u changed cost (the others' quadrics and end points did not;
        // whether they can still collapse is checked when they come off the heap).
        neighbours(&vt, &alive, &tris, ui, &mut nbr_u);
        for &w in &nbr_u {
            if !locked[w as usize] {
                push(&mut heap, &q, &pos, &stamp, u, w);
            }
        }
    }
    let mut moved = Vec::new();
    let mut touched = vec![false; nv];
    let triangles = tris
        .iter()
        .zip(&alive)
        .filter(|(_, &a)| a)
        .map(|(t, _)| {
            for &v in t {
                if !touched[v as usize] {
                    touched[v as usize] = true;
                    moved.push((ids[v as usize], pos[v as usize], q[v as usize]));
                }
            }
            t.map(|v| ids[v as usize])
        })
        .collect();
    Part {
        triangles,
        moved,
        collapses,
    }
}

/// The vertices sharing a live triangle with `w`, sorted.
fn neighbours(vt: &[Vec<u32>], alive: &[bool], tris: &[[u32; 3]], w: usize, out: &mut Vec<u32>) {
    out.clear();
    for &t in &vt[w] {
        if alive[t as usize] {
            out.extend(tris[t as usize].iter().copied().filter(|&x| x as usize != w));
        }
    }
    out.sort_unstable();
    out.dedup();
}
