//! 3D lines: the 26-connected thin line and the 6-connected supercover, against brute
//! force and connectivity checks, including zero-length and axis-parallel segments and
//! endpoints on voxel centres and faces.

use std::collections::HashSet;

use glam::{DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga::voxelize::{segment_voxels, voxelize_segments, LineConnectivity};
use volga::{Grid, NoProgress, Transform};

fn connected(path: &[IVec3], six: bool) -> bool {
    path.windows(2).all(|w| {
        let d = (w[1] - w[0]).abs();
        if six {
            d.x + d.y + d.z == 1
        } else {
            d.max_element() == 1
        }
    })
}

/// All voxels whose closed cell meets the closed segment, by brute force over the
/// bounding box. Exact reference independent of the library's separating-axis test: the
/// segment meets the cell iff the per-axis parameter intervals [num/den] overlap inside
/// [0, 1], compared by cross-multiplication (exact on the quarter-voxel lattice).
fn brute_supercover(p: DVec3, q: DVec3) -> HashSet<IVec3> {
    let lo = (p.min(q) - 1.0).floor().as_ivec3();
    let hi = (p.max(q) + 1.0).ceil().as_ivec3();
    let d = q - p;
    let mut out = HashSet::new();
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                let c = IVec3::new(x, y, z).as_dvec3();
                // Intervals as fractions (num, den) with den > 0; start with [0/1, 1/1].
                let mut lower = vec![(0.0, 1.0)];
                let mut upper = vec![(1.0, 1.0)];
                let mut ok = true;
                for a in 0..3 {
                    let (l, h) = (c[a] - 0.5 - p[a], c[a] + 0.5 - p[a]);
                    if d[a] == 0.0 {
                        ok &= l <= 0.0 && 0.0 <= h;
                    } else if d[a] > 0.0 {
                        lower.push((l, d[a]));
                        upper.push((h, d[a]));
                    } else {
                        lower.push((-h, -d[a]));
                        upper.push((-l, -d[a]));
                    }
                }
                // max(lower) ≤ min(upper)  ⇔  every lower ≤ every upper.
                ok &= lower
                    .iter()
                    .all(|&(ln, ld)| upper.iter().all(|&(un, ud)| ln * ud <= un * ld));
                if ok {
                    out.insert(IVec3::new(x, y, z));
                }
            }
        }
    }
    out
}

fn pt() -> impl Strategy<Value = DVec3> {
    // Quarter-voxel lattice: endpoints on centres, faces, edges and corners occur often.
    (-40i32..40, -40i32..40, -40i32..40).prop_map(|(x, y, z)| DVec3::new(x as f64, y as f64, z as f64) / 4.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn six_connected_is_exactly_the_supercover(p in pt(), q in pt()) {
        let line = segment_voxels(p, q, LineConnectivity::SIX);
        let set: HashSet<IVec3> = line.iter().copied().collect();
        prop_assert_eq!(set.len(), line.len(), "duplicates");
        prop_assert_eq!(&set, &brute_supercover(p, q));
        // 6-connected as a set: a 6-flood fill from the first voxel reaches all.
        let mut seen = HashSet::from([line[0]]);
        let mut stack = vec![line[0]];
        while let Some(v) = stack.pop() {
            for o in [IVec3::X, IVec3::NEG_X, IVec3::Y, IVec3::NEG_Y, IVec3::Z, IVec3::NEG_Z] {
                if set.contains(&(v + o)) && seen.insert(v + o) {
                    stack.push(v + o);
                }
            }
        }
        prop_assert_eq!(seen.len(), set.len(), "not 6-connected");
    }

    #[test]
    fn twenty_six_connected_thin_line(p in pt(), q in pt()) {
        let line = segment_voxels(p, q, LineConnectivity::TWENTY_SIX);
        let t = Transform::new(DVec3::ZERO, DVec3::ONE).unwrap();
        let (vp, vq) = (t.nearest_voxel(p), t.nearest_voxel(q));
        prop_assert_eq!(line[0], vp);
        prop_assert!(line.iter().collect::<HashSet<_>>().len() == line.len());
        prop_assert_eq!(*line.last().unwrap(), vq);
        prop_assert_eq!(line.len() as i32, (vq - vp).abs().max_element() + 1);
        prop_assert!(connected(&line, false));
        // Every voxel lies within half a voxel (per axis, off the dominant one) of the segment.
        let d = q - p;
        for v in &line {
            let c = v.as_dvec3();
            let t = if d == DVec3::ZERO { 0.0 } else { ((c - p).dot(d) / d.length_squared()).clamp(0.0, 1.0) };
            prop_assert!((p + d * t - c).length() <= 3f64.sqrt(), "{} far from the segment", v);
        }
        // Reversing the segment gives the same voxels except at exact rounding ties.
        prop_assert_eq!(segment_voxels(q, p, LineConnectivity::TWENTY_SIX).len(), line.len());
    }
}

#[test]
fn zero_length_and_axis_parallel_segments() {
    let p = DVec3::new(1.0, 2.0, 3.0);
    assert_eq!(
        segment_voxels(p, p, LineConnectivity::TWENTY_SIX),
        vec![IVec3::new(1, 2, 3)]
    );
    assert_eq!(segment_voxels(p, p, LineConnectivity::SIX), vec![IVec3::new(1, 2, 3)]);
    // A point exactly on a cell corner touches eight closed cells.
    let corner = DVec3::splat(0.5);
    assert_eq!(segment_voxels(corner, corner, LineConnectivity::SIX).len(), 8);
    // Along x through voxel centres: one row, both connectivities.
    let row = segment_voxels(
        DVec3::new(0.0, 2.0, 3.0),
        DVec3::new(9.0, 2.0, 3.0),
        LineConnectivity::SIX,
    );
    assert_eq!(row, (0..=9).map(|x| IVec3::new(x, 2, 3)).collect::<Vec<_>>());
    assert!(segment_voxels(DVec3::NAN, p, LineConnectivity::SIX).is_empty());
}

#[test]
fn voxelized_segments_clip_to_the_grid_and_agree_across_threads() {
    let grid = Grid::new(
        Transform::new(DVec3::splat(-1.0), DVec3::splat(0.125)).unwrap(),
        UVec3::splat(17),
    )
    .unwrap();
    let segs: Vec<[DVec3; 2]> = (0..40)
        .map(|i| {
            let a = i as f64 * 0.37;
            [
                DVec3::new(a.cos(), a.sin(), -1.5),
                DVec3::new(-a.sin(), a.cos() * 0.5, 1.5),
            ]
        })
        .collect();
    let run = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| {
                voxelize_segments(&grid, &segs, LineConnectivity::SIX, &NoProgress)
                    .to_dense()
                    .unwrap()
            })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    let count = one.density.as_slice().iter().filter(|d| **d == 1.0).count();
    let expected: HashSet<IVec3> = segs
        .iter()
        .flat_map(|[a, b]| {
            segment_voxels(
                grid.transform.world_to_index(*a),
                grid.transform.world_to_index(*b),
                LineConnectivity::SIX,
            )
        })
        .filter(|v| grid.contains(*v))
        .collect();
    assert_eq!(count, expected.len());
}
