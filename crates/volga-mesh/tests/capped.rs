//! `CappedWinding`: the capped inside test equals the brute-force winding number on every
//! mesh of the unclean corpus, at random points and at dyadic lattice points (where cap
//! planes and mesh planes pass through samples), and carrying `I` along segments agrees
//! with computing it afresh.
//!
//! `WindingModel`: the first-order model of `w` over a box no triangle meets decides only
//! the side the brute-force winding number has.
//!
//! `ConeCaps`: the caps' certified winding number summed cone by cone holds the exact sum
//! (every cap triangle's solid angle, summed one by one) within its certified error, at
//! points near the holes, on the caps' planes, far away and at every scale, for the caps
//! of the shared open meshes and of every mesh of the unclean corpus; and it refines to
//! the rounding allowance when never satisfied.

use glam::DVec3;
use volga_core::Aabb;
use volga_mesh::{cap_triangles, solid_angle, unclean, Bvh, CappedWinding, ConeCaps, TriMesh};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn capped_inside_equals_the_winding_number_and_carries_agree() {
    for (name, mesh) in unclean::corpus() {
        let capped = CappedWinding::new(&mesh);
        let bvh = Bvh::build(&mesh);
        let b = mesh.bounds();
        let size = b.size().max(DVec3::splat(1e-3));
        let mut rng = Rng(99);
        let (mut carried, mut undecided) = (0, 0);
        for k in 0..1500 {
            let raw = b.min - size * 0.1 + DVec3::new(rng.next(), rng.next(), rng.next()) * size * 1.2;
            // Every other point on a dyadic lattice of the mesh's scale.
            let p = if k % 2 == 0 {
                raw
            } else {
                (raw / size.max_element() * 32.0).round() / 32.0 * size.max_element()
            };
            if bvh.closest(p).unwrap().distance == 0.0 {
                continue; // on the mesh: no side
            }
            let exact = bvh.winding_number_exact(p);
            if (exact - 0.5).abs() < 1e-9 {
                continue;
            }
            let (inside, integer, _) = capped.inside_with(p, None);
            assert_eq!(inside, exact >= 0.5, "{name} at {p}: w = {exact}");
            // Carry I to a nearby point along an axis (or a diagonal) and compare.
            let axis = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE][k % 4];
            let q = p + axis * size.max_element() * ((rng.next() * 8.0).floor() - 4.0) / 64.0;
            if let (Some(i), (_, Some(j), _)) = (integer, capped.inside_with(q, None)) {
                match capped.integer_along(p, i, q) {
                    Some(c) => {
                        assert_eq!(c, j, "{name}: carry {p} → {q}");
                        carried += 1;
                    }
                    None => undecided += 1,
                }
            }
        }
        assert!(carried > undecided, "{name}: {carried} carried, {undecided} undecided");
    }
}

/// `caps_range_over_ball` bounds the caps' winding number at every point of the ball:
/// checked against the caps' exact winding number at points spread over balls of many
/// sizes, near the holes and away from them.
#[test]
fn the_caps_range_over_a_ball_holds_at_every_point_of_it() {
    let (mut proven, mut asked) = (0, 0);
    for (name, mesh) in unclean::corpus() {
        let caps = cap_triangles(&mesh);
        if caps.is_empty() {
            continue;
        }
        let capped = CappedWinding::new(&mesh);
        let cap_mesh = TriMesh {
            positions: caps.iter().flatten().copied().collect(),
            triangles: (0..caps.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
        };
        let cap_bvh = Bvh::build(&cap_mesh);
        let b = mesh.bounds();
        let size = b.size().max_element().max(1e-3);
        let mut rng = Rng(7);
        for k in 0..300 {
            // Centres over the mesh's box and near cap corners; radii from 1e-4 to 0.3 of it.
            let centre = if k % 2 == 0 {
                b.min - 0.1 * size + DVec3::new(rng.next(), rng.next(), rng.next()) * 1.2 * size
            } else {
                let corner = caps[(rng.next() * caps.len() as f64) as usize % caps.len()][k % 3];
                corner + (DVec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * 0.2 * size
            };
            let radius = size * 1e-4 * 3000f64.powf(rng.next());
            asked += 1;
            let Some((lo, hi)) = capped.caps_range_over_ball(centre, radius) else {
                continue;
            };
            proven += 1;
            for _ in 0..20 {
                let d = DVec3::new(rng.next(), rng.next(), rng.next()) * 2.0 - 1.0;
                let x = centre + d.normalize_or_zero() * radius * rng.next().cbrt();
                let w = cap_bvh.winding_number_exact(x);
                assert!(
                    lo - 1e-12 <= w && w <= hi + 1e-12,
                    "{name}: w_C = {w} at {x}, outside [{lo}, {hi}] over the ball at {centre} of radius {radius}"
                );
            }
        }
    }
    assert!(proven * 3 > asked, "{proven} of {asked} balls bounded");
}

/// `winding_model`'s side holds at every point of its box, and over any box inside it:
/// checked against the brute-force winding number at points of boxes no triangle meets
/// (their circumscribed ball is farther from the mesh than its radius), of many sizes,
/// near the holes' rims and away from them, on every open mesh of the unclean corpus and
/// the shared bunny.
#[test]
fn the_winding_model_holds_in_every_box_no_triangle_meets() {
    let mut meshes = unclean::corpus();
    meshes.push(("stanford-bunny", shared("stanford-bunny.obj")));
    let (mut modelled, mut decided, mut asked) = (0, 0, 0);
    for (name, mesh) in meshes {
        let caps = cap_triangles(&mesh);
        if caps.is_empty() {
            continue;
        }
        let capped = CappedWinding::new(&mesh);
        let bvh = Bvh::build(&mesh);
        let b = mesh.bounds();
        let size = b.size().max_element().max(1e-3);
        let mut rng = Rng(11);
        let boxes = if name == "stanford-bunny" { 40 } else { 120 };
        for k in 0..boxes {
            // Centres near rim corners (the caps' outer corners) or over the mesh's box;
            // edges from 1e-4 to 0.3 of it.
            let centre = if k % 2 == 0 {
                let corner = caps[(rng.next() * caps.len() as f64) as usize % caps.len()][k % 2];
                corner + (DVec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * 0.1 * size
            } else {
                b.min - 0.1 * size + DVec3::new(rng.next(), rng.next(), rng.next()) * 1.2 * size
            };
            let half = 0.5 * size * 1e-4 * 3000f64.powf(rng.next());
            let cell = Aabb::new(centre - DVec3::splat(half), centre + DVec3::splat(half));
            if bvh.closest(centre).unwrap().distance <= 0.5 * cell.size().length() {
                continue; // a triangle may meet the box
            }
            let (Some(model), _) = capped.winding_model(&cell, None) else {
                continue;
            };
            modelled += 1;
            let points = if name == "stanford-bunny" { 8 } else { 24 };
            for j in 0..points {
                let t = DVec3::new(rng.next(), rng.next(), rng.next());
                // Some points on the box's faces and corners.
                let t = if j % 4 == 0 { t.round() } else { t };
                let x = cell.min + t * cell.size();
                let w = bvh.winding_number_exact(x);
                asked += 1;
                if let Some(inside) = model.side_at(x) {
                    decided += 1;
                    assert_eq!(
                        inside,
                        w >= 0.5,
                        "{name}: w = {w} at {x}, in the box at {centre} of half-edge {half}"
                    );
                }
            }
            // A sub-box: its side, when proven, holds at its points.
            let sub_min = cell.min + DVec3::new(rng.next(), rng.next(), rng.next()) * cell.size() * 0.5;
            let sub = Aabb::new(sub_min, sub_min + cell.size() * 0.5 * rng.next());
            if let Some(inside) = model.side_in(&sub) {
                for _ in 0..4 {
                    let x = sub.min + DVec3::new(rng.next(), rng.next(), rng.next()) * sub.size();
                    let w = bvh.winding_number_exact(x);
                    assert_eq!(inside, w >= 0.5, "{name}: w = {w} at {x}, in the sub-box {sub:?}");
                }
            }
            // Outside its box the model answers nothing.
            assert_eq!(model.side_at(cell.max + DVec3::splat(half)), None);
        }
    }
    assert!(modelled > 100, "{modelled} boxes modelled");
    assert!(decided * 2 > asked, "{decided} of {asked} points decided");
}

fn shared(name: &str) -> TriMesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name);
    volga_mesh::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn exact(caps: &[[DVec3; 3]], p: DVec3) -> f64 {
    caps.iter().map(|&t| solid_angle(p, t)).sum::<f64>() / (4.0 * std::f64::consts::PI)
}

/// Points near the caps' corners (within a hole's size, down to 1e-9 of it), on segments
/// between two cap corners (in cap planes), and over the mesh's box.
fn probes(caps: &[[DVec3; 3]], size: f64, rng: &mut Rng, count: usize) -> Vec<DVec3> {
    (0..count)
        .map(|k| {
            let t = caps[(rng.next() * caps.len() as f64) as usize % caps.len()];
            match k % 4 {
                0 => {
                    t[k % 3]
                        + (DVec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * size * 10f64.powf(-9.0 * rng.next())
                }
                1 => {
                    let (a, b) = (rng.next(), rng.next());
                    let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                    t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b
                }
                2 => {
                    t[0].lerp(t[1], rng.next()).lerp(t[2], 0.5 * rng.next())
                        + DVec3::splat(size * 1e-3 * (rng.next() - 0.5))
                }
                _ => t[0] + (DVec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * 3.0 * size,
            }
        })
        .collect()
}

#[test]
fn cone_sums_hold_the_exact_sum_within_their_error() {
    let mut meshes = vec![
        ("bunny", shared("stanford-bunny.obj")),
        ("teapot", shared("teapot.obj")),
    ];
    meshes.extend(unclean::corpus());
    let mut rng = Rng(0x5eed);
    let (mut checked, mut open) = (0, 0);
    for (name, mesh) in &meshes {
        let caps = cap_triangles(mesh);
        if caps.is_empty() {
            continue;
        }
        open += 1;
        let cones = ConeCaps::build(&caps).unwrap_or_else(|| panic!("{name}: too many patches"));
        assert_eq!(cones.triangle_count(), caps.len());
        let size = mesh.bounds().size().max_element().max(1e-3);
        // Far from the origin as well: the same shapes moved by 1e6 sizes.
        for shift in [DVec3::ZERO, DVec3::new(1e6, -3e5, 2e6) * size] {
            let moved: Vec<[DVec3; 3]> = caps.iter().map(|t| t.map(|c| c + shift)).collect();
            let cones = ConeCaps::build(&moved).unwrap();
            let tree = Bvh::build(&TriMesh {
                positions: moved.iter().flatten().copied().collect(),
                triangles: (0..moved.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
            });
            for p in probes(&moved, size, &mut rng, 400) {
                let truth = exact(&moved, p);
                // Never satisfied: everything summed exactly, error only the allowance.
                let full = cones.winding_number_bounded(p, |_, _| false);
                assert!(
                    (full.value - truth).abs() <= full.error,
                    "{name} at {p}: {} vs {truth}",
                    full.value
                );
                assert!(full.error < 1e-10, "{name}: error {}", full.error);
                assert_eq!(full.exact_triangles as usize, moved.len());
                // Stopped early at several precisions, as the sign queries stop.
                for tolerance in [0.3, 0.05, 1e-3, 1e-6] {
                    let b = cones.winding_number_bounded(p, |_, e| e <= tolerance);
                    assert!(
                        (b.value - truth).abs() <= b.error,
                        "{name} at {p}: {} ± {} vs {truth}",
                        b.value,
                        b.error
                    );
                    assert!(b.error <= tolerance, "{name}: error {} above {tolerance}", b.error);
                }
                // The side of ½ and of −½, as the tree proves it.
                for threshold in [0.5, -0.5] {
                    let b = cones.winding_number_bounded(p, |w, e| (w - threshold).abs() > e);
                    if (truth - threshold).abs() > 1e-9 {
                        assert_eq!(
                            b.side(threshold),
                            Some(truth >= threshold),
                            "{name} at {p}: {b:?} vs {truth}"
                        );
                    }
                    let t = tree.winding_number_bounded(p, None, |w, e| (w - threshold).abs() > e);
                    if let (Some(x), Some(y)) = (b.side(threshold), t.side(threshold)) {
                        assert_eq!(x, y, "{name} at {p}: cones {b:?}, tree {t:?}, exact {truth}");
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(open >= 5, "{open} open meshes");
    assert!(checked > 3000, "{checked} points");
}

/// The bunny's five holes are five cones; a loop longer than a patch is cut into runs
/// along it; caps of too many patches are refused (the tree is the index then).
#[test]
fn cones_are_cut_into_patches_along_their_loops() {
    let caps = cap_triangles(&shared("stanford-bunny.obj"));
    assert_eq!(ConeCaps::build(&caps).unwrap().patch_count(), 5);
    // One loop of 1000 edges around a circle: 8 patches, each a run of the loop (its
    // expansion's radius well below the circle's).
    let ring = |k: usize, n: usize| {
        let a = std::f64::consts::TAU * (k % n) as f64 / n as f64;
        DVec3::new(a.cos(), a.sin(), 0.0)
    };
    let apex = DVec3::new(0.01, 0.02, 0.3);
    // Edges in a scrambled order: the chaining restores the loop.
    let mut order: Vec<usize> = (0..1000).collect();
    order.sort_by_key(|&k| (k * 7919) % 1000);
    let big: Vec<[DVec3; 3]> = order
        .iter()
        .map(|&k| [ring(k + 1, 1000), ring(k, 1000), apex])
        .collect();
    let cones = ConeCaps::build(&big).unwrap();
    assert_eq!(cones.patch_count(), 8);
    // Above the centre at 1.5 radii every run of an eighth of the loop is in the far
    // field (a patch of scattered edges, spanning the whole ring, would not be).
    let p = DVec3::new(0.0, 0.0, 1.5);
    let first = cones.winding_number_bounded(p, |_, _| true);
    assert_eq!((first.exact_triangles, first.terms), (0, 8), "{first:?}");
    assert!((first.value - exact(&big, p)).abs() <= first.error);
    let tight = cones.winding_number_bounded(p, |_, e| e < 1e-9);
    assert!((tight.value - exact(&big, p)).abs() <= tight.error);
    // 65 loops of 3 edges: 65 cones, more patches than allowed.
    let many: Vec<[DVec3; 3]> = (0..65)
        .flat_map(|k| {
            let o = DVec3::new(3.0 * k as f64, 0.0, 0.0);
            let apex = o + DVec3::new(0.3, 0.3, 0.5);
            [
                [o + DVec3::Y, o, apex],
                [o + DVec3::X, o + DVec3::Y, apex],
                [o, o + DVec3::X, apex],
            ]
        })
        .collect();
    assert!(ConeCaps::build(&many).is_none());
}

/// A query asked from inside another's `done` (the thread's buffers are taken by the
/// outer one) answers as it does alone, and so does the outer query.
#[test]
fn cone_queries_nest() {
    let caps = cap_triangles(&shared("stanford-bunny.obj"));
    let cones = ConeCaps::build(&caps).unwrap();
    let (p, q) = (caps[0][2] + DVec3::splat(1e-3), caps[40][2] - DVec3::splat(2e-3));
    let alone = cones.winding_number_bounded(q, |_, _| false);
    let mut nested = None;
    let outer = cones.winding_number_bounded(p, |_, _| {
        nested.get_or_insert_with(|| cones.winding_number_bounded(q, |_, _| false));
        false
    });
    assert_eq!(nested, Some(alone));
    assert_eq!(outer, cones.winding_number_bounded(p, |_, _| false));
}
