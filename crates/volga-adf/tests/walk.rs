//! The indexed ray walk (`Adf::first_crossing_between`) against the reference walk
//! without the index (`Adf::first_crossing_by_descent`) and against exact spheres:
//! random, grazing and axis-parallel rays, a camera inside, a far-from-origin ADF, iso
//! values on both sides of 0, and leaf look-ups through the index.

use glam::DVec3;
use volga_adf::{Adf, AdfOptions, ShapeSource};
use volga_shapes::{Sphere, Torus};

mod common;
use common::Rng;

fn options(tolerance: f64, max_depth: u8) -> AdfOptions {
    AdfOptions {
        tolerance,
        max_depth,
        ..AdfOptions::default()
    }
}

/// Both walks over `[t0, t1]` of the root cube: the same hit or miss, `t` within `eps`.
fn agree(adf: &Adf, origin: DVec3, dir: DVec3, iso: f64, eps: f64) -> Option<f64> {
    let (t0, t1) = adf.root_box().ray_interval(origin, dir)?;
    let (fast, _) = adf.first_crossing_between(origin, dir, t0, t1, iso);
    let (slow, _) = adf.first_crossing_by_descent(origin, dir, t0, t1, iso);
    match (fast, slow) {
        (Some(a), Some(b)) => assert!(
            (a - b).abs() <= eps,
            "t {a} vs reference {b} ({origin:?} {dir:?} iso {iso})"
        ),
        (None, None) => {}
        _ => panic!("hit {fast:?} vs reference {slow:?} ({origin:?} {dir:?} iso {iso})"),
    }
    fast
}

/// The exact first hit of a ray with a sphere (`None` if it misses).
fn sphere_t(origin: DVec3, dir: DVec3, centre: DVec3, r: f64) -> Option<(f64, f64)> {
    let oc = origin - centre;
    let b = oc.dot(dir);
    let disc = b * b - (oc.length_squared() - r * r);
    (disc >= 0.0).then(|| (-b - disc.sqrt(), disc))
}

#[test]
fn indexed_walk_matches_the_reference_and_the_exact_sphere() {
    let centre = DVec3::new(0.2, -0.1, 0.05);
    let r = 0.7;
    let tol = 1e-4;
    let adf = Adf::build(&ShapeSource(Sphere::new(centre, r).unwrap()), options(tol, 10)).unwrap();
    let mut rng = Rng(5);
    let mut hits = 0;
    for k in 0..3000 {
        // Rays from a sphere of radius 3 aimed near the centre; every 3rd one grazes.
        let origin = centre + rng.unit() * 3.0;
        let aim = if k % 3 == 0 {
            // Tangent-ish: aim at a point at distance r (± a sliver) from the centre.
            let to = (centre - origin).normalize();
            let side = to.cross(rng.unit()).normalize();
            centre + side * (r + (rng.next() - 0.5) * 4.0 * tol)
        } else {
            centre + rng.unit() * r * rng.next()
        };
        let dir = (aim - origin).normalize();
        let t = agree(&adf, origin, dir, 0.0, 1e-9);
        match (t, sphere_t(origin, dir, centre, r)) {
            (Some(t), Some((exact, disc))) => {
                if disc > 1e-2 {
                    assert!((t - exact).abs() < 10.0 * tol, "t {t} vs exact {exact}");
                    hits += 1;
                }
            }
            (Some(t), None) => {
                // A hit where the exact ray misses: only a graze within the tolerance.
                let p = origin + dir * t;
                assert!(((p - centre).length() - r).abs() < 2.0 * tol, "spurious hit at {p:?}");
            }
            (None, Some((_, disc))) => assert!(disc < 4.0 * r * tol, "missed a clear hit (disc {disc})"),
            (None, None) => {}
        }
    }
    assert!(hits > 1000, "{hits}");
}

#[test]
fn iso_values_on_both_sides_of_zero_and_the_steps_saved() {
    let torus = Torus::new(DVec3::new(0.0, 0.1, 0.0), DVec3::Y, 0.6, 0.2).unwrap();
    let adf = Adf::build(&ShapeSource(torus), options(1e-4, 10)).unwrap();
    let mut rng = Rng(9);
    let (mut fast_steps, mut slow_steps) = (0u64, 0u64);
    for k in 0..1500 {
        let origin = rng.unit() * 2.5;
        let dir = (rng.unit() * 0.7 - origin).normalize();
        let iso = [0.0, 0.05, -0.05, 0.3][k % 4];
        agree(&adf, origin, dir, iso, 1e-9);
        if iso == 0.0 {
            let (t0, t1) = adf.root_box().ray_interval(origin, dir).unwrap();
            fast_steps += adf.first_crossing_between(origin, dir, t0, t1, iso).1 as u64;
            slow_steps += adf.first_crossing_by_descent(origin, dir, t0, t1, iso).1 as u64;
        }
    }
    // The active box and the empty grid cells save leaf visits.
    assert!(fast_steps < slow_steps, "{fast_steps} vs {slow_steps}");
    // An iso value below every value: no crossing anywhere (the active box is empty).
    let (t0, t1) = adf
        .root_box()
        .ray_interval(DVec3::new(0.0, 0.1, 3.0), DVec3::NEG_Z)
        .unwrap();
    assert_eq!(
        adf.first_crossing_between(DVec3::new(0.0, 0.1, 3.0), DVec3::NEG_Z, t0, t1, -10.0)
            .0,
        None
    );
}

#[test]
fn a_camera_inside_and_axis_parallel_rays() {
    let centre = DVec3::new(0.0, 0.0, 0.0);
    let adf = Adf::build(&ShapeSource(Sphere::new(centre, 0.5).unwrap()), options(1e-4, 9)).unwrap();
    let root = adf.root_box();
    // Inside the surface: the start of the interval.
    let o = DVec3::new(0.1, 0.05, -0.02);
    assert_eq!(adf.first_crossing_between(o, DVec3::X, 0.0, 1.0, 0.0).0, Some(0.0));
    // Inside the root cube, outside the surface, looking at it and away from it.
    let o = DVec3::new(0.0, 0.0, 0.8);
    let t = agree(&adf, o, DVec3::NEG_Z, 0.0, 1e-9).unwrap();
    assert!((t - 0.3).abs() < 1e-4, "{t}");
    let (_, t1) = root.ray_interval(o, DVec3::Z).unwrap();
    assert_eq!(adf.first_crossing_between(o, DVec3::Z, 0.0, t1, 0.0).0, None);
    // Axis-parallel rays exactly on cell faces (the centre's planes are faces at every depth).
    for dir in [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z] {
        let t = agree(&adf, -dir * 0.9, dir, 0.0, 1e-9).unwrap();
        assert!((t - 0.4).abs() < 1e-4, "{dir:?}: {t}");
    }
}

#[test]
fn far_from_the_origin() {
    let centre = DVec3::new(1e6, -1e6, 1e6);
    let r = 0.5;
    let adf = Adf::build(&ShapeSource(Sphere::new(centre, r).unwrap()), options(1e-4, 9)).unwrap();
    let mut rng = Rng(21);
    let mut hits = 0;
    for _ in 0..500 {
        let origin = centre + rng.unit() * 2.0;
        let dir = (centre + rng.unit() * 0.6 * rng.next() - origin).normalize();
        if let Some(t) = agree(&adf, origin, dir, 0.0, 1e-7) {
            if let Some((exact, disc)) = sphere_t(origin, dir, centre, r) {
                if disc > 1e-2 {
                    assert!((t - exact).abs() < 1e-3, "t {t} vs {exact}");
                    hits += 1;
                }
            }
        }
    }
    assert!(hits > 100, "{hits}");
}

#[test]
fn the_index_finds_the_same_leaves_and_gradients() {
    let torus = Torus::new(DVec3::ZERO, DVec3::Z, 0.5, 0.15).unwrap();
    let adf = Adf::build(&ShapeSource(torus), options(1e-3, 8)).unwrap();
    let fresh = adf.clone();
    let mut rng = Rng(3);
    let root = adf.root_box();
    let mut points: Vec<DVec3> = (0..2000)
        .map(|_| root.min + DVec3::new(rng.next(), rng.next(), rng.next()) * root.size())
        .collect();
    // Dyadic points: on cell faces, edges and corners at every depth, and the root's faces.
    for _ in 0..2000 {
        let q = |r: &mut Rng| (r.next() * 257.0).floor() / 256.0;
        points.push(root.min + DVec3::new(q(&mut rng), q(&mut rng), q(&mut rng)) * root.size());
    }
    // Before the index exists the gradient descends from the root.
    let before: Vec<DVec3> = points.iter().map(|&p| fresh.gradient(p)).collect();
    assert!(adf.walk_index_bytes() > 0);
    for (p, g) in points.iter().zip(&before) {
        assert_eq!(adf.gradient(*p).to_array(), g.to_array(), "at {p:?}");
    }
    // The index is not part of the ADF's value.
    assert_eq!(adf, fresh);
}

/// The reach steps (empty cubes of the 128³ grid crossed at once) and the cubic from the
/// corners on a tree deep enough to use the whole grid: a torus ∪ sphere at depth 10,
/// 3,000 random and grazing rays from outside, 500 from a camera inside the root cube, at
/// the origin and at 1e6, against the reference walk.
#[test]
fn reach_steps_match_the_reference_on_a_deep_tree_near_and_far() {
    use volga_adf::{Csg, CsgOp};
    for offset in [DVec3::ZERO, DVec3::new(1e6, 1e6, -1e6)] {
        let torus = Torus::new(offset + DVec3::new(0.0, 0.1, 0.0), DVec3::Y, 0.6, 0.2).unwrap();
        let sphere = Sphere::new(offset + DVec3::new(0.3, -0.2, 0.1), 0.35).unwrap();
        let source = Csg {
            op: CsgOp::Union,
            a: ShapeSource(torus),
            b: ShapeSource(sphere),
        };
        let adf = Adf::build(&source, options(1e-4, 10)).unwrap();
        assert!(adf.stats().depth_reached >= 8);
        // Far from the origin `t` is resolved to the rounding of 1e6, not of 1.
        let eps = if offset == DVec3::ZERO { 1e-9 } else { 1e-7 };
        let mut rng = Rng(77);
        let (mut hits, mut fast_steps, mut slow_steps) = (0, 0u64, 0u64);
        for k in 0..3500 {
            let origin = if k < 3000 {
                offset + rng.unit() * 2.5
            } else {
                // Inside the root cube, outside or inside the surface.
                offset + rng.unit() * 0.9 * rng.next()
            };
            let dir = if k % 3 == 0 {
                // Grazing: towards a point at distance r ± a sliver from the torus's axis.
                let side = rng.unit().cross(DVec3::Y).normalize();
                let aim = offset
                    + DVec3::new(0.0, 0.1 + 0.2 * (rng.next() - 0.5), 0.0)
                    + side * (0.8 + (rng.next() - 0.5) * 4e-4);
                (aim - origin).normalize()
            } else {
                (offset + rng.unit() * 0.7 - origin).normalize()
            };
            if agree(&adf, origin, dir, 0.0, eps).is_some() {
                hits += 1;
            }
            if let Some((t0, t1)) = adf.root_box().ray_interval(origin, dir) {
                fast_steps += adf.first_crossing_between(origin, dir, t0, t1, 0.0).1 as u64;
                slow_steps += adf.first_crossing_by_descent(origin, dir, t0, t1, 0.0).1 as u64;
            }
        }
        assert!(hits > 1000, "{hits} hits at {offset:?}");
        assert!(fast_steps < slow_steps, "{fast_steps} vs {slow_steps} at {offset:?}");
    }
}

/// The batched walk (`Adf::first_crossings_between`, several rays advanced in turn) gives
/// every ray the one-ray walk's answer bit for bit, the crossing and the steps, whatever
/// the batch's length and split (fewer rays than the window, a window and one, many): on
/// a torus ∪ box (sharp edges) at the origin and at 1e6, iso values below, at and above 0,
/// rays from outside, grazing, axis-parallel, from inside the surface (answered at their
/// start), with empty intervals, and rays missing the active box.
#[test]
fn batched_walks_answer_each_ray_as_the_one_ray_walk() {
    use volga_adf::{Csg, CsgOp, WALK_WINDOW};
    use volga_core::{Crossing, CrossingRay, Field};
    use volga_shapes::AxisBox;
    for offset in [DVec3::ZERO, DVec3::new(1e6, -1e6, 1e6)] {
        let torus = Torus::new(offset + DVec3::new(0.0, 0.1, 0.0), DVec3::Y, 0.6, 0.2).unwrap();
        let cube = AxisBox::new(
            offset + DVec3::new(-0.2, -0.35, -0.2),
            offset + DVec3::new(0.25, 0.15, 0.3),
        )
        .unwrap();
        let source = Csg {
            op: CsgOp::Union,
            a: ShapeSource(torus),
            b: ShapeSource(cube),
        };
        let adf = Adf::build(&source, options(1e-3, 9)).unwrap();
        let root = adf.root_box();
        let mut rng = Rng(123);
        let mut rays = Vec::new();
        for k in 0..1200 {
            let origin = match k % 5 {
                0 => offset + rng.unit() * 0.3 * rng.next(), // inside the box or torus, or near
                1 => offset + rng.unit() * 0.9 * rng.next(), // inside the root cube
                _ => offset + rng.unit() * 2.5,
            };
            let dir = match k % 7 {
                0 => [DVec3::X, DVec3::NEG_Y, DVec3::Z][k % 3],
                1 => {
                    let side = rng.unit().cross(DVec3::Y).normalize();
                    (offset + DVec3::new(0.0, 0.1, 0.0) + side * (0.8 + (rng.next() - 0.5) * 1e-3) - origin).normalize()
                }
                _ => (offset + rng.unit() * 0.7 - origin).normalize(),
            };
            let Some((t0, t1)) = root.ray_interval(origin, dir) else {
                continue;
            };
            // Every 11th interval is empty (its end before its start).
            let (t0, t1) = if k % 11 == 0 { (t1, t0 - 1.0) } else { (t0, t1) };
            rays.push(CrossingRay {
                world_origin: origin,
                world_dir: dir,
                t0,
                t1,
            });
        }
        for iso in [-0.05, 0.0, 0.04, -10.0] {
            let one: Vec<(Option<f64>, u32)> = rays
                .iter()
                .map(|r| adf.first_crossing_between(r.world_origin, r.world_dir, r.t0, r.t1, iso))
                .collect();
            let hits = one.iter().filter(|a| a.0.is_some()).count();
            if iso > -1.0 {
                assert!(hits > 200, "{hits} hits at iso {iso}");
            } else {
                assert_eq!(hits, 0, "nothing is below −10");
            }
            for split in [0, 1, WALK_WINDOW - 1, WALK_WINDOW, WALK_WINDOW + 1, 97, rays.len()] {
                let mut batched = vec![(None, u32::MAX); rays.len()];
                let mut from = 0;
                while from < rays.len() {
                    let to = if split == 0 {
                        rays.len()
                    } else {
                        (from + split).min(rays.len())
                    };
                    adf.first_crossings_between(&rays[from..to], iso, &mut batched[from..to]);
                    from = to;
                }
                for (i, (a, b)) in one.iter().zip(&batched).enumerate() {
                    assert_eq!(
                        (a.0.map(f64::to_bits), a.1),
                        (b.0.map(f64::to_bits), b.1),
                        "ray {i} ({:?}) at iso {iso}, batches of {split}",
                        rays[i]
                    );
                }
            }
            // Through `Field`: the batch equals `first_crossing` ray by ray, rays the walk
            // does not take (non-finite, no direction) included.
            let mut asked = rays[..300].to_vec();
            asked[5].world_origin.x = f64::NAN;
            asked[17].world_dir = DVec3::ZERO;
            asked[40].t1 = f64::INFINITY;
            let mut batched = vec![Crossing::Miss; asked.len()];
            adf.first_crossings(&asked, iso, &mut batched);
            for (r, b) in asked.iter().zip(&batched) {
                assert_eq!(
                    *b,
                    adf.first_crossing(r.world_origin, r.world_dir, r.t0, r.t1, iso),
                    "{r:?}"
                );
            }
            assert_eq!(batched[5], Crossing::NotProvided);
            assert_eq!(batched[17], Crossing::NotProvided);
            assert_eq!(batched[40], Crossing::NotProvided);
        }
    }
}
