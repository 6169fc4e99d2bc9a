//! Which triangles are clean: no other triangle of the mesh (or a cap) crosses or
//! touches them off their shared edges and corners. Candidate pairs come from a hash
//! grid of boxes; each pair is decided conservatively.

use glam::DVec3;
use rayon::prelude::*;
use volga_core::Aabb;
use volga_mesh::{triangles_may_intersect, Bvh};

/// Relative tolerance of the adjacency tests: pairs closer than this to touching or to
/// coplanar count as crossing (which only sends their voxels down the slow path).
pub(super) const TOUCH: f64 = 1e-9;

/// Whether two triangles that share the welded corners in `ids_*` meet anywhere but
/// their shared edge or corner, decided conservatively.
pub(super) fn adjacent_pair_crosses(t: [DVec3; 3], t_ids: [u32; 3], s: [DVec3; 3], s_ids: [u32; 3]) -> bool {
    let repeats = |ids: [u32; 3]| ids[0] == ids[1] || ids[1] == ids[2] || ids[2] == ids[0];
    if repeats(t_ids) || repeats(s_ids) {
        return true; // a degenerate triangle is never clean, nor what touches it
    }
    let mut shared = [(0usize, 0usize); 9];
    let mut count = 0;
    for (i, ti) in t_ids.iter().enumerate() {
        for (j, sj) in s_ids.iter().enumerate() {
            if ti == sj {
                shared[count] = (i, j);
                count += 1;
            }
        }
    }
    match count {
        0 => {
            let scale = t
                .iter()
                .chain(&s)
                .map(|v| (*v - t[0]).length())
                .fold(0.0, f64::max)
                .max(f64::MIN_POSITIVE);
            triangles_may_intersect(t, s, TOUCH * scale)
        }
        1 => {
            let (i, j) = shared[0];
            let v = t[i];
            let (a1, a2) = (t[(i + 1) % 3] - v, t[(i + 2) % 3] - v);
            let (b1, b2) = (s[(j + 1) % 3] - v, s[(j + 2) % 3] - v);
            let (nt, ns) = (a1.cross(a2), b1.cross(b2));
            // `r` in the closed cone spanned by `a` and `b` about `n` (with slack).
            let in_cone = |r: DVec3, a: DVec3, b: DVec3, n: DVec3| {
                let slack = TOUCH * a.length() * r.length() * n.length();
                a.cross(r).dot(n) >= -slack && r.cross(b).dot(n) >= -slack
            };
            let d = nt.cross(ns);
            if d.length() <= TOUCH * nt.length() * ns.length() {
                // (Nearly) coplanar: the wedges overlap iff an edge of one lies in the other.
                let ns = if ns.dot(nt) < 0.0 { -ns } else { ns };
                let (b1, b2) = if b1.cross(b2).dot(nt) < 0.0 { (b2, b1) } else { (b1, b2) };
                in_cone(b1, a1, a2, nt) || in_cone(b2, a1, a2, nt) || in_cone(a1, b1, b2, ns) || in_cone(a2, b1, b2, ns)
            } else {
                in_cone(d, a1, a2, nt) && in_cone(d, b1, b2, ns) || in_cone(-d, a1, a2, nt) && in_cone(-d, b1, b2, ns)
            }
        }
        2 => {
            // The planes meet only along the shared edge unless `s` folds back onto `t`.
            let (i0, j0) = shared[0];
            let (i1, _) = shared[1];
            let (a, b) = (t[i0], t[i1]);
            let ot = t[3 - i0 - i1];
            let os = s[(0..3).find(|&k| k != j0 && k != shared[1].1).unwrap_or(0)];
            let nt = (b - a).cross(ot - a);
            let m = nt.cross(b - a);
            let same_side = m.dot(os - a) * m.dot(ot - a).signum() >= -TOUCH * m.length() * (os - a).length();
            let off_plane = nt.dot(os - a).abs();
            same_side && off_plane <= 1e-6 * nt.length() * (os - a).length()
        }
        _ => true,
    }
}

/// Pairs `(t, s)`, `t < s`, of triangles whose boxes overlap: a uniform hash grid of
/// cells about twice the median box size, each pair tested once, in the lowest cell both
/// boxes reach. Boxes spanning more than 64 cells (rare, large triangles) query the BVH
/// instead.
pub(super) fn candidate_pairs(boxes: &[Aabb], bvh: &Bvh, from_bvh: &[u32]) -> Vec<(u32, u32)> {
    if boxes.is_empty() {
        return Vec::new();
    }
    let mut sizes: Vec<f64> = boxes.iter().map(|b| b.size().max_element()).collect();
    let mid = sizes.len() / 2;
    sizes.select_nth_unstable_by(mid, f64::total_cmp);
    let all = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let cell = (2.0 * sizes[mid])
        .max(all.size().max_element() / 1e6)
        .max(f64::MIN_POSITIVE);
    let origin = all.min;
    let range = |b: &Aabb| {
        let lo = ((b.min - origin) / cell).floor().as_ivec3();
        let hi = ((b.max - origin) / cell).floor().as_ivec3();
        (lo, hi)
    };
    let key = |c: glam::IVec3| (c.x as u64) | (c.y as u64) << 21 | (c.z as u64) << 42;
    // Each box's cell range, once (the pair loop asks for the lower corners often).
    let ranges: Vec<(glam::IVec3, glam::IVec3)> = boxes.par_iter().map(range).collect();
    let small = |(lo, hi): (glam::IVec3, glam::IVec3)| {
        let span = (hi - lo + 1).as_i64vec3();
        span.x * span.y * span.z <= 64 && hi.max_element() < 1 << 21
    };
    let large: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| !small(ranges[i as usize]))
        .collect();
    let mut entries: Vec<(u64, u32)> = ranges
        .par_iter()
        .enumerate()
        .filter(|&(_, &r)| small(r))
        .flat_map_iter(|(i, &(lo, hi))| {
            (lo.z..=hi.z).flat_map(move |z| {
                (lo.y..=hi.y).flat_map(move |y| (lo.x..=hi.x).map(move |x| (key(glam::IVec3::new(x, y, z)), i as u32)))
            })
        })
        .collect();
    entries.par_sort_unstable();
    let groups: Vec<&[(u64, u32)]> = entries.chunk_by(|a, b| a.0 == b.0).collect();
    let mut pairs: Vec<(u32, u32)> = groups
        .par_iter()
        .flat_map_iter(|group| {
            let mut out = Vec::new();
            let here = group[0].0;
            for (k, &(_, a)) in group.iter().enumerate() {
                let (ba, lo_a) = (&boxes[a as usize], ranges[a as usize].0);
                for &(_, b) in &group[k + 1..] {
                    let bb = &boxes[b as usize];
                    if ba.min.cmpgt(bb.max).any() || bb.min.cmpgt(ba.max).any() {
                        continue;
                    }
                    // Test the pair only in the lowest cell both boxes reach.
                    if key(lo_a.max(ranges[b as usize].0)) == here {
                        out.push((a.min(b), a.max(b)));
                    }
                }
            }
            out
        })
        .collect();
    let large_set: rustc_hash::FxHashSet<u32> = large.iter().copied().collect();
    for &t in &large {
        let mut near = Vec::new();
        bvh.boxes_overlapping(&boxes[t as usize], &mut near);
        for b in near {
            let s = from_bvh[b as usize];
            // Pairs of two large boxes once; large with small from the large side.
            if s != t && (!large_set.contains(&s) || t < s) {
                pairs.push((t.min(s), t.max(s)));
            }
        }
    }
    pairs
}
